//! # unicac-tolerance
//!
//! Monte Carlo tolerancing, as lens designers do it (Zemax, CODE V, optiland's tolerancing module):
//! draw manufacturing errors within stated limits (`spec`: radius, thickness, surface and element
//! decentre and tilt, index), build the unit (`perturb`: the lens model's per-surface placements, the
//! axial stack, index offsets), compensate focus and grade it over the whole field (`evaluate`), and
//! gather yields over many units (`run`, resumable in a folder). Conventions in docs/tolerancing.md.
//!
//! Written here rather than borrowed: no Rust crate tolerances lenses, and the draws, the build and
//! the grading are the product's own (on unicac's lens model, tracer and aiming).

// `!(x > 0.0)` and friends are deliberate: they reject NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod error;
pub mod evaluate;
pub mod perturb;
pub mod run;
pub mod spec;

pub use error::{ToleranceError, ToleranceResult};
pub use evaluate::{field_points, score, FieldPoint, Grading, Score};
pub use perturb::{apply, draw, elements, Change, ChangeKind};
pub use run::{
    built_unit, built_unit_at_design_focus, run_folder, run_trial, unit_lens, Better, BuiltUnit, MonteCarlo,
    RunRecord, Statistic, Summary, Trial, MAX_TRIALS,
};
pub use spec::{Compensator, Distribution, ToleranceSpec};
