//! # unicac-optics
//!
//! The lens model of unicac: what a lens file says (`spec::LensSpec`), the validated model that analyses
//! use (`lens::Lens`), materials and the shipped glass catalogues (`material`), the unicac JSON and Zemax
//! `.zmx` formats (`format`), and first-order analysis (`paraxial`).
//!
//! Data flows one way: file -> `LensSpec` -> `Lens` -> views (`FirstOrder`, traces in `unicac-trace`).
//! Conventions (coordinates, signs, units) are documented once in `docs/conventions.md`.
//!
//! Hand-written parts and why: the surface math, paraxial optics and the dispersion formulas are the
//! product's own; the .zmx reader/writer is hand-written because no maintained Rust crate reads Zemax files.

// `!(x >= 0.0)` and friends are deliberate: they reject NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod builtin;
pub mod error;
pub mod format;
pub mod io;
pub mod lens;
pub mod material;
pub mod paraxial;
pub mod placement;
pub mod profile;
pub mod spec;

pub use error::{OpticsError, Result};
pub use format::{load_lens, read_spec, write_spec};
pub use lens::{Lens, Surface};
pub use material::Medium;
pub use paraxial::FirstOrder;
pub use placement::Placement;
pub use profile::Profile;
pub use spec::LensSpec;
