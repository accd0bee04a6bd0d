//! Real aiming of many rays of one field at once: an aiming map, then a chord-Newton step per ray.
//!
//! The per-ray solve (`Aimer::ray_at`) starts every ray from the paraxial guess: several Newton steps
//! of three traces each and, at wide fields of a lens like the 100-degree retrofocus, a continuation
//! over 16 field steps. Here, per field and wavelength:
//! 1. `AimingMap::fit`: exact per-ray solves at `node_points()` (the pupil centre and rings, each solve
//!    warm-started from its inner neighbour on the same spoke), and a least-squares polynomial
//!    s(px, py) of total degree `MAP_DEGREE` through them, s being the ray's point on the paraxial
//!    entrance-pupil plane;
//! 2. every ray starts at s(p) and takes chord-Newton steps s -= (ds/dp) r / R_stop, r being the error
//!    of its stop intercept: the map's derivative stands in for the inverse Jacobian the per-ray solve
//!    gets from two extra traces. The rays of a batch are traced to the stop together (lane tracer).
//!
//! **Bound:** a ray is aimed only when its stop intercept lies within `Aimer::stop_tolerance_mm`
//! (1e-13 R_stop per axis) of its target, the per-ray solve's own criterion, checked on the ray itself;
//! the map only decides where the search starts. A ray that leaves the lens, stalls or is not aimed
//! after `MAX_CHORD_STEPS` goes to the per-ray solve, as does every ray of a field whose map cannot be
//! fitted, and every ray of a pupil too small for a map to pay.

use crate::aim::{aim_failed, Aimer, Aiming, FieldStart};
use crate::error::TraceResult;
use crate::ray::{Ray, RayStatus};

/// Total degree of the aiming polynomial (all monomials px^i py^j with i + j <= MAP_DEGREE).
const MAP_DEGREE: usize = 6;
/// Exact solves of the map: the centre, then `NODE_RINGS` rings of `NODE_SPOKES` points each.
const NODE_RINGS: usize = 4;
const NODE_SPOKES: usize = 16;
/// Chord steps a ray may take before it is handed to the per-ray solve.
const MAX_CHORD_STEPS: usize = 8;
/// Rays traced to the stop together (a few lane blocks; keeps the working set in cache).
const BATCH_RAYS: usize = 256;

/// Aiming of rays of one field (`Aimer::for_field`): what the field's rays share, worked out once, and
/// for real aiming of many rays the field's aiming map, shared by every batch of pupil points.
pub struct FieldAiming<'a> {
    aimer: &'a Aimer,
    field_deg: [f64; 2],
    start: FieldStart,
    map: Option<AimingMap>,
}

// Declared here rather than in `aim.rs` so that `aim` (the per-ray solver) does not import its batch user.
impl Aimer {
    /// Aiming of about `rays` rays of one field, in batches (`rays_at` for pupils that come in parts).
    pub fn for_field(&self, field_deg: [f64; 2], rays: usize) -> FieldAiming<'_> {
        FieldAiming::new(self, field_deg, rays)
    }
}

impl<'a> FieldAiming<'a> {
    /// `rays` is about how many rays will be aimed: a map costs about as much as aiming its nodes one by
    /// one, so below a few times that it cannot pay and none is fitted.
    pub(crate) fn new(aimer: &'a Aimer, field_deg: [f64; 2], rays: usize) -> FieldAiming<'a> {
        let real = !matches!(aimer.aiming, Aiming::Paraxial);
        let map = (real && rays >= 4 * node_count())
            .then(|| AimingMap::fit(aimer, field_deg))
            .flatten();
        FieldAiming {
            aimer,
            field_deg,
            start: aimer.field_start(field_deg),
            map,
        }
    }

    /// The ray through normalised pupil point (px, py), aimed on its own (`Aimer::ray_at`).
    pub fn ray(&self, px: f64, py: f64) -> TraceResult<Ray> {
        let aimer = self.aimer;
        let ray = match aimer.aiming {
            Aiming::Paraxial => self.paraxial_ray(px, py),
            // `Aimer::new` resolves Auto; an Aimer built otherwise aims for real.
            Aiming::Real | Aiming::Auto => aimer.real_ray(self.field_deg, px, py)?,
        };
        // Extreme but finite lens data (found by fuzzing: an object 6e-314 mm away, a pupil 6e257 mm
        // behind it) overflow the start point or the direction: such a ray is refused here rather than
        // handed on holding NaN or infinity.
        if !ray.is_finite() {
            return Err(aim_failed(
                self.field_deg,
                px,
                py,
                "the aimed ray is not finite (the lens's dimensions overflow f64)".into(),
            ));
        }
        Ok(ray)
    }

    /// The paraxially aimed ray through (px, py): through (px, py) EPD / 2 on the entrance-pupil plane.
    #[inline]
    fn paraxial_ray(&self, px: f64, py: f64) -> Ray {
        let radius = self.aimer.first_order.epd_mm / 2.0;
        self.aimer.ray_from(self.start, px * radius, py * radius)
    }

    /// The rays of `pupil`, in order: `ray` of each point, or for real aiming with a map the same ray
    /// to the stop tolerance (see the module docs).
    pub fn rays(&self, pupil: &[[f64; 2]]) -> Vec<TraceResult<Ray>> {
        let Some(map) = &self.map else {
            return pupil.iter().map(|&[px, py]| self.ray(px, py)).collect();
        };
        let solved = pupil
            .chunks(BATCH_RAYS)
            .flat_map(|batch| chord_solve(self.aimer, map, self.start, batch));
        pupil
            .iter()
            .zip(solved)
            .map(|(&[px, py], s)| {
                let ray = s.map(|s| self.aimer.ray_from(self.start, s[0], s[1]));
                match ray {
                    Some(ray) if ray.is_finite() => Ok(ray),
                    _ => self.ray(px, py),
                }
            })
            .collect()
    }

    /// The rays of `pupil` that could be aimed (`rays`), in order, appended to `out`; returns how many
    /// points could not. Without a map no per-ray result vector is made.
    pub fn aimed_rays_into(&self, pupil: &[[f64; 2]], out: &mut Vec<Ray>) -> usize {
        let before = out.len();
        match (self.aimer.aiming, &self.map) {
            // `ray`'s paraxial case without its error value (a non-finite ray is one not aimed). All
            // rays are written first (an exact-size loop without a branch per ray, noting finiteness as
            // it goes); in the rare batch holding a non-finite one they are made again, filtered.
            (Aiming::Paraxial, _) => {
                let paraxial = |&[px, py]: &[f64; 2]| self.paraxial_ray(px, py);
                let mut all_finite = true;
                out.extend(pupil.iter().map(|point| {
                    let ray = paraxial(point);
                    all_finite &= ray.is_finite();
                    ray
                }));
                if !all_finite {
                    out.truncate(before);
                    out.extend(pupil.iter().map(paraxial).filter(Ray::is_finite));
                }
            }
            (_, None) => out.extend(pupil.iter().filter_map(|&[px, py]| self.ray(px, py).ok())),
            (_, Some(_)) => out.extend(self.rays(pupil).into_iter().filter_map(Result::ok)),
        }
        pupil.len() - (out.len() - before)
    }
}

/// Pupil-plane points of a batch of rays whose stop intercepts were brought within tolerance; `None`
/// for the rays the per-ray solve must take.
fn chord_solve(
    aimer: &Aimer,
    map: &AimingMap,
    field: FieldStart,
    batch: &[[f64; 2]],
) -> Vec<Option<[f64; 2]>> {
    let r_stop = aimer.first_order.stop_radius_mm;
    let tolerance = aimer.stop_tolerance_mm();
    let mut solved = vec![None; batch.len()];
    let mut pending: Vec<PendingRay> = batch
        .iter()
        .enumerate()
        .map(|(index, &p)| {
            let (s, ds_dp) = map.at(p);
            PendingRay {
                index,
                s,
                ds_dp,
                last_error_mm: f64::INFINITY,
            }
        })
        .collect();
    let mut rays = Vec::with_capacity(batch.len());
    let mut statuses = Vec::with_capacity(batch.len());
    for _ in 0..=MAX_CHORD_STEPS {
        if pending.is_empty() {
            break;
        }
        rays.clear();
        rays.extend(
            pending
                .iter()
                .map(|ray| aimer.ray_from(field, ray.s[0], ray.s[1])),
        );
        statuses.clear();
        statuses.resize(rays.len(), RayStatus::Ok);
        aimer.to_stop.trace_chunk(&mut rays, &mut statuses);
        let mut next = Vec::with_capacity(pending.len());
        for (pending_ray, (ray, status)) in pending.drain(..).zip(rays.iter().zip(&statuses)) {
            if !status.is_ok() {
                continue;
            }
            let PendingRay {
                index,
                s,
                ds_dp,
                last_error_mm,
            } = pending_ray;
            let hit = aimer.in_stop_frame(ray.position_mm);
            let r = [
                hit[0] - batch[index][0] * r_stop,
                hit[1] - batch[index][1] * r_stop,
            ];
            let error_mm = r[0].abs().max(r[1].abs());
            if error_mm <= tolerance {
                solved[index] = Some(s);
            } else if error_mm < last_error_mm {
                let step = [
                    (ds_dp[0][0] * r[0] + ds_dp[0][1] * r[1]) / r_stop,
                    (ds_dp[1][0] * r[0] + ds_dp[1][1] * r[1]) / r_stop,
                ];
                next.push(PendingRay {
                    index,
                    s: [s[0] - step[0], s[1] - step[1]],
                    ds_dp,
                    last_error_mm: error_mm,
                });
            }
            // else: stalled (or NaN), left to the per-ray solve.
        }
        pending = next;
    }
    solved
}

/// A ray of a batch still being aimed.
struct PendingRay {
    /// Its place in the batch.
    index: usize,
    /// Its current point on the paraxial entrance-pupil plane (mm).
    s: [f64; 2],
    /// The map's ds/dp at its target: the chord step's inverse Jacobian (times R_stop).
    ds_dp: [[f64; 2]; 2],
    /// Its stop error before this step (mm, per axis): a step must shrink it.
    last_error_mm: f64,
}

fn node_count() -> usize {
    1 + NODE_RINGS * NODE_SPOKES
}

/// The map's exact-solve points, spoke by spoke from the centre outwards; ring radii crowd towards the
/// rim (sin spacing), where a polynomial fit is least constrained.
fn node_points() -> Vec<[f64; 2]> {
    let mut points = vec![[0.0, 0.0]];
    for spoke in 0..NODE_SPOKES {
        let angle = std::f64::consts::TAU * (spoke as f64 + 0.5) / NODE_SPOKES as f64;
        for ring in 1..=NODE_RINGS {
            let radius = (std::f64::consts::FRAC_PI_2 * ring as f64 / NODE_RINGS as f64).sin();
            points.push([radius * angle.cos(), radius * angle.sin()]);
        }
    }
    points
}

/// s(px, py): the paraxial-entrance-pupil-plane point (mm) of the real-aimed ray, one polynomial per
/// coordinate over the monomials of `monomials()`.
struct AimingMap {
    coefficients: [Vec<f64>; 2],
}

impl AimingMap {
    /// The map of one field, or None when too few nodes could be aimed or the fit is degenerate.
    fn fit(aimer: &Aimer, field_deg: [f64; 2]) -> Option<AimingMap> {
        let nodes = solved_nodes(aimer, field_deg);
        let terms = monomials().count();
        if nodes.len() < 2 * terms {
            return None;
        }
        let rows: Vec<Vec<f64>> = nodes.iter().map(|(p, _)| basis(*p)).collect();
        let targets = [0, 1].map(|axis| nodes.iter().map(|(_, s)| s[axis]).collect::<Vec<f64>>());
        let [x, y] = targets.map(|column| least_squares(rows.clone(), column));
        Some(AimingMap {
            coefficients: [x?, y?],
        })
    }

    /// s at p and its derivative ds/dp (rows: s_x, s_y; columns: d/dpx, d/dpy).
    fn at(&self, p: [f64; 2]) -> ([f64; 2], [[f64; 2]; 2]) {
        let mut powers = [[1.0; MAP_DEGREE + 1]; 2];
        for axis in 0..2 {
            for k in 1..=MAP_DEGREE {
                powers[axis][k] = powers[axis][k - 1] * p[axis];
            }
        }
        let mut s = [0.0; 2];
        let mut ds_dp = [[0.0; 2]; 2];
        for (term, (i, j)) in monomials().enumerate() {
            let value = powers[0][i] * powers[1][j];
            let d_px = if i > 0 {
                i as f64 * powers[0][i - 1] * powers[1][j]
            } else {
                0.0
            };
            let d_py = if j > 0 {
                j as f64 * powers[0][i] * powers[1][j - 1]
            } else {
                0.0
            };
            for axis in 0..2 {
                let c = self.coefficients[axis][term];
                s[axis] += c * value;
                ds_dp[axis][0] += c * d_px;
                ds_dp[axis][1] += c * d_py;
            }
        }
        (s, ds_dp)
    }
}

/// Exponents (i, j) of px^i py^j with i + j <= MAP_DEGREE, in a fixed order.
fn monomials() -> impl Iterator<Item = (usize, usize)> {
    (0..=MAP_DEGREE).flat_map(|total| (0..=total).map(move |i| (i, total - i)))
}

fn basis(p: [f64; 2]) -> Vec<f64> {
    monomials()
        .map(|(i, j)| p[0].powi(i as i32) * p[1].powi(j as i32))
        .collect()
}

/// (pupil point, pupil-plane point) of every node the per-ray solve could aim; each spoke stops at its
/// first failure (the rays beyond it would start from nothing better than the paraxial guess).
fn solved_nodes(aimer: &Aimer, field_deg: [f64; 2]) -> Vec<([f64; 2], [f64; 2])> {
    let points = node_points();
    let Ok(centre) = aimer.real_pupil_point(field_deg, 0.0, 0.0) else {
        return Vec::new();
    };
    let mut nodes = vec![(points[0], centre)];
    for spoke in points[1..].chunks(NODE_RINGS) {
        let mut previous = centre;
        for &p in spoke {
            let solved = aimer
                .solve_stop_point(field_deg, p[0], p[1], previous)
                .or_else(|_| aimer.real_pupil_point(field_deg, p[0], p[1]));
            let Ok(s) = solved else { break };
            nodes.push((p, s));
            previous = s;
        }
    }
    nodes
}

/// The least-squares solution x of `rows` x = `target` (Householder QR); None when the rows do not
/// determine it (rank-deficient or not finite).
fn least_squares(mut rows: Vec<Vec<f64>>, mut target: Vec<f64>) -> Option<Vec<f64>> {
    let n = rows.len();
    let m = rows.first()?.len();
    for k in 0..m {
        let norm = (k..n).map(|i| rows[i][k] * rows[i][k]).sum::<f64>().sqrt();
        if !(norm > 0.0) {
            return None;
        }
        let alpha = if rows[k][k] > 0.0 { -norm } else { norm };
        let mut v: Vec<f64> = (k..n).map(|i| rows[i][k]).collect();
        v[0] -= alpha;
        let v_norm2: f64 = v.iter().map(|x| x * x).sum();
        if v_norm2 == 0.0 {
            continue;
        }
        let below = &mut rows[k..];
        for j in k..m {
            let factor = 2.0 * below.iter().zip(&v).map(|(row, vi)| vi * row[j]).sum::<f64>() / v_norm2;
            for (row, vi) in below.iter_mut().zip(&v) {
                row[j] -= factor * vi;
            }
        }
        let factor = 2.0 * target[k..].iter().zip(&v).map(|(t, vi)| vi * t).sum::<f64>() / v_norm2;
        for (t, vi) in target[k..].iter_mut().zip(&v) {
            *t -= factor * vi;
        }
    }
    let largest = (0..m).map(|k| rows[k][k].abs()).fold(0.0, f64::max);
    let mut x = vec![0.0; m];
    for k in (0..m).rev() {
        if !(rows[k][k].abs() > 1e-12 * largest) {
            return None;
        }
        let rest: f64 = (k + 1..m).map(|j| rows[k][j] * x[j]).sum();
        x[k] = (target[k] - rest) / rows[k][k];
    }
    x.iter().all(|c| c.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn least_squares_recovers_an_exact_polynomial() {
        let points = node_points();
        let truth: Vec<f64> = (0..monomials().count())
            .map(|k| (k as f64 * 0.37).sin())
            .collect();
        let rows: Vec<Vec<f64>> = points.iter().map(|&p| basis(p)).collect();
        let values: Vec<f64> = rows
            .iter()
            .map(|row| row.iter().zip(&truth).map(|(a, b)| a * b).sum())
            .collect();
        let fitted = least_squares(rows, values).unwrap();
        for (a, b) in fitted.iter().zip(&truth) {
            assert!((a - b).abs() < 1e-9, "{a} vs {b}");
        }
    }

    #[test]
    fn map_derivative_matches_finite_differences() {
        let map = AimingMap {
            coefficients: [0, 1].map(|axis| {
                (0..monomials().count())
                    .map(|k| ((k + axis) as f64 * 0.71).cos())
                    .collect()
            }),
        };
        let p = [0.31, -0.52];
        let (_, ds_dp) = map.at(p);
        let h = 1e-6;
        for column in 0..2 {
            let mut plus = p;
            let mut minus = p;
            plus[column] += h;
            minus[column] -= h;
            let (sp, _) = map.at(plus);
            let (sm, _) = map.at(minus);
            for row in 0..2 {
                let fd = (sp[row] - sm[row]) / (2.0 * h);
                assert!(
                    (fd - ds_dp[row][column]).abs() < 1e-7,
                    "{fd} vs {}",
                    ds_dp[row][column]
                );
            }
        }
    }
}
