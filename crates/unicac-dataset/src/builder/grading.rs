//! The ODE of every lens, graded on the sensor its pairs are rendered with (docs/dataset.md), and
//! cached on disk by content: the lens model, the sensor and the ODE settings.

use crate::error::{DatasetError, Result};
use crate::seeds::parts_sha256_hex;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use unicac_io::digest::canonical_json;
use unicac_ode::{OdeReport, OdeScores, OdeSettings};
use unicac_optics::Lens;

/// The scores of a lens that the dataset records (the ODE report without its timings and tables).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Grade {
    #[serde(flatten)]
    pub scores: OdeScores,
    pub pixel_um: f64,
    pub half_diagonal_mm: f64,
    pub kernel_px: usize,
}

impl From<&OdeReport> for Grade {
    fn from(r: &OdeReport) -> Grade {
        Grade {
            scores: r.scores,
            pixel_um: r.pixel_um,
            half_diagonal_mm: r.half_diagonal_mm,
            kernel_px: r.kernel_px,
        }
    }
}

/// The sensor of a build: the rule `unicac ode --frame` grades with (one implementation, in unicac-ode).
pub use unicac_ode::FrameSensor as BuildSensor;

/// On-disk cache of grades: `DIR/<key>.json`.
#[derive(Debug, Clone)]
pub struct GradeCache {
    pub dir: PathBuf,
}

/// The lens as the build sees it: a hash of the model every number the tracer reads (the PSF cache's
/// `lens_fingerprint`), without the lens's display name. Two files (a copy with another name or a
/// trailing newline, a `.zmx` conversion, a built-in lens) holding the same model share it: the grade
/// cache keys grades by it, and the build refuses two sources with one model.
pub fn model_fingerprint(lens: &Lens) -> String {
    let mut unnamed = lens.clone();
    unnamed.name.clear();
    unicac_sim::lens_fingerprint(&unnamed)
}

impl GradeCache {
    fn key(lens: &Lens, settings: &OdeSettings) -> String {
        parts_sha256_hex(&[
            b"unicac-dataset-ode 2",
            env!("CARGO_PKG_VERSION").as_bytes(),
            model_fingerprint(lens).as_bytes(),
            &canonical_json(&(settings, &settings.backend)),
        ])
    }

    fn path(&self, key: &str) -> PathBuf {
        self.dir.join(format!("{key}.json"))
    }

    /// The lens's grade, from the cache or computed (and stored). `what` names the lens in errors.
    pub fn grade(&self, lens: &Lens, settings: &OdeSettings, what: &str) -> Result<(Grade, bool)> {
        let key = GradeCache::key(lens, settings);
        let path = self.path(&key);
        if let Some(grade) = std::fs::read(&path)
            .ok()
            .and_then(|bytes| serde_json::from_slice::<Grade>(&bytes).ok())
        {
            return Ok((grade, true));
        }
        let report = unicac_ode::evaluate(lens, settings)
            .map_err(DatasetError::ode(format!("lens {what}: the ODE failed")))?;
        let grade = Grade::from(&report);
        for (name, value) in [
            ("ode", grade.scores.ode),
            ("oiq", grade.scores.oiq),
            ("u_s", grade.scores.u_s),
            ("u_c", grade.scores.u_c),
        ] {
            if !value.is_finite() {
                return Err(DatasetError::Invalid(format!(
                    "lens {what}: the ODE gave a non-finite {name}"
                )));
            }
        }
        crate::manifest::write_json(&path, &grade)?;
        Ok((grade, false))
    }
}

/// Where the cache of a dataset folder lives.
pub fn cache_dir(out: &Path) -> PathBuf {
    out.join(".cache")
}
