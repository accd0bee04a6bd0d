//! `unicac gpu info`, and the `--device` / `--gpu-precision` plumbing of spot, psf, simulate and ode.

use super::print_json;
use crate::args::DeviceArgs;
use anyhow::Result;
use clap::{Args, Subcommand};
use std::sync::Arc;
use unicac_gpu::{DeviceChoice, DeviceSelection};

#[derive(Subcommand)]
pub enum GpuCommand {
    /// List GPU adapters (Vulkan), their backends and features, and what `--device auto` would use.
    Info(GpuInfoArgs),
}

#[derive(Args)]
pub struct GpuInfoArgs {
    #[arg(long)]
    pub json: bool,
}

pub fn run(command: &GpuCommand) -> Result<()> {
    match command {
        GpuCommand::Info(args) => info(args),
    }
}

fn info(args: &GpuInfoArgs) -> Result<()> {
    let adapters = unicac_gpu::device::list_adapters();
    let auto = match adapters.iter().find(|a| !a.software) {
        Some(a) => format!(
            "gpu ({}) for batches of at least {} rays, else cpu",
            a.name,
            unicac_gpu::AUTO_MIN_RAYS
        ),
        None => "cpu (no hardware GPU adapter)".into(),
    };
    if args.json {
        return print_json(&serde_json::json!({
            "adapters": adapters,
            "auto": auto,
            "auto_min_rays": unicac_gpu::AUTO_MIN_RAYS,
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

/// The device policy of a command; also made the default PSF hit tracer, so that PSFs traced anywhere
/// in this run (psf, simulate, ode) follow it. With `cpu` nothing changes.
pub fn install(device: &DeviceArgs) -> Arc<DeviceSelection> {
    let selection = Arc::new(DeviceSelection::new(device.device, device.gpu_precision));
    if device.device != DeviceChoice::Cpu {
        unicac_psf::set_default_hit_tracer(selection.clone());
    }
    selection
}
