//! Evaluation budgets (`RunSettings::evaluations_per_spec`): a library that does not depend on the
//! machine, the number of threads or an interruption.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
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

/// Killed in the second round's global search (after a lens was written), then resumed: the library
/// is the uninterrupted run's, because the count of evaluations is saved with the search state.
#[test]
fn a_run_killed_mid_search_resumes_to_the_uninterrupted_library() {
    let (whole, killed) = (scratch("whole"), scratch("killed"));
    let uninterrupted = run_with_threads(2, &whole);
    let accepted = AtomicBool::new(false);
    let kill_after_a_lens = |event: Event| match event {
        Event::Accepted { .. } => accepted.store(true, Ordering::SeqCst),
        Event::Generation { .. } if accepted.load(Ordering::SeqCst) => panic!("killed"),
        _ => {}
    };
    let mut library = Library::open(&killed).unwrap();
    let died = catch_unwind(AssertUnwindSafe(|| {
        run_specs(&[spec()], &settings(), &mut library, &kill_after_a_lens)
    }));
    assert!(died.is_err(), "the run was not interrupted");
    drop(library);
    let resumed = run_with_threads(2, &killed);
    assert_eq!(resumed.evaluations, uninterrupted.evaluations);
    assert_eq!(resumed.stop_reason, StopReason::EvaluationBudget);
    assert_eq!(library_bytes(&killed), library_bytes(&whole));
    let _ = std::fs::remove_dir_all(&whole);
    let _ = std::fs::remove_dir_all(&killed);
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
