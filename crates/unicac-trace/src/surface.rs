//! What the scalar step (`system`) and the lane tracer (`lanes`) share: a surface prepared for the inner
//! loop, its placement frame, and the numerical tolerances both tracers apply identically (so that they
//! agree bit for bit). The GPU twin and the design tracer's dual-number tracer use the same constants.

use unicac_optics::Profile;

pub const MAX_NEWTON_ITERATIONS: usize = 40;

/// Rays traced together surface by surface: fits in L1 cache and gives the CPU independent work.
pub const LANE_BLOCK: usize = 64;

/// Relative size of the last Newton step at which the intersection counts as converged (see module docs).
pub const NEWTON_STEP_TOLERANCE: f64 = 1e-9;

/// Below this |N| a ray counts as parallel to a surface's tangent plane (angle > 89.99994 deg).
pub const GRAZING_N: f64 = 1e-6;

/// How far a refracted direction's squared length may stray from 1 before it counts as lost (a valid
/// one is within a few ulps; a NaN fails the comparison too). The lane tracer uses the same test.
pub const UNIT_DIRECTION_TOLERANCE: f64 = 1e-6;

/// One surface with everything the inner loop needs, precomputed.
#[derive(Debug, Clone, Copy)]
pub struct TraceSurface {
    /// Global z of the nominal vertex.
    pub z_mm: f64,
    /// The frame of a decentred or tilted surface; `None` when it is centred (the rotationally symmetric
    /// path, which never transforms).
    pub frame: Option<Frame>,
    pub profile: Profile,
    /// r^2 limit of the conic base (infinite if unbounded).
    pub conic_rho_limit: f64,
    /// Squared clear semi-diameter (infinite when not clipping).
    pub clip_rho: f64,
    /// Index of the medium after the surface.
    pub index_after: f64,
}

/// Where a decentred or tilted surface sits: its vertex and the rotation taking local vectors to global
/// ones (columns: the local axes). Both tracers transform with these same operations in the same order,
/// so they agree bit for bit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub origin: [f64; 3],
    pub rotation: [[f64; 3]; 3],
}

impl Frame {
    /// R^T (p - origin).
    #[inline]
    pub fn point_to_local(&self, p: [f64; 3]) -> [f64; 3] {
        let d = [
            p[0] - self.origin[0],
            p[1] - self.origin[1],
            p[2] - self.origin[2],
        ];
        self.vector_to_local(d)
    }

    /// R^T v.
    #[inline]
    pub fn vector_to_local(&self, v: [f64; 3]) -> [f64; 3] {
        let r = &self.rotation;
        [0, 1, 2].map(|k| r[0][k] * v[0] + r[1][k] * v[1] + r[2][k] * v[2])
    }

    /// origin + R p.
    #[inline]
    pub fn point_to_global(&self, p: [f64; 3]) -> [f64; 3] {
        let v = self.vector_to_global(p);
        [
            self.origin[0] + v[0],
            self.origin[1] + v[1],
            self.origin[2] + v[2],
        ]
    }

    /// R v.
    #[inline]
    pub fn vector_to_global(&self, v: [f64; 3]) -> [f64; 3] {
        unicac_optics::placement::rotate(&self.rotation, v)
    }
}

impl TraceSurface {
    /// This surface in its own frame: vertex at the origin, no frame (what the placed steps trace).
    pub(crate) fn local(&self) -> TraceSurface {
        TraceSurface {
            z_mm: 0.0,
            frame: None,
            ..*self
        }
    }
}
