//! `unicac gpu info`, and the `--device` / `--gpu-precision` choice of spot, psf, simulate and ode, made
//! into a value (`selection`, `backend`) that the command passes to the libraries.

use super::print_json;
use crate::args::{DeviceArgs, GpuCommand, GpuInfoArgs};
use anyhow::Result;
use std::sync::Arc;
use unicac_gpu::DeviceSelection;
use unicac_psf::RayBackend;

pub fn run(command: &GpuCommand) -> Result<()> {
    match command {
        GpuCommand::Info(args) => info(args),
    }
}

fn info(args: &GpuInfoArgs) -> Result<()> {
    let adapters = unicac_gpu::device::list_adapters();
    let auto = match adapters.iter().find(|a| !a.software) {
        Some(a) => format!(
            "gpu ({}) for ray batches of at least {} rays and image passes of at least {} pixels, else cpu",
            a.name,
            unicac_gpu::AUTO_MIN_RAYS,
            unicac_gpu::AUTO_MIN_PIXELS
        ),
        None => "cpu (no hardware GPU adapter)".into(),
    };
    if args.json {
        return print_json(&serde_json::json!({
            "adapters": adapters,
            "auto": auto,
            "auto_min_rays": unicac_gpu::AUTO_MIN_RAYS,
            "auto_min_pixels": unicac_gpu::AUTO_MIN_PIXELS,
        }));
    }
    if adapters.is_empty() {
        println!("no GPU adapter found (Vulkan); every command runs on the CPU");
        println!("(on Debian, `apt-get install mesa-vulkan-drivers libvulkan1` adds lavapipe, a CPU implementation)");
    }
    for a in &adapters {
        println!("{}", a.name);
        println!("  backend      {}", a.backend);
        println!(
            "  type         {}{}",
            a.device_type,
            if a.software {
                " (software: correct, not fast)"
            } else {
                ""
            }
        );
        println!("  driver       {} {}", a.driver, a.driver_info);
        println!("  shader f64   {}", if a.shader_f64 { "yes" } else { "no" });
        println!(
            "  storage      {} MiB per binding",
            a.max_storage_buffer_binding_size >> 20
        );
        println!("  features     {}", a.features.join(", "));
    }
    println!("--device auto: {auto}");
    Ok(())
}

/// The device policy of a command (spot asks it per batch).
pub fn selection(device: &DeviceArgs) -> Arc<DeviceSelection> {
    Arc::new(DeviceSelection::new(device.device, device.gpu_precision))
}

/// The ray backend of a command's PSFs (psf, simulate, ode), chosen by `--device` / `--gpu-precision`.
pub fn backend(device: &DeviceArgs) -> RayBackend {
    DeviceSelection::backend(device.device, device.gpu_precision)
}

/// Prints what the device noted during the run (a fallback to the CPU) as warnings.
pub fn print_notes(notes: Vec<String>) {
    for note in notes {
        eprintln!("warning: --device: {note}");
    }
}
