//! The ODE of a built unit (issue 36): every off-axis field at four azimuths (`UNIT_AZIMUTHS_DEG`),
//! turned to +y and averaged per field fraction.

use unicac_ode::{evaluate, OdeSettings, UNIT_AZIMUTHS_DEG};
use unicac_optics::{builtin, Lens, Placement};

fn quick() -> OdeSettings {
    OdeSettings {
        wavelengths: 11,
        rays_per_psf: 1024,
        ..Default::default()
    }
}

fn cooke_with(index: usize, placement: Placement) -> Lens {
    let mut spec = builtin::spec("cooke_triplet").unwrap();
    spec.surfaces[index].set_placement(placement);
    Lens::from_spec(&spec).unwrap()
}

#[test]
fn a_symmetric_lens_graded_as_a_unit_scores_as_itself() {
    let nominal = builtin::lens("cooke_triplet").unwrap();
    // A decentre far below any traced quantity's precision sends it down the unit's path.
    let nudged = cooke_with(
        1,
        Placement {
            decentre_x_mm: 1e-13,
            ..Placement::default()
        },
    );
    let (a, b) = (
        evaluate(&nominal, &quick()).unwrap(),
        evaluate(&nudged, &quick()).unwrap(),
    );
    assert_eq!(a.table.len(), 15);
    // The axis once, every other fraction at the four azimuths; three channels each.
    assert_eq!(b.table.len(), 3 * (1 + 4 * UNIT_AZIMUTHS_DEG.len()));
    assert_eq!(b.rms_radius_by_field_um.len(), 5);
    println!("ODE nominal {:.5}, as a unit {:.5}", a.scores.ode, b.scores.ode);
    // The azimuths differ only by the pupil sampling's orientation and the aiming (real for a unit).
    assert!(
        (a.scores.ode - b.scores.ode).abs() < 5e-3,
        "{} vs {}",
        a.scores.ode,
        b.scores.ode
    );
    assert!((a.scores.oiq - b.scores.oiq).abs() < 5e-3);
    for (x, y) in a.rms_radius_by_field_um.iter().zip(&b.rms_radius_by_field_um) {
        assert!((x - y).abs() < 0.02 * x.max(1.0), "RMS {x} vs {y}");
    }
}

#[test]
fn a_decentred_unit_grades_each_azimuth_and_below_its_design() {
    let nominal = builtin::lens("cooke_triplet").unwrap();
    let unit = cooke_with(
        2,
        Placement {
            decentre_x_mm: 0.2,
            ..Placement::default()
        },
    );
    let (design, built) = (
        evaluate(&nominal, &quick()).unwrap(),
        evaluate(&unit, &quick()).unwrap(),
    );
    println!(
        "ODE design {:.4}, unit {:.4}",
        design.scores.ode, built.scores.ode
    );
    assert!(built.scores.ode < design.scores.ode - 0.05);
    // A decentre along x leaves the lens mirror-symmetric in y: the +y and -y fields mirror each other
    // (their OIQs differ by the pupil sampling's asymmetry only), the +x and -x fields (azimuths 90
    // and 270) are two different fields.
    let oiq = |fraction: f64, azimuth: f64| {
        let row = built
            .table
            .iter()
            .find(|s| s.field_fraction == fraction && s.azimuth_deg == azimuth && s.channel == "G")
            .unwrap();
        row.oiq
    };
    let (plus_x, minus_x) = (oiq(0.75, 90.0), oiq(0.75, 270.0));
    let (plus_y, minus_y) = (oiq(0.75, 0.0), oiq(0.75, 180.0));
    println!("OIQ at 0.75: +x {plus_x:.4}, -x {minus_x:.4}, +y {plus_y:.4}, -y {minus_y:.4}");
    assert!((plus_x - minus_x).abs() > 0.008, "+x {plus_x}, -x {minus_x}");
    assert!((plus_x - minus_x).abs() > 1.5 * (plus_y - minus_y).abs());
}
