//! Built units graded against optiland 0.6.3 (tests/reference/tolerance): the same changes applied to
//! the Cooke triplet and graded with the same definitions agree to `RELATIVE_TOLERANCE`, and the draws
//! of seed 1 are the changes stored there (the random stream is pinned).

use serde_json::Value;
use std::path::Path;
use unicac_optics::builtin;
use unicac_tolerance::{apply, draw, score, Change, Compensator, FieldPoint, Grading, ToleranceSpec};

/// The two tracers agree to round-off (2.4e-13 relative at worst over 200 units); the bound leaves
/// room for other CPUs' libm.
const RELATIVE_TOLERANCE: f64 = 1e-9;

fn reference() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../tests/reference/tolerance/optiland_units_seed1.json");
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn close(a: f64, b: f64, what: &str) {
    assert!(
        (a - b).abs() <= RELATIVE_TOLERANCE * b.abs().max(1e-3),
        "{what}: unicac {a}, optiland {b}"
    );
}

fn check(scored: &unicac_tolerance::Score, expected: &Value, what: &str) {
    close(
        scored.focus_shift_mm,
        expected["focus_shift_mm"].as_f64().unwrap(),
        &format!("{what} focus"),
    );
    // Boresight is the distance of a centroid from the axis: compared in absolute terms (um).
    let boresight = expected["boresight_um"].as_f64().unwrap();
    assert!(
        (scored.boresight_um - boresight).abs() < 1e-9,
        "{what} boresight {} against {boresight}",
        scored.boresight_um
    );
    let rms: Vec<f64> = serde_json::from_value(expected["rms_um"].clone()).unwrap();
    assert_eq!(scored.rms_um.len(), rms.len());
    for (k, (a, b)) in scored.rms_um.iter().zip(&rms).enumerate() {
        close(*a, *b, &format!("{what} rms at point {k}"));
    }
}

#[test]
fn units_graded_like_optiland() {
    let reference = reference();
    let lens = builtin::lens("cooke_triplet").unwrap();
    let spec: ToleranceSpec = serde_json::from_value(reference["spec"].clone()).unwrap();
    let points: Vec<FieldPoint> = serde_json::from_value(reference["field_points"].clone()).unwrap();
    assert_eq!(points, unicac_tolerance::field_points(&lens).unwrap());
    let grading = Grading {
        pupil_grid: reference["pupil_grid"].as_u64().unwrap() as usize,
        mtf_frequencies_cy_mm: Vec::new(),
        ode: false,
    };
    let nominal = score(&lens, &points, &grading, Compensator::BackFocus).unwrap();
    check(&nominal, &reference["nominal"], "nominal");
    for unit in reference["units"].as_array().unwrap() {
        let trial = unit["trial"].as_u64().unwrap();
        let changes: Vec<Change> = serde_json::from_value(unit["changes"].clone()).unwrap();
        assert_eq!(
            draw(&lens, &spec, 1, trial),
            changes,
            "the draws of trial {trial}"
        );
        let scored = score(&apply(&lens, &changes), &points, &grading, Compensator::BackFocus).unwrap();
        check(&scored, unit, &format!("trial {trial}"));
    }
}
