//! The merit function (docs/design.md): a vector of residuals whose sum of squares is minimised, and the
//! named quantities behind it. Generic over `Scalar`, so one code path gives values and exact Jacobians.
//!
//! Units: lengths are scaled to a 50 mm focal length (`scale` = 50 / f) so that weights mean the same
//! at any focal length; spot residuals are in micrometres at that scale.
//! - Spot: per field, every ray at every wavelength about the field's polychromatic centroid
//!   (centroid-referenced RMS, lateral colour included); the pupil is sampled by an equal-area polar
//!   grid over the half pupil x >= 0 (the lens is symmetric about the y-z plane).
//! - Lateral colour: chief-ray height at the shortest minus the longest wavelength, per field.
//! - Constraints: one-sided linear violations, weighted, as residuals (quadratic penalties).
//! - A ray that fails (misses a surface, TIR) adds constant residuals (no gradient); designs with any
//!   failed ray are never accepted.

use crate::params::Parameterization;
use crate::scalar::{max, Scalar};
use crate::spec::DesignSpec;
use crate::system::{Material, Prescription, Surf};
use crate::tracer::{aimed_ray, paraxial, RayFailure, Tracer};
use serde::Serialize;
use std::f64::consts::PI;
use unicac_optics::material::shipped_catalogs;

/// Residual of a failed ray (per coordinate): larger than any spot a usable design has.
const FAILED_RAY_RESIDUAL: f64 = 300.0;
/// Semi-diameters = largest frame-ray height times this: room for rays between the sampled pupil
/// azimuths, and for mounting.
pub const SEMI_DIAMETER_MARGIN: f64 = 1.02;
const LATERAL_COLOUR_WEIGHT: f64 = 0.5;
/// Fractions of a semi-diameter where gaps, slopes and asphere departures are checked.
const CHECK_HEIGHTS: [f64; 4] = [0.25, 0.5, 0.75, 1.0];
/// Glass-map normalisation: nd / 0.1 and Vd / 10.
pub const GLASS_MAP_SCALE: [f64; 2] = [0.1, 10.0];

/// How finely the merit samples the pupil.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Sampling {
    pub rings: usize,
    pub arms: usize,
}

impl Sampling {
    /// The global search's coarse sampling and the refinement's finer one.
    pub const COARSE: Sampling = Sampling { rings: 2, arms: 4 };
    pub const FINE: Sampling = Sampling { rings: 4, arms: 7 };

    /// Equal-area polar points over the half pupil px > 0: ring radii sqrt((i + 0.5) / R), arm angles
    /// (j + 0.5) pi / A from +y.
    pub fn points(&self) -> Vec<[f64; 2]> {
        let mut points = Vec::with_capacity(self.rings * self.arms);
        for i in 0..self.rings {
            let r = ((i as f64 + 0.5) / self.rings as f64).sqrt();
            for j in 0..self.arms {
                let angle = (j as f64 + 0.5) * PI / self.arms as f64;
                points.push([r * angle.sin(), r * angle.cos()]);
            }
        }
        points
    }
}

/// Chief ray and pupil-edge rays at 0, 45, 90, 135, 180 deg from +y: they size the elements and give
/// distortion and relative illumination.
const FRAME: [[f64; 2]; 6] = [
    [0.0, 0.0],
    [0.0, 1.0],
    [std::f64::consts::FRAC_1_SQRT_2, std::f64::consts::FRAC_1_SQRT_2],
    [1.0, 0.0],
    [std::f64::consts::FRAC_1_SQRT_2, -std::f64::consts::FRAC_1_SQRT_2],
    [0.0, -1.0],
];

/// What a constraint limits. Names in reports are `kind[index]` (0-based surface or field index).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Kind {
    GlassCenterThickness,
    GlassEdgeThickness,
    AirCenterThickness,
    AirEdgeGap,
    BackFocalDistance,
    TotalTrack,
    FocalLength,
    Distortion,
    RelativeIllumination,
    SurfaceSlope,
    AsphereDeparture,
    GlassCatalogDistance,
    RaysTraced,
}

impl Kind {
    pub fn name(&self) -> &'static str {
        match self {
            Kind::GlassCenterThickness => "glass_center_thickness",
            Kind::GlassEdgeThickness => "glass_edge_thickness",
            Kind::AirCenterThickness => "air_center_thickness",
            Kind::AirEdgeGap => "air_edge_gap",
            Kind::BackFocalDistance => "back_focal_distance",
            Kind::TotalTrack => "total_track",
            Kind::FocalLength => "focal_length",
            Kind::Distortion => "distortion",
            Kind::RelativeIllumination => "relative_illumination",
            Kind::SurfaceSlope => "surface_slope",
            Kind::AsphereDeparture => "asphere_departure",
            Kind::GlassCatalogDistance => "glass_catalog_distance",
            Kind::RaysTraced => "rays_traced",
        }
    }

    /// Penalty weight per unit of violation (the unit of the constraint's value; lengths at f = 50).
    fn weight(&self) -> f64 {
        match self {
            Kind::Distortion => 200.0,
            Kind::RelativeIllumination | Kind::SurfaceSlope => 5000.0,
            Kind::GlassCatalogDistance => 2000.0,
            Kind::FocalLength => 1e4,
            Kind::RaysTraced => 0.0,
            _ => 1e4,
        }
    }

    /// Violation still counted as met (rounding of a converged penalty); lengths at f = 50.
    fn tolerance(&self) -> f64 {
        match self {
            Kind::Distortion => 0.05,
            Kind::RelativeIllumination | Kind::SurfaceSlope => 0.005,
            Kind::GlassCatalogDistance => 0.01,
            Kind::FocalLength => 1e-6,
            Kind::RaysTraced => 0.0,
            _ => 0.002,
        }
    }

    fn is_length(&self) -> bool {
        matches!(
            self,
            Kind::GlassCenterThickness
                | Kind::GlassEdgeThickness
                | Kind::AirCenterThickness
                | Kind::AirEdgeGap
                | Kind::BackFocalDistance
                | Kind::TotalTrack
                | Kind::AsphereDeparture
        )
    }
}

/// One checked limit: `value` must be <= `limit` (upper) or >= `limit`.
#[derive(Debug, Clone, Serialize)]
pub struct Check {
    pub name: String,
    pub kind: Kind,
    pub value: f64,
    pub limit: f64,
    pub upper: bool,
    /// How far beyond the limit (0 when met), in the value's unit.
    pub violation: f64,
    pub met: bool,
}

/// Named quantities of one evaluation (all f64).
#[derive(Debug, Clone, Default, Serialize)]
pub struct Terms {
    pub merit: f64,
    /// Polychromatic RMS spot radius per field about its centroid (um, not scaled).
    pub rms_um: Vec<f64>,
    pub rms_mean_um: f64,
    pub lateral_colour_um: Vec<f64>,
    pub distortion_percent: Vec<f64>,
    pub relative_illumination: Vec<f64>,
    pub failed_rays: usize,
    pub efl_mm: f64,
    pub back_focal_mm: f64,
    pub total_track_mm: f64,
    /// Per surface: the element's mechanical semi-diameter (lens surfaces) or the clear one (stop).
    pub semi_diameters_mm: Vec<f64>,
    pub checks: Vec<Check>,
}

impl Terms {
    pub fn violations(&self) -> impl Iterator<Item = &Check> {
        self.checks.iter().filter(|c| !c.met)
    }

    pub fn feasible(&self) -> bool {
        self.failed_rays == 0 && self.checks.iter().all(|c| c.met)
    }
}

/// Merit of one spec.
#[derive(Debug, Clone)]
pub struct Merit {
    pub spec: DesignSpec,
    pub sampling: Sampling,
    fields_deg: Vec<f64>,
    pupil: Vec<[f64; 2]>,
    scale: f64,
    /// Multiplies every penalty weight: raised by the finishing stage when a refined design still
    /// violates a limit (quadratic penalties always leave a small violation).
    pub penalty_scale: f64,
    /// (nd, Vd) of the catalogue glasses a model glass may approach.
    glass_map: Vec<[f64; 2]>,
}

/// The optical glasses of the shipped catalogues with nd, Vd in the design range whose data cover the
/// visible band the simulator and the ODE trace (400-700 nm): a library lens must be gradable (a glass
/// covering only F to C, e.g. CDGM D-ZF93-25 from 435.8 nm, made `unicac dataset` refuse the lens).
pub fn design_glasses() -> Vec<std::sync::Arc<unicac_optics::material::Glass>> {
    use crate::params::{ND_RANGE, VD_RANGE};
    use unicac_optics::material::VISIBLE_BAND_UM;
    shipped_catalogs()
        .iter()
        .flat_map(|c| c.glasses.iter())
        .filter(|g| match (g.nd, g.vd) {
            (Some(nd), Some(vd)) => {
                (ND_RANGE[0]..=ND_RANGE[1]).contains(&nd)
                    && (VD_RANGE[0]..=VD_RANGE[1]).contains(&vd)
                    && g.covers_um(VISIBLE_BAND_UM)
            }
            _ => false,
        })
        .cloned()
        .collect()
}

/// Residuals and the named quantities behind them.
pub struct Evaluation<S> {
    pub residuals: Vec<S>,
    pub terms: Terms,
}

impl Merit {
    pub fn new(spec: &DesignSpec, sampling: Sampling) -> Merit {
        Merit {
            spec: spec.clone(),
            sampling,
            fields_deg: spec.field_angles_deg(),
            pupil: sampling.points(),
            scale: 50.0 / spec.focal_length_mm,
            penalty_scale: 1.0,
            glass_map: design_glasses()
                .iter()
                .filter_map(|g| Some([g.nd?, g.vd?]))
                .collect(),
        }
    }

    pub fn fields_deg(&self) -> &[f64] {
        &self.fields_deg
    }

    /// Sum of squared residuals at x (f64), or `None` if the design is singular.
    pub fn value(&self, params: &Parameterization, x: &[f64]) -> Option<f64> {
        let p = params.decode(x)?;
        Some(self.evaluate(&p).terms.merit)
    }

    /// Evaluates a prescription.
    pub fn evaluate<S: Scalar>(&self, p: &Prescription<S>) -> Evaluation<S> {
        let spec = &self.spec;
        let f = spec.focal_length_mm;
        let to_um = 1000.0 * self.scale;
        let n_fields = self.fields_deg.len();
        let n_waves = spec.wavelengths_um.len();
        let n_surfaces = p.surfaces.len();
        let mut residuals = Vec::new();
        let mut terms = Terms::default();
        let Some(first) = paraxial(p, spec.primary_wavelength_um()) else {
            terms.merit = f64::INFINITY;
            terms.failed_rays = usize::MAX;
            return Evaluation { residuals, terms };
        };
        let pupil_radius = S::cst(f / (2.0 * spec.f_number));
        let pupil_z = first.entrance_pupil_z;

        // Traces: spot rays per (field, wavelength) and the frame rays.
        let mut heights = vec![S::cst(0.0); n_surfaces];
        let mut spots: Vec<Vec<Option<[S; 2]>>> = vec![Vec::new(); n_fields * n_waves];
        let mut chief_y: Vec<Option<S>> = vec![None; n_fields * n_waves];
        // Per field at the primary wavelength: image-space direction cosines of the frame's edge rays.
        let mut frame_directions: Vec<[Option<[S; 2]>; FRAME.len()]> = vec![[None; FRAME.len()]; n_fields];
        let mut failed = 0usize;
        for (w, &wavelength) in spec.wavelengths_um.iter().enumerate() {
            let tracer = Tracer::new(p, wavelength);
            for (fi, &field) in self.fields_deg.iter().enumerate() {
                for (k, &[px, py]) in FRAME.iter().enumerate() {
                    let mut ray = aimed_ray(field, px, py, pupil_radius, pupil_z);
                    let result = tracer.trace(&mut ray, |i, hit| {
                        heights[i] = max(heights[i], (hit[0] * hit[0] + hit[1] * hit[1]).sqrt());
                    });
                    match result {
                        Ok(()) => {
                            if k == 0 {
                                chief_y[fi * n_waves + w] = Some(ray.position[1]);
                            }
                            if w == spec.primary_wavelength_index {
                                frame_directions[fi][k] = Some([ray.direction[0], ray.direction[1]]);
                            }
                        }
                        Err(_) => failed += 1,
                    }
                }
                spots[fi * n_waves + w] = self
                    .pupil
                    .iter()
                    .map(|&[px, py]| {
                        let mut ray = aimed_ray(field, px, py, pupil_radius, pupil_z);
                        let traced: Result<(), RayFailure> = tracer.trace(&mut ray, |_, _| {});
                        traced.ok().map(|()| [ray.position[0], ray.position[1]])
                    })
                    .collect();
            }
        }

        // Spot residuals about each field's polychromatic centroid.
        let weight_sum: f64 = spec.wavelength_weights.iter().sum::<f64>().max(1e-300);
        let k_rays = self.pupil.len() as f64;
        for fi in 0..n_fields {
            let mut centroid = S::cst(0.0);
            let mut mass = 0.0;
            for w in 0..n_waves {
                for hit in spots[fi * n_waves + w].iter().flatten() {
                    centroid = centroid + hit[1] * spec.wavelength_weights[w];
                    mass += spec.wavelength_weights[w];
                }
            }
            let centroid = if mass > 0.0 { centroid / mass } else { centroid };
            let mut sum_sq = 0.0;
            for w in 0..n_waves {
                let factor = (spec.wavelength_weights[w] / (weight_sum * k_rays * n_fields as f64)).sqrt();
                for hit in &spots[fi * n_waves + w] {
                    match hit {
                        Some([x, y]) => {
                            let rx = *x * (factor * to_um);
                            let ry = (*y - centroid) * (factor * to_um);
                            sum_sq += (rx.re() * rx.re() + ry.re() * ry.re()) * n_fields as f64;
                            residuals.push(rx);
                            residuals.push(ry);
                        }
                        None => {
                            failed += 1;
                            residuals.push(S::cst(FAILED_RAY_RESIDUAL));
                            residuals.push(S::cst(FAILED_RAY_RESIDUAL));
                        }
                    }
                }
            }
            terms.rms_um.push(sum_sq.sqrt() / self.scale);
        }
        terms.rms_mean_um = terms.rms_um.iter().sum::<f64>() / n_fields as f64;

        // Lateral colour: chief ray, shortest minus longest wavelength.
        let by_wavelength =
            |a: &usize, b: &usize| spec.wavelengths_um[*a].total_cmp(&spec.wavelengths_um[*b]);
        let shortest = (0..n_waves).min_by(by_wavelength).unwrap_or(0);
        let longest = (0..n_waves).max_by(by_wavelength).unwrap_or(0);
        for fi in 0..n_fields {
            let colour = match (chief_y[fi * n_waves + shortest], chief_y[fi * n_waves + longest]) {
                (Some(a), Some(b)) => a - b,
                _ => S::cst(0.0),
            };
            residuals.push(colour * (to_um * LATERAL_COLOUR_WEIGHT / (n_fields as f64).sqrt()));
            terms.lateral_colour_um.push(colour.re() * 1000.0);
        }

        let mut checks = Checks {
            residuals: &mut residuals,
            list: Vec::new(),
            scale: self.scale,
            penalty_scale: self.penalty_scale,
        };
        // Distortion against f tan(F), and relative illumination (below).
        let primary = spec.primary_wavelength_index;
        for (fi, &field) in self.fields_deg.iter().enumerate() {
            let ideal = f * field.to_radians().tan();
            let distortion = match chief_y[fi * n_waves + primary] {
                Some(y) if ideal.abs() > 1e-9 => (y - ideal) * (100.0 / ideal),
                _ => S::cst(0.0),
            };
            terms.distortion_percent.push(distortion.re());
            if fi > 0 {
                checks.at_most(
                    Kind::Distortion,
                    fi,
                    distortion.abs(),
                    spec.constraints.distortion_max_percent,
                );
            }
        }
        // Irradiance at an image point is proportional to the area of its ray cone in direction-cosine
        // space (L, M) (projected solid angle); the cone is taken as the ellipse through the edge rays.
        let cone_area = |d: &[Option<[S; 2]>; FRAME.len()]| match (d[1], d[5], d[3]) {
            (Some(top), Some(bottom), Some(side)) => Some(((top[1] - bottom[1]) * side[0]).abs()),
            _ => None,
        };
        // Always the same residuals (the Jacobian's rows must not change): a failed cone counts as RI 0.
        let axis = frame_directions.first().and_then(cone_area);
        for (fi, d) in frame_directions.iter().enumerate() {
            let ri = match (axis, cone_area(d)) {
                (Some(axis), Some(a)) if axis.re() > 0.0 => a / axis,
                _ => S::cst(0.0),
            };
            terms.relative_illumination.push(ri.re());
            if fi + 1 == n_fields && n_fields > 1 {
                checks.at_least(
                    Kind::RelativeIllumination,
                    fi,
                    ri,
                    spec.constraints.relative_illumination_min,
                );
            }
        }

        // Geometry.
        let semi: Vec<S> = (0..n_surfaces)
            .map(|i| {
                let s = &p.surfaces[i];
                if s.is_stop {
                    heights[i] * SEMI_DIAMETER_MARGIN
                } else if !s.after.is_air() {
                    max(heights[i], heights[i + 1]) * SEMI_DIAMETER_MARGIN
                } else {
                    max(heights[i], heights[i - 1]) * SEMI_DIAMETER_MARGIN
                }
            })
            .collect();
        self.geometry_checks(p, &semi, &mut checks);
        checks.at_least(
            Kind::FocalLength,
            0,
            S::cst(1.0) - (first.efl / f - 1.0).abs(),
            1.0 - spec.constraints.focal_tolerance,
        );

        let list = checks.list;
        let mut total_track = S::cst(0.0);
        for s in &p.surfaces {
            total_track = total_track + s.thickness;
        }
        terms.efl_mm = first.efl.re();
        terms.back_focal_mm = p.surfaces[n_surfaces - 1].thickness.re();
        terms.total_track_mm = total_track.re();
        terms.semi_diameters_mm = semi.iter().map(|s| s.re()).collect();
        terms.failed_rays = failed;
        terms.checks = list;
        terms.checks.push(Check {
            name: format!("{}[0]", Kind::RaysTraced.name()),
            kind: Kind::RaysTraced,
            value: failed as f64,
            limit: 0.0,
            upper: true,
            violation: failed as f64,
            met: failed == 0,
        });
        terms.merit = residuals.iter().map(|r| r.re() * r.re()).sum();
        Evaluation { residuals, terms }
    }

    fn geometry_checks<S: Scalar>(&self, p: &Prescription<S>, semi: &[S], checks: &mut Checks<'_, S>) {
        let c = &self.spec.constraints;
        let last = p.surfaces.len() - 1;
        let mut total_track = S::cst(0.0);
        let max_sin_slope = c.surface_slope_max_deg.to_radians().sin();
        for (i, s) in p.surfaces.iter().enumerate() {
            total_track = total_track + s.thickness;
            if !s.is_stop {
                let slope = (0..CHECK_HEIGHTS.len())
                    .map(|k| sin_slope(s, semi[i] * CHECK_HEIGHTS[k]))
                    .fold(S::cst(0.0), max);
                checks.at_most(Kind::SurfaceSlope, i, slope, max_sin_slope);
            }
            if s.is_asphere {
                checks.at_most(
                    Kind::AsphereDeparture,
                    i,
                    departure(s, semi[i]),
                    c.asphere_departure_max_mm,
                );
            }
            if i == last {
                checks.at_least(Kind::BackFocalDistance, i, s.thickness, c.back_focal_min_mm);
                continue;
            }
            let next = &p.surfaces[i + 1];
            if let Material::Model { nd, vd } = &s.after {
                let (nd, vd) = (*nd, *vd);
                let distance_sq = |g: &[f64; 2]| {
                    ((nd.re() - g[0]) / GLASS_MAP_SCALE[0]).powi(2)
                        + ((vd.re() - g[1]) / GLASS_MAP_SCALE[1]).powi(2)
                };
                if let Some(g) = self
                    .glass_map
                    .iter()
                    .min_by(|a, b| distance_sq(a).total_cmp(&distance_sq(b)))
                {
                    let dn = (nd - g[0]) / GLASS_MAP_SCALE[0];
                    let dv = (vd - g[1]) / GLASS_MAP_SCALE[1];
                    let distance = (dn * dn + dv * dv + 1e-12).sqrt();
                    checks.at_most(Kind::GlassCatalogDistance, i, distance, c.glass_distance_max);
                }
            }
            let gap = |r: S| -> Option<S> {
                let rho = r * r;
                Some(s.thickness + next.sag_and_slope(rho)?.0 - s.sag_and_slope(rho)?.0)
            };
            if !s.after.is_air() {
                checks.in_range(Kind::GlassCenterThickness, i, s.thickness, c.glass_center_mm);
                if let Some(edge) = gap(semi[i]) {
                    checks.at_least(Kind::GlassEdgeThickness, i, edge, c.glass_edge_min_mm);
                }
            } else {
                checks.in_range(Kind::AirCenterThickness, i, s.thickness, c.air_center_mm);
                let reach = if semi[i + 1].re() < semi[i].re() {
                    semi[i + 1]
                } else {
                    semi[i]
                };
                let narrowest = CHECK_HEIGHTS
                    .iter()
                    .filter_map(|&h| gap(reach * h))
                    .reduce(|a, b| if b.re() < a.re() { b } else { a });
                if let Some(edge) = narrowest {
                    checks.at_least(Kind::AirEdgeGap, i, edge, c.air_edge_min_mm);
                }
            }
        }
        checks.at_most(Kind::TotalTrack, 0, total_track, c.total_track_max_mm);
    }
}

/// Sine of the surface normal's angle to the axis at height r; beyond the conic's domain it continues
/// above 1 (1 + how far (1+k) c^2 r^2 exceeds 1), so the penalty has a slope back towards valid shapes.
fn sin_slope<S: Scalar>(s: &Surf<S>, r: S) -> S {
    match s.sag_and_slope(r * r) {
        Some((_, slope)) => {
            let tan = slope * r * 2.0;
            (tan * tan / (tan * tan + 1.0)).sqrt()
        }
        None => s.curvature * s.curvature * (s.conic + 1.0) * r * r,
    }
}

/// Largest departure of a surface from its best-fit sphere (through the vertex and the edge point).
fn departure<S: Scalar>(s: &Surf<S>, h: S) -> S {
    let Some((edge, _)) = s.sag_and_slope(h * h) else {
        return S::cst(0.0);
    };
    let c_fit = edge * 2.0 / (h * h + edge * edge);
    let sphere = Surf {
        curvature: c_fit,
        conic: S::cst(0.0),
        is_asphere: false,
        ..s.clone()
    };
    CHECK_HEIGHTS[..3]
        .iter()
        .filter_map(|&k| {
            let rho = h * h * (k * k);
            Some((s.sag_and_slope(rho)?.0 - sphere.sag_and_slope(rho)?.0).abs())
        })
        .fold(S::cst(0.0), max)
}

/// Collects checks and their penalty residuals.
struct Checks<'a, S> {
    residuals: &'a mut Vec<S>,
    list: Vec<Check>,
    scale: f64,
    penalty_scale: f64,
}

impl<S: Scalar> Checks<'_, S> {
    fn push(&mut self, kind: Kind, index: usize, value: S, limit: f64, upper: bool) {
        let excess = if upper {
            value - limit
        } else {
            S::cst(limit) - value
        };
        let unit = if kind.is_length() { self.scale } else { 1.0 };
        let violation = excess.re().max(0.0);
        self.residuals.push(if excess.re() > 0.0 {
            excess * (kind.weight() * unit * self.penalty_scale)
        } else {
            S::cst(0.0)
        });
        self.list.push(Check {
            name: format!("{}[{index}]", kind.name()),
            kind,
            value: value.re(),
            limit,
            upper,
            violation,
            met: violation * unit <= kind.tolerance(),
        });
    }

    fn at_most(&mut self, kind: Kind, index: usize, value: S, limit: f64) {
        self.push(kind, index, value, limit, true);
    }

    fn at_least(&mut self, kind: Kind, index: usize, value: S, limit: f64) {
        self.push(kind, index, value, limit, false);
    }

    fn in_range(&mut self, kind: Kind, index: usize, value: S, range: [f64; 2]) {
        self.at_least(kind, index, value, range[0]);
        self.at_most(kind, index, value, range[1]);
    }
}
