//! `Real`: the working floating-point type of a kernel (f32 by default, f64 where the adapter offers
//! SHADER_F64), with what the WGSL prelude and the twins need to know about it.

use bytemuck::Pod;
use std::ops::{Add, Div, Mul, Neg, Sub};
pub use unicac_trace::pupil::TurnsFloat;

/// f32 or f64. The WGSL prelude (`shader::source`) is generated from these constants, so the kernel and
/// its twin use the same tolerances.
/// `TurnsFloat` (unicac-trace) brings `round_even` and `to_u32`, and with them the pupil patterns' angle.
pub trait Real:
    TurnsFloat
    + Pod
    + Copy
    + PartialOrd
    + std::fmt::Debug
    + std::fmt::LowerExp
    + Default
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Send
    + Sync
    + 'static
{
    const PRECISION: Precision;
    /// Unit roundoff's neighbour: the distance from 1 to the next representable number.
    const EPSILON: Self;
    const MAX: Self;
    const MIN_POSITIVE: Self;
    fn from_f64(v: f64) -> Self;
    fn to_f64(self) -> f64;
    fn from_u32(v: u32) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn floor(self) -> Self;
    /// Relative Newton step tolerance: sqrt(EPSILON) / 16 (f32: 2^-15.5, 183 ulps of 1; f64: 2^-30,
    /// 9.3e-10, next to the CPU's 1e-9). Newton converges quadratically, so the error left after a step
    /// this small is about curvature x step^2: within a few ulps of the coordinates.
    /// Guard band of the pass/fail decisions (apertures, TIR, missing a surface): 1024 ulps, relative.
    /// Accumulated rounding in f32 stays well inside it (tens of ulps over a lens); rays inside it are
    /// re-traced in f64 by the host.
    fn guard() -> Self {
        Self::from_f64(Self::EPSILON.to_f64() * 1024.0)
    }
    fn newton_tolerance() -> Self {
        Self::from_f64(Self::EPSILON.to_f64().sqrt() / 16.0)
    }
}

/// Which kernels to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    F32,
    F64,
}

impl Precision {
    pub fn wgsl_type(self) -> &'static str {
        match self {
            Precision::F32 => "f32",
            Precision::F64 => "f64",
        }
    }
}

impl std::str::FromStr for Precision {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "f32" => Ok(Precision::F32),
            "f64" => Ok(Precision::F64),
            _ => Err(format!("'{text}': expected f32 or f64")),
        }
    }
}

impl std::fmt::Display for Precision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.wgsl_type())
    }
}

macro_rules! impl_real {
    ($t:ty, $precision:expr) => {
        impl Real for $t {
            const PRECISION: Precision = $precision;
            const EPSILON: Self = <$t>::EPSILON;
            const MAX: Self = <$t>::MAX;
            const MIN_POSITIVE: Self = <$t>::MIN_POSITIVE;
            #[inline]
            fn from_f64(v: f64) -> Self {
                v as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn from_u32(v: u32) -> Self {
                v as $t
            }
            #[inline]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
        }
    };
}

impl_real!(f32, Precision::F32);
impl_real!(f64, Precision::F64);
