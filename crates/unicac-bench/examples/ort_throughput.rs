//! Images per second of ONNX restoration models through onnxruntime (the engine `unicac bench` uses), at
//! 1 x 3 x 256 x 256 (docs/performance.md): session creation, one warm-up, then the median of 20 runs,
//! with the contract's inputs (zeros for `fov` / `psf` maps when declared).
//!
//!     ORT_DYLIB_PATH=... cargo run --release -p unicac-bench --example ort_throughput -- [--threads 2] MODEL.onnx...

use std::time::Instant;

use unicac_onnx::contract::load_model;
use unicac_onnx::runtime::{Runtime, Tensor};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut threads = 2;
    if let Some(i) = args.iter().position(|a| a == "--threads") {
        threads = args.get(i + 1).ok_or("--threads needs a value")?.parse()?;
        args.drain(i..i + 2);
    }
    let runtime = Runtime::load()?;
    for path in args {
        let (contract, model, bytes) = load_model(path.as_ref())?;
        let start = Instant::now();
        let mut session = runtime.session(&bytes, threads, &path)?;
        let load_ms = start.elapsed().as_secs_f64() * 1e3;
        let side = 256;
        let inputs = || {
            contract
                .inputs
                .iter()
                .map(|i| {
                    let c = i.channels();
                    (
                        i.name(),
                        Tensor {
                            shape: vec![1, c, side, side],
                            data: vec![0.5; c * side * side],
                        },
                    )
                })
                .collect::<Vec<_>>()
        };
        session.run(inputs(), &["restored"])?;
        let mut times: Vec<f64> = (0..20)
            .map(|_| {
                let t = Instant::now();
                session
                    .run(inputs(), &["restored"])
                    .map(|_| t.elapsed().as_secs_f64())
            })
            .collect::<Result<_, _>>()?;
        times.sort_by(f64::total_cmp);
        let median = times[times.len() / 2];
        let params = unicac_onnx::cost::parameter_count(&model);
        println!(
            "{path}: params {params}, session {load_ms:.0} ms, median {:.1} ms = {:.1} images/s (1x3x256x256, {threads} threads)",
            median * 1e3,
            1.0 / median
        );
    }
    Ok(())
}
