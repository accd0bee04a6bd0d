//! PSFs of a decentred lens (issue 36): the PSF at a 2D field (`PsfTracer::field_psf_at`) is checked
//! against a direct trace of the same rays (centroid within `CENTROID_TOLERANCE_UM`), shows the
//! asymmetry a decentre causes (a centred lens's
//! on-axis PSF has its centroid on the chief ray; the decentred one's does not), and depends on the
//! field's azimuth (the PSFs at +x and -x are mirror images for the centred lens, not for the
//! decentred one).

use unicac_optics::{builtin, Lens, Placement};
use unicac_psf::geometric::{PsfSettings, PsfTracer};
use unicac_psf::kernel::Kernel;
use unicac_psf::spectrum::SpectralWeights;
use unicac_trace::{Aimer, Aiming, Clipping, PupilSampling, TraceSystem};

/// The Cooke triplet with its middle element's front surface (surface 3) decentred by 0.2 mm in x.
fn decentred_cooke() -> Lens {
    let mut spec = builtin::spec("cooke_triplet").unwrap();
    spec.surfaces[2].set_placement(Placement {
        decentre_x_mm: 0.2,
        ..Placement::default()
    });
    Lens::from_spec(&spec).unwrap()
}

fn tracer(lens: &Lens) -> PsfTracer {
    let mut settings = PsfSettings::new(4.0);
    // Hexapolar rings are mirror-symmetric in x, so a centred lens gives exactly mirrored PSFs.
    settings.pupil_sampling = PupilSampling::Hexapolar { rings: 24 };
    settings.aiming = Aiming::Real;
    PsfTracer::new(
        lens,
        SpectralWeights::monochromatic(lens.primary_wavelength_um()),
        settings,
    )
    .unwrap()
}

/// The centroid (um, kernel orientation: x right, y down) of the rays of `field_deg` that arrive,
/// relative to the primary-wavelength chief ray, traced directly with the aimer and the f64 tracer.
fn direct_centroid_um(lens: &Lens, field_deg: [f64; 2]) -> [f64; 2] {
    let wavelength = lens.primary_wavelength_um();
    let aimer = Aimer::new(lens, wavelength, Aiming::Real).unwrap();
    let clipped = TraceSystem::new(lens, wavelength, Clipping::Apertures).unwrap();
    let open = TraceSystem::new(lens, wavelength, Clipping::None).unwrap();
    let mut chief = aimer.ray_at(field_deg, 0.0, 0.0).unwrap();
    assert!(open.trace(&mut chief).is_ok());
    let mut sum = [0.0, 0.0];
    let mut count = 0.0;
    for [px, py] in (PupilSampling::Hexapolar { rings: 24 }).points() {
        let Ok(mut ray) = aimer.ray_at(field_deg, px, py) else {
            continue;
        };
        if clipped.trace(&mut ray).is_ok() {
            sum[0] += (ray.position_mm[0] - chief.position_mm[0]) * 1e3;
            sum[1] -= (ray.position_mm[1] - chief.position_mm[1]) * 1e3;
            count += 1.0;
        }
    }
    [sum[0] / count, sum[1] / count]
}

fn mirrored_half_l1(a: &Kernel, b: &Kernel) -> f64 {
    assert_eq!(a.size, b.size);
    let n = a.size;
    let mut total = 0.0;
    for y in 0..n {
        for x in 0..n {
            total += (a.at(x, y) as f64 - b.at(n - 1 - x, y) as f64).abs();
        }
    }
    0.5 * total
}

/// At 4 um pixels, +-252 um: every ray of these spots lands inside the kernel (no energy cut moves the
/// centroid).
const SIZE_PX: usize = 127;
/// Kernel centroid against the direct trace's (um), a tenth of the splat's sub-cell.
const CENTROID_TOLERANCE_UM: f64 = 0.1;

#[test]
fn a_decentred_lens_has_an_asymmetric_psf_on_axis_matching_a_direct_trace() {
    let nominal = builtin::lens("cooke_triplet").unwrap();
    let decentred = decentred_cooke();
    assert!(!decentred.is_rotationally_symmetric());
    let centred_psf = tracer(&nominal).field_psf_at([0.0, 0.0], SIZE_PX, true).unwrap();
    let psf = tracer(&decentred)
        .field_psf_at([0.0, 0.0], SIZE_PX, true)
        .unwrap();
    let centred_centroid = centred_psf.kernels[0].centroid_um();
    let centroid = psf.kernels[0].centroid_um();
    let direct = direct_centroid_um(&decentred, [0.0, 0.0]);
    eprintln!("on axis: centred lens centroid {centred_centroid:?} um, decentred {centroid:?} um, direct trace {direct:?} um");
    // The splat places rays on sub-cells of pitch / oversample (1 um here): the kernel centroid is the
    // direct one within CENTROID_TOLERANCE_UM (measured: 0.009 um on axis, 0.03 um at 14 deg).
    for k in 0..2 {
        assert!(
            (centroid[k] - direct[k]).abs() < CENTROID_TOLERANCE_UM,
            "{centroid:?} vs {direct:?}"
        );
        assert!(centred_centroid[k].abs() < 1e-3, "{centred_centroid:?}");
    }
    // The decentre in x throws the on-axis blur sideways (coma), not along y.
    assert!(centroid[0].abs() > 0.1, "{centroid:?}");
    assert!(centroid[1].abs() < 1e-3, "{centroid:?}");
}

#[test]
fn a_decentred_lens_psf_depends_on_the_field_azimuth() {
    let field_deg = 14.0;
    let nominal = tracer(&builtin::lens("cooke_triplet").unwrap());
    let decentred_lens = decentred_cooke();
    let decentred = tracer(&decentred_lens);
    let at = |t: &PsfTracer, x: f64| t.field_psf_at([x, 0.0], SIZE_PX, true).unwrap();
    let (centred_plus, centred_minus) = (at(&nominal, field_deg), at(&nominal, -field_deg));
    let (plus, minus) = (at(&decentred, field_deg), at(&decentred, -field_deg));
    let centred_asymmetry = mirrored_half_l1(&centred_plus.kernels[0], &centred_minus.kernels[0]);
    let asymmetry = mirrored_half_l1(&plus.kernels[0], &minus.kernels[0]);
    eprintln!(
        "+-{field_deg} deg in x: mirrored half-L1 centred {centred_asymmetry:.2e}, decentred {asymmetry:.3}"
    );
    assert!(centred_asymmetry < 1e-5, "{centred_asymmetry}");
    assert!(asymmetry > 0.05, "{asymmetry}");
    // And each is what a direct trace gives.
    for (psf, x) in [(&plus, field_deg), (&minus, -field_deg)] {
        let centroid = psf.kernels[0].centroid_um();
        let direct = direct_centroid_um(&decentred_lens, [x, 0.0]);
        for k in 0..2 {
            assert!(
                (centroid[k] - direct[k]).abs() < CENTROID_TOLERANCE_UM,
                "{x}: {centroid:?} vs {direct:?}"
            );
        }
    }
    // Along y the decentre moves the chief ray sideways: the image of a y field leaves the y axis.
    let centred_y = nominal.field_psf_at([0.0, field_deg], SIZE_PX, true).unwrap();
    let along_y = decentred.field_psf_at([0.0, field_deg], SIZE_PX, true).unwrap();
    eprintln!(
        "chief ray of (0, {field_deg}) deg: centred {:?} mm, decentred {:?} mm",
        centred_y.reference_mm, along_y.reference_mm
    );
    assert_eq!(centred_y.reference_mm[0], 0.0);
    assert!(along_y.reference_mm[0].abs() > 1e-3, "{:?}", along_y.reference_mm);
}

#[test]
fn fingerprints_follow_every_number_of_the_model_and_stay_put() {
    // The values `unicac psf --json` writes as `lens_sha256` (canonical JSON of the model since
    // 2026-12-05; the Debug-text fingerprints before that differ): pinned, so a change to the model's
    // serialised form is a deliberate one.
    let cooke = builtin::lens("cooke_triplet").unwrap();
    assert_eq!(
        unicac_psf::lens_fingerprint(&cooke),
        "e232797e9085f93ff3ed91e091b3eb27c58884616fb108d8b751ac063edcdad2"
    );
    assert_eq!(
        unicac_psf::lens_fingerprint(&builtin::lens("phone_asphere").unwrap()),
        "9b3c1e26db990c920249ef61706a67c8c4df61a359bef4e2b3a1177a754091c9"
    );
    assert_ne!(
        unicac_psf::lens_fingerprint(&decentred_cooke()),
        unicac_psf::lens_fingerprint(&cooke)
    );
    // One unit in the last place of one thickness is another lens.
    let mut nudged = cooke.clone();
    nudged.surfaces[2].thickness_mm = f64::from_bits(nudged.surfaces[2].thickness_mm.to_bits() + 1);
    assert_ne!(
        unicac_psf::lens_fingerprint(&nudged),
        unicac_psf::lens_fingerprint(&cooke)
    );
}

#[test]
fn a_field_psf_request_reaches_fields_off_the_y_axis() {
    use unicac_psf::{FieldPsfRequest, PsfMode};
    let lens = decentred_cooke();
    let wavelength = lens.primary_wavelength_um();
    let request = |x: f64| {
        FieldPsfRequest::new(PsfMode::Geometric, vec![10.0], vec![wavelength])
            .and_then(|r| r.with_field_x_deg(x))
            .unwrap()
    };
    let psf = |x: f64| request(x).run(&lens).unwrap().psfs.remove(0);
    // The request at (x, y) is the tracer's PSF there: what `unicac psf --field-x-deg` writes.
    let off_axis = psf(-6.0);
    assert_eq!((off_axis.field_x_deg, off_axis.field_deg), (-6.0, 10.0));
    let size = off_axis.kernels[0].size;
    let settings = PsfSettings::new(request(-6.0).pixel_um_for(&lens).unwrap());
    let direct = PsfTracer::new(&lens, SpectralWeights::monochromatic(wavelength), settings)
        .unwrap()
        .field_psf_at([-6.0, 10.0], size, true)
        .unwrap();
    assert_eq!(off_axis.kernels[0].data, direct.kernels[0].data);
    assert_eq!(off_axis.reference_mm, direct.reference_mm);
    // Mirror fields of a decentred lens differ; an x of 0 is the y-only request, key included.
    let mirrored = psf(6.0);
    let sum_x_mm = off_axis.reference_mm[0] + mirrored.reference_mm[0];
    assert!(
        sum_x_mm.abs() > 1e-3,
        "chief rays at -6 and +6 deg mirror each other: {sum_x_mm}"
    );
    let along_y = FieldPsfRequest::new(PsfMode::Geometric, vec![10.0], vec![wavelength]).unwrap();
    assert_eq!(
        request(0.0).key_bytes(&lens).unwrap(),
        along_y.key_bytes(&lens).unwrap()
    );
    assert_ne!(
        request(-6.0).key_bytes(&lens).unwrap(),
        along_y.key_bytes(&lens).unwrap()
    );
    // Refused by name: out of range, and in the wave mode (which traces fields along y only).
    let error = |r: Result<FieldPsfRequest, unicac_psf::PsfError>| r.unwrap_err().to_string();
    let base = || FieldPsfRequest::new(PsfMode::Geometric, vec![10.0], vec![wavelength]);
    assert!(error(base().and_then(|r| r.with_field_x_deg(f64::NAN))).contains("field_x_deg"));
    let wave = FieldPsfRequest::new(PsfMode::Wave, vec![10.0], vec![wavelength]);
    assert!(error(wave.and_then(|r| r.with_field_x_deg(3.0))).contains("fields along y only"));
}
