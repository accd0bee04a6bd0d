//! The paper's key analysis: does a lens metric predict how well lenses can be corrected? Per lens, the
//! mean O.P. of the restoration models is fitted by least squares against the lens's ODE and against its
//! RMS spot radius; R^2 of each fit says how much of the spread in restorability each metric explains.

use serde::Serialize;

/// A least-squares line y = intercept + slope x and its coefficient of determination.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct LineFit {
    pub intercept: f64,
    pub slope: f64,
    /// 1 - SS_res / SS_tot.
    pub r2: f64,
}

/// The ordinary least-squares line through `points`; `None` with fewer than 3 points or when x or y
/// does not vary (R^2 undefined).
pub fn fit_line(points: &[(f64, f64)]) -> Option<LineFit> {
    let points: Vec<(f64, f64)> = points
        .iter()
        .copied()
        .filter(|(x, y)| x.is_finite() && y.is_finite())
        .collect();
    let n = points.len() as f64;
    if points.len() < 3 {
        return None;
    }
    let mean_x = points.iter().map(|p| p.0).sum::<f64>() / n;
    let mean_y = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mean_x).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mean_x) * (p.1 - mean_y)).sum();
    let syy: f64 = points.iter().map(|p| (p.1 - mean_y).powi(2)).sum();
    if sxx <= 0.0 || syy <= 0.0 {
        return None;
    }
    let slope = sxy / sxx;
    let intercept = mean_y - slope * mean_x;
    let residual: f64 = points
        .iter()
        .map(|p| (p.1 - intercept - slope * p.0).powi(2))
        .sum();
    Some(LineFit {
        intercept,
        slope,
        r2: 1.0 - residual / syy,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exact_line_has_r2_one() {
        let fit = fit_line(&[(0.0, 1.0), (1.0, 3.0), (2.0, 5.0)]).unwrap();
        assert!((fit.slope - 2.0).abs() < 1e-12 && (fit.intercept - 1.0).abs() < 1e-12);
        assert!((fit.r2 - 1.0).abs() < 1e-12);
    }

    #[test]
    fn known_r2() {
        // y = (0, 2, 1, 3) at x = (0, 1, 2, 3): slope 0.8, intercept 0.3, SS_res 1.8, SS_tot 5.
        let fit = fit_line(&[(0.0, 0.0), (1.0, 2.0), (2.0, 1.0), (3.0, 3.0)]).unwrap();
        assert!((fit.slope - 0.8).abs() < 1e-12);
        assert!((fit.intercept - 0.3).abs() < 1e-12);
        assert!((fit.r2 - (1.0 - 1.8 / 5.0)).abs() < 1e-12);
        assert!(fit_line(&[(0.0, 1.0), (1.0, 2.0)]).is_none());
        assert!(fit_line(&[(0.0, 1.0), (1.0, 1.0), (2.0, 1.0)]).is_none());
    }
}
