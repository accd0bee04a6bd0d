//! The as-built split against its designs (`--split as_built`): what each method loses when the test
//! lenses are units as built rather than their designs. Every unit pair (`PAIR__uK`) is paired with its
//! design's reference pair `PAIR__d` (same scene, crop, seed and rendering path), the differences
//! averaged per design lens (over its units and pairs), and the mean over design lenses given with a
//! percentile bootstrap interval over them (`analysis::bootstrap_indices_ci95`: the units of one design
//! are not independent lenses).

use std::collections::BTreeMap;

use serde::Serialize;

use super::PairScore;
use crate::analysis::bootstrap_indices_ci95;
use unicac_dataset::builder::as_built::design_of;

/// The as-built section of a report.
#[derive(Debug, Clone, Serialize)]
pub struct AsBuiltReport {
    pub units_per_lens: usize,
    pub rows: Vec<AsBuiltLoss>,
}

/// One method's loss at one ODE level (`level` None: every level).
#[derive(Debug, Clone, Serialize)]
pub struct AsBuiltLoss {
    pub model: String,
    pub level: Option<u8>,
    /// Design lenses and unit pairs behind the row.
    pub designs: usize,
    pub pairs: usize,
    pub psnr: Difference,
    pub ssim: Difference,
    /// None when LPIPS was not computed.
    pub lpips: Option<Difference>,
}

/// A metric on the designs' pairs and on the units' pairs (means over design lenses), and the
/// difference as built minus design with its 95% interval.
#[derive(Debug, Clone, Serialize)]
pub struct Difference {
    pub design: f64,
    pub as_built: f64,
    pub difference: f64,
    pub ci95: Option<[f64; 2]>,
}

/// Per (design lens), the (design, as built) values of every matched pair.
type ByDesign = BTreeMap<String, Vec<(f64, f64)>>;

fn difference(by_design: &ByDesign) -> Difference {
    // Per design lens: the mean design value and the mean as-built value of its pairs.
    let lenses: Vec<(f64, f64)> = by_design
        .values()
        .map(|values| {
            let n = values.len() as f64;
            let (d, a) = values.iter().fold((0.0, 0.0), |(d, a), v| (d + v.0, a + v.1));
            (d / n, a / n)
        })
        .collect();
    let mean = |drawn: &mut dyn Iterator<Item = (f64, f64)>| {
        let (mut d, mut a, mut n) = (0.0, 0.0, 0.0);
        for (x, y) in drawn {
            (d, a, n) = (d + x, a + y, n + 1.0);
        }
        (d / n, a / n)
    };
    let (design, as_built) = mean(&mut lenses.iter().copied());
    let ci95 = bootstrap_indices_ci95(lenses.len(), |drawn| {
        let (d, a) = mean(&mut drawn.iter().map(|&i| lenses[i]));
        Some(a - d)
    });
    Difference {
        design,
        as_built,
        difference: as_built - design,
        ci95,
    }
}

/// The loss rows of every method (in `models` order), per level and over all levels.
pub fn as_built_loss(units: &[PairScore], designs: &[PairScore], models: &[String]) -> Vec<AsBuiltLoss> {
    let design_scores: BTreeMap<(&str, &str), &PairScore> = designs
        .iter()
        .map(|p| ((p.model.as_str(), design_of(&p.pair_id)), p))
        .collect();
    let mut levels: Vec<Option<u8>> = units.iter().map(|p| Some(p.level)).collect();
    levels.sort_unstable();
    levels.dedup();
    levels.push(None);
    let mut rows = Vec::new();
    for model in models {
        for &level in &levels {
            let matched: Vec<(&PairScore, &PairScore)> = units
                .iter()
                .filter(|u| &u.model == model && level.is_none_or(|l| u.level == l))
                .filter_map(|u| Some((u, *design_scores.get(&(model.as_str(), design_of(&u.pair_id)))?)))
                .collect();
            if matched.is_empty() {
                continue;
            }
            let collect = |value: &dyn Fn(&PairScore) -> Option<f64>| -> Option<ByDesign> {
                let mut by_design = ByDesign::new();
                for (u, d) in &matched {
                    by_design
                        .entry(design_of(&u.lens_id).to_string())
                        .or_default()
                        .push((value(d)?, value(u)?));
                }
                Some(by_design)
            };
            let psnr = collect(&|p| Some(p.psnr_db)).expect("PSNR of every pair");
            let ssim = collect(&|p| Some(p.ssim)).expect("SSIM of every pair");
            rows.push(AsBuiltLoss {
                model: model.clone(),
                level,
                designs: psnr.len(),
                pairs: matched.len(),
                psnr: difference(&psnr),
                ssim: difference(&ssim),
                lpips: collect(&|p| p.lpips).map(|by_design| difference(&by_design)),
            });
        }
    }
    rows
}

fn cell(d: &Difference, decimals: usize) -> [String; 3] {
    let ci = d
        .ci95
        .map(|[lo, hi]| format!(" [{lo:+.decimals$}, {hi:+.decimals$}]"))
        .unwrap_or_default();
    [
        format!("{:.decimals$}", d.design),
        format!("{:.decimals$}", d.as_built),
        format!("{:+.decimals$}{ci}", d.difference),
    ]
}

/// The markdown section of `tables.md`.
pub fn markdown(rows: &[AsBuiltLoss], units_per_lens: usize) -> String {
    let mut md = format!(
        "### As built against the design\n\nEvery test pair rendered again through {units_per_lens} unit(s) of \
         its lens built within the dataset's tolerances (`dataset build --as-built`), scored against the \
         same pair rendered through the design by the same path (`__d`): means over design lenses, differences as built minus design with \
         95% bootstrap intervals over design lenses. Non-blind inputs (`psf`, `psf_code`, Wiener) are the \
         design's.\n\n| model | level | designs | PSNR design | PSNR as built | PSNR change | SSIM design | \
         SSIM as built | SSIM change | LPIPS change |\n|---|---|---:|---:|---:|---|---:|---:|---|---|\n"
    );
    for row in rows {
        let [pd, pa, pc] = cell(&row.psnr, 2);
        let [sd, sa, sc] = cell(&row.ssim, 4);
        let lpips = row
            .lpips
            .as_ref()
            .map_or("-".to_string(), |d| cell(d, 4)[2].clone());
        let level = row.level.map_or("all".to_string(), |l| format!("L{l}"));
        md.push_str(&format!(
            "| {} | {level} | {} | {pd} | {pa} | {pc} | {sd} | {sa} | {sc} | {lpips} |\n",
            row.model, row.designs
        ));
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    fn score(model: &str, pair_id: &str, lens_id: &str, psnr_db: f64) -> PairScore {
        PairScore {
            model: model.into(),
            pair_id: pair_id.into(),
            lens_id: lens_id.into(),
            level: 1,
            psnr_db,
            ssim: 0.9,
            lpips: None,
            clipiqa: None,
            features: None,
        }
    }

    #[test]
    fn each_unit_pair_meets_its_design_pair_and_lenses_weigh_alike() {
        // Design a: 30 dB; its two units 28 and 26 (loss 3). Design b: 20 dB; one unit at 19 (loss 1).
        let designs = [
            score("m", "a-p0__d", "a__d", 30.0),
            score("m", "b-p0__d", "b__d", 20.0),
        ];
        let units = [
            score("m", "a-p0__u0", "a__u0", 28.0),
            score("m", "a-p0__u1", "a__u1", 26.0),
            score("m", "b-p0__u0", "b__u0", 19.0),
        ];
        let rows = as_built_loss(&units, &designs, &["m".to_string()]);
        assert_eq!(rows.len(), 2, "level 1 and all");
        let all = &rows[1];
        assert_eq!((all.level, all.designs, all.pairs), (None, 2, 3));
        assert!((all.psnr.design - 25.0).abs() < 1e-12);
        assert!(
            (all.psnr.as_built - 23.0).abs() < 1e-12,
            "mean of a's 27 and b's 19"
        );
        assert!((all.psnr.difference + 2.0).abs() < 1e-12);
        assert!(all.lpips.is_none());
        assert!(all.psnr.ci95.is_none(), "no interval from 2 lenses");
    }
}
