//! The PSF-map cache through `LensSimulator`: a second run loads what the first traced, and a change of
//! tracing device is a miss. One test in its own binary, because it changes the process-wide default
//! hit tracer.

use std::sync::Arc;
use unicac_optics::examples;
use unicac_psf::{set_default_hit_tracer, CpuHitTracer, HitTracer};
use unicac_sim::{LensSimulator, PsfCache, SimulationSettings};
use unicac_trace::{PupilSampling, Ray, RayStatus, TraceSystem};

/// The CPU tracer under another device name, standing in for a GPU.
struct OtherDevice;

impl HitTracer for OtherDevice {
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> Vec<RayStatus> {
        CpuHitTracer.trace(system, rays)
    }

    fn describe(&self) -> String {
        "other device".into()
    }
}

#[test]
fn a_second_run_loads_the_map_and_another_device_traces_again() {
    let dir = std::env::temp_dir().join(format!("unicac-sim-cache-{}", std::process::id()));
    let mut settings = SimulationSettings {
        wavelengths: 5,
        radial_samples: 4,
        cache: Some(PsfCache::new(&dir)),
        ..Default::default()
    };
    settings.psf.pupil_sampling = PupilSampling::Fibonacci { n: 256 };
    let lens = examples::lens("cooke_triplet").unwrap();
    let build = || LensSimulator::new(&lens, 64, 48, None, settings.clone()).unwrap();
    let first = build();
    let second = build();
    assert!(!first.psfs_from_cache && first.cache_warning.is_none());
    assert!(second.psfs_from_cache);
    for (a, b) in first.radial.psfs.iter().zip(&second.radial.psfs) {
        assert_eq!(a.kernels, b.kernels);
    }
    set_default_hit_tracer(Arc::new(OtherDevice));
    assert!(
        !build().psfs_from_cache,
        "a map traced on another device was served from the cache"
    );
    assert!(build().psfs_from_cache);
    std::fs::remove_dir_all(&dir).unwrap();
}
