//! # unicac-design
//!
//! Automatic design of spherical and aspherical photographic lenses into a lens library (docs/design.md).
//!
//! - `spec`: what to design (elements, field, F/#, stop position, focal length, wavelengths) and the
//!   constraints, with the paper's specification grid;
//! - `system`, `tracer`: the design's prescription and a compact real-ray and paraxial tracer generic
//!   over `scalar::Scalar`, implemented for f64 and for the forward-mode `dual::Dual<N>`, so merit values
//!   and exact gradients come from one code path (checked against unicac-trace and finite differences);
//! - `params`: design variables, their bounds and the EFL and focus solves;
//! - `merit`: residuals (spot, lateral colour, distortion, relative illumination, constraint penalties)
//!   and the named checks reported for every design;
//! - `local`: damped least squares (Levenberg-Marquardt) on exact Jacobians, or finite differences for
//!   the baseline;
//! - `global`: the population search (simulated annealing, genetic operators, diversity-preserving
//!   selection, in-loop local refinement);
//! - `curriculum`: a fast aperture's search started from a slower aperture's solutions;
//! - `glass_snap`: continuous (nd, Vd) to the nearest catalogue glass, then re-optimisation;
//! - `asphere`: conversion of chosen surfaces to even aspheres and re-optimisation within
//!   manufacturability limits;
//! - `verify`: independent physical checks of a finished lens with unicac-trace;
//! - `library`: lens files, reports, layout plots, the manifest, resume;
//! - `budget`: what a run may spend per specification (time, or merit evaluations: reproducible);
//! - `run`: one specification or a grid, within a budget.
//!
//! Everything is the product's own optics, hence hand-written; parallelism is rayon's.

// `!(x >= 0.0)` and friends are deliberate: they reject NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod asphere;
pub mod budget;
pub mod curriculum;
pub mod dual;
pub mod error;
pub mod export;
pub mod glass_snap;
pub mod global;
pub mod library;
pub mod local;
pub mod merit;
pub mod params;
pub mod run;
pub mod scalar;
pub mod spec;
pub mod system;
pub mod tracer;
pub mod verify;

pub use error::{DesignError, Result};
pub use spec::{Constraints, DesignSpec, FocalLength, Grid, SensorSize, StopPosition};
