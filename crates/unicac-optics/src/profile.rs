//! Surface profiles: the sag z(r) of standard (conic) and even-aspheric surfaces and its derivative.
//!
//! Everything is written in terms of rho = r^2 = x^2 + y^2, which avoids a square root for the polynomial
//! and gives the surface normal directly: grad(z - s(rho)) = (-2 x s', -2 y s', 1) with s' = ds/drho.

use serde::{Deserialize, Serialize};

/// Highest number of even-asphere coefficients: r^2, r^4, ..., r^20.
pub const MAX_ASPHERE_TERMS: usize = 10;

/// The shape of one rotationally symmetric surface.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Profile {
    pub curvature_per_mm: f64,
    pub conic: f64,
    /// Coefficients of r^2, r^4, ..., r^20 (index i multiplies r^(2i+2)); all zero for a standard surface.
    pub aspheric_coefficients: [f64; MAX_ASPHERE_TERMS],
    /// Number of leading coefficients that can be non-zero (0 for a conic): the polynomial loop stops there.
    pub aspheric_terms: usize,
}

impl Profile {
    pub fn conic(curvature_per_mm: f64, conic: f64) -> Self {
        Profile {
            curvature_per_mm,
            conic,
            aspheric_coefficients: [0.0; MAX_ASPHERE_TERMS],
            aspheric_terms: 0,
        }
    }

    pub fn even_asphere(curvature_per_mm: f64, conic: f64, coefficients: &[f64]) -> Self {
        let mut profile = Profile::conic(curvature_per_mm, conic);
        let used = coefficients.len().min(MAX_ASPHERE_TERMS);
        profile.aspheric_coefficients[..used].copy_from_slice(&coefficients[..used]);
        profile.aspheric_terms = profile
            .aspheric_coefficients
            .iter()
            .rposition(|&a| a != 0.0)
            .map_or(0, |last| last + 1);
        profile
    }

    pub fn is_plane(&self) -> bool {
        self.curvature_per_mm == 0.0 && self.aspheric_terms == 0
    }

    pub fn has_polynomial(&self) -> bool {
        self.aspheric_terms > 0
    }

    /// The largest rho = r^2 where the conic base is defined (infinite when it is defined everywhere).
    pub fn conic_rho_limit(&self) -> f64 {
        let q = (1.0 + self.conic) * self.curvature_per_mm * self.curvature_per_mm;
        if q > 0.0 {
            1.0 / q
        } else {
            f64::INFINITY
        }
    }

    /// Sag of the conic base. Written as c rho / (1 + sqrt(1 - (1+k) c^2 rho)), which has no cancellation
    /// for small c and stays exact for a plane. Returns NaN outside the conic's domain (callers check
    /// `conic_rho_limit` first).
    #[inline]
    pub fn conic_sag(&self, rho: f64) -> f64 {
        let c = self.curvature_per_mm;
        let root = (1.0 - (1.0 + self.conic) * c * c * rho).sqrt();
        c * rho / (1.0 + root)
    }

    /// ds/drho of the conic base: c / (2 sqrt(1 - (1+k) c^2 rho)).
    #[inline]
    pub fn conic_slope_rho(&self, rho: f64) -> f64 {
        let c = self.curvature_per_mm;
        c / (2.0 * (1.0 - (1.0 + self.conic) * c * c * rho).sqrt())
    }

    /// Polynomial part sum a_(2i+2) rho^(i+1) and its derivative with respect to rho, by Horner's rule.
    #[inline]
    pub fn polynomial(&self, rho: f64) -> (f64, f64) {
        let mut value = 0.0;
        let mut slope = 0.0;
        for i in (0..self.aspheric_terms).rev() {
            let a = self.aspheric_coefficients[i];
            // value = sum a_i rho^(i+1); slope = sum (i+1) a_i rho^i
            slope = slope * rho + (i as f64 + 1.0) * a;
            value = value * rho + a;
        }
        (value * rho, slope)
    }

    /// Full sag z(r^2).
    #[inline]
    pub fn sag(&self, rho: f64) -> f64 {
        self.conic_sag(rho) + self.polynomial(rho).0
    }

    /// Sag and ds/drho together (one square root for both).
    #[inline]
    pub fn sag_and_slope(&self, rho: f64) -> (f64, f64) {
        let (poly, poly_slope) = self.polynomial(rho);
        let c = self.curvature_per_mm;
        let root = (1.0 - (1.0 + self.conic) * c * c * rho).sqrt();
        (c * rho / (1.0 + root) + poly, c / (2.0 * root) + poly_slope)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_sag_matches_closed_form() {
        let radius = 25.0;
        let p = Profile::conic(1.0 / radius, 0.0);
        for r in [0.0, 1.0, 5.0, 12.5, 24.9] {
            let exact = radius - (radius * radius - r * r).sqrt();
            assert!((p.sag(r * r) - exact).abs() < 1e-12, "r = {r}");
        }
    }

    #[test]
    fn parabola_sag_is_c_rho_over_two() {
        let p = Profile::conic(0.01, -1.0);
        assert_eq!(p.sag(400.0), 0.01 * 400.0 / 2.0);
        assert!(p.conic_rho_limit().is_infinite());
    }

    #[test]
    fn near_flat_surface_has_no_cancellation() {
        let p = Profile::conic(1e-15, 0.0);
        let rho = 100.0;
        // z = c rho / 2 to first order; relative error of the stable form stays at rounding level.
        assert!((p.sag(rho) / (1e-15 * rho / 2.0) - 1.0).abs() < 1e-15);
    }

    #[test]
    fn polynomial_and_slope_match_direct_sums() {
        let coefficients = [1e-3, -2e-5, 3e-7, -4e-9, 5e-11];
        let p = Profile::even_asphere(0.0, 0.0, &coefficients);
        let rho: f64 = 7.3;
        let value: f64 = coefficients
            .iter()
            .enumerate()
            .map(|(i, a)| a * rho.powi(i as i32 + 1))
            .sum();
        let slope: f64 = coefficients
            .iter()
            .enumerate()
            .map(|(i, a)| (i as f64 + 1.0) * a * rho.powi(i as i32))
            .sum();
        let (v, s) = p.polynomial(rho);
        assert!((v - value).abs() < 1e-15 * value.abs().max(1.0));
        assert!((s - slope).abs() < 1e-15 * slope.abs().max(1.0));
    }

    #[test]
    fn slope_matches_finite_difference() {
        let p = Profile::even_asphere(0.05, -0.7, &[0.0, 1e-4, -2e-6]);
        let rho = 20.0;
        let h = 1e-6;
        let fd = (p.sag(rho + h) - p.sag(rho - h)) / (2.0 * h);
        assert!((p.sag_and_slope(rho).1 - fd).abs() < 1e-8);
    }
}
