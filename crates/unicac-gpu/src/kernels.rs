//! Running the standalone f32 image kernels (blur, geometry, read-out, development): a pipeline whose
//! bindings are one uniform, read-only inputs and one output; buffers; a dispatch over 8 x 8
//! workgroups; the read-back. Shared by `image`, `sensor` and `develop`.

use crate::device::{GpuContext, GpuResult};
use bytemuck::Pod;
use wgpu::util::DeviceExt;

/// Invocations per workgroup side (`@workgroup_size(8, 8)` in the image kernels).
pub(crate) const TILE: u32 = 8;
/// Largest staging buffer of a read-back (a 12 MP plane comes back in 3 pieces).
const READ_BACK_BYTES: u64 = 16 << 20;

/// A kernel's bind group layout and pipeline.
pub(crate) type Kernel = (wgpu::BindGroupLayout, wgpu::ComputePipeline);

fn entry(binding: u32, ty: wgpu::BufferBindingType) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

/// A pipeline of `source`'s `entry_point` whose bindings are a uniform (0), `inputs` read-only storage
/// buffers and one read-write storage buffer after them.
pub(crate) fn pipeline(device: &wgpu::Device, source: &str, entry_point: &str, inputs: u32) -> Kernel {
    let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(entry_point),
        source: wgpu::ShaderSource::Wgsl(source.into()),
    });
    let mut entries = vec![entry(0, wgpu::BufferBindingType::Uniform)];
    entries.extend((1..=inputs).map(|b| entry(b, wgpu::BufferBindingType::Storage { read_only: true })));
    entries.push(entry(
        inputs + 1,
        wgpu::BufferBindingType::Storage { read_only: false },
    ));
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some(entry_point),
        entries: &entries,
    });
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(entry_point),
        bind_group_layouts: &[Some(&layout)],
        immediate_size: 0,
    });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(entry_point),
        layout: Some(&pipeline_layout),
        module: &module,
        entry_point: Some(entry_point),
        compilation_options: Default::default(),
        cache: None,
    });
    (layout, pipeline)
}

pub(crate) fn input_buffer(context: &GpuContext, bytes: &[u8]) -> wgpu::Buffer {
    context
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytes,
            usage: wgpu::BufferUsages::STORAGE,
        })
}

pub(crate) fn uniform_buffer<T: Pod>(context: &GpuContext, params: &T) -> wgpu::Buffer {
    context
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: None,
            contents: bytemuck::bytes_of(params),
            usage: wgpu::BufferUsages::UNIFORM,
        })
}

/// A read-write plane of `pixels` f32 samples.
pub(crate) fn storage_buffer(context: &GpuContext, pixels: usize) -> wgpu::Buffer {
    context.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: (pixels.max(1) * 4) as u64,
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

/// One dispatch of `kernel` over `size` (columns, rows) pixels with `buffers` bound in order.
pub(crate) fn run_kernel(context: &GpuContext, kernel: &Kernel, buffers: &[&wgpu::Buffer], size: [usize; 2]) {
    let device = &context.device;
    let entries: Vec<wgpu::BindGroupEntry> = buffers
        .iter()
        .enumerate()
        .map(|(i, buffer)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: buffer.as_entire_binding(),
        })
        .collect();
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: None,
        layout: &kernel.0,
        entries: &entries,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = encoder.begin_compute_pass(&Default::default());
        pass.set_pipeline(&kernel.1);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups(
            size[0].div_ceil(TILE as usize) as u32,
            size[1].div_ceil(TILE as usize) as u32,
            1,
        );
    }
    context.queue.submit([encoder.finish()]);
}

/// The first `pixels` samples of `buffer`, waiting for the work before.
pub(crate) fn read_back(context: &GpuContext, buffer: &wgpu::Buffer, pixels: usize) -> GpuResult<Vec<f32>> {
    let bytes = (pixels * 4) as u64;
    let staging = context.device.create_buffer(&wgpu::BufferDescriptor {
        label: None,
        size: bytes.clamp(4, READ_BACK_BYTES),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    let samples = context.read_through(buffer, bytes, &staging)?;
    Ok(bytemuck::pod_collect_to_vec(&samples))
}
