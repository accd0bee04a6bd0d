//! onnxruntime through the `ort` crate, loaded at run time from the shared library of the `onnxruntime`
//! PyPI wheel (`ort`'s `load-dynamic` feature; the `api-31` feature needs onnxruntime >= 1.31).
//!
//! [`Runtime::load`] takes the library [`crate::ort_library::locate`] finds (`ORT_DYLIB_PATH`, else a
//! Python's onnxruntime package) and refuses clearly, saying how to get a good one, when there is none
//! or it is of an older API. onnxruntime has one environment per process, so the loaded runtime is kept
//! once for the process (`OnceLock`): the first search decides; sessions are values owned by their users.

use std::path::Path;
use std::sync::OnceLock;

use crate::error::{OnnxError, Result};
use crate::ort_library::{locate, Located, Search, HINT};

/// The onnxruntime version the bench is built and tested against.
pub const ORT_VERSION: &str = "1.31.1";

/// The loaded onnxruntime.
#[derive(Debug)]
pub struct Runtime {
    located: Located,
    environment: ort::environment::Environment,
}

static RUNTIME: OnceLock<std::result::Result<Runtime, String>> = OnceLock::new();

impl Runtime {
    /// Loads onnxruntime found by [`Search::from_environment`] without a host interpreter.
    pub fn load() -> Result<&'static Runtime> {
        Runtime::load_with(&Search::from_environment(None))
    }

    /// Loads onnxruntime from where `search` finds it (once per process: later calls get the first
    /// result whatever their search).
    pub fn load_with(search: &Search) -> Result<&'static Runtime> {
        RUNTIME
            .get_or_init(|| Runtime::init(search).map_err(|e| e.to_string()))
            .as_ref()
            .map_err(|message| OnnxError::RuntimeMissing(message.clone()))
    }

    fn init(search: &Search) -> Result<Runtime> {
        let located = locate(search)?;
        let library = &located.library;
        let builder = ort::init_from(library).map_err(|e| {
            let why = match e {
                ort::LoadDynamicError::BadVersion { version_str, .. } => format!(
                    "it is onnxruntime {version_str}, older than 1.{} (the API this build of unicac uses)",
                    ort::MINOR_VERSION
                ),
                other => format!("cannot load it ({other})"),
            };
            OnnxError::RuntimeMissing(format!(
                "{} (found by {}): {why}; {HINT}",
                library.display(),
                located.found_by
            ))
        })?;
        let environment = builder
            .with_name("unicac")
            .build()
            .map_err(|e| OnnxError::ort("creating the environment", e))?;
        Ok(Runtime { located, environment })
    }

    /// The shared library in use.
    pub fn library(&self) -> &Path {
        &self.located.library
    }

    /// The shared library in use and how it was found.
    pub fn located(&self) -> &Located {
        &self.located
    }

    /// A session for the ONNX model in `bytes`, running with `threads` intra-op threads.
    pub fn session(&self, bytes: &[u8], threads: usize, what: &str) -> Result<Session> {
        let context = format!("loading {what}");
        let mut builder = ort::session::Session::builder(&self.environment)
            .map_err(|e| OnnxError::ort(&context, e))?
            .with_optimization_level(ort::session::builder::GraphOptimizationLevel::Level3)
            .map_err(|e| OnnxError::ort(&context, e))?
            .with_intra_threads(threads.max(1))
            .map_err(|e| OnnxError::ort(&context, e))?;
        let session = builder
            .commit_from_memory(bytes)
            .map_err(|e| OnnxError::ort(&context, e))?;
        Ok(Session {
            session,
            what: what.to_string(),
        })
    }
}

/// A float32 tensor in row-major order.
#[derive(Debug, Clone, PartialEq)]
pub struct Tensor {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

/// An onnxruntime session over one model.
pub struct Session {
    session: ort::session::Session,
    what: String,
}

impl std::fmt::Debug for Session {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "Session({})", self.what)
    }
}

impl Session {
    /// Runs the model on named float32 inputs and returns the named outputs, in the order asked.
    pub fn run(&mut self, inputs: Vec<(&str, Tensor)>, outputs: &[&str]) -> Result<Vec<Tensor>> {
        let context = format!("running {}", self.what);
        let mut values = Vec::with_capacity(inputs.len());
        for (name, tensor) in inputs {
            let shape: Vec<i64> = tensor.shape.iter().map(|&d| d as i64).collect();
            let value = ort::value::Tensor::from_array((shape, tensor.data))
                .map_err(|e| OnnxError::ort(&context, e))?;
            values.push((name.to_string(), value));
        }
        let result = self
            .session
            .run(values)
            .map_err(|e| OnnxError::ort(&context, e))?;
        outputs
            .iter()
            .map(|name| {
                let value = result
                    .get(*name)
                    .ok_or_else(|| OnnxError::ort(&context, format!("no output `{name}`")))?;
                let (shape, data) = value
                    .try_extract_tensor::<f32>()
                    .map_err(|e| OnnxError::ort(&context, e))?;
                Ok(Tensor {
                    shape: shape.iter().map(|&d| d as usize).collect(),
                    data: data.to_vec(),
                })
            })
            .collect()
    }
}
