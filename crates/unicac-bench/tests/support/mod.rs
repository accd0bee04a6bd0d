//! Shared test support: onnxruntime or a printed skip, tiny ONNX models built with the crate's graph
//! builder (no binary fixtures), and a tiny dataset following docs/dataset.md.

#![allow(dead_code)]

pub mod dataset;

use unicac_image::Planar;
use unicac_onnx::builder::{float_tensor, image_dims, Attr, GraphBuilder};
use unicac_onnx::runtime::Runtime;

/// onnxruntime, or None with the reason printed once. With `CI` set a missing library fails the run:
/// CI installs the onnxruntime wheel and exports ORT_DYLIB_PATH, so its absence there is a broken setup.
pub fn ort_or_skip() -> Option<&'static Runtime> {
    match Runtime::load() {
        Ok(runtime) => Some(runtime),
        Err(reason) if std::env::var_os("CI").is_some() => {
            panic!("CI is set and these tests need onnxruntime: {reason}")
        }
        Err(reason) => {
            skip(&reason.to_string());
            None
        }
    }
}

/// Says why, once per test binary, on the real stderr (the harness captures `eprintln!`).
pub fn skip(reason: &str) {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "skipping onnxruntime tests: {reason}");
    });
}

/// Deterministic pseudo-random values in [-scale, scale] (a 64-bit LCG).
pub fn values(count: usize, seed: u64, scale: f32) -> Vec<f32> {
    let mut state = seed
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (0..count)
        .map(|_| {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0) * scale
        })
        .collect()
}

/// `restored = lq`.
pub fn identity_model() -> Vec<u8> {
    let mut g = GraphBuilder::new("identity");
    g.input("lq", &image_dims(3)).output("restored", &image_dims(3));
    g.node("Identity", &["lq"], &["restored"], &[]);
    g.metadata("unicac_contract", "1").metadata("inputs", "lq");
    g.to_bytes()
}

/// A test-only model that ignores its input's values and returns `gt` (which it holds as a constant).
pub fn gt_model(gt: &Planar) -> Vec<u8> {
    let mut g = GraphBuilder::new("returns_gt");
    g.input("lq", &image_dims(3)).output("restored", &image_dims(3));
    g.initializer(float_tensor("zero", &[1], &[0.0]));
    g.initializer(float_tensor(
        "gt",
        &[1, 3, gt.height as i64, gt.width as i64],
        &gt.data,
    ));
    g.node("Mul", &["lq", "zero"], &["nothing"], &[]);
    g.node("Add", &["nothing", "gt"], &["restored"], &[]);
    g.to_bytes()
}

/// A model that returns flat mid-grey whatever its input: every edge destroyed.
pub fn flat_model() -> Vec<u8> {
    let mut g = GraphBuilder::new("flat");
    g.input("lq", &image_dims(3)).output("restored", &image_dims(3));
    g.initializer(float_tensor("zero", &[1], &[0.0]));
    g.initializer(float_tensor("grey", &[1], &[0.5]));
    g.node("Mul", &["lq", "zero"], &["nothing"], &[]);
    g.node("Add", &["nothing", "grey"], &["restored"], &[]);
    g.metadata("unicac_contract", "1").metadata("inputs", "lq");
    g.to_bytes()
}

/// Two 3x3 convolutions (receptive-field radius 2 px) over `lq` and, with `with_fov`, the FoV map.
pub fn conv_model(with_fov: bool) -> Vec<u8> {
    let mut g = GraphBuilder::new("conv2");
    g.input("lq", &image_dims(3));
    let mut source = "lq";
    let mut channels = 3;
    if with_fov {
        g.input("fov", &image_dims(2));
        g.node("Concat", &["lq", "fov"], &["x"], &[("axis", Attr::Int(1))]);
        source = "x";
        channels = 5;
    }
    g.output("restored", &image_dims(3));
    g.initializer(float_tensor(
        "w1",
        &[4, channels, 3, 3],
        &values(4 * channels as usize * 9, 1, 0.3),
    ));
    g.initializer(float_tensor("b1", &[4], &values(4, 2, 0.1)));
    g.initializer(float_tensor("w2", &[3, 4, 3, 3], &values(3 * 4 * 9, 3, 0.3)));
    g.initializer(float_tensor("b2", &[3], &values(3, 4, 0.1)));
    let pads = ("pads", Attr::Ints(vec![1, 1, 1, 1]));
    let kernel = ("kernel_shape", Attr::Ints(vec![3, 3]));
    g.node(
        "Conv",
        &[source, "w1", "b1"],
        &["h1"],
        &[kernel.clone(), pads.clone()],
    );
    g.node("Relu", &["h1"], &["h1r"], &[]);
    g.node("Conv", &["h1r", "w2", "b2"], &["restored"], &[kernel, pads]);
    g.to_bytes()
}

/// An identity model whose output is named `out` (breaks the contract).
pub fn wrong_output_model() -> Vec<u8> {
    let mut g = GraphBuilder::new("bad");
    g.input("lq", &image_dims(3)).output("out", &image_dims(3));
    g.node("Identity", &["lq"], &["out"], &[]);
    g.to_bytes()
}

/// An identity model whose input is named `image` (breaks the contract).
pub fn wrong_input_model() -> Vec<u8> {
    let mut g = GraphBuilder::new("bad");
    g.input("image", &image_dims(3))
        .output("restored", &image_dims(3));
    g.node("Identity", &["image"], &["restored"], &[]);
    g.to_bytes()
}

/// A model that asks for the PSF-feature map.
pub fn psf_model() -> Vec<u8> {
    let mut g = GraphBuilder::new("psf");
    g.input("lq", &image_dims(3))
        .input("psf", &image_dims(15))
        .output("restored", &image_dims(3));
    g.node("Identity", &["lq"], &["restored"], &[]);
    g.to_bytes()
}

/// A contract-2 model: `restored = wiener + 0 x mean(psf_code)`; the sum only broadcasts when the
/// code map has the image's height and width, and onnxruntime checks its 50 channels.
pub fn wiener_code_model(basis_sha256: &str, contract: &str) -> Vec<u8> {
    let mut g = GraphBuilder::new("wiener_code");
    g.input("lq", &image_dims(3))
        .input("psf_code", &image_dims(unicac_dataset::PSF_CODE_CHANNELS as i64))
        .input("wiener", &image_dims(3))
        .output("restored", &image_dims(3));
    g.initializer(float_tensor("zero", &[1], &[0.0]));
    g.node(
        "ReduceMean",
        &["psf_code"],
        &["code_mean"],
        &[("axes", Attr::Ints(vec![1])), ("keepdims", Attr::Int(1))],
    );
    g.node("Mul", &["code_mean", "zero"], &["nothing"], &[]);
    g.node("Add", &["wiener", "nothing"], &["restored"], &[]);
    g.metadata("unicac_contract", contract)
        .metadata("inputs", "lq,psf_code,wiener")
        .metadata("psf_basis_sha256", basis_sha256);
    g.to_bytes()
}

/// A scratch folder under the target directory, emptied first.
pub fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}
