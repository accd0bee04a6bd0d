//! Host structs that cross into GPU buffers. Each mirrors, field for field, a struct of
//! `shaders/common.wgsl` (`Surface`, `Ray`, `Params`); no vec3 members (WGSL aligns them to 16 bytes),
//! Real fields first and u32 fields last, so neither precision has padding. Sizes are asserted below.

use crate::real::Real;
use bytemuck::{Pod, Zeroable};
use unicac_optics::profile::MAX_ASPHERE_TERMS;
use unicac_trace::{RayStatus, TraceSystem};

/// Mirror: `struct Surface` in shaders/common.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surface<R> {
    pub gap_mm: R,
    pub curvature_per_mm: R,
    pub conic: R,
    pub conic_rho_limit: R,
    pub clip_rho: R,
    pub mu: R,
    pub coefficients: [R; MAX_ASPHERE_TERMS],
    pub terms: u32,
    pub refract: u32,
}

/// Mirror: `struct Ray` in shaders/common.wgsl. Position local to the vertex of the last surface
/// reached (surface 1's vertex, i.e. global coordinates, on input).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GpuRay<R> {
    pub x: R,
    pub y: R,
    pub z: R,
    pub l: R,
    pub m: R,
    pub n: R,
}

/// Mirror: `struct Params` in shaders/common.wgsl.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Params<R> {
    pub pupil_radius_mm: R,
    pub pupil_z_mm: R,
    pub sin_field: R,
    pub cos_field: R,
    pub object_y_mm: R,
    pub object_to_pupil_mm: R,
    pub chief_x_mm: R,
    pub chief_y_mm: R,
    pub sub_pitch_um: R,
    pub weight_r: R,
    pub weight_g: R,
    pub weight_b: R,
    pub surface_count: u32,
    pub ray_count: u32,
    pub first_index: u32,
    pub pattern: u32,
    pub pattern_n: u32,
    pub seed_lo: u32,
    pub seed_hi: u32,
    pub finite_object: u32,
    pub fine_size: u32,
    pub pad: u32,
}

// SAFETY: repr(C), every field is f32/f64 (R) or u32, Real fields precede u32 fields and the counts
// make every size a multiple of the alignment (asserted below), so there is no padding in either
// precision; all bit patterns are valid.
unsafe impl<R: Real> Zeroable for Surface<R> {}
unsafe impl<R: Real> Pod for Surface<R> {}
unsafe impl<R: Real> Zeroable for GpuRay<R> {}
unsafe impl<R: Real> Pod for GpuRay<R> {}
unsafe impl<R: Real> Zeroable for Params<R> {}
unsafe impl<R: Real> Pod for Params<R> {}

const _: () = {
    assert!(std::mem::size_of::<Surface<f32>>() == 16 * 4 + 2 * 4);
    assert!(std::mem::size_of::<Surface<f64>>() == 16 * 8 + 2 * 4);
    assert!(std::mem::size_of::<GpuRay<f32>>() == 24);
    assert!(std::mem::size_of::<GpuRay<f64>>() == 48);
    assert!(std::mem::size_of::<Params<f32>>() == 12 * 4 + 10 * 4);
    assert!(std::mem::size_of::<Params<f64>>() == 12 * 8 + 10 * 4);
};

/// Pattern codes of `Params::pattern` (constants PATTERN_* in common.wgsl).
pub mod pattern {
    pub const HOST_RAYS: u32 = 0;
    pub const HEXAPOLAR: u32 = 1;
    pub const GRID: u32 = 2;
    pub const FIBONACCI: u32 = 3;
    pub const RANDOM: u32 = 4;
}

/// Status kinds of a status word's low byte (constants in common.wgsl).
pub mod kind {
    pub const OK: u32 = 0;
    pub const MISSED: u32 = 1;
    pub const TIR: u32 = 2;
    pub const CLIPPED: u32 = 3;
    pub const NO_CONVERGENCE: u32 = 4;
    pub const INVALID_INPUT: u32 = 5;
    pub const NOT_SAMPLED: u32 = 6;
    /// Flag bit: a decision fell within the guard band; the host re-traces the ray in f64.
    pub const UNDECIDED: u32 = 0x80;
    /// Length of the counters buffer.
    pub const COUNTERS: usize = 8;
}

/// A status word (kind | UNDECIDED? | surface << 8) as the CPU's `RayStatus`; None for NOT_SAMPLED.
pub fn decode_status(word: u32) -> Option<RayStatus> {
    let surface = word >> 8;
    Some(match word & 0x7f {
        kind::OK => RayStatus::Ok,
        kind::MISSED => RayStatus::Missed { surface },
        kind::TIR => RayStatus::Tir { surface },
        kind::CLIPPED => RayStatus::Clipped { surface },
        kind::NO_CONVERGENCE => RayStatus::NoConvergence { surface },
        kind::INVALID_INPUT => RayStatus::InvalidInput,
        _ => return None,
    })
}

/// Clamp +-inf to the largest finite value of R (an infinite limit is "unbounded" on both paths, and
/// no infinity ever enters a buffer).
fn finite_real<R: Real>(v: f64) -> R {
    let max = R::MAX.to_f64();
    R::from_f64(v.clamp(-max, max))
}

/// The GPU kernels trace centred surfaces only: a decentred or tilted one is refused (the CPU tracers
/// take it).
pub fn check_supported(system: &TraceSystem) -> crate::GpuResult<()> {
    match system.surfaces.iter().position(|s| s.frame.is_some()) {
        None => Ok(()),
        Some(i) => Err(crate::GpuError::Unsupported(format!(
            "surface {} is decentred or tilted; the GPU path traces rotationally symmetric lenses only (use the CPU path)",
            i + 1
        ))),
    }
}

/// The surfaces of a trace system, local to each vertex. Everything that is a combination of inputs
/// (gaps, index ratios) is formed in f64 on the host and rounded once.
pub fn surfaces<R: Real>(system: &TraceSystem) -> Vec<Surface<R>> {
    let last = system.image_index();
    let mut previous_z = 0.0;
    let mut n_before = system.object_index;
    system
        .surfaces
        .iter()
        .enumerate()
        .map(|(i, s)| {
            let p = &s.profile;
            let mut coefficients = [R::default(); MAX_ASPHERE_TERMS];
            for (c, a) in coefficients.iter_mut().zip(&p.aspheric_coefficients) {
                *c = R::from_f64(*a);
            }
            let surface = Surface {
                gap_mm: R::from_f64(s.z_mm - previous_z),
                curvature_per_mm: R::from_f64(p.curvature_per_mm),
                conic: R::from_f64(p.conic),
                conic_rho_limit: finite_real(s.conic_rho_limit),
                clip_rho: finite_real(s.clip_rho),
                mu: R::from_f64(n_before / s.index_after),
                coefficients,
                terms: p.aspheric_terms as u32,
                refract: u32::from(i < last && n_before != s.index_after),
            };
            previous_z = s.z_mm;
            n_before = s.index_after;
            surface
        })
        .collect()
}

/// z of the vertex whose frame a traced ray ends in: the image surface's for rays that arrive, the
/// last surface passed for rays that failed (global frame before surface 1).
pub fn frame_z_mm(system: &TraceSystem, status: RayStatus) -> f64 {
    let surface = match status {
        RayStatus::Ok => return system.surfaces[system.image_index()].z_mm,
        RayStatus::InvalidInput => return 0.0,
        RayStatus::Missed { surface }
        | RayStatus::Tir { surface }
        | RayStatus::Clipped { surface }
        | RayStatus::NoConvergence { surface } => surface as usize,
    };
    if surface == 0 {
        0.0
    } else {
        system.surfaces[surface - 1].z_mm
    }
}
