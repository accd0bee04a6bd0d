//! # unicac-trace
//!
//! Sequential real-ray tracing in f64, the reference path of unicac (the GPU path is checked against it).
//!
//! - `surface`: a surface prepared for the inner loop and the tolerances both tracers share;
//! - `system`: a lens prepared at one wavelength and the per-surface step (cancellation-free conic
//!   intersection, Newton for even aspheres, aperture clipping, vector Snell refraction, TIR);
//! - `ray`: rays and per-ray outcomes (`RayStatus`, counted in `StatusCounts`; no NaN ever leaves);
//! - `lanes`: the batch tracer, SIMD over ray lanes (AVX-512 / AVX2 / portable, chosen at run time),
//!   bit for bit the scalar `system` step;
//! - `batch`: many rays in parallel (rayon);
//! - `aim`: paraxial and real ray aiming (`aim_map`: real aiming of many rays at once); `pupil`: pupil sampling patterns;
//! - `spot`: spot diagrams, RMS radii, ray fans, distortion, working F/#;
//! - `apertures`: clear semi-diameters computed from the beams.
//!
//! Everything here is the product's own optics, hence hand-written; parallelism is rayon's, the SIMD
//! vector types and their run-time dispatch are `pulp`'s (see `lanes` for why).

// `!(x >= 0.0)` and friends are deliberate: they reject NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod aim;
mod aim_map;
pub mod apertures;
pub mod batch;
pub mod error;
pub mod lanes;
pub mod meridional;
pub mod params;
pub mod pupil;
pub mod ray;
pub mod spot;
pub mod summary;
pub mod surface;
pub mod system;
pub mod workload;

pub use aim::{Aimer, Aiming, AutoAiming, AUTO_REAL_AIMING_STOP_MISS};
pub use aim_map::FieldAiming;
pub use batch::{trace_rays, trace_rays_from_start, trace_rays_serial};
pub use error::{TraceError, TraceResult};
pub use lanes::SimdLevel;
pub use params::{
    check_at_least, check_field_deg, check_fields_deg, check_odd, check_positive, check_wavelength_um,
    check_wavelengths_um, InvalidParameter,
};
pub use pupil::PupilSampling;
pub use ray::{Ray, RayStatus, StatusCounts};
pub use spot::{spots, spots_at, Spot, SpotTracer};
pub use summary::LensSummary;
pub use system::{Clipping, TraceSystem};
