//! The as-built test split (`dataset build --as-built N --tolerances TOL.json`, issue 36): every test
//! lens is also built N times within the tolerance file's limits (`unicac_tolerance`: drawn errors as
//! `unicac tolerance` draws them, then focused by the file's compensator as the design is focused:
//! `built_unit_at_design_focus`, so a unit differs from its design by its errors alone) and every test pair
//! is rendered again through each unit, on the design's sensor and from the same scene crop and seed.
//! Each test pair is also rendered through the design itself by the same path (`LENS__d`: the planar
//! maps, which every unit needs; the test split's radial path turns its kernels by resampling, which
//! would tell design and units apart by the path as well as by their errors). What a restoration model
//! loses on units as they leave the factory is then the bench's `--split as_built` (each unit pair
//! against its design pair; docs/dataset.md, "As-built split").
//!
//! Files, under `as_built/`: `units.jsonl` (one row per unit and one per design reference, `unit`
//! null: its design, drawn errors, focus and ODE, the design's levels), `pairs.jsonl` (the test pairs'
//! rows per unit and design reference, `lens_id` the unit's id, `psf` the design's PSF table:
//! non-blind methods know the design, not the unit), `lq/`, `gt/` and `check/`. Written by the run that completes the dataset, after it; resumable like the test pairs
//! (a pair is done when its check file exists), `pairs.jsonl` last.

use std::collections::BTreeMap;
use std::path::Path;

use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use unicac_io::progress::Progress;
use unicac_ode::OdeScores;
use unicac_optics::Lens;
use unicac_tolerance::{Change, Grading, MonteCarlo, ToleranceSpec};

use super::{pair_complete, render, render_and_write, sources, PlannedLens};
use crate::error::{DatasetError, Result};
use crate::manifest::{self, LensRow, PairRow};
use crate::seeds::derive_seed;

/// Most units per test lens.
pub const MAX_AS_BUILT_UNITS: usize = 16;
/// The split's name (pair rows, the bench's `--split`).
pub const AS_BUILT_SPLIT: &str = "as_built";
pub const UNITS_JSONL: &str = "as_built/units.jsonl";
pub const AS_BUILT_PAIRS_JSONL: &str = "as_built/pairs.jsonl";

/// What the as-built split is made of (recorded in `dataset.json`'s settings).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct AsBuiltSettings {
    /// Units per test lens (1 to `MAX_AS_BUILT_UNITS`).
    pub units: usize,
    /// The tolerance file's content (docs/tolerancing.md), so the record names what was drawn.
    pub tolerances: ToleranceSpec,
}

impl AsBuiltSettings {
    pub fn check(&self) -> Result<()> {
        if !(1..=MAX_AS_BUILT_UNITS).contains(&self.units) {
            return Err(DatasetError::setting(
                "as_built",
                format!(
                    "{}: takes 1 to {MAX_AS_BUILT_UNITS} units per test lens",
                    self.units
                ),
            ));
        }
        self.tolerances
            .check()
            .map_err(|e| DatasetError::setting("tolerances", e.to_string()))
    }
}

/// One built unit of a test lens, or the design's reference (`as_built/units.jsonl`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct UnitRow {
    /// `LENS_ID__uK` (`LENS_ID__d` for the design's reference): the `lens_id` of its pairs.
    pub unit_id: String,
    /// The design it was built from.
    pub lens_id: String,
    /// K; None for the design's reference (no errors: the design through the units' path).
    pub unit: Option<usize>,
    /// The design's levels (the unit is scored at its design's level).
    pub level: Option<u32>,
    pub us_level: Option<u32>,
    pub uc_level: Option<u32>,
    /// The drawn errors (`unicac tolerance`'s changes) and the compensator's image shift relative to the
    /// design's own best-focus shift.
    pub changes: Vec<Change>,
    pub focus_shift_mm: f64,
    /// The refocused unit's ODE and scores, graded on the dataset's sensor (docs/ode.md, "A built unit");
    /// the design's grade for its reference.
    #[serde(flatten)]
    pub scores: OdeScores,
}

impl UnitRow {
    /// The design's reference row: no errors, its grade.
    fn design(row: &LensRow) -> UnitRow {
        UnitRow {
            unit_id: format!("{}__d", row.lens_id),
            lens_id: row.lens_id.clone(),
            unit: None,
            level: row.level,
            us_level: row.us_level,
            uc_level: row.uc_level,
            changes: Vec::new(),
            focus_shift_mm: 0.0,
            scores: row.scores,
        }
    }

    /// The suffix of its pairs' ids: `__uK`, or `__d` for the design's reference.
    fn suffix(&self) -> String {
        self.unit.map_or("__d".into(), |k| format!("__u{k}"))
    }
}

/// The design pair or lens id a unit's or design reference's id comes from (`X__uK`, `X__d` -> `X`).
pub fn design_of(id: &str) -> &str {
    match id.rsplit_once("__") {
        Some((design, "d")) => design,
        Some((design, unit)) if unit.strip_prefix('u').is_some_and(|k| k.parse::<usize>().is_ok()) => design,
        _ => id,
    }
}

/// The design's reference, then test lens `row`'s units, drawn, built and graded (the same for every
/// run: the draw's seed comes from the dataset's seed and the lens id).
fn units_of(
    row: &LensRow,
    lens: &Lens,
    settings: &AsBuiltSettings,
    seed: u64,
    ode: &unicac_ode::OdeSettings,
) -> Result<Vec<(UnitRow, Lens)>> {
    let request = MonteCarlo {
        lens_identity: row.lens_id.clone(),
        spec: settings.tolerances.clone(),
        grading: Grading::default(),
        seed: derive_seed(seed, &[b"as-built", row.lens_id.as_bytes()]),
        trials: settings.units,
    };
    let units = (0..settings.units).map(|k| {
        let context = || format!("lens {}: as-built unit {k}", row.lens_id);
        let built = unicac_tolerance::built_unit_at_design_focus(lens, &request, k as u64)
            .map_err(|e| DatasetError::setting("tolerances", format!("{}: {e}", context())))?;
        let report = unicac_ode::evaluate(&built.lens, ode).map_err(DatasetError::ode(context()))?;
        let row = UnitRow {
            unit_id: format!("{}__u{k}", row.lens_id),
            lens_id: row.lens_id.clone(),
            unit: Some(k),
            level: row.level,
            us_level: row.us_level,
            uc_level: row.uc_level,
            changes: built.changes,
            focus_shift_mm: built.score.focus_shift_mm,
            scores: report.scores,
        };
        Ok((row, built.lens))
    });
    std::iter::once(Ok((UnitRow::design(row), lens.clone())))
        .chain(units)
        .collect()
}

/// The as-built pair rows of `unit` from its design's test pairs.
fn pairs_of(unit: &UnitRow, design_pairs: &[&PairRow]) -> Vec<PairRow> {
    design_pairs
        .iter()
        .map(|p| {
            let pair_id = format!("{}{}", p.pair_id, unit.suffix());
            PairRow {
                lq: format!("{AS_BUILT_SPLIT}/lq/{pair_id}.png"),
                gt: format!("{AS_BUILT_SPLIT}/gt/{pair_id}.png"),
                pair_id,
                split: AS_BUILT_SPLIT.into(),
                lens_id: unit.unit_id.clone(),
                check: None,
                ..(*p).clone()
            }
        })
        .collect()
}

/// What the as-built stage needs of the build.
pub(super) struct Context<'a> {
    pub settings: &'a super::BuildSettings,
    pub as_built: &'a AsBuiltSettings,
    pub out: &'a Path,
    pub plan: &'a super::Plan,
    pub planned: &'a [PlannedLens],
    pub scenes: &'a BTreeMap<&'a str, &'a sources::Scene>,
    pub ode: &'a unicac_ode::OdeSettings,
    pub depth: unicac_image::io::SampleDepth,
}

/// Builds every test lens's units and renders the as-built pairs not yet complete; writes the two
/// manifests. Returns the pairs rendered.
pub(super) fn render_as_built(context: &Context, progress: &dyn Progress) -> Result<usize> {
    let Context {
        settings,
        as_built,
        out,
        plan,
        planned,
        scenes,
        ode,
        depth,
    } = *context;
    let test: Vec<usize> = (0..plan.lenses.len())
        .filter(|&i| plan.lenses[i].split == "test")
        .collect();
    if finished(out, plan, &test, as_built.units)? {
        return Ok(0);
    }
    progress.stage("as-built units", test.len() * (as_built.units + 1));
    let mut units: Vec<(UnitRow, Lens, usize)> = Vec::new();
    for &i in &test {
        for (row, lens) in units_of(&plan.lenses[i], &planned[i].lens, as_built, settings.seed, ode)? {
            units.push((row, lens, i));
            progress.advance(1);
        }
    }
    let unit_pairs: Vec<Vec<PairRow>> = (units.iter())
        .map(|(unit, _, i)| {
            let design_pairs: Vec<&PairRow> = (plan.pairs.iter())
                .filter(|p| p.split == "test" && p.lens_id == plan.lenses[*i].lens_id)
                .collect();
            pairs_of(unit, &design_pairs)
        })
        .collect();
    progress.stage("as-built pairs", unit_pairs.iter().map(Vec::len).sum());
    let mut rows = Vec::new();
    let mut rendered = 0;
    let scene_cache = sources::SceneCache::new(sources::SCENE_CACHE_BYTES);
    for ((unit, lens, i), pairs) in units.iter().zip(unit_pairs) {
        let missing: Vec<&PairRow> = pairs.iter().filter(|p| !pair_complete(out, p)).collect();
        if !missing.is_empty() {
            let sim = render::unit_simulator(
                lens,
                &planned[*i].lens,
                plan.frame_px,
                planned[*i].grade.pixel_um,
                settings.distortion,
                settings.illumination,
                settings.image.clone(),
            )
            .map_err(DatasetError::simulation(format!(
                "as-built unit {}",
                unit.unit_id
            )))?;
            missing.par_iter().try_for_each(|pair| {
                render_and_write(
                    out,
                    &sim,
                    &scene_cache,
                    scenes[pair.image_id.as_str()],
                    pair,
                    depth,
                )
            })?;
            rendered += missing.len();
        }
        progress.advance(pairs.len());
        rows.extend(pairs);
    }
    let unit_rows: Vec<UnitRow> = units.into_iter().map(|(row, _, _)| row).collect();
    manifest::write_atomically(&out.join(UNITS_JSONL), &manifest::jsonl_bytes(&unit_rows))?;
    let rows = super::with_checks(out, &rows)?;
    manifest::write_atomically(&out.join(AS_BUILT_PAIRS_JSONL), &manifest::jsonl_bytes(&rows))?;
    Ok(rendered)
}

/// Whether a previous run wrote the whole split: both manifests, one row per expected unit and design
/// reference, every pair complete (then nothing is graded or rendered again).
fn finished(out: &Path, plan: &super::Plan, test: &[usize], units: usize) -> Result<bool> {
    let Some((rows, pairs)) = read_as_built(out)? else {
        return Ok(false);
    };
    let expected: Vec<String> = (test.iter())
        .flat_map(|&i| {
            let id = &plan.lenses[i].lens_id;
            std::iter::once(format!("{id}__d")).chain((0..units).map(move |k| format!("{id}__u{k}")))
        })
        .collect();
    let found: Vec<&str> = rows.iter().map(|r| r.unit_id.as_str()).collect();
    Ok(found == expected && pairs.iter().all(|p| pair_complete(out, p)))
}

/// A dataset's as-built units and pairs (`as_built/`), or None when it was built without them.
pub fn read_as_built(dir: &Path) -> Result<Option<(Vec<UnitRow>, Vec<PairRow>)>> {
    let (units, pairs) = (dir.join(UNITS_JSONL), dir.join(AS_BUILT_PAIRS_JSONL));
    if !pairs.exists() {
        return Ok(None);
    }
    let units: Vec<UnitRow> = manifest::read_jsonl(&units)?;
    let rows: Vec<PairRow> = manifest::read_jsonl(&pairs)?;
    if let Some(stray) = rows
        .iter()
        .find(|p| !units.iter().any(|u| u.unit_id == p.lens_id))
    {
        return Err(DatasetError::format(
            dir.join(AS_BUILT_PAIRS_JSONL),
            format!(
                "pair {} names unit {}, which units.jsonl does not hold",
                stray.pair_id, stray.lens_id
            ),
        ));
    }
    Ok(Some((units, rows)))
}
