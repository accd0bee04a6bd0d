//! Tolerancing checked against direct traces and geometry, and its run folder against kills.

use unicac_analysis::refocused;
use unicac_io::Shard;
use unicac_optics::{builtin, Lens};
use unicac_tolerance::{
    apply, elements, field_points, run_folder, score, Change, ChangeKind, Compensator, FieldPoint, Grading,
    MonteCarlo, ToleranceError, ToleranceSpec,
};
use unicac_trace::{spots, Aiming, PupilSampling};

fn cooke() -> Lens {
    builtin::lens("cooke_triplet").expect("builtin lens")
}

fn grading() -> Grading {
    Grading {
        pupil_grid: 16,
        mtf_frequencies_cy_mm: Vec::new(),
        ode: false,
    }
}

fn change(kind: ChangeKind, surfaces: [usize; 2], value: f64) -> Change {
    Change {
        kind,
        surfaces,
        value,
    }
}

#[test]
fn the_nominal_score_is_the_polychromatic_rms_of_a_direct_trace() {
    let lens = cooke();
    let points = field_points(&lens).unwrap();
    let scored = score(&lens, &points, &grading(), Compensator::None).unwrap();
    assert_eq!(scored.focus_shift_mm, 0.0);
    let wavelengths = lens.wavelengths_um();
    let weights: Vec<f64> = lens.wavelengths.iter().map(|w| w.weight).collect();
    for (point, &rms) in points.iter().zip(&scored.rms_um) {
        let [x, y] = point.field_deg;
        // The rotationally symmetric lens: an x field is the y field turned by 90 degrees.
        let field = if x != 0.0 { x.abs() } else { y.abs() };
        let spot = spots(
            &lens,
            &[field],
            &wavelengths,
            Aiming::Real,
            &PupilSampling::Grid { n: 16 },
        )
        .unwrap();
        let mut sum = [0.0; 3];
        let mut centroid = [0.0; 2];
        let mut total = 0.0;
        for (s, w) in spot.iter().zip(&weights) {
            let per_ray = w / s.points_mm.len() as f64;
            for p in &s.points_mm {
                centroid[0] += per_ray * p[0];
                centroid[1] += per_ray * p[1];
                total += per_ray;
            }
        }
        centroid = centroid.map(|c| c / total);
        for (s, w) in spot.iter().zip(&weights) {
            let per_ray = w / s.points_mm.len() as f64;
            for p in &s.points_mm {
                sum[0] += per_ray * ((p[0] - centroid[0]).powi(2) + (p[1] - centroid[1]).powi(2));
            }
        }
        let expected = (sum[0] / total).sqrt() * 1e3;
        assert!(
            (rms / expected - 1.0).abs() < 1e-9,
            "field {:?}: {rms} against {expected}",
            point.field_deg
        );
    }
}

#[test]
fn the_solved_focus_is_the_traced_optimum() {
    let lens = cooke();
    let unit = apply(
        &lens,
        &[
            change(ChangeKind::Thickness, [2, 2], 0.04),
            change(ChangeKind::ElementDecentreY, [3, 4], 0.02),
            change(ChangeKind::Radius, [5, 5], -0.003),
        ],
    );
    let points = field_points(&lens).unwrap();
    let solved = score(&unit, &points, &grading(), Compensator::BackFocus).unwrap();
    assert!(solved.focus_shift_mm.abs() > 1e-3, "the unit needs refocusing");
    let traced = |shift: f64| {
        score(&refocused(&unit, shift), &points, &grading(), Compensator::None)
            .unwrap()
            .rms_um
    };
    // The criterion: the weighted mean of squared RMS radii.
    let criterion = |rms: &[f64]| points.iter().zip(rms).map(|(p, r)| p.weight * r * r).sum::<f64>();
    let at_solution = traced(solved.focus_shift_mm);
    for (a, b) in at_solution.iter().zip(&solved.rms_um) {
        assert!((a / b - 1.0).abs() < 1e-9, "{a} against {b}");
    }
    for step in [-0.01, 0.01] {
        assert!(criterion(&traced(solved.focus_shift_mm + step)) > criterion(&at_solution));
    }
}

#[test]
fn an_element_moves_as_a_rigid_body_about_its_front_vertex() {
    let lens = cooke();
    let [first, last] = elements(&lens)[0];
    assert_eq!(
        [first, last],
        [0, 1],
        "the Cooke triplet's first element is surfaces 1-2"
    );
    let theta_deg: f64 = 0.5;
    let unit = apply(&lens, &[change(ChangeKind::ElementTiltX, [1, 2], theta_deg)]);
    let thickness = lens.surfaces[0].thickness_mm;
    let back = &unit.surfaces[1];
    let theta = theta_deg.to_radians();
    // Tilting about x by +theta turns the local z axis towards -y.
    assert!((back.placement.decentre_y_mm + thickness * theta.sin()).abs() < 1e-12);
    assert!((back.z_mm - thickness * theta.cos()).abs() < 1e-12);
    assert!((back.placement.tilt_x_deg - theta_deg).abs() < 1e-12);
    assert!((unit.surfaces[0].placement.tilt_x_deg - theta_deg).abs() < 1e-12);
    // The surfaces after the element and the image keep their places.
    for (a, b) in unit.surfaces[2..].iter().zip(&lens.surfaces[2..]) {
        assert_eq!((a.z_mm, a.placement), (b.z_mm, b.placement));
    }
    let decentred = apply(&lens, &[change(ChangeKind::ElementDecentreX, [1, 2], 0.03)]);
    assert!(decentred.surfaces[..2]
        .iter()
        .all(|s| s.placement.decentre_x_mm == 0.03));
    // A thickness error moves every later vertex but the image.
    let thicker = apply(&lens, &[change(ChangeKind::Thickness, [1, 1], 0.05)]);
    let image = lens.image_index();
    for i in 1..image {
        assert!((thicker.surfaces[i].z_mm - lens.surfaces[i].z_mm - 0.05).abs() < 1e-12);
    }
    assert_eq!(thicker.surfaces[image].z_mm, lens.surfaces[image].z_mm);
    assert!(
        (thicker.surfaces[image - 1].thickness_mm - lens.surfaces[image - 1].thickness_mm + 0.05).abs()
            < 1e-12
    );
}

#[test]
fn a_unit_decentred_in_y_grades_the_x_fields_alike_and_the_y_fields_apart() {
    let lens = cooke();
    let unit = apply(&lens, &[change(ChangeKind::ElementDecentreY, [3, 4], 0.05)]);
    let points = field_points(&lens).unwrap();
    let scored = score(&unit, &points, &grading(), Compensator::BackFocus).unwrap();
    let rms_at = |field: [f64; 2]| {
        let i = points
            .iter()
            .position(|p: &FieldPoint| p.field_deg == field)
            .unwrap();
        scored.rms_um[i]
    };
    let f = points.last().unwrap().field_deg[0].abs();
    assert!((rms_at([f, 0.0]) / rms_at([-f, 0.0]) - 1.0).abs() < 1e-9);
    assert!((rms_at([0.0, f]) / rms_at([0.0, -f]) - 1.0).abs() > 1e-3);
    assert!(
        scored.boresight_um > 1.0,
        "a decentred element moves the on-axis image"
    );
}

#[test]
fn the_ode_column_is_the_refocused_units_ode() {
    let lens = cooke();
    let unit = apply(&lens, &[change(ChangeKind::ElementDecentreY, [3, 4], 0.2)]);
    let points = field_points(&lens).unwrap();
    let with_ode = Grading {
        ode: true,
        ..grading()
    };
    let scored = score(&unit, &points, &with_ode, Compensator::BackFocus).unwrap();
    let direct = unicac_ode::evaluate(
        &refocused(&unit, scored.focus_shift_mm),
        &unicac_ode::OdeSettings::default(),
    )
    .unwrap();
    assert_eq!(scored.ode, Some(direct.scores.ode));
    let nominal = score(&lens, &points, &with_ode, Compensator::BackFocus).unwrap();
    let (built, design) = (scored.ode.unwrap(), nominal.ode.unwrap());
    assert!(
        built < design,
        "the decentred unit grades worse: {built} vs {design}"
    );
    // Off, the score carries none and its JSON no key (run files keep their bytes).
    let plain = score(&unit, &points, &grading(), Compensator::BackFocus).unwrap();
    assert_eq!(plain.ode, None);
    assert!(!serde_json::to_string(&plain).unwrap().contains("ode"));
}

/// Every file under `folder` (relative name -> bytes).
fn files(folder: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    let mut out = std::collections::BTreeMap::new();
    for entry in std::fs::read_dir(folder).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            for (name, bytes) in files(&path) {
                out.insert(
                    format!("{}/{name}", path.file_name().unwrap().to_string_lossy()),
                    bytes,
                );
            }
        } else {
            out.insert(
                path.file_name().unwrap().to_string_lossy().into(),
                std::fs::read(&path).unwrap(),
            );
        }
    }
    out
}

#[test]
fn killed_grown_and_sharded_runs_end_with_the_bytes_of_one_run_and_a_foreign_folder_is_refused() {
    let lens = cooke();
    let spec = ToleranceSpec::from_json(
        r#"{"radius_fraction": 0.002, "thickness_mm": 0.05, "element_decentre_mm": 0.025,
            "element_tilt_deg": 0.05, "index": 0.001}"#,
    )
    .unwrap();
    let grading = grading();
    let dir = tempfile::tempdir().unwrap();
    let folder = |name: &str| dir.path().join(name);
    let run = |folder: &std::path::Path, trials: usize, seed: u64, shard: &str| {
        let request = MonteCarlo {
            lens_identity: "cooke".into(),
            spec: spec.clone(),
            grading: grading.clone(),
            seed,
            trials,
        };
        run_folder(
            &lens,
            &request,
            folder,
            Shard::parse(shard).unwrap(),
            &unicac_io::progress::Silent,
        )
    };
    // Three chunk files: 64 + 64 + 2 trials.
    let summary = run(&folder("whole"), 130, 3, "1/1").unwrap().unwrap();
    assert_eq!((summary.trials, summary.failed), (130, 0));
    let whole = files(&folder("whole"));
    assert_eq!(whole.keys().filter(|k| k.starts_with("trials/")).count(), 3);
    // A run of 70 (its last chunk holds 6 trials), a kill that left a temporary and a chunk cut short,
    // then the run of 130: the short chunks are made again.
    let resumed = folder("resumed");
    run(&resumed, 70, 3, "1/1").unwrap();
    std::fs::write(resumed.join("trials/.000002.jsonl.tmp-999999"), "half").unwrap();
    let first = resumed.join("trials/000000.jsonl");
    let text = std::fs::read_to_string(&first).unwrap();
    std::fs::write(&first, &text[..text.len() / 2]).unwrap();
    assert_eq!(run(&resumed, 130, 3, "1/1").unwrap().unwrap(), summary);
    assert_eq!(files(&resumed), whole);
    // Two shards into one folder, then the unsharded run writes the summary.
    let sharded = folder("sharded");
    assert!(run(&sharded, 130, 3, "2/2").unwrap().is_none());
    assert!(run(&sharded, 130, 3, "1/2").unwrap().is_none());
    assert!(!sharded.join("summary.json").exists());
    run(&sharded, 130, 3, "1/1").unwrap();
    assert_eq!(files(&sharded), whole);
    // Units differ from one another, and every metric's yield curve is ordered best first.
    let rms = &summary.statistics[0];
    assert_eq!(rms.metric, "rms_mean_um");
    assert!(rms.yield_curve.windows(2).all(|w| w[0] <= w[1]) && rms.std > 0.0);
    assert!(rms.met_by_50 <= rms.met_by_90 && rms.met_by_90 <= rms.met_by_98);
    match run(&resumed, 130, 4, "1/1") {
        Err(ToleranceError::Folder { reason, .. }) => assert!(reason.contains("seed"), "{reason}"),
        other => panic!("another seed must be refused: {other:?}"),
    }
    let foreign = folder("foreign");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("notes.txt"), "mine").unwrap();
    assert!(matches!(
        run(&foreign, 2, 3, "1/1"),
        Err(ToleranceError::Folder { .. })
    ));
}

#[test]
fn a_lens_without_field_weight_is_refused_not_graded_as_nan() {
    let mut lens = cooke();
    lens.field_weights.iter_mut().for_each(|w| *w = 0.0);
    match field_points(&lens) {
        Err(ToleranceError::Unsupported(message)) => assert!(message.contains("field weights"), "{message}"),
        other => panic!("expected a refusal, got {other:?}"),
    }
}

#[test]
fn a_written_unit_is_the_graded_lens_read_back() {
    let lens = cooke();
    let spec = ToleranceSpec::from_json(
        r#"{"radius_fraction": 0.002, "thickness_mm": 0.05, "surface_decentre_mm": 0.01,
            "element_decentre_mm": 0.025, "element_tilt_deg": 0.05, "index": 0.001}"#,
    )
    .unwrap();
    let request = MonteCarlo {
        lens_identity: "cooke".into(),
        spec: spec.clone(),
        grading: grading(),
        seed: 3,
        trials: 8,
    };
    let points = field_points(&lens).unwrap();
    let dir = tempfile::tempdir().unwrap();
    for trial in [0, 5] {
        let graded = unicac_tolerance::run_trial(&lens, &run_record(&request, &points), trial);
        let expected = graded.score.expect("a graded unit");
        let unit = unicac_tolerance::unit_lens(&lens, &request, trial).unwrap();
        assert!(!unit.is_rotationally_symmetric(), "a decentred unit");
        // Through a lens file and back: the unit at its compensated focus grades as the trial did.
        let path = dir.path().join(format!("unit-{trial}.json"));
        unicac_optics::format::write_spec(&unit.to_spec(), &path).unwrap();
        let (read, _) = unicac_optics::format::load_lens(&path).unwrap();
        let again = score(&read, &points, &grading(), Compensator::None).unwrap();
        for (a, b) in again.rms_um.iter().zip(&expected.rms_um) {
            assert!(
                (a - b).abs() <= 1e-9 * b,
                "trial {trial}: RMS {a} um read back, {b} um graded"
            );
        }
        assert!(
            (again.boresight_um - expected.boresight_um).abs() <= 1e-9,
            "trial {trial}: boresight"
        );
        // An index error survives as `index_offset`; a .zmx file cannot hold it.
        assert!(std::fs::read_to_string(&path).unwrap().contains("index_offset"));
        let zmx = dir.path().join("unit.zmx");
        let refused = unicac_optics::format::write_spec(&unit.to_spec(), &zmx).unwrap_err();
        assert!(refused.to_string().contains("index_offset"), "{refused}");
    }
}

fn run_record(request: &MonteCarlo, points: &[FieldPoint]) -> unicac_tolerance::RunRecord {
    unicac_tolerance::RunRecord {
        format: 1,
        lens: request.lens_identity.clone(),
        spec: request.spec.clone(),
        grading: request.grading.clone(),
        seed: request.seed,
        field_points: points.to_vec(),
    }
}
