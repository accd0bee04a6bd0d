//! ODE of one lens (docs/ode.md).

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use unicac_image::{charts, color, quantise, Planar};
use unicac_metrics::{
    ode_from_oiq_grid, oiq, oiqe, psnr, slanted_edge_mtf, ssim, EdgeMtf, FullReferenceOptions, MtfSummary,
    OdeWeights, OiqeWeights, Roi, SlantedEdgeOptions,
};
use unicac_optics::Lens;
use unicac_psf::{
    visible_wavelengths_um, DarkFields, Kernel, PsfError, PsfSettings, PsfTracer, RayBackend,
    SpectralResponse, SpectralWeights,
};
use unicac_sim::convolve::{convolve_invariant_many, convolve_invariant_many_and_transpose, Borders};
use unicac_sim::ChiefRayMap;
use unicac_trace::{spots_at, Aiming, PupilSampling};

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
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
    #[error("slanted edge at field {field_fraction}, channel {channel}, {direction} (kernel {kernel_px} px): {source}")]
    Edge {
        field_fraction: f64,
        channel: &'static str,
        direction: String,
        kernel_px: usize,
        /// What failed in measuring the edge (kept whole, so its kind survives).
        #[source]
        source: Box<OdeError>,
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
    /// Who traces the PSF rays (CPU or GPU), chosen by the face.
    #[serde(skip)]
    pub backend: RayBackend,
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
            backend: RayBackend::cpu(),
        }
    }
}

/// Azimuths (deg, from sensor +y towards +x) at which a lens that is not rotationally symmetric (a
/// built unit) has every off-axis field graded: +y, +x, -y, -x, as `unicac tolerance` grades them.
/// A symmetric lens is graded on +y only (one azimuth stands for all).
pub const UNIT_AZIMUTHS_DEG: [f64; 4] = [0.0, 90.0, 180.0, 270.0];

/// Scores of one field in one channel.
#[derive(Debug, Clone, Serialize)]
pub struct FieldChannelScore {
    pub field_fraction: f64,
    pub field_deg: f64,
    /// The field's azimuth (deg, from sensor +y towards +x; `UNIT_AZIMUTHS_DEG`): only a built unit's
    /// fields have one (absent when 0).
    #[serde(skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub azimuth_deg: f64,
    pub channel: &'static str,
    pub psnr_db: f64,
    pub ssim: f64,
    pub oiqe: f64,
    pub oiq: f64,
    pub mtf50_sagittal_cy_per_px: f64,
    pub mtf50_tangential_cy_per_px: f64,
}

/// The scores of one lens: the ODE and its parts, the image-quality means behind them and the RMS spot
/// radius. Declared once and flattened (serde) into the ODE report, the dataset's grades and its lens
/// rows, so every file names them alike; `NAMES` is their order there (CSV headers).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct OdeScores {
    pub ode: f64,
    pub oiq: f64,
    pub u_s: f64,
    pub u_c: f64,
    /// Means over the evaluated fields and channels.
    pub oiqe: f64,
    pub psnr_db: f64,
    pub ssim: f64,
    /// Mean RMS spot radius (about the centroid) over the evaluated fields and the lens's wavelengths.
    pub rms_radius_um: f64,
}

impl OdeScores {
    pub const NAMES: [&'static str; 8] = [
        "ode",
        "oiq",
        "u_s",
        "u_c",
        "oiqe",
        "psnr_db",
        "ssim",
        "rms_radius_um",
    ];

    /// The values in `NAMES` order.
    pub fn values(&self) -> [f64; 8] {
        [
            self.ode,
            self.oiq,
            self.u_s,
            self.u_c,
            self.oiqe,
            self.psnr_db,
            self.ssim,
            self.rms_radius_um,
        ]
    }
}

#[derive(Debug, Clone, Serialize)]
pub struct OdeReport {
    #[serde(flatten)]
    pub scores: OdeScores,
    pub pixel_um: f64,
    pub half_diagonal_mm: f64,
    pub kernel_px: usize,
    /// Per field and channel, fields varying slowest.
    pub table: Vec<FieldChannelScore>,
    /// RMS spot radius per field fraction (um; a unit's: the mean over its azimuths).
    pub rms_radius_by_field_um: Vec<f64>,
    /// Where the time went (not part of the result; varies run to run).
    pub times: StageTimes,
}

/// One lens's report under the name it was given (a `builtin:NAME` or a path): an entry of
/// `unicac ode --json`'s `lenses` list and the dict of Python's `unicac.ode`.
#[derive(Debug, Clone, Serialize)]
pub struct LensOde {
    pub lens: String,
    #[serde(flatten)]
    pub report: OdeReport,
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

/// The frame, pixel pitch and PSF tracer the ODE fields are measured with (docs/ode.md).
pub struct EvaluationSetup {
    /// The lens's chief-ray map, or its centred twin's (`Lens::nominal`) for a built unit: the field
    /// angle of each image height, so a unit is graded at its design's fields.
    pub chief: ChiefRayMap,
    pub half_diagonal_mm: f64,
    pub pixel_um: f64,
    /// The azimuths every off-axis field is graded at: [0] for a symmetric lens, `UNIT_AZIMUTHS_DEG`
    /// for a unit.
    pub azimuths_deg: Vec<f64>,
    tracer: PsfTracer,
}

impl EvaluationSetup {
    pub fn new(lens: &Lens, settings: &OdeSettings) -> Result<EvaluationSetup, OdeError> {
        let (chief, azimuths_deg) = if lens.is_rotationally_symmetric() {
            (ChiefRayMap::new(lens)?, vec![0.0])
        } else {
            (ChiefRayMap::new(&lens.nominal())?, UNIT_AZIMUTHS_DEG.to_vec())
        };
        let (half_diagonal_mm, pixel_um) = match lens.sensor {
            Some(sensor) => (
                sensor.half_diagonal_mm().min(chief.max_height_mm()),
                sensor.pixel_um,
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
        let mut psf_settings = PsfSettings::new(pixel_um).with_backend(settings.backend.clone());
        psf_settings.pupil_sampling = PupilSampling::Fibonacci {
            n: settings.rays_per_psf,
        };
        let weights = SpectralWeights::new(
            &SpectralResponse::default_camera(),
            &visible_wavelengths_um(settings.wavelengths),
        );
        let tracer = PsfTracer::new(lens, weights, psf_settings)?;
        Ok(EvaluationSetup {
            chief,
            half_diagonal_mm,
            pixel_um,
            azimuths_deg,
            tracer,
        })
    }

    /// The graded fields: (fraction, azimuth deg, [x, y] field angles deg), fractions varying slowest;
    /// the axis once.
    fn fields(&self, fractions: &[f64]) -> Vec<(f64, f64, [f64; 2])> {
        fractions
            .iter()
            .flat_map(|&fraction| {
                let angle = self.chief.angle_for_height(fraction * self.half_diagonal_mm);
                let azimuths = if fraction == 0.0 {
                    &self.azimuths_deg[..1]
                } else {
                    &self.azimuths_deg[..]
                };
                azimuths.iter().map(move |&azimuth: &f64| {
                    let tan = angle.to_radians().tan();
                    let (sin, cos) = azimuth.to_radians().sin_cos();
                    let field = if azimuth == 0.0 {
                        [0.0, angle]
                    } else {
                        [(tan * sin).atan().to_degrees(), (tan * cos).atan().to_degrees()]
                    };
                    (fraction, azimuth, field)
                })
            })
            .collect()
    }

    /// R, G, B kernels at the given normalised image heights, one common size from the largest spot;
    /// a unit's at each of `azimuths_deg`, turned so that every field lies on +y (the sagittal and
    /// tangential edges then mean what they mean on a symmetric lens's +y fields).
    pub fn field_kernels(&self, fractions: &[f64]) -> Result<Vec<FieldKernels>, OdeError> {
        let fields = self.fields(fractions);
        let angles: Vec<[f64; 2]> = fields.iter().map(|f| f.2).collect();
        let set = self
            .tracer
            .common_size_psfs_at(&angles, false, DarkFields::Refused)
            .map_err(|error| match error {
                PsfError::FieldVignetted { field_deg, .. } => OdeError::Vignetted {
                    field_fraction: (fields.iter())
                        .find(|f| f.2[1] == field_deg)
                        .map_or(f64::NAN, |f| f.0),
                    field_deg,
                },
                other => other.into(),
            })?;
        Ok(fields
            .iter()
            .zip(set.psfs)
            .map(|(&(fraction, azimuth_deg, _), psf)| FieldKernels {
                fraction,
                angle_deg: self.chief.angle_for_height(fraction * self.half_diagonal_mm),
                azimuth_deg,
                // Azimuths are whole quarter turns: turned back to +y exactly (none on +y).
                kernels: match azimuth_deg {
                    0.0 => psf.kernels,
                    _ => (psf.kernels.iter())
                        .map(|k| k.quarter_turned(-((azimuth_deg / 90.0).round() as i32)))
                        .collect(),
                },
            })
            .collect())
    }
}

pub fn evaluate(lens: &Lens, settings: &OdeSettings) -> Result<OdeReport, OdeError> {
    let mut times = StageTimes::default();
    let lap = |since: &mut std::time::Instant| {
        let seconds = since.elapsed().as_secs_f64();
        *since = std::time::Instant::now();
        seconds
    };
    let mut since = std::time::Instant::now();
    let setup = EvaluationSetup::new(lens, settings)?;
    times.chief_ray_map_s = lap(&mut since);
    let fields = setup.field_kernels(&settings.field_fractions)?;
    let kernel_px = fields[0].kernels[0].size;
    let (half_diagonal_mm, pixel_um) = (setup.half_diagonal_mm, setup.pixel_um);
    times.psf_tracing_s = lap(&mut since);
    let (breakdown, table) = score_fields(&fields, settings)?;
    times.imaging_and_scoring_s = lap(&mut since);
    let mean = |f: fn(&FieldChannelScore) -> f64| table.iter().map(f).sum::<f64>() / table.len() as f64;
    let rms_radius_by_field_um = rms_by_field(lens, &setup, &settings.field_fractions)?;
    times.rms_spot_s = lap(&mut since);
    Ok(OdeReport {
        scores: OdeScores {
            ode: breakdown.ode,
            oiq: breakdown.oiq,
            u_s: breakdown.u_s,
            u_c: breakdown.u_c,
            oiqe: mean(|s| s.oiqe),
            psnr_db: mean(|s| s.psnr_db),
            ssim: mean(|s| s.ssim),
            rms_radius_um: rms_radius_by_field_um.iter().sum::<f64>() / rms_radius_by_field_um.len() as f64,
        },
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
    /// 0 but for a built unit's fields (`UNIT_AZIMUTHS_DEG`); the kernels are then turned to +y.
    pub azimuth_deg: f64,
    pub kernels: Vec<Kernel>,
}

/// Scores every field's kernels and combines them into OIQ, U_s, U_c and ODE (the lens-independent
/// half of `evaluate`, usable with any kernels, e.g. an ideal lens's deltas).
pub fn score_fields(
    fields: &[FieldKernels],
    settings: &OdeSettings,
) -> Result<(unicac_metrics::OdeBreakdown, Vec<FieldChannelScore>), OdeError> {
    // One task per field and channel. The kernels of one size share their ideal charts (which cost as
    // much to draw as a patch costs to score) and each chart's transform (`convolve_invariant_many`).
    let tasks: Vec<(&FieldKernels, usize)> = fields
        .iter()
        .flat_map(|f| (0..f.kernels.len()).map(move |c| (f, c)))
        .collect();
    let mut sizes: Vec<usize> = tasks.iter().map(|(f, c)| f.kernels[*c].size).collect();
    sizes.sort_unstable();
    sizes.dedup();
    let mut table: Vec<Option<FieldChannelScore>> = vec![None; tasks.len()];
    for size in sizes {
        let ideal = IdealCharts::new(size, settings)?;
        let members: Vec<usize> = (0..tasks.len())
            .filter(|&i| tasks[i].0.kernels[tasks[i].1].size == size)
            .collect();
        let kernels: Vec<&Kernel> = members.iter().map(|&i| &tasks[i].0.kernels[tasks[i].1]).collect();
        let imaged = ideal.image(&kernels);
        let scores: Vec<FieldChannelScore> = members
            .par_iter()
            .zip(imaged.into_par_iter())
            .map(|(&i, imaged)| {
                let (f, c) = tasks[i];
                score_channel(f, c, &f.kernels[c], &ideal, imaged, settings)
            })
            .collect::<Result<_, OdeError>>()?;
        for (i, score) in members.into_iter().zip(scores) {
            table[i] = Some(score);
        }
    }
    let table: Vec<FieldChannelScore> = table.into_iter().map(|s| s.expect("every task scored")).collect();
    // One row per field fraction: a unit's azimuths averaged (each a share of the fraction's weight).
    // Every fraction's fields start at azimuth 0.
    let by_field: Vec<&[FieldChannelScore]> = table.chunks(3).collect();
    let oiq_grid: Vec<Vec<f64>> = by_field
        .chunk_by(|_, next| next[0].azimuth_deg != 0.0)
        .map(|azimuths| {
            (0..3)
                .map(|c| azimuths.iter().map(|field| field[c].oiq).sum::<f64>() / azimuths.len() as f64)
                .collect()
        })
        .collect();
    Ok((ode_from_oiq_grid(&oiq_grid, &settings.weights)?, table))
}

/// The ideal charts a kernel of `kernel_px` is scored with: the grey checkerboard (linear, one plane, and
/// encoded) and the two slanted edges. They depend on the kernel size and the settings only.
struct IdealCharts {
    checker_side: usize,
    checker: Vec<f32>,
    checker_encoded: Planar,
    edges: [Planar; 2],
}

/// One kernel's charts imaged through it: the checkerboard and the [sagittal, tangential] edges.
struct ImagedCharts {
    checker: Vec<f32>,
    edges: [Vec<f32>; 2],
}

impl IdealCharts {
    fn new(kernel_px: usize, settings: &OdeSettings) -> Result<IdealCharts, OdeError> {
        let crop = kernel_px / 2 + 1;
        // Fixed checkerboard period and evaluated area, so PSNR and SSIM compare across lenses.
        let checker_side = CHECKER_AREA_PX + 2 * crop;
        let checker = charts::checkerboard(
            checker_side,
            checker_side,
            2.0 * settings.square_px as f64,
            settings.contrast,
            settings.slant_deg,
        )?;
        let checker_encoded = encode(&checker)?;
        // The chart is grey (equal planes), so every channel's kernel blurs the same plane.
        let checker = checker.plane(0).to_vec();
        let edges = ideal_edges(kernel_px, settings).map_err(|(_, e)| e)?;
        Ok(IdealCharts {
            checker_side,
            checker,
            checker_encoded,
            edges,
        })
    }

    /// The charts imaged through each of `kernels` (all of this chart set's size), in their order.
    fn image(&self, kernels: &[&Kernel]) -> Vec<ImagedCharts> {
        let side = self.checker_side;
        // Only the interior is scored (the border crop and the edge ROI keep `kernel_px / 2 + 1` px from
        // every side), so the border pixels are not computed.
        let checker = convolve_invariant_many(&self.checker, side, side, kernels, Borders::Interior);
        // The tangential edge is the sagittal one transposed (`ideal_edges`): both from one transform.
        let sagittal = &self.edges[0];
        let edges = convolve_invariant_many_and_transpose(
            sagittal.plane(0),
            sagittal.width,
            kernels,
            Borders::Interior,
        );
        checker
            .into_iter()
            .zip(edges)
            .map(|(checker, edges)| ImagedCharts { checker, edges })
            .collect()
    }
}

/// Scores channel `c`'s kernel of one field from its imaged charts: the checkerboard patch (PSNR, SSIM)
/// and the two slanted edges (OIQE).
fn score_channel(
    field: &FieldKernels,
    c: usize,
    kernel: &Kernel,
    ideal: &IdealCharts,
    imaged: ImagedCharts,
    settings: &OdeSettings,
) -> Result<FieldChannelScore, OdeError> {
    let k = kernel.size;
    let crop = k / 2 + 1;
    let options = FullReferenceOptions {
        crop_border: crop,
        ..Default::default()
    };
    let blurred = Planar {
        width: ideal.checker_side,
        height: ideal.checker_side,
        channels: 1,
        data: imaged.checker,
    };
    let encoded = encode(&blurred)?;
    let ideal_plane = single_channel(&ideal.checker_encoded, c);
    let p = psnr(&encoded, &ideal_plane, &options)?;
    let s = ssim(&encoded, &ideal_plane, &options)?;
    let [sagittal_edge, tangential_edge] = imaged.edges;
    let measured = |i: usize, data: Vec<f32>| {
        let side = ideal.edges[i].width;
        let blurred = Planar {
            width: side,
            height: side,
            channels: 1,
            data,
        };
        measure_edge(&blurred, edge_roi(k, side), i)
    };
    let edges = measured(0, sagittal_edge)
        .and_then(|s| Ok([s, measured(1, tangential_edge)?]))
        .map_err(|(direction, e)| OdeError::Edge {
            field_fraction: field.fraction,
            channel: CHANNELS[c],
            direction: direction.to_string(),
            kernel_px: k,
            source: Box::new(e),
        })?;
    let (sagittal, tangential) = (edges[0].summary(), edges[1].summary());
    let quality = oiqe(&tangential, &sagittal, &settings.oiqe_weights)?;
    Ok(FieldChannelScore {
        field_fraction: field.fraction,
        field_deg: field.angle_deg,
        azimuth_deg: field.azimuth_deg,
        channel: CHANNELS[c],
        psnr_db: p.db,
        ssim: s.mean,
        oiqe: quality,
        oiq: oiq(p.db, s.mean, quality, &settings.weights),
        mtf50_sagittal_cy_per_px: mtf50(&sagittal),
        mtf50_tangential_cy_per_px: mtf50(&tangential),
    })
}

/// One slanted-edge patch of the ODE: the ideal (pixel-integrated) edge chart and the chart imaged
/// through a kernel, single-channel linear light, with the region the MTF is measured on.
#[derive(Debug, Clone)]
pub struct EdgePatch {
    /// "sagittal" (near-vertical edge) or "tangential" (its transpose).
    pub direction: &'static str,
    pub ideal: Planar,
    pub blurred: Planar,
    pub roi: Roi,
}

/// The two slanted-edge patches of one kernel ([sagittal, tangential]), each an isolated edge of
/// max(`min_edge_px`, 4 kernel widths) so the whole blurred edge fits; what `edge_mtfs` measures and
/// what `unicac dataset` stores as the benchmark's edge pairs.
pub fn edge_patches(
    kernel: &Kernel,
    settings: &OdeSettings,
) -> Result<[EdgePatch; 2], (&'static str, OdeError)> {
    let [sagittal, tangential] = ideal_edges(kernel.size, settings)?;
    let patch = |ideal: Planar, direction: &'static str| {
        let (blurred, roi) = image_edge(kernel, &ideal);
        EdgePatch {
            direction,
            ideal,
            blurred,
            roi,
        }
    };
    Ok([
        patch(sagittal, EDGE_DIRECTIONS[0]),
        patch(tangential, EDGE_DIRECTIONS[1]),
    ])
}

/// The edges' names, in the order of `ideal_edges`.
const EDGE_DIRECTIONS: [&str; 2] = ["sagittal", "tangential"];

/// The ideal [sagittal, tangential] edge charts for kernels of `kernel_px`: an isolated edge of
/// max(`min_edge_px`, 4 kernel widths) and its transpose.
fn ideal_edges(kernel_px: usize, settings: &OdeSettings) -> Result<[Planar; 2], (&'static str, OdeError)> {
    let edge_size = settings.min_edge_px.max(4 * kernel_px);
    let vertical = charts::slanted_edge(edge_size, edge_size, settings.slant_deg, 0.2, 0.8)
        .map_err(|e| (EDGE_DIRECTIONS[0], e.into()))?;
    let horizontal = transpose(&vertical);
    Ok([vertical, horizontal])
}

/// An ideal edge imaged through `kernel`, and the region its MTF is measured on.
fn image_edge(kernel: &Kernel, ideal: &Planar) -> (Planar, Roi) {
    let edge_size = ideal.width;
    let blurred = Planar {
        width: edge_size,
        height: edge_size,
        channels: 1,
        data: convolve_patch(ideal.plane(0), edge_size, kernel),
    };
    (blurred, edge_roi(kernel.size, edge_size))
}

/// The region of an `edge_size` edge patch whose MTF is measured: the reach of a `kernel_px` kernel
/// cropped from every side.
fn edge_roi(kernel_px: usize, edge_size: usize) -> Roi {
    let crop = kernel_px / 2 + 1;
    Roi {
        x: crop,
        y: crop,
        width: edge_size - 2 * crop,
        height: edge_size - 2 * crop,
    }
}

/// Slanted-edge MTFs of one kernel: [sagittal (near-vertical edge), tangential (its transpose)], measured
/// on the patches of `edge_patches`.
pub fn edge_mtfs(kernel: &Kernel, settings: &OdeSettings) -> Result<[EdgeMtf; 2], (&'static str, OdeError)> {
    let ideal = ideal_edges(kernel.size, settings)?;
    let measure = |i: usize| {
        let (blurred, roi) = image_edge(kernel, &ideal[i]);
        measure_edge(&blurred, roi, i)
    };
    Ok([measure(0)?, measure(1)?])
}

/// The MTF of blurred edge `i` (0 sagittal, 1 tangential) over `roi`.
fn measure_edge(blurred: &Planar, roi: Roi, i: usize) -> Result<EdgeMtf, (&'static str, OdeError)> {
    slanted_edge_mtf(blurred, 0, roi, &SlantedEdgeOptions::default())
        .map_err(|e| (EDGE_DIRECTIONS[i], e.into()))
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

fn rms_by_field(lens: &Lens, setup: &EvaluationSetup, fractions: &[f64]) -> Result<Vec<f64>, OdeError> {
    let fields = setup.fields(fractions);
    let angles: Vec<[f64; 2]> = fields.iter().map(|f| f.2).collect();
    let wavelengths = lens.wavelengths_um();
    let all = spots_at(
        lens,
        &angles,
        &wavelengths,
        Aiming::Auto,
        &PupilSampling::Hexapolar { rings: 10 },
    )?;
    // (azimuth, RMS) per field.
    let by_field: Vec<(f64, f64)> = (0..angles.len())
        .map(|f| {
            let values: Vec<f64> = (0..wavelengths.len())
                .filter_map(|w| all[w * angles.len() + f].rms_radius_um)
                .collect();
            (
                fields[f].1,
                values.iter().sum::<f64>() / values.len().max(1) as f64,
            )
        })
        .collect();
    // A unit's azimuths of one fraction averaged (every fraction's fields start at azimuth 0).
    Ok(by_field
        .chunk_by(|_, next| next.0 != 0.0)
        .map(|group| group.iter().map(|g| g.1).sum::<f64>() / group.len() as f64)
        .collect())
}

/// MTF of a lens at one field and channel, in one direction, measured two ways.
#[derive(Debug, Clone, Serialize)]
pub struct LensMtf {
    pub field_fraction: f64,
    pub field_deg: f64,
    pub channel: &'static str,
    /// "sagittal" or "tangential".
    pub direction: &'static str,
    pub frequency_cy_per_px: Vec<f64>,
    /// Slanted-edge MTF of the edge imaged through the kernel (what ODE's OIQE uses).
    pub edge_mtf: Vec<f64>,
    /// MTF computed directly from the pixel-integrated kernel (projection-slice theorem), times the
    /// pixel aperture of the rendered (pixel-integrated) edge chart, so both curves describe the same
    /// chain: chart pixels, then lens-and-pixel kernel.
    pub exact_mtf: Vec<f64>,
}

/// Slanted-edge and exact MTFs at the ODE fields, every channel and both directions.
pub fn lens_mtf(lens: &Lens, settings: &OdeSettings) -> Result<Vec<LensMtf>, OdeError> {
    let setup = EvaluationSetup::new(lens, settings)?;
    let fields = setup.field_kernels(&settings.field_fractions)?;
    let mut curves = Vec::new();
    for field in &fields {
        for (c, kernel) in field.kernels.iter().enumerate() {
            let edges = edge_mtfs(kernel, settings).map_err(|(_, e)| e)?;
            let samples: Vec<f64> = kernel.data.iter().map(|&v| v as f64).collect();
            let psf = unicac_metrics::PsfSamples {
                data: &samples,
                width: kernel.size,
                height: kernel.size,
                sample_pitch: 1.0,
            };
            // Sagittal: along image x; tangential: along image y (the field lies on sensor +y).
            for (edge, direction, angle) in [
                (&edges[0], "sagittal", 0.0),
                (&edges[1], "tangential", std::f64::consts::FRAC_PI_2),
            ] {
                curves.push(LensMtf {
                    field_fraction: field.fraction,
                    field_deg: field.angle_deg,
                    channel: CHANNELS[c],
                    direction,
                    exact_mtf: unicac_metrics::psf_mtf(psf, angle, &edge.frequency_cy_per_px)?
                        .iter()
                        .zip(&edge.frequency_cy_per_px)
                        .map(|(m, &f)| {
                            m * unicac_metrics::mtf::pixel_aperture_mtf(f, settings.slant_deg.to_radians())
                        })
                        .collect(),
                    frequency_cy_per_px: edge.frequency_cy_per_px.clone(),
                    edge_mtf: edge.mtf.clone(),
                });
            }
        }
    }
    Ok(curves)
}
