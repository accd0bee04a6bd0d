//! # unicac-plot
//!
//! Pictures of a lens and its analyses, written as PNG or SVG (chosen by the output file's extension,
//! `.png` or `.svg`, case-insensitive; anything else is `PlotError::UnknownExtension`):
//!
//! - [`layout`]: the lens in the y-z plane (z to the right, y up, equal scale on both axes): each surface's
//!   profile z = z_vertex + sag(y^2) over its clear semi-diameter, glass elements shaded and closed by
//!   flat edges, the aperture stop marked by blades, the image surface as a thick line, and traced rays in
//!   one colour per field. `unicac_trace::meridional::layout_bundles` traces the usual meridional fans
//!   for it.
//! - [`spot_diagram`]: one panel per field (rows) and wavelength (columns), each centred on its centroid
//!   and all at one common scale so sizes compare; titles give field, wavelength and RMS radius.
//! - [`ray_fan_plot`]: per field, the tangential (ey against py) and sagittal (ex against px) transverse
//!   aberration fans about the chief ray, wavelengths overlaid, in µm on a common vertical scale.
//! - [`mtf_curves`]: MTF curves against cycles/pixel with Nyquist (dashed) and MTF50 (dotted) marked.
//! - [`line_panels`]: line charts in up to twelve panels (three per row), series in ramp colours, reference
//!   curves (a diffraction limit) black; the lens analyses of `unicac analysis`.
//! - [`ode_bars`]: one row per lens, bars of Optical Degradation Evaluator (ODE) score and RMS spot radius side by side.
//! - [`psf_panels`]: PSF kernels as images (each normalised to its peak, viridis colour map, scale bar in
//!   µm) above a chart of their central rows.
//! - [`level_histograms`]: per-level stacked histograms of lens scores (the dataset's stratification).
//! - [`psf_map`]: R, G, B kernels at a grid of sensor positions, each drawn where it sits on the sensor.
//! - [`level_lines`] and [`scatter_fits`]: benchmark pictures (metric and ranking trends across levels;
//!   scatter plots with least-squares lines).
//!
//! Conventions: lengths in the layout are mm, aberrations and spot coordinates µm; field angles are in
//! degrees; wavelength colours run from blue (shortest) to red (longest) whatever the actual
//! wavelengths, so any set stays distinguishable; field colours use the same ramp in field order.
//!
//! Each picture is drawn once by a generic `draw` over plotters' `DrawingBackend`; a small `render`
//! picks the bitmap or SVG backend. Files are written to a temporary sibling and renamed into place, so a
//! failed plot never leaves a partial file. Text uses the system's sans-serif font through fontconfig.

mod bench;
mod fan;
mod histogram;
mod layout;
mod lines;
mod mtf;
mod ode;
mod psf;
mod psf_map;
mod render;
mod spot;
mod style;

pub use bench::{level_lines, scatter_fits, LevelSeries, ScatterPanel};
pub use fan::ray_fan_plot;
pub use histogram::{level_histograms, LevelHistogram};
pub use layout::layout;
pub use lines::{line_panels, Line, LineColour, LinePanel, MAX_PANELS};
pub use mtf::{mtf_curves, Curve};
pub use ode::ode_bars;
pub use psf::{psf_panels, PsfPanel};
pub use psf_map::{psf_map, PsfMapCell};
pub use spot::spot_diagram;

use std::path::PathBuf;

/// Why a picture could not be made.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum PlotError {
    #[error("{path}: unknown picture format (expected a .png or .svg file name)")]
    UnknownExtension { path: PathBuf },
    /// The drawing backend failed (font lookup, bitmap encoding, ...); carries its message.
    #[error("drawing failed: {0}")]
    Backend(String),
    #[error("{path}: {source}")]
    Io {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    /// The data given cannot be drawn (no spots, one semi-diameter missing, ...).
    #[error("cannot plot: {0}")]
    InvalidInput(String),
    #[error(transparent)]
    Optics(#[from] unicac_optics::OpticsError),
}

impl<E: std::error::Error + Send + Sync> From<plotters::drawing::DrawingAreaErrorKind<E>> for PlotError {
    fn from(error: plotters::drawing::DrawingAreaErrorKind<E>) -> Self {
        PlotError::Backend(error.to_string())
    }
}
