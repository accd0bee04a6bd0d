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
    /// Checkerboard square side (px) at least this, and at least 3 kernel widths.
    pub min_square_px: usize,
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
            min_square_px: 48,
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
}

const CHANNELS: [&str; 3] = ["R", "G", "B"];

pub fn evaluate(lens: &Lens, settings: &OdeSettings) -> Result<OdeReport, OdeError> {
    let chief = ChiefRayMap::new(lens)?;
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
    let table: Vec<FieldChannelScore> = settings
        .field_fractions
        .par_iter()
        .zip(&angles)
        .zip(&traced)
        .map(|((&fraction, &angle), (reference, hits))| {
            let psf = tracer.kernels_from_hits(angle, *reference, hits, kernel_px, false);
            score_field(fraction, angle, &psf.kernels, settings)
        })
        .collect::<Result<Vec<Vec<_>>, OdeError>>()?
        .into_iter()
        .flatten()
        .collect();
    let oiq_grid: Vec<Vec<f64>> = table
        .chunks(3)
        .map(|field| field.iter().map(|s| s.oiq).collect())
        .collect();
    let breakdown = ode_from_oiq_grid(&oiq_grid, &settings.weights)?;
    let mean = |f: fn(&FieldChannelScore) -> f64| table.iter().map(f).sum::<f64>() / table.len() as f64;
    let rms_radius_by_field_um = rms_by_field(lens, &angles)?;
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
    })
}

/// Images a checkerboard patch through one field's R, G, B kernels and scores each channel.
fn score_field(
    fraction: f64,
    angle: f64,
    kernels: &[Kernel],
    settings: &OdeSettings,
) -> Result<Vec<FieldChannelScore>, OdeError> {
    let k = kernels[0].size;
    let side = settings.min_square_px.max(3 * k);
    let size = 4 * side;
    let chart = charts::checkerboard(
        size,
        size,
        2.0 * side as f64,
        settings.contrast,
        settings.slant_deg,
    )?;
    let ideal = encode(&chart)?;
    let crop = k / 2 + 1;
    let options = FullReferenceOptions {
        crop_border: crop,
        ..Default::default()
    };
    let (cx, cy) = (size / 2, size / 2);
    let roi_side = 2 * side / 3;
    // The field lies on sensor +y, so image x is sagittal and y tangential; ROIs hold one edge each.
    let sagittal_roi = Roi {
        x: cx - roi_side / 2,
        y: cy + side / 2 - roi_side / 2,
        width: roi_side,
        height: roi_side,
    };
    let tangential_roi = Roi {
        x: cx + side / 2 - roi_side / 2,
        y: cy - roi_side / 2,
        width: roi_side,
        height: roi_side,
    };
    let edge_options = SlantedEdgeOptions::default();
    kernels
        .iter()
        .enumerate()
        .map(|(c, kernel)| {
            let blurred = convolve_patch(chart.plane(c), size, kernel);
            let blurred_plane = Planar {
                width: size,
                height: size,
                channels: 1,
                data: blurred,
            };
            let ideal_plane = single_channel(&ideal, c);
            let encoded = encode(&blurred_plane)?;
            let p = psnr(&encoded, &ideal_plane, &options)?;
            let s = ssim(&encoded, &ideal_plane, &options)?;
            let sagittal = slanted_edge_mtf(&blurred_plane, 0, sagittal_roi, &edge_options)?.summary();
            let tangential = slanted_edge_mtf(&blurred_plane, 0, tangential_roi, &edge_options)?.summary();
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
