//! The simulator's image pass on the device: `unicac_sim::ImagePass` run by shaders/blur.wgsl (the
//! spatially varying convolution) and shaders/geometry.wgsl (the distortion warp and the shading), one
//! channel at a time, with nothing but the output coming back. The twin is the CPU path itself
//! (`LensSimulator` with the CPU backend): the device reads the CPU's tile layout, so both blend by the
//! same weights and crops, and differ only by f32 summation order (the blur) and by f32 pixel positions
//! (the warp; the CPU's are f64). Limits and parity figures: docs/gpu.md.

use crate::device::{GpuContext, GpuError, GpuResult};
use crate::kernels::{self, pipeline, Kernel, TILE};
use bytemuck::{Pod, Zeroable};
use std::sync::{Arc, Mutex};
use unicac_image::isp::{Demosaic, IspDevice, SensorNoise, WhiteBalanceGains};
use unicac_image::Planar;
use unicac_sim::convolve::Blend;
use unicac_sim::radial_table::{RadialTable, RADIAL_TABLE_STEP_PX};
use unicac_sim::{ImageDevice, ImagePass};

const BLUR: &str = include_str!("../../../shaders/blur.wgsl");
const GEOMETRY: &str = include_str!("../../../shaders/geometry.wgsl");
/// Multiply-adds one blur dispatch may hold (a band of rows): keeps each submission short enough for
/// display drivers' watchdogs (~2 s) on a slow GPU, and the wait between bands bounded.
const DISPATCH_MULTIPLY_ADDS: usize = 1 << 30;

/// `blur.wgsl`'s `BlurParams`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
struct BlurParams {
    width: u32,
    height: u32,
    row_start: u32,
    rows: u32,
    tiles_x: u32,
    kernel_size: u32,
    nodes_x: u32,
    nearest: u32,
    row_tile_at: u32,
    tile_half_at: u32,
    row_t_at: u32,
    flat_at: u32,
    flat_values_at: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

/// `geometry.wgsl`'s `GeometryParams`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable, Default)]
struct GeometryParams {
    width: u32,
    height: u32,
    window_x0: u32,
    window_y0: u32,
    source_width: u32,
    source_height: u32,
    source_x0: u32,
    source_y0: u32,
    centre_x: f32,
    centre_y: f32,
    warp: u32,
    shade: u32,
    warp_samples: u32,
    shade_samples: u32,
    inverse_step: f32,
    _pad: u32,
}

/// The image kernels compiled once on a context.
pub struct GpuImagePass {
    context: Arc<GpuContext>,
    blur: Kernel,
    geometry: Kernel,
    /// The sensor read-out (`crate::sensor`) and the development of the mosaic (`crate::develop`).
    sensor: Kernel,
    develop: Kernel,
    /// Failures since the last `take_notes` (the `ImageDevice` face).
    notes: Mutex<Vec<String>>,
}

impl GpuImagePass {
    pub fn new(context: Arc<GpuContext>) -> GpuImagePass {
        let device = &context.device;
        let blur = pipeline(device, BLUR, "blur", 4);
        let geometry = pipeline(device, GEOMETRY, "geometry", 3);
        let sensor = crate::sensor::kernel(device);
        let develop = crate::develop::kernel(device);
        GpuImagePass {
            context,
            blur,
            geometry,
            sensor,
            develop,
            notes: Mutex::new(Vec::new()),
        }
    }

    pub fn context(&self) -> &Arc<GpuContext> {
        &self.context
    }

    /// `read_out(exposure, sensor, Some(noise_seed))` on the device (`crate::sensor`): the raw DN of
    /// every sample (any channel count), sample i drawing from stream `derive_seed(noise_seed, i)`.
    pub fn read_out(&self, exposure: &Planar, sensor: &SensorNoise, noise_seed: u64) -> GpuResult<Planar> {
        crate::sensor::read_out_on(&self.context, &self.sensor, exposure, sensor, noise_seed)
    }

    /// `demosaic(apply_white_balance_mosaic(subtract_black_level(dn, sensor), gains), method)` on the
    /// device (`crate::develop`).
    pub fn develop(
        &self,
        dn: &Planar,
        sensor: &SensorNoise,
        gains: WhiteBalanceGains,
        method: Demosaic,
    ) -> GpuResult<Planar> {
        crate::develop::develop_on(&self.context, &self.develop, dn, sensor, gains, method)
    }

    /// A device result, or None with the failure kept as a note (the `ImageDevice` faces).
    fn noted(&self, work: &str, result: GpuResult<Planar>) -> Option<Planar> {
        match result {
            Ok(out) => Some(out),
            Err(error) => {
                let mut notes = self.notes.lock().unwrap_or_else(|e| e.into_inner());
                notes.push(format!("GPU {work} failed ({error}); the CPU path ran"));
                None
            }
        }
    }

    /// The pass's output (`window`'s size, 3 channels), as `LensSimulator` computes it on the CPU.
    pub fn apply(&self, pass: &ImagePass) -> GpuResult<Planar> {
        self.check(pass)?;
        let (source, window) = (pass.source, pass.window);
        let mut out = Planar::new(window.width, window.height, 3);
        let pixels = window.width * window.height;
        // A pass whose geometry is the identity on the whole region (the blur alone) reads the blur back
        // as it is: the geometry kernel would copy it sample for sample.
        let identity = pass.warp_scale.is_none() && pass.shading.is_none() && source == window;
        let tables = self.tables(pass);
        let geometry = kernels::uniform_buffer(
            &self.context,
            &GeometryParams {
                width: window.width as u32,
                height: window.height as u32,
                window_x0: window.x0 as u32,
                window_y0: window.y0 as u32,
                source_width: source.width as u32,
                source_height: source.height as u32,
                source_x0: source.x0 as u32,
                source_y0: source.y0 as u32,
                centre_x: pass.centre_px[0] as f32,
                centre_y: pass.centre_px[1] as f32,
                warp: u32::from(pass.warp_scale.is_some()),
                shade: u32::from(pass.shading.is_some()),
                warp_samples: pass.warp_scale.map_or(0, |t| t.samples().len() as u32),
                shade_samples: pass.shading.map_or(0, |t| t.samples().len() as u32),
                inverse_step: (1.0 / RADIAL_TABLE_STEP_PX) as f32,
                _pad: 0,
            },
        );
        for c in 0..3 {
            let blurred = if pass.blur {
                self.blur_plane(pass.image.plane(c), pass, c)?
            } else {
                kernels::input_buffer(&self.context, bytemuck::cast_slice(pass.image.plane(c)))
            };
            let result = if identity {
                blurred
            } else {
                let warped = kernels::storage_buffer(&self.context, pixels);
                let buffers = [&geometry, &blurred, &tables[0], &tables[1], &warped];
                kernels::run_kernel(
                    &self.context,
                    &self.geometry,
                    &buffers,
                    [window.width, window.height],
                );
                warped
            };
            out.plane_mut(c)
                .copy_from_slice(&kernels::read_back(&self.context, &result, pixels)?);
        }
        Ok(out)
    }

    /// Refuses, before any work, what the device cannot hold or the pass does not describe.
    fn check(&self, pass: &ImagePass) -> GpuResult<()> {
        let (source, window) = (pass.source, pass.window);
        let image = pass.image;
        if (image.width, image.height, image.channels) != (source.width, source.height, 3) {
            return Err(GpuError::Unsupported(format!(
                "an image of {} x {} x {} for a {} x {} RGB region",
                image.width, image.height, image.channels, source.width, source.height
            )));
        }
        let limits = &self.context.limits;
        let binding = limits.max_storage_buffer_binding_size as usize;
        let workgroups = limits.max_compute_workgroups_per_dimension as usize;
        let largest_plane = (source.width * source.height).max(window.width * window.height);
        if 4 * largest_plane > binding {
            return Err(GpuError::Unsupported(format!(
                "a {} x {} frame (planes above the device's {} MiB storage binding)",
                source.width,
                source.height,
                binding >> 20
            )));
        }
        if source.width.max(window.width).div_ceil(TILE as usize) > workgroups
            || window.height.div_ceil(TILE as usize) > workgroups
        {
            return Err(GpuError::Unsupported(format!(
                "a {} x {} frame (more workgroups per dimension than the device's {workgroups})",
                source.width, source.height
            )));
        }
        for (grid, layout) in pass.grids.iter().zip(pass.layouts) {
            let kernel = grid.kernels()[0].size;
            if 4 * grid.kernels().len() * kernel * kernel > binding {
                return Err(GpuError::Unsupported(format!(
                    "{} node kernels of {kernel} px (above the device's {} MiB storage binding)",
                    grid.kernels().len(),
                    binding >> 20
                )));
            }
            if (layout.column_tile.len(), layout.row_tile.len()) != (source.width, source.height)
                || layout.tiles != [grid.nodes()[0] - 1, grid.nodes()[1] - 1]
            {
                return Err(GpuError::Unsupported(
                    "a tile layout made for another region or grid".into(),
                ));
            }
        }
        Ok(())
    }

    /// The warp table as scale - 1 (`geometry.wgsl` adds the small offset to the exact pixel index) and
    /// the shading table, in f32 (a one-sample stand-in where one is off: bindings are never empty).
    fn tables(&self, pass: &ImagePass) -> [wgpu::Buffer; 2] {
        let f32_samples = |table: Option<&RadialTable>, minus: f64| -> Vec<f32> {
            table.map_or(vec![0.0], |t| {
                t.samples().iter().map(|&v| (v - minus) as f32).collect()
            })
        };
        [f32_samples(pass.warp_scale, 1.0), f32_samples(pass.shading, 0.0)]
            .map(|values| kernels::input_buffer(&self.context, bytemuck::cast_slice(&values)))
    }

    /// One channel's blur into a device buffer, in bands of rows.
    fn blur_plane(&self, plane: &[f32], pass: &ImagePass, channel: usize) -> GpuResult<wgpu::Buffer> {
        let (grid, layout) = (pass.grids[channel], pass.layouts[channel]);
        let (width, height) = (pass.source.width, pass.source.height);
        let kernel_size = grid.kernels()[0].size;
        let kernels: Vec<f32> = grid
            .kernels()
            .iter()
            .flat_map(|k| k.data.iter().copied())
            .collect();
        let flat = layout.flat_tiles(plane, grid);
        let mut words = layout.column_tile.clone();
        words.extend(&layout.row_tile);
        words.extend(&layout.tile_half_px);
        let flat_at = words.len();
        words.extend(flat.iter().map(|f| u32::from(f.is_some())));
        let mut positions = layout.column_t.clone();
        positions.extend(&layout.row_t);
        let flat_values_at = positions.len();
        positions.extend(flat.iter().flat_map(|f| f.unwrap_or_default()));
        let inputs = [
            kernels::input_buffer(&self.context, bytemuck::cast_slice(plane)),
            kernels::input_buffer(&self.context, bytemuck::cast_slice(&kernels)),
            kernels::input_buffer(&self.context, bytemuck::cast_slice(&words)),
            kernels::input_buffer(&self.context, bytemuck::cast_slice(&positions)),
        ];
        let blurred = kernels::storage_buffer(&self.context, width * height);
        let largest = 2 * layout.tile_half_px.iter().copied().max().unwrap_or(0) as usize + 1;
        let per_row = (4 * largest * largest * width).max(1);
        let band = (DISPATCH_MULTIPLY_ADDS / per_row).clamp(1, height);
        for row_start in (0..height).step_by(band) {
            let params = BlurParams {
                width: width as u32,
                height: height as u32,
                row_start: row_start as u32,
                rows: band.min(height - row_start) as u32,
                tiles_x: layout.tiles[0] as u32,
                kernel_size: kernel_size as u32,
                nodes_x: grid.nodes()[0] as u32,
                nearest: u32::from(pass.blend == Blend::Nearest),
                row_tile_at: width as u32,
                tile_half_at: (width + height) as u32,
                row_t_at: width as u32,
                flat_at: flat_at as u32,
                flat_values_at: flat_values_at as u32,
                _pad0: 0,
                _pad1: 0,
                _pad2: 0,
            };
            let uniform = kernels::uniform_buffer(&self.context, &params);
            let buffers = [&uniform, &inputs[0], &inputs[1], &inputs[2], &inputs[3], &blurred];
            kernels::run_kernel(&self.context, &self.blur, &buffers, [width, params.rows as usize]);
        }
        Ok(blurred)
    }
}

/// The pass as an image device that always takes the pass: for a caller that chose this device
/// (tests, examples, benchmarks). A failure is kept as a note and leaves the pass to the CPU path.
impl ImageDevice for GpuImagePass {
    fn apply(&self, pass: &ImagePass) -> Option<Planar> {
        self.noted("image pass", GpuImagePass::apply(self, pass))
    }

    fn describe(&self) -> String {
        format!("gpu (f32, {})", self.context.adapter.name)
    }

    fn take_notes(&self) -> Vec<String> {
        std::mem::take(&mut self.notes.lock().unwrap_or_else(|e| e.into_inner()))
    }
}

impl IspDevice for GpuImagePass {
    fn read_out(&self, exposure: &Planar, sensor: &SensorNoise, noise_seed: u64) -> Option<Planar> {
        self.noted(
            "read-out",
            GpuImagePass::read_out(self, exposure, sensor, noise_seed),
        )
    }

    fn develop(
        &self,
        dn: &Planar,
        sensor: &SensorNoise,
        gains: WhiteBalanceGains,
        method: Demosaic,
    ) -> Option<Planar> {
        self.noted(
            "development",
            GpuImagePass::develop(self, dn, sensor, gains, method),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_kernels_validate_with_naga_without_extra_capabilities() {
        for (name, text) in [("blur.wgsl", BLUR), ("geometry.wgsl", GEOMETRY)] {
            let module = naga::front::wgsl::parse_str(text)
                .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(text)));
            naga::valid::Validator::new(
                naga::valid::ValidationFlags::all(),
                naga::valid::Capabilities::empty(),
            )
            .validate(&module)
            .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(text)));
        }
    }

    #[test]
    fn parameter_blocks_are_the_shaders_sizes() {
        // 16 four-byte fields each, as declared in the WGSL structs (uniforms: multiples of 16 bytes).
        assert_eq!(size_of::<BlurParams>(), 64);
        assert_eq!(size_of::<GeometryParams>(), 64);
        assert!(BLUR.contains("flat_values_at: u32,\n    _pad0: u32,\n    _pad1: u32,\n    _pad2: u32,\n}"));
        assert!(GEOMETRY.contains("inverse_step: f32,\n    _pad: u32,"));
    }
}
