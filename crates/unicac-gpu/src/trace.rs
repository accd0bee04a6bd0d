//! `GpuTracer`: the kernels of one precision compiled once on a `GpuContext`, with buffers allocated
//! once and reused. Any number of rays is streamed through in chunks (`chunk_rays`, by default 2^20):
//! device memory stays bounded by one chunk however many rays a job holds.

use crate::device::{GpuContext, GpuError, GpuResult};
use crate::layout::{self, decode_status, kind, GpuRay, Params, Surface};
use crate::real::{Precision, Real};
use crate::shader;
use crate::source::RaySource;
use crate::twin;
use std::sync::{Arc, Mutex};
use unicac_trace::{Ray, RayStatus, StatusCounts, TraceSystem};

/// Default rays per chunk: 24 MiB of f32 rays, 48 MiB of f64 rays (lavapipe binds up to 128 MiB), and
/// 16384 workgroups (the limit per dimension is 65535).
pub const DEFAULT_CHUNK_RAYS: usize = 1 << 20;
/// Most surfaces a lens may have on the GPU path.
pub const MAX_SURFACES: usize = 256;

/// Rays after a trace, in global coordinates; pattern slots that are not rays (grid cells outside the
/// disc) are dropped. `rays` is empty for `GpuTracer::count`.
#[derive(Debug, Clone, Default)]
pub struct Traced {
    pub rays: Vec<Ray>,
    pub statuses: Vec<RayStatus>,
    pub counts: StatusCounts,
    /// Rays whose pass/fail decision fell within the kernel's guard band and were re-traced in f64 on
    /// the CPU (their statuses and rays are the CPU's).
    pub resolved_on_cpu: usize,
}

pub(crate) struct Buffers {
    pub params: wgpu::Buffer,
    pub surfaces: wgpu::Buffer,
    pub rays: wgpu::Buffer,
    pub statuses: wgpu::Buffer,
    pub grid: wgpu::Buffer,
    pub counters: wgpu::Buffer,
    pub readback: wgpu::Buffer,
    pub bind_group: wgpu::BindGroup,
}

/// Pipelines and buffers of one precision on one device.
pub struct GpuTracer {
    pub(crate) context: Arc<GpuContext>,
    precision: Precision,
    layout: wgpu::BindGroupLayout,
    trace_pipeline: wgpu::ComputePipeline,
    psf_pipeline: wgpu::ComputePipeline,
    pub(crate) buffers: Mutex<Buffers>,
    chunk_rays: usize,
}

fn storage_entry(binding: u32, read_only: bool) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty: wgpu::BufferBindingType::Storage { read_only },
            has_dynamic_offset: false,
            min_binding_size: None,
        },
        count: None,
    }
}

impl GpuTracer {
    pub fn new(context: Arc<GpuContext>, precision: Precision) -> GpuResult<GpuTracer> {
        GpuTracer::with_chunk_rays(context, precision, DEFAULT_CHUNK_RAYS)
    }

    /// As `new`, streaming at most `chunk_rays` rays per dispatch.
    pub fn with_chunk_rays(
        context: Arc<GpuContext>,
        precision: Precision,
        chunk_rays: usize,
    ) -> GpuResult<GpuTracer> {
        if !context.supports(precision) {
            return Err(GpuError::F64Unsupported {
                adapter: context.adapter.name.clone(),
            });
        }
        let ray_bytes = ray_size(precision);
        let max_chunk = (context.limits.max_storage_buffer_binding_size as usize / ray_bytes)
            .min(context.limits.max_compute_workgroups_per_dimension as usize * shader::WORKGROUP as usize);
        let chunk_rays = chunk_rays.clamp(shader::WORKGROUP as usize, max_chunk);
        let device = &context.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("unicac kernels"),
            source: wgpu::ShaderSource::Wgsl(shader::source(precision).into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("unicac bindings"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, true),
                storage_entry(2, false),
                storage_entry(3, false),
                storage_entry(4, false),
                storage_entry(5, false),
            ],
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("unicac pipeline layout"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let trace_pipeline = pipeline(shader::TRACE_ENTRY);
        let psf_pipeline = pipeline(shader::PSF_ENTRY);
        let buffers = Buffers::new(device, &layout, precision, chunk_rays, 8);
        Ok(GpuTracer {
            context,
            precision,
            layout,
            trace_pipeline,
            psf_pipeline,
            buffers: Mutex::new(buffers),
            chunk_rays,
        })
    }

    pub fn precision(&self) -> Precision {
        self.precision
    }

    pub fn context(&self) -> &Arc<GpuContext> {
        &self.context
    }

    pub fn chunk_rays(&self) -> usize {
        self.chunk_rays
    }

    /// Traces every ray of `source` through `system` to the image surface.
    pub fn trace(&self, system: &TraceSystem, source: &RaySource) -> GpuResult<Traced> {
        match self.precision {
            Precision::F32 => self.run::<f32>(system, source, true),
            Precision::F64 => self.run::<f64>(system, source, true),
        }
    }

    /// Status counts only: 4 bytes per ray come back, no rays (for huge ray counts).
    pub fn count(&self, system: &TraceSystem, source: &RaySource) -> GpuResult<Traced> {
        match self.precision {
            Precision::F32 => self.run::<f32>(system, source, false),
            Precision::F64 => self.run::<f64>(system, source, false),
        }
    }

    fn run<R: Real>(&self, system: &TraceSystem, source: &RaySource, read_rays: bool) -> GpuResult<Traced> {
        layout::check_supported(system)?;
        let surfaces = layout::surfaces::<R>(system);
        let slots = source.slots()? as usize;
        let mut buffers = self.buffers.lock().unwrap_or_else(|e| e.into_inner());
        self.begin(&mut buffers, &surfaces, 0)?;
        let mut traced = Traced::default();
        for first in (0..slots).step_by(self.chunk_rays) {
            let count = self.chunk_rays.min(slots - first);
            let params = self.chunk_params::<R>(source, &buffers, surfaces.len(), first, count);
            self.dispatch(&buffers, &self.trace_pipeline, &params, count);
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(&self.read_back(
                &buffers,
                &buffers.statuses,
                (count * 4) as u64,
            )?);
            let rays: Vec<GpuRay<R>> = if read_rays {
                let bytes = (count * size_of::<GpuRay<R>>()) as u64;
                bytemuck::pod_collect_to_vec(&self.read_back(&buffers, &buffers.rays, bytes)?)
            } else {
                Vec::new()
            };
            for (i, word) in words.iter().enumerate() {
                let Some(mut status) = decode_status(*word) else {
                    continue;
                };
                let mut ray = rays.get(i).map(|r| to_global(system, r, status));
                if word & kind::UNDECIDED != 0 {
                    let mut reference = source_ray_f64(source, first + i);
                    status = system.trace(&mut reference);
                    ray = ray.map(|_| reference);
                    traced.resolved_on_cpu += 1;
                }
                traced.counts.add(status);
                if let Some(ray) = ray {
                    traced.rays.push(ray);
                    traced.statuses.push(status);
                }
            }
        }
        Ok(traced)
    }

    /// Grows the grid if needed and clears grid and counters; uploads the surfaces.
    pub(crate) fn begin<R: Real>(
        &self,
        buffers: &mut Buffers,
        surfaces: &[Surface<R>],
        grid_words: usize,
    ) -> GpuResult<()> {
        if surfaces.is_empty() || surfaces.len() > MAX_SURFACES {
            return Err(GpuError::Unsupported(format!(
                "{} surfaces: the GPU path takes 1 to {MAX_SURFACES}",
                surfaces.len()
            )));
        }
        let grid_bytes = (grid_words.max(2) * 4) as u64;
        if grid_bytes > self.context.limits.max_storage_buffer_binding_size {
            return Err(GpuError::Unsupported(format!(
                "a PSF grid of {grid_bytes} bytes exceeds the device's storage binding limit"
            )));
        }
        if buffers.grid.size() < grid_bytes {
            *buffers = Buffers::new(
                &self.context.device,
                &self.layout,
                self.precision,
                self.chunk_rays,
                grid_bytes,
            );
        }
        let queue = &self.context.queue;
        queue.write_buffer(&buffers.surfaces, 0, bytemuck::cast_slice(surfaces));
        let mut encoder = self.context.device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&buffers.grid, 0, Some(grid_bytes));
        encoder.clear_buffer(&buffers.counters, 0, None);
        queue.submit([encoder.finish()]);
        Ok(())
    }

    /// Parameters of one chunk; uploads host rays.
    pub(crate) fn chunk_params<R: Real>(
        &self,
        source: &RaySource,
        buffers: &Buffers,
        surface_count: usize,
        first: usize,
        count: usize,
    ) -> Params<R> {
        let mut params = Params::<R> {
            surface_count: surface_count as u32,
            ray_count: count as u32,
            first_index: first as u32,
            ..Default::default()
        };
        match source {
            RaySource::Host(rays) => {
                let chunk: Vec<GpuRay<R>> = rays[first..first + count].iter().map(to_gpu).collect();
                self.context
                    .queue
                    .write_buffer(&buffers.rays, 0, bytemuck::cast_slice(&chunk));
            }
            RaySource::Pupil(pupil) => pupil.fill(&mut params),
        }
        params
    }

    /// Runs one chunk through `pipeline` and waits for it.
    pub(crate) fn dispatch<R: Real>(
        &self,
        buffers: &Buffers,
        pipeline: &wgpu::ComputePipeline,
        params: &Params<R>,
        count: usize,
    ) {
        let context = &self.context;
        context
            .queue
            .write_buffer(&buffers.params, 0, bytemuck::bytes_of(params));
        let mut encoder = context.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, &buffers.bind_group, &[]);
            pass.dispatch_workgroups(count.div_ceil(shader::WORKGROUP as usize) as u32, 1, 1);
        }
        context.queue.submit([encoder.finish()]);
    }

    pub(crate) fn psf_pipeline(&self) -> &wgpu::ComputePipeline {
        &self.psf_pipeline
    }

    /// Copies `bytes` of `from` into the readback buffer and maps them.
    fn read_back(&self, buffers: &Buffers, from: &wgpu::Buffer, bytes: u64) -> GpuResult<Vec<u8>> {
        self.context.read_through(from, bytes, &buffers.readback)
    }

    pub(crate) fn read_counters(&self, buffers: &Buffers) -> GpuResult<StatusCounts> {
        let bytes = self.read_back(buffers, &buffers.counters, (kind::COUNTERS * 4) as u64)?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(counts_from_histogram(&words))
    }

    pub(crate) fn read_grid(&self, buffers: &Buffers, words: usize) -> GpuResult<Vec<u64>> {
        let bytes = self.read_back(buffers, &buffers.grid, (words * 4) as u64)?;
        let pairs: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(pairs
            .chunks_exact(2)
            .map(|p| p[0] as u64 | ((p[1] as u64) << 32))
            .collect())
    }
}

/// The ray of slot `index` in f64 (for re-tracing undecided rays on the CPU): the host's ray, or the
/// device's sampling and aiming evaluated by their f64 twins.
fn source_ray_f64(source: &RaySource, index: usize) -> Ray {
    match source {
        RaySource::Host(rays) => rays[index],
        RaySource::Pupil(pupil) => {
            let mut params = Params::<f64>::default();
            pupil.fill(&mut params);
            let [px, py, _] = twin::pupil_point(&params, index as u32);
            let g = twin::aimed_ray(&params, px, py);
            Ray {
                position_mm: [g.x, g.y, g.z],
                direction: [g.l, g.m, g.n],
            }
        }
    }
}

fn ray_size(precision: Precision) -> usize {
    match precision {
        Precision::F32 => size_of::<GpuRay<f32>>(),
        Precision::F64 => size_of::<GpuRay<f64>>(),
    }
}

impl Buffers {
    fn new(
        device: &wgpu::Device,
        layout: &wgpu::BindGroupLayout,
        precision: Precision,
        chunk_rays: usize,
        grid_bytes: u64,
    ) -> Buffers {
        use wgpu::BufferUsages as U;
        let buffer = |label: &str, size: u64, usage: U| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage,
                mapped_at_creation: false,
            })
        };
        let storage = U::STORAGE | U::COPY_DST | U::COPY_SRC;
        let ray_bytes = (chunk_rays * ray_size(precision)) as u64;
        let params = buffer("params", size_of::<Params<f64>>() as u64, storage);
        let surfaces = buffer(
            "surfaces",
            (MAX_SURFACES * size_of::<Surface<f64>>()) as u64,
            storage,
        );
        let rays = buffer("rays", ray_bytes, storage);
        let statuses = buffer("statuses", (chunk_rays * 4) as u64, storage);
        let grid = buffer("grid", grid_bytes, storage);
        let counters = buffer("counters", (kind::COUNTERS * 4) as u64, storage);
        // Read back in pieces of at most 16 MiB: bounded host-visible memory.
        let readback = buffer("readback", ray_bytes.min(16 << 20), U::MAP_READ | U::COPY_DST);
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("unicac bind group"),
            layout,
            entries: &[
                entry(0, &params),
                entry(1, &surfaces),
                entry(2, &rays),
                entry(3, &statuses),
                entry(4, &grid),
                entry(5, &counters),
            ],
        });
        Buffers {
            params,
            surfaces,
            rays,
            statuses,
            grid,
            counters,
            readback,
            bind_group,
        }
    }
}

/// Status counts from the kernels' histogram (NOT_SAMPLED slots are not rays).
pub fn counts_from_histogram(words: &[u32]) -> StatusCounts {
    StatusCounts {
        ok: words[kind::OK as usize] as usize,
        missed: words[kind::MISSED as usize] as usize,
        tir: words[kind::TIR as usize] as usize,
        clipped: words[kind::CLIPPED as usize] as usize,
        no_convergence: words[kind::NO_CONVERGENCE as usize] as usize,
        invalid_input: words[kind::INVALID_INPUT as usize] as usize,
    }
}

pub fn to_gpu<R: Real>(ray: &Ray) -> GpuRay<R> {
    let [x, y, z] = ray.position_mm;
    let [l, m, n] = ray.direction;
    GpuRay {
        x: R::from_f64(x),
        y: R::from_f64(y),
        z: R::from_f64(z),
        l: R::from_f64(l),
        m: R::from_f64(m),
        n: R::from_f64(n),
    }
}

/// A kernel's output ray (local to the vertex of the last surface reached) in global coordinates.
pub fn to_global<R: Real>(system: &TraceSystem, ray: &GpuRay<R>, status: RayStatus) -> Ray {
    Ray {
        position_mm: [
            ray.x.to_f64(),
            ray.y.to_f64(),
            ray.z.to_f64() + layout::frame_z_mm(system, status),
        ],
        direction: [ray.l.to_f64(), ray.m.to_f64(), ray.n.to_f64()],
    }
}
