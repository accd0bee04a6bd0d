//! Checking a run's output paths before any work: never an input, never two outputs on one path, and
//! extensions that name the format written.

use std::path::{Path, PathBuf};

/// Why a run's outputs are refused. Each names the flag (or role) and the paths involved.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum OutputError {
    #[error("{flag} {output}: would overwrite the input {input}; choose another output path")]
    OverwritesInput {
        flag: String,
        output: PathBuf,
        input: PathBuf,
    },
    #[error("{flag} {output}: lies inside the input folder {folder}; choose a path outside it")]
    InsideInputFolder {
        flag: String,
        output: PathBuf,
        folder: PathBuf,
    },
    #[error(
        "{first_flag} {first} and {second_flag} {second} are the same file; each output needs its own path"
    )]
    Collision {
        first_flag: String,
        first: PathBuf,
        second_flag: String,
        second: PathBuf,
    },
    #[error("{flag} {path}: the extension must be {expected} (the format written)")]
    WrongExtension {
        flag: String,
        path: PathBuf,
        expected: String,
    },
}

/// The inputs and outputs of one run, checked together before any work.
#[derive(Debug, Default, Clone)]
pub struct OutputPlan {
    inputs: Vec<PathBuf>,
    input_folders: Vec<PathBuf>,
    outputs: Vec<(String, PathBuf)>,
}

impl OutputPlan {
    pub fn new() -> OutputPlan {
        OutputPlan::default()
    }

    /// A file the run reads (lens, image, cache entries need not be listed).
    pub fn input(&mut self, path: impl Into<PathBuf>) -> &mut Self {
        self.inputs.push(path.into());
        self
    }

    /// A folder the run reads as a whole (a dataset): no output may be it or lie anywhere inside it
    /// (a later run would read the output as part of the input).
    pub fn input_folder(&mut self, path: impl Into<PathBuf>) -> &mut Self {
        let path = path.into();
        self.inputs.push(path.clone());
        self.input_folders.push(path);
        self
    }

    /// A file the run writes, with the flag (or role) that named it, for messages.
    pub fn output(&mut self, flag: impl Into<String>, path: impl Into<PathBuf>) -> &mut Self {
        self.outputs.push((flag.into(), path.into()));
        self
    }

    pub fn outputs(&self) -> impl Iterator<Item = &Path> {
        self.outputs.iter().map(|(_, p)| p.as_path())
    }

    /// Refuses an output that is an input, or two outputs that are one file.
    pub fn check(&self) -> Result<(), OutputError> {
        let inputs: Vec<(Identity, &PathBuf)> = self.inputs.iter().map(|p| (Identity::of(p), p)).collect();
        let folders: Vec<(Identity, &PathBuf)> =
            self.input_folders.iter().map(|p| (Identity::of(p), p)).collect();
        let mut seen: Vec<(Identity, &String, &PathBuf)> = Vec::new();
        for (flag, output) in &self.outputs {
            let identity = Identity::of(output);
            if let Some((_, input)) = inputs.iter().find(|(i, _)| i.same(&identity)) {
                return Err(OutputError::OverwritesInput {
                    flag: flag.clone(),
                    output: output.clone(),
                    input: (*input).clone(),
                });
            }
            if let Some((_, folder)) = folders
                .iter()
                .find(|(f, _)| identity.normalised.starts_with(&f.normalised))
            {
                return Err(OutputError::InsideInputFolder {
                    flag: flag.clone(),
                    output: output.clone(),
                    folder: (*folder).clone(),
                });
            }
            if let Some((_, first_flag, first)) = seen.iter().find(|(i, _, _)| i.same(&identity)) {
                return Err(OutputError::Collision {
                    first_flag: (*first_flag).clone(),
                    first: (*first).clone(),
                    second_flag: flag.clone(),
                    second: output.clone(),
                });
            }
            seen.push((identity, flag, output));
        }
        Ok(())
    }
}

/// What makes two paths the same file: the absolute, symlink-resolved folder plus the file name (so
/// files that do not exist yet compare too), and the device and inode where the file exists (hard
/// links, case-insensitive file systems).
#[derive(Debug)]
struct Identity {
    normalised: PathBuf,
    #[cfg(unix)]
    inode: Option<(u64, u64)>,
}

impl Identity {
    fn of(path: &Path) -> Identity {
        let normalised = std::fs::canonicalize(path).unwrap_or_else(|_| {
            let parent = path
                .parent()
                .filter(|p| !p.as_os_str().is_empty())
                .unwrap_or(Path::new("."));
            let folder = std::fs::canonicalize(parent).unwrap_or_else(|_| absolute(parent));
            match path.file_name() {
                Some(name) => folder.join(name),
                None => folder,
            }
        });
        Identity {
            #[cfg(unix)]
            inode: {
                use std::os::unix::fs::MetadataExt;
                std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
            },
            normalised,
        }
    }

    fn same(&self, other: &Identity) -> bool {
        #[cfg(unix)]
        if let (Some(a), Some(b)) = (self.inode, other.inode) {
            return a == b;
        }
        self.normalised == other.normalised
    }
}

fn absolute(path: &Path) -> PathBuf {
    std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf())
}

/// The lower-case extension of `path` ("" when none).
pub fn extension_of(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// The extension of `path` if it is one of `allowed` (lower case, without dots), else an error naming
/// `flag` and the extensions expected.
pub fn require_extension(flag: &str, path: &Path, allowed: &[&str]) -> Result<String, OutputError> {
    let extension = extension_of(path);
    if allowed.contains(&extension.as_str()) {
        Ok(extension)
    } else {
        let dotted: Vec<String> = allowed.iter().map(|e| format!(".{e}")).collect();
        Err(OutputError::WrongExtension {
            flag: flag.to_string(),
            path: path.to_path_buf(),
            expected: dotted.join(" or "),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_output_that_is_an_input_is_refused_however_it_is_spelled() {
        let dir = std::env::temp_dir().join(format!("unicac-io-plan-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        let input = dir.join("a.png");
        std::fs::write(&input, b"x").unwrap();
        let mut plan = OutputPlan::new();
        plan.input(&input).output("--out", dir.join("sub/../a.png"));
        let message = plan.check().unwrap_err().to_string();
        assert!(
            message.contains("--out") && message.contains("would overwrite the input"),
            "{message}"
        );
        #[cfg(unix)]
        {
            let link = dir.join("hard.png");
            let _ = std::fs::remove_file(&link);
            std::fs::hard_link(&input, &link).unwrap();
            let mut plan = OutputPlan::new();
            plan.input(&input).output("--plot", &link);
            assert!(plan.check().is_err());
        }
        let mut plan = OutputPlan::new();
        plan.input(&input).output("--out", dir.join("b.png"));
        plan.check().unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn an_output_inside_an_input_folder_is_refused_at_any_depth() {
        let dir = std::env::temp_dir().join(format!("unicac-io-folder-{}", std::process::id()));
        let dataset = dir.join("dataset");
        std::fs::create_dir_all(dataset.join("test")).unwrap();
        for (output, refused) in [
            (dataset.join("report"), true),
            (dataset.join("test").join("new").join("report"), true),
            (dataset.join("test").join("..").join("report"), true),
            (dir.join("report"), false),
            (dir.join("dataset-report"), false),
        ] {
            let mut plan = OutputPlan::new();
            plan.input_folder(&dataset).output("--out", &output);
            let result = plan.check();
            assert_eq!(
                matches!(result, Err(OutputError::InsideInputFolder { .. })),
                refused,
                "{output:?}: {result:?}"
            );
        }
        let mut plan = OutputPlan::new();
        plan.input_folder(&dataset).output("--out", &dataset);
        assert!(plan
            .check()
            .unwrap_err()
            .to_string()
            .contains("would overwrite the input"));
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn two_outputs_on_one_path_collide_before_either_exists() {
        let mut plan = OutputPlan::new();
        plan.output("--out", "o/a.png").output("--out", "o/./a.png");
        let message = plan.check().unwrap_err().to_string();
        assert!(message.contains("same file"), "{message}");
    }

    #[test]
    fn extensions_must_name_the_format() {
        assert_eq!(
            require_extension("--out", Path::new("k.EXR"), &["exr"]).unwrap(),
            "exr"
        );
        let message = require_extension("--out", Path::new("k.png"), &["exr"])
            .unwrap_err()
            .to_string();
        assert_eq!(
            message,
            "--out k.png: the extension must be .exr (the format written)"
        );
    }
}
