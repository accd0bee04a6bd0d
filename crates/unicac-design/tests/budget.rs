//! Evaluation budgets (`RunSettings::evaluations_per_spec`): a library that does not depend on the
//! machine, the number of threads or an interruption.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use unicac_design::global::GlobalSettings;
use unicac_design::library::{Library, RoundRecord};
use unicac_design::run::{run_specs, Event, RunSettings, SpecSummary, StopReason};
use unicac_design::{DesignSpec, StopPosition};

const LIMIT: u64 = 12_000;

fn spec() -> DesignSpec {
    DesignSpec::new(2, 20.0, 4.0, StopPosition::Middle, 50.0).unwrap()
}

fn settings() -> RunSettings {
    let mut settings = RunSettings::new(2, 5);
    settings.global = GlobalSettings {
        population: 16,
        generations: 3,
        parents: 4,
        archive: 6,
        ..GlobalSettings::new(5)
    };
    settings.refine_iterations = 15;
    settings.rounds = usize::MAX;
    settings.evaluations_per_spec = Some(LIMIT);
    settings
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-budget-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn run_with_threads(threads: usize, dir: &Path) -> SpecSummary {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap();
    let mut library = Library::open(dir).unwrap();
    let summaries = pool
        .install(|| run_specs(&[spec()], &settings(), &mut library, &|_: Event| {}))
        .unwrap();
    summaries.into_iter().next().unwrap()
}

/// Every lens file, and the manifest without its wall-clock column (`elapsed_s`).
fn library_bytes(dir: &Path) -> Vec<(String, String)> {
    let mut files: Vec<(String, String)> = std::fs::read_dir(dir.join("lenses"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json" || e == "zmx"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    files.sort();
    let library = Library::open(dir).unwrap();
    for row in &library.rows {
        let mut row = row.clone();
        row.elapsed_s = 0.0;
        files.push((row.id.clone(), serde_json::to_string(&row).unwrap()));
    }
    files
}

fn rounds(dir: &Path) -> Vec<RoundRecord> {
    let library = Library::open(dir).unwrap();
    let text = std::fs::read_to_string(library.rounds_log_path(&spec().slug())).unwrap_or_default();
    text.lines().map(|l| serde_json::from_str(l).unwrap()).collect()
}

#[test]
fn an_evaluation_budget_gives_the_same_library_on_one_thread_as_on_two() {
    let (one, two) = (scratch("one"), scratch("two"));
    let a = run_with_threads(1, &one);
    let b = run_with_threads(2, &two);
    assert_eq!(a.stop_reason, StopReason::EvaluationBudget, "{a:?}");
    assert!(a.accepted >= 1, "{a:?}");
    assert_eq!(
        (a.evaluations, a.rounds, a.accepted),
        (b.evaluations, b.rounds, b.accepted)
    );
    // It stops once the count reaches the limit: past it by at most the candidate or generation
    // that crossed it.
    assert!(
        a.evaluations >= LIMIT && a.evaluations < LIMIT + LIMIT / 2,
        "{a:?}"
    );
    assert_eq!(library_bytes(&one), library_bytes(&two));
    let (ra, rb) = (rounds(&one), rounds(&two));
    assert!(ra.len() >= 2, "{} rounds", ra.len());
    for (x, y) in ra.iter().zip(&rb) {
        assert_eq!(
            (x.round, x.evaluations, x.best_merit),
            (y.round, y.evaluations, y.best_merit)
        );
    }
    for pair in ra.windows(2) {
        assert!(pair[1].evaluations > pair[0].evaluations);
    }
    let _ = std::fs::remove_dir_all(&one);
    let _ = std::fs::remove_dir_all(&two);
}

/// Designs `spec` on two threads into `dir`; with `kill_at`, killed (a panic out of the run, which
/// leaves the folder as a SIGKILL would) at that global generation, counted from 1 over all rounds.
fn run_spec_into(
    spec: &DesignSpec,
    settings: &RunSettings,
    dir: &Path,
    kill_at: Option<usize>,
) -> Option<SpecSummary> {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().unwrap();
    let generations = AtomicUsize::new(0);
    let events = |event: Event| {
        if let Event::Generation { .. } = event {
            if Some(generations.fetch_add(1, Ordering::SeqCst) + 1) == kill_at {
                panic!("killed");
            }
        }
    };
    let mut library = Library::open(dir).unwrap();
    let outcome = catch_unwind(AssertUnwindSafe(|| {
        pool.install(|| run_specs(std::slice::from_ref(spec), settings, &mut library, &events))
    }));
    outcome
        .ok()
        .map(|summaries| summaries.unwrap().into_iter().next().unwrap())
}

fn trace(dir: &Path, slug: &str) -> Vec<(usize, u64, Option<f64>)> {
    let library = Library::open(dir).unwrap();
    std::fs::read_to_string(library.rounds_log_path(slug))
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str::<RoundRecord>(l).unwrap())
        .map(|r| (r.round, r.evaluations, r.best_merit))
        .collect()
}

/// Killed as the round after the last better design starts its global search (so that only rounds
/// without a better design follow, which a resumed run must count as the uninterrupted one did), then
/// resumed: the library, the evaluations spent and
/// the convergence trace are the uninterrupted run's, because the count of evaluations and the
/// convergence state are saved with the search state. Both ways a run ends: a poor spec at the
/// budget, a good one (a slow singlet) by converging first.
#[test]
fn a_run_killed_mid_search_resumes_to_the_uninterrupted_library() {
    let good = DesignSpec::new(1, 5.0, 8.0, StopPosition::Front, 50.0).unwrap();
    let mut converging = settings();
    converging.count = 1;
    converging.evaluations_per_spec = Some(10 * LIMIT);
    for (name, spec, settings, stop) in [
        ("poor", spec(), settings(), StopReason::EvaluationBudget),
        ("good", good, converging, StopReason::Converged),
    ] {
        let (whole, killed) = (
            scratch(&format!("whole-{name}")),
            scratch(&format!("killed-{name}")),
        );
        let uninterrupted = run_spec_into(&spec, &settings, &whole, None).unwrap();
        assert_eq!(uninterrupted.stop_reason, stop, "{name}: {uninterrupted:?}");
        let rounds = trace(&whole, &spec.slug());
        let last_better = (1..rounds.len())
            .rev()
            .find(|&r| rounds[r].2 < rounds[r - 1].2)
            .unwrap_or(0);
        // (Where every round found a better design, the last round.)
        let kill_round = (last_better + 1).min(rounds.len() - 1).max(1);
        let kill_at = kill_round * settings.global.generations + 1;
        assert!(
            run_spec_into(&spec, &settings, &killed, Some(kill_at)).is_none(),
            "{name}: not killed"
        );
        let resumed = run_spec_into(&spec, &settings, &killed, None).unwrap();
        assert_eq!(resumed.stop_reason, stop, "{name}");
        assert_eq!(resumed.evaluations, uninterrupted.evaluations, "{name}");
        assert_eq!(library_bytes(&killed), library_bytes(&whole), "{name}");
        assert_eq!(trace(&killed, &spec.slug()), rounds, "{name}");
        let _ = std::fs::remove_dir_all(&whole);
        let _ = std::fs::remove_dir_all(&killed);
    }
}

#[test]
fn an_evaluation_budget_out_of_range_is_refused_by_name() {
    for bad in [0, u64::MAX] {
        let mut settings = settings();
        settings.evaluations_per_spec = Some(bad);
        let error = settings.validate().unwrap_err().to_string();
        assert!(error.contains("evaluations_per_spec"), "{error}");
    }
}
