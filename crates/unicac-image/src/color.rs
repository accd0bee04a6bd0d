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
//! chunks (each sample on its own, so the result does not depend on the thread count), and each chunk
//! in blocks read twice over, like the sensor read-out: first every sample by the table without a
//! branch (a loop the compiler vectorises, with gathers, for the machine's instruction set: `pulp`
//! dispatch), then the few samples the table does not cover by the exact path.

use crate::quantise::from_code;
use crate::Planar;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
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
fn power_branch_table() -> &'static EncodeTable {
    static TABLE: OnceLock<Box<EncodeTable>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let entries: Vec<f32> = (0..=TABLE_CELLS)
            .map(|i| {
                let v = i as f64 / TABLE_CELLS as f64;
                ((1.0 + OFFSET) * v.powf(1.0 / GAMMA) - OFFSET) as f32
            })
            .collect();
        entries
            .into_boxed_slice()
            .try_into()
            .expect("TABLE_CELLS + 1 entries")
    })
}

/// The encoding table as a fixed-size array, so that its lookups need no bounds checks (a branch would
/// keep the blocked loop from vectorising).
type EncodeTable = [f32; TABLE_CELLS + 1];

/// One sample's encoding as [`apply_srgb`] makes it: [`srgb_encode`] within [`TABLE_ENCODE_BOUND`], by
/// table lookup on (breakpoint, 1], exact elsewhere. The reference the blocked encoding is tested
/// against, one sample at a time with branches.
#[cfg(test)]
fn srgb_encode_by_table(linear: f32, table: &EncodeTable) -> f32 {
    let v = f64::from(linear);
    if !(v > LINEAR_BREAK && v <= 1.0) {
        return srgb_encode(linear);
    }
    let position = v * TABLE_CELLS as f64;
    let cell = (position as usize).min(TABLE_CELLS - 1);
    let fraction = position - cell as f64;
    let (low, high) = (f64::from(table[cell]), f64::from(table[cell + 1]));
    (low + (high - low) * fraction) as f32
}

/// [`apply_srgb`]'s encoding without a branch where it can: the table on (breakpoint, 1] and the
/// exact linear toe on [-breakpoint, breakpoint]: (encoding, covered). When not covered (beyond 1 or
/// below -breakpoint, NaN: the power law, computed), the encoding means nothing.
#[inline(always)]
fn srgb_encode_common(linear: f32, table: &EncodeTable) -> (f32, bool) {
    let v = f64::from(linear);
    let in_table = v > LINEAR_BREAK && v <= 1.0;
    // Off the table, any cell will do: its value is not used.
    let position = if in_table { v } else { 1.0 } * TABLE_CELLS as f64;
    // v <= 1, so the cell index is at most TABLE_CELLS - 1 except at v = 1 exactly (its own entry).
    let cell = (position as usize).min(TABLE_CELLS - 1);
    let fraction = position - cell as f64;
    let (low, high) = (f64::from(table[cell]), f64::from(table[cell + 1]));
    let by_table = (low + (high - low) * fraction) as f32;
    // `srgb_encode`'s toe, operation for operation.
    let in_toe = v.abs() <= LINEAR_BREAK;
    let toe = (TOE_SLOPE * v.abs()).copysign(v) as f32;
    (if in_table { by_table } else { toe }, in_table || in_toe)
}

/// Applies the sRGB curve in `direction` to every sample of `samples` (one plane, or a whole image).
/// Encoding uses the table (within [`TABLE_ENCODE_BOUND`] of [`srgb_encode`]); decoding is exact.
pub fn apply_srgb(samples: &mut [f32], direction: Transfer) {
    match direction {
        Transfer::Encode => {
            let table = power_branch_table();
            map_in_blocks(samples, |v| srgb_encode_common(v, table), srgb_encode);
        }
        Transfer::Decode => {
            let table = code_decode_table();
            map_in_blocks(samples, |v| srgb_decode_common(v, table), srgb_decode);
        }
    }
}

/// Clips every sample to [0, 1] and, with `encode`, sRGB-encodes it as [`apply_srgb`] does, in one
/// parallel pass; false when a sample is NaN (the samples are then left part done).
pub(crate) fn clip_and_encode_in_place(samples: &mut [f32], encode: bool) -> bool {
    // Clipped, every number is covered by the table or the toe, so NaN is the one sample that reaches
    // the exact path: it is noted there, at no cost to the rest.
    let nan_seen = AtomicBool::new(false);
    let table = power_branch_table();
    let clip = |v: f32| v.clamp(0.0, 1.0);
    let exact = |v: f32| {
        if v.is_nan() {
            nan_seen.store(true, Ordering::Relaxed);
        }
        let clipped = clip(v);
        if encode {
            srgb_encode(clipped)
        } else {
            clipped
        }
    };
    if encode {
        map_in_blocks(samples, |v| srgb_encode_common(clip(v), table), exact);
    } else {
        map_in_blocks(samples, |v| (clip(v), !v.is_nan()), exact);
    }
    !nan_seen.into_inner()
}

/// Replaces every sample v by `common(v)`'s value where it covers v, else by `exact(v)`: in parallel
/// chunks, each compiled for the machine's widest vectors ([`BlockedMap`]).
fn map_in_blocks<C, E>(samples: &mut [f32], common: C, exact: E)
where
    C: Fn(f32) -> (f32, bool) + Sync,
    E: Fn(f32) -> f32 + Sync,
{
    let arch = pulp::Arch::new();
    samples.par_chunks_mut(MAP_CHUNK).for_each(|chunk| {
        arch.dispatch(BlockedMap {
            samples: chunk,
            common: &common,
            exact: &exact,
        })
    });
}

/// A chunk of [`map_in_blocks`], compiled by `pulp` once per instruction set. Each block of
/// [`LANE_BLOCK`] samples is mapped twice over: every sample by `common` in a loop without branches
/// (vectorised), then the samples it does not cover one at a time by `exact`.
struct BlockedMap<'a, C, E> {
    samples: &'a mut [f32],
    common: &'a C,
    exact: &'a E,
}

/// Samples per block of [`BlockedMap`] (its buffers live on the stack).
const LANE_BLOCK: usize = 256;

impl<C, E> pulp::WithSimd for BlockedMap<'_, C, E>
where
    C: Fn(f32) -> (f32, bool),
    E: Fn(f32) -> f32,
{
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        for block in self.samples.chunks_mut(LANE_BLOCK) {
            let mut mapped = [0.0f32; LANE_BLOCK];
            let mut covered = [false; LANE_BLOCK];
            for ((&v, mapped), covered) in block.iter().zip(&mut mapped).zip(&mut covered) {
                (*mapped, *covered) = (self.common)(v);
            }
            for ((v, &mapped), &covered) in block.iter_mut().zip(&mapped).zip(&covered) {
                *v = if covered { mapped } else { (self.exact)(*v) };
            }
        }
    }
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
fn code_decode_table() -> &'static DecodeTable {
    static TABLE: OnceLock<Box<DecodeTable>> = OnceLock::new();
    TABLE.get_or_init(|| {
        let entries: Vec<(f32, f32)> = (0..=MAX_CODE_16)
            .map(|code| {
                let sample = from_code(code, MAX_CODE_16);
                (sample, srgb_decode(sample))
            })
            .collect();
        entries.into_boxed_slice().try_into().expect("2^16 entries")
    })
}

/// The decoding table as a fixed-size array (lookups without bounds checks, as [`EncodeTable`]).
type DecodeTable = [(f32, f32); MAX_CODE_16 as usize + 1];

/// [`srgb_decode`] of `encoded` from the table when `encoded` is a 16-bit (or 8-bit) code's sample,
/// without a branch: (decoding, covered). Not covered (any other value), the decoding means nothing.
#[inline(always)]
fn srgb_decode_common(encoded: f32, table: &DecodeTable) -> (f32, bool) {
    let in_range = (0.0..=1.0).contains(&encoded);
    // The nearest code; the table says whether `encoded` is exactly its sample. Out of range, any
    // code will do: it is not used.
    let position = if in_range { f64::from(encoded) } else { 0.0 };
    let code = ((position * f64::from(MAX_CODE_16) + 0.5) as usize).min(MAX_CODE_16 as usize);
    let (sample, decoded) = table[code];
    (decoded, in_range && sample.to_bits() == encoded.to_bits())
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

    /// Values across every branch of the encoding: a sweep from below the toe's breakpoint to 1 in
    /// steps of 997 ulps, the ends, beyond 1, negatives, subnormals, infinities.
    fn encoding_test_values() -> Vec<f32> {
        let mut values = vec![0.0, -0.0, 1.0, 1.5, -0.25, -1e-3, 1e-9, f32::MIN_POSITIVE, 1e-45];
        values.extend([
            LINEAR_BREAK as f32,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::MAX,
            -f32::MAX,
        ]);
        let mut bits = (LINEAR_BREAK as f32 * 0.5).to_bits();
        while bits <= 1.0f32.to_bits() {
            values.push(f32::from_bits(bits));
            values.push(-f32::from_bits(bits));
            bits += 997;
        }
        if values.len().is_multiple_of(LANE_BLOCK) {
            values.push(0.25);
        }
        values
    }

    #[test]
    fn blocked_encoding_is_the_per_sample_encoding_bit_for_bit() {
        let table = power_branch_table();
        // An odd length: blocks and parallel chunks end part-filled.
        let values = encoding_test_values();
        assert!(!values.len().is_multiple_of(LANE_BLOCK) && values.len() > MAP_CHUNK);
        let mut encoded = values.clone();
        apply_srgb(&mut encoded, Transfer::Encode);
        for (v, e) in values.iter().zip(&encoded) {
            assert_eq!(e.to_bits(), srgb_encode_by_table(*v, table).to_bits(), "{v:e}");
        }
        let mut nan = [f32::NAN, 0.5];
        apply_srgb(&mut nan, Transfer::Encode);
        assert!(nan[0].is_nan() && nan[1] == srgb_encode_by_table(0.5, table));
    }

    #[test]
    fn clipping_and_encoding_in_place_clips_encodes_and_reports_nan() {
        let table = power_branch_table();
        let values = encoding_test_values();
        for encode in [true, false] {
            let mut out = values.clone();
            assert!(clip_and_encode_in_place(&mut out, encode));
            for (v, o) in values.iter().zip(&out) {
                let clipped = v.clamp(0.0, 1.0);
                let want = if encode {
                    srgb_encode_by_table(clipped, table)
                } else {
                    clipped
                };
                assert_eq!(o.to_bits(), want.to_bits(), "{v:e}, encode {encode}");
            }
            let mut with_nan = values.clone();
            with_nan[MAP_CHUNK + 3] = f32::NAN;
            assert!(
                !clip_and_encode_in_place(&mut with_nan, encode),
                "encode {encode}"
            );
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
