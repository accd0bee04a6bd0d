//! ODE on the bundled lenses: values in range, ordering that matches optical quality, reproducibility.

use unicac_ode::{evaluate, OdeSettings};
use unicac_optics::examples;

fn quick() -> OdeSettings {
    OdeSettings {
        wavelengths: 11,
        rays_per_psf: 1024,
        ..Default::default()
    }
}

#[test]
fn ode_is_bounded_tabulated_and_reproducible() {
    let lens = examples::lens("cooke_triplet").unwrap();
    let report = evaluate(&lens, &quick()).unwrap();
    assert_eq!(report.table.len(), 15, "5 fields x 3 channels");
    for s in &report.table {
        assert!(s.psnr_db.is_finite() && s.psnr_db > 10.0, "{s:?}");
        assert!(
            (0.0..=1.0).contains(&s.ssim) && (0.0..=1.0).contains(&s.oiqe),
            "{s:?}"
        );
    }
    assert!(report.ode > 0.0 && report.ode <= 1.01, "{}", report.ode);
    assert!(report.u_s > 0.0 && report.u_s <= 1.0 && report.u_c > 0.0 && report.u_c <= 1.0);
    let again = evaluate(&lens, &quick()).unwrap();
    assert_eq!(report.ode, again.ode);
}

#[test]
fn a_sharper_lens_scores_higher() {
    // The same Cooke triplet stopped down from F/5 to F/10 has much smaller geometric blur.
    let mut spec = examples::spec("cooke_triplet").unwrap();
    let wide = unicac_optics::Lens::from_spec(&spec).unwrap();
    spec.aperture = unicac_optics::spec::ApertureSpec::EntrancePupilDiameterMm(5.0);
    let stopped = unicac_optics::Lens::from_spec(&spec).unwrap();
    let (a, b) = (
        evaluate(&wide, &quick()).unwrap(),
        evaluate(&stopped, &quick()).unwrap(),
    );
    assert!(b.rms_radius_um < a.rms_radius_um);
    assert!(b.ode > a.ode, "F/10 {} vs F/5 {}", b.ode, a.ode);
    assert!(b.oiqe > a.oiqe);
}
