//! Image simulation of lenses that are not rotationally symmetric (issue 36): the planar maps agree
//! with the radial path on a symmetric lens, invert exactly, and carry a decentred lens's own PSFs.

use unicac_image::Planar;
use unicac_optics::{builtin, Lens, Placement};
use unicac_psf::{visible_wavelengths_um, Kernel, PsfTracer, SpectralWeights};
use unicac_sim::{FieldOptics, LensSimulator, PlanarField, SimulationSettings};
use unicac_trace::{Aiming, PupilSampling};

fn quick_settings() -> SimulationSettings {
    let mut settings = SimulationSettings {
        wavelengths: 7,
        node_intervals: 8,
        ..Default::default()
    };
    settings.psf.pupil_sampling = PupilSampling::Fibonacci { n: 1024 };
    // Decentred lenses are always aimed for real (`Aiming::Auto`); so are the symmetric ones here, so
    // that the two paths trace the same rays.
    settings.psf.aiming = Aiming::Real;
    settings
}

/// The Cooke triplet with surface `index` (0-based) placed by `placement`.
fn cooke_with(index: usize, placement: Placement) -> Lens {
    let mut spec = builtin::spec("cooke_triplet").unwrap();
    spec.surfaces[index].set_placement(placement);
    Lens::from_spec(&spec).unwrap()
}

/// The Cooke triplet with a decentre far below any traced quantity's precision: the same optics,
/// sent down the planar path.
fn nudged_cooke() -> Lens {
    cooke_with(
        1,
        Placement {
            decentre_x_mm: 1e-13,
            ..Placement::default()
        },
    )
}

fn planar(sim: &LensSimulator) -> &PlanarField {
    match &sim.optics {
        FieldOptics::Planar(planar) => planar,
        FieldOptics::Radial { .. } => panic!("expected the planar maps"),
    }
}

/// A smooth test scene with detail at several scales.
fn scene(width: usize, height: usize) -> Planar {
    Planar::from_fn(width, height, 3, |c, x, y| {
        let (x, y) = (x as f32, y as f32);
        0.5 + 0.3 * (0.21 * x + c as f32).sin() * (0.17 * y).cos() + 0.1 * (0.05 * (x + y)).sin()
    })
}

fn psnr(a: &Planar, b: &Planar) -> f64 {
    let mse = a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| ((x - y) as f64).powi(2))
        .sum::<f64>()
        / a.data.len() as f64;
    10.0 * (1.0 / mse).log10()
}

fn largest_difference(a: &Planar, b: &Planar) -> f32 {
    a.data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn half_l1(a: &Kernel, b: &Kernel) -> f64 {
    0.5 * a
        .data
        .iter()
        .zip(&b.data)
        .map(|(x, y)| (x - y).abs() as f64)
        .sum::<f64>()
}

/// The kernel mirrored left to right (x -> -x about its centre).
fn mirrored(kernel: &Kernel) -> Kernel {
    let mut out = kernel.clone();
    for row in 0..kernel.size {
        for column in 0..kernel.size {
            out.data[row * kernel.size + column] = kernel.data[row * kernel.size + kernel.size - 1 - column];
        }
    }
    out
}

#[test]
fn a_symmetric_lens_through_the_planar_maps_matches_the_radial_path() {
    let (w, h) = (800, 600);
    let nominal = builtin::lens("cooke_triplet").unwrap();
    let nudged = nudged_cooke();
    assert!(!nudged.is_rotationally_symmetric());
    let radial = LensSimulator::new(&nominal, w, h, None, quick_settings()).unwrap();
    let planar_sim = LensSimulator::new(&nudged, w, h, None, quick_settings()).unwrap();
    assert!(radial.radial().is_some() && planar_sim.radial().is_none());
    assert_eq!(
        radial.grid, planar_sim.grid,
        "the same sensor grid (from the nominal chief ray)"
    );

    // The geometry alone (warp and shading of a sharp image): the landing map against the radial
    // chief-ray table, the Jacobian's illumination against the radial slope's. Most of the difference
    // is the vignetting's interpolation near the corners (17 radii against a 17 x 13 field lattice).
    let image = scene(w, h);
    let (a, b) = (
        radial.geometry(&image).unwrap(),
        planar_sim.geometry(&image).unwrap(),
    );
    let geometry_difference = largest_difference(&a, &b);
    println!("geometry: largest difference {geometry_difference:.2e}");
    assert!(
        geometry_difference < 5e-3,
        "geometry differs by {geometry_difference}"
    );

    // The whole chain: 17 x 13 traced fields interpolated against 17 radii turned into place.
    let (a, b) = (radial.apply(&image).unwrap(), planar_sim.apply(&image).unwrap());
    let agreement = psnr(&a, &b);
    println!(
        "apply: PSNR {agreement:.1} dB, largest difference {:.2e}",
        largest_difference(&a, &b)
    );
    assert!(agreement > 60.0, "PSNR {agreement} dB");

    // The kernels the output sees at points on the axes (off them the radial path turns its kernels
    // by resampling, which is not exact for kernels of a few pixels; the planar path traces the field
    // itself, checked in `a_decentred_lens_blurs_with_its_own_asymmetric_psfs`).
    let [corner_x, corner_y] = radial.grid.to_mm(0.0, 0.0);
    for (fx, fy) in [(0.0, 0.0), (0.5, 0.0), (0.0, -0.7), (-0.9, 0.0), (0.0, 1.0)] {
        let (x, y) = (fx * corner_x, fy * corner_y);
        let worst = (0..3)
            .map(|c| half_l1(&radial.kernel_at(x, y, c), &planar_sim.kernel_at(x, y, c)))
            .fold(0.0, f64::max);
        println!("kernel at ({x:.2}, {y:.2}) mm: half-L1 {worst:.4}");
        assert!(worst < 0.01, "kernel at ({x}, {y}) mm: half-L1 {worst}");
        let angles = (
            radial.field_angle_deg_at(x, y),
            planar_sim.field_angle_deg_at(x, y),
        );
        assert!((angles.0 - angles.1).abs() < 1e-3, "field angle {angles:?}");
    }
}

#[test]
fn the_warp_inverts_the_landing_map_and_a_decentre_moves_the_image() {
    let (w, h) = (200, 150);
    let lens = cooke_with(
        2,
        Placement {
            decentre_x_mm: 0.2,
            tilt_y_deg: 0.3,
            ..Placement::default()
        },
    );
    let sim = LensSimulator::new(&lens, w, h, None, quick_settings()).unwrap();
    let planar = planar(&sim);
    let mut worst = 0.0f64;
    for row in (0..h).step_by(7) {
        for column in (0..w).step_by(5) {
            let real = [column as f64, row as f64];
            let ideal = planar.ideal_for(real, real);
            let landing = planar.landing_px(ideal);
            worst = worst.max((landing[0] - real[0]).hypot(landing[1] - real[1]));
        }
    }
    assert!(worst <= 2e-6, "the inverse misses its pixel by {worst} px");
    // The decentre moves the axis's image sideways (in x, the decentre's direction) but not up.
    let centre = sim.grid.centre_px();
    let landing = planar.landing_px(centre);
    let shift = [landing[0] - centre[0], landing[1] - centre[1]];
    println!("the axis lands {shift:?} px from the centre");
    assert!(shift[0].abs() > 0.5 && shift[1].abs() < 1e-6, "shift {shift:?}");
    assert!(planar.largest_shift_px() >= shift[0].abs());
}

#[test]
fn a_decentred_lens_blurs_with_its_own_asymmetric_psfs() {
    let (w, h) = (200, 150);
    let nominal = builtin::lens("cooke_triplet").unwrap();
    let decentred = cooke_with(
        2,
        Placement {
            decentre_x_mm: 0.2,
            ..Placement::default()
        },
    );
    let settings = quick_settings();
    let sim = LensSimulator::new(&decentred, w, h, None, settings.clone()).unwrap();
    let planar = planar(&sim);

    // Every lattice PSF is the field's own, traced directly at its (x, y) field.
    let weights = SpectralWeights::new(&settings.response, &visible_wavelengths_um(settings.wavelengths));
    let mut psf_settings = settings.psf.clone();
    psf_settings.pixel_um = sim.grid.pitch_um;
    let tracer = PsfTracer::new(&decentred, weights, psf_settings).unwrap();
    let last = planar.psfs.len() - 1;
    for n in [0, last / 2, last] {
        let stored = &planar.psfs[n];
        let field = [stored.field_x_deg, stored.field_deg];
        let direct = tracer.field_psf_at(field, sim.kernel_size(), false).unwrap();
        for c in 0..3 {
            assert_eq!(
                stored.kernels[c].data, direct.kernels[c].data,
                "field {field:?} channel {c}"
            );
        }
    }
    // The top-left frame pixel is the lattice's first node: its kernel is that PSF itself.
    assert_eq!(
        planar.kernel_at_ideal([0.0, 0.0], 1).data,
        planar.psfs[0].kernels[1].data
    );

    // Left and right of the axis: mirror images for the centred lens, not for the decentred one.
    let centred = LensSimulator::new(&nominal, w, h, None, settings).unwrap();
    let x_mm = 0.6 * sim.grid.to_mm(0.0, 0.0)[0].abs();
    let asymmetry =
        |s: &LensSimulator| half_l1(&s.kernel_at(x_mm, 0.0, 1), &mirrored(&s.kernel_at(-x_mm, 0.0, 1)));
    let (centred_asymmetry, decentred_asymmetry) = (asymmetry(&centred), asymmetry(&sim));
    println!("mirror half-L1: centred {centred_asymmetry:.4}, decentred {decentred_asymmetry:.4}");
    assert!(centred_asymmetry < 1e-3, "centred {centred_asymmetry}");
    assert!(decentred_asymmetry > 0.01, "decentred {decentred_asymmetry}");

    // And the simulated image is another one than the centred lens's.
    let image = scene(w, h);
    let agreement = psnr(&centred.apply(&image).unwrap(), &sim.apply(&image).unwrap());
    println!("centred against decentred: PSNR {agreement:.1} dB");
    assert!(agreement < 40.0, "PSNR {agreement} dB");
}

#[test]
fn pixels_beyond_the_largest_field_sample_its_edge_as_the_radial_path_does() {
    // A sensor larger than the lens's field: its corners lie beyond every field the lens has, where
    // fields are taken at the largest one and the landing map is flat. The warp's inversion used to
    // run off there (a tolerance draw's corner became NaN in `dataset build --as-built`).
    let (w, h) = (240, 180);
    let nominal = builtin::lens("cooke_triplet").unwrap();
    let nudged = nudged_cooke();
    let filling = LensSimulator::new(&nominal, w, h, None, quick_settings()).unwrap();
    let pitch_um = filling.grid.pitch_um * 1.25;
    let radial = LensSimulator::new(&nominal, w, h, Some(pitch_um), quick_settings()).unwrap();
    let planar_sim = LensSimulator::new(&nudged, w, h, Some(pitch_um), quick_settings()).unwrap();
    // Beyond the field the corner pixels take the field's edge on their own azimuth, as the radial
    // path does: the ideal position of the largest field, whatever the start.
    let centre = planar_sim.grid.centre_px();
    let mm_per_px = pitch_um * 1e-3;
    let chief = &radial.chief;
    let edge_px = chief.paraxial_height_per_tan_mm() * chief.max_angle_deg().to_radians().tan() / mm_per_px;
    let real_edge_px = chief.max_height_mm() / mm_per_px;
    for real in [
        [0.0, 0.0],
        [(w - 1) as f64, 0.0],
        [(w - 1) as f64, (h - 1) as f64],
        [1.0, (h - 2) as f64],
    ] {
        let ideal = planar(&planar_sim).ideal_for(real, [0.0, (h - 1) as f64]);
        let (ideal_radius, real_radius) = (
            (ideal[0] - centre[0]).hypot(ideal[1] - centre[1]),
            (real[0] - centre[0]).hypot(real[1] - centre[1]),
        );
        let turn = (ideal[1] - centre[1]).atan2(ideal[0] - centre[0])
            - (real[1] - centre[1]).atan2(real[0] - centre[0]);
        assert!(
            real_radius > real_edge_px + 1.0,
            "{real:?} lies beyond the field's image"
        );
        // (Along the circle the projected iteration converges slowly: within 1e-4 rad, 0.012 px here.)
        assert!(
            (ideal_radius - edge_px).abs() < 1e-9 && turn.abs() < 1e-4,
            "{real:?} -> {ideal:?}"
        );
    }
    let image = scene(w, h);
    let (a, b) = (
        radial.geometry(&image).unwrap(),
        planar_sim.geometry(&image).unwrap(),
    );
    assert!(b.data.iter().all(|v| v.is_finite()));
    // Differences remain where the vignetting falls steeply at the field's edge (17 radii against a
    // 16-px chief lattice).
    let agreement = psnr(&a, &b);
    println!("geometry on a sensor beyond the field: PSNR {agreement:.1} dB");
    assert!(agreement > 40.0, "PSNR {agreement} dB");
    // A decentred unit on the same sensor: finite everywhere.
    let unit = cooke_with(
        2,
        Placement {
            decentre_x_mm: 0.2,
            tilt_y_deg: 0.3,
            ..Placement::default()
        },
    );
    let sim = LensSimulator::new(&unit, w, h, Some(pitch_um), quick_settings()).unwrap();
    assert!(sim.apply(&image).unwrap().data.iter().all(|v| v.is_finite()));
}
