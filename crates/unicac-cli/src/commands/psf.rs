//! `unicac psf`: one field's PSF as an EXR stack (monochromatic "Y", or R, G, B) with JSON metadata.

use super::print_json;
use crate::args::PsfArgs;
use crate::lens_input::load_spec;
use anyhow::{bail, Result};
use serde::Serialize;
use unicac_image::Planar;
use unicac_optics::Lens;
use unicac_psf::{
    visible_wavelengths_um, FieldPsf, PsfSettings, PsfTracer, SpectralResponse, SpectralWeights,
    WavePsfSettings, WavePsfTracer,
};

/// Pixel pitch when neither --pixel-um nor the lens's sensor gives one.
const DEFAULT_PIXEL_UM: f64 = 2.0;

#[derive(Serialize)]
struct PsfReport<'a> {
    lens: &'a str,
    mode: &'a str,
    field_deg: f64,
    pixel_um: f64,
    kernel_px: usize,
    wavelengths_um: &'a [f64],
    skipped_wavelengths_um: &'a [f64],
    channels: Vec<&'static str>,
    reference_mm: [f64; 2],
    transmission: f64,
    energy_cut: &'a [f64],
    rays_traced: usize,
    /// SHA-256 of the lens model (the PSF cache's key starts with it).
    lens_sha256: String,
    from_cache: bool,
    out: String,
}

pub fn run(args: &PsfArgs) -> Result<()> {
    check_request(args)?;
    super::gpu::install(&args.device);
    let mut spec = load_spec(&args.lens.lens)?;
    if let Some(distance) = args.object_distance_mm {
        spec.object_distance_mm = Some(distance);
    }
    let lens = Lens::from_spec(&spec).map_err(|e| anyhow::anyhow!("{}: {e}", args.lens.lens))?;
    let pixel_um = args
        .pixel_um
        .or(lens.sensor.map(|s| s.pixel_pitch_um))
        .unwrap_or(DEFAULT_PIXEL_UM);
    if !(pixel_um.is_finite() && pixel_um > 0.0) {
        bail!("--pixel-um {pixel_um}: must be positive");
    }
    let monochromatic = args.wavelengths_um.len() == 1;
    let weights = match args.wavelengths_um.as_slice() {
        [] => SpectralWeights::new(&SpectralResponse::default_camera(), &visible_wavelengths_um(31)),
        [w] => SpectralWeights::monochromatic(*w),
        many => SpectralWeights::new(&SpectralResponse::default_camera(), many),
    };
    let lens_sha256 = unicac_sim::lens_fingerprint(&lens);
    let key = unicac_sim::PsfCache::key(&[
        b"field",
        lens_sha256.as_bytes(),
        format!(
            "{:?}",
            (
                &args.mode,
                args.field_deg,
                pixel_um,
                &weights,
                monochromatic,
                unicac_psf::default_hit_tracer().describe()
            )
        )
        .as_bytes(),
    ]);
    let cache = (!args.no_cache)
        .then(unicac_sim::PsfCache::default_location)
        .flatten();
    let cached = cache
        .as_ref()
        .and_then(|c| c.load(&key))
        .and_then(|mut p| p.pop());
    let from_cache = cached.is_some();
    let psf = match cached {
        Some(psf) => psf,
        None => {
            let psf = compute(&lens, &weights, pixel_um, args, monochromatic)?;
            if let Some(cache) = &cache {
                if let Err(error) = cache.store(&key, std::slice::from_ref(&psf)) {
                    eprintln!("warning: PSF cache {}: {error}", cache.dir.display());
                }
            }
            psf
        }
    };
    let names: Vec<&'static str> = if monochromatic {
        vec!["Y"]
    } else {
        vec!["R", "G", "B"]
    };
    let size = psf.kernels[0].size;
    let mut stack = Planar::new(size, size, names.len());
    for (c, kernel) in psf.kernels.iter().enumerate() {
        stack.plane_mut(c).copy_from_slice(&kernel.data);
    }
    unicac_image::io::write_exr_channels(&args.out, &stack, &names)?;
    if let Some(path) = &args.plot {
        plot(&psf, &names, args, path)?;
    }
    let report = PsfReport {
        lens: &args.lens.lens,
        mode: &args.mode,
        field_deg: args.field_deg,
        pixel_um,
        kernel_px: size,
        wavelengths_um: &weights.wavelengths_um,
        skipped_wavelengths_um: &weights.skipped_um,
        channels: names,
        reference_mm: psf.reference_mm,
        transmission: psf.transmission,
        energy_cut: &psf.energy_cut,
        rays_traced: psf.rays_traced,
        lens_sha256,
        from_cache,
        out: args.out.display().to_string(),
    };
    let metadata = args.out.with_extension("json");
    unicac_optics::io::write_atomically(&metadata, serde_json::to_string_pretty(&report)?.as_bytes())?;
    if args.json {
        return print_json(&report);
    }
    eprintln!(
        "wrote {} and {} ({size} x {size} px at {pixel_um} um)",
        args.out.display(),
        metadata.display()
    );
    Ok(())
}

/// Everything that can be refused before any work: the field, the wavelengths, and the outputs (the
/// EXR under an .exr name, its JSON sidecar and the picture never over the lens file or each other).
fn check_request(args: &PsfArgs) -> Result<()> {
    if !(args.field_deg.is_finite() && args.field_deg.abs() < 90.0) {
        bail!("--field-deg {}: must lie strictly between -90 and 90", args.field_deg);
    }
    if let Some(bad) = args.wavelengths_um.iter().find(|w| !(w.is_finite() && **w > 0.0)) {
        bail!("--wavelength-um {bad}: must be positive");
    }
    if let Some(pixel_um) = args.pixel_um.filter(|p| !(p.is_finite() && *p > 0.0)) {
        bail!("--pixel-um {pixel_um}: must be positive");
    }
    unicac_io::require_extension("--out", &args.out, &["exr"])?;
    let mut plan = crate::outputs::plan(Some(args.lens.lens.as_str()));
    plan.output("--out", &args.out)
        .output("--out (JSON sidecar)", args.out.with_extension("json"));
    crate::outputs::picture(&mut plan, "--plot", args.plot.as_deref())?;
    plan.check()?;
    Ok(())
}

/// The PSF of the requested mode, traced now.
fn compute(
    lens: &Lens,
    weights: &SpectralWeights,
    pixel_um: f64,
    args: &PsfArgs,
    monochromatic: bool,
) -> Result<FieldPsf> {
    Ok(match args.mode.as_str() {
        "wave" => wave_psf(lens, weights.clone(), pixel_um, args.field_deg, monochromatic)?,
        _ => {
            let tracer = PsfTracer::new(lens, weights.clone(), PsfSettings::new(pixel_um))?;
            let reference = tracer.reference_point_mm(args.field_deg)?;
            let hits = tracer.hits(args.field_deg, reference);
            tracer.require_arrivals(args.field_deg, &hits)?;
            let size = tracer.kernel_size_for(&hits);
            let psf = tracer.kernels_from_hits(args.field_deg, reference, &hits, size, monochromatic);
            warn_if_cut(&psf, size, tracer.settings().max_kernel_px);
            psf
        }
    })
}

fn warn_if_cut(psf: &FieldPsf, requested: usize, cap: usize) {
    let worst = psf.energy_cut.iter().fold(0.0f64, |m, v| m.max(*v));
    if requested > cap || worst > 0.01 {
        eprintln!(
            "warning: kernel capped at {cap} px; {:.2}% of the energy fell outside and was cut",
            100.0 * worst
        );
    }
}

/// Wave-optics PSF, sized like the geometric one of the same field (so both modes compare pixel for
/// pixel) and at least 31 px, for the diffraction rings.
fn wave_psf(
    lens: &Lens,
    weights: SpectralWeights,
    pixel_um: f64,
    field_deg: f64,
    monochromatic: bool,
) -> Result<FieldPsf> {
    let geometric = PsfTracer::new(lens, weights.clone(), PsfSettings::new(pixel_um))?;
    let reference = geometric.reference_point_mm(field_deg)?;
    let size = geometric
        .kernel_size_for(&geometric.hits(field_deg, reference))
        .max(31);
    let tracer = WavePsfTracer::new(lens, weights, WavePsfSettings::new(pixel_um))?;
    let detailed = tracer.field_psf_detailed(field_deg, reference, size, monochromatic)?;
    if detailed.undersampled {
        eprintln!("warning: the pupil grid undersamples this wavefront; the wave PSF is approximate");
    }
    Ok(detailed.psf)
}

fn plot(psf: &FieldPsf, names: &[&str], args: &PsfArgs, path: &std::path::Path) -> Result<()> {
    let panels: Vec<unicac_plot::PsfPanel> = psf
        .kernels
        .iter()
        .zip(names)
        .map(|(k, name)| unicac_plot::PsfPanel {
            label: name.to_string(),
            size: k.size,
            pitch_um: k.pitch_um,
            data: k.data.clone(),
        })
        .collect();
    let title = format!("{} PSF, {} at {} deg", args.mode, args.lens.lens, args.field_deg);
    unicac_plot::psf_panels(&title, &panels, path)?;
    eprintln!("wrote {}", path.display());
    Ok(())
}
