//! The development of a raw mosaic on the device (`unicac_image::isp::IspDevice::develop`):
//! shaders/develop.wgsl, black level, white balance and demosaicing in one pass per output channel. The
//! kernel repeats the CPU's correctly rounded f32 operations in the CPU's order, so the CPU path is its
//! twin (bit for bit on lavapipe; `--test sensor`).

use crate::device::{GpuContext, GpuError, GpuResult};
use crate::kernels::{self, Kernel};
use bytemuck::{Pod, Zeroable};
use unicac_image::isp::{demosaic_taps, Demosaic, SensorNoise, WhiteBalanceGains};
use unicac_image::Planar;

pub(crate) const DEVELOP: &str = include_str!("../../../shaders/develop.wgsl");

/// Words before the taps in `tap_words` (TAP_TABLE_WORDS in the shader): (first, count) per site and
/// channel.
const TAP_TABLE_WORDS: usize = 24;

/// `develop.wgsl`'s `DevelopParams`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
struct DevelopParams {
    width: u32,
    height: u32,
    channel: u32,
    _pad0: u32,
    black_dn: f32,
    range_dn: f32,
    gain_red: f32,
    gain_green: f32,
    gain_blue: f32,
    _pad1: u32,
    _pad2: u32,
    _pad3: u32,
}

/// The filter bank as the shader's tables: (first, count) per site and channel, then j * 5 + i per
/// tap; the weights alongside.
fn tap_tables(method: Demosaic) -> (Vec<u32>, Vec<f32>) {
    let mut words = vec![0u32; TAP_TABLE_WORDS];
    let mut weights = Vec::new();
    for (site, channels) in demosaic_taps(method).iter().enumerate() {
        for (channel, taps) in channels.iter().enumerate() {
            let entry = 2 * (site * 3 + channel);
            words[entry] = words.len() as u32;
            for &(j, i, weight) in taps.iter().flatten() {
                words.push((j * 5 + i) as u32);
                weights.push(weight);
            }
            words[entry + 1] = (words.len() as u32) - words[entry];
        }
    }
    (words, weights)
}

/// The development kernel of a device.
pub(crate) fn kernel(device: &wgpu::Device) -> Kernel {
    kernels::pipeline(device, DEVELOP, "develop", 3)
}

/// The development by `kernel` (`GpuImagePass::develop`). Declines (the CPU path then reports it) an
/// invalid sensor or gains, a mosaic that is not one channel or is empty, and planes beyond the
/// device's limits.
pub(crate) fn develop_on(
    context: &GpuContext,
    kernel: &Kernel,
    dn: &Planar,
    sensor: &SensorNoise,
    gains: WhiteBalanceGains,
    method: Demosaic,
) -> GpuResult<Planar> {
    let unsupported = |why: &str| Err(GpuError::Unsupported(why.into()));
    let (Ok(white), Ok(_), Ok(gains)) = (sensor.white_level_dn(), sensor.validate(), gains.validate()) else {
        return unsupported("an invalid sensor or white balance");
    };
    let (width, height) = (dn.width, dn.height);
    if dn.channels != 1 || width == 0 || height == 0 {
        return unsupported("a mosaic that is not one non-empty channel");
    }
    let limits = &context.limits;
    if 4 * width * height > limits.max_storage_buffer_binding_size as usize
        || width.max(height).div_ceil(kernels::TILE as usize)
            > limits.max_compute_workgroups_per_dimension as usize
    {
        return Err(GpuError::Unsupported(format!("a {width} x {height} mosaic")));
    }
    let (words, weights) = tap_tables(method);
    let inputs = [
        kernels::input_buffer(context, bytemuck::cast_slice(&dn.data)),
        kernels::input_buffer(context, bytemuck::cast_slice(&words)),
        kernels::input_buffer(context, bytemuck::cast_slice(&weights)),
    ];
    let mut rgb = Planar::new(width, height, 3);
    for channel in 0..3 {
        let params = DevelopParams {
            width: width as u32,
            height: height as u32,
            channel: channel as u32,
            black_dn: sensor.black_level_dn,
            range_dn: white - sensor.black_level_dn,
            gain_red: gains.red,
            gain_green: gains.green,
            gain_blue: gains.blue,
            ..Default::default()
        };
        let uniform = kernels::uniform_buffer(context, &params);
        let output = kernels::storage_buffer(context, width * height);
        let buffers = [&uniform, &inputs[0], &inputs[1], &inputs[2], &output];
        kernels::run_kernel(context, kernel, &buffers, [width, height]);
        rgb.plane_mut(channel)
            .copy_from_slice(&kernels::read_back(context, &output, width * height)?);
    }
    Ok(rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_develop_kernel_validates_with_naga_and_its_tables_cover_the_bank() {
        let module =
            naga::front::wgsl::parse_str(DEVELOP).unwrap_or_else(|e| panic!("{}", e.emit_to_string(DEVELOP)));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::empty(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{}", e.emit_to_string(DEVELOP)));
        assert_eq!(size_of::<DevelopParams>(), 48);
        assert!(DEVELOP.contains(&format!("const TAP_TABLE_WORDS: u32 = {TAP_TABLE_WORDS}u;")));
        let (words, weights) = tap_tables(Demosaic::MalvarHeCutler);
        assert_eq!(words.len(), TAP_TABLE_WORDS + weights.len());
        // Each site keeps its own colour (no taps) and interpolates the other two.
        let own: usize = (0..12).filter(|e| words[2 * e + 1] == 0).count();
        assert_eq!(own, 4);
    }
}
