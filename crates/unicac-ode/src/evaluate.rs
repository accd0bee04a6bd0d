//! ODE of one lens (docs/ode.md).

use rayon::prelude::*;
use serde::Serialize;
use unicac_image::{charts, color, quantise, Planar};
use unicac_metrics::{
    ode_from_oiq_grid, oiq, oiqe, psnr, slanted_edge_mtf, ssim, FullReferenceOptions, MtfSummary, OdeWeights,
    OiqeWeights, Roi, SlantedEdgeOptions,
};
use unicac_optics::Lens;
use unicac_psf::{visible_wavelengths_um, Kernel, PsfSettings, PsfTracer, SpectralResponse, SpectralWeights};
use unicac_sim::ChiefRayMap;
use unicac_trace::{spots, Aiming, PupilSampling};

#[derive(Debug, thiserror::Error)]
pub enum OdeError {
    #[error(transparent)]
    Sim(#[from] unicac_sim::SimError),
    #[error(transparent)]
    Psf(#[from] unicac_psf::PsfError),
    #[error(transparent)]
    Trace(#[from] unicac_trace::TraceError),
    #[error(transparent)]
    Metrics(#[from] unicac_metrics::MetricsError),
    #[error(transparent)]
    Image(#[from] unicac_image::ImageError),
    #[error("field {field_fraction} ({field_deg:.3} deg) is fully vignetted: no ray reaches the image")]
    Vignetted { field_fraction: f64, field_deg: f64 },
    #[error("slanted edge at field {field_fraction}, channel {channel}, {direction} (kernel {kernel_px} px): {message}")]
    Edge {
        field_fraction: f64,
        channel: &'static str,
        direction: String,
        kernel_px: usize,
        message: String,
    },
}

/// What ODE is computed on; defaults as in docs/ode.md.
#[derive(Debug, Clone, Serialize)]
pub struct OdeSettings {
    /// Normalised image heights of the evaluated fields (fractions of the half-diagonal).
    pub field_fractions: Vec<f64>,
    /// Frame used when the lens file has no sensor: its half-diagonal holds the largest field.
    pub default_frame_px: [usize; 2],
    pub wavelengths: usize,
    pub rays_per_psf: usize,
    /// Checkerboard square side (px); fixed so PSNR and SSIM compare across lenses.
    pub square_px: usize,
    /// Slanted-edge patch side (px): at least this and at least 4 kernel widths.
    pub min_edge_px: usize,
    pub slant_deg: f64,
    pub contrast: f64,
    pub weights: OdeWeights,
    pub oiqe_weights: OiqeWeights,
}

impl Default for OdeSettings {
    fn default() -> Self {
        OdeSettings {
            field_fractions: vec![0.0, 0.25, 0.5, 0.75, 1.0],
            default_frame_px: [1920, 1080],
            wavelengths: 31,
            rays_per_psf: 2048,
            square_px: 32,
            min_edge_px: 64,
            slant_deg: 5.0,
            contrast: 1.0,
            weights: OdeWeights::default(),
            oiqe_weights: OiqeWeights::default(),
        }
    }
}

/// Scores of one field in one channel.
#[derive(Debug, Clone, Serialize)]
pub struct FieldChannelScore {
    pub field_fraction: f64,
    pub field_deg: f64,
    pub channel: &'static str,
    pub psnr_db: f64,
    pub ssim: f64,
    pub oiqe: f64,
    pub oiq: f64,
    pub mtf50_sagittal_cy_per_px: f64,
    pub mtf50_tangential_cy_per_px: f64,
}

#[derive(Debug, Clone, Serialize)]
pub struct OdeReport {
    pub ode: f64,
    pub oiq: f64,
    pub u_s: f64,
    pub u_c: f64,
    pub oiqe: f64,
    pub psnr_db: f64,
    pub ssim: f64,
    /// Mean RMS spot radius (about the centroid) over the evaluated fields and the lens's wavelengths.
    pub rms_radius_um: f64,
    pub pixel_um: f64,
    pub half_diagonal_mm: f64,
    pub kernel_px: usize,
    /// Per field and channel, fields varying slowest.
    pub table: Vec<FieldChannelScore>,
    /// RMS spot radius per field (um), same order as the fields.
    pub rms_radius_by_field_um: Vec<f64>,
    /// Where the time went (not part of the result; varies run to run).
    pub times: StageTimes,
}

const CHANNELS: [&str; 3] = ["R", "G", "B"];

/// Wall-clock seconds spent per stage of one evaluation.
#[derive(Debug, Clone, Default, Serialize)]
pub struct StageTimes {
    pub chief_ray_map_s: f64,
    pub psf_tracing_s: f64,
    pub imaging_and_scoring_s: f64,
    pub rms_spot_s: f64,
}

pub fn evaluate(lens: &Lens, settings: &OdeSettings) -> Result<OdeReport, OdeError> {
    let mut times = StageTimes::default();
    let clock = std::time::Instant::now();
    let lap = |since: &mut std::time::Instant| {
        let seconds = since.elapsed().as_secs_f64();
        *since = std::time::Instant::now();
        seconds
    };
    let mut since = clock;
    let chief = ChiefRayMap::new(lens)?;
    times.chief_ray_map_s = lap(&mut since);
    let (half_diagonal_mm, pixel_um) = match lens.sensor {
        Some(sensor) => (
            sensor.half_diagonal_mm().min(chief.max_height_mm()),
            sensor.pixel_pitch_um,
        ),
        None => {
            let [w, h] = settings.default_frame_px;
            let half_diagonal_mm = chief.max_height_mm();
            (
                half_diagonal_mm,
                half_diagonal_mm * 1e3 / (0.5 * (w as f64).hypot(h as f64)),
            )
        }
    };
    let mut psf_settings = PsfSettings::new(pixel_um);
    psf_settings.pupil_sampling = PupilSampling::Fibonacci {
        n: settings.rays_per_psf,
    };
    let weights = SpectralWeights::new(
        &SpectralResponse::default_camera(),
        &visible_wavelengths_um(settings.wavelengths),
    );
    let tracer = PsfTracer::new(lens, weights, psf_settings)?;
    let angles: Vec<f64> = settings
        .field_fractions
        .iter()
        .map(|f| chief.angle_for_height(f * half_diagonal_mm))
        .collect();
    // One kernel size for all fields, from the largest spot.
    let traced: Vec<_> = angles
        .par_iter()
        .map(|&angle| {
            let reference = tracer.reference_point_mm(angle)?;
            Ok((reference, tracer.hits(angle, reference)))
        })
        .collect::<Result<Vec<_>, OdeError>>()?;
    let kernel_px = traced
        .iter()
        .map(|(_, hits)| tracer.kernel_size_for(hits))
        .max()
        .unwrap_or(1)
        .min(psf_settings.max_kernel_px);
    let fields: Vec<FieldKernels> = settings
        .field_fractions
        .iter()
        .zip(&angles)
        .zip(&traced)
        .map(|((&fraction, &angle), (reference, hits))| FieldKernels {
            fraction,
            angle_deg: angle,
            kernels: tracer
                .kernels_from_hits(angle, *reference, hits, kernel_px, false)
                .kernels,
        })
        .collect();
    times.psf_tracing_s = lap(&mut since);
    if let Some((dark, _)) = fields
        .iter()
        .zip(&traced)
        .find(|(_, (_, hits))| hits.iter().all(|h| h.offsets_um.is_empty()))
    {
        return Err(OdeError::Vignetted {
            field_fraction: dark.fraction,
            field_deg: dark.angle_deg,
        });
    }
    let (breakdown, table) = score_fields(&fields, settings)?;
    times.imaging_and_scoring_s = lap(&mut since);
    let mean = |f: fn(&FieldChannelScore) -> f64| table.iter().map(f).sum::<f64>() / table.len() as f64;
    let rms_radius_by_field_um = rms_by_field(lens, &angles)?;
    times.rms_spot_s = lap(&mut since);
    Ok(OdeReport {
        ode: breakdown.ode,
        oiq: breakdown.oiq,
        u_s: breakdown.u_s,
        u_c: breakdown.u_c,
        oiqe: mean(|s| s.oiqe),
        psnr_db: mean(|s| s.psnr_db),
        ssim: mean(|s| s.ssim),
        rms_radius_um: rms_radius_by_field_um.iter().sum::<f64>() / rms_radius_by_field_um.len() as f64,
        pixel_um,
        half_diagonal_mm,
        kernel_px,
        table,
        rms_radius_by_field_um,
        times,
    })
}

/// The R, G, B kernels of one evaluated field.
#[derive(Debug, Clone)]
pub struct FieldKernels {
    pub fraction: f64,
    pub angle_deg: f64,
    pub kernels: Vec<Kernel>,
}

/// Scores every field's kernels and combines them into OIQ, U_s, U_c and ODE (the lens-independent
/// half of `evaluate`, usable with any kernels, e.g. an ideal lens's deltas).
pub fn score_fields(
    fields: &[FieldKernels],
    settings: &OdeSettings,
) -> Result<(unicac_metrics::OdeBreakdown, Vec<FieldChannelScore>), OdeError> {
    let table: Vec<FieldChannelScore> = fields
        .par_iter()
        .map(|f| score_field(f.fraction, f.angle_deg, &f.kernels, settings))
        .collect::<Result<Vec<Vec<_>>, OdeError>>()?
        .into_iter()
        .flatten()
        .collect();
    let oiq_grid: Vec<Vec<f64>> = table
        .chunks(3)
        .map(|field| field.iter().map(|s| s.oiq).collect())
        .collect();
    Ok((ode_from_oiq_grid(&oiq_grid, &settings.weights)?, table))
}

/// Images a checkerboard patch (PSNR, SSIM) and two slanted edges (OIQE) through one field's R, G, B
/// kernels and scores each channel.
fn score_field(
    fraction: f64,
    angle: f64,
    kernels: &[Kernel],
    settings: &OdeSettings,
) -> Result<Vec<FieldChannelScore>, OdeError> {
    let k = kernels[0].size;
    let crop = k / 2 + 1;
    // Fixed checkerboard period and evaluated area, so PSNR and SSIM compare across lenses.
    let checker_size = CHECKER_AREA_PX + 2 * crop;
    let chart = charts::checkerboard(
        checker_size,
        checker_size,
        2.0 * settings.square_px as f64,
        settings.contrast,
        settings.slant_deg,
    )?;
    let ideal = encode(&chart)?;
    let options = FullReferenceOptions {
        crop_border: crop,
        ..Default::default()
    };
    // Isolated edges, large enough that the whole blurred edge fits: near-vertical (sagittal MTF, since
    // the field lies on sensor +y) and its transpose, near-horizontal (tangential MTF).
    let edge_size = settings.min_edge_px.max(4 * k);
    let vertical = charts::slanted_edge(edge_size, edge_size, settings.slant_deg, 0.2, 0.8)?;
    let horizontal = transpose(&vertical);
    let roi = Roi {
        x: crop,
        y: crop,
        width: edge_size - 2 * crop,
        height: edge_size - 2 * crop,
    };
    let edge_options = SlantedEdgeOptions::default();
    kernels
        .iter()
        .enumerate()
        .map(|(c, kernel)| {
            let blurred = Planar {
                width: checker_size,
                height: checker_size,
                channels: 1,
                data: convolve_patch(chart.plane(c), checker_size, kernel),
            };
            let encoded = encode(&blurred)?;
            let ideal_plane = single_channel(&ideal, c);
            let p = psnr(&encoded, &ideal_plane, &options)?;
            let s = ssim(&encoded, &ideal_plane, &options)?;
            let edge_mtf = |edge: &Planar, direction: &str| {
                let blurred = Planar {
                    width: edge_size,
                    height: edge_size,
                    channels: 1,
                    data: convolve_patch(edge.plane(c), edge_size, kernel),
                };
                slanted_edge_mtf(&blurred, 0, roi, &edge_options)
                    .map(|m| m.summary())
                    .map_err(|e| OdeError::Edge {
                        field_fraction: fraction,
                        channel: CHANNELS[c],
                        direction: direction.to_string(),
                        kernel_px: k,
                        message: e.to_string(),
                    })
            };
            let sagittal = edge_mtf(&vertical, "sagittal")?;
            let tangential = edge_mtf(&horizontal, "tangential")?;
            let quality = oiqe(&tangential, &sagittal, &settings.oiqe_weights)?;
            Ok(FieldChannelScore {
                field_fraction: fraction,
                field_deg: angle,
                channel: CHANNELS[c],
                psnr_db: p.db,
                ssim: s.mean,
                oiqe: quality,
                oiq: oiq(p.db, s.mean, quality, &settings.weights),
                mtf50_sagittal_cy_per_px: mtf50(&sagittal),
                mtf50_tangential_cy_per_px: mtf50(&tangential),
            })
        })
        .collect()
}

/// Side of the checkerboard area PSNR and SSIM are computed on (after the border crop).
const CHECKER_AREA_PX: usize = 256;

fn transpose(image: &Planar) -> Planar {
    Planar::from_fn(image.height, image.width, image.channels, |c, x, y| {
        image.get(c, y, x)
    })
}

fn mtf50(summary: &MtfSummary) -> f64 {
    summary.mtf50_cy_per_px
}

/// The noise-free sensor chain for scoring: sRGB encoding and 8-bit quantisation (BasicSR scores
/// 8-bit images).
fn encode(linear: &Planar) -> Result<Planar, OdeError> {
    Ok(quantise::quantise(&color::linear_to_srgb(linear), 8)?)
}

fn single_channel(image: &Planar, channel: usize) -> Planar {
    Planar {
        width: image.width,
        height: image.height,
        channels: 1,
        data: image.plane(channel).to_vec(),
    }
}

/// The patch sees one PSF: a spatially invariant convolution (direct or FFT by kernel size).
fn convolve_patch(plane: &[f32], size: usize, kernel: &Kernel) -> Vec<f32> {
    unicac_sim::convolve::convolve_invariant(plane, size, size, kernel)
}

fn rms_by_field(lens: &Lens, angles: &[f64]) -> Result<Vec<f64>, OdeError> {
    let wavelengths = lens.wavelengths_um();
    let all = spots(
        lens,
        angles,
        &wavelengths,
        Aiming::Paraxial,
        &PupilSampling::Hexapolar { rings: 10 },
    )?;
    Ok((0..angles.len())
        .map(|f| {
            let values: Vec<f64> = (0..wavelengths.len())
                .filter_map(|w| all[w * angles.len() + f].rms_radius_um)
                .collect();
            values.iter().sum::<f64>() / values.len().max(1) as f64
        })
        .collect())
}
