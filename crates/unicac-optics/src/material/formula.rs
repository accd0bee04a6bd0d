//! Dispersion formulas of the refractiveindex.info database (the numbering used in its YAML files and in
//! our shipped catalogues). Wavelengths in micrometres. The AGF formulas map onto these: AGF "Schott" is
//! formula 3 (polynomial with exponents 2, -2, -4, -6, -8), AGF "Sellmeier 1" is formula 2.
//!
//! Hand-written because no maintained Rust crate evaluates these formulas; each is one line of the
//! database's documentation and is tested against optiland's evaluation of the same data.

use serde::{Deserialize, Serialize};

/// A refractiveindex.info dispersion formula with its coefficients C1, C2, ... (index 0 is C1).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Formula {
    pub formula: u8,
    pub coefficients: Vec<f64>,
}

impl Formula {
    /// Formula numbers this evaluator knows.
    pub const SUPPORTED: std::ops::RangeInclusive<u8> = 1..=9;

    /// Refractive index at `wavelength_um`.
    pub fn index(&self, wavelength_um: f64) -> f64 {
        let c = |i: usize| self.coefficients.get(i - 1).copied().unwrap_or(0.0);
        let l = wavelength_um;
        let l2 = l * l;
        // Pairs (C_{2i}, C_{2i+1}) for i = 1.. starting at coefficient index `first` (1-based).
        let pairs = |first: usize| {
            (first..=self.coefficients.len())
                .step_by(2)
                .map(move |i| (c(i), c(i + 1)))
        };
        match self.formula {
            1 => (1.0 + c(1) + pairs(2).map(|(b, k)| b * l2 / (l2 - k * k)).sum::<f64>()).sqrt(),
            2 => (1.0 + c(1) + pairs(2).map(|(b, k)| b * l2 / (l2 - k)).sum::<f64>()).sqrt(),
            3 => (c(1) + pairs(2).map(|(a, p)| a * l.powf(p)).sum::<f64>()).sqrt(),
            4 => {
                let resonances = c(2) * l.powf(c(3)) / (l2 - c(4).powf(c(5)))
                    + c(6) * l.powf(c(7)) / (l2 - c(8).powf(c(9)));
                let tail: f64 = pairs(10).map(|(a, p)| a * l.powf(p)).sum();
                (c(1) + resonances + tail).sqrt()
            }
            5 => c(1) + pairs(2).map(|(a, p)| a * l.powf(p)).sum::<f64>(),
            6 => 1.0 + c(1) + pairs(2).map(|(b, k)| b / (k - 1.0 / l2)).sum::<f64>(),
            7 => {
                let q = 1.0 / (l2 - 0.028);
                c(1) + c(2) * q + c(3) * q * q + c(4) * l2 + c(5) * l2 * l2 + c(6) * l2 * l2 * l2
            }
            8 => {
                let r = c(1) + c(2) * l2 / (l2 - c(3)) + c(4) * l2;
                ((1.0 + 2.0 * r) / (1.0 - r)).sqrt()
            }
            9 => {
                let d = l - c(5);
                (c(1) + c(2) / (l2 - c(3)) + c(4) * d / (d * d + c(6))).sqrt()
            }
            _ => f64::NAN,
        }
    }
}

/// Fraunhofer lines used for nd, Vd (um).
pub const LINE_F_UM: f64 = 0.4861327;
pub const LINE_D_UM: f64 = 0.5875618;
pub const LINE_C_UM: f64 = 0.6562725;

/// Model glass dispersion from (nd, Vd): Cauchy n = A + B / lambda^2 fitted so n(d) = nd and
/// (nd - 1) / (nF - nC) = Vd. The same model DeepLens and OptiFusion use during search; documented in
/// docs/lens-format.md.
pub fn model_glass_index(nd: f64, vd: f64, wavelength_um: f64) -> f64 {
    let b = (nd - 1.0) / (vd * (1.0 / (LINE_F_UM * LINE_F_UM) - 1.0 / (LINE_C_UM * LINE_C_UM)));
    let a = nd - b / (LINE_D_UM * LINE_D_UM);
    a + b / (wavelength_um * wavelength_um)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sellmeier_n_bk7_matches_schott_datasheet() {
        // SCHOTT datasheet N-BK7: B1..B3, C1..C3; nd = 1.51680, nF = 1.52238, nC = 1.51432.
        let bk7 = Formula {
            formula: 2,
            coefficients: vec![
                0.0,
                1.03961212,
                0.00600069867,
                0.231792344,
                0.0200179144,
                1.01046945,
                103.560653,
            ],
        };
        assert!((bk7.index(LINE_D_UM) - 1.51680).abs() < 5e-6);
        assert!((bk7.index(LINE_F_UM) - 1.52238).abs() < 5e-6);
        assert!((bk7.index(LINE_C_UM) - 1.51432).abs() < 5e-6);
    }

    #[test]
    fn formula_1_and_2_agree_when_poles_are_squared() {
        let f1 = Formula {
            formula: 1,
            coefficients: vec![0.0, 1.0, 0.1, 0.5, 3.0],
        };
        let f2 = Formula {
            formula: 2,
            coefficients: vec![0.0, 1.0, 0.01, 0.5, 9.0],
        };
        assert!((f1.index(0.55) - f2.index(0.55)).abs() < 1e-15);
    }

    #[test]
    fn model_glass_reproduces_nd_and_abbe_number() {
        let (nd, vd) = (1.6204, 60.3);
        let n = |l| model_glass_index(nd, vd, l);
        assert!((n(LINE_D_UM) - nd).abs() < 1e-14);
        assert!(((nd - 1.0) / (n(LINE_F_UM) - n(LINE_C_UM)) - vd).abs() < 1e-9);
    }
}
