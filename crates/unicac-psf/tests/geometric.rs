//! Geometric PSFs: energy, centring, convergence with ray count, agreement with spot statistics.

use unicac_optics::builtin;
use unicac_psf::{PsfSettings, PsfTracer, SpectralResponse, SpectralWeights};
use unicac_trace::{spots, Aiming, PupilSampling};

fn tracer(lens: &str, rays: usize, pixel_um: f64, weights: SpectralWeights) -> PsfTracer {
    let lens = builtin::lens(lens).unwrap();
    let mut settings = PsfSettings::new(pixel_um);
    settings.pupil_sampling = PupilSampling::Fibonacci { n: rays };
    PsfTracer::new(&lens, weights, settings).unwrap()
}

#[test]
fn kernels_are_normalised_and_on_axis_psfs_are_centred() {
    let weights = SpectralWeights::new(
        &SpectralResponse::default_camera(),
        &unicac_psf::visible_wavelengths_um(31),
    );
    let t = tracer("cooke_triplet", 2048, 2.0, weights);
    let psf = t.field_psf(0.0, 41, false).unwrap();
    assert_eq!(psf.kernels.len(), 3);
    for k in &psf.kernels {
        assert!((k.sum() - 1.0).abs() < 1e-5);
        let c = k.centroid_um();
        assert!(c[0].abs() < 0.01 && c[1].abs() < 0.01, "{c:?}");
    }
    assert!((psf.transmission - 1.0).abs() < 1e-12);
}

#[test]
fn kernel_second_moment_matches_the_spot_rms() {
    // A fine pixel grid (1 um) and no cut: the kernel's RMS radius about its centroid equals the
    // tracer's RMS spot radius up to the splat's smoothing (sub-cell variance ~ (p/4)^2/6 per axis).
    let wavelength = 0.5875618;
    let t = tracer(
        "cooke_triplet",
        4096,
        1.0,
        SpectralWeights::monochromatic(wavelength),
    );
    let field = 14.0;
    let psf = t.field_psf(field, 127, true).unwrap();
    let k = &psf.kernels[0];
    let c = k.centroid_um();
    let half = k.half() as f64;
    let mut m2 = 0.0;
    for y in 0..k.size {
        for x in 0..k.size {
            let dx = (x as f64 - half) * k.pitch_um - c[0];
            let dy = (y as f64 - half) * k.pitch_um - c[1];
            m2 += k.at(x, y) as f64 * (dx * dx + dy * dy);
        }
    }
    let lens = builtin::lens("cooke_triplet").unwrap();
    let spot = &spots(
        &lens,
        &[field],
        &[wavelength],
        Aiming::Paraxial,
        &PupilSampling::Fibonacci { n: 4096 },
    )
    .unwrap()[0];
    let rms = spot.rms_radius_um.unwrap();
    assert!(psf.energy_cut[0] < 0.005, "cut {}", psf.energy_cut[0]);
    assert!(
        (m2.sqrt() - rms).abs() < 0.03 * rms,
        "kernel {} vs spot {rms}",
        m2.sqrt()
    );
}

#[test]
fn psfs_converge_as_rays_grow() {
    let wavelength = 0.5875618;
    let reference = tracer(
        "double_gauss",
        65536,
        2.0,
        SpectralWeights::monochromatic(wavelength),
    )
    .field_psf(10.0, 31, true)
    .unwrap();
    let mut previous = f64::INFINITY;
    for rays in [256, 1024, 4096, 16384] {
        let psf = tracer(
            "double_gauss",
            rays,
            2.0,
            SpectralWeights::monochromatic(wavelength),
        )
        .field_psf(10.0, 31, true)
        .unwrap();
        let l1: f64 = psf.kernels[0]
            .data
            .iter()
            .zip(&reference.kernels[0].data)
            .map(|(a, b)| (a - b).abs() as f64)
            .sum();
        assert!(
            l1 < previous,
            "{rays} rays: L1 {l1} did not drop below {previous}"
        );
        previous = l1;
    }
    assert!(previous < 0.05, "L1 at 16384 rays: {previous}");
}
