//! Predicates for `#[serde(skip_serializing_if = ...)]`: a field at its default is left out, so files
//! written before the field existed keep their bytes.

/// A number that is exactly 0 (an x field angle of a y-axis field, a centred surface's decentre).
pub fn is_zero(value: &f64) -> bool {
    *value == 0.0
}
