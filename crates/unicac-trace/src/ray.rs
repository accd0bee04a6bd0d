//! Rays and their outcome. Per-ray failures are data: every ray ends with a `RayStatus`, and a failed
//! ray keeps its last valid position (never NaN).

use serde::Serialize;

/// A ray in global coordinates: a point (mm) and unit direction cosines (L, M, N).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Ray {
    pub position_mm: [f64; 3],
    pub direction: [f64; 3],
}

impl Ray {
    /// A ray from `position_mm` along `direction`, normalised here so callers may pass any non-zero vector.
    pub fn new(position_mm: [f64; 3], direction: [f64; 3]) -> Ray {
        let norm =
            (direction[0] * direction[0] + direction[1] * direction[1] + direction[2] * direction[2]).sqrt();
        Ray {
            position_mm,
            direction: direction.map(|d| d / norm),
        }
    }

    /// Every coordinate finite. All six are tested (no early exit): branch-free, as a million-ray
    /// aiming loop wants it.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.position_mm
            .iter()
            .chain(&self.direction)
            .fold(true, |finite, v| finite & v.is_finite())
    }
}

/// How a ray's trace ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum RayStatus {
    Ok,
    /// The ray does not meet surface `surface` (0-based), or meets it outside the surface's valid region.
    Missed {
        surface: u32,
    },
    /// Total internal reflection at surface `surface`.
    Tir {
        surface: u32,
    },
    /// The ray meets surface `surface` outside its clear semi-diameter.
    Clipped {
        surface: u32,
    },
    /// The even-asphere intersection did not converge at surface `surface`.
    NoConvergence {
        surface: u32,
    },
    /// The ray given to the tracer was not finite or had a zero direction.
    InvalidInput,
}

impl RayStatus {
    pub fn is_ok(&self) -> bool {
        matches!(self, RayStatus::Ok)
    }

    /// Short machine-friendly name: "ok", "missed", "tir", "clipped", "no_convergence", "invalid_input".
    pub fn kind(&self) -> &'static str {
        match self {
            RayStatus::Ok => "ok",
            RayStatus::Missed { .. } => "missed",
            RayStatus::Tir { .. } => "tir",
            RayStatus::Clipped { .. } => "clipped",
            RayStatus::NoConvergence { .. } => "no_convergence",
            RayStatus::InvalidInput => "invalid_input",
        }
    }
}

impl std::fmt::Display for RayStatus {
    /// Surfaces are shown 1-based, as in lens files and Zemax.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            RayStatus::Ok => write!(f, "ok"),
            RayStatus::Missed { surface } => write!(f, "missed surface {}", surface + 1),
            RayStatus::Tir { surface } => write!(f, "total internal reflection at surface {}", surface + 1),
            RayStatus::Clipped { surface } => write!(f, "clipped at surface {}", surface + 1),
            RayStatus::NoConvergence { surface } => write!(f, "no convergence at surface {}", surface + 1),
            RayStatus::InvalidInput => write!(f, "invalid input ray"),
        }
    }
}

/// How many rays ended each way.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct StatusCounts {
    pub ok: usize,
    pub missed: usize,
    pub tir: usize,
    pub clipped: usize,
    pub no_convergence: usize,
    pub invalid_input: usize,
}

impl StatusCounts {
    pub fn add(&mut self, status: RayStatus) {
        match status {
            RayStatus::Ok => self.ok += 1,
            RayStatus::Missed { .. } => self.missed += 1,
            RayStatus::Tir { .. } => self.tir += 1,
            RayStatus::Clipped { .. } => self.clipped += 1,
            RayStatus::NoConvergence { .. } => self.no_convergence += 1,
            RayStatus::InvalidInput => self.invalid_input += 1,
        }
    }

    pub fn total(&self) -> usize {
        self.ok + self.missed + self.tir + self.clipped + self.no_convergence + self.invalid_input
    }

    pub fn merge(mut self, other: StatusCounts) -> StatusCounts {
        self.ok += other.ok;
        self.missed += other.missed;
        self.tir += other.tir;
        self.clipped += other.clipped;
        self.no_convergence += other.no_convergence;
        self.invalid_input += other.invalid_input;
        self
    }

    pub fn from_statuses<'a>(statuses: impl IntoIterator<Item = &'a RayStatus>) -> StatusCounts {
        let mut counts = StatusCounts::default();
        statuses.into_iter().for_each(|s| counts.add(*s));
        counts
    }
}
