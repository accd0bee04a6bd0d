//! Sensor read-out in digital numbers (DN): the Poisson-Gaussian model (Foi et al., "Practical
//! Poissonian-Gaussian noise modeling and fitting for single-image raw-data", IEEE TIP 2008; EMVA 1288
//! release 4.0 linear camera model), with black level, bit depth, rounding and clipping.
//!
//! For a relative exposure s in [0, 1] (1 = white level) the mean signal above black is
//! S = s (W - B) DN, with W = 2^bits - 1 the white level and B the black level. With analogue gain
//! g = ISO / ISO_base, conversion gain K = K_base g (DN per photo-electron) and read noise
//! σ_r = σ_base g (DN):
//!
//! n ~ Poisson(S / K) photo-electrons,  DN = clip(round(B + K n + σ_r z), 0, W),  z ~ N(0, 1),
//!
//! so E[DN] = B + S and Var[DN] = K S + σ_r² (+ 1/12 from rounding) away from clipping: DeepLens' variance
//! "shot² · gain + read² · gain²" (`deeplens/sensor/rgb_sensor.py`) with K_base = shot².
//! Random numbers come from the counter-based draws of `unicac_io::counter_draws` (Poisson by inversion
//! or Hörmann's PTRS, normals by Acklam's inverse distribution function): each sample has its own
//! stream keyed by the seed and the sample's index, so a seed reproduces the same noise everywhere, on
//! any number of threads, and a GPU kernel can draw the same numbers. (Releases before 2026-12-06
//! drew from one ChaCha8 stream in raster order: the same model, another realisation.)

use crate::error::{check_layout, ImageError, Result};
use crate::quantise::max_code;
use crate::Planar;
use rayon::prelude::*;
use unicac_io::counter_draws::{common_poisson_then_normal, CounterStream};
use unicac_io::counter_random::derive_seed;

/// Read-out bit depth of the default sensor: DeepLens' 10 bits (`unicac simulate --sensor-bits`).
pub const DEFAULT_BIT_DEPTH: u8 = 10;
/// Fewest bits the default sensor reads out with: its black level (64 DN) must lie below the white
/// level 2^bits - 1, which takes 7 bits (127 DN).
pub const MIN_DEFAULT_SENSOR_BITS: u8 = 7;

/// The name of the read-out's random draws, recorded by datasets: per-sample counter streams
/// (SplitMix64), Poisson by inversion / PTRS, normals by inverse distribution function. Another
/// generator is another noise realisation of the same model.
pub const NOISE_DRAWS: &str = "counter-splitmix64-ptrs";

/// Sensor read-out parameters. `Default` gives DeepLens' default sensor (prior-art.md section 1.4).
/// Serialised by field name (a dataset records it with every pair).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SensorNoise {
    /// Bits per raw sample (1..=16): white level 2^bits - 1 DN. Default 10.
    pub bit_depth: u8,
    /// Black level (dark offset), DN, below the white level. Default 64.
    pub black_level_dn: f32,
    /// Exposure index; the analogue gain is `iso / iso_base`. Default 100.
    pub iso: f32,
    /// ISO at unit analogue gain. Default 100.
    pub iso_base: f32,
    /// Conversion gain at base ISO, DN per photo-electron. Default 0.16 (= 0.4²: DeepLens' shot-noise std
    /// 0.4 sqrt(signal) DN), i.e. 6.25 e-/DN and about 6,000 e- between black and white at 10 bits.
    pub dn_per_electron_at_base_iso: f32,
    /// Read-noise standard deviation at base ISO, DN (scales with the analogue gain). Default 0.5.
    pub read_noise_dn_at_base_iso: f32,
}

impl Default for SensorNoise {
    fn default() -> Self {
        SensorNoise {
            bit_depth: DEFAULT_BIT_DEPTH,
            black_level_dn: 64.0,
            iso: 100.0,
            iso_base: 100.0,
            dn_per_electron_at_base_iso: 0.16,
            read_noise_dn_at_base_iso: 0.5,
        }
    }
}

impl SensorNoise {
    /// White level W = 2^bits - 1, DN.
    pub fn white_level_dn(&self) -> Result<f32> {
        Ok(max_code(self.bit_depth)? as f32)
    }

    /// Analogue gain g = ISO / ISO_base.
    pub fn analogue_gain(&self) -> f32 {
        self.iso / self.iso_base
    }

    /// Conversion gain K at the current ISO, DN per photo-electron.
    pub fn dn_per_electron(&self) -> f32 {
        self.dn_per_electron_at_base_iso * self.analogue_gain()
    }

    /// Read-noise standard deviation at the current ISO, DN.
    pub fn read_noise_dn(&self) -> f32 {
        self.read_noise_dn_at_base_iso * self.analogue_gain()
    }

    /// Model mean and variance (DN, DN²) of an unclipped sample at relative exposure `signal`, before
    /// rounding: (B + S, K S + σ_r²) with S = signal (W - B).
    pub fn expected_mean_and_variance_dn(&self, signal: f32) -> Result<(f64, f64)> {
        self.validate()?;
        let above_black =
            f64::from(signal.max(0.0)) * f64::from(self.white_level_dn()? - self.black_level_dn);
        let read = f64::from(self.read_noise_dn());
        Ok((
            f64::from(self.black_level_dn) + above_black,
            f64::from(self.dn_per_electron()) * above_black + read * read,
        ))
    }

    /// Refuses, naming the field, a sensor the read-out cannot use.
    pub fn validate(&self) -> Result<()> {
        let white = self.white_level_dn()?;
        let positive = |field: &'static str, v: f32| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(ImageError::invalid(
                    field,
                    format!("{v}, expected a finite value > 0"),
                ))
            }
        };
        positive("iso", self.iso)?;
        positive("iso_base", self.iso_base)?;
        positive("dn_per_electron_at_base_iso", self.dn_per_electron_at_base_iso)?;
        if !(self.read_noise_dn_at_base_iso.is_finite() && self.read_noise_dn_at_base_iso >= 0.0) {
            return Err(ImageError::invalid(
                "read_noise_dn_at_base_iso",
                "expected a finite value >= 0",
            ));
        }
        // Each value finite, their products can still overflow (a sample would read out as NaN).
        let gain = self.analogue_gain();
        if !(gain.is_finite() && gain > 0.0) {
            return Err(ImageError::invalid(
                "iso",
                format!(
                    "{} / iso_base {} gives an analogue gain of {gain}, expected a finite value > 0",
                    self.iso, self.iso_base
                ),
            ));
        }
        for (field, value) in [
            ("dn_per_electron_at_base_iso", self.dn_per_electron()),
            ("read_noise_dn_at_base_iso", self.read_noise_dn()),
        ] {
            if !value.is_finite() {
                return Err(ImageError::invalid(
                    field,
                    format!("times the analogue gain {gain} overflows to {value}"),
                ));
            }
        }
        if !(self.black_level_dn >= 0.0 && self.black_level_dn < white) {
            return Err(ImageError::invalid(
                "black_level_dn",
                format!(
                    "{}, expected 0 <= black < white level {white}",
                    self.black_level_dn
                ),
            ));
        }
        Ok(())
    }
}

/// Raw read-out in DN (integer-valued f32 in [0, W]) of `exposure` (relative to white, any channel count):
/// black level + signal, with Poisson shot noise and Gaussian read noise drawn from `noise_seed`, or
/// noiseless when `noise_seed` is `None`; then rounded and clipped to the bit depth.
///
/// Sample i (its index in `exposure.data`) draws from its own counter stream
/// `derive_seed(noise_seed, i)`: first its photo-electrons, then its read noise. The samples are
/// therefore read out in parallel, and the same on any number of threads.
pub fn read_out(exposure: &Planar, sensor: &SensorNoise, noise_seed: Option<u64>) -> Result<Planar> {
    super::edited_copy(exposure, |image| read_out_in_place(image, sensor, noise_seed))
}

/// [`read_out`] where the samples are: `exposure` becomes the DN (the pipeline's own mosaic: no copy).
pub(crate) fn read_out_in_place(
    exposure: &mut Planar,
    sensor: &SensorNoise,
    noise_seed: Option<u64>,
) -> Result<()> {
    sensor.validate()?;
    check_layout(exposure, "exposure", &[])?;
    if exposure.data.par_iter().any(|v| v.is_nan()) {
        return Err(ImageError::invalid("exposure", "NaN sample"));
    }
    let digitiser = Digitiser {
        black_dn: f64::from(sensor.black_level_dn),
        white_dn: f64::from(sensor.white_level_dn()?),
        dn_per_electron: f64::from(sensor.dn_per_electron()),
        read_noise_dn: f64::from(sensor.read_noise_dn()),
        noise_seed,
    };
    let arch = pulp::Arch::new();
    exposure
        .data
        .par_chunks_mut(READ_OUT_CHUNK)
        .enumerate()
        .for_each(|(chunk, samples)| {
            arch.dispatch(ReadOutChunk {
                digitiser,
                first_index: (chunk * READ_OUT_CHUNK) as u64,
                samples,
            })
        });
    Ok(())
}

/// The read-out of one sample, in f64: the sensor's constants and the noise seed.
#[derive(Clone, Copy)]
struct Digitiser {
    black_dn: f64,
    white_dn: f64,
    dn_per_electron: f64,
    read_noise_dn: f64,
    noise_seed: Option<u64>,
}

impl Digitiser {
    /// DN of the sample at `index` (its place in the image, which keys its noise stream) exposed to
    /// `exposure` (relative to white).
    #[inline(always)]
    fn read(&self, index: u64, exposure: f32) -> f32 {
        let above_black = self.above_black_dn(exposure);
        let signal = match self.noise_seed {
            None => above_black,
            Some(seed) => {
                let k = self.dn_per_electron;
                let mut stream = CounterStream::new(derive_seed(seed, index));
                k * stream.poisson(above_black / k) + self.read_noise_dn * stream.standard_normal()
            }
        };
        self.digitise(signal)
    }

    /// [`Self::read`] with noise from `seed` in the draws' common case, without a branch
    /// ([`common_poisson_then_normal`]): (DN, taken). When not taken, the DN means nothing.
    #[inline(always)]
    fn read_common(&self, seed: u64, index: u64, exposure: f32) -> (f32, bool) {
        let k = self.dn_per_electron;
        let (electrons, z, taken) =
            common_poisson_then_normal(derive_seed(seed, index), self.above_black_dn(exposure) / k);
        (self.digitise(k * electrons + self.read_noise_dn * z), taken)
    }

    #[inline(always)]
    fn above_black_dn(&self, exposure: f32) -> f64 {
        f64::from(exposure.max(0.0)) * (self.white_dn - self.black_dn)
    }

    /// Rounded and clipped to [0, W]: `f64::clamp` without its assertion, whose branch would keep the
    /// common-case loop from vectorising (W >= 1 holds by [`SensorNoise::validate`]).
    #[inline(always)]
    fn digitise(&self, signal_dn: f64) -> f32 {
        let dn = (self.black_dn + signal_dn).round();
        let dn = if dn < 0.0 { 0.0 } else { dn };
        (if dn > self.white_dn { self.white_dn } else { dn }) as f32
    }
}

/// A chunk of [`read_out`], compiled by `pulp` once per instruction set: with SSE4.1 and later the
/// per-sample `round` and the Poisson draw's `floor` are single instructions instead of libm calls.
/// The same IEEE operations in the same order on every path, so the same digits on every machine.
///
/// With noise, each block of [`LANE_BLOCK`] samples is read out twice over: first every sample in the
/// draws' common case by a loop without branches, which the compiler vectorises, then the samples
/// outside it (dark ones, first attempts left to the exact test, normal tails: a quarter of bright
/// samples, more of dark ones) one at a time by the sequential draws. Both give the same bits for a
/// sample that either can read.
struct ReadOutChunk<'a> {
    digitiser: Digitiser,
    first_index: u64,
    samples: &'a mut [f32],
}

/// Samples per block of the vectorised read-out (its buffers live on the stack).
const LANE_BLOCK: usize = 256;

impl pulp::WithSimd for ReadOutChunk<'_> {
    type Output = ();
    #[inline(always)]
    fn with_simd<S: pulp::Simd>(self, _simd: S) {
        let digitiser = self.digitiser;
        let Some(seed) = digitiser.noise_seed else {
            for (offset, v) in self.samples.iter_mut().enumerate() {
                *v = digitiser.read(self.first_index + offset as u64, *v);
            }
            return;
        };
        for (block_index, block) in self.samples.chunks_mut(LANE_BLOCK).enumerate() {
            let first = self.first_index + (block_index * LANE_BLOCK) as u64;
            let mut common_dn = [0.0f32; LANE_BLOCK];
            let mut taken = [false; LANE_BLOCK];
            for (offset, ((&exposure, dn), taken)) in
                block.iter().zip(&mut common_dn).zip(&mut taken).enumerate()
            {
                (*dn, *taken) = digitiser.read_common(seed, first + offset as u64, exposure);
            }
            for (offset, ((v, &dn), &taken)) in block.iter_mut().zip(&common_dn).zip(&taken).enumerate() {
                *v = if taken {
                    dn
                } else {
                    digitiser.read(first + offset as u64, *v)
                };
            }
        }
    }
}

/// Samples per parallel task of [`read_out`] (a size that keeps the scheduling cost negligible; the
/// result does not depend on it).
const READ_OUT_CHUNK: usize = 1 << 14;

/// Relative exposure from DN: black level subtracted and divided by (W - B). Not clipped: read noise below
/// black stays negative so that averages remain unbiased.
pub fn subtract_black_level(dn: &Planar, sensor: &SensorNoise) -> Result<Planar> {
    super::edited_copy(dn, |image| subtract_black_level_in_place(image, sensor))
}

/// [`subtract_black_level`] where the samples are.
pub(crate) fn subtract_black_level_in_place(dn: &mut Planar, sensor: &SensorNoise) -> Result<()> {
    sensor.validate()?;
    check_layout(dn, "dn", &[])?;
    let black = sensor.black_level_dn;
    let range = sensor.white_level_dn()? - black;
    crate::color::map_in_parallel(&mut dn.data, |v| (v - black) / range);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn noisy_mean_and_variance_match_the_model_within_four_standard_errors() {
        let n = 256 * 256;
        for (i, iso) in [100.0, 800.0].into_iter().enumerate() {
            let sensor = SensorNoise {
                iso,
                ..SensorNoise::default()
            };
            for (k, level) in [0.02f32, 0.1, 0.35, 0.8].into_iter().enumerate() {
                let flat = Planar::from_fn(256, 256, 1, |_, _, _| level);
                let dn = read_out(&flat, &sensor, Some(1000 + 10 * i as u64 + k as u64)).unwrap();
                let mean = dn.data.iter().map(|&v| f64::from(v)).sum::<f64>() / n as f64;
                let variance = dn
                    .data
                    .iter()
                    .map(|&v| (f64::from(v) - mean).powi(2))
                    .sum::<f64>()
                    / (n - 1) as f64;
                let (model_mean, model_variance) = sensor.expected_mean_and_variance_dn(level).unwrap();
                let model_variance = model_variance + 1.0 / 12.0; // rounding to integer DN (Sheppard)
                let mean_error = model_variance.sqrt() / (n as f64).sqrt();
                let variance_error = model_variance * (2.0 / (n - 1) as f64).sqrt();
                eprintln!(
                    "ISO {iso} level {level}: mean {mean:.3} (model {model_mean:.3}, {:+.2} se), variance {variance:.3} (model {model_variance:.3}, {:+.2} se)",
                    (mean - model_mean) / mean_error,
                    (variance - model_variance) / variance_error
                );
                assert!(
                    (mean - model_mean).abs() < 4.0 * mean_error,
                    "ISO {iso}, level {level}: mean {mean} vs {model_mean} (se {mean_error})"
                );
                assert!(
                    (variance - model_variance).abs() < 4.0 * variance_error,
                    "ISO {iso}, level {level}: variance {variance} vs {model_variance} (se {variance_error})"
                );
            }
        }
    }

    #[test]
    fn noiseless_read_out_is_exact_digitisation() {
        let sensor = SensorNoise::default();
        let exposure = Planar::from_fn(5, 1, 1, |_, x, _| [-0.1, 0.0, 0.5, 1.0, 1.5][x]);
        let dn = read_out(&exposure, &sensor, None).unwrap();
        assert_eq!(
            dn.data,
            [64.0, 64.0, (64.0f32 + 0.5 * 959.0).round(), 1023.0, 1023.0]
        );
        let back = subtract_black_level(&dn, &sensor).unwrap();
        assert!((back.data[2] - 0.5).abs() <= 0.5 / 959.0);
        assert_eq!(back.data[3], 1.0);
    }

    #[test]
    fn noise_is_reproducible_per_seed() {
        let sensor = SensorNoise {
            iso: 400.0,
            ..SensorNoise::default()
        };
        let flat = Planar::from_fn(32, 32, 3, |_, _, _| 0.3);
        let a = read_out(&flat, &sensor, Some(9)).unwrap();
        assert_eq!(a, read_out(&flat, &sensor, Some(9)).unwrap());
        let b = read_out(&flat, &sensor, Some(10)).unwrap();
        assert!(a.data.iter().zip(&b.data).filter(|(x, y)| x != y).count() > a.data.len() / 2);
    }

    #[test]
    fn each_sample_draws_from_its_own_stream_on_any_number_of_threads() {
        let sensor = SensorNoise {
            iso: 400.0,
            ..SensorNoise::default()
        };
        // More samples than one parallel task holds, with a dark and a saturated sample.
        let mut exposure = Planar::from_fn(181, 100, 2, |x, y, c| (x * 7 + y * 3 + c) as f32 / 2000.0);
        exposure.data[0] = 0.0;
        exposure.data[1] = f32::INFINITY;
        let on = |threads| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| read_out(&exposure, &sensor, Some(21)).unwrap())
        };
        let one = on(1);
        assert_eq!(one, on(3));
        assert_eq!(one.data[1], 1023.0, "a saturated sample reads the white level");
        // The contract a GPU twin repeats: sample i's stream is derive_seed(seed, i). Checked for every
        // sample (Poisson by inversion and by PTRS, normal tails): this loop draws sequentially and is
        // compiled for the baseline instruction set, `read_out` takes the vectorised common case where it
        // can and is compiled for the machine's (`pulp` dispatch), and they must agree bit for bit.
        let (k, read) = (
            f64::from(sensor.dn_per_electron()),
            f64::from(sensor.read_noise_dn()),
        );
        for i in 0..exposure.data.len() {
            let mut stream = CounterStream::new(derive_seed(21, i as u64));
            let above_black = f64::from(exposure.data[i]) * (1023.0 - 64.0);
            let signal = k * stream.poisson(above_black / k) + read * stream.standard_normal();
            assert_eq!(
                one.data[i],
                (64.0 + signal).round().clamp(0.0, 1023.0) as f32,
                "sample {i}"
            );
        }
    }

    #[test]
    fn invalid_sensors_and_samples_are_typed_errors() {
        let flat = Planar::new(2, 2, 1);
        let bad_black = SensorNoise {
            black_level_dn: 2000.0,
            ..SensorNoise::default()
        };
        assert!(matches!(
            read_out(&flat, &bad_black, None),
            Err(ImageError::InvalidParameter {
                field: "black_level_dn",
                ..
            })
        ));
        let bad_bits = SensorNoise {
            bit_depth: 20,
            ..SensorNoise::default()
        };
        assert!(matches!(
            read_out(&flat, &bad_bits, None),
            Err(ImageError::InvalidParameter {
                field: "bit_depth",
                ..
            })
        ));
        let overflowing_gain = SensorNoise {
            iso: 3e38,
            iso_base: 1e-38,
            ..SensorNoise::default()
        };
        assert!(matches!(
            read_out(&flat, &overflowing_gain, Some(1)),
            Err(ImageError::InvalidParameter { field: "iso", .. })
        ));
        let overflowing_read_noise = SensorNoise {
            iso: 1e4,
            read_noise_dn_at_base_iso: 1e37,
            ..SensorNoise::default()
        };
        assert!(matches!(
            read_out(&flat, &overflowing_read_noise, Some(1)),
            Err(ImageError::InvalidParameter {
                field: "read_noise_dn_at_base_iso",
                ..
            })
        ));
        let nan = Planar::from_fn(1, 1, 1, |_, _, _| f32::NAN);
        assert!(read_out(&nan, &SensorNoise::default(), Some(1)).is_err());
    }

    #[test]
    fn the_default_sensor_reads_out_at_every_depth_from_its_minimum_to_16_bits() {
        let flat = Planar::from_fn(2, 2, 1, |_, _, _| 0.5);
        for bit_depth in 1..=16u8 {
            let sensor = SensorNoise {
                bit_depth,
                ..SensorNoise::default()
            };
            assert_eq!(
                read_out(&flat, &sensor, Some(1)).is_ok(),
                bit_depth >= MIN_DEFAULT_SENSOR_BITS,
                "{bit_depth} bits"
            );
        }
    }
}
