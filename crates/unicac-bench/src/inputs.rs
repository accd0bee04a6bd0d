//! What the bench reads for a model: an image as RGB, and the maps it offers besides `lq`. Shared by
//! the test pairs (`run`) and the edge patches (`edges`).

use std::collections::BTreeMap;
use std::path::Path;

use unicac_image::io::read_image;
use unicac_image::Planar;

use crate::error::{BenchError, Result};
use unicac_onnx::contract::ModelContract;

/// An RGB image in [0, 1] as stored (sRGB-encoded), named in errors.
pub fn read_rgb(path: &Path) -> Result<Planar> {
    let loaded = read_image(path)?;
    loaded
        .rgb_planes(&loaded.image)
        .ok_or_else(|| BenchError::InvalidInput(format!("{}: expected a grey or RGB image", path.display())))
}

/// The maps an image offers its models besides `lq` (docs/models.md), each of the image's size.
#[derive(Debug, Clone, Copy, Default)]
pub struct InputMaps<'a> {
    pub fov: Option<&'a Planar>,
    pub psf: Option<&'a Planar>,
    pub psf_code: Option<&'a Planar>,
    /// The Wiener estimate with the model's own noise-to-signal ratio.
    pub wiener: Option<&'a Planar>,
}

/// The Wiener estimates of one image, keyed by the bits of their noise-to-signal ratio: computed once
/// per ratio the models take and shared with the Wiener method.
pub(crate) type WienerEstimates = BTreeMap<u64, Planar>;

/// The estimate `contract` takes as its `wiener` input, if it takes one.
pub(crate) fn wiener_input<'a>(
    contract: &ModelContract,
    estimates: &'a WienerEstimates,
) -> Option<&'a Planar> {
    contract
        .wiener_input_nsr(crate::wiener::DEFAULT_NSR)
        .and_then(|nsr| estimates.get(&nsr.to_bits()))
}

/// The Wiener restoration at `nsr`: the estimate already computed for a model's input, else `restore()`.
pub(crate) fn wiener_at(
    estimates: &WienerEstimates,
    nsr: f64,
    restore: impl FnOnce() -> Result<Planar>,
) -> Result<Planar> {
    match estimates.get(&nsr.to_bits()) {
        Some(estimate) => Ok(estimate.clone()),
        None => restore(),
    }
}
