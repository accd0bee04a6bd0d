//! The lens library on disk: every accepted design as unicac JSON, Zemax .zmx, a report (spec, merit,
//! every check by name, RMS spot) and a layout plot, plus a manifest with one row per lens (JSON lines
//! and CSV) so that thousands of lenses can be filtered.
//!
//! Every file is written atomically (temporary sibling, then rename), the lens files before the manifest
//! row that lists them, so an interrupted run never leaves a listed lens half-written. A run resumes by
//! reading the manifest (finished lenses are kept and not redone) and the per-spec search checkpoint in
//! `state/` (the global stage is not repeated; candidates already finished are skipped).

use crate::error::{DesignError, Result};
use crate::merit::Terms;
use crate::spec::DesignSpec;
use crate::verify::Verification;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use unicac_optics::io::write_atomically;
use unicac_optics::LensSpec;

/// One manifest row.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ManifestRow {
    pub id: String,
    pub spec: String,
    pub elements: usize,
    pub half_fov_deg: f64,
    pub f_number: f64,
    pub stop: String,
    pub focal_length_mm: f64,
    pub aspheric: bool,
    /// The spherical design an aspheric one was made from ("" for spherical designs).
    pub parent: String,
    pub merit: f64,
    pub rms_mean_um: f64,
    pub rms_max_um: f64,
    pub distortion_max_percent: f64,
    pub relative_illumination_edge: f64,
    pub lateral_colour_max_um: f64,
    pub total_track_mm: f64,
    pub back_focal_mm: f64,
    pub efl_mm: f64,
    pub glasses: String,
    pub seed: u64,
    /// Seconds from the start of the run (of this spec) to this lens being written.
    pub elapsed_s: f64,
    pub json: String,
    pub zmx: String,
    /// Why the lens fails basic photographic usefulness ([`ManifestRow::photographic_flags`], written
    /// with the row; empty for a usable lens and in libraries made before flags existed).
    #[serde(default)]
    pub flags: Vec<String>,
}

const CSV_COLUMNS: &str = "id,spec,elements,half_fov_deg,f_number,stop,focal_length_mm,aspheric,parent,merit,rms_mean_um,rms_max_um,distortion_max_percent,relative_illumination_edge,lateral_colour_max_um,total_track_mm,back_focal_mm,efl_mm,glasses,seed,elapsed_s,json,zmx,flags";

/// Edge relative illumination below which a lens is flagged: 0.3, about 1.7 stops of fall-off (a
/// 40-degree half field alone loses cos^4 = 0.34 to natural vignetting; designs below 0.3 add pupil
/// distortion on top).
pub const MIN_EDGE_RELATIVE_ILLUMINATION: f64 = 0.3;

/// Largest lateral colour (F-C chief-ray separation, any field) as a fraction of the image height
/// f tan(half field) before a lens is flagged: 0.25 % (45 um for f = 50 mm over 20 degrees, 105 um over
/// 40 degrees), a visible colour fringe of several pixels on any sensor that image height fills.
pub const MAX_LATERAL_COLOUR_FRACTION: f64 = 0.0025;

impl ManifestRow {
    /// Each way this lens fails basic photographic usefulness, as `name: value (limit)`: edge relative
    /// illumination below [`MIN_EDGE_RELATIVE_ILLUMINATION`], lateral colour above
    /// [`MAX_LATERAL_COLOUR_FRACTION`] of the image height. Computed from the row's own figures, so
    /// libraries made before flags existed are judged by the same rule.
    pub fn photographic_flags(&self) -> Vec<String> {
        let mut flags = Vec::new();
        if self.relative_illumination_edge < MIN_EDGE_RELATIVE_ILLUMINATION {
            flags.push(format!(
                "relative_illumination_edge: {:.3} (floor {MIN_EDGE_RELATIVE_ILLUMINATION})",
                self.relative_illumination_edge
            ));
        }
        let image_height_um = 1e3 * self.focal_length_mm * self.half_fov_deg.to_radians().tan();
        let bound_um = MAX_LATERAL_COLOUR_FRACTION * image_height_um;
        if self.lateral_colour_max_um > bound_um {
            flags.push(format!(
                "lateral_colour_max_um: {:.1} (bound {bound_um:.1}, {MAX_LATERAL_COLOUR_FRACTION} of the image height)",
                self.lateral_colour_max_um
            ));
        }
        flags
    }

    fn csv(&self) -> String {
        // Flag names only (the values are in their own columns): no commas inside the CSV cell.
        let flag_names: Vec<&str> = self
            .flags
            .iter()
            .map(|f| f.split(':').next().unwrap_or(f))
            .collect();
        format!(
            "{},{},{},{},{},{},{},{},{},{:.6e},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.6},{},{},{:.2},{},{},{}",
            self.id,
            self.spec,
            self.elements,
            self.half_fov_deg,
            self.f_number,
            self.stop,
            self.focal_length_mm,
            self.aspheric,
            self.parent,
            self.merit,
            self.rms_mean_um,
            self.rms_max_um,
            self.distortion_max_percent,
            self.relative_illumination_edge,
            self.lateral_colour_max_um,
            self.total_track_mm,
            self.back_focal_mm,
            self.efl_mm,
            self.glasses,
            self.seed,
            self.elapsed_s,
            self.json,
            self.zmx,
            flag_names.join(";")
        )
    }
}

/// The report written next to each lens.
#[derive(Debug, Clone, Serialize)]
pub struct Report<'a> {
    pub id: &'a str,
    pub spec: &'a DesignSpec,
    pub merit: f64,
    pub terms: &'a Terms,
    pub verification: &'a Verification,
    pub parent: Option<&'a str>,
    pub parent_rms_mean_um: Option<f64>,
}

/// A finished design ready to be written.
pub struct Entry<'a> {
    pub spec: &'a DesignSpec,
    pub aspheric: bool,
    pub parent: Option<String>,
    pub parent_rms_mean_um: Option<f64>,
    pub lens: &'a LensSpec,
    pub terms: &'a Terms,
    pub verification: &'a Verification,
    pub seed: u64,
    pub elapsed_s: f64,
}

pub struct Library {
    pub dir: PathBuf,
    pub rows: Vec<ManifestRow>,
    /// What went wrong but lost nothing (a layout plot not drawn), for the caller to show.
    notes: Vec<String>,
}

fn io_error(path: &Path) -> impl FnOnce(std::io::Error) -> DesignError + '_ {
    move |source| DesignError::Io {
        path: path.to_path_buf(),
        source,
    }
}

impl Library {
    /// Opens (creating) a library directory and reads its manifest.
    pub fn open(dir: &Path) -> Result<Library> {
        for sub in ["", "lenses", "state"] {
            let path = dir.join(sub);
            std::fs::create_dir_all(&path).map_err(io_error(&path))?;
            // Temporaries a killed run left behind (`.manifest.csv.tmp-*`, ...) go on resume.
            unicac_io::clean_stale_temporaries(&path).map_err(io_error(&path))?;
        }
        let manifest = dir.join("manifest.jsonl");
        let rows = match std::fs::read_to_string(&manifest) {
            Ok(text) => text
                .lines()
                .filter(|l| !l.trim().is_empty())
                .enumerate()
                .map(|(i, line)| {
                    serde_json::from_str(line).map_err(|e| DesignError::Resume {
                        path: manifest.clone(),
                        message: format!("line {}: {e}", i + 1),
                    })
                })
                .collect::<Result<Vec<ManifestRow>>>()?,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
            Err(e) => return Err(io_error(&manifest)(e)),
        };
        Ok(Library {
            dir: dir.to_path_buf(),
            rows,
            notes: Vec::new(),
        })
    }

    pub fn rows_for<'a>(&'a self, slug: &'a str) -> impl Iterator<Item = &'a ManifestRow> + 'a {
        self.rows.iter().filter(move |r| r.spec == slug)
    }

    /// Whether a lens with the same spec, kind and figures (RMS and total track to 1e-6) is listed.
    pub fn is_duplicate(&self, slug: &str, aspheric: bool, rms_mean_um: f64, total_track_mm: f64) -> bool {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1e-9);
        self.rows_for(slug).any(|r| {
            r.aspheric == aspheric
                && close(r.rms_mean_um, rms_mean_um)
                && close(r.total_track_mm, total_track_mm)
        })
    }

    /// Writes the lens files, report and layout plot, then lists the lens in the manifest. Returns the id.
    pub fn add(&mut self, entry: &Entry<'_>) -> Result<String> {
        let slug = entry.spec.slug();
        let kind = if entry.aspheric { "a" } else { "s" };
        // One past the highest number in use: ids stay unique when replaced lenses have been removed.
        let prefix = format!("{slug}_{kind}");
        let number = self
            .rows_for(&slug)
            .filter_map(|r| r.id.strip_prefix(&prefix)?.parse::<usize>().ok())
            .max()
            .unwrap_or(0)
            + 1;
        let id = format!("{slug}_{kind}{number:03}");
        let base = self.dir.join("lenses").join(&id);
        let json = base.with_extension("json");
        let zmx = base.with_extension("zmx");
        unicac_optics::write_spec(entry.lens, &json)?;
        unicac_optics::write_spec(entry.lens, &zmx)?;
        let report = Report {
            id: &id,
            spec: entry.spec,
            merit: entry.terms.merit,
            terms: entry.terms,
            verification: entry.verification,
            parent: entry.parent.as_deref(),
            parent_rms_mean_um: entry.parent_rms_mean_um,
        };
        let report_path = self.dir.join("lenses").join(format!("{id}.report.json"));
        let text = serde_json::to_string_pretty(&report).unwrap_or_default();
        write_atomically(&report_path, text.as_bytes())?;
        // A plot that cannot be drawn (no fonts on a server) must not lose the lens: note it and go on.
        if let Err(e) = layout_plot(entry.lens, &base.with_extension("png")) {
            self.notes.push(format!("{id}: layout plot not written: {e}"));
        }
        let t = entry.terms;
        let mut row = ManifestRow {
            id: id.clone(),
            spec: slug,
            elements: entry.spec.elements,
            half_fov_deg: entry.spec.half_fov_deg,
            f_number: entry.spec.f_number,
            stop: entry.spec.stop.name().into(),
            focal_length_mm: entry.spec.focal_length_mm,
            aspheric: entry.aspheric,
            parent: entry.parent.clone().unwrap_or_default(),
            merit: t.merit,
            rms_mean_um: entry.verification.rms_mean_um,
            rms_max_um: entry.verification.rms_um.iter().copied().fold(0.0, f64::max),
            distortion_max_percent: t.distortion_percent.iter().fold(0.0, |m, d| m.max(d.abs())),
            relative_illumination_edge: t.relative_illumination.last().copied().unwrap_or(1.0),
            lateral_colour_max_um: t.lateral_colour_um.iter().fold(0.0, |m, d| m.max(d.abs())),
            total_track_mm: t.total_track_mm,
            back_focal_mm: t.back_focal_mm,
            efl_mm: entry.verification.efl_mm,
            glasses: glasses(entry.lens),
            seed: entry.seed,
            elapsed_s: entry.elapsed_s,
            json: format!("lenses/{id}.json"),
            zmx: format!("lenses/{id}.zmx"),
            flags: Vec::new(),
        };
        row.flags = row.photographic_flags();
        self.rows.push(row);
        self.write_manifest()?;
        Ok(id)
    }

    /// Removes a lens and the aspheric designs made from it: first from the manifest (so an interrupted
    /// run never lists a missing file), then its files.
    /// The notes gathered since the last call (see [`Library::add`]).
    pub fn take_notes(&mut self) -> Vec<String> {
        std::mem::take(&mut self.notes)
    }

    pub fn remove(&mut self, id: &str) -> Result<()> {
        let gone: Vec<String> = self
            .rows
            .iter()
            .filter(|r| r.id == id || r.parent == id)
            .map(|r| r.id.clone())
            .collect();
        self.rows.retain(|r| !gone.contains(&r.id));
        self.write_manifest()?;
        for gone_id in &gone {
            let base = self.dir.join("lenses").join(gone_id);
            for extension in ["json", "zmx", "png", "report.json"] {
                let path = base.with_extension(extension);
                match std::fs::remove_file(&path) {
                    Ok(()) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                    Err(e) => return Err(io_error(&path)(e)),
                }
            }
        }
        Ok(())
    }

    fn write_manifest(&self) -> Result<()> {
        let mut jsonl = String::new();
        let mut csv = format!("{CSV_COLUMNS}\n");
        for row in &self.rows {
            jsonl.push_str(&serde_json::to_string(row).unwrap_or_default());
            jsonl.push('\n');
            csv.push_str(&row.csv());
            csv.push('\n');
        }
        write_atomically(&self.dir.join("manifest.jsonl"), jsonl.as_bytes())?;
        write_atomically(&self.dir.join("manifest.csv"), csv.as_bytes())?;
        Ok(())
    }

    pub fn checkpoint_path(&self, slug: &str) -> PathBuf {
        self.dir.join("state").join(format!("{slug}.json"))
    }

    /// `state/<slug>.rounds.jsonl`: one line per finished search round (the convergence trace).
    pub fn rounds_log_path(&self, slug: &str) -> PathBuf {
        self.dir.join("state").join(format!("{slug}.rounds.jsonl"))
    }

    /// Appends `round` to the spec's convergence trace (the file rewritten atomically: it is small,
    /// one line per round, and a killed run never leaves half a line). A line of the same seed and
    /// round (a run killed after logging it, resumed) is replaced, not repeated.
    pub fn log_round(&self, slug: &str, round: &RoundRecord) -> Result<()> {
        let path = self.rounds_log_path(slug);
        let old = match std::fs::read_to_string(&path) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
            Err(e) => return Err(io_error(&path)(e)),
        };
        let same_round = |line: &str| {
            serde_json::from_str::<RoundRecord>(line)
                .is_ok_and(|r| r.seed == round.seed && r.round == round.round)
        };
        let mut text: String = old
            .lines()
            .filter(|line| !same_round(line))
            .map(|line| format!("{line}\n"))
            .collect();
        text.push_str(&serde_json::to_string(round).expect("a round record serialises"));
        text.push('\n');
        write_atomically(&path, text.as_bytes())?;
        Ok(())
    }
}

/// One finished search round of a spec, as the convergence trace records it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RoundRecord {
    pub seed: u64,
    /// The round's index (rounds of earlier runs into the same library count too).
    pub round: usize,
    /// Seconds since this run started on the spec.
    pub elapsed_s: f64,
    /// Whether the round started from slower-aperture designs (`curriculum`).
    pub curriculum: bool,
    /// Spherical designs kept after the round, and the best one's mean RMS spot radius and merit.
    pub kept: usize,
    pub best_rms_mean_um: Option<f64>,
    pub best_merit: Option<f64>,
    /// Merit evaluations this run had spent on the spec at the round's end (`crate::budget`).
    #[serde(default)]
    pub evaluations: u64,
}

fn glasses(lens: &LensSpec) -> String {
    lens.surfaces
        .iter()
        .filter_map(|s| match &s.material {
            Some(unicac_optics::spec::MaterialSpec::Named(n)) => Some(n.clone()),
            Some(unicac_optics::spec::MaterialSpec::Model { nd, vd }) => Some(format!("{nd:.4}/{vd:.1}")),
            None => None,
        })
        .collect::<Vec<_>>()
        .join(";")
}

fn layout_plot(spec: &LensSpec, path: &Path) -> Result<()> {
    let lens = unicac_optics::Lens::from_spec(spec)?;
    let semi = unicac_trace::apertures::clear_semi_diameters(&lens, unicac_trace::Aiming::Paraxial)?;
    let bundles = unicac_trace::meridional::layout_bundles(&lens, 7)?;
    unicac_plot::layout(&lens, &bundles, &semi, path)?;
    Ok(())
}

/// The resumable state of one spec's search: the archive of candidates and which ones are finished.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct Checkpoint {
    pub slug: String,
    pub seed: u64,
    pub round: usize,
    pub candidates: Vec<Vec<f64>>,
    pub merits: Vec<f64>,
    pub finished: Vec<usize>,
    /// The `count` of the run of this spec and seed that ended (converged, rounds done, count reached or
    /// budget used): a rerun asking for at most as many lenses keeps the library as it is; a larger count
    /// continues. A run that was killed leaves it unset and resumes.
    #[serde(default)]
    pub done_count: Option<usize>,
    /// Merit evaluations the run had spent on the spec when this was saved: a killed run with an
    /// evaluation budget resumes its count, so it stops where an uninterrupted run would.
    #[serde(default)]
    pub evaluations_used: u64,
    /// Search rounds in a row without a better design before this round, and whether this round has
    /// written a better design so far: a killed run converges where an uninterrupted one would.
    #[serde(default)]
    pub idle_rounds: usize,
    #[serde(default)]
    pub improved: bool,
}

impl Checkpoint {
    pub fn load(path: &Path) -> Result<Option<Checkpoint>> {
        match std::fs::read_to_string(path) {
            Ok(text) => serde_json::from_str(&text)
                .map(Some)
                .map_err(|e| DesignError::Resume {
                    path: path.to_path_buf(),
                    message: e.to_string(),
                }),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
            Err(e) => Err(io_error(path)(e)),
        }
    }

    pub fn save(&self, path: &Path) -> Result<()> {
        let text = serde_json::to_string(self).unwrap_or_default();
        write_atomically(path, text.as_bytes())?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(relative_illumination_edge: f64, lateral_colour_max_um: f64, half_fov_deg: f64) -> ManifestRow {
        ManifestRow {
            id: "e6_h40_f2_middle_f50_s001".into(),
            spec: "e6_h40_f2_middle_f50".into(),
            elements: 6,
            half_fov_deg,
            f_number: 2.0,
            stop: "middle".into(),
            focal_length_mm: 50.0,
            aspheric: false,
            parent: String::new(),
            merit: 1.0,
            rms_mean_um: 10.0,
            rms_max_um: 12.0,
            distortion_max_percent: 1.0,
            relative_illumination_edge,
            lateral_colour_max_um,
            total_track_mm: 80.0,
            back_focal_mm: 30.0,
            efl_mm: 50.0,
            glasses: "SCHOTT:N-BK7".into(),
            seed: 1,
            elapsed_s: 1.0,
            json: "lenses/x.json".into(),
            zmx: "lenses/x.zmx".into(),
            flags: Vec::new(),
        }
    }

    #[test]
    fn the_issue_s_failed_design_is_flagged_twice_and_a_usable_one_not_at_all() {
        // Issue 32's 6-element F/2 40-degree design: edge illumination 0.25, lateral colour 216 um.
        let failed = row(0.25, 216.0, 40.0).photographic_flags();
        assert_eq!(failed.len(), 2, "{failed:?}");
        assert!(failed[0].starts_with("relative_illumination_edge: 0.250"));
        // 0.25 % of 50 mm x tan 40 deg = 104.9 um.
        assert!(failed[1].contains("bound 104.9"), "{failed:?}");
        assert!(row(0.5, 40.0, 40.0).photographic_flags().is_empty());
        // The colour bound follows the image height: 40 um is too much over 10 degrees (22 um).
        assert_eq!(row(0.5, 40.0, 10.0).photographic_flags().len(), 1);
    }

    #[test]
    fn the_csv_names_the_flags_without_commas_and_old_rows_read_without_flags() {
        let mut r = row(0.25, 216.0, 40.0);
        r.flags = r.photographic_flags();
        let csv = r.csv();
        assert_eq!(csv.split(',').count(), CSV_COLUMNS.split(',').count());
        assert!(
            csv.ends_with(",relative_illumination_edge;lateral_colour_max_um"),
            "{csv}"
        );
        let mut old = serde_json::to_value(row(0.5, 1.0, 20.0)).unwrap();
        old.as_object_mut().unwrap().remove("flags");
        let read: ManifestRow = serde_json::from_value(old).unwrap();
        assert!(read.flags.is_empty());
    }
}
