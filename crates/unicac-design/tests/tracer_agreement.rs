//! The design tracer against unicac-trace (the reference f64 tracer) on the same lenses, and its dual
//! gradients against central finite differences.

use unicac_design::dual::Dual;
use unicac_design::export::{from_lens, to_lens_spec};
use unicac_design::merit::{Merit, Sampling};
use unicac_design::params::Parameterization;
use unicac_design::scalar::Scalar;
use unicac_design::system::Prescription;
use unicac_design::tracer::{aimed_ray, paraxial, Tracer};
use unicac_design::{DesignSpec, StopPosition};
use unicac_optics::Lens;
use unicac_trace::{Aimer, Aiming, Clipping, TraceSystem};

fn cooke() -> Lens {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../../lenses/cooke_triplet.json");
    unicac_optics::load_lens(std::path::Path::new(path)).unwrap().0
}

/// Largest |intercept difference| (mm) between the two tracers over fields, pupil points, wavelengths.
fn worst_intercept_difference(lens: &Lens, p: &Prescription<f64>, fields_deg: &[f64]) -> f64 {
    let first = lens.first_order().unwrap();
    let mut worst = 0.0f64;
    for wavelength in lens.wavelengths_um() {
        let system = TraceSystem::new(lens, wavelength, Clipping::None).unwrap();
        let aimer = Aimer::new(lens, wavelength, Aiming::Paraxial).unwrap();
        let tracer = Tracer::new(p, wavelength);
        let ours_first = paraxial(p, lens.primary_wavelength_um()).unwrap();
        for &field in fields_deg {
            for k in 0..24 {
                let angle = k as f64 * 0.37;
                let r = (k as f64 / 23.0).sqrt();
                let (px, py) = (r * angle.sin(), r * angle.cos());
                let mut reference = aimer.ray(field, px, py).unwrap();
                assert!(system.trace(&mut reference).is_ok());
                let mut ray = aimed_ray(field, px, py, first.epd_mm / 2.0, ours_first.entrance_pupil_z);
                tracer.trace(&mut ray, |_, _| {}).unwrap();
                for a in 0..3 {
                    worst = worst.max((ray.position[a] - reference.position_mm[a]).abs());
                    worst = worst.max((ray.direction[a] - reference.direction[a]).abs());
                }
            }
        }
    }
    worst
}

#[test]
fn f64_trace_matches_unicac_trace_on_the_cooke_triplet() {
    let lens = cooke();
    let p = from_lens(&lens).unwrap();
    let first = lens.first_order().unwrap();
    let ours = paraxial(&p, lens.primary_wavelength_um()).unwrap();
    assert!((ours.efl - first.efl_mm).abs() < 1e-12 * first.efl_mm);
    assert!((ours.entrance_pupil_z - first.entrance_pupil_z_mm).abs() < 1e-12);
    let worst = worst_intercept_difference(&lens, &p, &[0.0, 14.0, 20.0]);
    eprintln!("Cooke triplet: worst intercept/direction difference {worst:e}");
    assert!(worst < 1e-12, "worst difference {worst:e} mm");
}

/// A designed aspheric lens (r^4..r^10 on two surfaces, a conic, catalogue and model glass) written as
/// a lens file, read back by unicac-optics and traced by both.
#[test]
fn f64_trace_matches_unicac_trace_on_an_aspheric_design() {
    let spec = DesignSpec::new(2, 25.0, 4.0, StopPosition::Middle, 30.0).unwrap();
    let mut p = from_lens(&cooke()).unwrap();
    p.surfaces.truncate(4);
    p.surfaces[3].thickness = 30.0;
    p.surfaces[0].is_asphere = true;
    p.surfaces[0].conic = -0.8;
    p.surfaces[0].asphere = [2e-5, -3e-7, 1e-9, -2e-12];
    p.surfaces[3].is_asphere = true;
    p.surfaces[3].asphere = [-1e-5, 2e-7, 0.0, 1e-12];
    let lens_spec = to_lens_spec(&p, &spec, &[], "test", "");
    let lens = Lens::from_spec(&lens_spec).unwrap();
    let round_trip = from_lens(&lens).unwrap();
    let worst = worst_intercept_difference(&lens, &round_trip, &[0.0, 10.0, 18.0]);
    eprintln!("aspheric design: worst intercept/direction difference {worst:e}");
    assert!(worst < 1e-12, "worst difference {worst:e} mm");
}

/// Central finite differences of the f64 residuals against the dual Jacobian, variable by variable.
fn check_gradients(spec: &DesignSpec, aspheric: bool) {
    let merit = Merit::new(spec, Sampling::COARSE);
    let mut params = Parameterization::spherical(spec);
    // A plausible, not optimised, design point: inside every bound, rays all traced.
    let x: Vec<f64> = (0..params.len())
        .map(|i| 0.5 + 0.013 * ((i * 7) % 5) as f64 - 0.02)
        .collect();
    let mut x = x;
    if aspheric {
        let p = params.decode(&x).unwrap();
        params = params.with_aspheres(p.clone(), &[(0, 10.0), (p.surfaces.len() - 2, 10.0)], 0.5);
        x = params.encode(&p);
        // Move the new conic and polynomial variables off zero.
        let n = x.len();
        for xi in &mut x[n - 10..] {
            *xi += 0.01;
        }
    }
    const N: usize = 32;
    assert!(params.len() <= N);
    let dual_x: Vec<Dual<N>> = x.iter().enumerate().map(|(i, &v)| Dual::variable(v, i)).collect();
    let p = params.decode(&dual_x).unwrap();
    let evaluation = merit.evaluate(&p);
    assert_eq!(evaluation.terms.failed_rays, 0);
    let residual_at = |x: &[f64]| merit.evaluate(&params.decode(x).unwrap()).residuals;
    let base = residual_at(&x);
    assert_eq!(base.len(), evaluation.residuals.len());
    for (r, d) in base.iter().zip(&evaluation.residuals) {
        assert!((r - d.re()).abs() <= 1e-12 * r.abs().max(1.0));
    }
    // Residuals are image heights (~10 mm) minus a centroid, in um: their rounding noise (~1e-12) over a
    // step of 4e-5 (normalised) stays near 1e-8 relative, and the truncation error h^2 f''' / 6 below it.
    let h = 4e-5;
    let mut worst = 0.0f64;
    let difference = |j: usize, step: f64| {
        let mut plus = x.clone();
        let mut minus = x.clone();
        plus[j] += step;
        minus[j] -= step;
        (residual_at(&plus), residual_at(&minus))
    };
    for j in 0..params.len() {
        let (rp, rm) = difference(j, h);
        let column_scale = (0..base.len())
            .map(|i| evaluation.residuals[i].grad[j].abs())
            .fold(0.0, f64::max)
            .max(1e-3);
        for i in 0..base.len() {
            // Penalties switch on at their limits: skip residuals that change branch within +-h.
            if (rp[i] == 0.0) != (rm[i] == 0.0) {
                continue;
            }
            let fd = (rp[i] - rm[i]) / (2.0 * h);
            let ad = evaluation.residuals[i].grad[j];
            worst = worst.max((fd - ad).abs() / column_scale);
        }
    }
    eprintln!("worst relative gradient error {worst:e}");
    assert!(worst < 1e-6, "worst relative gradient error {worst:e}");
}

#[test]
fn dual_gradients_match_central_differences_spherical() {
    check_gradients(
        &DesignSpec::new(3, 20.0, 5.0, StopPosition::Middle, 50.0).unwrap(),
        false,
    );
}

#[test]
fn dual_gradients_match_central_differences_aspheric() {
    check_gradients(
        &DesignSpec::new(3, 20.0, 5.0, StopPosition::Middle, 50.0).unwrap(),
        true,
    );
}

#[test]
fn model_glass_dispersion_is_the_optics_crate_model() {
    use unicac_design::system::Material;
    let m = Material::Model { nd: 1.62, vd: 60.3 };
    for l in [0.45, 0.5876, 0.7] {
        let n: f64 = m.index(l);
        assert!((n - unicac_optics::material::model_glass_index(1.62, 60.3, l)).abs() < 1e-15);
    }
}
