//! # unicac-gpu
//!
//! The GPU compute path: WGSL kernels (`shaders/*.wgsl`) for batched sequential ray tracing, pupil
//! sampling on the device, PSF accumulation and the simulator's image pass, run through wgpu (Vulkan; Mesa lavapipe where there is
//! no GPU), each with a plain-Rust twin (`twin`) and GPU-vs-CPU tests. See docs/gpu.md.
//!
//! - `device`: adapters, `GpuContext` (device + queue), typed errors; getting a device is separate from
//!   running a kernel;
//! - `layout`: the `#[repr(C)]` + Pod structs mirrored in WGSL; `real`: f32 / f64;
//! - `source`: host rays, or pupil sampling and paraxial aiming on the device;
//! - `shader`: the embedded WGSL, one text for both precisions;
//! - `trace`: pipelines and buffers built once, chunked streaming of any number of rays;
//! - `psf`: deterministic PSF accumulation (64-bit fixed point with u32 atomics);
//! - `hits`, `spot`: the GPU behind `unicac_psf::HitTracer` and spot diagrams;
//! - `image`: the simulator's image pass (spatially varying blur, warp, shading) behind
//!   `unicac_sim::ImageDevice`;
//! - `sensor`, `sensor_twin`: the sensor read-out with noise (counter draws in f32) and its twin;
//! - `develop`: black level, white balance and demosaicing of the mosaic (the CPU path is its twin);
//! - `select`: `--device cpu|gpu|auto`, opened lazily, always ending on the CPU when the GPU cannot run;
//! - `twin`: the kernels in plain Rust.

// `!(x >= 0.0)` and friends are deliberate: they reject NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod develop;
pub mod device;
pub mod hits;
pub mod image;
mod kernels;
pub mod layout;
pub mod psf;
pub mod real;
pub mod select;
pub mod sensor;
pub mod sensor_twin;
pub mod shader;
pub mod source;
pub mod spot;
pub mod trace;
pub mod twin;

pub use device::{AdapterSummary, GpuContext, GpuError, GpuResult};
pub use hits::GpuHitTracer;
pub use image::GpuImagePass;
pub use psf::{Accumulated, PsfPass, SplatGrid};
pub use real::{Precision, Real};
pub use select::{DeviceChoice, DeviceSelection, AUTO_MIN_PIXELS, AUTO_MIN_RAYS};
pub use source::{ParaxialAim, PupilSource, RaySource};
pub use trace::{GpuTracer, Traced};
