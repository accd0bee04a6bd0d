//! The shipped glass catalogues (SCHOTT, CDGM, OHARA from the refractiveindex.info database, CC0 1.0;
//! provenance in `data/glass/README.md`), parsed once on first use.

use super::formula::Formula;
use crate::error::{OpticsError, Result};
use serde::{Deserialize, Serialize};
use std::sync::{Arc, OnceLock};

/// One catalogue glass.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Glass {
    /// Set from the catalogue file's own name when it is read.
    #[serde(skip_deserializing)]
    pub catalog: String,
    pub name: String,
    #[serde(flatten)]
    pub formula: Formula,
    pub wavelength_range_um: [f64; 2],
    pub nd: Option<f64>,
    pub vd: Option<f64>,
}

impl Glass {
    pub fn index(&self, wavelength_um: f64) -> f64 {
        self.formula.index(wavelength_um)
    }

    /// Whether the glass's data covers the band `[lo, hi]` (um), within `RANGE_SLACK_UM`.
    pub fn covers_um(&self, [lo, hi]: [f64; 2]) -> bool {
        let [min, max] = self.wavelength_range_um;
        lo >= min - super::RANGE_SLACK_UM && hi <= max + super::RANGE_SLACK_UM
    }

    /// `CATALOG:NAME`, the unambiguous name written back to files.
    pub fn qualified_name(&self) -> String {
        format!("{}:{}", self.catalog, self.name)
    }
}

#[derive(Deserialize)]
struct CatalogFile {
    catalog: String,
    glasses: Vec<Glass>,
}

/// A named set of glasses.
#[derive(Debug)]
pub struct Catalog {
    pub name: String,
    pub glasses: Vec<Arc<Glass>>,
}

const SHIPPED: [&str; 3] = [
    include_str!("../../data/glass/schott.json"),
    include_str!("../../data/glass/cdgm.json"),
    include_str!("../../data/glass/ohara.json"),
];

/// All shipped catalogues in search order: SCHOTT, CDGM, OHARA.
pub fn shipped_catalogs() -> &'static [Catalog] {
    static CATALOGS: OnceLock<Vec<Catalog>> = OnceLock::new();
    CATALOGS.get_or_init(|| {
        SHIPPED
            .iter()
            .map(|text| parse_catalog(text).expect("shipped catalogue"))
            .collect()
    })
}

fn parse_catalog(text: &str) -> serde_json::Result<Catalog> {
    let file: CatalogFile = serde_json::from_str(text)?;
    let glasses = file
        .glasses
        .into_iter()
        .map(|mut g| {
            g.catalog = file.catalog.clone();
            Arc::new(g)
        })
        .collect();
    Ok(Catalog {
        name: file.catalog,
        glasses,
    })
}

/// Finds a glass by name, case-insensitively. `name` may be qualified as `CATALOG:NAME`. `search_order`
/// restricts and orders the catalogues (empty: all shipped ones).
pub fn find_glass(name: &str, search_order: &[String]) -> Result<Arc<Glass>> {
    let (catalog_filter, glass_name) = match name.split_once(':') {
        Some((catalog, glass)) => (Some(catalog.trim()), glass.trim()),
        None => (None, name.trim()),
    };
    let catalogs = ordered_catalogs(catalog_filter, search_order);
    catalogs
        .iter()
        .flat_map(|c| c.glasses.iter())
        .find(|g| g.name.eq_ignore_ascii_case(glass_name))
        .cloned()
        .ok_or_else(|| OpticsError::UnknownGlass {
            name: name.to_string(),
            nearest: nearest_names(glass_name, &catalogs, 5),
        })
}

fn ordered_catalogs(only: Option<&str>, search_order: &[String]) -> Vec<&'static Catalog> {
    let all = shipped_catalogs();
    let wanted: Vec<&str> = match only {
        Some(one) => vec![one],
        None if search_order.is_empty() => all.iter().map(|c| c.name.as_str()).collect(),
        None => search_order.iter().map(String::as_str).collect(),
    };
    wanted
        .iter()
        .filter_map(|w| all.iter().find(|c| c.name.eq_ignore_ascii_case(w)))
        .collect()
}

fn nearest_names(name: &str, catalogs: &[&Catalog], count: usize) -> Vec<String> {
    let upper = name.to_ascii_uppercase();
    let mut scored: Vec<(f64, String)> = catalogs
        .iter()
        .flat_map(|c| c.glasses.iter())
        .map(|g| {
            (
                strsim::jaro_winkler(&upper, &g.name.to_ascii_uppercase()),
                g.qualified_name(),
            )
        })
        .collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then_with(|| a.1.cmp(&b.1)));
    scored.into_iter().take(count).map(|(_, n)| n).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_glass_case_insensitively_and_qualified() {
        let g = find_glass("n-bk7", &[]).unwrap();
        assert_eq!(g.name, "N-BK7");
        assert_eq!(g.catalog, "SCHOTT");
        assert_eq!(find_glass("schott:N-BK7", &[]).unwrap().name, "N-BK7");
    }

    #[test]
    fn unknown_glass_lists_nearest_names() {
        let err = find_glass("N-BK8", &[]).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("unknown glass 'N-BK8'"), "{text}");
        assert!(text.contains("SCHOTT:N-BK7"), "{text}");
    }

    #[test]
    fn every_shipped_glass_has_a_supported_formula_and_finite_visible_index() {
        let mut count = 0;
        for glass in shipped_catalogs().iter().flat_map(|c| c.glasses.iter()) {
            assert!(
                Formula::SUPPORTED.contains(&glass.formula.formula),
                "{}",
                glass.name
            );
            let [lo, hi] = glass.wavelength_range_um;
            // Visible mid-band, or the middle of the data range for infrared-only glasses.
            let probe = if lo <= 0.55 && hi >= 0.55 {
                0.55
            } else {
                0.5 * (lo + hi)
            };
            let n = glass.index(probe);
            assert!(
                n.is_finite() && n > 1.0 && n < 4.5,
                "{} n = {n}",
                glass.qualified_name()
            );
            count += 1;
        }
        assert!(count > 300, "only {count} glasses shipped");
    }

    #[test]
    fn catalogue_nd_vd_agree_with_the_formula() {
        use super::super::formula::{LINE_C_UM, LINE_D_UM, LINE_F_UM};
        for glass in shipped_catalogs().iter().flat_map(|c| c.glasses.iter()) {
            let [lo, hi] = glass.wavelength_range_um;
            if lo > LINE_F_UM || hi < LINE_C_UM {
                continue;
            }
            if let (Some(nd), Some(vd)) = (glass.nd, glass.vd) {
                let n = |l| glass.index(l);
                assert!((n(LINE_D_UM) - nd).abs() < 2e-4, "{} nd", glass.qualified_name());
                let v = (n(LINE_D_UM) - 1.0) / (n(LINE_F_UM) - n(LINE_C_UM));
                assert!((v - vd).abs() < 0.5, "{} vd {v} vs {vd}", glass.qualified_name());
            }
        }
    }
}
