//! O.P., the paper's overall performance score of a restoration (UniCAC, Sec. 5):
//!
//! ```text
//! O.P. = 0.4 PSNR/50 + 0.3 (SSIM - 0.5)/0.5 + 0.4 (1 - LPIPS)/0.4 + 0.3 OIQE
//!        + 0.1 (100 - FID)/100 + 0.1 ClipIQA
//! ```
//!
//! with the paper's coefficients, PSNR in dB and the other metrics as pyiqa reports them. A metric that
//! is unavailable (weights not installed, no edge patches) leaves its term out: the score is then the
//! sum of the terms present, flagged as partial and listing them. It is never rescaled to make up for
//! the missing terms, so a partial O.P. is a lower bound of the full one and compares only with O.P.
//! values over the same terms.

use serde::Serialize;

/// The metric values O.P. combines; `None` = unavailable.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct OpInputs {
    pub psnr_db: Option<f64>,
    pub ssim: Option<f64>,
    pub lpips: Option<f64>,
    pub oiqe: Option<f64>,
    pub fid: Option<f64>,
    pub clipiqa: Option<f64>,
}

/// An O.P. value with the terms it contains.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct OpScore {
    /// Sum of the available terms.
    pub value: f64,
    /// Names of the terms included (`psnr`, `ssim`, `lpips`, `oiqe`, `fid`, `clipiqa`), in formula order.
    pub terms: Vec<&'static str>,
    /// True when all six terms are present.
    pub complete: bool,
}

/// A term's metric name and its value for a metric value.
type Term = (&'static str, fn(f64) -> f64);

/// The six terms.
const TERMS: [Term; 6] = [
    ("psnr", |v| 0.4 * v / 50.0),
    ("ssim", |v| 0.3 * (v - 0.5) / 0.5),
    ("lpips", |v| 0.4 * (1.0 - v) / 0.4),
    ("oiqe", |v| 0.3 * v),
    ("fid", |v| 0.1 * (100.0 - v) / 100.0),
    ("clipiqa", |v| 0.1 * v),
];

/// O.P. of `inputs`; `None` when no term is available.
pub fn overall_performance(inputs: &OpInputs) -> Option<OpScore> {
    let values = [
        inputs.psnr_db,
        inputs.ssim,
        inputs.lpips,
        inputs.oiqe,
        inputs.fid,
        inputs.clipiqa,
    ];
    let mut value = 0.0;
    let mut terms = Vec::new();
    for ((name, term), v) in TERMS.iter().zip(values) {
        if let Some(v) = v.filter(|v| v.is_finite()) {
            value += term(v);
            terms.push(*name);
        }
    }
    if terms.is_empty() {
        return None;
    }
    let complete = terms.len() == TERMS.len();
    Some(OpScore {
        value,
        terms,
        complete,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_formula_on_fixed_numbers() {
        let inputs = OpInputs {
            psnr_db: Some(25.0),
            ssim: Some(0.8),
            lpips: Some(0.2),
            oiqe: Some(0.5),
            fid: Some(40.0),
            clipiqa: Some(0.6),
        };
        let op = overall_performance(&inputs).unwrap();
        // 0.2 + 0.18 + 0.8 + 0.15 + 0.06 + 0.06
        assert!((op.value - 1.45).abs() < 1e-12, "{}", op.value);
        assert!(op.complete);
        assert_eq!(op.terms, vec!["psnr", "ssim", "lpips", "oiqe", "fid", "clipiqa"]);
    }

    #[test]
    fn missing_terms_are_left_out_not_renormalised() {
        let inputs = OpInputs {
            psnr_db: Some(25.0),
            ssim: Some(0.8),
            lpips: Some(0.2),
            oiqe: Some(0.5),
            fid: None,
            clipiqa: None,
        };
        let op = overall_performance(&inputs).unwrap();
        assert!((op.value - 1.33).abs() < 1e-12, "{}", op.value);
        assert!(!op.complete);
        assert_eq!(op.terms, vec!["psnr", "ssim", "lpips", "oiqe"]);
        assert!(overall_performance(&OpInputs::default()).is_none());
    }
}
