//! Where onnxruntime's shared library is: `ORT_DYLIB_PATH` when set, else the `onnxruntime` package of
//! the Pythons a user is likely to have installed it into, asked in order.
//!
//! A Python is asked where its `onnxruntime` package lives (`importlib.util.find_spec`, which does not
//! import it) and the library is the package's `capi/libonnxruntime.so.X.Y.Z`. Asking costs one short
//! process per interpreter (tens of milliseconds) and only happens when a command needs onnxruntime.
//! A library whose file name says it is older than the API this build uses is passed over with the
//! reason, so an old wheel in one environment does not hide a good one in the next; when nothing fits,
//! the error lists every place asked and what it held.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde::Serialize;

use crate::error::{OnnxError, Result};

/// The onnxruntime minor version whose API this build uses (`ort`'s `api-31` feature): older
/// libraries lack functions it calls.
pub const MIN_MINOR_VERSION: u32 = ort::MINOR_VERSION;

/// How long one interpreter may take to answer (a stated limit: a hung or very slow `python3` must not
/// hang the command).
pub const PYTHON_TIMEOUT: Duration = Duration::from_secs(30);

/// How to get a suitable library, for error messages.
pub const HINT: &str =
    "install onnxruntime 1.31.1 into your Python (python3 -m pip install onnxruntime==1.31.1), \
     name that Python with UNICAC_PYTHON=/path/to/python, or set ORT_DYLIB_PATH to the library \
     (<site-packages>/onnxruntime/capi/libonnxruntime.so.1.31.1)";

/// Prints the interpreter's path, then the folder of its `onnxruntime` package (an empty line when there
/// is none).
const FIND_PACKAGE: &str = "import importlib.util, os, sys\n\
     s = importlib.util.find_spec('onnxruntime')\n\
     print(sys.executable)\n\
     print(os.path.dirname(s.origin) if s is not None and s.origin else '')\n";

/// One interpreter to ask, and why it is on the list (said in reports and errors).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PythonCandidate {
    pub program: OsString,
    pub role: String,
}

/// Where to look, in order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Search {
    /// A library named by the user (`ORT_DYLIB_PATH`): when set, the only place looked at.
    pub dylib_path: Option<PathBuf>,
    /// Interpreters asked for their `onnxruntime` package, first match wins.
    pub pythons: Vec<PythonCandidate>,
}

impl Search {
    /// The search a command makes: `ORT_DYLIB_PATH`; else `UNICAC_PYTHON`, the Python hosting this
    /// process (`host_python`: the interpreter the `unicac` package runs in), the active virtual
    /// environment's Python (`VIRTUAL_ENV`) and the `python3` on `PATH`, in that order.
    pub fn from_environment(host_python: Option<&Path>) -> Search {
        let set = |name: &str| std::env::var_os(name).filter(|v| !v.is_empty());
        let mut pythons = Vec::new();
        if let Some(program) = set("UNICAC_PYTHON") {
            pythons.push(PythonCandidate {
                program,
                role: "UNICAC_PYTHON".into(),
            });
        }
        if let Some(program) = host_python {
            pythons.push(PythonCandidate {
                program: program.into(),
                role: "the Python running unicac".into(),
            });
        }
        if let Some(venv) = set("VIRTUAL_ENV") {
            pythons.push(PythonCandidate {
                program: Path::new(&venv).join("bin").join("python").into(),
                role: "the active virtual environment (VIRTUAL_ENV)".into(),
            });
        }
        pythons.push(PythonCandidate {
            program: "python3".into(),
            role: "python3 on PATH".into(),
        });
        let mut unique: Vec<PythonCandidate> = Vec::new();
        for candidate in pythons {
            if !unique.iter().any(|u| u.program == candidate.program) {
                unique.push(candidate);
            }
        }
        Search {
            dylib_path: set("ORT_DYLIB_PATH").map(PathBuf::from),
            pythons: unique,
        }
    }
}

/// The library chosen and how it was found (`unicac bench|metrics --json` report it).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Located {
    pub library: PathBuf,
    /// From the file name (`libonnxruntime.so.1.31.1`); None when the name carries none.
    pub version: Option<String>,
    /// `ORT_DYLIB_PATH`, or the interpreter whose package holds it and why that one was asked.
    pub found_by: String,
}

/// Finds the library: `search.dylib_path` if set (a missing file is an error, never a fallback), else
/// the first interpreter whose `onnxruntime` package holds a library of a usable version.
pub fn locate(search: &Search) -> Result<Located> {
    if let Some(path) = &search.dylib_path {
        if !path.is_file() {
            return Err(OnnxError::RuntimeMissing(format!(
                "onnxruntime not found: ORT_DYLIB_PATH={} is not a file; {HINT}",
                path.display()
            )));
        }
        return Ok(Located {
            library: path.clone(),
            version: version_of(path).map(|v| v.text),
            found_by: "ORT_DYLIB_PATH".into(),
        });
    }
    let mut tried = Vec::new();
    for python in &search.pythons {
        let asked = format!("{} ({})", python.program.to_string_lossy(), python.role);
        match library_of(python) {
            Ok(located) => return Ok(located),
            Err(why) => tried.push(format!("{asked}: {why}")),
        }
    }
    Err(OnnxError::RuntimeMissing(format!(
        "onnxruntime not found: ORT_DYLIB_PATH is not set and no Python asked has a usable onnxruntime package ({}); {HINT}",
        tried.join("; ")
    )))
}

/// The usable library in `python`'s onnxruntime package, or why there is none.
fn library_of(python: &PythonCandidate) -> std::result::Result<Located, String> {
    let (executable, package) = package_folder(&python.program)?;
    let capi = package.join("capi");
    let entries = std::fs::read_dir(&capi)
        .map_err(|e| format!("its onnxruntime package has no readable {}: {e}", capi.display()))?;
    let mut libraries: Vec<(PathBuf, Option<Version>)> = entries
        .filter_map(|entry| entry.ok().map(|e| e.path()))
        .filter(|path| is_library_name(path))
        .map(|path| {
            let version = version_of(&path);
            (path, version)
        })
        .collect();
    // The newest first; a name without a version after every versioned one.
    libraries.sort_by(|a, b| {
        b.1.as_ref()
            .map(|v| v.numbers)
            .cmp(&a.1.as_ref().map(|v| v.numbers))
    });
    let Some((library, version)) = libraries.into_iter().next() else {
        return Err(format!("no libonnxruntime shared library in {}", capi.display()));
    };
    if let Some(v) = &version {
        if !v.usable() {
            return Err(format!(
                "{} is onnxruntime {}, older than 1.{MIN_MINOR_VERSION} (upgrade it: {} -m pip install onnxruntime==1.31.1)",
                library.display(),
                v.text,
                python.program.to_string_lossy()
            ));
        }
    }
    Ok(Located {
        library,
        version: version.map(|v| v.text),
        found_by: format!("the onnxruntime package of {executable} ({})", python.role),
    })
}

/// The interpreter's own path (`sys.executable`, e.g. `python3` resolved on PATH) and the folder of
/// its onnxruntime package, or why there is none.
fn package_folder(program: &OsString) -> std::result::Result<(String, PathBuf), String> {
    let mut child = Command::new(program)
        .args(["-c", FIND_PACKAGE])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => "not found".to_string(),
            _ => format!("cannot run it: {e}"),
        })?;
    let start = Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) if start.elapsed() < PYTHON_TIMEOUT => std::thread::sleep(Duration::from_millis(5)),
            Ok(None) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("no answer within {} s", PYTHON_TIMEOUT.as_secs()));
            }
            Err(e) => return Err(format!("waiting for it failed: {e}")),
        }
    };
    let mut out = String::new();
    if let Some(mut stdout) = child.stdout.take() {
        use std::io::Read;
        // The answer is one short line: a larger read means this is not the program we think it is.
        let _ = (&mut stdout).take(64 * 1024).read_to_string(&mut out);
    }
    if !status.success() {
        return Err(format!("it failed ({status})"));
    }
    let mut lines = out.lines();
    let executable = match lines.next().map(str::trim) {
        Some(path) if !path.is_empty() => path.to_string(),
        _ => program.to_string_lossy().into_owned(),
    };
    match lines.next().map(str::trim) {
        Some(folder) if !folder.is_empty() => Ok((executable, PathBuf::from(folder))),
        _ => Err("it has no onnxruntime package".into()),
    }
}

/// `libonnxruntime.so`, `libonnxruntime.so.1.31.1` (Linux) or `libonnxruntime.1.31.1.dylib` (macOS);
/// not the providers' libraries beside it.
fn is_library_name(path: &Path) -> bool {
    let Some(name) = path.file_name().and_then(|n| n.to_str()) else {
        return false;
    };
    let linux = name == "libonnxruntime.so" || name.starts_with("libonnxruntime.so.");
    let mac = name.starts_with("libonnxruntime.") && name.ends_with(".dylib");
    (linux || mac) && path.is_file()
}

#[derive(Debug, Clone, PartialEq, Eq)]
struct Version {
    numbers: [u32; 3],
    text: String,
}

impl Version {
    fn usable(&self) -> bool {
        self.numbers[0] == 1 && self.numbers[1] >= MIN_MINOR_VERSION
    }
}

/// The X.Y.Z in a library's file name.
fn version_of(path: &Path) -> Option<Version> {
    let name = path.file_name()?.to_str()?;
    let rest = name
        .strip_prefix("libonnxruntime.so.")
        .or_else(|| name.strip_prefix("libonnxruntime.")?.strip_suffix(".dylib"))?;
    let parts: Vec<u32> = rest.split('.').map(|p| p.parse().ok()).collect::<Option<_>>()?;
    match parts[..] {
        [major, minor, patch] => Some(Version {
            numbers: [major, minor, patch],
            text: rest.to_string(),
        }),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> PathBuf {
        let dir = std::env::temp_dir()
            .join(format!("unicac-ort-library-{}", std::process::id()))
            .join(name);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A fake interpreter: a shell script that prints `folder` as its onnxruntime package.
    fn fake_python(dir: &Path, folder: &Path) -> OsString {
        use std::os::unix::fs::PermissionsExt;
        let script = dir.join("python");
        let text = format!("#!/bin/sh\necho \"$0\"\necho '{}'\n", folder.display());
        std::fs::write(&script, text).unwrap();
        std::fs::set_permissions(&script, std::fs::Permissions::from_mode(0o755)).unwrap();
        script.into()
    }

    fn package_with(dir: &Path, libraries: &[&str]) -> PathBuf {
        let package = dir.join("site-packages/onnxruntime");
        std::fs::create_dir_all(package.join("capi")).unwrap();
        for name in libraries {
            std::fs::write(package.join("capi").join(name), b"").unwrap();
        }
        package
    }

    #[test]
    fn versions_are_read_from_library_names() {
        let v = version_of(Path::new("/x/libonnxruntime.so.1.31.1")).unwrap();
        assert_eq!((v.numbers, v.text.as_str()), ([1, 31, 1], "1.31.1"));
        assert!(v.usable());
        assert_eq!(
            version_of(Path::new("libonnxruntime.1.32.0.dylib"))
                .unwrap()
                .numbers,
            [1, 32, 0]
        );
        assert!(!version_of(Path::new("libonnxruntime.so.1.20.1"))
            .unwrap()
            .usable());
        assert!(!version_of(Path::new("libonnxruntime.so.2.0.0")).unwrap().usable());
        assert_eq!(version_of(Path::new("libonnxruntime.so")), None);
        assert_eq!(version_of(Path::new("libonnxruntime.so.1")), None);
    }

    #[test]
    fn the_first_python_with_a_usable_library_wins_and_older_ones_are_passed_over_by_name() {
        let old_dir = scratch("old");
        let old = fake_python(&old_dir, &package_with(&old_dir, &["libonnxruntime.so.1.20.1"]));
        let good_dir = scratch("good");
        let good_package = package_with(
            &good_dir,
            &["libonnxruntime.so.1.31.1", "libonnxruntime_providers_shared.so"],
        );
        let good = fake_python(&good_dir, &good_package);
        let search = Search {
            dylib_path: None,
            pythons: vec![
                PythonCandidate {
                    program: "/nonexistent/python3".into(),
                    role: "UNICAC_PYTHON".into(),
                },
                PythonCandidate {
                    program: old.clone(),
                    role: "old".into(),
                },
                PythonCandidate {
                    program: good.clone(),
                    role: "python3 on PATH".into(),
                },
            ],
        };
        let located = locate(&search).unwrap();
        assert_eq!(
            located.library,
            good_package.join("capi/libonnxruntime.so.1.31.1")
        );
        assert_eq!(located.version.as_deref(), Some("1.31.1"));
        assert!(
            located.found_by.contains("python3 on PATH"),
            "{}",
            located.found_by
        );
        // Without the good one, the error names every place asked and the old version.
        let search = Search {
            pythons: search.pythons[..2].to_vec(),
            ..search
        };
        let message = locate(&search).unwrap_err().to_string();
        for part in [
            "/nonexistent/python3",
            "not found",
            "1.20.1",
            "older than 1.31",
            "ORT_DYLIB_PATH",
        ] {
            assert!(message.contains(part), "{part}: {message}");
        }
    }

    #[test]
    fn an_explicit_library_path_is_the_only_place_looked_at() {
        let dir = scratch("explicit");
        let good = fake_python(&dir, &package_with(&dir, &["libonnxruntime.so.1.31.1"]));
        let search = Search {
            dylib_path: Some(dir.join("missing.so")),
            pythons: vec![PythonCandidate {
                program: good,
                role: "python3 on PATH".into(),
            }],
        };
        let message = locate(&search).unwrap_err().to_string();
        assert!(
            message.contains("ORT_DYLIB_PATH=") && message.contains("missing.so"),
            "{message}"
        );
    }

    #[test]
    fn a_python_without_the_package_says_so() {
        let dir = scratch("none");
        let script = fake_python(&dir, Path::new(""));
        let message = locate(&Search {
            dylib_path: None,
            pythons: vec![PythonCandidate {
                program: script,
                role: "python3 on PATH".into(),
            }],
        })
        .unwrap_err()
        .to_string();
        assert!(message.contains("has no onnxruntime package"), "{message}");
    }
}
