//! Lenses from a `unicac design` library folder, and `exclude_flagged` (issue 32): flagged rows are
//! judged by their figures, also in libraries written before the `flags` column existed.

use std::path::Path;
use unicac_dataset::builder::sources::lens_sources;

fn row(id: &str, relative_illumination_edge: f64, lateral_colour_max_um: f64) -> serde_json::Value {
    serde_json::json!({
        "id": id, "spec": "e3_h20_f5_middle_f50", "elements": 3, "half_fov_deg": 20.0, "f_number": 5.0,
        "stop": "middle", "focal_length_mm": 50.0, "aspheric": false, "parent": "", "merit": 1.0,
        "rms_mean_um": 10.0, "rms_max_um": 12.0, "distortion_max_percent": 1.0,
        "relative_illumination_edge": relative_illumination_edge,
        "lateral_colour_max_um": lateral_colour_max_um, "total_track_mm": 60.0, "back_focal_mm": 40.0,
        "efl_mm": 50.0, "glasses": "", "seed": 1, "elapsed_s": 1.0,
        "json": format!("lenses/{id}.json"), "zmx": format!("lenses/{id}.zmx"),
    })
}

#[test]
fn exclude_flagged_leaves_out_the_library_lenses_that_fail_photographic_usefulness() {
    let folder = std::env::temp_dir().join(format!("unicac-library-sources-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&folder);
    let library = folder.join("library");
    std::fs::create_dir_all(library.join("lenses")).unwrap();
    let source = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../lenses");
    for (id, file) in [
        ("good", "cooke_triplet.json"),
        ("dim", "achromat.json"),
        ("fringed", "petzval.json"),
    ] {
        std::fs::copy(
            source.join(file),
            library.join("lenses").join(format!("{id}.json")),
        )
        .unwrap();
    }
    // No `flags` field: a library written before flags existed.
    let rows = [
        row("good", 0.8, 5.0),
        row("dim", 0.2, 5.0),
        row("fringed", 0.8, 80.0),
    ];
    let jsonl: String = rows.iter().map(|r| format!("{r}\n")).collect();
    std::fs::write(library.join("manifest.jsonl"), jsonl).unwrap();
    let out = folder.join("out");
    let arguments = [library.to_string_lossy().into_owned()];
    let all = lens_sources(&arguments, &out, false).unwrap();
    assert_eq!(all.len(), 3);
    let kept = lens_sources(&arguments, &out, true).unwrap();
    let ids: Vec<&str> = kept.iter().map(|s| s.lens_id.as_str()).collect();
    assert_eq!(ids.len(), 1, "{ids:?}");
    assert!(ids[0].starts_with("good-"), "{ids:?}");
    // A library of flagged lenses only: the error says the exclusion emptied it.
    let rows = [row("dim", 0.2, 5.0), row("fringed", 0.8, 80.0)];
    let jsonl: String = rows.iter().map(|r| format!("{r}\n")).collect();
    std::fs::write(library.join("manifest.jsonl"), jsonl).unwrap();
    let error = lens_sources(&arguments, &out, true).unwrap_err();
    match &error {
        unicac_dataset::DatasetError::Setting { field, message } => {
            assert_eq!(field, "exclude_flagged");
            assert!(message.contains("all 2 library lenses are flagged"), "{message}");
        }
        other => panic!("{other}"),
    }
    let _ = std::fs::remove_dir_all(&folder);
}
