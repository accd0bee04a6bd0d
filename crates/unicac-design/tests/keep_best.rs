//! `--count N` keeps the N best distinct designs (issue 11, part 4), on small deterministic runs (no clock:
//! a number of search rounds instead of a time budget, so the test cannot depend on machine speed):
//! a longer search keeps designs at least as good, the first-acceptable mode stops at once, and every kept
//! design holds the default 0.1 mm (at f = 50 mm) edge air gap, checked here on the lens file itself.

use std::path::PathBuf;
use unicac_design::library::Library;
use unicac_design::run::{run_specs, Event, RunSettings, StopReason};
use unicac_design::{DesignSpec, StopPosition};
use unicac_optics::Lens;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-keep-best-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

fn small(count: usize, rounds: usize) -> RunSettings {
    let mut settings = RunSettings::new(count, 5);
    settings.global.population = 24;
    settings.global.generations = 5;
    settings.global.parents = 6;
    settings.refine_iterations = 40;
    settings.rounds = rounds;
    settings
}

fn spec() -> DesignSpec {
    DesignSpec::new(2, 20.0, 4.0, StopPosition::Middle, 50.0).unwrap()
}

/// Mean RMS of the kept spherical designs, best first.
fn kept(library: &Library) -> Vec<f64> {
    let mut rms: Vec<f64> = library
        .rows
        .iter()
        .filter(|r| !r.aspheric)
        .map(|r| r.rms_mean_um)
        .collect();
    rms.sort_by(f64::total_cmp);
    rms
}

/// Smallest air gap (mm) between neighbouring surfaces over the heights up to the smaller semi-diameter.
fn smallest_air_edge_gap_mm(lens: &Lens) -> f64 {
    let mut smallest = f64::INFINITY;
    let image = lens.surfaces.len() - 1;
    for i in 0..image.saturating_sub(1) {
        let (a, b) = (&lens.surfaces[i], &lens.surfaces[i + 1]);
        if !a.medium_after.is_air() {
            continue;
        }
        let height = a.semi_diameter_mm.unwrap().min(b.semi_diameter_mm.unwrap());
        for k in 0..=100 {
            let r = height * k as f64 / 100.0;
            // `Profile::sag` takes r^2.
            let gap = b.z_mm + b.profile.sag(r * r) - (a.z_mm + a.profile.sag(r * r));
            smallest = smallest.min(gap);
        }
    }
    smallest
}

#[test]
fn more_search_keeps_better_or_equal_designs_with_the_edge_gap_held() {
    let quiet = |_: Event| {};
    let (one, two) = (scratch("one"), scratch("two"));
    let mut a = Library::open(&one).unwrap();
    let short = run_specs(&[spec()], &small(2, 1), &mut a, &quiet).unwrap();
    let mut b = Library::open(&two).unwrap();
    let long = run_specs(&[spec()], &small(2, 3), &mut b, &quiet).unwrap();
    let (rms_short, rms_long) = (kept(&a), kept(&b));
    println!(
        "1 round: {rms_short:?} um ({:?}); 3 rounds: {rms_long:?} um ({:?}, {} rounds)",
        short[0].stop_reason, long[0].stop_reason, long[0].rounds
    );
    assert!(!rms_short.is_empty() && rms_short.len() <= 2, "{rms_short:?}");
    assert!(
        rms_long.len() >= rms_short.len() && rms_long.len() <= 2,
        "{rms_long:?}"
    );
    // Same seed, so the longer search saw every design of the shorter one: it keeps the best two of a
    // superset.
    for (l, s) in rms_long.iter().zip(&rms_short) {
        assert!(
            l <= s,
            "kept {rms_long:?} after 3 rounds vs {rms_short:?} after 1"
        );
    }
    assert!(matches!(
        long[0].stop_reason,
        StopReason::RoundsDone | StopReason::Converged
    ));
    for (dir, library) in [(&one, &a), (&two, &b)] {
        assert_eq!(
            std::fs::read_dir(dir.join("lenses")).unwrap().count(),
            4 * library.rows.len()
        );
        for row in &library.rows {
            let lens = unicac_optics::format::load_lens(&dir.join(&row.json)).unwrap().0;
            let gap = smallest_air_edge_gap_mm(&lens);
            assert!(gap >= 0.1 - 1e-6, "{}: air gap {gap} mm at the edge", row.id);
        }
    }
    let _ = std::fs::remove_dir_all(&one);
    let _ = std::fs::remove_dir_all(&two);
}

#[test]
fn first_acceptable_stops_at_the_count() {
    let dir = scratch("first");
    let mut library = Library::open(&dir).unwrap();
    let mut settings = small(1, 3);
    settings.first_acceptable = true;
    let summary = run_specs(&[spec()], &settings, &mut library, &|_| {}).unwrap();
    assert_eq!(summary[0].stop_reason, StopReason::CountReached);
    assert_eq!(library.rows.len(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}
