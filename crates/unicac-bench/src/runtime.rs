//! onnxruntime through the `ort` crate, loaded at run time from the shared library of the `onnxruntime`
//! PyPI wheel (`ort`'s `load-dynamic` feature; the `api-31` feature needs onnxruntime >= 1.31).
//!
//! [`Runtime::load`] finds the library through `ORT_DYLIB_PATH` and refuses clearly, saying how to get it,
//! when the variable is unset or names no file. onnxruntime has one environment per process, so the
//! loaded runtime is kept once for the process (`OnceLock`); sessions are values owned by their users.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use crate::error::{BenchError, Result};

/// The onnxruntime version the bench is built and tested against.
pub const ORT_VERSION: &str = "1.31.1";

/// How to get the library, for error messages and docs.
pub const ORT_HINT: &str = "install the onnxruntime 1.31.1 wheel (python3 -m pip install onnxruntime==1.31.1) and \
     export ORT_DYLIB_PATH=<site-packages>/onnxruntime/capi/libonnxruntime.so.1.31.1 \
     (python3 -c 'import onnxruntime, os; print(os.path.join(os.path.dirname(onnxruntime.__file__), \"capi\"))' prints the folder)";

/// The loaded onnxruntime.
#[derive(Debug)]
pub struct Runtime {
    library: PathBuf,
    environment: ort::environment::Environment,
}

static RUNTIME: OnceLock<std::result::Result<Runtime, String>> = OnceLock::new();

impl Runtime {
    /// Loads onnxruntime from `ORT_DYLIB_PATH` (once per process).
    pub fn load() -> Result<&'static Runtime> {
        RUNTIME
            .get_or_init(|| Runtime::init().map_err(|e| e.to_string()))
            .as_ref()
            .map_err(|message| BenchError::RuntimeMissing(message.clone()))
    }

    fn init() -> Result<Runtime> {
        let library = match std::env::var_os("ORT_DYLIB_PATH").filter(|v| !v.is_empty()) {
            Some(path) => PathBuf::from(path),
            None => {
                return Err(BenchError::RuntimeMissing(format!(
                    "onnxruntime not found: ORT_DYLIB_PATH is not set; {ORT_HINT}"
                )))
            }
        };
        if !library.is_file() {
            return Err(BenchError::RuntimeMissing(format!(
                "onnxruntime not found: ORT_DYLIB_PATH={} is not a file; {ORT_HINT}",
                library.display()
            )));
        }
        let environment = ort::init_from(&library)
            .map_err(|e| {
                BenchError::RuntimeMissing(format!(
                    "{}: cannot load onnxruntime ({e}); {ORT_HINT}",
                    library.display()
                ))
            })?
            .with_name("unicac")
            .build()
            .map_err(|e| BenchError::ort("creating the environment", e))?;
        Ok(Runtime { library, environment })
    }

    /// The shared library in use.
    pub fn library(&self) -> &Path {
        &self.library
    }

    /// A session for the ONNX model in `bytes`, running with `threads` intra-op threads.
    pub fn session(&self, bytes: &[u8], threads: usize, what: &str) -> Result<Session> {
        let context = format!("loading {what}");
        let mut builder = ort::session::Session::builder(&self.environment)
            .map_err(|e| BenchError::ort(&context, e))?
            .with_optimization_level(ort::session::builder::GraphOptimizationLevel::Level3)
            .map_err(|e| BenchError::ort(&context, e))?
            .with_intra_threads(threads.max(1))
            .map_err(|e| BenchError::ort(&context, e))?;
        let session = builder
            .commit_from_memory(bytes)
            .map_err(|e| BenchError::ort(&context, e))?;
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
                .map_err(|e| BenchError::ort(&context, e))?;
            values.push((name.to_string(), value));
        }
        let result = self
            .session
            .run(values)
            .map_err(|e| BenchError::ort(&context, e))?;
        outputs
            .iter()
            .map(|name| {
                let value = result
                    .get(*name)
                    .ok_or_else(|| BenchError::ort(&context, format!("no output `{name}`")))?;
                let (shape, data) = value
                    .try_extract_tensor::<f32>()
                    .map_err(|e| BenchError::ort(&context, e))?;
                Ok(Tensor {
                    shape: shape.iter().map(|&d| d as usize).collect(),
                    data: data.to_vec(),
                })
            })
            .collect()
    }
}
