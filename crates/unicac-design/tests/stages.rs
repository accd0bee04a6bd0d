//! Each stage on small budgets: refinement against a brute-force bound, the global search's diversity,
//! the physical checks of accepted lenses, reproducibility, resume, the aspheric stage, time budgets.

use std::path::PathBuf;
use std::time::Instant;
use unicac_design::global::search;
use unicac_design::library::Library;
use unicac_design::local::{linearise, refine, Gradient, LocalSettings};
use unicac_design::merit::{Merit, Sampling};
use unicac_design::params::{distance, Parameterization, Target};
use unicac_design::run::{finish_candidate, run_specs, Event, RunSettings};
use unicac_design::verify::verify;
use unicac_design::{DesignSpec, StopPosition};

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-design-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

/// Small settings in the first-acceptable mode (these tests are about the stages, resume and
/// reproducibility; keeping the best designs is tested in tests/keep_best.rs).
fn small(count: usize, seed: u64) -> RunSettings {
    let mut settings = RunSettings::new(count, seed);
    settings.first_acceptable = true;
    settings.global.population = 24;
    settings.global.generations = 5;
    settings.global.parents = 6;
    settings.refine_iterations = 40;
    settings.rounds = 2;
    settings
}

fn quiet(event: Event) {
    if let Event::Rejected { reasons, .. } = event {
        eprintln!("rejected: {reasons:?}");
    }
}

/// A singlet's design, refined over all its variables, is at least as good as the best bending of the
/// same glass and thickness found by brute force (201 bendings, each with its best focus).
#[test]
fn refined_singlet_reaches_the_best_bending() {
    let mut spec = DesignSpec::new(1, 5.0, 8.0, StopPosition::Front, 50.0).unwrap();
    spec.field_fractions = vec![0.0, 1.0];
    let settings = small(1, 3);
    let merit = Merit::new(&spec, Sampling::FINE);
    let params = Parameterization::spherical(&spec);
    let candidates = search(
        &Merit::new(&spec, Sampling::COARSE),
        &params,
        &settings.global,
        &|_| {},
    )
    .archive;
    let (design, _) = finish_candidate(&spec, &candidates[0].x, &settings, None)
        .designs
        .unwrap();
    let designed = design.terms.merit;
    // The same glass and thicknesses; only the bending (front curvature; the back one is solved for the
    // EFL) and the focus vary.
    let spherical = Parameterization::spherical(&spec);
    let bending = spherical.restricted(design.prescription.clone(), |v| {
        matches!(v.target, Target::Curvature(_))
    });
    assert_eq!(bending.len(), 1);
    let focus_only = LocalSettings::new(20, Gradient::Exact);
    let mut best_scan = f64::INFINITY;
    for k in 0..=200 {
        let Some(bent) = bending.decode(&[k as f64 / 200.0]) else {
            continue;
        };
        let focus = spherical.restricted(unicac_design::system::values(&bent), |v| {
            v.target == Target::Defocus
        });
        let y = focus.encode(&focus.base);
        best_scan = best_scan.min(refine(&merit, &focus, &y, &focus_only, |_| {}).merit);
    }
    eprintln!("designed merit {designed:.4}, best bending by scan {best_scan:.4}");
    assert!(
        designed <= best_scan * 1.01,
        "designed {designed} vs scan {best_scan}"
    );
}

#[test]
fn exact_and_finite_difference_jacobians_agree() {
    let spec = DesignSpec::new(3, 20.0, 5.0, StopPosition::Middle, 50.0).unwrap();
    let merit = Merit::new(&spec, Sampling::COARSE);
    let params = Parameterization::spherical(&spec);
    let x: Vec<f64> = (0..params.len()).map(|i| 0.48 + 0.01 * (i % 4) as f64).collect();
    let exact = linearise(&merit, &params, &x, Gradient::Exact).unwrap();
    let fd = linearise(&merit, &params, &x, Gradient::FiniteDifference).unwrap();
    let scale = exact.jacobian.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let worst = exact
        .jacobian
        .iter()
        .zip(&fd.jacobian)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0f64, f64::max);
    // Finite differences at step 1e-6 carry ~1e-6 relative noise; penalties switching on within the step
    // would show as O(1) errors, and there are none at this point.
    assert!(worst < 1e-4 * scale, "worst {worst:e} of {scale:e}");
}

#[test]
fn global_search_returns_many_distinct_improving_designs() {
    let spec = DesignSpec::new(2, 20.0, 4.0, StopPosition::Middle, 50.0).unwrap();
    let merit = Merit::new(&spec, Sampling::COARSE);
    let params = Parameterization::spherical(&spec);
    let settings = small(4, 5).global;
    let archive = search(&merit, &params, &settings, &|_| {}).archive;
    assert!(archive.len() >= 4, "only {} designs", archive.len());
    for (i, a) in archive.iter().enumerate() {
        for b in &archive[i + 1..] {
            assert!(distance(&a.x, &b.x) >= settings.diversity / 2.0);
        }
    }
    assert!(archive.windows(2).all(|w| w[0].merit <= w[1].merit));
}

/// Every accepted lens passes the physical checks when read back from its files (JSON and .zmx), and
/// the same seed gives the same designs.
#[test]
fn accepted_lenses_pass_physical_checks_and_runs_are_reproducible() {
    let spec = DesignSpec::new(2, 20.0, 4.0, StopPosition::Middle, 50.0).unwrap();
    let (dir_a, dir_b) = (scratch("repro-a"), scratch("repro-b"));
    let settings = small(2, 11);
    let mut a = Library::open(&dir_a).unwrap();
    run_specs(std::slice::from_ref(&spec), &settings, &mut a, &quiet).unwrap();
    let mut b = Library::open(&dir_b).unwrap();
    run_specs(std::slice::from_ref(&spec), &settings, &mut b, &quiet).unwrap();
    assert!(!a.rows.is_empty());
    assert_eq!(a.rows.len(), b.rows.len());
    for (ra, rb) in a.rows.iter().zip(&b.rows) {
        assert_eq!(
            (ra.merit, &ra.glasses, ra.total_track_mm),
            (rb.merit, &rb.glasses, rb.total_track_mm)
        );
        for file in [&ra.json, &ra.zmx] {
            let spec_read = unicac_optics::read_spec(&dir_a.join(file)).unwrap().spec;
            let check = verify(&spec_read, 50.0, 1e-6);
            assert!(check.passed, "{file}: {:?}", check.failures);
            assert!((check.rms_mean_um - ra.rms_mean_um).abs() < 1e-6 * ra.rms_mean_um);
        }
        let report: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir_a.join(ra.json.replace(".json", ".report.json"))).unwrap(),
        )
        .unwrap();
        let checks = report["terms"]["checks"].as_array().unwrap();
        assert!(checks.iter().all(|c| c["met"] == true));
        assert!(checks.iter().any(|c| c["name"] == "glass_edge_thickness[0]"));
    }
    let _ = std::fs::remove_dir_all(&dir_a);
    let _ = std::fs::remove_dir_all(&dir_b);
}

#[test]
fn resume_keeps_finished_lenses_and_skips_them() {
    let spec = DesignSpec::new(2, 20.0, 4.0, StopPosition::Front, 50.0).unwrap();
    let dir = scratch("resume");
    let mut library = Library::open(&dir).unwrap();
    run_specs(std::slice::from_ref(&spec), &small(1, 2), &mut library, &quiet).unwrap();
    assert_eq!(library.rows.len(), 1);
    let first = library.rows[0].clone();
    let first_text = std::fs::read_to_string(dir.join(&first.json)).unwrap();
    // A rerun with the same count does nothing; a larger count adds lenses after the first.
    let start = Instant::now();
    let mut reopened = Library::open(&dir).unwrap();
    run_specs(std::slice::from_ref(&spec), &small(1, 2), &mut reopened, &quiet).unwrap();
    assert_eq!(reopened.rows, vec![first.clone()]);
    assert!(start.elapsed().as_secs_f64() < 1.0);
    let mut reopened = Library::open(&dir).unwrap();
    run_specs(std::slice::from_ref(&spec), &small(2, 2), &mut reopened, &quiet).unwrap();
    assert_eq!(reopened.rows.len(), 2);
    assert_eq!(reopened.rows[0], first);
    assert_eq!(
        std::fs::read_to_string(dir.join(&first.json)).unwrap(),
        first_text
    );
    assert_ne!(reopened.rows[1].id, first.id);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn aspheric_designs_improve_on_their_spherical_parents() {
    let mut spec = DesignSpec::new(2, 20.0, 4.0, StopPosition::Front, 50.0).unwrap();
    spec.aspheric = true;
    let dir = scratch("asphere");
    let mut library = Library::open(&dir).unwrap();
    run_specs(std::slice::from_ref(&spec), &small(1, 4), &mut library, &quiet).unwrap();
    let child = library
        .rows
        .iter()
        .find(|r| r.aspheric)
        .expect("an aspheric lens");
    let parent = library.rows.iter().find(|r| r.id == child.parent).unwrap();
    eprintln!(
        "parent rms {} um, aspheric rms {} um",
        parent.rms_mean_um, child.rms_mean_um
    );
    assert!(child.merit < parent.merit);
    assert!(child.rms_mean_um < parent.rms_mean_um);
    let lens = unicac_optics::read_spec(&dir.join(&child.json)).unwrap().spec;
    assert!(lens
        .surfaces
        .iter()
        .any(|s| s.surface_type == unicac_optics::spec::SurfaceType::EvenAsphere));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn work_stops_at_the_time_budget() {
    let spec = DesignSpec::new(6, 30.0, 3.0, StopPosition::Middle, 50.0).unwrap();
    let dir = scratch("budget");
    let mut settings = RunSettings::new(1000, 1);
    settings.time_budget_s = Some(3.0);
    settings.rounds = usize::MAX;
    let mut library = Library::open(&dir).unwrap();
    let start = Instant::now();
    run_specs(std::slice::from_ref(&spec), &settings, &mut library, &quiet).unwrap();
    let elapsed = start.elapsed().as_secs_f64();
    // One refinement iteration of a 6-element design is the longest step that cannot be interrupted.
    assert!(elapsed < 6.0, "took {elapsed} s");
    for row in &library.rows {
        let lens = unicac_optics::read_spec(&dir.join(&row.json)).unwrap().spec;
        assert!(verify(&lens, 50.0, 1e-6).passed);
    }
    let _ = std::fs::remove_dir_all(&dir);
}
