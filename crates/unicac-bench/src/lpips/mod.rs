//! LPIPS (Zhang et al. 2018), AlexNet backbone, v0.1 linear heads: pyiqa's default `lpips`.
//!
//! The network runs through onnxruntime: [`lpips_alex_graph`] builds its ONNX graph from the converted
//! weights (`CACHE/weights/lpips/alexnet.npz`, see [`fetch`]) with the crate's own ONNX messages, so the
//! same engine that runs the restoration models runs the metric and no second inference library is
//! needed. The graph takes `x` (distorted) and `y` (reference), N x 3 x H x W in [0, 1], and computes,
//! as pyiqa's `LPIPS.forward(normalize=True)` does:
//!
//! 1. `2 v - 1`, then the ScalingLayer `(v - shift) / scale` with shift (-0.030, -0.088, -0.188) and
//!    scale (0.458, 0.448, 0.450);
//! 2. torchvision AlexNet `features` up to each ReLU (relu1..relu5: conv 11x11/4 pad 2, max-pool 3/2,
//!    conv 5x5 pad 2, max-pool 3/2, three conv 3x3 pad 1);
//! 3. per layer: unit-normalise over channels (`v / (sqrt(sum v^2) + 1e-10)`), squared difference,
//!    the 1x1 linear head (no bias), spatial mean;
//! 4. the sum over the 5 layers: output `lpips`, N x 1 x 1 x 1.

pub mod fetch;
pub mod pickle;

use std::path::Path;

use unicac_image::Planar;

use crate::error::{BenchError, Result};
use crate::npz;
use crate::onnx::builder::{float_tensor, image_dims, Attr, Dim, GraphBuilder};
use crate::runtime::{Runtime, Session, Tensor};

const SHIFT: [f32; 3] = [-0.030, -0.088, -0.188];
const SCALE: [f32; 3] = [0.458, 0.448, 0.450];
const NORM_EPS: f32 = 1e-10;

/// AlexNet's five convolutions: (kernel, stride, padding, max-pool before it).
const ALEX_CONVS: [(i64, i64, i64, bool); 5] = [
    (11, 4, 2, false),
    (5, 1, 2, true),
    (3, 1, 1, true),
    (3, 1, 1, false),
    (3, 1, 1, false),
];

/// The LPIPS-alex ONNX graph from the arrays of `alexnet.npz`.
pub fn lpips_alex_graph(
    weights: &std::collections::BTreeMap<String, npz::NamedArray>,
    path: &Path,
) -> Result<Vec<u8>> {
    let get = |name: &str| {
        weights.get(name).ok_or_else(|| BenchError::Weights {
            path: path.to_path_buf(),
            why: format!("no array `{name}`; run `unicac weights fetch lpips` again"),
        })
    };
    let mut g = GraphBuilder::new("lpips_alex_v0.1");
    g.input("x", &image_dims(3)).input("y", &image_dims(3));
    g.output(
        "lpips",
        &[Dim::Named("N"), Dim::Fixed(1), Dim::Fixed(1), Dim::Fixed(1)],
    );
    let a: Vec<f32> = SCALE.iter().map(|s| 2.0 / s).collect();
    let b: Vec<f32> = SHIFT.iter().zip(&SCALE).map(|(sh, s)| (-1.0 - sh) / s).collect();
    g.initializer(float_tensor("scale_a", &[1, 3, 1, 1], &a));
    g.initializer(float_tensor("scale_b", &[1, 3, 1, 1], &b));
    g.node("Concat", &["x", "y"], &["xy"], &[("axis", Attr::Int(0))]);
    g.node("Mul", &["xy", "scale_a"], &["xy_a"], &[]);
    g.node("Add", &["xy_a", "scale_b"], &["h_in"], &[]);
    let mut current = "h_in".to_string();
    let mut layer_scores = Vec::new();
    for (i, (k, stride, pad, pool)) in ALEX_CONVS.iter().enumerate() {
        if *pool {
            let pooled = format!("pool{i}");
            g.node(
                "MaxPool",
                &[&current],
                &[&pooled],
                &[
                    ("kernel_shape", Attr::Ints(vec![3, 3])),
                    ("strides", Attr::Ints(vec![2, 2])),
                ],
            );
            current = pooled;
        }
        let (w, bias) = (get(&format!("conv{i}.weight"))?, get(&format!("conv{i}.bias"))?);
        if w.shape.len() != 4 || w.shape[2] != *k as usize || bias.shape != [w.shape[0]] {
            return Err(BenchError::Weights {
                path: path.to_path_buf(),
                why: format!("conv{i} has shapes {:?} / {:?}", w.shape, bias.shape),
            });
        }
        let dims: Vec<i64> = w.shape.iter().map(|&d| d as i64).collect();
        g.initializer(float_tensor(&format!("conv{i}.weight"), &dims, &w.data));
        g.initializer(float_tensor(&format!("conv{i}.bias"), &[dims[0]], &bias.data));
        let (conv, relu) = (format!("conv{i}"), format!("relu{i}"));
        g.node(
            "Conv",
            &[&current, &format!("conv{i}.weight"), &format!("conv{i}.bias")],
            &[&conv],
            &[
                ("kernel_shape", Attr::Ints(vec![*k, *k])),
                ("strides", Attr::Ints(vec![*stride, *stride])),
                ("pads", Attr::Ints(vec![*pad; 4])),
            ],
        );
        g.node("Relu", &[&conv], &[&relu], &[]);
        current = relu.clone();
        layer_scores.push(distance_head(
            &mut g,
            &relu,
            i,
            get(&format!("lin{i}.weight"))?,
            dims[0],
            path,
        )?);
    }
    let names: Vec<&str> = layer_scores.iter().map(String::as_str).collect();
    g.node("Sum", &names, &["lpips"], &[]);
    Ok(g.to_bytes())
}

/// Per-layer LPIPS term of the features `feature` (the 2N batch: distorted then reference).
fn distance_head(
    g: &mut GraphBuilder,
    feature: &str,
    i: usize,
    lin: &npz::NamedArray,
    channels: i64,
    path: &Path,
) -> Result<String> {
    if lin.shape != [1, channels as usize, 1, 1] {
        return Err(BenchError::Weights {
            path: path.to_path_buf(),
            why: format!(
                "lin{i}.weight has shape {:?}, expected [1, {channels}, 1, 1]",
                lin.shape
            ),
        });
    }
    let n = |s: &str| format!("{s}{i}");
    g.node(
        "ReduceSumSquare",
        &[feature],
        &[&n("sq")],
        &[("axes", Attr::Ints(vec![1])), ("keepdims", Attr::Int(1))],
    );
    g.node("Sqrt", &[&n("sq")], &[&n("norm")], &[]);
    g.initializer(float_tensor(&n("eps"), &[], &[NORM_EPS]));
    g.node("Add", &[&n("norm"), &n("eps")], &[&n("norm_eps")], &[]);
    g.node("Div", &[feature, &n("norm_eps")], &[&n("unit")], &[]);
    g.node(
        "Split",
        &[&n("unit")],
        &[&n("fx"), &n("fy")],
        &[("axis", Attr::Int(0))],
    );
    g.node("Sub", &[&n("fx"), &n("fy")], &[&n("diff")], &[]);
    g.node("Mul", &[&n("diff"), &n("diff")], &[&n("diff2")], &[]);
    g.initializer(float_tensor(&n("lin.weight"), &[1, channels, 1, 1], &lin.data));
    g.node(
        "Conv",
        &[&n("diff2"), &n("lin.weight")],
        &[&n("lin")],
        &[("kernel_shape", Attr::Ints(vec![1, 1]))],
    );
    g.node(
        "ReduceMean",
        &[&n("lin")],
        &[&n("score")],
        &[("axes", Attr::Ints(vec![2, 3])), ("keepdims", Attr::Int(1))],
    );
    Ok(n("score"))
}

/// LPIPS-alex through onnxruntime.
#[derive(Debug)]
pub struct Lpips {
    session: Session,
}

impl Lpips {
    /// Loads `alexnet.npz` from the LPIPS weights folder of `cache_root`.
    pub fn load(runtime: &Runtime, cache_root: &Path, threads: usize) -> Result<Lpips> {
        let path = fetch::npz_path(cache_root, &fetch::ALEXNET);
        if !path.is_file() {
            return Err(BenchError::Weights {
                path,
                why: "LPIPS weights are not installed; run `unicac weights fetch lpips` once".into(),
            });
        }
        let weights = npz::read(&path)?;
        let graph = lpips_alex_graph(&weights, &path)?;
        Ok(Lpips {
            session: runtime.session(&graph, threads, "the LPIPS network")?,
        })
    }

    /// LPIPS of `image` against `reference` (RGB in [0, 1], same size, at least 32 x 32 px).
    pub fn distance(&mut self, image: &Planar, reference: &Planar) -> Result<f64> {
        if image.channels != 3
            || (image.width, image.height, image.channels)
                != (reference.width, reference.height, reference.channels)
        {
            return Err(BenchError::InvalidInput(format!(
                "LPIPS needs two RGB images of one size, got {}x{}x{} and {}x{}x{}",
                image.width,
                image.height,
                image.channels,
                reference.width,
                reference.height,
                reference.channels
            )));
        }
        if image.width < 32 || image.height < 32 {
            return Err(BenchError::InvalidInput(format!(
                "LPIPS needs at least 32 x 32 px, got {}x{}",
                image.width, image.height
            )));
        }
        let tensor = |p: &Planar| Tensor {
            shape: vec![1, 3, p.height, p.width],
            data: p.data.clone(),
        };
        let out = self
            .session
            .run(vec![("x", tensor(image)), ("y", tensor(reference))], &["lpips"])?;
        Ok(out[0].data[0] as f64)
    }
}
