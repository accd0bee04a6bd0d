//! The image-plane optics of a lens that is not rotationally symmetric (decentred or tilted surfaces:
//! a unit as built, docs/tolerancing.md). One field radius turned into place cannot stand for such a
//! lens, so what the radial path reads off one radius (`chief`, `psf_map`, `radial_table`) is sampled
//! over the whole image plane here:
//!
//! - **the warp**: the real landing point of the chief ray (primary wavelength, aimed at the stop
//!   centre) on a fine lattice of ideal positions, interpolated bilinearly (linearly extrapolated
//!   beyond the frame) and inverted per output pixel by fixed-point iteration on the smooth
//!   displacement;
//! - **the shading**: the relative illumination from the Jacobian of that landing map (for fields
//!   (u, v) = (tan x, tan y): E / E(0) = |det J(0)| / ((1 + u^2 + v^2)^2 |det J(u, v)|), which is
//!   `ChiefRayMap::illumination_factor`'s cos F sin F h'(0)^2 / (h h') for a symmetric lens and cos^4 F
//!   for h = f tan F), times the PSF fields' vignetting, normalised by its peak;
//! - **the PSFs**: a lattice of fields over the frame traced at their own (x, y) angles
//!   (`PsfTracer::trace_fields_at`), blended bilinearly at each kernel node. Not turned: a unit's
//!   PSF carries parts fixed on the sensor (what the build adds) beside the parts that turn with the
//!   azimuth. A polar lattice whose samples were turned to each node's azimuth was tried and lost at
//!   equal fields on a decentred phone lens (docs/tolerancing.md, the sweep).
//!
//! A field's ideal position is where a distortion-free lens images it, `paraxial_height_per_tan * (tan
//! x, tan y)` (the field convention of `Aimer::ray_at`); fields beyond the lens's largest field are
//! taken at it, on the same azimuth (as the radial path clamps its radius). Symmetric lenses never come
//! here: they keep the radial path and its bytes.

use crate::chief::ChiefRayMap;
use crate::error::{SimError, SimResult};
use crate::geometry::SensorGrid;
use rayon::prelude::*;
use unicac_optics::Lens;
use unicac_psf::{DarkFields, FieldPsf, Kernel, PsfTracer};
use unicac_trace::{Aimer, Aiming, Clipping, TraceSystem};

/// Chief-ray lattice spacing (pixels) for large frames; the node count per side stays within
/// `CHIEF_NODES_PER_SIDE`. The landing map's bilinear interpolation error is checked in the tests.
pub const CHIEF_STEP_PX: f64 = 16.0;
/// Fewest and most chief-ray lattice nodes along one side of the frame.
pub const CHIEF_NODES_PER_SIDE: (usize, usize) = (33, 129);
/// Default PSF lattice intervals along the frame's longer side (17 x 13 = 221 traced fields for a 4:3
/// frame, against the radial path's 17): the sweep's ~57 dB, near 8-bit quantisation (59 dB), as the
/// radial defaults (docs/tolerancing.md).
pub const DEFAULT_PLANAR_PSF_INTERVALS: usize = 16;
/// Most PSF lattice intervals along the longer side (the PSFs are traced per lattice node).
pub const MAX_PLANAR_PSF_INTERVALS: usize = 64;
/// The warp's inversion stops when the landing point is this close to the output pixel (pixels).
pub const INVERSE_TOLERANCE_PX: f64 = 1e-6;
/// Fixed-point steps allowed per output pixel (a smooth map converges in a few; the warm start from
/// the previous pixel usually in one or two).
const MAX_INVERSE_STEPS: usize = 64;
/// Step in (tan x, tan y) of the one-sided differences that give the landing map's Jacobian.
const JACOBIAN_STEP_TAN: f64 = 1e-5;

/// Nodes at pixel positions `i * step` along each axis of the frame, from pixel 0 to the last pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Lattice {
    nodes: [usize; 2],
    step_px: [f64; 2],
}

impl Lattice {
    /// `nodes` per side over a `width` x `height` frame.
    fn new(grid: &SensorGrid, nodes: [usize; 2]) -> Lattice {
        let span = [grid.width_px as f64 - 1.0, grid.height_px as f64 - 1.0];
        Lattice {
            nodes,
            step_px: [span[0] / (nodes[0] - 1) as f64, span[1] / (nodes[1] - 1) as f64],
        }
    }

    fn count(&self) -> usize {
        self.nodes[0] * self.nodes[1]
    }

    /// Frame pixel position of node `index` (rows of nodes first).
    fn position(&self, index: usize) -> [f64; 2] {
        let (i, j) = (index % self.nodes[0], index / self.nodes[0]);
        [i as f64 * self.step_px[0], j as f64 * self.step_px[1]]
    }

    /// The cell holding `x` on `axis` (clamped to the lattice) and the coordinate within it (0 .. 1
    /// inside; beyond that outside the lattice, which extrapolates the edge cell linearly).
    fn locate(&self, axis: usize, x: f64) -> (usize, f64) {
        let position = x / self.step_px[axis];
        let cell = (position.max(0.0) as usize).min(self.nodes[axis] - 2);
        (cell, position - cell as f64)
    }

    /// The four nodes around `p` with their bilinear weights; `clamp` keeps the weights in 0 .. 1 (no
    /// extrapolation).
    fn weights(&self, p: [f64; 2], clamp: bool) -> [(usize, f64); 4] {
        let (i, mut tx) = self.locate(0, p[0]);
        let (j, mut ty) = self.locate(1, p[1]);
        if clamp {
            (tx, ty) = (tx.clamp(0.0, 1.0), ty.clamp(0.0, 1.0));
        }
        let at = |di: usize, dj: usize| (j + dj) * self.nodes[0] + i + di;
        [
            (at(0, 0), (1.0 - tx) * (1.0 - ty)),
            (at(1, 0), tx * (1.0 - ty)),
            (at(0, 1), (1.0 - tx) * ty),
            (at(1, 1), tx * ty),
        ]
    }

    /// Bilinear interpolation of per-node values at `p`.
    fn interpolate<const N: usize>(&self, values: &[[f64; N]], p: [f64; 2], clamp: bool) -> [f64; N] {
        let mut out = [0.0; N];
        for (node, weight) in self.weights(p, clamp) {
            for (o, v) in out.iter_mut().zip(&values[node]) {
                *o += weight * v;
            }
        }
        out
    }
}

/// Nodes along each side for a lattice of `intervals` along the longer side (the shorter side in
/// proportion, at least one interval).
fn nodes_for(grid: &SensorGrid, intervals: usize) -> [usize; 2] {
    let longer = grid.width_px.max(grid.height_px) as f64;
    let along = |length: usize| ((intervals as f64 * length as f64 / longer).ceil() as usize).max(1) + 1;
    [along(grid.width_px), along(grid.height_px)]
}

/// The field (x, y angles, deg) whose ideal image is at sensor point (x, y) mm, taken at the lens's
/// largest field on the same azimuth when it lies beyond it; and its (tan x, tan y).
fn field_at([x_mm, y_mm]: [f64; 2], chief: &ChiefRayMap) -> ([f64; 2], [f64; 2]) {
    let per_tan = chief.paraxial_height_per_tan_mm();
    let mut tan = [x_mm / per_tan, y_mm / per_tan];
    let largest = chief.max_angle_deg().to_radians().tan();
    let length = tan[0].hypot(tan[1]);
    if length > largest {
        tan = tan.map(|t| t * largest / length);
    }
    (tan.map(|t| t.atan().to_degrees()), tan)
}

/// The image-plane maps of one lens on one sensor grid (see the module docs).
#[derive(Debug, Clone)]
pub struct PlanarField {
    grid: SensorGrid,
    chief_lattice: Lattice,
    /// Frame pixel where each chief-lattice node's field lands.
    landing_px: Vec<[f64; 2]>,
    /// Relative illumination times vignetting (normalised by the peak transmission) per chief node.
    shading: Vec<[f64; 1]>,
    /// Ideal radius (pixels from the frame centre) of the lens's largest field: beyond it `field_at`
    /// takes every field at the largest, so the landing map is flat there and cannot be inverted.
    field_radius_px: f64,
    psf_lattice: Lattice,
    /// The PSF of each PSF-lattice node's field (rows of nodes first), all of `kernel_size` px.
    pub psfs: Vec<FieldPsf>,
    pub kernel_size: usize,
    /// Kernel size the spots asked for before the cap.
    pub requested_kernel_size: usize,
}

impl PlanarField {
    /// Traces the maps of `lens` over `grid`. `chief` is the centred twin's chief-ray map (the ideal
    /// scale and the largest field); `psf_intervals` the PSF lattice's intervals along the longer side.
    pub fn trace(
        lens: &Lens,
        tracer: &PsfTracer,
        chief: &ChiefRayMap,
        grid: SensorGrid,
        psf_intervals: usize,
    ) -> SimResult<PlanarField> {
        if chief.paraxial_height_per_tan_mm() <= 0.0 {
            return Err(SimError::Unsupported(
                "the lens has no paraxial image scale to place fields by".into(),
            ));
        }
        if !(1..=MAX_PLANAR_PSF_INTERVALS).contains(&psf_intervals) {
            return Err(unicac_trace::InvalidParameter::new(
                "planar_psf_intervals",
                format!("{psf_intervals}: takes 1 to {MAX_PLANAR_PSF_INTERVALS}"),
            )
            .into());
        }
        let psf_lattice = Lattice::new(&grid, nodes_for(&grid, psf_intervals));
        let fields: Vec<[f64; 2]> = (0..psf_lattice.count())
            .map(|n| {
                let [x, y] = psf_lattice.position(n);
                field_at(grid.to_mm(x, y), chief).0
            })
            .collect();
        let traced = tracer.trace_fields_at(&fields)?;
        let set = tracer.rasterise_common_size(&traced, false, DarkFields::AllowedIfAnyLit)?;
        let chief_nodes = |length: usize| {
            let (fewest, most) = CHIEF_NODES_PER_SIDE;
            (((length - 1) as f64 / CHIEF_STEP_PX).ceil() as usize + 1).clamp(fewest, most)
        };
        let chief_lattice = Lattice::new(&grid, [chief_nodes(grid.width_px), chief_nodes(grid.height_px)]);
        let landing = ChiefLanding::new(lens, &grid)?;
        let (_, axis_det) = landing.landing_and_det([0.0, 0.0])?;
        let peak = set
            .psfs
            .iter()
            .map(|p| p.transmission)
            .fold(0.0, f64::max)
            .max(1e-12);
        let transmission: Vec<[f64; 1]> = set.psfs.iter().map(|p| [p.transmission]).collect();
        let nodes: Vec<([f64; 2], [f64; 1])> = (0..chief_lattice.count())
            .into_par_iter()
            .map(|n| {
                let p = chief_lattice.position(n);
                let (_, tan) = field_at(grid.to_mm(p[0], p[1]), chief);
                let (landing_px, det) = landing.landing_and_det(tan)?;
                if det.signum() != axis_det.signum() {
                    return Err(SimError::Unsupported(format!(
                        "the chief-ray map folds over at field tan ({:.4}, {:.4}); the field cannot be mapped",
                        tan[0], tan[1]
                    )));
                }
                let obliquity = 1.0 + tan[0] * tan[0] + tan[1] * tan[1];
                let vignetting = psf_lattice.interpolate(&transmission, p, true)[0] / peak;
                Ok((landing_px, [axis_det / (obliquity * obliquity * det) * vignetting]))
            })
            .collect::<SimResult<_>>()?;
        let (landing_px, shading) = nodes.into_iter().unzip();
        let largest_tan = chief.max_angle_deg().to_radians().tan();
        Ok(PlanarField {
            grid,
            chief_lattice,
            landing_px,
            shading,
            field_radius_px: largest_tan * chief.paraxial_height_per_tan_mm() / (grid.pitch_um * 1e-3),
            psf_lattice,
            psfs: set.psfs,
            kernel_size: set.kernel_px,
            requested_kernel_size: set.requested_kernel_px,
        })
    }

    /// Frame pixel where the chief ray of the field ideally imaged at `ideal_px` lands.
    pub fn landing_px(&self, ideal_px: [f64; 2]) -> [f64; 2] {
        self.chief_lattice.interpolate(&self.landing_px, ideal_px, false)
    }

    /// The ideal position (frame pixels) whose field lands at `real_px`, by fixed-point iteration
    /// q <- q + (real - landing(q)) from `start` (the previous pixel's answer is a good one); within
    /// `INVERSE_TOLERANCE_PX` of it in landing. Each step is kept within the lens's largest field:
    /// a pixel that no field of the unit reaches (a corner beyond its image of the largest field) takes
    /// the field's edge, as the radial path clamps its radius, where the unclamped iteration ran off
    /// along the flat map's extrapolation (to NaN at a tolerance draw's frame corner).
    pub fn ideal_for(&self, real_px: [f64; 2], start: [f64; 2]) -> [f64; 2] {
        let mut q = self.within_field(start);
        for _ in 0..MAX_INVERSE_STEPS {
            let landing = self.landing_px(q);
            let miss = [real_px[0] - landing[0], real_px[1] - landing[1]];
            q = self.within_field([q[0] + miss[0], q[1] + miss[1]]);
            if miss[0].abs().max(miss[1].abs()) <= INVERSE_TOLERANCE_PX {
                break;
            }
        }
        q
    }

    /// `ideal_px`, or the point of the largest field's circle on its azimuth when it lies beyond.
    fn within_field(&self, ideal_px: [f64; 2]) -> [f64; 2] {
        let [cx, cy] = self.grid.centre_px();
        let (dx, dy) = (ideal_px[0] - cx, ideal_px[1] - cy);
        let radius = dx.hypot(dy);
        if radius <= self.field_radius_px {
            return ideal_px;
        }
        let scale = self.field_radius_px / radius;
        [cx + dx * scale, cy + dy * scale]
    }

    /// Relative illumination times vignetting of the field ideally imaged at `ideal_px`.
    pub fn shading_at(&self, ideal_px: [f64; 2]) -> f64 {
        self.chief_lattice.interpolate(&self.shading, ideal_px, true)[0]
    }

    /// The PSF of `channel` for the field ideally imaged at `ideal_px`: the four PSF-lattice kernels
    /// around it, weighted bilinearly (clamped to the frame's lattice).
    pub fn kernel_at_ideal(&self, ideal_px: [f64; 2], channel: usize) -> Kernel {
        let pitch_um = self.psfs[0].kernels[channel].pitch_um;
        let mut kernel = Kernel::zeros(self.kernel_size, pitch_um);
        for (node, weight) in self.psf_lattice.weights(ideal_px, true) {
            if weight > 0.0 {
                kernel.add_scaled(&self.psfs[node].kernels[channel], weight as f32);
            }
        }
        kernel
    }

    /// Field angles (x, y deg) of the field ideally imaged at `ideal_px` (at most the largest field).
    pub fn field_deg_at(&self, chief: &ChiefRayMap, ideal_px: [f64; 2]) -> [f64; 2] {
        field_at(self.grid.to_mm(ideal_px[0], ideal_px[1]), chief).0
    }

    /// The largest distance (pixels) between an output pixel and the ideal position it samples, over
    /// the chief lattice: how far the warp reaches.
    pub fn largest_shift_px(&self) -> f64 {
        (0..self.chief_lattice.count())
            .map(|n| {
                let [x, y] = self.chief_lattice.position(n);
                let [u, v] = self.landing_px[n];
                (u - x).hypot(v - y)
            })
            .fold(0.0, f64::max)
    }
}

/// The chief ray of any field on the frame: where it lands (frame pixels) and the Jacobian of that
/// landing point over (tan x, tan y).
struct ChiefLanding<'a> {
    grid: &'a SensorGrid,
    system: TraceSystem,
    aimer: Aimer,
}

impl<'a> ChiefLanding<'a> {
    fn new(lens: &Lens, grid: &'a SensorGrid) -> SimResult<ChiefLanding<'a>> {
        let wavelength = lens.primary_wavelength_um();
        Ok(ChiefLanding {
            grid,
            system: TraceSystem::new(lens, wavelength, Clipping::None)?,
            aimer: Aimer::new(lens, wavelength, Aiming::Real)?,
        })
    }

    fn landing_px(&self, field_deg: [f64; 2]) -> SimResult<[f64; 2]> {
        let mut ray = self.aimer.ray_at(field_deg, 0.0, 0.0)?;
        if !self.system.trace(&mut ray).is_ok() {
            return Err(SimError::Unsupported(format!(
                "the chief ray of field ({:.3}, {:.3}) deg does not reach the image",
                field_deg[0], field_deg[1]
            )));
        }
        Ok(self.grid.to_px([ray.position_mm[0], ray.position_mm[1]]))
    }

    /// Where the field of (tan x, tan y) = `tan` lands, and the determinant of d(landing px) / d(tan x,
    /// tan y) there, by one-sided differences towards the axis (they stay inside the largest field,
    /// where every chief ray is known to land). Its sign is the map's orientation (rows run down).
    fn landing_and_det(&self, tan: [f64; 2]) -> SimResult<([f64; 2], f64)> {
        let field = |t: [f64; 2]| t.map(|t| t.atan().to_degrees());
        let here = self.landing_px(field(tan))?;
        let step = |axis: usize| {
            let h = if tan[axis] > 0.0 {
                -JACOBIAN_STEP_TAN
            } else {
                JACOBIAN_STEP_TAN
            };
            let mut moved = tan;
            moved[axis] += h;
            let there = self.landing_px(field(moved))?;
            Ok::<_, SimError>([(there[0] - here[0]) / h, (there[1] - here[1]) / h])
        };
        let (dx, dy) = (step(0)?, step(1)?);
        let det = dx[0] * dy[1] - dx[1] * dy[0];
        if !(det != 0.0 && det.is_finite()) {
            return Err(SimError::Unsupported(format!(
                "the chief-ray map is singular at field tan ({:.4}, {:.4}); the field cannot be mapped",
                tan[0], tan[1]
            )));
        }
        Ok((here, det))
    }
}
