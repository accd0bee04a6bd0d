//! FID (Heusel et al. 2017): the Fréchet distance between Gaussians fitted to the Inception features of
//! the restored images and of their ground truths, per (model, benchmark, level).
//!
//! No package registry ships the FID Inception weights (pytorch-fid, clean-fid and pyiqa download them at
//! run time), so the network is user-supplied: `WEIGHTS_DIR/fid/inception.onnx`, any ONNX graph with one
//! float32 input N x 3 x H x W in [0, 1] (RGB) and one output whose per-image values are the feature
//! vector (N x D, or N x D x 1 x 1); resizing to 299 x 299 and the network's own normalisation belong
//! inside the graph, as in pytorch-fid's `InceptionV3(resize_input=True, normalize_input=True)`, whose
//! ONNX export is such a graph. Without the file FID is unavailable (null), never estimated otherwise.
//!
//! Statistics as pytorch-fid: mean and unbiased covariance (divide by n - 1); distance
//! `|mu1 - mu2|^2 + tr(S1) + tr(S2) - 2 tr((S1 S2)^(1/2))`, with the trace term computed from the
//! symmetric form `tr((S1^(1/2) S2 S1^(1/2))^(1/2))` (same eigenvalues, numerically stable); tiny
//! negative eigenvalues from rounding are clamped to 0.

use std::path::{Path, PathBuf};

use nalgebra::{DMatrix, DVector};
use unicac_image::Planar;

use crate::error::{LearnedMetricError, Result};
use unicac_onnx::runtime::{Runtime, Session, Tensor};

/// The feature network's file inside `--weights-dir`.
pub const FID_NETWORK: &str = "fid/inception.onnx";

/// Mean and covariance of a feature set.
#[derive(Debug, Clone)]
pub struct Gaussian {
    pub mean: DVector<f64>,
    pub covariance: DMatrix<f64>,
}

impl Gaussian {
    /// Fits the mean and unbiased covariance of `features` (one row per image, at least 2 rows).
    pub fn fit(features: &[Vec<f32>]) -> Result<Gaussian> {
        let n = features.len();
        if n < 2 {
            return Err(LearnedMetricError::InvalidInput(format!(
                "FID needs at least 2 images, got {n}"
            )));
        }
        let d = features[0].len();
        if features.iter().any(|f| f.len() != d) {
            return Err(LearnedMetricError::InvalidInput(
                "feature vectors of different lengths".into(),
            ));
        }
        let x = DMatrix::from_fn(n, d, |i, j| features[i][j] as f64);
        let mean = DVector::from_fn(d, |j, _| x.column(j).mean());
        let centred = DMatrix::from_fn(n, d, |i, j| x[(i, j)] - mean[j]);
        let covariance = centred.transpose() * &centred / (n as f64 - 1.0);
        Ok(Gaussian { mean, covariance })
    }
}

/// The principal square root of a symmetric positive semi-definite matrix.
fn sqrt_psd(m: &DMatrix<f64>) -> DMatrix<f64> {
    let eigen = nalgebra::SymmetricEigen::new(m.clone());
    let roots = eigen.eigenvalues.map(|v| v.max(0.0).sqrt());
    &eigen.eigenvectors * DMatrix::from_diagonal(&roots) * eigen.eigenvectors.transpose()
}

/// The Fréchet distance between two Gaussians.
pub fn frechet_distance(a: &Gaussian, b: &Gaussian) -> f64 {
    let diff = &a.mean - &b.mean;
    let root_a = sqrt_psd(&a.covariance);
    let inner = &root_a * &b.covariance * &root_a;
    let inner = (&inner + inner.transpose()) * 0.5;
    let trace_root: f64 = nalgebra::SymmetricEigen::new(inner)
        .eigenvalues
        .iter()
        .map(|v| v.max(0.0).sqrt())
        .sum();
    diff.norm_squared() + a.covariance.trace() + b.covariance.trace() - 2.0 * trace_root
}

/// The user-supplied feature network.
#[derive(Debug)]
pub struct FidNetwork {
    session: Session,
    input: String,
    output: String,
    pub path: PathBuf,
}

/// The name of the first graph input and output of an ONNX file.
pub(crate) fn io_names(path: &Path, bytes: &[u8]) -> Result<(String, String)> {
    let model = unicac_onnx::contract::decode(path, bytes)?;
    let graph = model.graph.expect("decode checked the graph");
    let initializers: Vec<&str> = graph.initializer.iter().map(|t| t.name.as_str()).collect();
    let input = graph
        .input
        .iter()
        .find(|v| !initializers.contains(&v.name.as_str()))
        .map(|v| v.name.clone());
    let output = graph.output.first().map(|v| v.name.clone());
    match (input, output) {
        (Some(i), Some(o)) => Ok((i, o)),
        _ => Err(unicac_onnx::OnnxError::Contract {
            path: path.to_path_buf(),
            why: "a feature network needs one input and one output".into(),
        }
        .into()),
    }
}

impl FidNetwork {
    /// Loads `WEIGHTS_DIR/fid/inception.onnx`; `Ok(None)` when the file is absent.
    pub fn load(runtime: &Runtime, weights_dir: &Path, threads: usize) -> Result<Option<FidNetwork>> {
        let path = weights_dir.join(FID_NETWORK);
        if !path.is_file() {
            return Ok(None);
        }
        let bytes = unicac_onnx::contract::read_model_bytes(&path)?;
        let (input, output) = io_names(&path, &bytes)?;
        let session = runtime.session(&bytes, threads, &path.display().to_string())?;
        Ok(Some(FidNetwork {
            session,
            input,
            output,
            path,
        }))
    }

    /// The feature vector of one RGB image in [0, 1].
    pub fn features(&mut self, image: &Planar) -> Result<Vec<f32>> {
        let tensor = Tensor {
            shape: vec![1, image.channels, image.height, image.width],
            data: image.data.clone(),
        };
        let out = self.session.run(vec![(&self.input, tensor)], &[&self.output])?;
        let features = out.into_iter().next().expect("one output").data;
        if features.iter().any(|v| !v.is_finite()) {
            return Err(LearnedMetricError::InvalidInput(format!(
                "{}: non-finite features",
                self.path.display()
            )));
        }
        Ok(features)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rotation(angle: f64) -> DMatrix<f64> {
        let (s, c) = angle.sin_cos();
        DMatrix::from_row_slice(2, 2, &[c, -s, s, c])
    }

    #[test]
    fn matches_the_closed_form_for_commuting_covariances() {
        // S1 = R diag(4, 1) R^T, S2 = R diag(9, 0.25) R^T: tr sqrt(S1 S2) = sqrt(36) + sqrt(0.25).
        let r = rotation(0.3);
        let s1 = &r * DMatrix::from_diagonal(&DVector::from_vec(vec![4.0, 1.0])) * r.transpose();
        let s2 = &r * DMatrix::from_diagonal(&DVector::from_vec(vec![9.0, 0.25])) * r.transpose();
        let a = Gaussian {
            mean: DVector::from_vec(vec![1.0, 2.0]),
            covariance: s1,
        };
        let b = Gaussian {
            mean: DVector::from_vec(vec![-1.0, 0.5]),
            covariance: s2,
        };
        let expected = (4.0 + 2.25) + (4.0 + 1.0 + 9.0 + 0.25) - 2.0 * (6.0 + 0.5);
        assert!((frechet_distance(&a, &b) - expected).abs() < 1e-10);
        assert!(frechet_distance(&a, &a).abs() < 1e-10);
    }

    #[test]
    fn matches_the_closed_form_for_general_covariances() {
        // Non-commuting 2 x 2 case: tr sqrt(M) = sqrt(tr M + 2 sqrt(det M)) for a 2 x 2 M with real
        // non-negative eigenvalues; M = S1 S2 has det = det S1 det S2.
        let s1 = DMatrix::<f64>::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
        let s2 = DMatrix::<f64>::from_row_slice(2, 2, &[1.0, -0.3, -0.3, 3.0]);
        let m = &s1 * &s2;
        let trace_root = (m.trace() + 2.0 * (s1.determinant() * s2.determinant()).sqrt()).sqrt();
        let a = Gaussian {
            mean: DVector::from_vec(vec![0.0, 0.0]),
            covariance: s1.clone(),
        };
        let b = Gaussian {
            mean: DVector::from_vec(vec![3.0, 4.0]),
            covariance: s2.clone(),
        };
        let expected = 25.0 + s1.trace() + s2.trace() - 2.0 * trace_root;
        assert!((frechet_distance(&a, &b) - expected).abs() < 1e-10);
    }

    #[test]
    fn fit_uses_the_unbiased_covariance() {
        let g = Gaussian::fit(&[vec![1.0, 0.0], vec![3.0, 2.0]]).unwrap();
        assert_eq!(g.mean.as_slice(), &[2.0, 1.0]);
        assert_eq!(g.covariance[(0, 0)], 2.0);
        assert_eq!(g.covariance[(0, 1)], 2.0);
        assert!(Gaussian::fit(&[vec![1.0]]).is_err());
    }
}
