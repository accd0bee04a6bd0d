//! What the build reads: lenses (files, folders, `unicac design` libraries, `builtin:NAME`) and scenes
//! (image folders or files, `dead-leaves:N[:WxH]` charts), each with a stable id from its name and a
//! content hash.

use crate::error::{DatasetError, Result};
use crate::seeds::{derive_seed, parts_sha256_hex};
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use unicac_image::Planar;
use unicac_optics::{builtin, Lens, LensSpec};

pub use unicac_optics::builtin::BUILTIN_PREFIX;
const LENS_EXTENSIONS: [&str; 2] = ["json", "zmx"];
const IMAGE_EXTENSIONS: [&str; 4] = ["png", "tif", "tiff", "exr"];
/// Most lenses / scenes one build takes (a stated limit on the size of the plan held in memory).
pub const MAX_ITEMS: usize = 1_000_000;

/// One lens of the build.
#[derive(Debug, Clone)]
pub struct LensSource {
    /// `NAME-HASH12`: the file stem (sanitised) and the first 12 hex digits of `sha256`.
    pub lens_id: String,
    /// The path as given (a file name when the given path is absolute), for the manifest.
    pub source: String,
    /// Where to read it (`builtin:NAME` for built-in lenses).
    pub location: String,
    /// SHA-256 of the file's bytes, length-prefixed (`seeds::parts_sha256_hex`; of the spec's JSON for
    /// a built-in lens).
    pub sha256: String,
}

impl LensSource {
    /// Reads and validates the lens (errors name the file).
    pub fn load(&self) -> Result<Lens> {
        let spec = load_spec(&self.location)?;
        Lens::from_spec(&spec).map_err(DatasetError::optics(format!("lens {}", self.location)))
    }
}

fn load_spec(location: &str) -> Result<LensSpec> {
    // A bundled name is one of the `lenses` settings; a file may also come from a folder or a library.
    builtin::resolve_spec(Path::new(location))
        .map(|loaded| loaded.spec)
        .map_err(|e| match builtin::is_builtin(location) {
            true => DatasetError::setting("lenses", format!("{location}: {e}")),
            false => DatasetError::optics(format!("lens {location}"))(e),
        })
}

/// Expands every `lenses` argument; ids sorted, duplicates (same id) listed once. Folders are scanned
/// without entering `out` (the build's own output). With `exclude_flagged`, lenses of `unicac design`
/// libraries that fail basic photographic usefulness (`ManifestRow::photographic_flags`) are left out.
pub fn lens_sources(arguments: &[String], out: &Path, exclude_flagged: bool) -> Result<Vec<LensSource>> {
    let mut found = Vec::new();
    let mut flagged = 0;
    for argument in arguments {
        if let Some(name) = argument.strip_prefix(BUILTIN_PREFIX) {
            let spec = load_spec(argument)?;
            let json = serde_json::to_vec(&spec).expect("a spec serialises");
            found.push(source_for(name, argument.clone(), argument.clone(), &json));
            continue;
        }
        let path = Path::new(argument);
        if path.is_dir() {
            let manifest = path.join("manifest.jsonl");
            if manifest.is_file() {
                let (lenses, left_out) = library_lenses(argument, &manifest, exclude_flagged)?;
                found.extend(lenses);
                flagged += left_out;
            } else {
                for file in files_with(path, &LENS_EXTENSIONS, out)? {
                    found.push(file_source(&file, &display_path(argument, &file, path))?);
                }
            }
        } else {
            found.push(file_source(path, &recorded(argument))?);
        }
        if found.len() > MAX_ITEMS {
            return Err(DatasetError::setting(
                "lenses",
                format!("more than {MAX_ITEMS} lenses"),
            ));
        }
    }
    found.sort_by(|a, b| a.lens_id.cmp(&b.lens_id));
    found.dedup_by(|a, b| a.lens_id == b.lens_id);
    if found.is_empty() && flagged > 0 {
        return Err(DatasetError::setting(
            "exclude_flagged",
            format!(
                "{}: all {flagged} library lenses are flagged as failing photographic usefulness; \
                 nothing is left to build from",
                arguments.join(", ")
            ),
        ));
    }
    if found.is_empty() {
        return Err(DatasetError::setting(
            "lenses",
            format!("{}: no lens files found", arguments.join(", ")),
        ));
    }
    Ok(found)
}

/// The lenses a `unicac design` library lists (read only: the library is an input), without the
/// flagged ones when `exclude_flagged` (judged from each row's figures, so older libraries too).
/// Also returns how many rows were left out.
fn library_lenses(
    argument: &str,
    manifest: &Path,
    exclude_flagged: bool,
) -> Result<(Vec<LensSource>, usize)> {
    let rows: Vec<unicac_design::library::ManifestRow> = crate::manifest::read_jsonl(manifest)?;
    let dir = Path::new(argument);
    let kept: Vec<_> = rows
        .iter()
        .filter(|row| !exclude_flagged || row.photographic_flags().is_empty())
        .collect();
    let left_out = rows.len() - kept.len();
    let sources = kept
        .into_iter()
        .map(|row| {
            let file = dir.join(&row.json);
            file_source(
                &file,
                &recorded(&format!("{}/{}", argument.trim_end_matches('/'), row.json)),
            )
        })
        .collect::<Result<Vec<_>>>()?;
    Ok((sources, left_out))
}

fn file_source(path: &Path, source: &str) -> Result<LensSource> {
    let bytes = std::fs::read(path).map_err(|e| DatasetError::io(path, e))?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "lens".into());
    Ok(source_for(
        &stem,
        source.to_string(),
        path.to_string_lossy().into_owned(),
        &bytes,
    ))
}

fn source_for(stem: &str, source: String, location: String, bytes: &[u8]) -> LensSource {
    let sha256 = parts_sha256_hex(&[bytes]);
    LensSource {
        lens_id: format!("{}-{}", sanitise(stem), &sha256[..12]),
        source,
        location,
        sha256,
    }
}

/// Letters, digits, `-` and `_` (others become `_`), at most 48 characters: safe in file names.
pub fn sanitise(name: &str) -> String {
    let cleaned: String = name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .take(48)
        .collect();
    if cleaned.is_empty() {
        "x".into()
    } else {
        cleaned
    }
}

/// Manifests hold no absolute paths: an absolute argument is recorded by its file name.
fn recorded(argument: &str) -> String {
    let path = Path::new(argument);
    if path.is_absolute() {
        path.file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| argument.to_string())
    } else {
        argument.to_string()
    }
}

fn display_path(argument: &str, file: &Path, dir: &Path) -> String {
    let relative = file
        .strip_prefix(dir)
        .unwrap_or(file)
        .to_string_lossy()
        .into_owned();
    if Path::new(argument).is_absolute() {
        relative
    } else {
        format!("{}/{relative}", argument.trim_end_matches('/'))
    }
}

/// Files under `dir` (recursively, dot-named entries and the folder `skip` left out) with one of
/// `extensions`, sorted.
fn files_with(dir: &Path, extensions: &[&str], skip: &Path) -> Result<Vec<PathBuf>> {
    let skip = std::fs::canonicalize(skip).ok();
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(folder) = stack.pop() {
        if skip.is_some() && std::fs::canonicalize(&folder).ok() == skip {
            continue;
        }
        let entries = std::fs::read_dir(&folder).map_err(|e| DatasetError::io(&folder, e))?;
        for entry in entries {
            let entry = entry.map_err(|e| DatasetError::io(&folder, e))?;
            let path = entry.path();
            if entry.file_name().to_string_lossy().starts_with('.') {
                continue;
            }
            if path.is_dir() {
                stack.push(path);
            } else if path
                .extension()
                .map(|e| e.to_string_lossy().to_ascii_lowercase())
                .is_some_and(|e| extensions.contains(&e.as_str()))
            {
                out.push(path);
            }
        }
    }
    out.sort();
    Ok(out)
}

/// One scene (a sharp image) of the build.
#[derive(Debug, Clone)]
pub struct Scene {
    /// `NAME-HASH8` for files, `dead-leaves-KIND-INDEX` for charts.
    pub image_id: String,
    /// For the manifest: the path as given, or `dead-leaves:SEED:WxH`.
    pub source: String,
    pub kind: SceneKind,
}

#[derive(Debug, Clone)]
pub enum SceneKind {
    File { path: PathBuf, sha256: String },
    DeadLeaves { seed: u64, width: usize, height: usize },
}

/// Default size of generated charts when neither the chart nor `--frame` gives one.
pub const DEFAULT_CHART_PX: [usize; 2] = [1280, 800];
/// Most charts one `dead-leaves:N` argument makes.
pub const MAX_CHARTS: usize = 100_000;

/// What a `dead-leaves:N` source must look like.
fn chart_count_expected() -> String {
    format!("expected dead-leaves:N[:WxH] with 1 <= N <= {MAX_CHARTS}")
}

/// Where a build's scenes come from (`images`, `test_images`). Its text form, what the CLI takes and
/// `dataset.json` records: `dead-leaves:N[:WxH]` or a path.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SceneSource {
    /// `count` generated dead-leaves charts of `size_px` (None: the frame's size, else
    /// `DEFAULT_CHART_PX`).
    DeadLeaves {
        count: usize,
        size_px: Option<[usize; 2]>,
    },
    /// A PNG, TIFF or EXR file, or a folder of them (scanned recursively).
    Path(PathBuf),
}

impl std::str::FromStr for SceneSource {
    type Err = String;

    /// `dead-leaves:N[:WxH]` (N a whole number, the size as `parse_size` reads it), else a path.
    fn from_str(text: &str) -> std::result::Result<SceneSource, String> {
        let Some(spec) = text.strip_prefix("dead-leaves:") else {
            return Ok(SceneSource::Path(PathBuf::from(text)));
        };
        let mut parts = spec.splitn(2, ':');
        let count = parts
            .next()
            .and_then(|n| n.parse().ok())
            .ok_or_else(|| format!("{text}: {}", chart_count_expected()))?;
        let size_px = parts
            .next()
            .map(parse_size)
            .transpose()
            .map_err(|message| format!("{text}: {message}"))?;
        Ok(SceneSource::DeadLeaves { count, size_px })
    }
}

impl std::fmt::Display for SceneSource {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SceneSource::DeadLeaves { count, size_px: None } => write!(f, "dead-leaves:{count}"),
            SceneSource::DeadLeaves {
                count,
                size_px: Some([w, h]),
            } => write!(f, "dead-leaves:{count}:{w}x{h}"),
            SceneSource::Path(path) => write!(f, "{}", path.display()),
        }
    }
}

// Recorded in `dataset.json`'s settings in its text form (as the CLI was given it).
impl serde::Serialize for SceneSource {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> std::result::Result<S::Ok, S::Error> {
        serializer.collect_str(self)
    }
}

impl<'de> serde::Deserialize<'de> for SceneSource {
    fn deserialize<D: serde::Deserializer<'de>>(deserializer: D) -> std::result::Result<Self, D::Error> {
        let text = String::deserialize(deserializer)?;
        text.parse().map_err(serde::de::Error::custom)
    }
}

/// Scenes of an `images` / `test_images` source (`field` names it in errors); `kind` (`train` or
/// `test`) separates the chart seeds. Folders are scanned without entering `out`.
pub fn scenes(
    source: &SceneSource,
    field: &str,
    kind: &str,
    seed: u64,
    frame_px: Option<[usize; 2]>,
    out: &Path,
) -> Result<Vec<Scene>> {
    let argument = source.to_string();
    let invalid = |message: String| DatasetError::setting(field, format!("{argument}: {message}"));
    let path = match *source {
        SceneSource::Path(ref path) => path.as_path(),
        SceneSource::DeadLeaves { count, size_px } => {
            if !(1..=MAX_CHARTS).contains(&count) {
                return Err(invalid(chart_count_expected()));
            }
            let [width, height] = size_px.or(frame_px).unwrap_or(DEFAULT_CHART_PX);
            // Checked here, before any lens is graded, not when the first chart is drawn.
            unicac_image::charts::check_chart_size(width, height).map_err(|e| invalid(e.to_string()))?;
            return Ok((0..count)
                .map(|i| {
                    let chart_seed = derive_seed(
                        seed,
                        &[b"dead-leaves", kind.as_bytes(), &(i as u64).to_le_bytes()],
                    );
                    Scene {
                        image_id: format!("dead-leaves-{kind}-{i:04}"),
                        source: format!("dead-leaves:{chart_seed}:{width}x{height}"),
                        kind: SceneKind::DeadLeaves {
                            seed: chart_seed,
                            width,
                            height,
                        },
                    }
                })
                .collect());
        }
    };
    let files = if path.is_dir() {
        files_with(path, &IMAGE_EXTENSIONS, out)?
    } else if path.exists() {
        vec![path.to_path_buf()]
    } else {
        return Err(invalid("no such file or folder".into()));
    };
    if files.is_empty() {
        return Err(invalid("no PNG, TIFF or EXR images found".into()));
    }
    if files.len() > MAX_ITEMS {
        return Err(invalid(format!("more than {MAX_ITEMS} images (MAX_ITEMS)")));
    }
    files
        .iter()
        .map(|file| {
            let bytes = std::fs::read(file).map_err(|e| DatasetError::io(file, e))?;
            let sha256 = parts_sha256_hex(&[&bytes]);
            let stem = file
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default();
            let source = if path.is_dir() {
                display_path(&argument, file, path)
            } else {
                recorded(&argument)
            };
            Ok(Scene {
                image_id: format!("{}-{}", sanitise(&stem), &sha256[..8]),
                source,
                kind: SceneKind::File {
                    path: file.clone(),
                    sha256,
                },
            })
        })
        .collect()
}

/// SHA-256 of every scene file, by its source: the build's record of its scenes (charts are generated
/// from the seed and need none).
pub fn scene_hashes<'a>(
    scenes: impl Iterator<Item = &'a Scene>,
) -> std::collections::BTreeMap<String, String> {
    scenes
        .filter_map(|scene| match &scene.kind {
            SceneKind::File { sha256, .. } => Some((scene.source.clone(), sha256.clone())),
            SceneKind::DeadLeaves { .. } => None,
        })
        .collect()
}

/// "WxH" (unicac-image's one parser) with each side at most `MAX_FRAME_SIDE_PX`.
pub fn parse_size(text: &str) -> std::result::Result<[usize; 2], String> {
    let size = unicac_image::size::parse_wxh(text)?;
    if size.iter().any(|&side| side > crate::MAX_FRAME_SIDE_PX) {
        return Err(format!(
            "size {text:?}: each side must be at most {} px (MAX_FRAME_SIDE_PX)",
            crate::MAX_FRAME_SIDE_PX
        ));
    }
    Ok(size)
}

/// Bytes of decoded scenes a build keeps between lenses (a stated limit: 1 GiB, about 85 MP of linear RGB).
pub const SCENE_CACHE_BYTES: usize = 1 << 30;

/// Decoded scenes kept between lenses: every lens renders the same images, and decoding a file or
/// generating a chart costs as much as rendering its pair (0.6 s for a 1 MP dead-leaves chart). Holds
/// scenes until `budget_bytes` is reached; later ones are decoded each time they are needed (held
/// scenes are never evicted, which suits the build's loop over lenses that each visit the images in the same order).
pub struct SceneCache {
    budget_bytes: usize,
    held: Mutex<Held>,
}

/// What the cache holds, and whether the budget has refused a scene (then warming stops: decoding more
/// up front would only be thrown away).
#[derive(Default)]
struct Held {
    bytes: usize,
    scenes: HashMap<String, Arc<Planar>>,
    full: bool,
}

impl SceneCache {
    pub fn new(budget_bytes: usize) -> SceneCache {
        SceneCache {
            budget_bytes,
            held: Mutex::new(Held::default()),
        }
    }

    /// Decodes `scenes` in parallel before they are needed, until the budget refuses one: a build
    /// renders one lens at a time, and a lens with few pairs would otherwise decode them one by one.
    pub fn warm(&self, scenes: &[&Scene]) -> Result<()> {
        scenes.par_iter().try_for_each(|scene| {
            if self.lock().full {
                return Ok(());
            }
            self.get(scene).map(|_| ())
        })
    }

    /// The scene's linear pixels, decoded once while the budget lasts.
    pub fn get(&self, scene: &Scene) -> Result<Arc<Planar>> {
        if let Some(image) = self.lock().scenes.get(&scene.image_id) {
            return Ok(Arc::clone(image));
        }
        // Decoded outside the lock, so threads decode different scenes at once (two threads may decode
        // the same scene; the result is the same).
        let image = Arc::new(scene.load_linear()?);
        let bytes = image.data.len() * std::mem::size_of::<f32>();
        let mut held = self.lock();
        if held.bytes + bytes > self.budget_bytes {
            held.full = true;
        } else if !held.scenes.contains_key(&scene.image_id) {
            held.bytes += bytes;
            held.scenes.insert(scene.image_id.clone(), Arc::clone(&image));
        }
        Ok(image)
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Held> {
        // A panic elsewhere cannot leave the map half-updated (inserts are single calls), so a poisoned
        // lock is still usable.
        self.held.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

impl Scene {
    /// The scene's size without decoding pixels (charts) or by decoding the file.
    pub fn load_linear(&self) -> Result<Planar> {
        match &self.kind {
            SceneKind::DeadLeaves { seed, width, height } => {
                unicac_image::charts::dead_leaves(*width, *height, *seed)
                    .map_err(DatasetError::image(&self.source))
            }
            SceneKind::File { path, .. } => {
                let loaded = unicac_image::io::read_image(path)
                    .map_err(DatasetError::image(format!("image {}", path.display())))?;
                if loaded.image.width == 0 || loaded.image.height == 0 {
                    return Err(DatasetError::Invalid(format!(
                        "image {}: the image is empty",
                        path.display()
                    )));
                }
                loaded.into_linear_rgb().ok_or_else(|| {
                    DatasetError::Invalid(format!("image {}: expected a grey or RGB image", path.display()))
                })
            }
        }
    }

    /// The frame cut from the scene: the centred `frame` crop ([x0, y0, w, h]); an error naming the
    /// image when it is smaller than the frame.
    pub fn frame_crop(&self, width: usize, height: usize, frame: [usize; 2]) -> Result<[usize; 4]> {
        if width < frame[0] || height < frame[1] {
            return Err(DatasetError::setting(
                "frame_px",
                format!(
                    "{}x{}: larger than image {} ({width} x {height} px)",
                    frame[0], frame[1], self.source
                ),
            ));
        }
        Ok([
            (width - frame[0]) / 2,
            (height - frame[1]) / 2,
            frame[0],
            frame[1],
        ])
    }
}

/// Cuts [x0, y0, w, h] out of an image.
pub fn cut(image: &Planar, [x0, y0, w, h]: [usize; 4]) -> Planar {
    Planar::from_fn(w, h, image.channels, |c, x, y| image.get(c, x0 + x, y0 + y))
}
