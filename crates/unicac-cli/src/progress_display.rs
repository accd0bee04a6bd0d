//! How the CLI shows progress (`unicac_io::progress::Progress`, the protocol of dataset builds, benches
//! and tolerance runs, also driven by the faces' own loops: `ode` over lenses, `simulate` over images,
//! `design` over its designs): a bar per stage on a terminal; without one (a log file, a script), a
//! plain line at most every `LOG_EVERY` and when a stage of some seconds ends, so a long run in a log
//! still shows that it moves and how far it is. Notes go above any bar.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};
use unicac_io::progress::Progress;

/// Time between two log lines of one stage when stderr is not a terminal.
const LOG_EVERY: Duration = Duration::from_secs(30);
/// A stage shorter than this ends without a log line (one lens's ODE needs no "100% (1/1)").
const QUIET_BELOW: Duration = Duration::from_secs(2);

/// The progress of one command's library work on stderr.
pub(crate) struct ProgressDisplay {
    command: &'static str,
    terminal: bool,
    stage: Mutex<Option<Stage>>,
}

struct Stage {
    name: String,
    total: usize,
    done: usize,
    started: Instant,
    last_line: Instant,
    /// Whether a log line was written for this stage.
    logged: bool,
    bar: Option<ProgressBar>,
}

impl ProgressDisplay {
    /// Progress of `command` ("bench", "dataset build"), drawn as bars when stderr is a terminal.
    pub(crate) fn new(command: &'static str) -> ProgressDisplay {
        ProgressDisplay {
            command,
            terminal: std::io::stderr().is_terminal(),
            stage: Mutex::new(None),
        }
    }

    /// Ends the current stage (its bar cleared).
    pub(crate) fn finish(&self) {
        if let Some(stage) = self.lock().take() {
            if let Some(bar) = stage.bar {
                bar.finish_and_clear();
            }
        }
    }

    /// Runs `print` with the bar hidden, so lines it writes to stderr stay above the bar.
    pub(crate) fn suspend<R>(&self, print: impl FnOnce() -> R) -> R {
        let bar = self.lock().as_ref().and_then(|s| s.bar.clone());
        match bar {
            Some(bar) => bar.suspend(print),
            None => print(),
        }
    }

    /// What the current stage is doing now (e.g. a design search's generation and best merit), shown
    /// beside the bar on a terminal; not logged (the stage's own lines say how far it is).
    pub(crate) fn status(&self, message: &str) {
        if let Some(bar) = self.lock().as_ref().and_then(|s| s.bar.as_ref()) {
            bar.set_message(format!("{}: {message}", self.command));
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Option<Stage>> {
        // A panic elsewhere while drawing leaves the state usable: it only holds counters.
        self.stage.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

impl Progress for ProgressDisplay {
    fn stage(&self, name: &str, total: usize) {
        self.finish();
        let bar = (self.terminal && total > 0).then(|| {
            let bar = ProgressBar::new(total as u64);
            bar.set_style(
                ProgressStyle::with_template(
                    "{msg} [{bar:30}] {human_pos}/{human_len} ({percent}%) {elapsed_precise} eta {eta}",
                )
                .expect("template")
                .progress_chars("=> "),
            );
            bar.set_message(format!("{}: {name}", self.command));
            bar
        });
        let now = Instant::now();
        *self.lock() = Some(Stage {
            name: name.to_string(),
            total,
            done: 0,
            started: now,
            last_line: now,
            logged: false,
            bar,
        });
    }

    fn advance(&self, count: usize) {
        let mut slot = self.lock();
        let Some(stage) = slot.as_mut() else { return };
        stage.done = (stage.done + count).min(stage.total);
        match &stage.bar {
            Some(bar) => bar.set_position(stage.done as u64),
            None if !self.terminal
                && (stage.last_line.elapsed() >= LOG_EVERY
                    || (stage.done == stage.total
                        && (stage.logged || stage.started.elapsed() >= QUIET_BELOW))) =>
            {
                eprintln!(
                    "{}: {}",
                    self.command,
                    progress_line(stage.done, stage.total, &stage.name, stage.started.elapsed())
                );
                stage.last_line = Instant::now();
                stage.logged = true;
            }
            None => {}
        }
    }

    fn note(&self, message: &str) {
        self.suspend(|| eprintln!("{message}"));
    }
}

/// "test pixels: 37% (370/1000), 5 min 10 s elapsed, about 8 min 48 s left": the estimate assumes the
/// rest of the stage's work goes at the rate so far.
fn progress_line(done: usize, total: usize, what: &str, elapsed: Duration) -> String {
    let share = if total == 0 {
        1.0
    } else {
        done as f64 / total as f64
    };
    let elapsed_s = elapsed.as_secs_f64();
    let left = if share > 0.0 && share < 1.0 {
        format!(
            ", about {} left",
            minutes_seconds(elapsed_s * (1.0 - share) / share)
        )
    } else {
        String::new()
    };
    format!(
        "{what}: {:.0}% ({done}/{total}), {} elapsed{left}",
        100.0 * share,
        minutes_seconds(elapsed_s)
    )
}

fn minutes_seconds(seconds: f64) -> String {
    let whole = seconds.round() as u64;
    if whole >= 60 {
        format!("{} min {} s", whole / 60, whole % 60)
    } else {
        format!("{whole} s")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_log_line_estimates_the_time_left_from_the_rate_so_far() {
        assert_eq!(
            progress_line(25, 100, "pairs", Duration::from_secs(70)),
            "pairs: 25% (25/100), 1 min 10 s elapsed, about 3 min 30 s left"
        );
        assert_eq!(
            progress_line(100, 100, "trials", Duration::from_secs(9)),
            "trials: 100% (100/100), 9 s elapsed"
        );
        assert_eq!(
            progress_line(0, 100, "test pixels", Duration::ZERO),
            "test pixels: 0% (0/100), 0 s elapsed"
        );
    }

    #[test]
    fn work_is_counted_per_stage_and_never_beyond_its_total() {
        let display = ProgressDisplay {
            command: "test",
            terminal: true,
            stage: Mutex::new(None),
        };
        display.stage("pairs", 4);
        display.advance(3);
        display.advance(3);
        assert_eq!(display.lock().as_ref().map(|s| s.done), Some(4));
        display.stage("edges", 2);
        assert_eq!(
            display.lock().as_ref().map(|s| (s.name.as_str(), s.done)),
            Some(("edges", 0))
        );
        display.finish();
        assert!(display.lock().is_none());
    }
}
