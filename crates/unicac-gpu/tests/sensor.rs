//! The sensor read-out on the device (shaders/sensor.wgsl) against its twin (`sensor_twin`, the
//! same arithmetic on the host) and both against the f64 CPU read-out, the reference (`unicac_image::isp::read_out`:
//! the same counter streams, so most samples agree exactly; the share that does not is the f32
//! rounding of the draws). Figures are printed (`-- --nocapture`).

mod support;

use support::gpu_or_skip;
use unicac_gpu::sensor::sensor_constants;
use unicac_gpu::sensor_twin::{normal_draw, poisson_draw, read_out_sample};
use unicac_gpu::GpuImagePass;
use unicac_image::isp::{read_out, SensorNoise};
use unicac_image::Planar;
use unicac_io::counter_draws::CounterStream;
use unicac_io::counter_random::derive_seed;

/// Exposures from black to beyond white (a ramp with a dark band and a few negatives), any channels.
fn exposure(width: usize, height: usize, channels: usize) -> Planar {
    Planar::from_fn(width, height, channels, |c, x, y| {
        let t = (x + 7 * y + 13 * c) as f32 / (width + 7 * height) as f32;
        if y % 5 == 0 {
            0.004 * t - 0.001
        } else {
            1.15 * t
        }
    })
}

/// The default sensor and a high-ISO one (gain 64: ~94 electrons at white, so the dark samples use
/// the inversion method and the read noise is large).
fn sensors() -> [(&'static str, SensorNoise); 2] {
    [
        ("ISO 100", SensorNoise::default()),
        (
            "ISO 6400",
            SensorNoise {
                iso: 6400.0,
                ..SensorNoise::default()
            },
        ),
    ]
}

/// (samples that differ, largest difference in DN).
fn differences(a: &[f32], b: &[f32]) -> (usize, f32) {
    a.iter()
        .zip(b)
        .filter(|(x, y)| x != y)
        .fold((0, 0.0f32), |(n, worst), (x, y)| {
            (n + 1, worst.max((x - y).abs()))
        })
}

fn twin(exposure: &Planar, sensor: &SensorNoise, seed: u64) -> Vec<f32> {
    let constants = sensor_constants(exposure, sensor, seed).unwrap();
    exposure
        .data
        .iter()
        .enumerate()
        .map(|(i, &v)| read_out_sample(&constants, i as u32, v))
        .collect()
}

#[test]
fn the_kernel_equals_its_twin_and_follows_the_cpu_read_out() {
    let Some(context) = gpu_or_skip() else {
        return;
    };
    let pass = GpuImagePass::new(context);
    for (name, sensor) in sensors() {
        for (width, height, channels) in [(640, 480, 1), (97, 61, 3)] {
            let image = exposure(width, height, channels);
            let gpu = pass.read_out(&image, &sensor, 11).unwrap();
            let twin = twin(&image, &sensor, 11);
            let cpu = read_out(&image, &sensor, Some(11)).unwrap();
            let (kernel_twin, _) = differences(&gpu.data, &twin);
            let (kernel_cpu, worst) = differences(&gpu.data, &cpu.data);
            let share = kernel_cpu as f64 / image.data.len() as f64;
            eprintln!(
                "{name}, {width} x {height} x {channels}: kernel vs twin {kernel_twin} samples differ; \
                 vs the f64 CPU read-out {kernel_cpu} of {} ({:.4}%), at most {worst} DN",
                image.data.len(),
                100.0 * share
            );
            // A draw whose floor or rounding sits within an ulp of a whole number can land on the
            // other side on the device (1.3e-5 of samples on lavapipe, one electron or DN each).
            assert!(
                kernel_twin as f64 <= 1e-4 * image.data.len() as f64,
                "{name}: {kernel_twin} samples left the twin"
            );
            assert!(
                share <= 1e-3,
                "{name}: {kernel_cpu} samples differ from the CPU read-out"
            );
            assert_eq!((gpu.width, gpu.height, gpu.channels), (width, height, channels));
            assert!(gpu
                .data
                .iter()
                .all(|v| v.fract() == 0.0 && (0.0..=1023.0).contains(v)));
        }
    }
    // Bands of rows: a 4.5 MP plane is read out in two dispatches, the second starting mid-image.
    let image = exposure(3000, 1500, 1);
    let gpu = pass.read_out(&image, &SensorNoise::default(), 3).unwrap();
    let (differ, _) = differences(&gpu.data, &twin(&image, &SensorNoise::default(), 3));
    eprintln!("3000 x 1500 in bands: kernel vs twin {differ} samples differ");
    assert!(
        differ as f64 <= 1e-4 * image.data.len() as f64,
        "{differ} samples left the twin"
    );
    let again = pass.read_out(&image, &SensorNoise::default(), 3).unwrap();
    assert_eq!(gpu.data, again.data, "the read-out is deterministic");
}

/// The f32 draws are the CPU's draws on the same streams, except where the f32 rounding moves one:
/// the CPU's draws pass the chi-square tests against the Poisson and normal laws
/// (unicac_io::counter_draws), so agreement on all but a small share keeps the laws within that share.
#[test]
fn the_f32_draws_are_the_cpus_draws_on_the_same_streams() {
    let draws = 100_000u64;
    for mean in [0.05f32, 0.7, 3.0, 9.99, 10.0, 17.3, 250.0, 6000.0, 400_000.0] {
        let seed = derive_seed(91, mean.to_bits().into());
        let (mut differ, mut sum_twin, mut sum_cpu) = (0u64, 0.0f64, 0.0f64);
        for i in 0..draws {
            let stream = derive_seed(seed, i);
            let twin = f64::from(poisson_draw(stream, mean));
            let cpu = CounterStream::new(stream).poisson(f64::from(mean));
            differ += u64::from(twin != cpu);
            sum_twin += twin;
            sum_cpu += cpu;
        }
        let share = differ as f64 / draws as f64;
        eprintln!(
            "Poisson mean {mean}: {differ} of {draws} draws differ; means {:.3} (f32) and {:.3} (f64)",
            sum_twin / draws as f64,
            sum_cpu / draws as f64
        );
        assert!(share <= 2e-3, "mean {mean}: {differ} draws differ");
    }
    let (mut worst, mut worst_share) = (0.0f64, 0.0f64);
    for i in 0..draws {
        let stream = derive_seed(92, i);
        let twin = f64::from(normal_draw(stream));
        let cpu = CounterStream::new(stream).standard_normal();
        // The f32 draw keeps 23 of the hash's 52 bits, so its probability moves by up to 2^-24: its
        // quantile by that over the density there, plus f32's rounding of the rational function.
        let density = (-0.5 * cpu * cpu).exp() / std::f64::consts::TAU.sqrt();
        let allowed = 2f64.powi(-24) / density + 2e-6 * (1.0 + cpu.abs());
        worst = worst.max((twin - cpu).abs());
        worst_share = worst_share.max((twin - cpu).abs() / allowed);
    }
    eprintln!("normal draws: largest |f32 - f64| {worst:.2e}, {worst_share:.2} of the allowance");
    assert!(worst_share <= 1.0, "normal draws: {worst_share} of the allowance");
}

/// The development (black level, white balance, demosaicing) on the device against the CPU chain it
/// replaces: the same correctly rounded f32 operations in the same order, so equal bit for bit on
/// lavapipe (a driver that fuses multiply-adds may differ by rounding).
#[test]
fn the_development_equals_the_cpu_chain() {
    use unicac_image::isp::{
        apply_white_balance_mosaic, demosaic, subtract_black_level, Demosaic, WhiteBalanceGains,
    };
    let Some(context) = gpu_or_skip() else {
        return;
    };
    let lavapipe = context.adapter.name.contains("llvmpipe");
    let pass = GpuImagePass::new(context);
    let sensor = SensorNoise::default();
    let gains = WhiteBalanceGains {
        red: 2.1,
        green: 1.0,
        blue: 1.7,
    };
    for (width, height) in [(640, 480), (97, 61), (1, 1), (2, 5), (5, 2)] {
        let dn = read_out(&exposure(width, height, 1), &sensor, Some(4)).unwrap();
        for method in [Demosaic::Bilinear, Demosaic::MalvarHeCutler] {
            let gpu = pass.develop(&dn, &sensor, gains, method).unwrap();
            let balanced =
                apply_white_balance_mosaic(&subtract_black_level(&dn, &sensor).unwrap(), gains).unwrap();
            let cpu = demosaic(&balanced, method).unwrap();
            let (differ, worst) = differences(&gpu.data, &cpu.data);
            eprintln!("develop {width} x {height} {method:?}: {differ} samples differ, at most {worst:e}");
            if lavapipe {
                assert_eq!(differ, 0, "{width} x {height} {method:?}");
            }
            assert!(worst <= 1e-5, "{width} x {height} {method:?}: {worst}");
        }
    }
    // What the CPU path refuses, the device declines (the CPU path then names the field).
    let bad = WhiteBalanceGains { red: -1.0, ..gains };
    assert!(pass
        .develop(&Planar::new(4, 4, 1), &sensor, bad, Demosaic::Bilinear)
        .is_err());
    assert!(pass
        .develop(&Planar::new(4, 4, 3), &sensor, gains, Demosaic::Bilinear)
        .is_err());
}
