//! CLIP-IQA (Wang, Chan, Loy 2023), pyiqa's `clipiqa`: the probability that CLIP matches an image to
//! "Good photo." rather than "Bad photo.".
//!
//! No registry ships the CLIP weights, so they are user-supplied in `WEIGHTS_DIR/clipiqa/`:
//!
//! - `image_encoder.onnx`: CLIP's image tower, one float32 input N x 3 x H x W in [0, 1] (RGB; CLIP's
//!   mean/std normalisation inside the graph, as pyiqa applies it before `encode_image`), one output
//!   N x D, the image embedding;
//! - `prompts.npy`: float32 [2P, D], the text embeddings of P antonym prompt pairs, positive then
//!   negative for each pair (pyiqa's default is the one pair "Good photo." / "Bad photo.").
//!
//! Score, as pyiqa: cosine similarities of the image embedding with each prompt, logits = 100 x cosine
//! (CLIP's logit scale), softmax within each pair, the positive prompt's probability averaged over the
//! pairs. Without the files ClipIQA is unavailable (null).

use std::path::{Path, PathBuf};

use unicac_image::Planar;

use crate::error::{LearnedMetricError, Result};
use unicac_onnx::runtime::{Runtime, Session, Tensor};

pub const CLIPIQA_ENCODER: &str = "clipiqa/image_encoder.onnx";
pub const CLIPIQA_PROMPTS: &str = "clipiqa/prompts.npy";
/// CLIP's logit scale (exp of the trained temperature, 100 in the released models).
const LOGIT_SCALE: f64 = 100.0;

/// The positive prompt's probability, averaged over prompt pairs, for one image embedding.
pub fn clipiqa_score(image: &[f32], prompts: &[Vec<f32>]) -> f64 {
    let norm = |v: &[f32]| v.iter().map(|&x| (x as f64) * (x as f64)).sum::<f64>().sqrt();
    let cosine = |p: &[f32]| {
        let dot: f64 = image.iter().zip(p).map(|(&a, &b)| a as f64 * b as f64).sum();
        dot / (norm(image) * norm(p)).max(1e-12)
    };
    let pairs = prompts.len() / 2;
    let total: f64 = (0..pairs)
        .map(|k| {
            let (good, bad) = (
                LOGIT_SCALE * cosine(&prompts[2 * k]),
                LOGIT_SCALE * cosine(&prompts[2 * k + 1]),
            );
            // softmax([good, bad])[0], written to avoid overflow
            1.0 / (1.0 + (bad - good).exp())
        })
        .sum();
    total / pairs as f64
}

/// The user-supplied CLIP image tower and prompt embeddings.
#[derive(Debug)]
pub struct ClipIqa {
    session: Session,
    input: String,
    output: String,
    prompts: Vec<Vec<f32>>,
    pub path: PathBuf,
}

impl ClipIqa {
    /// Loads the files from `weights_dir`; `Ok(None)` when either is absent.
    pub fn load(runtime: &Runtime, weights_dir: &Path, threads: usize) -> Result<Option<ClipIqa>> {
        let (path, prompts_path) = (
            weights_dir.join(CLIPIQA_ENCODER),
            weights_dir.join(CLIPIQA_PROMPTS),
        );
        if !path.is_file() || !prompts_path.is_file() {
            return Ok(None);
        }
        let (shape, data) =
            unicac_dataset::npy::read_f32(&prompts_path).map_err(|e| LearnedMetricError::Weights {
                path: prompts_path.clone(),
                why: e.to_string(),
            })?;
        if shape.len() != 2 || shape[0] == 0 || shape[0] % 2 != 0 {
            return Err(LearnedMetricError::Weights {
                path: prompts_path,
                why: format!("shape {shape:?} is not [2P, D]"),
            });
        }
        let prompts: Vec<Vec<f32>> = data.chunks_exact(shape[1]).map(<[f32]>::to_vec).collect();
        let bytes = unicac_onnx::contract::read_model_bytes(&path)?;
        let (input, output) = crate::fid::io_names(&path, &bytes)?;
        let session = runtime.session(&bytes, threads, &path.display().to_string())?;
        Ok(Some(ClipIqa {
            session,
            input,
            output,
            prompts,
            path,
        }))
    }

    /// ClipIQA of one RGB image in [0, 1].
    pub fn score(&mut self, image: &Planar) -> Result<f64> {
        let tensor = Tensor {
            shape: vec![1, image.channels, image.height, image.width],
            data: image.data.clone(),
        };
        let out = self.session.run(vec![(&self.input, tensor)], &[&self.output])?;
        let embedding = &out[0].data;
        if embedding.len() != self.prompts[0].len() {
            return Err(LearnedMetricError::Weights {
                path: self.path.clone(),
                why: format!(
                    "image embedding of {} values, prompt embeddings of {}",
                    embedding.len(),
                    self.prompts[0].len()
                ),
            });
        }
        Ok(clipiqa_score(embedding, &self.prompts))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn softmax_of_scaled_cosines() {
        // Image along the good prompt: cos 1 vs 0 -> 1 / (1 + e^-100).
        let good = vec![1.0, 0.0];
        let bad = vec![0.0, 1.0];
        let s = clipiqa_score(&[2.0, 0.0], &[good.clone(), bad.clone()]);
        assert!((s - 1.0 / (1.0 + (-100.0f64).exp())).abs() < 1e-15);
        // Halfway between: 0.5; two pairs average.
        let s = clipiqa_score(&[1.0, 1.0], &[good.clone(), bad.clone(), bad, good]);
        assert!((s - 0.5).abs() < 1e-12);
    }
}
