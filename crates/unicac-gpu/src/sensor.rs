//! The sensor read-out (`unicac_image::isp::read_out` with noise) on the device: shaders/sensor.wgsl,
//! one invocation per sample in bands of rows, each sample drawing from its own counter stream as the
//! CPU does. The kernel works in f32 where the CPU reference works in f64, so a draw that sits at a
//! rounding boundary can come out one electron or one DN apart; the parity figures are in docs/gpu.md,
//! the twin (`sensor_twin`) is the kernel's arithmetic on the host.

use crate::device::{GpuContext, GpuError, GpuResult};
use crate::kernels::{self, Kernel};
use crate::sensor_twin::SensorConstants;
use bytemuck::{Pod, Zeroable};
use unicac_image::isp::SensorNoise;
use unicac_image::Planar;

pub(crate) const SENSOR: &str = include_str!("../../../shaders/sensor.wgsl");

/// The kernel module: counter.wgsl's integer helpers, then the read-out.
pub(crate) fn module_source() -> String {
    [crate::shader::COUNTER, SENSOR].join("\n")
}

/// Largest mean photo-electron count (at the brightest sample) the f32 kernel takes: its whole
/// numbers stay exact and its draws keep the CPU's law well below 2^24. Sensors beyond it (the
/// default reads ~6,000 electrons at white) read out on the CPU.
pub const MAX_DEVICE_ELECTRONS: f64 = (1u64 << 22) as f64;

/// Samples per dispatch (a band of whole rows): keeps submissions short on slow devices.
const BAND_SAMPLES: usize = 1 << 22;

/// `sensor.wgsl`'s `SensorParams`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
struct SensorParams {
    seed_lo: u32,
    seed_hi: u32,
    width: u32,
    rows: u32,
    first: u32,
    range_dn: f32,
    black_dn: f32,
    white_dn: f32,
    dn_per_electron: f32,
    read_noise_dn: f32,
    _pad0: u32,
    _pad1: u32,
}

/// The read-out's constants as the kernel takes them, formed in f64 like the CPU's, or why the device
/// declines the job: an invalid sensor (the CPU path names the field), more samples than 32-bit
/// indices reach, a NaN sample (the CPU path refuses it), an infinite one, or a mean above
/// [`MAX_DEVICE_ELECTRONS`].
pub fn sensor_constants(
    exposure: &Planar,
    sensor: &SensorNoise,
    noise_seed: u64,
) -> GpuResult<SensorConstants> {
    let unsupported = |why: String| Err(GpuError::Unsupported(why));
    if sensor.validate().is_err() {
        return unsupported("an invalid sensor".into());
    }
    if exposure.data.len() > u32::MAX as usize {
        return unsupported(format!("{} samples (above 2^32)", exposure.data.len()));
    }
    let brightest = exposure
        .data
        .iter()
        .fold(0.0f32, |m, &v| if v > m || v.is_nan() { v } else { m });
    if !brightest.is_finite() {
        return unsupported(format!("a sample of {brightest}"));
    }
    let white = f64::from(
        sensor
            .white_level_dn()
            .map_err(|e| GpuError::Unsupported(e.to_string()))?,
    );
    let black = f64::from(sensor.black_level_dn);
    let dn_per_electron = f64::from(sensor.dn_per_electron());
    let range = white - black;
    let electrons = f64::from(brightest) * range / dn_per_electron;
    if electrons > MAX_DEVICE_ELECTRONS {
        return unsupported(format!(
            "a sensor reading {electrons:.3e} photo-electrons (above {MAX_DEVICE_ELECTRONS:e} in f32)"
        ));
    }
    Ok(SensorConstants {
        noise_seed,
        range_dn: range as f32,
        black_dn: black as f32,
        white_dn: white as f32,
        dn_per_electron: dn_per_electron as f32,
        read_noise_dn: sensor.read_noise_dn(),
    })
}

/// The read-out kernel of a device.
pub(crate) fn kernel(device: &wgpu::Device) -> Kernel {
    kernels::pipeline(device, &module_source(), "read_out", 1)
}

/// `read_out(exposure, sensor, Some(noise_seed))` by `kernel` (`GpuImagePass::read_out`).
pub(crate) fn read_out_on(
    context: &GpuContext,
    kernel: &Kernel,
    exposure: &Planar,
    sensor: &SensorNoise,
    noise_seed: u64,
) -> GpuResult<Planar> {
    let constants = sensor_constants(exposure, sensor, noise_seed)?;
    let width = exposure.width.max(1);
    let rows = exposure.data.len() / width;
    if width.div_ceil(kernels::TILE as usize) > context.limits.max_compute_workgroups_per_dimension as usize {
        return Err(GpuError::Unsupported(format!("a {width} px wide image")));
    }
    let band_rows = (BAND_SAMPLES / width).max(1);
    let mut out = exposure.clone();
    for first_row in (0..rows).step_by(band_rows) {
        let band = band_rows.min(rows - first_row);
        let samples = &exposure.data[first_row * width..(first_row + band) * width];
        let params = SensorParams {
            seed_lo: noise_seed as u32,
            seed_hi: (noise_seed >> 32) as u32,
            width: width as u32,
            rows: band as u32,
            first: (first_row * width) as u32,
            range_dn: constants.range_dn,
            black_dn: constants.black_dn,
            white_dn: constants.white_dn,
            dn_per_electron: constants.dn_per_electron,
            read_noise_dn: constants.read_noise_dn,
            _pad0: 0,
            _pad1: 0,
        };
        let uniform = kernels::uniform_buffer(context, &params);
        let input = kernels::input_buffer(context, bytemuck::cast_slice(samples));
        let output = kernels::storage_buffer(context, samples.len());
        kernels::run_kernel(context, kernel, &[&uniform, &input, &output], [width, band]);
        out.data[first_row * width..(first_row + band) * width].copy_from_slice(&kernels::read_back(
            context,
            &output,
            samples.len(),
        )?);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_sensor_kernel_validates_with_naga_and_its_parameters_match() {
        let text = module_source();
        let module =
            naga::front::wgsl::parse_str(&text).unwrap_or_else(|e| panic!("{}", e.emit_to_string(&text)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&text)));
        assert_eq!(size_of::<SensorParams>(), 48);
        assert!(SENSOR.contains("read_noise_dn: f32,\n    _pad0: u32,\n    _pad1: u32,\n}"));
    }

    #[test]
    fn the_device_declines_what_f32_cannot_draw_faithfully() {
        let sensor = SensorNoise::default();
        let mut exposure = Planar::new(4, 4, 1);
        exposure.data.fill(0.5);
        assert!(sensor_constants(&exposure, &sensor, 1).is_ok());
        for bad in [f32::NAN, f32::INFINITY, 1e6] {
            exposure.data[5] = bad;
            assert!(
                matches!(
                    sensor_constants(&exposure, &sensor, 1),
                    Err(GpuError::Unsupported(_))
                ),
                "{bad}"
            );
        }
    }
}
