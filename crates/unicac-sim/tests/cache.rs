//! The PSF-map cache through `LensSimulator`: a second run loads what the first traced, and a change of
//! tracing device (the settings' ray backend) is a miss.

use std::sync::Arc;
use unicac_optics::builtin;
use unicac_psf::{CpuHitTracer, HitTracer, PsfResult, RayBackend};
use unicac_sim::{LensSimulator, PsfCache, RadialSampling, SimulationSettings};
use unicac_trace::{PupilSampling, Ray, RayStatus, TraceSystem};

/// The CPU tracer under another device name, standing in for a GPU.
struct OtherDevice;

impl HitTracer for OtherDevice {
    fn trace(&self, system: &TraceSystem, rays: &mut [Ray]) -> PsfResult<Vec<RayStatus>> {
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
        radial: RadialSampling {
            max_samples: 5,
            ..SimulationSettings::default().radial
        },
        cache: Some(PsfCache::new(&dir)),
        ..Default::default()
    };
    settings.psf.pupil_sampling = PupilSampling::Fibonacci { n: 256 };
    let lens = builtin::lens("cooke_triplet").unwrap();
    let build =
        |settings: &SimulationSettings| LensSimulator::new(&lens, 64, 48, None, settings.clone()).unwrap();
    let first = build(&settings);
    let second = build(&settings);
    assert!(!first.psfs_from_cache && first.cache_warning.is_none());
    assert!(second.psfs_from_cache);
    for (a, b) in first
        .radial()
        .unwrap()
        .psfs
        .iter()
        .zip(&second.radial().unwrap().psfs)
    {
        assert_eq!(a.kernels, b.kernels);
    }
    settings.psf.backend = RayBackend::new(Arc::new(OtherDevice));
    assert!(
        !build(&settings).psfs_from_cache,
        "a map traced on another device was served from the cache"
    );
    assert!(build(&settings).psfs_from_cache);
    std::fs::remove_dir_all(&dir).unwrap();
}
