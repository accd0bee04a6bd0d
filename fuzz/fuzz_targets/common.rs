//! Shared by the lens targets: a loaded spec must either be refused with an error or give a lens
//! whose reported first-order data and traced rays are finite.

use unicac_optics::{Lens, LensSpec};
use unicac_trace::{Aimer, Aiming, Clipping, Ray, TraceSystem};

pub fn check_spec(spec: &LensSpec) {
    let Ok(lens) = Lens::from_spec(spec) else { return };
    check_lens(&lens);
}

pub fn check_lens(lens: &Lens) {
    let Ok(first) = lens.first_order() else { return };
    for value in [
        first.efl_mm,
        first.bfl_mm,
        first.epd_mm,
        first.f_number,
        first.stop_radius_mm,
        first.paraxial_image_z_mm,
        first.entrance_pupil_z_mm,
    ] {
        assert!(value.is_finite(), "first-order data reported valid but not finite: {first:?}");
    }
    let wavelength = lens.primary_wavelength_um();
    let (Ok(system), Ok(aimer)) = (
        TraceSystem::new(lens, wavelength, Clipping::Apertures),
        Aimer::new(lens, wavelength, Aiming::Paraxial),
    ) else {
        return;
    };
    for &field in first.field_angles_deg.iter().take(3) {
        for [px, py] in [[0.0, 0.0], [0.0, 1.0], [0.7, -0.7], [-1.0, 0.0]] {
            let Ok(mut ray) = aimer.ray(field, px, py) else { continue };
            let status = system.trace(&mut ray);
            assert!(ray.is_finite(), "a traced ray holds NaN: {ray:?} ({status})");
            if status.is_ok() {
                let norm: f64 = ray.direction.iter().map(|d| d * d).sum();
                assert!((norm - 1.0).abs() < 1e-6, "direction not unit: {ray:?}");
            }
        }
        let start = Ray::new([0.0, 0.5, -1.0], [0.0, 0.1, 1.0]);
        let (_, status) = system.trace_path_from_start(start);
        let _ = status;
    }
}
