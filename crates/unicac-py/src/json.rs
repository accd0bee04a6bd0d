//! Serde values to Python objects: the dictionaries this module returns are the CLI's JSON, built from
//! the same `Serialize` structs, so key names and values match `unicac ... --json` exactly.

use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList};
use serde::Serialize;
use serde_json::Value;

/// JSON value -> Python (null -> None, numbers -> int or float, arrays -> list, objects -> dict).
pub fn to_py<'py>(py: Python<'py>, value: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match value {
        Value::Null => py.None().into_bound(py),
        Value::Bool(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::Number(n) => {
            if let Some(i) = n.as_i64() {
                i.into_pyobject(py)?.into_any()
            } else if let Some(u) = n.as_u64() {
                u.into_pyobject(py)?.into_any()
            } else {
                n.as_f64().unwrap_or(f64::NAN).into_pyobject(py)?.into_any()
            }
        }
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Array(items) => {
            let list = PyList::empty(py);
            for item in items {
                list.append(to_py(py, item)?)?;
            }
            list.into_any()
        }
        Value::Object(map) => {
            let dict = PyDict::new(py);
            for (key, item) in map {
                dict.set_item(key, to_py(py, item)?)?;
            }
            dict.into_any()
        }
    })
}

/// Any serialisable value as a Python dict/list/scalar, through its JSON text: an f32 field arrives as
/// the number the CLI's JSON and the files on disk print (0.16, not 0.1599999964237213, which
/// `serde_json::to_value` would widen it to).
pub fn serialize<'py, T: Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyAny>> {
    let failed = |e: serde_json::Error| PyValueError::new_err(format!("serialising: {e}"));
    let text = serde_json::to_string(value).map_err(failed)?;
    let json: Value = serde_json::from_str(&text).map_err(failed)?;
    to_py(py, &json)
}

/// Like `serialize`, for values that serialise to a JSON object.
pub fn serialize_dict<'py, T: Serialize>(py: Python<'py>, value: &T) -> PyResult<Bound<'py, PyDict>> {
    Ok(serialize(py, value)?.cast_into::<PyDict>()?)
}
