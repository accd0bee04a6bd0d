//! sRGB transfer function (IEC 61966-2-1:1999, section 5.2 and 5.3): the piecewise curve with a linear toe,
//! not the pure 2.2 power law. Applied per sample on `Planar` planes.
//!
//! Hand-written because it is four lines and the crate needs it on planar f32 data in place; the image
//! crate only converts between its own pixel types. The maths runs in f64 so that a decode/encode round
//! trip in f32 is exact to about one f32 ulp.
//!
//! Outside [0, 1] the curve is extended as an odd function (`f(-v) = -f(v)`, the power law continued above
//! 1), so noisy or out-of-gamut values survive a round trip instead of being clipped silently.
//!
//! Whole-image encoding ([`apply_srgb`]) looks the power branch up in a table of 2^16 cells on [0, 1] with
//! linear interpolation instead of calling `powf` per sample: it is every ISP image's and every dataset
//! pair's most expensive step otherwise (~30 ns per sample). The table's error against [`srgb_encode`]
//! is below [`TABLE_ENCODE_BOUND`] (1/75 of a 16-bit code step); values outside [0, 1], the linear toe
//! and NaN take the exact path.
//!
//! Whole-image decoding looks every sample that is an integer code of a 16- or 8-bit file (every
//! sample a PNG or TIFF reader gives) up in a table of the 2^16 codes' exact decodings: the same value
//! [`srgb_decode`] gives, bit for bit (an 8-bit code c is the 16-bit code 257 c: both are the f64 quotient
//! of one rational rounded to f32); other samples take the exact path. Both directions run in parallel
//! chunks (each sample on its own, so the result does not depend on the thread count).

use crate::quantise::from_code;
use crate::Planar;
use rayon::prelude::*;
use std::sync::OnceLock;

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

/// Cells of the encoding table on [0, 1].
const TABLE_CELLS: usize = 1 << 16;

/// Largest difference between the table encoding of [`apply_srgb`] and [`srgb_encode`]. The interpolation error of the
/// power branch is below h^2/8 max|f''| = 7e-8 (h = 2^-16, f'' largest at the toe's breakpoint); the f32
/// table entries and the f32 result add half an ulp each (6e-8 near 1).
pub const TABLE_ENCODE_BOUND: f32 = 2e-7;

/// The power branch 1.055 v^(1/2.4) - 0.055 at v = i / 2^16, i = 0..=2^16 (the branch alone, also below
/// the breakpoint, so that every cell used interpolates a smooth function). Built once per process.
fn power_branch_table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..=TABLE_CELLS)
            .map(|i| {
                let v = i as f64 / TABLE_CELLS as f64;
                ((1.0 + OFFSET) * v.powf(1.0 / GAMMA) - OFFSET) as f32
            })
            .collect()
    })
}

/// [`srgb_encode`] within [`TABLE_ENCODE_BOUND`], by table lookup on (breakpoint, 1]; exact elsewhere.
fn srgb_encode_by_table(linear: f32, table: &[f32]) -> f32 {
    let v = f64::from(linear);
    if !(v > LINEAR_BREAK && v <= 1.0) {
        return srgb_encode(linear);
    }
    let position = v * TABLE_CELLS as f64;
    // v <= 1, so the cell index is at most TABLE_CELLS - 1 except at v = 1 exactly (its own entry).
    let cell = (position as usize).min(TABLE_CELLS - 1);
    let fraction = position - cell as f64;
    let (low, high) = (f64::from(table[cell]), f64::from(table[cell + 1]));
    (low + (high - low) * fraction) as f32
}

/// Applies the sRGB curve in `direction` to every sample of `samples` (one plane, or a whole image).
/// Encoding uses the table (within [`TABLE_ENCODE_BOUND`] of [`srgb_encode`]); decoding is exact.
pub fn apply_srgb(samples: &mut [f32], direction: Transfer) {
    match direction {
        Transfer::Encode => {
            let table = power_branch_table();
            map_in_parallel(samples, |v| srgb_encode_by_table(v, table));
        }
        Transfer::Decode => {
            let table = code_decode_table();
            map_in_parallel(samples, |v| srgb_decode_by_table(v, table));
        }
    }
}

/// Clips every sample to [0, 1] and, with `encode`, sRGB-encodes it as [`apply_srgb`] does, in one
/// parallel pass; false when a sample is NaN (the samples are then left part done).
pub(crate) fn clip_and_encode_in_place(samples: &mut [f32], encode: bool) -> bool {
    let table = power_branch_table();
    samples
        .par_chunks_mut(MAP_CHUNK)
        .map(|chunk| {
            let mut numbers = true;
            for v in chunk {
                let clipped = v.clamp(0.0, 1.0);
                numbers &= !clipped.is_nan();
                *v = if encode {
                    srgb_encode_by_table(clipped, table)
                } else {
                    clipped
                };
            }
            numbers
        })
        .reduce(|| true, |a, b| a && b)
}

/// Replaces every sample by `f` of it, in parallel chunks large enough that scheduling costs nothing
/// next to the work.
pub(crate) fn map_in_parallel(samples: &mut [f32], f: impl Fn(f32) -> f32 + Sync) {
    samples
        .par_chunks_mut(MAP_CHUNK)
        .for_each(|chunk| chunk.iter_mut().for_each(|v| *v = f(*v)));
}

/// Samples per parallel task of the sample maps (large enough that scheduling costs nothing next to the
/// work).
const MAP_CHUNK: usize = 1 << 16;

/// Largest code of 16-bit samples; the decoding table's last index.
const MAX_CODE_16: u32 = 65_535;

/// For every 16-bit code i: the sample a reader makes of it (`from_code(i, 65535)`) and that sample's
/// exact decoding. Built once per process.
fn code_decode_table() -> &'static [(f32, f32)] {
    static TABLE: OnceLock<Vec<(f32, f32)>> = OnceLock::new();
    TABLE.get_or_init(|| {
        (0..=MAX_CODE_16)
            .map(|code| {
                let sample = from_code(code, MAX_CODE_16);
                (sample, srgb_decode(sample))
            })
            .collect()
    })
}

/// [`srgb_decode`] of `encoded`, bit for bit: from the table when `encoded` is a 16-bit (or 8-bit)
/// code's sample, else computed.
fn srgb_decode_by_table(encoded: f32, table: &[(f32, f32)]) -> f32 {
    if (0.0..=1.0).contains(&encoded) {
        // The nearest code; the table says whether `encoded` is exactly its sample.
        let code = (f64::from(encoded) * f64::from(MAX_CODE_16) + 0.5) as usize;
        let (sample, decoded) = table[code.min(MAX_CODE_16 as usize)];
        if sample.to_bits() == encoded.to_bits() {
            return decoded;
        }
    }
    srgb_decode(encoded)
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
    fn table_decoder_equals_the_exact_decoder_bit_for_bit() {
        // Every 16-bit and 8-bit code's sample (the table path), their neighbouring f32 values and
        // values outside [0, 1] (the exact path).
        let mut samples: Vec<f32> = (0..=MAX_CODE_16).map(|c| from_code(c, MAX_CODE_16)).collect();
        samples.extend((0..=255).map(|c| from_code(c, 255)));
        let neighbours: Vec<f32> = samples
            .iter()
            .flat_map(|v| {
                [
                    f32::from_bits(v.to_bits() + 1),
                    f32::from_bits(v.to_bits().max(1) - 1),
                ]
            })
            .collect();
        samples.extend(neighbours);
        samples.extend([-0.0, -0.5, 1.5, f32::MAX, f32::MIN_POSITIVE, f32::INFINITY]);
        let mut decoded = samples.clone();
        apply_srgb(&mut decoded, Transfer::Decode);
        for (v, d) in samples.iter().zip(&decoded) {
            assert_eq!(d.to_bits(), srgb_decode(*v).to_bits(), "{v:e}");
        }
        let mut nan = [f32::NAN];
        apply_srgb(&mut nan, Transfer::Decode);
        assert!(nan[0].is_nan());
    }

    #[test]
    fn table_encoder_stays_within_its_bound_everywhere() {
        let table = power_branch_table();
        let mut worst = 0.0f32;
        // Every f32 from just below the breakpoint to 1 in steps of 97 ulps (about 10 million values),
        // plus the ends, values above 1, negatives and NaN, which take the exact path.
        let mut bits = (LINEAR_BREAK as f32 * 0.999).to_bits();
        let last = 1.0f32.to_bits();
        let mut values = vec![0.0, 1.0, 1.5, -0.25, 1e-9, f32::MIN_POSITIVE, LINEAR_BREAK as f32];
        while bits <= last {
            values.push(f32::from_bits(bits));
            bits += 97;
        }
        for v in values {
            worst = worst.max((srgb_encode_by_table(v, table) - srgb_encode(v)).abs());
        }
        eprintln!("sRGB table encoder: worst error {worst:e} (bound {TABLE_ENCODE_BOUND:e})");
        assert!(worst <= TABLE_ENCODE_BOUND, "worst table error {worst}");
        assert!(srgb_encode_by_table(f32::NAN, table).is_nan());
        assert_eq!(srgb_encode_by_table(1.0, table), srgb_encode(1.0));
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
