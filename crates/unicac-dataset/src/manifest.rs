//! The manifests of a dataset directory (docs/dataset.md): row types, readers that check
//! `dataset.json`'s format version, and atomic writers. Every path inside is relative to DIR; nothing
//! run-specific (times, host names, absolute paths) is written outside `dataset.json`.

use crate::error::{DatasetError, Result};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use unicac_image::isp::SensorNoise;
use unicac_ode::OdeScores;

/// `dataset.json`'s `format`.
pub const FORMAT_NAME: &str = "unicac-dataset";
/// The layout this code writes and the newest it reads.
pub const FORMAT_VERSION: u32 = 1;

pub const DATASET_JSON: &str = "dataset.json";
pub const LENSES_JSONL: &str = "lenses.jsonl";
pub const LENSES_CSV: &str = "lenses.csv";
pub const PAIRS_JSONL: &str = "pairs.jsonl";
pub const EDGES_JSONL: &str = "edges.jsonl";

/// Split names, in manifest order.
pub const SPLITS: [&str; 3] = ["train", "val", "test"];

/// One lens of the library (`lenses.jsonl`, `lenses.csv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LensRow {
    /// Stable id: the file name's stem (sanitised) and the first 12 hex digits of `lens_sha256`.
    pub lens_id: String,
    /// The lens path as given on the command line (or the library manifest's entry).
    pub source: String,
    /// SHA-256 of the lens file's bytes, length-prefixed (`seeds::parts_sha256_hex`: not `sha256sum`).
    pub lens_sha256: String,
    #[serde(flatten)]
    pub scores: OdeScores,
    /// `train`, `val`, `test` or `unused`.
    pub split: String,
    /// ODE level of a test lens: 1 = mildest (highest ODE) .. `levels` = most severe.
    pub level: Option<u32>,
    /// U_s / U_c sub-benchmark level (1 = most uniform), when built with `--sub-benchmarks`.
    pub us_level: Option<u32>,
    pub uc_level: Option<u32>,
    /// Pixel pitch the ODE was graded with and the pairs are rendered at.
    #[serde(rename = "pixel_pitch_um")]
    pub pixel_um: f64,
    /// The lens's PSF table folder (`psf/LENS_ID`); empty for unused lenses.
    pub psf: String,
}

impl LensRow {
    /// The lens's level in the stratification by `metric` (`ode`, `u_s` or `u_c`).
    pub fn level_in(&self, metric: &str) -> Option<u32> {
        match metric {
            "u_s" => self.us_level,
            "u_c" => self.uc_level,
            _ => self.level,
        }
    }
}

/// The random draws of one pair's sensor/ISP chain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IspRecord {
    /// White-balance gains (R, G, B) used to invert and re-apply the white balance.
    pub white_balance_gains: [f32; 3],
    /// Standard deviation of the per-pair gain perturbation the gains were drawn with.
    pub white_balance_jitter: f32,
    /// Seed of the sensor noise (`None` when noiseless).
    pub noise_seed: Option<u64>,
    pub isp: bool,
    pub noise: bool,
    /// The sensor the pair was read out with.
    #[serde(flatten)]
    pub sensor: SensorNoise,
}

/// What a pair asks a model to undo (docs/dataset.md, "What a pair teaches").
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PairTask {
    /// The GT is the sharp scene carried through the lens's own distortion warp and shading, so LQ
    /// and GT differ by the blur (and the noise) alone: what the ODE grades.
    #[default]
    Aligned,
    /// The GT is the undistorted, unshaded scene: the model must also undo the geometry and the
    /// fall-off, which the ODE does not grade (levels then do not order the pairs' difficulty).
    Full,
}

impl PairTask {
    pub fn name(self) -> &'static str {
        match self {
            PairTask::Aligned => "aligned",
            PairTask::Full => "full",
        }
    }

    /// Whether the ODE levels order the difficulty of the pairs (they grade blur alone).
    pub fn comparable_by_ode_level(self) -> bool {
        self == PairTask::Aligned
    }

    /// Datasets written before the task existed carried the geometry in the LQ only.
    fn legacy() -> PairTask {
        PairTask::Full
    }
}

/// Sanity measurements of one rendered pair (docs/dataset.md, "Pair checks"), on the sRGB values
/// of the crop before PNG quantisation.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PairCheck {
    /// PSNR of LQ against GT (peak 1).
    pub lq_gt_psnr_db: f64,
    /// Mean over tiles of the length of the best shift of the GT (blurred by the lens in its own
    /// geometry) onto the LQ, on luminance (px).
    pub registration_px: f64,
    /// 1 - MSE(LQ', GT blurred by the lens) / MSE(LQ', GT), LQ' the LQ without noise, clamped to
    /// [0, 1]: the share of the lens's part of the pair's error that its blur explains.
    pub blur_share: f64,
}

/// One LQ/GT pair (`pairs.jsonl`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairRow {
    /// Also the file name stem in `SPLIT/lq/` and `SPLIT/gt/`.
    pub pair_id: String,
    pub split: String,
    pub lens_id: String,
    pub image_id: String,
    /// The scene: a file path as given, or `dead-leaves:SEED:WxH`.
    pub image_source: String,
    /// Relative paths of the degraded and ground-truth PNGs.
    pub lq: String,
    pub gt: String,
    /// The pair's seed; every draw below derives from it.
    pub seed: u64,
    /// The rendered sensor frame [W, H] (px).
    pub frame_px: [usize; 2],
    /// Where the frame came from in the scene image: [x0, y0, w, h] (px).
    pub scene_crop: [usize; 4],
    /// Where this pair sits in the frame: [x0, y0, w, h] (px); the whole frame for test pairs.
    pub crop: [usize; 4],
    #[serde(rename = "pixel_pitch_um")]
    pub pixel_um: f64,
    pub distortion: bool,
    pub illumination: bool,
    /// What the GT holds: `aligned` (the lens's geometry too) or `full` (the undistorted scene).
    #[serde(default = "PairTask::legacy")]
    pub task: PairTask,
    pub isp_draw: IspRecord,
    /// The lens's PSF table folder and the frame's FoV map (relative paths).
    pub psf: String,
    pub fov: String,
    /// Measured once the pair is rendered (every pair of a complete dataset has it).
    #[serde(flatten, skip_serializing_if = "Option::is_none")]
    pub check: Option<PairCheck>,
}

/// One slanted-edge patch of a test lens's ODE (`edges.jsonl`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EdgeRow {
    pub edge_id: String,
    pub lens_id: String,
    pub level: Option<u32>,
    /// Normalised image height of the ODE field (0 = centre, 1 = half-diagonal).
    pub field_fraction: f64,
    pub field_deg: f64,
    /// `R`, `G` or `B`: the channel whose kernel blurred the (grey) edge.
    pub channel: String,
    /// `sagittal` (near-vertical edge) or `tangential` (its transpose).
    pub direction: String,
    pub lq: String,
    pub gt: String,
    pub size_px: usize,
    pub slant_deg: f64,
    #[serde(rename = "pixel_pitch_um")]
    pub pixel_um: f64,
}

/// One level of a stratification.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LevelSummary {
    /// 1 = mildest.
    pub level: u32,
    pub lenses: usize,
    /// The level holds the lenses whose metric lies in [lower, upper].
    pub lower: f64,
    pub upper: f64,
    /// Distribution of the four scores over the level's lenses: [min, mean, max].
    pub ode: [f64; 3],
    pub oiq: [f64; 3],
    pub u_s: [f64; 3],
    pub u_c: [f64; 3],
}

/// How lenses were stratified by one metric (`ode`, `u_s` or `u_c`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Stratification {
    pub metric: String,
    /// The rule, in words (docs/dataset.md has the full statement).
    pub rule: String,
    /// Level boundaries, descending (mild to severe): level k holds [thresholds[k], thresholds[k-1]].
    pub thresholds: Vec<f64>,
    pub levels: Vec<LevelSummary>,
}

/// `dataset.json`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct DatasetManifest {
    pub format: String,
    pub format_version: u32,
    pub unicac_version: String,
    /// The build's settings (the command's options, with defaults filled in).
    pub settings: serde_json::Value,
    pub seed: u64,
    /// Rendered sensor frame [W, H] (px).
    pub frame_px: [usize; 2],
    /// `ode`, then `u_s` and `u_c` when built with sub-benchmarks.
    pub stratifications: Vec<Stratification>,
    /// Lenses per split, pairs per split, edge patches.
    pub counts: Counts,
    /// What the pairs ask a model to undo (also in `settings`).
    #[serde(default = "PairTask::legacy")]
    pub task: PairTask,
    /// Whether the ODE levels order the pairs' difficulty: false for `full` pairs, whose error is
    /// dominated by geometry the ODE does not grade.
    #[serde(default)]
    pub comparable_by_ode_level: bool,
}

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Counts {
    pub lenses: BTreeMap<String, usize>,
    pub pairs: BTreeMap<String, usize>,
    pub edges: usize,
    pub train_images: usize,
    pub test_images: usize,
}

/// Reads and checks `DIR/dataset.json`.
pub fn read_manifest(dir: &Path) -> Result<DatasetManifest> {
    let path = dir.join(DATASET_JSON);
    let bytes = match std::fs::read(&path) {
        Ok(bytes) => bytes,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(DatasetError::NotADataset {
                path: dir.to_path_buf(),
            })
        }
        Err(e) => return Err(DatasetError::io(path, e)),
    };
    let value: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| DatasetError::format(&path, e.to_string()))?;
    if value.get("format").and_then(|f| f.as_str()) != Some(FORMAT_NAME) {
        return Err(DatasetError::NotADataset {
            path: dir.to_path_buf(),
        });
    }
    let found = value
        .get("format_version")
        .and_then(|v| v.as_u64())
        .ok_or_else(|| DatasetError::format(&path, "missing field `format_version`"))?;
    if found > FORMAT_VERSION as u64 {
        return Err(DatasetError::NewerFormat {
            path,
            found: found.min(u32::MAX as u64) as u32,
            supported: FORMAT_VERSION,
        });
    }
    serde_json::from_value(value).map_err(|e| DatasetError::format(&path, e.to_string()))
}

/// Rows of a JSON-lines file (blank lines skipped); errors name the file and line.
pub fn read_jsonl<T: DeserializeOwned>(path: &Path) -> Result<Vec<T>> {
    let text = std::fs::read_to_string(path).map_err(|e| DatasetError::io(path, e))?;
    text.lines()
        .enumerate()
        .filter(|(_, line)| !line.trim().is_empty())
        .map(|(i, line)| {
            serde_json::from_str(line).map_err(|e| DatasetError::format(path, format!("line {}: {e}", i + 1)))
        })
        .collect()
}

/// The bytes of a JSON-lines file: one compact row per line, in the given order.
pub fn jsonl_bytes<T: Serialize>(rows: &[T]) -> Vec<u8> {
    let mut bytes = Vec::new();
    for row in rows {
        serde_json::to_writer(&mut bytes, row).expect("rows serialise");
        bytes.push(b'\n');
    }
    bytes
}

/// Writes rows as JSON lines, atomically.
pub fn write_jsonl<T: Serialize>(path: &Path, rows: &[T]) -> Result<()> {
    write_atomically(path, &jsonl_bytes(rows))
}

/// Pretty JSON with a final newline, atomically.
pub fn write_json<T: Serialize>(path: &Path, value: &T) -> Result<()> {
    let mut bytes = serde_json::to_vec_pretty(value).expect("value serialises");
    bytes.push(b'\n');
    write_atomically(path, &bytes)
}

/// `lenses.csv`: the columns of `lenses.jsonl`, empty cells for absent levels.
pub fn lenses_csv(rows: &[LensRow]) -> Vec<u8> {
    let mut out = Vec::new();
    writeln!(
        out,
        "lens_id,source,lens_sha256,{},split,level,us_level,uc_level,pixel_pitch_um,psf",
        OdeScores::NAMES.join(",")
    )
    .expect("in memory");
    let level = |l: Option<u32>| l.map(|v| v.to_string()).unwrap_or_default();
    for r in rows {
        let scores: Vec<String> = r.scores.values().iter().map(f64::to_string).collect();
        writeln!(
            out,
            "{},{},{},{},{},{},{},{},{},{}",
            r.lens_id,
            csv_field(&r.source),
            r.lens_sha256,
            scores.join(","),
            r.split,
            level(r.level),
            level(r.us_level),
            level(r.uc_level),
            r.pixel_um,
            r.psf
        )
        .expect("in memory");
    }
    out
}

fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n']) {
        format!("\"{}\"", text.replace('"', "\"\""))
    } else {
        text.to_string()
    }
}

/// Writes `bytes` to `path` atomically with unicac-io (parent folders made).
pub fn write_atomically(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
        std::fs::create_dir_all(parent).map_err(|e| DatasetError::io(parent, e))?;
    }
    unicac_io::write_atomically(path, bytes).map_err(|e| DatasetError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn jsonl_round_trips_and_names_the_bad_line() {
        let dir = std::env::temp_dir().join(format!("unicac-dataset-jsonl-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let row = EdgeRow {
            edge_id: "a".into(),
            lens_id: "l".into(),
            level: Some(2),
            field_fraction: 0.25,
            field_deg: 3.5,
            channel: "G".into(),
            direction: "sagittal".into(),
            lq: "edges/lq/a.png".into(),
            gt: "edges/gt/a.png".into(),
            size_px: 64,
            slant_deg: 5.0,
            pixel_um: 1.1,
        };
        let path = dir.join(EDGES_JSONL);
        write_jsonl(&path, &[row.clone(), row.clone()]).unwrap();
        assert_eq!(read_jsonl::<EdgeRow>(&path).unwrap(), vec![row.clone(), row]);
        std::fs::write(&path, "{}\n").unwrap();
        let error = read_jsonl::<EdgeRow>(&path).unwrap_err().to_string();
        assert!(
            error.contains("line 1") && error.contains("edges.jsonl"),
            "{error}"
        );
        assert!(std::fs::read_dir(&dir)
            .unwrap()
            .all(|e| !unicac_io::is_temporary_name(&e.unwrap().file_name().to_string_lossy())));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
