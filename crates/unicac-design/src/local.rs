//! Local refinement: damped least squares (Levenberg-Marquardt with Marquardt's diagonal scaling) on the
//! merit's residual vector, in the normalised variables (clamped to the box [0, 1]).
//!
//! The Jacobian is exact, by forward-mode AD (`Dual`): one dual pass carries N directions (N = 16, 24
//! or 48, the smallest that holds all n variables; beyond 48, passes of 32), at about N times the f64
//! cost.
//! `Gradient::FiniteDifference` is the baseline (central differences, 2n f64 evaluations per Jacobian)
//! that docs/performance.md compares against.

use crate::dual::Dual;
use crate::merit::Merit;
use crate::params::Parameterization;
use crate::scalar::Scalar;
use serde::Serialize;
use std::time::Instant;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Gradient {
    Exact,
    FiniteDifference,
}

impl std::str::FromStr for Gradient {
    type Err = String;

    /// `exact` (dual numbers) or `fd` (central differences, the baseline).
    fn from_str(text: &str) -> std::result::Result<Gradient, String> {
        match text {
            "exact" => Ok(Gradient::Exact),
            "fd" => Ok(Gradient::FiniteDifference),
            other => Err(format!("{other:?}: expected exact or fd")),
        }
    }
}

/// Step of the finite-difference baseline (normalised units), as OptiFusion's 1e-6.
pub const FD_STEP: f64 = 1e-6;

/// Residuals and their Jacobian (row-major, rows = residuals).
pub struct Linearisation {
    pub residuals: Vec<f64>,
    pub jacobian: Vec<f64>,
    pub columns: usize,
}

fn dual_pass<const N: usize>(
    merit: &Merit,
    params: &Parameterization,
    x: &[f64],
    first: usize,
    out: &mut Linearisation,
) -> Option<()> {
    let columns = out.columns;
    let dual_x: Vec<Dual<N>> = x
        .iter()
        .enumerate()
        .map(|(i, &v)| {
            if (first..first + N).contains(&i) {
                Dual::variable(v, i - first)
            } else {
                Dual::cst(v)
            }
        })
        .collect();
    let evaluation = merit.evaluate(&params.decode(&dual_x)?);
    if out.residuals.is_empty() {
        out.residuals = evaluation.residuals.iter().map(|r| r.re()).collect();
        out.jacobian = vec![0.0; out.residuals.len() * columns];
    }
    if evaluation.residuals.len() != out.residuals.len() {
        return None;
    }
    for (row, r) in evaluation.residuals.iter().enumerate() {
        for k in 0..N.min(columns - first) {
            out.jacobian[row * columns + first + k] = r.grad[k];
        }
    }
    Some(())
}

/// Dual lanes of `linearise`'s passes for `columns` variables: (lanes per pass, passes).
fn dual_lanes(columns: usize) -> (usize, usize) {
    match columns {
        0..=16 => (16, 1),
        17..=24 => (24, 1),
        25..=48 => (48, 1),
        _ => (32, columns.div_ceil(32)),
    }
}

/// What one `linearise` at `columns` variables costs, in merit values: a dual pass of N lanes about
/// N/3 (docs/performance.md "One merit value and one Jacobian": 5.7, 8.8 and 19.6 values measured at
/// 12, 24 and 36 variables, 6, 8 and 16 here), central differences 2n + 1. The unit of evaluation
/// budgets (`crate::budget`).
pub fn linearisation_cost(columns: usize, gradient: Gradient) -> usize {
    match gradient {
        Gradient::Exact => {
            let (lanes, passes) = dual_lanes(columns);
            passes * lanes.div_ceil(3)
        }
        Gradient::FiniteDifference => 2 * columns + 1,
    }
}

/// Residuals and Jacobian at x; `None` if the design is singular there.
pub fn linearise(
    merit: &Merit,
    params: &Parameterization,
    x: &[f64],
    gradient: Gradient,
) -> Option<Linearisation> {
    let columns = x.len();
    let mut out = Linearisation {
        residuals: Vec::new(),
        jacobian: Vec::new(),
        columns,
    };
    match gradient {
        Gradient::Exact => match dual_lanes(columns).0 {
            16 => dual_pass::<16>(merit, params, x, 0, &mut out)?,
            24 => dual_pass::<24>(merit, params, x, 0, &mut out)?,
            48 => dual_pass::<48>(merit, params, x, 0, &mut out)?,
            _ => {
                for first in (0..columns).step_by(32) {
                    dual_pass::<32>(merit, params, x, first, &mut out)?;
                }
            }
        },
        Gradient::FiniteDifference => {
            out.residuals = merit.evaluate(&params.decode(x)?).residuals;
            let rows = out.residuals.len();
            out.jacobian = vec![0.0; rows * columns];
            let mut probe = x.to_vec();
            for j in 0..columns {
                probe[j] = x[j] + FD_STEP;
                let plus = merit.evaluate(&params.decode(&probe)?).residuals;
                probe[j] = x[j] - FD_STEP;
                let minus = merit.evaluate(&params.decode(&probe)?).residuals;
                probe[j] = x[j];
                if plus.len() != rows || minus.len() != rows {
                    return None;
                }
                for i in 0..rows {
                    out.jacobian[i * columns + j] = (plus[i] - minus[i]) / (2.0 * FD_STEP);
                }
            }
        }
    }
    Some(out)
}

/// Settings of one refinement.
#[derive(Debug, Clone, Copy)]
pub struct LocalSettings {
    pub iterations: usize,
    pub gradient: Gradient,
    /// Stop when the merit improves by less than this fraction over an iteration, twice in a row.
    pub tolerance: f64,
    pub deadline: Option<Instant>,
}

impl LocalSettings {
    pub fn new(iterations: usize, gradient: Gradient) -> Self {
        LocalSettings {
            iterations,
            gradient,
            tolerance: 1e-5,
            deadline: None,
        }
    }
}

/// Result of a refinement.
#[derive(Debug, Clone)]
pub struct Refined {
    pub x: Vec<f64>,
    pub merit: f64,
    pub iterations: usize,
    /// Merit evaluations spent, a Jacobian counted at its cost ([`linearisation_cost`]).
    pub evaluations: usize,
}

/// Levenberg-Marquardt from x. `progress(merit)` is called after every accepted step.
pub fn refine(
    merit: &Merit,
    params: &Parameterization,
    x: &[f64],
    settings: &LocalSettings,
    mut progress: impl FnMut(f64),
) -> Refined {
    let mut x = x.to_vec();
    let mut value = merit.value(params, &x).unwrap_or(f64::INFINITY);
    let mut lambda = 1e-3;
    let mut evaluations = 1;
    let mut slow = 0;
    let mut iterations = 0;
    let n = x.len();
    while iterations < settings.iterations && value.is_finite() {
        if settings.deadline.is_some_and(|d| Instant::now() >= d) {
            break;
        }
        iterations += 1;
        let Some(lin) = linearise(merit, params, &x, settings.gradient) else {
            break;
        };
        evaluations += linearisation_cost(n, settings.gradient);
        let (a, g) = normal_equations(&lin);
        let mut accepted = false;
        for _ in 0..16 {
            let mut damped = a.clone();
            for i in 0..n {
                damped[i * n + i] += lambda * a[i * n + i].max(1e-9) + 1e-12;
            }
            let Some(step) = cholesky_solve(&damped, &g, n) else {
                lambda *= 4.0;
                continue;
            };
            let candidate: Vec<f64> = x
                .iter()
                .zip(&step)
                .map(|(xi, s)| (xi - s).clamp(0.0, 1.0))
                .collect();
            evaluations += 1;
            match merit.value(params, &candidate) {
                Some(v) if v < value => {
                    let gain = (value - v) / value.max(1e-300);
                    slow = if gain < settings.tolerance { slow + 1 } else { 0 };
                    x = candidate;
                    value = v;
                    lambda = (lambda / 3.0).max(1e-9);
                    accepted = true;
                    progress(value);
                    break;
                }
                _ => lambda *= 6.0,
            }
        }
        if !accepted || slow >= 2 {
            break;
        }
    }
    Refined {
        x,
        merit: value,
        iterations,
        evaluations,
    }
}

/// J^T J and J^T r.
fn normal_equations(lin: &Linearisation) -> (Vec<f64>, Vec<f64>) {
    let n = lin.columns;
    let mut a = vec![0.0; n * n];
    let mut g = vec![0.0; n];
    for (row, r) in lin.jacobian.chunks_exact(n).zip(&lin.residuals) {
        for i in 0..n {
            let ji = row[i];
            if ji == 0.0 {
                continue;
            }
            g[i] += ji * r;
            for j in i..n {
                a[i * n + j] += ji * row[j];
            }
        }
    }
    for i in 0..n {
        for j in 0..i {
            a[i * n + j] = a[j * n + i];
        }
    }
    (a, g)
}

/// Solves A s = b for symmetric positive definite A (n x n, row-major); `None` if A is not.
fn cholesky_solve(a: &[f64], b: &[f64], n: usize) -> Option<Vec<f64>> {
    let mut l = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            let mut sum = a[i * n + j];
            for k in 0..j {
                sum -= l[i * n + k] * l[j * n + k];
            }
            if i == j {
                if !(sum > 0.0) {
                    return None;
                }
                l[i * n + i] = sum.sqrt();
            } else {
                l[i * n + j] = sum / l[j * n + j];
            }
        }
    }
    let mut y = vec![0.0; n];
    for i in 0..n {
        let sum: f64 = (0..i).map(|k| l[i * n + k] * y[k]).sum();
        y[i] = (b[i] - sum) / l[i * n + i];
    }
    let mut s = vec![0.0; n];
    for i in (0..n).rev() {
        let sum: f64 = (i + 1..n).map(|k| l[k * n + i] * s[k]).sum();
        s[i] = (y[i] - sum) / l[i * n + i];
    }
    Some(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_solves_a_small_system() {
        let a = [4.0, 1.0, 1.0, 3.0];
        let s = cholesky_solve(&a, &[1.0, 2.0], 2).unwrap();
        assert!((4.0 * s[0] + s[1] - 1.0).abs() < 1e-14);
        assert!((s[0] + 3.0 * s[1] - 2.0).abs() < 1e-14);
    }
}
