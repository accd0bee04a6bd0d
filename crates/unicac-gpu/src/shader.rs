//! The WGSL source of one precision: a generated prelude (`alias Real = f32;` or f64, and the
//! precision's constants from `Real`) followed by shaders/counter.wgsl, common.wgsl, trace.wgsl and psf.wgsl, all
//! embedded at compile time. One text, two precisions: the kernels write literals as abstract numbers
//! (`Real(0.5)`), which WGSL converts to whichever type `Real` names.

use crate::real::{Precision, Real};

pub const COUNTER: &str = include_str!("../../../shaders/counter.wgsl");
pub const COMMON: &str = include_str!("../../../shaders/common.wgsl");
pub const TRACE: &str = include_str!("../../../shaders/trace.wgsl");
pub const PSF: &str = include_str!("../../../shaders/psf.wgsl");

/// Entry points.
pub const TRACE_ENTRY: &str = "trace_rays";
pub const PSF_ENTRY: &str = "accumulate_psf";
/// Invocations per workgroup (`@workgroup_size(64)` in the kernels).
pub const WORKGROUP: u32 = 64;

fn prelude<R: Real>() -> String {
    // `{:e}` prints the shortest text that reads back as the same value.
    format!(
        "alias Real = {ty};\n\
         const EPSILON: Real = Real({eps:e});\n\
         const REAL_MAX: Real = Real({max:e});\n\
         const REAL_MIN_POSITIVE: Real = Real({min:e});\n\
         const NEWTON_TOLERANCE: Real = Real({tol:e});\n\
         const GUARD: Real = Real({guard:e});\n",
        ty = R::PRECISION.wgsl_type(),
        eps = R::EPSILON,
        max = R::MAX,
        min = R::MIN_POSITIVE,
        tol = R::newton_tolerance(),
        guard = R::guard(),
    )
}

/// The complete module for one precision.
pub fn source(precision: Precision) -> String {
    let prelude = match precision {
        Precision::F32 => prelude::<f32>(),
        Precision::F64 => prelude::<f64>(),
    };
    [prelude.as_str(), COUNTER, COMMON, TRACE, PSF].join("\n")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn validate(precision: Precision) -> Result<(), String> {
        let text = source(precision);
        let module = naga::front::wgsl::parse_str(&text).map_err(|e| e.emit_to_string(&text))?;
        // Exactly what wgpu asks of the device: f64 only for the f64 variant.
        let capabilities = match precision {
            Precision::F32 => naga::valid::Capabilities::empty(),
            Precision::F64 => naga::valid::Capabilities::FLOAT64,
        };
        naga::valid::Validator::new(naga::valid::ValidationFlags::all(), capabilities)
            .validate(&module)
            .map_err(|e| e.emit_to_string(&text))?;
        Ok(())
    }

    #[test]
    fn kernels_validate_with_naga_in_both_precisions() {
        for precision in [Precision::F32, Precision::F64] {
            if let Err(message) = validate(precision) {
                panic!("{precision} kernels do not validate:\n{message}");
            }
        }
    }

    #[test]
    fn prelude_constants_read_back_exactly() {
        let text = prelude::<f32>();
        assert!(text.contains("alias Real = f32;"), "{text}");
        assert!(text.contains(&format!("{:e}", f32::EPSILON)));
        assert_eq!(format!("{:e}", f32::MAX).parse::<f32>().unwrap(), f32::MAX);
    }

    #[test]
    fn shader_tolerances_are_the_cpu_tracers() {
        use unicac_trace::surface::{GRAZING_N, MAX_NEWTON_ITERATIONS};
        let newton = format!("const MAX_NEWTON_ITERATIONS: u32 = {MAX_NEWTON_ITERATIONS}u;");
        assert!(COMMON.contains(&newton), "common.wgsl lacks `{newton}`");
        let grazing = format!("const GRAZING_N: Real = Real({GRAZING_N:e});");
        assert!(COMMON.contains(&grazing), "common.wgsl lacks `{grazing}`");
    }
}
