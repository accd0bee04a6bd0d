//! sRGB transfer function (IEC 61966-2-1:1999, section 5.2 and 5.3): the piecewise curve with a linear toe,
//! not the pure 2.2 power law. Applied per sample on `Planar` planes.
//!
//! Hand-written because it is four lines and the crate needs it on planar f32 data in place; the image
//! crate only converts between its own pixel types. The maths runs in f64 so that a decode/encode round
//! trip in f32 is exact to about one f32 ulp.
//!
//! Outside [0, 1] the curve is extended as an odd function (`f(-v) = -f(v)`, the power law continued above
//! 1), so noisy or out-of-gamut values survive a round trip instead of being clipped silently.

use crate::Planar;

/// Linear-light breakpoint of the encoding curve (IEC 61966-2-1, 5.3).
const LINEAR_BREAK: f64 = 0.003_130_8;
/// Encoded-value breakpoint of the decoding curve (IEC 61966-2-1, 5.2): 12.92 * `LINEAR_BREAK`, rounded as
/// in the standard.
const ENCODED_BREAK: f64 = 0.040_45;
const TOE_SLOPE: f64 = 12.92;
const GAMMA: f64 = 2.4;
const OFFSET: f64 = 0.055;

/// Transfer curve direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Transfer {
    /// Linear light -> sRGB-encoded value (IEC 61966-2-1, 5.3).
    Encode,
    /// sRGB-encoded value -> linear light (IEC 61966-2-1, 5.2).
    Decode,
}

/// sRGB encoding of one linear-light value (IEC 61966-2-1, 5.3).
pub fn srgb_encode(linear: f32) -> f32 {
    let v = f64::from(linear).abs();
    let encoded = if v <= LINEAR_BREAK {
        TOE_SLOPE * v
    } else {
        (1.0 + OFFSET) * v.powf(1.0 / GAMMA) - OFFSET
    };
    (encoded.copysign(f64::from(linear))) as f32
}

/// Linear-light value of one sRGB-encoded value (IEC 61966-2-1, 5.2).
pub fn srgb_decode(encoded: f32) -> f32 {
    let v = f64::from(encoded).abs();
    let linear = if v <= ENCODED_BREAK {
        v / TOE_SLOPE
    } else {
        ((v + OFFSET) / (1.0 + OFFSET)).powf(GAMMA)
    };
    (linear.copysign(f64::from(encoded))) as f32
}

/// Applies the sRGB curve in `direction` to every sample of `samples` (one plane, or a whole image).
pub fn apply_srgb(samples: &mut [f32], direction: Transfer) {
    let curve = match direction {
        Transfer::Encode => srgb_encode,
        Transfer::Decode => srgb_decode,
    };
    samples.iter_mut().for_each(|v| *v = curve(*v));
}

/// sRGB-encoded copy of a linear-light image; every channel is encoded (pass colour planes only, not alpha).
pub fn linear_to_srgb(image: &Planar) -> Planar {
    let mut out = image.clone();
    apply_srgb(&mut out.data, Transfer::Encode);
    out
}

/// Linear-light copy of an sRGB-encoded image; every channel is decoded (pass colour planes only, not alpha).
pub fn srgb_to_linear(image: &Planar) -> Planar {
    let mut out = image.clone();
    apply_srgb(&mut out.data, Transfer::Decode);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_round_trip_is_identity_to_1e_6() {
        let mut worst = 0.0f32;
        for i in 0..=100_000 {
            let v = i as f32 / 100_000.0;
            worst = worst.max((srgb_decode(srgb_encode(v)) - v).abs());
            worst = worst.max((srgb_encode(srgb_decode(v)) - v).abs());
        }
        assert!(worst <= 1e-6, "worst round-trip error {worst}");
        let image = Planar::from_fn(7, 5, 3, |c, x, y| (c + x * 3 + y * 21) as f32 / 120.0);
        let back = srgb_to_linear(&linear_to_srgb(&image));
        for (a, b) in image.data.iter().zip(&back.data) {
            assert!((a - b).abs() <= 1e-6);
        }
    }

    #[test]
    fn srgb_curve_hits_the_standards_anchor_points() {
        assert_eq!(srgb_encode(0.0), 0.0);
        assert!((srgb_encode(1.0) - 1.0).abs() < 1e-7);
        // Mid grey: linear 0.18 encodes to about 0.4614 (118/255).
        assert!((srgb_encode(0.18) - 0.461_356).abs() < 1e-5);
        // The two branches meet at the breakpoint (continuity to the standard's rounding, ~1e-7).
        let below = srgb_decode(0.040_45);
        let above = srgb_decode(0.040_450_1);
        assert!((above - below).abs() < 1e-6);
        // Odd extension.
        assert_eq!(srgb_encode(-0.25), -srgb_encode(0.25));
    }
}
