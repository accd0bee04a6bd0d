//! Spot diagrams, RMS spot radius, ray fans and distortion.

use crate::aim::{Aimer, Aiming};
use crate::aim_map::FieldAiming;
use crate::error::TraceResult;
use crate::pupil::PupilSampling;
use crate::ray::{Ray, RayStatus, StatusCounts};
use crate::system::{Clipping, TraceSystem};
use rayon::prelude::*;
use serde::Serialize;
use unicac_optics::Lens;

/// One field at one wavelength, traced with one pupil sampling.
#[derive(Debug, Clone, Serialize)]
pub struct Spot {
    pub field_deg: f64,
    /// The field's x angle (deg), for a lens that is not rotationally symmetric (absent when 0).
    #[serde(skip_serializing_if = "unicac_io::serde_skip::is_zero")]
    pub field_x_deg: f64,
    pub wavelength_um: f64,
    pub rays_traced: usize,
    pub rays_ok: usize,
    /// Rays that real aiming could not place (counted in `rays_traced`, not traced).
    pub rays_not_aimed: usize,
    pub status_counts: StatusCounts,
    pub centroid_x_mm: Option<f64>,
    pub centroid_y_mm: Option<f64>,
    /// RMS radius about the centroid.
    pub rms_radius_um: Option<f64>,
    /// RMS radius about the chief ray's intercept.
    pub rms_radius_chief_um: Option<f64>,
    /// Largest distance of a ray from the centroid.
    pub geometric_radius_um: Option<f64>,
    pub chief_x_mm: Option<f64>,
    pub chief_y_mm: Option<f64>,
    /// Image-surface intercepts of the rays that arrived.
    #[serde(skip)]
    pub points_mm: Vec<[f64; 2]>,
}

/// The system and aimer for one wavelength, built once and reused for every field.
pub struct SpotTracer {
    pub system: TraceSystem,
    pub aimer: Aimer,
}

impl SpotTracer {
    pub fn new(lens: &Lens, wavelength_um: f64, aiming: Aiming) -> TraceResult<SpotTracer> {
        Ok(SpotTracer {
            system: TraceSystem::new(lens, wavelength_um, Clipping::Apertures)?,
            aimer: Aimer::new(lens, wavelength_um, aiming)?,
        })
    }

    /// Rays of one field through the given pupil points; points real aiming cannot place are dropped
    /// and counted.
    pub fn aimed_rays(&self, field_deg: f64, pupil: &[[f64; 2]]) -> (Vec<Ray>, usize) {
        let rays: Vec<Ray> = self
            .aimer
            .rays(field_deg, pupil)
            .into_iter()
            .filter_map(Result::ok)
            .collect();
        let not_aimed = pupil.len() - rays.len();
        (rays, not_aimed)
    }

    /// The chief ray's image intercept, if it arrives.
    pub fn chief_intercept(&self, field_deg: f64) -> Option<[f64; 2]> {
        self.chief_intercept_at([0.0, field_deg])
    }

    /// `chief_intercept` of a 2D field ([x, y] angles, deg; `Aimer::ray_at`).
    pub fn chief_intercept_at(&self, field_deg: [f64; 2]) -> Option<[f64; 2]> {
        let mut ray = self.aimer.ray_at(field_deg, 0.0, 0.0).ok()?;
        self.system
            .trace(&mut ray)
            .is_ok()
            .then_some([ray.position_mm[0], ray.position_mm[1]])
    }

    pub fn spot(&self, field_deg: f64, sampling: &PupilSampling) -> Spot {
        self.spot_at([0.0, field_deg], sampling)
    }

    /// `spot` of a 2D field ([x, y] angles, deg): what a lens that is not rotationally symmetric needs.
    pub fn spot_at(&self, field: [f64; 2], sampling: &PupilSampling) -> Spot {
        let count = sampling.point_count();
        let aiming = self.aimer.for_field(field, count);
        // Aimed, traced and reduced to arrivals chunk by chunk on every core, each task reusing its
        // buffers: no whole-pupil ray or status buffer is ever held (nor, for the patterns whose points
        // are made by index, a pupil buffer). Chunk c's arrivals go straight to the spot's own buffer at
        // c * SPOT_CHUNK (closed up below where rays were lost), so they are never gathered, and its
        // pages (huge ones where the kernel agrees) are first touched by the threads that fill them.
        let listed = sampling.indexed_point(0).is_none().then(|| sampling.points());
        let mut points_mm = vec![[0.0; 2]; count];
        unicac_io::memory::advise_huge_pages(&mut points_mm);
        let parts: Vec<SpotPart> = points_mm
            .par_chunks_mut(SPOT_CHUNK)
            .enumerate()
            .map_init(ChunkBuffers::default, |buffers, (c, out)| {
                let indices = c * SPOT_CHUNK..c * SPOT_CHUNK + out.len();
                let pupil = match &listed {
                    Some(points) => &points[indices],
                    None => {
                        buffers.pupil.clear();
                        sampling.indexed_points_into(indices, &mut buffers.pupil);
                        &buffers.pupil
                    }
                };
                self.arrivals(&aiming, pupil, &mut buffers.rays, &mut buffers.statuses, out)
            })
            .collect();
        close_up(&mut points_mm, &parts);
        let rays_not_aimed = parts.iter().map(|part| part.not_aimed).sum();
        let status_counts = parts
            .iter()
            .fold(StatusCounts::default(), |all, part| all.merge(part.counts));
        let chief = self.chief_intercept_at(field);
        let statistics = SpotStatistics::of(&points_mm, chief);
        Spot {
            field_deg: field[1],
            field_x_deg: field[0],
            wavelength_um: self.system.wavelength_um,
            rays_traced: count,
            rays_ok: points_mm.len(),
            rays_not_aimed,
            status_counts,
            centroid_x_mm: statistics.centroid_mm.map(|c| c[0]),
            centroid_y_mm: statistics.centroid_mm.map(|c| c[1]),
            rms_radius_um: statistics.rms_radius_um,
            rms_radius_chief_um: statistics.rms_radius_chief_um,
            geometric_radius_um: statistics.geometric_radius_um,
            chief_x_mm: chief.map(|c| c[0]),
            chief_y_mm: chief.map(|c| c[1]),
            points_mm,
        }
    }

    /// One chunk of a spot: the rays of `pupil` aimed into `rays`, traced, and their image points
    /// written to the front of `out` in pupil order.
    fn arrivals(
        &self,
        aiming: &FieldAiming<'_>,
        pupil: &[[f64; 2]],
        rays: &mut Vec<Ray>,
        statuses: &mut Vec<RayStatus>,
        out: &mut [[f64; 2]],
    ) -> SpotPart {
        rays.clear();
        let not_aimed = aiming.aimed_rays_into(pupil, rays);
        statuses.clear();
        statuses.resize(rays.len(), RayStatus::Ok);
        self.system.trace_chunk(rays, statuses);
        let mut arrived = 0;
        for (ray, status) in rays.iter().zip(statuses.iter()) {
            if status.is_ok() {
                out[arrived] = [ray.position_mm[0], ray.position_mm[1]];
                arrived += 1;
            }
        }
        SpotPart {
            not_aimed,
            counts: StatusCounts::from_statuses(statuses.iter()),
            arrived,
        }
    }
}

/// Moves each chunk's arrivals (written at the chunk's start, c x SPOT_CHUNK) down to follow the previous
/// chunk's, and cuts the buffer to the arrivals.
fn close_up(points_mm: &mut Vec<[f64; 2]>, parts: &[SpotPart]) {
    let mut end = 0;
    for (c, part) in parts.iter().enumerate() {
        let start = c * SPOT_CHUNK;
        if start != end {
            points_mm.copy_within(start..start + part.arrived, end);
        }
        end += part.arrived;
    }
    points_mm.truncate(end);
}

/// Pupil points per parallel task of `SpotTracer::spot` (the batch tracer's own task size).
const SPOT_CHUNK: usize = 2048;

/// What one chunk of a spot's pupil contributes (its arrivals are written in place).
struct SpotPart {
    not_aimed: usize,
    counts: StatusCounts,
    arrived: usize,
}

/// A spot task's working buffers, reused from chunk to chunk.
#[derive(Default)]
struct ChunkBuffers {
    pupil: Vec<[f64; 2]>,
    rays: Vec<Ray>,
    statuses: Vec<RayStatus>,
}

/// Spots for every (field, wavelength) pair, fields varying fastest.
pub fn spots(
    lens: &Lens,
    fields_deg: &[f64],
    wavelengths_um: &[f64],
    aiming: Aiming,
    sampling: &PupilSampling,
) -> TraceResult<Vec<Spot>> {
    let fields: Vec<[f64; 2]> = fields_deg.iter().map(|&y| [0.0, y]).collect();
    spots_at(lens, &fields, wavelengths_um, aiming, sampling)
}

/// `spots` of 2D fields ([x, y] angles, deg).
pub fn spots_at(
    lens: &Lens,
    fields_deg: &[[f64; 2]],
    wavelengths_um: &[f64],
    aiming: Aiming,
    sampling: &PupilSampling,
) -> TraceResult<Vec<Spot>> {
    sampling
        .check()
        .map_err(|e| crate::InvalidParameter::new("pupil_sampling", e.to_string()))?;
    let mut spots = Vec::with_capacity(fields_deg.len() * wavelengths_um.len());
    for &wavelength in wavelengths_um {
        let tracer = SpotTracer::new(lens, wavelength, aiming)?;
        spots.extend(fields_deg.iter().map(|&field| tracer.spot_at(field, sampling)));
    }
    Ok(spots)
}

/// A spot's size figures from its arrivals (mm) and the chief ray's intercept: the one implementation
/// behind the CPU and GPU spots.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SpotStatistics {
    pub centroid_mm: Option<[f64; 2]>,
    /// RMS radius about the centroid.
    pub rms_radius_um: Option<f64>,
    /// RMS radius about the chief ray's intercept.
    pub rms_radius_chief_um: Option<f64>,
    /// Largest distance of an arrival from the centroid.
    pub geometric_radius_um: Option<f64>,
}

impl SpotStatistics {
    /// Two passes over the arrivals, each on every core: the centroid and both RMS radii from each
    /// chunk's moments merged in chunk order (Chan et al.'s pairwise update: no cancellation of large
    /// sums of squares, and the same digits whatever the threads), then the largest distance from the
    /// centroid (an exact maximum, so chunking cannot change it). None where no ray arrived (and for
    /// the chief radius, where the chief ray did not).
    pub fn of(points_mm: &[[f64; 2]], chief_mm: Option<[f64; 2]>) -> SpotStatistics {
        let Some(&origin) = points_mm.first() else {
            return SpotStatistics::default(); // no arrival: every figure None
        };
        // Moments of the offsets from the first arrival: small numbers whose sums round far below an ulp
        // of a spot's position off axis (where the offsets themselves are exact, by Sterbenz's lemma).
        let parts: Vec<Moments> = points_mm
            .par_chunks(SPOT_CHUNK)
            .map(|chunk| Moments::of(chunk, origin, chief_mm))
            .collect();
        let all = parts.into_iter().fold(Moments::default(), Moments::merge);
        let centroid_mm = [origin[0] + all.mean[0], origin[1] + all.mean[1]];
        SpotStatistics {
            centroid_mm: Some(centroid_mm),
            rms_radius_um: Some((all.squared_deviations / all.count).sqrt() * 1e3),
            rms_radius_chief_um: chief_mm.map(|_| (all.squared_to_chief / all.count).sqrt() * 1e3),
            geometric_radius_um: Some(
                points_mm
                    .par_chunks(SPOT_CHUNK)
                    .map(|chunk| max_distance(chunk, centroid_mm))
                    .reduce(|| 0.0, f64::max)
                    * 1e3,
            ),
        }
    }
}

/// Count, mean offset from an origin and sums of squares of some arrivals: about their own mean, and
/// about the chief ray's intercept (0 without one).
#[derive(Debug, Clone, Copy, Default)]
struct Moments {
    count: f64,
    mean: [f64; 2],
    squared_deviations: f64,
    squared_to_chief: f64,
}

impl Moments {
    /// Two loops over the points: the offsets' sums together with the squares about the chief ray's
    /// intercept, then the squares about the mean. Each sum is still a chain in point order (so the same
    /// bits as one sum per loop); the chains of one loop are independent, so they overlap in the pipeline
    /// instead of each waiting on its own adder.
    fn of(points: &[[f64; 2]], origin: [f64; 2], chief: Option<[f64; 2]>) -> Moments {
        let offset = |p: &[f64; 2]| [p[0] - origin[0], p[1] - origin[1]];
        let n = points.len() as f64;
        // Without a chief ray the third sum is taken about the origin and discarded (a rare case).
        let reference = chief.unwrap_or(origin);
        let (sx, sy, squared_to_reference) = points.iter().fold((0.0, 0.0, 0.0), |(sx, sy, sr), p| {
            let d = offset(p);
            (sx + d[0], sy + d[1], sr + squared_distance(p, reference))
        });
        let mean = [sx / n, sy / n];
        Moments {
            count: n,
            mean,
            squared_deviations: points
                .iter()
                .map(|p| {
                    let d = offset(p);
                    (d[0] - mean[0]).powi(2) + (d[1] - mean[1]).powi(2)
                })
                .sum(),
            squared_to_chief: if chief.is_some() {
                squared_to_reference
            } else {
                0.0
            },
        }
    }

    /// The moments of both sets of arrivals together (`self` first; Chan et al.'s update).
    fn merge(self, other: Moments) -> Moments {
        if other.count == 0.0 {
            return self;
        }
        if self.count == 0.0 {
            return other;
        }
        let count = self.count + other.count;
        let delta = [other.mean[0] - self.mean[0], other.mean[1] - self.mean[1]];
        let share = other.count / count;
        Moments {
            count,
            mean: [self.mean[0] + delta[0] * share, self.mean[1] + delta[1] * share],
            squared_deviations: self.squared_deviations
                + other.squared_deviations
                + (delta[0] * delta[0] + delta[1] * delta[1]) * self.count * share,
            squared_to_chief: self.squared_to_chief + other.squared_to_chief,
        }
    }
}

/// Squared distance of a point from `reference`.
#[inline(always)]
fn squared_distance(p: &[f64; 2], reference: [f64; 2]) -> f64 {
    (p[0] - reference[0]).powi(2) + (p[1] - reference[1]).powi(2)
}

/// Largest distance of a point from `reference`, the largest of every point's `hypot`. hypot is a libm
/// call (~20 ns: on a million-ray spot more than the rest of its statistics together), so squared
/// distances pick the points within rounding of the largest and hypot decides among those only. dx^2 +
/// dy^2 is within a few ulps of hypot^2, far inside the 1e-12 margin; when the largest square is so
/// small that squares lose precision (subnormals), every point is a candidate. The largest square is
/// taken in [`MAX_LANES`] running maxima (a maximum does not depend on the order it is taken in, so this
/// is the same number as one running maximum), compiled for the CPU's widest vectors.
fn max_distance(points: &[[f64; 2]], reference: [f64; 2]) -> f64 {
    let largest_squared = pulp::Arch::new().dispatch(LargestSquare { points, reference });
    let threshold = if largest_squared > 1e-280 {
        largest_squared * (1.0 - 1e-12)
    } else {
        0.0
    };
    points
        .iter()
        .filter(|p| squared_distance(p, reference) >= threshold)
        .map(|p| (p[0] - reference[0]).hypot(p[1] - reference[1]))
        .fold(0.0, f64::max)
}

/// Running maxima kept side by side by [`max_distance`]'s first pass (one AVX-512 vector of f64).
const MAX_LANES: usize = 8;

/// The largest squared distance of the points from `reference`, under `pulp`'s run-time dispatch.
struct LargestSquare<'a> {
    points: &'a [[f64; 2]],
    reference: [f64; 2],
}

impl pulp::WithSimd for LargestSquare<'_> {
    type Output = f64;
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) -> f64 {
        let LargestSquare { points, reference } = self;
        let mut lanes = [0.0f64; MAX_LANES];
        let mut groups = points.chunks_exact(MAX_LANES);
        for group in &mut groups {
            for (lane, p) in lanes.iter_mut().zip(group) {
                *lane = lane.max(squared_distance(p, reference));
            }
        }
        let rest = groups.remainder().iter().map(|p| squared_distance(p, reference));
        lanes.into_iter().chain(rest).fold(0.0, f64::max)
    }
}

/// One point of a ray fan: transverse aberration relative to the chief ray.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct FanPoint {
    pub pupil: f64,
    pub ex_um: f64,
    pub ey_um: f64,
    pub status: RayStatus,
}

/// Tangential (py varies, px = 0) and sagittal (px varies, py = 0) fans.
#[derive(Debug, Clone, Serialize)]
pub struct RayFan {
    pub field_deg: f64,
    pub wavelength_um: f64,
    pub tangential: Vec<FanPoint>,
    pub sagittal: Vec<FanPoint>,
}

/// Most points per fan: each is an aimed ray (a real-aimed one costs a Newton solve).
pub const MAX_FAN_SAMPLES: usize = 100_001;

/// Fans need at least two points (the pupil's two ends) and at most [`MAX_FAN_SAMPLES`].
pub fn check_fan_samples(samples: usize) -> Result<(), crate::InvalidParameter> {
    if !(2..=MAX_FAN_SAMPLES).contains(&samples) {
        return Err(crate::InvalidParameter::new(
            "samples",
            format!("fan samples {samples}: must lie between 2 and {MAX_FAN_SAMPLES} (MAX_FAN_SAMPLES)"),
        ));
    }
    Ok(())
}

pub fn ray_fan(tracer: &SpotTracer, field_deg: f64, samples: usize) -> Option<RayFan> {
    let chief = tracer.chief_intercept(field_deg)?;
    let fan = |tangential: bool| -> Vec<FanPoint> {
        (0..samples)
            .filter_map(|i| {
                let p = -1.0 + 2.0 * i as f64 / (samples.max(2) - 1) as f64;
                let (px, py) = if tangential { (0.0, p) } else { (p, 0.0) };
                let mut ray = tracer.aimer.ray(field_deg, px, py).ok()?;
                let status = tracer.system.trace(&mut ray);
                let (ex_um, ey_um) = if status.is_ok() {
                    (
                        (ray.position_mm[0] - chief[0]) * 1e3,
                        (ray.position_mm[1] - chief[1]) * 1e3,
                    )
                } else {
                    (0.0, 0.0)
                };
                Some(FanPoint {
                    pupil: p,
                    ex_um,
                    ey_um,
                    status,
                })
            })
            .collect()
    };
    Some(RayFan {
        field_deg,
        wavelength_um: tracer.system.wavelength_um,
        tangential: fan(true),
        sagittal: fan(false),
    })
}

/// Real chief-ray image height against the paraxial image height.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct DistortionPoint {
    pub field_deg: f64,
    pub real_image_height_mm: f64,
    pub paraxial_image_height_mm: f64,
    /// 100 (real - paraxial) / paraxial; 0 on axis.
    pub distortion_percent: f64,
}

/// Distortion of the chief ray (real aiming: it passes the stop centre) at the primary wavelength.
pub fn distortion(lens: &Lens, fields_deg: &[f64]) -> TraceResult<Vec<DistortionPoint>> {
    let tracer = SpotTracer::new(lens, lens.primary_wavelength_um(), Aiming::Real)?;
    let first = &tracer.aimer.first_order;
    let per_tan = if first.field_angles_deg.is_empty() {
        0.0
    } else {
        paraxial_height_per_tan(first)
    };
    let unclipped = TraceSystem::new(lens, lens.primary_wavelength_um(), Clipping::None)?;
    Ok(fields_deg
        .iter()
        .filter_map(|&field| {
            let mut ray = tracer.aimer.ray(field, 0.0, 0.0).ok()?;
            unclipped.trace(&mut ray).is_ok().then_some(())?;
            let paraxial = per_tan * field.to_radians().tan();
            let real = ray.position_mm[1];
            let distortion_percent = if paraxial == 0.0 {
                0.0
            } else {
                100.0 * (real - paraxial) / paraxial
            };
            Some(DistortionPoint {
                field_deg: field,
                real_image_height_mm: real,
                paraxial_image_height_mm: paraxial,
                distortion_percent,
            })
        })
        .collect())
}

fn paraxial_height_per_tan(first: &unicac_optics::FirstOrder) -> f64 {
    first
        .field_angles_deg
        .iter()
        .zip(&first.paraxial_image_heights_mm)
        .find(|(f, _)| **f != 0.0)
        .map(|(f, h)| h / f.to_radians().tan())
        .unwrap_or(0.0)
}

/// Working F/# from the real on-axis marginal ray: 1 / (2 n' sin theta') (None if it does not arrive).
pub fn real_working_f_number(lens: &Lens) -> TraceResult<Option<f64>> {
    let wavelength = lens.primary_wavelength_um();
    let system = TraceSystem::new(lens, wavelength, Clipping::None)?;
    let aimer = Aimer::new(lens, wavelength, Aiming::Real)?;
    let Ok(mut ray) = aimer.ray(0.0, 0.0, 1.0) else {
        return Ok(None);
    };
    if !system.trace(&mut ray).is_ok() {
        return Ok(None);
    }
    let n_image = system.surfaces[system.image_index() - 1].index_after;
    let sin_theta = ray.direction[0].hypot(ray.direction[1]);
    Ok((sin_theta > 0.0).then(|| 1.0 / (2.0 * n_image * sin_theta)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pupil::{counter_hash, unit_interval};

    #[test]
    fn spot_statistics_match_compensated_sums_on_a_spot_far_off_axis() {
        // Neumaier's compensated sum: a reference within an ulp or two of the exact sum.
        let exact_sum = |values: &mut dyn Iterator<Item = f64>| {
            let (mut sum, mut carried) = (0.0f64, 0.0f64);
            for v in values {
                let t = sum + v;
                carried += if sum.abs() >= v.abs() {
                    (sum - t) + v
                } else {
                    (v - t) + sum
                };
                sum = t;
            }
            sum + carried
        };
        // 300,001 arrivals 30 um across, 18 mm off axis (a real spot's shape of numbers), and an empty spot.
        let points: Vec<[f64; 2]> = (0..300_001u64)
            .map(|i| {
                let u = unit_interval(counter_hash(9, 2 * i)) - 0.5;
                let v = unit_interval(counter_hash(9, 2 * i + 1)) - 0.5;
                [3e-6 + 0.03 * u, 18.134 + 0.03 * v * v]
            })
            .collect();
        let chief = [1e-6, 18.1345];
        let n = points.len() as f64;
        let mean = [0, 1].map(|a| exact_sum(&mut points.iter().map(|p| p[a])) / n);
        let rms_about = |r: [f64; 2]| {
            (exact_sum(
                &mut points
                    .iter()
                    .map(|p| (p[0] - r[0]).powi(2) + (p[1] - r[1]).powi(2)),
            ) / n)
                .sqrt()
                * 1e3
        };
        let statistics = SpotStatistics::of(&points, Some(chief));
        let centroid = statistics.centroid_mm.unwrap();
        assert!((centroid[0] - mean[0]).abs() <= 1e-18, "{centroid:?} {mean:?}");
        assert!(
            (centroid[1] - mean[1]).abs() <= f64::EPSILON * mean[1],
            "{centroid:?} {mean:?}"
        );
        let close = |ours: f64, reference: f64| (ours / reference - 1.0).abs() < 1e-14;
        assert!(close(statistics.rms_radius_um.unwrap(), rms_about(mean)));
        assert!(close(statistics.rms_radius_chief_um.unwrap(), rms_about(chief)));
        let farthest = points
            .iter()
            .map(|p| (p[0] - mean[0]).hypot(p[1] - mean[1]))
            .fold(0.0, f64::max);
        assert!(close(statistics.geometric_radius_um.unwrap(), farthest * 1e3));
        let empty = SpotStatistics::of(&[], Some(chief));
        assert_eq!(
            (
                empty.centroid_mm,
                empty.rms_radius_um,
                empty.rms_radius_chief_um,
                empty.geometric_radius_um
            ),
            (None, None, None, None)
        );
        assert_eq!(SpotStatistics::of(&points, None).rms_radius_chief_um, None);
    }

    #[test]
    fn max_distance_equals_the_largest_hypot() {
        let naive = |points: &[[f64; 2]], r: [f64; 2]| {
            points
                .iter()
                .map(|p| (p[0] - r[0]).hypot(p[1] - r[1]))
                .fold(0.0, f64::max)
        };
        for (scale, seed) in [(1e-3, 1), (1.0, 2), (1e150, 3), (1e-160, 4), (1e-300, 5)] {
            let mut points: Vec<[f64; 2]> = (0..20_000u64)
                .map(|i| {
                    let u = unit_interval(counter_hash(seed, 2 * i)) - 0.5;
                    let v = unit_interval(counter_hash(seed, 2 * i + 1)) - 0.5;
                    [u * scale, v * scale]
                })
                .collect();
            // Near-ties: points whose distances differ in the last bits only.
            let far = points[7];
            points.push([far[0] * (1.0 + f64::EPSILON), far[1]]);
            points.push([far[0], far[1] * (1.0 - f64::EPSILON)]);
            let reference = [0.01 * scale, -0.02 * scale];
            assert_eq!(
                max_distance(&points, reference),
                naive(&points, reference),
                "scale {scale}"
            );
        }
        assert_eq!(max_distance(&[], [0.0, 0.0]), 0.0);
    }
}
