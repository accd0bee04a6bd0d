//! Shared by the GPU test binaries: a device or a printed reason to skip.

#![allow(dead_code)]

use std::sync::{Arc, OnceLock};
use unicac_gpu::{GpuContext, GpuTracer, Precision};

/// The GPU context, or None with the reason printed. With `CI` set a missing adapter fails the run:
/// CI installs lavapipe, so an absent device there is a broken setup, not a reason to skip.
pub fn gpu_or_skip() -> Option<Arc<GpuContext>> {
    static CONTEXT: OnceLock<Result<Arc<GpuContext>, String>> = OnceLock::new();
    let context = CONTEXT.get_or_init(|| GpuContext::new().map(Arc::new).map_err(|e| e.to_string()));
    match context {
        Ok(context) => Some(context.clone()),
        Err(reason) if std::env::var_os("CI").is_some() => {
            panic!("CI is set and the GPU tests need an adapter: {reason}")
        }
        Err(reason) => {
            skip(reason);
            None
        }
    }
}

/// Says why, once per test binary, on the real stderr: the harness captures `eprintln!` of passing
/// tests, and a silent skip would read as a pass.
fn skip(reason: &str) {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "skipping GPU tests: {reason}");
    });
}

/// A tracer of `precision`, None (skip) without an adapter or, for f64, without SHADER_F64 outside CI.
pub fn tracer_or_skip(precision: Precision) -> Option<GpuTracer> {
    let context = gpu_or_skip()?;
    match GpuTracer::new(context, precision) {
        Ok(tracer) => Some(tracer),
        Err(e) if std::env::var_os("CI").is_some() => panic!("{e}"),
        Err(e) => {
            skip(&e.to_string());
            None
        }
    }
}

pub fn lens(name: &str) -> unicac_optics::Lens {
    unicac_optics::builtin::lens(name).unwrap()
}

pub fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}
