//! The restoration-model contract of docs/models.md, checked on the ONNX file itself before any work:
//! the file must decode as an ONNX `ModelProto` with a graph; its graph inputs (initializers excluded,
//! as older exporters list them) must be `lq` plus any of `fov`, `psf` (contract 1), `psf_code`,
//! `wiener` (contract 2), float32, rank 4, with 3, 2, 15, 50 and 3 channels where the channel dimension
//! is fixed; exactly one output, `restored`, float32, rank 4, 3 channels; default-domain opset >= 17;
//! metadata `unicac_contract`, when present, an integer not newer than [`CONTRACT_VERSION`] (and at
//! least 2 for a model with a contract-2 input), and `inputs`, when present, equal to the graph's
//! inputs. A `psf_code` model must record `psf_basis_sha256` (the code means nothing in another basis);
//! `wiener_nsr`, when present, is a positive number.
//!
//! Models without the metadata keys are accepted (hand-made ONNX files follow the contract through
//! their graph alone); the report records which keys were present.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use prost::Message;
use serde::Serialize;

use crate::error::{OnnxError, Result};
use unicac_io::named_choice;

use crate::proto::{data_type, tensor_shape_proto, type_proto, ModelProto, ValueInfoProto};

/// The contract version this reader knows (`unicac_contract` metadata).
pub const CONTRACT_VERSION: u32 = 2;
/// The lowest default-domain opset the contract allows.
pub const MIN_OPSET: i64 = 17;

named_choice! {
    /// A model input the contract defines.
    ModelInput {
        /// The degraded image, N x 3 x H x W.
        Lq = "lq",
        /// The field-of-view map, N x 2 x H x W.
        Fov = "fov",
        /// The PSF-feature map, N x 15 x H x W.
        Psf = "psf",
        /// The dense PSF code (the dataset's PCA basis), N x 50 x H x W (contract 2).
        PsfCode = "psf_code",
        /// The field-varying Wiener estimate of `lq`, N x 3 x H x W (contract 2).
        Wiener = "wiener",
    }
}

impl ModelInput {
    pub fn channels(self) -> usize {
        match self {
            ModelInput::Lq => 3,
            ModelInput::Fov => 2,
            ModelInput::Psf => 15,
            ModelInput::PsfCode => unicac_dataset::PSF_CODE_CHANNELS,
            ModelInput::Wiener => 3,
        }
    }

    /// The first contract version that defines the input.
    pub fn since(self) -> u32 {
        match self {
            ModelInput::Lq | ModelInput::Fov | ModelInput::Psf => 1,
            ModelInput::PsfCode | ModelInput::Wiener => 2,
        }
    }
}

/// A model that passed the contract checks.
#[derive(Debug, Clone, Serialize)]
pub struct ModelContract {
    pub path: PathBuf,
    /// The inputs the graph declares, in graph order.
    pub inputs: Vec<ModelInput>,
    /// The default-domain opset.
    pub opset: i64,
    /// `metadata_props` as stored.
    pub metadata: BTreeMap<String, String>,
    /// The PSF basis a `psf_code` model was trained with (`psf_basis_sha256`).
    pub psf_basis_sha256: Option<String>,
    /// The noise-to-signal ratio of a `wiener` model's input (`wiener_nsr`; None: the bench default).
    pub wiener_nsr: Option<f64>,
    /// Whether the graph leaves the batch dimension N free on every input and on `restored` (the
    /// bench then runs a lens's edge patches as one batch; a model fixed at N = 1 gets them one by one).
    pub dynamic_batch: bool,
}

impl ModelContract {
    pub fn wants(&self, input: ModelInput) -> bool {
        self.inputs.contains(&input)
    }

    /// The noise-to-signal ratio of the Wiener estimate this model takes as its `wiener` input (its
    /// `wiener_nsr`, else `default_nsr`, the bench's); `None` when it takes none.
    pub fn wiener_input_nsr(&self, default_nsr: f64) -> Option<f64> {
        self.wants(ModelInput::Wiener)
            .then(|| self.wiener_nsr.unwrap_or(default_nsr))
    }
}

/// Largest ONNX file read (2 GiB, protobuf's own limit on one message): a regular file, refused from
/// its size before reading.
pub const MAX_MODEL_FILE_BYTES: u64 = 2 << 30;

/// The bytes of an ONNX file (a restoration model or a metric network), within [`MAX_MODEL_FILE_BYTES`].
pub fn read_model_bytes(path: &Path) -> Result<Vec<u8>> {
    unicac_io::read_capped(path, MAX_MODEL_FILE_BYTES, "MAX_MODEL_FILE_BYTES").map_err(|source| {
        OnnxError::Io {
            path: path.to_path_buf(),
            source,
        }
    })
}

/// Reads and checks `path`; returns the contract and the decoded model.
pub fn load_model(path: &Path) -> Result<(ModelContract, ModelProto, Vec<u8>)> {
    let bytes = read_model_bytes(path)?;
    let model = decode(path, &bytes)?;
    let contract = check(path, &model)?;
    Ok((contract, model, bytes))
}

/// Decodes ONNX bytes; a file that is not a protobuf `ModelProto` with a graph is refused.
pub fn decode(path: &Path, bytes: &[u8]) -> Result<ModelProto> {
    let refuse = |why: String| OnnxError::NotOnnx {
        path: path.to_path_buf(),
        why,
    };
    let model = ModelProto::decode(bytes).map_err(|e| refuse(format!("protobuf decoding failed ({e})")))?;
    match &model.graph {
        Some(graph) if !graph.node.is_empty() || !graph.output.is_empty() => {}
        _ => return Err(refuse("no graph".into())),
    }
    if model.ir_version <= 0 || model.opset_import.is_empty() {
        return Err(refuse("no IR version or opset".into()));
    }
    Ok(model)
}

/// Checks a decoded model against docs/models.md.
pub fn check(path: &Path, model: &ModelProto) -> Result<ModelContract> {
    let refuse = |why: String| OnnxError::Contract {
        path: path.to_path_buf(),
        why,
    };
    let graph = model.graph.as_ref().expect("decode checked the graph");
    let opset = model
        .opset_import
        .iter()
        .find(|o| o.domain.is_empty() || o.domain == "ai.onnx")
        .map(|o| o.version)
        .ok_or_else(|| refuse("no default-domain (ai.onnx) opset".into()))?;
    if opset < MIN_OPSET {
        return Err(refuse(format!(
            "opset {opset} is older than the contract's {MIN_OPSET}"
        )));
    }
    let initializers: Vec<&str> = graph.initializer.iter().map(|t| t.name.as_str()).collect();
    let mut inputs = Vec::new();
    for value in graph
        .input
        .iter()
        .filter(|v| !initializers.contains(&v.name.as_str()))
    {
        let input: ModelInput = value.name.parse().map_err(|_| {
            let allowed: Vec<&str> = ModelInput::ALL.iter().map(|i| i.name()).collect();
            refuse(format!(
                "input `{}` is not in the contract (allowed: {})",
                value.name,
                allowed.join(", ")
            ))
        })?;
        if inputs.contains(&input) {
            return Err(refuse(format!("input `{}` is declared twice", value.name)));
        }
        check_image_value(value, input.channels())
            .map_err(|why| refuse(format!("input `{}`: {why}", value.name)))?;
        inputs.push(input);
    }
    if !inputs.contains(&ModelInput::Lq) {
        return Err(refuse("the graph has no `lq` input".into()));
    }
    match graph.output.as_slice() {
        [only] if only.name == "restored" => {
            check_image_value(only, 3).map_err(|why| refuse(format!("output `restored`: {why}")))?
        }
        [only] => return Err(refuse(format!("the output is `{}`, not `restored`", only.name))),
        outputs => {
            let names: Vec<&str> = outputs.iter().map(|o| o.name.as_str()).collect();
            return Err(refuse(format!(
                "the graph has {} outputs ({}); the contract has one, `restored`",
                outputs.len(),
                names.join(", ")
            )));
        }
    }
    let metadata: BTreeMap<String, String> = model
        .metadata_props
        .iter()
        .map(|e| (e.key.clone(), e.value.clone()))
        .collect();
    if let Some(version) = metadata.get("unicac_contract") {
        let version: u32 = version.trim().parse().map_err(|_| {
            refuse(format!(
                "metadata unicac_contract = `{version}` is not an integer"
            ))
        })?;
        if version > CONTRACT_VERSION {
            return Err(refuse(format!(
                "metadata unicac_contract = {version} is newer than this reader's {CONTRACT_VERSION}; update unicac"
            )));
        }
        if let Some(input) = inputs.iter().find(|i| i.since() > version) {
            return Err(refuse(format!(
                "input `{}` needs contract {}, but metadata unicac_contract = {version}",
                input.name(),
                input.since()
            )));
        }
    }
    let psf_basis_sha256 = metadata.get("psf_basis_sha256").map(|s| s.trim().to_string());
    if inputs.contains(&ModelInput::PsfCode)
        && !psf_basis_sha256
            .as_ref()
            .is_some_and(|s| s.len() == 64 && s.chars().all(|c| c.is_ascii_hexdigit()))
    {
        return Err(refuse(
            "input `psf_code` needs metadata psf_basis_sha256 (the SHA-256 of the PSF basis it was trained with)"
                .into(),
        ));
    }
    let wiener_nsr = match metadata.get("wiener_nsr") {
        None => None,
        Some(text) => match text.trim().parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Some(v),
            _ => {
                return Err(refuse(format!(
                    "metadata wiener_nsr = `{text}` is not a positive number"
                )))
            }
        },
    };
    if let Some(declared) = metadata.get("inputs") {
        let mut declared: Vec<&str> = declared
            .split(',')
            .map(str::trim)
            .filter(|s| !s.is_empty())
            .collect();
        let mut actual: Vec<&str> = inputs.iter().map(|i| i.name()).collect();
        declared.sort_unstable();
        actual.sort_unstable();
        if declared != actual {
            return Err(refuse(format!(
                "metadata inputs = `{}` but the graph's inputs are `{}`",
                declared.join(","),
                actual.join(",")
            )));
        }
    }
    let dynamic_batch = graph
        .input
        .iter()
        .filter(|v| !initializers.contains(&v.name.as_str()))
        .chain(&graph.output)
        .all(batch_is_free);
    Ok(ModelContract {
        path: path.to_path_buf(),
        inputs,
        opset,
        metadata,
        psf_basis_sha256,
        wiener_nsr,
        dynamic_batch,
    })
}

/// True unless the value's dimension 0 (N) is a fixed number.
fn batch_is_free(value: &ValueInfoProto) -> bool {
    let Some(type_proto::Value::TensorType(tensor)) = value.r#type.as_ref().and_then(|t| t.value.as_ref())
    else {
        return true;
    };
    let first = tensor.shape.as_ref().and_then(|shape| shape.dim.first());
    !matches!(
        first.and_then(|d| d.value.as_ref()),
        Some(tensor_shape_proto::dimension::Value::DimValue(_))
    )
}

/// float32, rank 4, and `channels` in dimension 1 when that dimension is fixed.
fn check_image_value(value: &ValueInfoProto, channels: usize) -> std::result::Result<(), String> {
    let tensor = match value.r#type.as_ref().and_then(|t| t.value.as_ref()) {
        Some(type_proto::Value::TensorType(t)) => t,
        _ => return Err("not a tensor".into()),
    };
    if tensor.elem_type != data_type::FLOAT {
        return Err(format!("element type {} is not float32", tensor.elem_type));
    }
    if let Some(shape) = &tensor.shape {
        if shape.dim.len() != 4 {
            return Err(format!("rank {} is not 4 (N x C x H x W)", shape.dim.len()));
        }
        if let Some(tensor_shape_proto::dimension::Value::DimValue(c)) = &shape.dim[1].value {
            if *c != channels as i64 {
                return Err(format!("{c} channels, the contract says {channels}"));
            }
        }
    }
    Ok(())
}
