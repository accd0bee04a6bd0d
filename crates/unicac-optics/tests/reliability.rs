//! Issue 16: inputs that used to give a confident wrong answer (rc 0) are errors naming the cause.

use unicac_optics::{builtin, Lens};

#[test]
fn first_order_data_that_overflows_is_an_error_not_nan() {
    let mut spec = builtin::spec("cooke_triplet").unwrap();
    spec.surfaces[0].radius_mm = None;
    spec.surfaces[0].curvature_per_mm = Some(1e308);
    let outcome = Lens::from_spec(&spec).and_then(|lens| lens.first_order());
    let message = outcome
        .expect_err("NaN first-order data must not be reported")
        .to_string();
    assert!(
        message.contains("paraxial") && (message.contains("NaN") || message.contains("inf")),
        "{message}"
    );
}
