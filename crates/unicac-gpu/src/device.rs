//! Adapters and devices. Getting a device (`GpuContext::new`) is separate from running kernels
//! (`trace::GpuTracer`, built once on a context and reused). Only Vulkan is enabled: with no GPU, Mesa's
//! lavapipe (a Vulkan driver on the CPU) is the adapter, and no GL adapter shows up twice.

use crate::real::Precision;
use serde::Serialize;

#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    #[error("no GPU adapter found (Vulkan); on Debian `apt-get install mesa-vulkan-drivers libvulkan1` provides lavapipe, a CPU implementation")]
    NoAdapter,
    #[error("the adapter '{adapter}' does not offer SHADER_F64 (f64 precision); trace in f32 precision")]
    F64Unsupported { adapter: String },
    #[error("could not open the GPU device: {0}")]
    RequestDevice(String),
    #[error("GPU error: {0}")]
    Device(String),
    /// A request parameter out of its range.
    #[error(transparent)]
    InvalidParameter(#[from] unicac_trace::InvalidParameter),
    /// A request beyond what the GPU path or this device supports (the CPU path takes it).
    #[error("unsupported on the GPU: {0}")]
    Unsupported(String),
    #[error(transparent)]
    Trace(#[from] unicac_trace::TraceError),
    #[error(transparent)]
    Optics(#[from] unicac_optics::OpticsError),
    #[error(transparent)]
    Psf(#[from] unicac_psf::PsfError),
}

pub type GpuResult<T> = std::result::Result<T, GpuError>;

/// What `unicac gpu info` shows about one adapter.
#[derive(Debug, Clone, Serialize)]
pub struct AdapterSummary {
    pub name: String,
    pub backend: String,
    pub device_type: String,
    pub driver: String,
    pub driver_info: String,
    /// A CPU implementation (lavapipe, SwiftShader): correct, but no faster than the CPU path.
    pub software: bool,
    pub shader_f64: bool,
    pub features: Vec<String>,
    pub max_storage_buffer_binding_size: u64,
    pub max_buffer_size: u64,
    pub max_compute_workgroups_per_dimension: u32,
}

impl AdapterSummary {
    fn of(adapter: &wgpu::Adapter) -> AdapterSummary {
        let info = adapter.get_info();
        let features = adapter.features();
        let limits = adapter.limits();
        AdapterSummary {
            name: info.name,
            backend: format!("{:?}", info.backend),
            device_type: format!("{:?}", info.device_type),
            driver: info.driver,
            driver_info: info.driver_info,
            software: info.device_type == wgpu::DeviceType::Cpu,
            shader_f64: features.contains(wgpu::Features::SHADER_F64),
            features: features.iter_names().map(|(name, _)| name.to_string()).collect(),
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            max_buffer_size: limits.max_buffer_size,
            max_compute_workgroups_per_dimension: limits.max_compute_workgroups_per_dimension,
        }
    }
}

fn instance() -> wgpu::Instance {
    wgpu::Instance::new(wgpu::InstanceDescriptor {
        backends: wgpu::Backends::VULKAN,
        ..wgpu::InstanceDescriptor::new_without_display_handle()
    })
}

/// Every Vulkan adapter of this machine (empty when there is none: never an error).
pub fn list_adapters() -> Vec<AdapterSummary> {
    let adapters = pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN));
    adapters.iter().map(AdapterSummary::of).collect()
}

/// One device and its queue, with what the adapter offers. Cheap to share (`Arc`).
pub struct GpuContext {
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub adapter: AdapterSummary,
    pub limits: wgpu::Limits,
}

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("GpuContext")
            .field("adapter", &self.adapter.name)
            .finish()
    }
}

impl GpuContext {
    /// The default (high-performance) Vulkan adapter with SHADER_F64 enabled when offered and the
    /// adapter's own limits (wgpu's defaults cap storage bindings lower than lavapipe's 128 MiB).
    pub fn new() -> GpuResult<GpuContext> {
        let adapter = pollster::block_on(instance().request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|_| GpuError::NoAdapter)?;
        let summary = AdapterSummary::of(&adapter);
        let features = adapter.features() & wgpu::Features::SHADER_F64;
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("unicac"),
            required_features: features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::RequestDevice(e.to_string()))?;
        Ok(GpuContext {
            device,
            queue,
            adapter: summary,
            limits,
        })
    }

    /// The first `bytes` of `from`, copied through `staging` (MAP_READ | COPY_DST) one staging-sized
    /// piece at a time after the work submitted before: device memory for read-back stays bounded.
    pub(crate) fn read_through(
        &self,
        from: &wgpu::Buffer,
        bytes: u64,
        staging: &wgpu::Buffer,
    ) -> GpuResult<Vec<u8>> {
        let device_error = |e: &dyn std::fmt::Display| GpuError::Device(e.to_string());
        let mut out = Vec::with_capacity(bytes as usize);
        let step = staging.size();
        let mut offset = 0;
        while offset < bytes {
            let size = step.min(bytes - offset);
            let mut encoder = self.device.create_command_encoder(&Default::default());
            encoder.copy_buffer_to_buffer(from, offset, staging, 0, size);
            let index = self.queue.submit([encoder.finish()]);
            let slice = staging.slice(..size);
            let (sender, receiver) = std::sync::mpsc::channel();
            slice.map_async(wgpu::MapMode::Read, move |result| {
                let _ = sender.send(result);
            });
            self.device
                .poll(wgpu::PollType::Wait {
                    submission_index: Some(index),
                    timeout: None,
                })
                .map_err(|e| device_error(&e))?;
            receiver
                .recv()
                .map_err(|e| device_error(&e))?
                .map_err(|e| device_error(&e))?;
            {
                let view = slice.get_mapped_range().map_err(|e| device_error(&e))?;
                out.extend_from_slice(&view);
            }
            staging.unmap();
            offset += size;
        }
        Ok(out)
    }

    pub fn supports(&self, precision: Precision) -> bool {
        match precision {
            Precision::F32 => true,
            Precision::F64 => self.adapter.shader_f64,
        }
    }
}
