//! Forward-mode automatic differentiation: `Dual<N>` carries a value and its gradient with respect to
//! N seeded variables, in a fixed-size array.
//!
//! Hand-written rather than `num-dual`: the gradient length is a const generic, so a dual is a plain
//! `Copy` value on the stack (no heap allocation per operation, as `num-dual`'s dynamically sized
//! gradients need), and the loops over `[f64; N]` vectorise. The design parameter count varies (about 5
//! to 60), so `local::linearise` picks the smallest of a few compiled sizes (16, 24, 48; passes of 32 beyond)
//! that fits and leaves the unused directions at zero.

use crate::scalar::Scalar;
use std::ops::{Add, Div, Mul, Neg, Sub};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dual<const N: usize> {
    pub value: f64,
    pub grad: [f64; N],
}

impl<const N: usize> Dual<N> {
    /// The i-th independent variable at `value`.
    pub fn variable(value: f64, i: usize) -> Self {
        let mut grad = [0.0; N];
        grad[i] = 1.0;
        Dual { value, grad }
    }

    /// value f(x) with derivative f'(x) applied by the chain rule.
    #[inline]
    fn chain(self, value: f64, derivative: f64) -> Self {
        let mut grad = self.grad;
        for g in &mut grad {
            *g *= derivative;
        }
        Dual { value, grad }
    }
}

impl<const N: usize> Add for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(self, o: Self) -> Self {
        let mut grad = self.grad;
        for (g, h) in grad.iter_mut().zip(&o.grad) {
            *g += h;
        }
        Dual {
            value: self.value + o.value,
            grad,
        }
    }
}

impl<const N: usize> Sub for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(self, o: Self) -> Self {
        let mut grad = self.grad;
        for (g, h) in grad.iter_mut().zip(&o.grad) {
            *g -= h;
        }
        Dual {
            value: self.value - o.value,
            grad,
        }
    }
}

impl<const N: usize> Mul for Dual<N> {
    type Output = Self;
    #[inline]
    fn mul(self, o: Self) -> Self {
        let mut grad = [0.0; N];
        for ((g, a), b) in grad.iter_mut().zip(&self.grad).zip(&o.grad) {
            *g = a * o.value + b * self.value;
        }
        Dual {
            value: self.value * o.value,
            grad,
        }
    }
}

impl<const N: usize> Div for Dual<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: Self) -> Self {
        let inv = 1.0 / o.value;
        let value = self.value * inv;
        let mut grad = [0.0; N];
        for ((g, a), b) in grad.iter_mut().zip(&self.grad).zip(&o.grad) {
            *g = (a - value * b) * inv;
        }
        Dual { value, grad }
    }
}

impl<const N: usize> Neg for Dual<N> {
    type Output = Self;
    #[inline]
    fn neg(self) -> Self {
        self.chain(-self.value, -1.0)
    }
}

impl<const N: usize> Add<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn add(mut self, o: f64) -> Self {
        self.value += o;
        self
    }
}

impl<const N: usize> Sub<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn sub(mut self, o: f64) -> Self {
        self.value -= o;
        self
    }
}

impl<const N: usize> Mul<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn mul(self, o: f64) -> Self {
        self.chain(self.value * o, o)
    }
}

impl<const N: usize> Div<f64> for Dual<N> {
    type Output = Self;
    #[inline]
    fn div(self, o: f64) -> Self {
        self.chain(self.value / o, 1.0 / o)
    }
}

impl<const N: usize> Scalar for Dual<N> {
    #[inline]
    fn cst(value: f64) -> Self {
        Dual {
            value,
            grad: [0.0; N],
        }
    }
    #[inline]
    fn re(&self) -> f64 {
        self.value
    }
    #[inline]
    fn sqrt(self) -> Self {
        let root = self.value.sqrt();
        // d sqrt(0) is infinite; a zero radicand only occurs on the axis, where the derivative is unused.
        let derivative = if root > 0.0 { 0.5 / root } else { 0.0 };
        self.chain(root, derivative)
    }
    #[inline]
    fn sin(self) -> Self {
        self.chain(self.value.sin(), self.value.cos())
    }
    #[inline]
    fn cos(self) -> Self {
        self.chain(self.value.cos(), -self.value.sin())
    }
    #[inline]
    fn atan(self) -> Self {
        self.chain(self.value.atan(), 1.0 / (1.0 + self.value * self.value))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn derivatives_of_a_composite_match_closed_form() {
        let x = Dual::<2>::variable(0.7, 0);
        let y = Dual::<2>::variable(1.3, 1);
        // f = sqrt(x y) / (x + 2) + sin(x) cos(y) + atan(y)
        let f = (x * y).sqrt() / (x + 2.0) + x.sin() * y.cos() + y.atan();
        let (xv, yv) = (0.7f64, 1.3f64);
        let s = (xv * yv).sqrt();
        let dfx = (0.5 * yv / s) / (xv + 2.0) - s / ((xv + 2.0) * (xv + 2.0)) + xv.cos() * yv.cos();
        let dfy = (0.5 * xv / s) / (xv + 2.0) - xv.sin() * yv.sin() + 1.0 / (1.0 + yv * yv);
        assert!((f.grad[0] - dfx).abs() < 1e-14);
        assert!((f.grad[1] - dfy).abs() < 1e-14);
    }
}
