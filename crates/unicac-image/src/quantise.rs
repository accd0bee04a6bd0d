//! Conversion between unit-range f32 samples and integer code values of a given bit depth, the one
//! rounding rule shared by the ISP quantiser and the PNG/TIFF writers: code = round(v * (2^bits - 1)),
//! clamped to [0, 2^bits - 1] (ITU-R BT.709 / IEC 61966-2-1 full-range digital coding, round half away
//! from zero).

use crate::error::{ImageError, Result};
use crate::Planar;

/// Largest code value of `bits`-bit samples, `2^bits - 1`; `bits` must be 1..=16.
pub fn max_code(bits: u8) -> Result<u32> {
    if (1..=16).contains(&bits) {
        Ok((1u32 << bits) - 1)
    } else {
        Err(ImageError::invalid(
            "bit_depth",
            format!("{bits} bits, expected 1..=16"),
        ))
    }
}

/// Integer code of one unit-range sample; `None` for NaN or infinite input.
pub fn to_code(value: f32, max_code: u32) -> Option<u32> {
    if !value.is_finite() {
        return None;
    }
    // Round half away from zero as floor(x + 0.5) by truncation (`f64::round` is a libm call on
    // baseline x86-64): the product of an f32 and a code <= 2^16 is exact in f64, and so is adding 0.5
    // below 2^36, so this equals `round` wherever the result is not clamped.
    let shifted = f64::from(value) * f64::from(max_code) + 0.5;
    Some(if shifted <= 0.0 {
        0
    } else {
        (shifted as u32).min(max_code)
    })
}

/// Unit-range value of an integer code.
pub fn from_code(code: u32, max_code: u32) -> f32 {
    (f64::from(code) / f64::from(max_code)) as f32
}

/// Rounds every sample to the nearest of the `2^bits` levels in [0, 1] (values outside are clipped), as an
/// 8- or 16-bit output would store it, but keeps f32 storage. Fails on NaN/infinite samples.
pub fn quantise(image: &Planar, bits: u8) -> Result<Planar> {
    let max = max_code(bits)?;
    // One division per code instead of one per sample (the same values as `from_code`).
    let level: Vec<f32> = (0..=max).map(|code| from_code(code, max)).collect();
    let mut out = image.clone();
    for v in &mut out.data {
        let code = to_code(*v, max)
            .ok_or_else(|| ImageError::invalid("image", "NaN or infinite sample cannot be quantised"))?;
        *v = level[code as usize];
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_to_nearest_and_clip() {
        assert_eq!(to_code(0.5, 255), Some(128));
        assert_eq!(to_code(-0.1, 255), Some(0));
        assert_eq!(to_code(1.7, 65535), Some(65535));
        assert_eq!(to_code(f32::NAN, 255), None);
        assert_eq!(max_code(16).unwrap(), 65535);
        assert!(max_code(0).is_err() && max_code(17).is_err());
        for code in 0..=255 {
            assert_eq!(to_code(from_code(code, 255), 255), Some(code));
        }
    }

    #[test]
    fn codes_equal_round_half_away_from_zero_on_every_16_bit_half_step() {
        let reference =
            |v: f32, max: u32| (f64::from(v) * f64::from(max)).round().clamp(0.0, f64::from(max)) as u32;
        for max in [255u32, 1023, 65535] {
            for step in 0..=(2 * max + 2) {
                let exact_half = step as f32 * 0.5 / max as f32;
                for v in [
                    exact_half,
                    exact_half.next_up(),
                    exact_half.next_down(),
                    -exact_half,
                ] {
                    assert_eq!(to_code(v, max), Some(reference(v, max)), "{v} at max {max}");
                }
            }
        }
        assert_eq!(to_code(f32::MAX, 255), Some(255));
        assert_eq!(to_code(-f32::MAX, 255), Some(0));
    }

    #[test]
    fn quantise_leaves_at_most_half_a_step_of_error() {
        let image = Planar::from_fn(64, 1, 1, |_, x, _| x as f32 / 63.0 * 0.999);
        let q = quantise(&image, 8).unwrap();
        for (a, b) in image.data.iter().zip(&q.data) {
            assert!((a - b).abs() <= 0.5 / 255.0 + 1e-7);
        }
        assert!(quantise(&Planar::from_fn(1, 1, 1, |_, _, _| f32::NAN), 8).is_err());
    }
}
