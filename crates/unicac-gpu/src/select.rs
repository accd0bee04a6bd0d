//! `--device cpu|gpu|auto`: which path a job runs on, decided per job size, with the device opened
//! lazily (small jobs under `auto` never pay for adapter discovery) and every failure ending on the CPU
//! with a note for the user (`HitTracer::take_notes`; the face prints it), never an error.
//!
//! `auto` takes the GPU only when (a) an adapter exists, (b) it is a real GPU, not a CPU implementation
//! such as lavapipe (measured slower than the CPU path at every batch size on the same cores, see
//! docs/gpu.md), and (c) the batch holds at least `AUTO_MIN_RAYS` rays. (a) and (b) are first decided
//! without Vulkan: no GPU device node, no hardware GPU (`hardware_gpu_node_present`).

use crate::device::GpuContext;
use crate::image::GpuImagePass;
use crate::real::Precision;
use crate::trace::GpuTracer;
use crate::RaySource;
use std::sync::{Arc, Mutex, OnceLock};
use unicac_image::isp::{Demosaic, IspDevice, SensorNoise, WhiteBalanceGains};
use unicac_image::Planar;
use unicac_psf::{HitTracer, PsfResult, RayBackend};
use unicac_sim::{ImageBackend, ImageDevice, ImagePass};
use unicac_trace::{trace_rays, Ray, RayStatus, TraceSystem};

/// Smallest batch `auto` sends to a GPU. A batch pays a fixed ~0.3-0.5 ms (submit, wait, map; measured
/// 0.4 ms on lavapipe) plus ~50 bytes per ray over the bus, against ~90 ns per ray on the CPU path
/// (Cooke triplet, 2 cores): break-even near 4k rays, so 16k leaves a factor 4 of margin (docs/gpu.md).
pub const AUTO_MIN_RAYS: usize = 16_384;

/// Smallest image pass (output pixels) `auto` sends to a GPU. Each channel of a pass costs three
/// uploads, one download and two submissions (~1-2 ms of fixed cost and ~12 bytes per pixel over
/// the bus) against ~50 ns per pixel of the CPU path's image pass (12 MP in ~0.65 s on 2 cores,
/// docs/performance.md): break-even near 64k pixels, so 2^18 (a 512 x 512 frame) leaves a factor 4.
/// An estimate from those figures: no hardware GPU was available to measure it.
pub const AUTO_MIN_PIXELS: usize = 1 << 18;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DeviceChoice {
    Cpu,
    Gpu,
    #[default]
    Auto,
}

impl std::str::FromStr for DeviceChoice {
    type Err = String;
    fn from_str(text: &str) -> Result<Self, String> {
        match text {
            "cpu" => Ok(DeviceChoice::Cpu),
            "gpu" => Ok(DeviceChoice::Gpu),
            "auto" => Ok(DeviceChoice::Auto),
            _ => Err(format!("'{text}': expected cpu, gpu or auto")),
        }
    }
}

/// The device policy of one run.
pub struct DeviceSelection {
    choice: DeviceChoice,
    precision: Precision,
    /// One device for both kinds of work, opened on first use.
    context: OnceLock<Option<Arc<GpuContext>>>,
    tracer: OnceLock<Option<GpuTracer>>,
    image: OnceLock<Option<GpuImagePass>>,
    /// Fallbacks to the CPU not yet reported, and whether a trace failure was already noted (once).
    notes: Mutex<(Vec<String>, bool)>,
}

impl DeviceSelection {
    pub fn new(choice: DeviceChoice, precision: Precision) -> DeviceSelection {
        DeviceSelection {
            choice,
            precision,
            context: OnceLock::new(),
            tracer: OnceLock::new(),
            image: OnceLock::new(),
            notes: Mutex::new((Vec::new(), false)),
        }
    }

    /// This policy as the image device of simulation settings: the plain CPU path for `cpu`.
    pub fn image_backend(selection: &Arc<DeviceSelection>) -> ImageBackend {
        match selection.choice {
            DeviceChoice::Cpu => ImageBackend::cpu(),
            _ => ImageBackend::new(selection.clone()),
        }
    }

    /// This policy as the ray backend of PSF settings, sharing its device with `image_backend`.
    pub fn ray_backend(selection: &Arc<DeviceSelection>) -> RayBackend {
        match selection.choice {
            DeviceChoice::Cpu => RayBackend::cpu(),
            _ => RayBackend::new(selection.clone()),
        }
    }

    /// This policy as the ray backend of PSF settings: the plain CPU tracer for `cpu`.
    pub fn backend(choice: DeviceChoice, precision: Precision) -> RayBackend {
        DeviceSelection::ray_backend(&Arc::new(DeviceSelection::new(choice, precision)))
    }

    fn note(&self, text: String) {
        self.notes.lock().unwrap_or_else(|e| e.into_inner()).0.push(text);
    }

    pub fn choice(&self) -> DeviceChoice {
        self.choice
    }

    /// The GPU tracer for a batch of `rays` rays, or None for the CPU.
    pub fn tracer_for(&self, rays: usize) -> Option<&GpuTracer> {
        self.uses_gpu(rays, AUTO_MIN_RAYS).then(|| self.open()).flatten()
    }

    /// The policy for a job of `size` (rays, pixels) against `auto`'s smallest GPU job `auto_min`:
    /// `gpu` always (a missing device is noted when it is opened); `auto` only for jobs of at least
    /// `auto_min` on a hardware GPU, and without its device node Vulkan is never touched.
    fn uses_gpu(&self, size: usize, auto_min: usize) -> bool {
        match self.choice {
            DeviceChoice::Cpu => false,
            DeviceChoice::Auto => {
                size >= auto_min
                    && hardware_gpu_node_present()
                    && self.context().is_some_and(|c| !c.adapter.software)
            }
            DeviceChoice::Gpu => true,
        }
    }

    /// The device, opened on first use (a failure is noted once when the GPU was asked for).
    fn context(&self) -> Option<&Arc<GpuContext>> {
        self.context
            .get_or_init(|| match GpuContext::new() {
                Ok(context) => Some(Arc::new(context)),
                Err(error) => {
                    if self.choice == DeviceChoice::Gpu {
                        self.note(format!(
                            "GPU requested but not available ({error}); running on the CPU instead"
                        ));
                    }
                    None
                }
            })
            .as_ref()
    }

    fn open(&self) -> Option<&GpuTracer> {
        self.tracer
            .get_or_init(|| {
                let context = self.context()?;
                match GpuTracer::new(context.clone(), self.precision) {
                    Ok(tracer) => Some(tracer),
                    Err(error) => {
                        if self.choice == DeviceChoice::Gpu {
                            self.note(format!(
                                "GPU requested but not available ({error}); tracing on the CPU instead"
                            ));
                        }
                        None
                    }
                }
            })
            .as_ref()
    }

    /// The GPU image pass, opened now, for a job that must know its device before it starts (a dataset
    /// build records it): the pass, or why there is none (`auto`: no hardware GPU).
    pub fn image_pass_now(&self) -> Result<&GpuImagePass, String> {
        match self.image_pass_for(usize::MAX) {
            Some(pass) => Ok(pass),
            None => {
                let notes = HitTracer::take_notes(self);
                Err(match notes.is_empty() {
                    true => "no hardware GPU adapter".into(),
                    false => notes.join("; "),
                })
            }
        }
    }

    /// The GPU image pass for `pixels` output pixels, or None for the CPU path.
    pub fn image_pass_for(&self, pixels: usize) -> Option<&GpuImagePass> {
        if !self.uses_gpu(pixels, AUTO_MIN_PIXELS) {
            return None;
        }
        self.image
            .get_or_init(|| self.context().map(|context| GpuImagePass::new(context.clone())))
            .as_ref()
    }

    fn fall_back(&self, work: &str, error: impl std::fmt::Display) {
        let mut notes = self.notes.lock().unwrap_or_else(|e| e.into_inner());
        if !std::mem::replace(&mut notes.1, true) {
            notes
                .0
                .push(format!("GPU {work} failed ({error}); continuing on the CPU"));
        }
    }

    fn adapter_name(&self) -> Option<&str> {
        match self.context.get() {
            Some(Some(context)) => Some(&context.adapter.name),
            _ => None,
        }
    }
}

impl DeviceSelection {
    /// A device result, or None for the CPU path with a note: a job beyond the device's limits is
    /// declined, not failed (said once per kind of reason); a failure is said once.
    fn on_device(&self, work: &str, result: crate::GpuResult<Planar>) -> Option<Planar> {
        match result {
            Ok(out) => Some(out),
            Err(crate::GpuError::Unsupported(why)) => {
                let note = format!("the GPU {work} does not take {why}; running it on the CPU");
                let mut notes = self.notes.lock().unwrap_or_else(|e| e.into_inner());
                if !notes.0.contains(&note) {
                    notes.0.push(note);
                }
                None
            }
            Err(error) => {
                self.fall_back(work, error);
                None
            }
        }
    }
}

impl IspDevice for DeviceSelection {
    fn read_out(&self, exposure: &Planar, sensor: &SensorNoise, noise_seed: u64) -> Option<Planar> {
        let image = self.image_pass_for(exposure.width * exposure.height)?;
        self.on_device("read-out", image.read_out(exposure, sensor, noise_seed))
    }

    fn develop(
        &self,
        dn: &Planar,
        sensor: &SensorNoise,
        gains: WhiteBalanceGains,
        method: Demosaic,
    ) -> Option<Planar> {
        let image = self.image_pass_for(dn.width * dn.height)?;
        self.on_device("development", image.develop(dn, sensor, gains, method))
    }
}

impl ImageDevice for DeviceSelection {
    fn apply(&self, pass: &ImagePass) -> Option<Planar> {
        let image = self.image_pass_for(pass.window.width * pass.window.height)?;
        self.on_device("image pass", image.apply(pass))
    }

    fn describe(&self) -> String {
        match (self.image.get(), self.adapter_name()) {
            (Some(Some(_)), Some(name)) => format!("gpu (f32, {name})"),
            _ => "cpu".into(),
        }
    }

    fn take_notes(&self) -> Vec<String> {
        HitTracer::take_notes(self)
    }
}

impl HitTracer for DeviceSelection {
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> PsfResult<Vec<RayStatus>> {
        if let Some(tracer) = self.tracer_for(rays.len()) {
            match tracer.trace(system, &RaySource::Host(rays)) {
                Ok(traced) => {
                    rays.copy_from_slice(&traced.rays);
                    return Ok(traced.statuses);
                }
                Err(error) => self.fall_back("trace", error),
            }
        }
        Ok(trace_rays(system, rays))
    }

    fn take_notes(&self) -> Vec<String> {
        std::mem::take(&mut self.notes.lock().unwrap_or_else(|e| e.into_inner()).0)
    }

    /// The device this policy traces on, decided now: cache keys are made before the first trace, and a
    /// description that waited for it said "cpu" for a GPU run, so GPU f32 PSFs were stored under (and
    /// served to) CPU keys. `gpu` opens the device here; `auto` names the GPU when it could take a
    /// batch (a hardware adapter), so its results never share the CPU's key either.
    fn describe(&self) -> String {
        // The tracer a batch just large enough for `auto` would get (`gpu`: always; `cpu`: none).
        match (self.tracer_for(AUTO_MIN_RAYS), self.choice) {
            (None, _) => "cpu".into(),
            (Some(t), DeviceChoice::Auto) => format!(
                "auto (gpu ({}, {}) for batches of at least {AUTO_MIN_RAYS} rays)",
                t.precision(),
                t.context().adapter.name
            ),
            (Some(t), _) => format!("gpu ({}, {})", t.precision(), t.context().adapter.name),
        }
    }
}

/// Whether this machine shows a device node a hardware Vulkan driver could use: a DRM render node
/// (`/dev/dri/renderD*`: AMD, Intel, Nouveau, Apple, virtio GPUs) or an NVIDIA node (`/dev/nvidia0..`).
/// Without one, the only Vulkan adapters are CPU implementations (lavapipe, SwiftShader), which `auto`
/// never uses, so it can decide "CPU" without creating a Vulkan instance (which costs ~0.5-1 s with
/// lavapipe and may print Mesa warnings). Looked up once per process: device nodes do not come and go
/// during a run.
pub fn hardware_gpu_node_present() -> bool {
    static PRESENT: OnceLock<bool> = OnceLock::new();
    *PRESENT.get_or_init(|| gpu_node_in(std::path::Path::new("/dev")))
}

fn gpu_node_in(dev: &std::path::Path) -> bool {
    let has_entry = |dir: &std::path::Path, prefix: &str| {
        std::fs::read_dir(dir).is_ok_and(|entries| {
            entries
                .flatten()
                .any(|e| e.file_name().to_string_lossy().starts_with(prefix))
        })
    };
    has_entry(&dev.join("dri"), "renderD") || has_entry(dev, "nvidia")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_and_small_auto_jobs_never_open_a_device() {
        let cpu = DeviceSelection::new(DeviceChoice::Cpu, Precision::F32);
        assert!(cpu.tracer_for(usize::MAX).is_none());
        let auto = DeviceSelection::new(DeviceChoice::Auto, Precision::F32);
        assert!(auto.tracer_for(AUTO_MIN_RAYS - 1).is_none());
        assert!(
            auto.tracer.get().is_none(),
            "adapter discovery must wait for a big job"
        );
        assert_eq!(HitTracer::describe(&auto), "cpu");
        assert_eq!(ImageDevice::describe(&auto), "cpu");
    }

    #[test]
    fn gpu_nodes_are_recognised_from_the_device_directory() {
        let dev = std::env::temp_dir().join(format!("unicac-dev-{}", std::process::id()));
        std::fs::create_dir_all(dev.join("dri")).unwrap();
        assert!(!gpu_node_in(&dev), "empty /dev");
        std::fs::write(dev.join("dri").join("card0"), b"").unwrap();
        assert!(!gpu_node_in(&dev), "a display node alone is no render node");
        std::fs::write(dev.join("dri").join("renderD128"), b"").unwrap();
        assert!(gpu_node_in(&dev));
        std::fs::remove_dir_all(dev.join("dri")).unwrap();
        std::fs::write(dev.join("nvidia0"), b"").unwrap();
        assert!(gpu_node_in(&dev));
        std::fs::remove_dir_all(&dev).unwrap();
    }

    #[test]
    fn auto_without_a_gpu_node_never_opens_a_device() {
        if hardware_gpu_node_present() {
            return; // a machine with a GPU: auto may open it
        }
        let auto = DeviceSelection::new(DeviceChoice::Auto, Precision::F32);
        assert!(auto.tracer_for(usize::MAX).is_none());
        assert!(
            auto.tracer.get().is_none(),
            "no Vulkan instance without a GPU node"
        );
    }

    #[test]
    fn device_choices_parse() {
        assert_eq!("auto".parse::<DeviceChoice>(), Ok(DeviceChoice::Auto));
        assert!("tpu".parse::<DeviceChoice>().is_err());
        assert_eq!("f64".parse::<Precision>(), Ok(Precision::F64));
    }
}
