//! `unicac psf`: one field's PSF as an EXR stack (monochromatic "Y", or R, G, B) with JSON metadata.

use super::print_json;
use crate::args::PsfArgs;
use crate::lens_input::load_spec;
use anyhow::Result;
use unicac_image::Planar;
use unicac_optics::Lens;
use unicac_psf::{
    FieldPsf, FieldPsfRequest, FieldPsfResponse, PsfCache, PsfError, PsfMetadata, PsfMode, Served,
};

pub fn run(args: &PsfArgs) -> Result<()> {
    let request = check_request(args)?.with_backend(super::gpu::backend(&args.device));
    let mut spec = load_spec(&args.lens.lens)?;
    if let Some(distance) = args.object_distance_mm {
        spec.object_distance_mm = Some(distance);
    }
    let lens = Lens::from_spec(&spec).map_err(|e| anyhow::anyhow!("{}: {e}", args.lens.lens))?;
    let pixel_um = request.pixel_um_for(&lens).map_err(flag_error)?;
    let weights = request.weights();
    let lens_sha256 = unicac_psf::lens_fingerprint(&lens);
    let cache = (!args.no_cache).then(PsfCache::default_location).flatten();
    let run = request.run_cached(&lens, cache.as_ref());
    super::gpu::print_notes(request.backend().take_notes());
    let run = run.map_err(flag_error)?;
    if let Some(warning) = &run.cache_warning {
        eprintln!("warning: {warning}");
    }
    let (psf, from_cache) = match run.served {
        Served::Cached(mut psfs) => (
            psfs.pop().ok_or_else(|| anyhow::anyhow!("no PSF was cached"))?,
            true,
        ),
        Served::Traced(traced) => (one_psf(request.mode(), traced)?, false),
    };
    let metadata = PsfMetadata::new(request.mode(), &psf, pixel_um, &weights);
    let size = metadata.kernel_px;
    let mut stack = Planar::new(size, size, metadata.channels.len());
    for (c, kernel) in psf.kernels.iter().enumerate() {
        stack.plane_mut(c).copy_from_slice(&kernel.data);
    }
    unicac_image::io::write_exr_channels(&args.out, &stack, &metadata.channels)?;
    if let Some(path) = &args.plot {
        plot(&psf, &metadata.channels, args, path)?;
    }
    let report = unicac_psf::PsfReport {
        lens: args.lens.lens.clone(),
        metadata,
        lens_sha256,
        from_cache,
        out: args.out.display().to_string(),
    };
    let sidecar = args.out.with_extension("json");
    unicac_optics::io::write_atomically(&sidecar, serde_json::to_string_pretty(&report)?.as_bytes())?;
    if args.json {
        return print_json(&report);
    }
    eprintln!(
        "wrote {} and {} ({size} x {size} px at {pixel_um} um)",
        args.out.display(),
        sidecar.display()
    );
    Ok(())
}

/// A library parameter error in this face's words: the flag (`--field-deg`) for the field (`field_deg`).
pub(crate) fn flag_error(error: PsfError) -> anyhow::Error {
    match error {
        PsfError::InvalidParameter(parameter) => super::flag_error(parameter),
        other => other.into(),
    }
}

/// Everything that can be refused before any work: the field, the wavelengths and the pitch (checked
/// by the request), and the outputs (the EXR under an .exr name, its JSON sidecar and the picture
/// never over the lens file or each other).
fn check_request(args: &PsfArgs) -> Result<FieldPsfRequest> {
    let mode: PsfMode = args.mode.parse().map_err(flag_error)?;
    let request = FieldPsfRequest::new(mode, vec![args.field_deg], args.wavelengths_um.clone())
        .and_then(|r| r.with_field_x_deg(args.field_x_deg))
        .and_then(|r| r.with_pixel_um(args.pixel_um))
        .and_then(|r| r.with_kernel_cap(args.max_kernel_px))
        .map_err(flag_error)?;
    unicac_io::require_extension("--out", &args.out, &["exr"])?;
    let mut plan = crate::outputs::plan(Some(args.lens.lens.as_str()));
    plan.output("--out", &args.out)
        .output("--out (JSON sidecar)", args.out.with_extension("json"));
    crate::outputs::picture(&mut plan, "--plot", args.plot.as_deref())?;
    plan.check()?;
    Ok(request)
}

/// The one PSF of a traced request, with the warnings it calls for.
fn one_psf(mode: PsfMode, mut traced: FieldPsfResponse) -> Result<FieldPsf> {
    let psf = traced
        .psfs
        .pop()
        .ok_or_else(|| anyhow::anyhow!("no PSF was traced"))?;
    match mode {
        PsfMode::Geometric => warn_if_cut(&psf, traced.requested_kernel_px, traced.max_kernel_px),
        PsfMode::Wave if traced.undersampled => {
            eprintln!("warning: the pupil grid undersamples this wavefront; the wave PSF is approximate")
        }
        PsfMode::Wave => {}
    }
    Ok(psf)
}

fn warn_if_cut(psf: &FieldPsf, requested: usize, cap: usize) {
    let worst = psf.energy_cut.iter().fold(0.0f64, |m, v| m.max(*v));
    if requested > cap || worst > 0.01 {
        eprintln!(
            "warning: kernel capped at {cap} px; {:.2}% of the energy fell outside and was cut \
             (--max-kernel-px lifts the cap)",
            100.0 * worst
        );
    }
}

fn plot(psf: &FieldPsf, names: &[&'static str], args: &PsfArgs, path: &std::path::Path) -> Result<()> {
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
