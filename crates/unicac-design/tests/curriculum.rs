//! Issue 32: a fast aperture's search started from a slower one's solutions, and budgeted searches that
//! do not call a poor best design converged.

use std::path::PathBuf;
use unicac_design::curriculum::{search_from_slower_aperture, CURRICULUM_START_F_NUMBER};
use unicac_design::global::GlobalSettings;
use unicac_design::library::{Library, RoundRecord};
use unicac_design::local::{Gradient, LocalSettings};
use unicac_design::merit::{Merit, Sampling};
use unicac_design::params::Parameterization;
use unicac_design::run::{good_rms_um, run_specs, Event, RunSettings, StopReason};
use unicac_design::{DesignSpec, StopPosition};

fn small_global(seed: u64) -> GlobalSettings {
    GlobalSettings {
        population: 16,
        generations: 3,
        parents: 4,
        archive: 6,
        ..GlobalSettings::new(seed)
    }
}

#[test]
fn the_curriculum_hands_over_designs_of_the_target_aperture_best_first() {
    let spec = DesignSpec::new(2, 20.0, 2.0, StopPosition::Middle, 50.0).unwrap();
    assert!(spec.f_number < CURRICULUM_START_F_NUMBER);
    let local = LocalSettings::new(10, Gradient::Exact);
    let found = search_from_slower_aperture(&spec, &small_global(3), &local, &|_| {}).unwrap();
    let archive = found.archive;
    assert!(found.evaluations > 0);
    assert!(!archive.is_empty());
    let merit = Merit::new(&spec, Sampling::COARSE);
    let params = Parameterization::spherical(&spec);
    for pair in archive.windows(2) {
        assert!(pair[0].merit <= pair[1].merit);
    }
    for candidate in &archive {
        // The merit handed over is the target spec's (F/2), not the start's (F/4).
        let at_target = merit.value(&params, &candidate.x).unwrap();
        assert_eq!(candidate.merit, at_target);
        assert!(candidate.x.iter().all(|v| (0.0..=1.0).contains(v)));
    }
    // Deterministic for a seed.
    let again = search_from_slower_aperture(&spec, &small_global(3), &local, &|_| {}).unwrap();
    assert_eq!(again.evaluations, found.evaluations);
    let again = again.archive;
    assert_eq!(
        archive.iter().map(|c| c.merit).collect::<Vec<_>>(),
        again.iter().map(|c| c.merit).collect::<Vec<_>>()
    );
}

#[test]
fn the_good_bar_is_ten_airy_radii_at_the_primary_wavelength() {
    let f2 = DesignSpec::new(6, 40.0, 2.0, StopPosition::Middle, 50.0).unwrap();
    let f4 = DesignSpec::new(6, 40.0, 4.0, StopPosition::Middle, 50.0).unwrap();
    let airy_um = 1.22 * f2.wavelengths_um[f2.primary_wavelength_index] * 2.0;
    assert!((good_rms_um(&f2) - 10.0 * airy_um).abs() < 1e-12);
    assert!((good_rms_um(&f4) - 2.0 * good_rms_um(&f2)).abs() < 1e-12);
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-curriculum-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// A singlet at F/2 over 30 degrees cannot be good (its field curvature alone is hundreds of um); with
/// a budget the search keeps restarting (both kinds of round) until the budget ends instead of calling
/// two idle rounds convergence. Does not depend on the machine's speed: however few rounds fit, the
/// stop is the budget's.
#[test]
fn a_budgeted_search_whose_best_design_is_poor_uses_the_whole_budget() {
    let spec = DesignSpec::new(1, 30.0, 2.0, StopPosition::Front, 50.0).unwrap();
    let mut settings = RunSettings::new(1, 2);
    settings.global = small_global(2);
    settings.refine_iterations = 20;
    settings.rounds = usize::MAX;
    settings.time_budget_s = Some(6.0);
    let dir = scratch("poor");
    let mut library = Library::open(&dir).unwrap();
    let summary = run_specs(
        std::slice::from_ref(&spec),
        &settings,
        &mut library,
        &|_: Event| {},
    )
    .unwrap();
    let s = &summary[0];
    assert_eq!(s.stop_reason, StopReason::Budget, "{s:?}");
    assert!(s.elapsed_s >= 5.9, "{s:?}");
    let best = s.best_rms_mean_um.expect("a kept design");
    assert!(best > good_rms_um(&spec), "{s:?}");
    assert_eq!(s.good_rms_um, good_rms_um(&spec));
    // The convergence trace: one line per finished round, the best RMS never getting worse.
    let trace = std::fs::read_to_string(library.rounds_log_path(&spec.slug())).unwrap();
    let rounds: Vec<RoundRecord> = trace.lines().map(|l| serde_json::from_str(l).unwrap()).collect();
    assert!(!rounds.is_empty() && rounds.len() <= s.rounds, "{trace}");
    for (i, r) in rounds.iter().enumerate() {
        assert_eq!(r.round, i);
        assert_eq!(r.curriculum, i % 2 == 1);
    }
    for pair in rounds.windows(2) {
        assert!(pair[1].elapsed_s >= pair[0].elapsed_s);
        if let (Some(a), Some(b)) = (pair[0].best_rms_mean_um, pair[1].best_rms_mean_um) {
            assert!(b <= a, "{trace}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
