//! Optical media: air, catalogue glasses and model glasses given by (nd, Vd).

pub mod catalog;
pub mod formula;

pub use catalog::{find_glass, shipped_catalogs, Catalog, Glass};
pub use formula::{model_glass_index, Formula, LINE_C_UM, LINE_D_UM, LINE_F_UM};

use crate::error::{OpticsError, Result};
use std::sync::Arc;

/// Tolerance on a glass's data range: tiny overshoots (e.g. 0.4 um against a 0.4047 um range start) are
/// common in lens files and the Sellmeier fits extrapolate smoothly that far.
pub const RANGE_SLACK_UM: f64 = 0.02;

/// The band the simulator and the ODE trace (400-700 nm): a glass meant for them must cover it.
pub const VISIBLE_BAND_UM: [f64; 2] = [0.4, 0.7];

/// The medium after a surface.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub enum Medium {
    Air,
    Catalog(Arc<Glass>),
    Model {
        nd: f64,
        vd: f64,
    },
    /// A glass whose index departs from its nominal one by `delta_n` at every wavelength (a melt's
    /// index error, as tolerancing draws it: the dispersion is kept).
    Offset {
        base: Box<Medium>,
        delta_n: f64,
    },
}

impl Medium {
    /// Refractive index relative to air at `wavelength_um`.
    pub fn index(&self, wavelength_um: f64) -> Result<f64> {
        match self {
            Medium::Air => Ok(1.0),
            Medium::Model { nd, vd } => Ok(model_glass_index(*nd, *vd, wavelength_um)),
            Medium::Offset { base, delta_n } => Ok(base.index(wavelength_um)? + delta_n),
            Medium::Catalog(glass) => {
                let [lo, hi] = glass.wavelength_range_um;
                if !glass.covers_um([wavelength_um, wavelength_um]) {
                    return Err(OpticsError::WavelengthOutOfRange {
                        name: glass.qualified_name(),
                        wavelength_um,
                        min_um: lo,
                        max_um: hi,
                    });
                }
                Ok(glass.index(wavelength_um))
            }
        }
    }

    pub fn is_air(&self) -> bool {
        matches!(self, Medium::Air)
    }

    /// Short label for reports and plots.
    pub fn label(&self) -> String {
        match self {
            Medium::Air => "AIR".into(),
            Medium::Catalog(g) => g.name.clone(),
            Medium::Model { nd, vd } => format!("{nd:.4}/{vd:.1}"),
            Medium::Offset { base, delta_n } => format!("{}{delta_n:+.5}", base.label()),
        }
    }
}
