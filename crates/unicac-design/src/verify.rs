//! Independent physical checks of a finished design, on the lens file it will be written as, with
//! unicac-optics and unicac-trace (not the design tracer): the file validates; every ray of every design
//! field and wavelength reaches the image through the clear apertures; no two neighbouring surfaces cross
//! and no glass edge is negative; the EFL is on target. Also the polychromatic RMS spot radius per field,
//! the figure compared with classic designs.

use serde::Serialize;
use unicac_optics::{Lens, LensSpec};
use unicac_trace::{Aiming, PupilSampling, SpotTracer};

/// Pupil sampling of the reported RMS spot radii (127 rays per field and wavelength).
pub const REPORT_SAMPLING: PupilSampling = PupilSampling::Hexapolar { rings: 6 };

#[derive(Debug, Clone, Serialize)]
pub struct Verification {
    pub passed: bool,
    /// Each failed check, by name.
    pub failures: Vec<String>,
    pub efl_mm: f64,
    /// Polychromatic RMS spot radius per field about the field's centroid over all wavelengths (um).
    pub rms_um: Vec<f64>,
    pub rms_mean_um: f64,
    pub rays_traced: usize,
    pub rays_ok: usize,
}

/// Polychromatic RMS radius (um) per field of `lens` at `fields_deg`, default (auto) aiming, and ray
/// counts.
pub fn polychromatic_rms(
    lens: &Lens,
    fields_deg: &[f64],
) -> unicac_trace::TraceResult<(Vec<f64>, usize, usize)> {
    let mut points: Vec<Vec<[f64; 2]>> = vec![Vec::new(); fields_deg.len()];
    let (mut traced, mut ok) = (0, 0);
    for wavelength in lens.wavelengths_um() {
        let tracer = SpotTracer::new(lens, wavelength, Aiming::Auto)?;
        for (fi, &field) in fields_deg.iter().enumerate() {
            let spot = tracer.spot(field, &REPORT_SAMPLING);
            traced += spot.rays_traced;
            ok += spot.rays_ok;
            points[fi].extend(spot.points_mm);
        }
    }
    let rms = points
        .iter()
        .map(|p| {
            let n = p.len().max(1) as f64;
            let cx = p.iter().map(|q| q[0]).sum::<f64>() / n;
            let cy = p.iter().map(|q| q[1]).sum::<f64>() / n;
            1000.0
                * (p.iter()
                    .map(|q| (q[0] - cx).powi(2) + (q[1] - cy).powi(2))
                    .sum::<f64>()
                    / n)
                    .sqrt()
        })
        .collect();
    Ok((rms, traced, ok))
}

/// Checks `spec` (a finished design) against `focal_length_mm` within `focal_tolerance`.
pub fn verify(spec: &LensSpec, focal_length_mm: f64, focal_tolerance: f64) -> Verification {
    let mut failures = Vec::new();
    let lens = match Lens::from_spec(spec) {
        Ok(lens) => lens,
        Err(e) => {
            return Verification {
                passed: false,
                failures: vec![format!("lens_file: {e}")],
                efl_mm: f64::NAN,
                rms_um: Vec::new(),
                rms_mean_um: f64::NAN,
                rays_traced: 0,
                rays_ok: 0,
            }
        }
    };
    let efl_mm = lens.first_order().map_or(f64::NAN, |f| f.efl_mm);
    if !((efl_mm / focal_length_mm - 1.0).abs() <= focal_tolerance) {
        failures.push(format!("focal_length: {efl_mm} mm, target {focal_length_mm} mm"));
    }
    let fields = match &spec.fields {
        unicac_optics::spec::FieldSpec::AnglesDeg(a) => a.clone(),
        other => other.values().to_vec(),
    };
    let (rms_um, traced, ok) = polychromatic_rms(&lens, &fields).unwrap_or((Vec::new(), 1, 0));
    if ok != traced {
        failures.push(format!("rays_traced: {} of {traced} rays lost", traced - ok));
    }
    failures.extend(geometry_failures(&lens));
    let rms_mean_um = rms_um.iter().sum::<f64>() / rms_um.len().max(1) as f64;
    Verification {
        passed: failures.is_empty(),
        failures,
        efl_mm,
        rms_um,
        rms_mean_um,
        rays_traced: traced,
        rays_ok: ok,
    }
}

/// Surfaces crossing (gap < 0 anywhere up to the smaller semi-diameter) and negative glass edges (at
/// the larger semi-diameter), from the lens model's own sag.
fn geometry_failures(lens: &Lens) -> Vec<String> {
    let mut failures = Vec::new();
    let image = lens.image_index();
    for i in 0..image.saturating_sub(1) {
        let (a, b) = (&lens.surfaces[i], &lens.surfaces[i + 1]);
        let (Some(ha), Some(hb)) = (a.semi_diameter_mm, b.semi_diameter_mm) else {
            continue;
        };
        let gap = |r: f64| {
            let rho = r * r;
            b.z_mm + b.profile.sag(rho) - a.z_mm - a.profile.sag(rho)
        };
        let reach = ha.min(hb);
        if (0..=32).any(|k| !(gap(reach * k as f64 / 32.0) >= 0.0)) {
            failures.push(format!(
                "surfaces_cross[{i}]: surfaces {} and {} intersect",
                i + 1,
                i + 2
            ));
        }
        if !a.medium_after.is_air() {
            let edge = gap(ha.max(hb));
            if !(edge >= 0.0) {
                failures.push(format!("negative_edge_thickness[{i}]: {edge:.4} mm"));
            }
        }
    }
    failures
}
