//! The scalar the design tracer is generic over: `f64` for fast merit values, `Dual<N>` for exact
//! gradients. Only the operations the tracer needs.

use std::ops::{Add, Div, Mul, Neg, Sub};

pub trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + Add<f64, Output = Self>
    + Sub<f64, Output = Self>
    + Mul<f64, Output = Self>
    + Div<f64, Output = Self>
    + Send
    + Sync
    + std::fmt::Debug
{
    /// A constant (zero derivative).
    fn cst(value: f64) -> Self;
    /// The value (real part).
    fn re(&self) -> f64;
    fn sqrt(self) -> Self;
    /// |x| with the derivative of the branch taken (sign(x) x).
    fn abs(self) -> Self {
        if self.re() < 0.0 {
            -self
        } else {
            self
        }
    }
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    fn atan(self) -> Self;
}

impl Scalar for f64 {
    #[inline]
    fn cst(value: f64) -> Self {
        value
    }
    #[inline]
    fn re(&self) -> f64 {
        *self
    }
    #[inline]
    fn sqrt(self) -> Self {
        f64::sqrt(self)
    }
    #[inline]
    fn sin(self) -> Self {
        f64::sin(self)
    }
    #[inline]
    fn cos(self) -> Self {
        f64::cos(self)
    }
    #[inline]
    fn atan(self) -> Self {
        f64::atan(self)
    }
}

/// The larger of two scalars by value (the derivative follows the one chosen).
#[inline]
pub fn max<S: Scalar>(a: S, b: S) -> S {
    if b.re() > a.re() {
        b
    } else {
        a
    }
}
