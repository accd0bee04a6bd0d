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
//!    the 1x1 linear head (no bias): outputs `d0` .. `d4`, N x 1 x h_i x w_i;
//! 4. here, in f64: the spatial mean of each map, summed over the 5 layers.
//!
//! Large images go through the network in tiles ([`Lpips::distance`]), exactly: every layer's feature
//! at stride s (4, 8, 16, 16, 16 px) is anchored at s times its index, and relu5's features see 66 px
//! before and 96 px after their anchor. A tile starts on a multiple of 16 px, so its features are the
//! image's own with their indices shifted; it owns the features anchored in its core (cores partition the
//! image) and extends [`TILE_MARGIN_PX`] beyond it, so no owned feature sees the tile's padding. The
//! owned map values are summed over the tiles and divided by the whole image's map sizes: the same sums
//! as one pass, in another order (tested to 1e-6). Memory is then that of one tile, not of the image
//! (~70 B per pixel for the whole 24 MP image before).

pub mod fetch;
pub mod pickle;

use std::path::Path;

use unicac_image::Planar;

use crate::error::{LearnedMetricError, Result};
use crate::npz;
use unicac_onnx::builder::{float_tensor, image_dims, Attr, Dim, GraphBuilder};
use unicac_onnx::runtime::{Runtime, Session, Tensor};

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

/// Side of a tile's core (px, a multiple of 16): images up to this plus two margins go in one pass.
pub const TILE_CORE_PX: usize = 1024;
/// How far a tile reaches beyond its core (px, a multiple of 16, at least relu5's 96 px reach).
pub const TILE_MARGIN_PX: usize = 96;
/// The anchor spacing (stride in input px) of each layer's features.
const LAYER_STRIDE_PX: [usize; 5] = [4, 8, 16, 16, 16];
/// The per-layer map outputs.
const LAYER_OUTPUTS: [&str; 5] = ["d0", "d1", "d2", "d3", "d4"];
const LAYER_ROWS: [&str; 5] = ["h0", "h1", "h2", "h3", "h4"];
const LAYER_COLUMNS: [&str; 5] = ["w0", "w1", "w2", "w3", "w4"];

/// The length of each layer's map along an image axis of `len` px (at least 32): conv 11/4 pad 2, then
/// max-pools 3/2 without padding before layers 2 and 3; the other convolutions keep the size.
fn layer_lengths(len: usize) -> [usize; 5] {
    let conv1 = (len + 4 - 11) / 4 + 1;
    let pool1 = (conv1 - 3) / 2 + 1;
    let pool2 = (pool1 - 3) / 2 + 1;
    [conv1, pool1, pool2, pool2, pool2]
}

/// The tiles along an axis of `len` px with cores of `core` px (a multiple of 16): (core start, core
/// end, tile start, tile end).
fn axis_tiles(len: usize, core: usize) -> Vec<[usize; 4]> {
    if len <= core + 2 * TILE_MARGIN_PX {
        return vec![[0, len, 0, len]];
    }
    (0..len.div_ceil(core))
        .map(|i| {
            let (c0, c1) = (i * core, ((i + 1) * core).min(len));
            [
                c0,
                c1,
                c0.saturating_sub(TILE_MARGIN_PX),
                (c1 + TILE_MARGIN_PX).min(len),
            ]
        })
        .collect()
}

/// The LPIPS-alex ONNX graph from the arrays of `alexnet.npz`.
pub fn lpips_alex_graph(
    weights: &std::collections::BTreeMap<String, npz::NamedArray>,
    path: &Path,
) -> Result<Vec<u8>> {
    let get = |name: &str| {
        weights.get(name).ok_or_else(|| LearnedMetricError::Weights {
            path: path.to_path_buf(),
            why: format!("no array `{name}`; run `unicac weights fetch lpips` again"),
        })
    };
    let mut g = GraphBuilder::new("lpips_alex_v0.1");
    g.input("x", &image_dims(3)).input("y", &image_dims(3));
    for i in 0..5 {
        g.output(
            LAYER_OUTPUTS[i],
            &[
                Dim::Named("N"),
                Dim::Fixed(1),
                Dim::Named(LAYER_ROWS[i]),
                Dim::Named(LAYER_COLUMNS[i]),
            ],
        );
    }
    let a: Vec<f32> = SCALE.iter().map(|s| 2.0 / s).collect();
    let b: Vec<f32> = SHIFT.iter().zip(&SCALE).map(|(sh, s)| (-1.0 - sh) / s).collect();
    g.initializer(float_tensor("scale_a", &[1, 3, 1, 1], &a));
    g.initializer(float_tensor("scale_b", &[1, 3, 1, 1], &b));
    g.node("Concat", &["x", "y"], &["xy"], &[("axis", Attr::Int(0))]);
    g.node("Mul", &["xy", "scale_a"], &["xy_a"], &[]);
    g.node("Add", &["xy_a", "scale_b"], &["h_in"], &[]);
    let mut current = "h_in".to_string();
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
            return Err(LearnedMetricError::Weights {
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
        distance_head(&mut g, &relu, i, get(&format!("lin{i}.weight"))?, dims[0], path)?;
    }
    Ok(g.to_bytes())
}

/// Per-layer LPIPS map (output `d{i}`) of the features `feature` (the 2N batch: distorted then
/// reference).
fn distance_head(
    g: &mut GraphBuilder,
    feature: &str,
    i: usize,
    lin: &npz::NamedArray,
    channels: i64,
    path: &Path,
) -> Result<()> {
    if lin.shape != [1, channels as usize, 1, 1] {
        return Err(LearnedMetricError::Weights {
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
        &[LAYER_OUTPUTS[i]],
        &[("kernel_shape", Attr::Ints(vec![1, 1]))],
    );
    Ok(())
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
            return Err(LearnedMetricError::Weights {
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
            return Err(LearnedMetricError::InvalidInput(format!(
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
            return Err(LearnedMetricError::InvalidInput(format!(
                "LPIPS needs at least 32 x 32 px, got {}x{}",
                image.width, image.height
            )));
        }
        self.distance_in_tiles(image, reference, TILE_CORE_PX)
    }

    /// [`Lpips::distance`] with tile cores of `core_px` (a multiple of 16; see the module note).
    pub fn distance_in_tiles(&mut self, image: &Planar, reference: &Planar, core_px: usize) -> Result<f64> {
        assert!(
            core_px >= 16 && core_px.is_multiple_of(16),
            "tile cores are multiples of 16 px"
        );
        let (rows_full, columns_full) = (layer_lengths(image.height), layer_lengths(image.width));
        let mut sums = [0.0f64; 5];
        for [cy0, cy1, y0, y1] in axis_tiles(image.height, core_px) {
            for [cx0, cx1, x0, x1] in axis_tiles(image.width, core_px) {
                let crop = |p: &Planar| {
                    let mut data = Vec::with_capacity(3 * (y1 - y0) * (x1 - x0));
                    for c in 0..3 {
                        let plane = p.plane(c);
                        for y in y0..y1 {
                            data.extend_from_slice(&plane[y * p.width + x0..y * p.width + x1]);
                        }
                    }
                    Tensor {
                        shape: vec![1, 3, y1 - y0, x1 - x0],
                        data,
                    }
                };
                let maps = self
                    .session
                    .run(vec![("x", crop(image)), ("y", crop(reference))], &LAYER_OUTPUTS)?;
                for (i, map) in maps.iter().enumerate() {
                    let s = LAYER_STRIDE_PX[i];
                    let (h, w) = (map.shape[2], map.shape[3]);
                    // Owned: anchored in the core, inside the whole image's map (full index = tile
                    // index + tile start / stride).
                    let rows = cy0 / s..cy1.div_ceil(s).min(rows_full[i]);
                    let columns = cx0 / s..cx1.div_ceil(s).min(columns_full[i]);
                    for row in rows {
                        let r = row - y0 / s;
                        if r >= h {
                            break;
                        }
                        let line = &map.data[r * w..(r + 1) * w];
                        for column in columns.clone() {
                            let c = column - x0 / s;
                            if c < w {
                                sums[i] += line[c] as f64;
                            }
                        }
                    }
                }
            }
        }
        Ok((0..5)
            .map(|i| sums[i] / (rows_full[i] * columns_full[i]) as f64)
            .sum())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_lengths_follow_alexnets_arithmetic() {
        // 64 px: conv1 (64 + 4 - 11) / 4 + 1 = 15, pool 7, pool 3.
        assert_eq!(layer_lengths(64), [15, 7, 3, 3, 3]);
        assert_eq!(layer_lengths(256), [63, 31, 15, 15, 15]);
    }

    #[test]
    fn tiles_cover_the_axis_with_cores_that_partition_it() {
        assert_eq!(axis_tiles(300, 1024), vec![[0, 300, 0, 300]]);
        let tiles = axis_tiles(2500, 1024);
        assert_eq!(
            tiles,
            vec![
                [0, 1024, 0, 1120],
                [1024, 2048, 928, 2144],
                [2048, 2500, 1952, 2500]
            ]
        );
        for [c0, _, t0, _] in tiles {
            assert_eq!((c0 % 16, t0 % 16), (0, 0));
        }
    }
}
