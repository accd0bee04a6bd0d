//! Rendering one unit of work: a lens's PSF table, one LQ/GT pair, a test lens's edge patches.
//! Each is a pure function of its manifest row (and the lens), so a resumed or sharded build, or a
//! reader checking a pair, recomputes exactly the stored bytes.

use crate::builder::pair_check;
use crate::builder::sources::cut;
use crate::error::{DatasetError, Result};
use crate::manifest::{IspRecord, PairCheck, PairRow, PairTask};
use crate::psf_table::{PsfTable, PsfTableMeta, TABLE_FORMAT};
use unicac_image::isp::{IspDraw, Pipeline};
use unicac_image::Planar;
use unicac_psf::{visible_wavelengths_um, SpectralWeights};
use unicac_sim::{ImageBackend, LensSimulator, PsfCache, RadialPsfs, SimulationSettings};

/// The simulator of a lens on the build's sensor (`lens` already carries the build sensor; a lens of
/// the build is rotationally symmetric, `check_inputs`, so its PSFs lie along one radius).
pub fn simulator(
    lens: &unicac_optics::Lens,
    frame_px: [usize; 2],
    pixel_um: f64,
    distortion: bool,
    illumination: bool,
    cache: Option<PsfCache>,
    image: ImageBackend,
) -> std::result::Result<LensSimulator, unicac_sim::SimError> {
    let settings = settings(distortion, illumination, cache, image);
    LensSimulator::new(lens, frame_px[0], frame_px[1], Some(pixel_um), settings)
}

/// The simulation settings of every pair: the library's defaults with the build's switches.
fn settings(
    distortion: bool,
    illumination: bool,
    cache: Option<PsfCache>,
    image: ImageBackend,
) -> SimulationSettings {
    SimulationSettings {
        distortion,
        illumination,
        cache,
        image,
        ..SimulationSettings::default()
    }
}

/// The simulator of an as-built unit, or of its design as the as-built split renders it: the planar
/// maps (not cached) on the design's sensor, the rays aimed as the design's are (`Aiming::Auto`
/// decided on the design: `auto` would aim every unit for real, and a design aimed paraxially would
/// then differ from its units by the aiming as well as by their errors).
pub fn unit_simulator(
    unit: &unicac_optics::Lens,
    design: &unicac_optics::Lens,
    frame_px: [usize; 2],
    pixel_um: f64,
    distortion: bool,
    illumination: bool,
    image: ImageBackend,
) -> std::result::Result<LensSimulator, unicac_sim::SimError> {
    let mut settings = settings(distortion, illumination, None, image);
    settings.psf.aiming = unicac_trace::AutoAiming::decide(design)?.aiming;
    settings.planar = true;
    LensSimulator::new(unit, frame_px[0], frame_px[1], Some(pixel_um), settings)
}

/// The sensor/ISP configuration a pair row records.
pub fn pipeline(record: &IspRecord, white_balance_jitter: f32) -> Pipeline {
    Pipeline {
        white_balance_jitter,
        sensor: record.sensor,
        no_isp: !record.isp,
        no_noise: !record.noise,
        ..Pipeline::default()
    }
}

/// What a row records of a pipeline and its draw for `seed`.
pub fn isp_record(pipeline: &Pipeline, draw: &IspDraw) -> IspRecord {
    IspRecord {
        white_balance_gains: [draw.gains.red, draw.gains.green, draw.gains.blue],
        white_balance_jitter: pipeline.white_balance_jitter,
        noise_seed: draw.noise_seed,
        isp: !pipeline.no_isp,
        noise: !pipeline.no_noise,
        sensor: pipeline.sensor,
    }
}

/// A rendered pair: the images as written (sRGB in [0, 1], cut to the row's crop) and their checks.
pub struct RenderedPair {
    pub lq: Planar,
    pub gt: Planar,
    pub check: PairCheck,
}

/// The LQ/GT images of a pair. `frame` is the scene already cut to the sensor frame (linear light).
/// LQ: the lens (blur, then its geometry: distortion warp and shading), sensor noise and the ISP.
/// GT: the same ISP draw (white balance, mosaic and demosaic, tone) without the blur and without
/// noise, on the scene carried through the lens's geometry (`aligned`) or on the scene itself
/// (`full`); the geometry is the simulator's own, so both tasks warp with one implementation.
pub fn render_pair(sim: &LensSimulator, frame: &Planar, row: &PairRow) -> Result<RenderedPair> {
    let pipeline = pipeline(&row.isp_draw, row.isp_draw.white_balance_jitter);
    let draw = pipeline.draw(row.seed).map_err(image_error(&row.pair_id))?;
    let recorded = row.isp_draw.white_balance_gains;
    if [draw.gains.red, draw.gains.green, draw.gains.blue] != recorded
        || draw.noise_seed != row.isp_draw.noise_seed
    {
        return Err(DatasetError::Invalid(format!(
            "pair {}: the recorded ISP draw does not follow from its seed",
            row.pair_id
        )));
    }
    let sim_error = |e: unicac_sim::SimError| DatasetError::simulation(format!("pair {}", row.pair_id))(e);
    let raw = pipeline
        .unprocess(frame.clone(), &draw)
        .map_err(image_error(&row.pair_id))?;
    let blurred = sim.blur(&raw).map_err(sim_error)?;
    let through_lens = sim.geometry(&blurred).map_err(sim_error)?;
    // The noisy read-out follows the simulator's device (a GPU build reads out there).
    let lq = sim
        .process(&pipeline, &through_lens, &draw)
        .map_err(|e| match e {
            unicac_sim::SimError::Image(e) => image_error(&row.pair_id)(e),
            other => sim_error(other),
        })?;
    let clean = IspDraw {
        noise_seed: None,
        gains: draw.gains,
    };
    let gt_pipeline = Pipeline {
        no_noise: true,
        ..pipeline
    };
    let finish = |linear: &Planar| -> Result<Planar> {
        let image = gt_pipeline
            .process(linear, &clean)
            .map_err(image_error(&row.pair_id))?;
        Ok(cut(&image, row.crop))
    };
    // The GT, and the GT with the lens blur put in (what blur alone makes of it: the reference of
    // `blur_share`); for aligned pairs that is the noiseless LQ itself, the same chain.
    let lq_clean = finish(&through_lens)?;
    let (gt, gt_blurred) = match row.task {
        PairTask::Aligned => (finish(&sim.geometry(&raw).map_err(sim_error)?)?, lq_clean.clone()),
        PairTask::Full => (finish(&raw)?, finish(&blurred)?),
    };
    let lq = cut(&lq, row.crop);
    let check = pair_check::measure(&lq, &lq_clean, &gt, &gt_blurred);
    Ok(RenderedPair { lq, gt, check })
}

fn image_error(what: &str) -> impl Fn(unicac_image::ImageError) -> DatasetError + '_ {
    move |e| DatasetError::image(format!("pair {what}"))(e)
}

/// The lens's PSF table from the simulator's radial PSFs (the PSFs that render its pairs), turned
/// from the simulator's sensor +y radius to the frame's +x axis (docs/dataset.md). `radial`:
/// `sim.radial()`, which `simulator` guarantees.
pub fn psf_table(lens_id: &str, sim: &LensSimulator, radial: &RadialPsfs) -> PsfTable {
    let half_diagonal_mm = sim.grid.half_diagonal_mm();
    let peak = radial.peak_transmission().max(1e-12);
    let weights = SpectralWeights::new(
        &sim.settings.response,
        &visible_wavelengths_um(sim.settings.wavelengths),
    );
    let k = radial.kernel_size;
    let mut kernels = Vec::with_capacity(radial.psfs.len() * 3 * k * k);
    for psf in &radial.psfs {
        for c in 0..3 {
            // The field on sensor +y turned by 90 degrees to lie on image +x.
            let mut kernel = psf.kernels[c].quarter_turned(1);
            kernel.normalise();
            kernels.extend_from_slice(&kernel.data);
        }
    }
    let radii = &radial.radii_mm;
    PsfTable {
        meta: PsfTableMeta {
            format: TABLE_FORMAT.into(),
            format_version: crate::FORMAT_VERSION,
            lens_id: lens_id.into(),
            field_radius_norm: radii.iter().map(|r| r / half_diagonal_mm).collect(),
            field_deg: radial.psfs.iter().map(|p| p.field_deg).collect(),
            kernel_px: k,
            pixel_um: sim.grid.pitch_um,
            frame_px: [sim.grid.width_px, sim.grid.height_px],
            relative_illumination: radii
                .iter()
                .map(|&r| sim.chief.illumination_factor(r) * radial.transmission_at(r) / peak)
                .collect(),
            distortion: radii
                .iter()
                .map(|&r| {
                    let ideal = sim.chief.ideal_height(r);
                    if r > 0.0 && ideal > 0.0 {
                        r / ideal
                    } else {
                        1.0
                    }
                })
                .collect(),
            channel_weights: (0..3)
                .map(|c| weights.weights.iter().map(|w| w[c]).collect())
                .collect(),
            wavelengths_um: weights.wavelengths_um.clone(),
            energy_cut: radial
                .psfs
                .iter()
                .map(|p| std::array::from_fn(|c| p.energy_cut.get(c).copied().unwrap_or(0.0)))
                .collect(),
            unicac_version: env!("CARGO_PKG_VERSION").into(),
        },
        kernels,
    }
}

/// A grey linear patch as the 3-channel sRGB image a restoration model takes.
pub fn grey_to_srgb(patch: &Planar) -> Planar {
    let rgb = Planar::from_fn(patch.width, patch.height, 3, |_, x, y| patch.get(0, x, y));
    unicac_image::color::linear_to_srgb(&rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turning_to_plus_x_matches_the_simulators_psf_on_the_x_axis() {
        let lens =
            unicac_optics::Lens::from_spec(&unicac_optics::builtin::spec("cooke_triplet").unwrap()).unwrap();
        let sim = simulator(&lens, [96, 64], 8.0, true, true, None, ImageBackend::cpu()).unwrap();
        let radial = sim.radial().expect("a symmetric lens");
        let table = psf_table("cooke", &sim, radial);
        let f = table.fields() - 1;
        let radius_mm = radial.radii_mm[f];
        for c in 0..3 {
            // The simulator rotates a +y kernel to +x by bilinear resampling; ours is a permutation.
            let reference = radial.kernel_at(radius_mm, 0.0, c);
            let ours = table.kernel(f, c);
            let difference: f64 = reference
                .data
                .iter()
                .zip(ours)
                .map(|(a, b)| (a - b).abs() as f64)
                .sum();
            assert!(difference < 1e-3, "channel {c}: L1 {difference}");
        }
        // Each stored channel sums to 1 and the outer field's centroid lies on the +x axis.
        let [dx, dy, ..] = crate::psf_table::raw_moments(table.kernel(f, 1), table.meta.kernel_px);
        assert!(dy.abs() < 1e-3 && dx.abs() >= dy.abs(), "{dx} {dy}");
        for c in 0..3 {
            let sum: f64 = table.kernel(f, c).iter().map(|&v| v as f64).sum();
            assert!((sum - 1.0).abs() < 1e-5);
        }
        assert!((table.meta.field_radius_norm[f] - 1.0).abs() < 1e-9);
        assert_eq!(table.meta.relative_illumination[0], 1.0);
    }
}
