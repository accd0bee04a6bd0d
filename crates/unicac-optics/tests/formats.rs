//! Lens file formats: exact round trips, Zemax encodings, and clear errors for bad input.

use std::path::Path;
use unicac_optics::format::{json, zmx};
use unicac_optics::spec::{ApertureSpec, FieldSpec, MaterialSpec, SurfaceType};
use unicac_optics::{builtin, Lens, OpticsError};

fn temp_dir() -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "unicac-formats-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

#[test]
fn json_to_zmx_to_json_round_trips_exactly_for_every_bundled_lens() {
    for name in builtin::names() {
        let spec = builtin::spec(name).unwrap();
        let zmx_text = zmx::to_string(&spec);
        let back = zmx::parse(zmx_text.as_bytes(), Path::new("x.zmx")).unwrap();
        assert!(back.warnings.is_empty(), "{name}: {:?}", back.warnings);
        let mut expected = spec.clone();
        // .zmx carries no sensor; everything else must come back bit for bit.
        expected.sensor = None;
        assert_eq!(back.spec, expected, "{name}");
        assert_eq!(json::to_string(&back.spec), json::to_string(&expected), "{name}");
    }
}

#[test]
fn json_text_round_trips_exactly() {
    for name in builtin::names() {
        let spec = builtin::spec(name).unwrap();
        let text = json::to_string(&spec);
        assert_eq!(
            json::parse(text.as_bytes(), Path::new("x.json")).unwrap(),
            spec,
            "{name}"
        );
    }
}

/// A small hand-written Zemax file in the style OpticStudio writes.
const ZEMAX_SAMPLE: &str = "VERS 140716 214 54014 L54014\nMODE SEQ\nNAME Test doublet\nUNIT MM X W X CM MR CPMM\nENPD 1.0E+1\nFTYP 0 0 3 3 0 0 0\nXFLN 0 0 0 0 0 0 0 0 0 0 0 0\nYFLN 0 7 10 0 0 0 0 0 0 0 0 0\nFWGN 1 1 1 1 1 1 1 1 1 1 1 1\nWAVM 1 0.4861327 1\nWAVM 2 0.5875618 2\nWAVM 3 0.6562725 1\nPWAV 2\nGCAT SCHOTT\nRAIM 0 0 1 1 0 0 0 0 0\nSURF 0\n  TYPE STANDARD\n  CURV 0.0 0 0 0 0 \"\"\n  HIDE 0 0 0 0 0 0 0 0 0 0\n  DISZ INFINITY\nSURF 1\n  STOP\n  TYPE STANDARD\n  CURV 1.6129032258064516E-2 0 0 0 0 \"\"\n  DISZ 6\n  GLAS N-BK7 0 0 1.5168 64.17 0 0 0 0 0 0\n  DIAM 6 1 0 0 1 \"\"\nSURF 2\n  TYPE EVENASPH\n  CURV -2.3E-2 0 0 0 0 \"\"\n  PARM 1 0\n  PARM 2 1.5E-5\n  PARM 3 -2E-8\n  CONI -0.5\n  DISZ 2.5\n  GLAS ___BLANK 1 0 1.6727 32.2 0 0 0 0 0 0\nSURF 3\n  TYPE STANDARD\n  CURV -4.0E-3\n  DISZ 95\nSURF 4\n  TYPE STANDARD\n  CURV 0\n  DISZ 0\n";

fn check_sample(spec: &unicac_optics::LensSpec) {
    assert_eq!(spec.name, "Test doublet");
    assert_eq!(spec.aperture, ApertureSpec::EntrancePupilDiameterMm(10.0));
    assert_eq!(spec.fields, FieldSpec::AnglesDeg(vec![0.0, 7.0, 10.0]));
    assert_eq!(spec.wavelengths.len(), 3);
    assert_eq!(spec.wavelengths[1].weight, 2.0);
    assert_eq!(spec.primary_wavelength_index, Some(1));
    assert_eq!(spec.surfaces.len(), 4);
    assert!(spec.surfaces[0].stop);
    assert_eq!(
        spec.surfaces[0].material,
        Some(MaterialSpec::Named("N-BK7".into()))
    );
    assert_eq!(spec.surfaces[0].semi_diameter_mm, Some(6.0));
    let asphere = &spec.surfaces[1];
    assert_eq!(asphere.surface_type, SurfaceType::EvenAsphere);
    // PARM n is the coefficient of r^(2n).
    assert_eq!(asphere.aspheric_coefficients, vec![0.0, 1.5e-5, -2e-8]);
    assert_eq!(asphere.conic, -0.5);
    assert_eq!(
        asphere.material,
        Some(MaterialSpec::Model { nd: 1.6727, vd: 32.2 })
    );
    assert_eq!(spec.surfaces[2].thickness_mm, 95.0);
    Lens::from_spec(spec).unwrap();
}

#[test]
fn reads_zemax_in_utf8_and_utf16() {
    let utf8 = zmx::parse(ZEMAX_SAMPLE.as_bytes(), Path::new("a.zmx")).unwrap();
    check_sample(&utf8.spec);
    let mut utf16le = vec![0xFF, 0xFE];
    utf16le.extend(ZEMAX_SAMPLE.encode_utf16().flat_map(|u| u.to_le_bytes()));
    check_sample(&zmx::parse(&utf16le, Path::new("b.zmx")).unwrap().spec);
    let mut utf16be = vec![0xFE, 0xFF];
    utf16be.extend(ZEMAX_SAMPLE.encode_utf16().flat_map(|u| u.to_be_bytes()));
    check_sample(&zmx::parse(&utf16be, Path::new("c.zmx")).unwrap().spec);
    let no_bom: Vec<u8> = ZEMAX_SAMPLE
        .encode_utf16()
        .flat_map(|u| u.to_le_bytes())
        .collect();
    check_sample(&zmx::parse(&no_bom, Path::new("d.zmx")).unwrap().spec);
}

#[test]
fn unsupported_zemax_features_are_named() {
    let text = ZEMAX_SAMPLE.replace("SURF 3\n  TYPE STANDARD", "SURF 3\n  TYPE TOROIDAL\n  DECX 0.1");
    let err = zmx::parse(text.as_bytes(), Path::new("t.zmx")).unwrap_err();
    let message = err.to_string();
    assert!(matches!(err, OpticsError::UnsupportedZemax { .. }));
    assert!(
        message.contains("TYPE TOROIDAL") && message.contains("DECX"),
        "{message}"
    );
    assert!(message.contains("t.zmx"), "{message}");
    let unknown = ZEMAX_SAMPLE.replace("PWAV 2", "PWAV 2\nZZZZ 1 2 3");
    let loaded = zmx::parse(unknown.as_bytes(), Path::new("u.zmx")).unwrap();
    assert_eq!(loaded.warnings, vec!["ZZZZ (keyword ignored)".to_string()]);
}

#[test]
fn bad_numbers_in_zemax_name_the_line() {
    let text = ZEMAX_SAMPLE.replace("DISZ 2.5", "DISZ two");
    let message = zmx::parse(text.as_bytes(), Path::new("n.zmx"))
        .unwrap_err()
        .to_string();
    assert!(message.starts_with("n.zmx:35:"), "{message}");
    assert!(message.contains("'two' is not a number"), "{message}");
}

#[test]
fn json_errors_name_file_line_and_field() {
    let broken = "{\n  \"format_version\": 1,\n  \"aperture\": {\"f_number\": 4.0},\n  \"fields\": {\"angles_deg\": [0]},\n  \"wavelengths\": [{\"wavelength_um\": 0.55}],\n  \"surfaces\": [{\"thickness_mm\": \"x\"}]\n}";
    let message = json::parse(broken.as_bytes(), Path::new("bad.json"))
        .unwrap_err()
        .to_string();
    assert!(message.starts_with("bad.json:6:"), "{message}");
    let unknown_key = broken.replace("\"thickness_mm\": \"x\"", "\"thicknes_mm\": 1");
    let message = json::parse(unknown_key.as_bytes(), Path::new("k.json"))
        .unwrap_err()
        .to_string();
    assert!(message.contains("thicknes_mm"), "{message}");
}

#[test]
fn invalid_lenses_name_the_field() {
    let mut spec = builtin::spec("cooke_triplet").unwrap();
    spec.surfaces[2].material = Some(MaterialSpec::Named("N-BK8".into()));
    let message = Lens::from_spec(&spec).unwrap_err().to_string();
    assert!(
        message.contains("unknown glass 'N-BK8'") && message.contains("N-BK7"),
        "{message}"
    );
    let mut spec = builtin::spec("cooke_triplet").unwrap();
    spec.surfaces[1].stop = true;
    assert!(Lens::from_spec(&spec)
        .unwrap_err()
        .to_string()
        .contains("surfaces[].stop"));
    let mut spec = builtin::spec("cooke_triplet").unwrap();
    spec.surfaces[0].semi_diameter_mm = Some(-1.0);
    assert!(Lens::from_spec(&spec)
        .unwrap_err()
        .to_string()
        .contains("surfaces[0].semi_diameter_mm"));
    let mut spec = builtin::spec("cooke_triplet").unwrap();
    spec.wavelengths[0].wavelength_um = 12.0;
    assert!(matches!(
        Lens::from_spec(&spec).unwrap_err(),
        OpticsError::WavelengthOutOfRange { .. }
    ));
}

#[test]
fn written_files_are_complete_or_absent() {
    let dir = temp_dir();
    let spec = builtin::spec("double_gauss").unwrap();
    for file in ["a.json", "a.zmx"] {
        let path = dir.join(file);
        unicac_optics::write_spec(&spec, &path).unwrap();
        let loaded = unicac_optics::read_spec(&path).unwrap();
        assert_eq!(loaded.spec.surfaces, spec.surfaces);
    }
    let missing_dir = dir.join("no/such/dir/a.json");
    assert!(unicac_optics::write_spec(&spec, &missing_dir).is_err());
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty());
    std::fs::remove_dir_all(dir).unwrap();
}

#[test]
fn the_json_schema_names_every_key_the_writer_emits() {
    let schema: serde_json::Value =
        serde_json::from_str(include_str!("../../../docs/lens-format.schema.json")).unwrap();
    let top = schema["properties"].as_object().unwrap();
    let surface = schema["$defs"]["surface"]["properties"].as_object().unwrap();
    for name in builtin::names() {
        let value = serde_json::to_value(builtin::spec(name).unwrap()).unwrap();
        for key in value.as_object().unwrap().keys() {
            assert!(
                top.contains_key(key),
                "{name}: top-level key {key} missing from the schema"
            );
        }
        for s in value["surfaces"].as_array().unwrap() {
            for key in s.as_object().unwrap().keys() {
                assert!(
                    surface.contains_key(key),
                    "{name}: surface key {key} missing from the schema"
                );
            }
        }
    }
}

/// Issue 16: a `.zmx` cut short (or edited into an inconsistent state) must not load as a smaller lens.
#[test]
fn truncated_or_inconsistent_zemax_files_are_errors() {
    let parse = |text: &str| zmx::parse(text.as_bytes(), Path::new("cut.zmx"));
    // Truncated right after a SURF line: used to load as a lens one surface shorter.
    let cut = &ZEMAX_SAMPLE[..ZEMAX_SAMPLE.find("SURF 4").unwrap() + "SURF 4\n".len()];
    let message = parse(cut).unwrap_err().to_string();
    assert!(
        message.contains("SURF 4") && message.contains("truncated"),
        "{message}"
    );
    // Truncated inside a surface block (CURV kept, DISZ lost).
    let cut = &ZEMAX_SAMPLE[..ZEMAX_SAMPLE.rfind("  DISZ 0").unwrap()];
    let message = parse(cut).unwrap_err().to_string();
    assert!(message.contains("SURF 4 has no DISZ"), "{message}");
    // Surface blocks out of order.
    let message = parse(&ZEMAX_SAMPLE.replace("SURF 3\n", "SURF 5\n"))
        .unwrap_err()
        .to_string();
    assert!(message.contains("expected SURF 3"), "{message}");
    // No stop.
    let message = parse(&ZEMAX_SAMPLE.replace("  STOP\n", ""))
        .unwrap_err()
        .to_string();
    assert!(message.contains("0 surfaces are marked STOP"), "{message}");
    // PWAV naming a wavelength that is not listed.
    let message = parse(&ZEMAX_SAMPLE.replace("PWAV 2", "PWAV 7"))
        .unwrap_err()
        .to_string();
    assert!(message.contains("PWAV 7"), "{message}");
    let message = parse(&ZEMAX_SAMPLE.replace("PWAV 2", "PWAV -1"))
        .unwrap_err()
        .to_string();
    assert!(message.contains("PWAV -1"), "{message}");
    // A negative DIAM is rejected, as JSON rejects a negative semi_diameter_mm.
    let message = parse(&ZEMAX_SAMPLE.replace("DIAM 6 1", "DIAM -6 1"))
        .unwrap_err()
        .to_string();
    assert!(
        message.starts_with("cut.zmx:") && message.contains("DIAM -6"),
        "{message}"
    );
    // The intact sample still loads.
    check_sample(&parse(ZEMAX_SAMPLE).unwrap().spec);
}

/// The lens files of the repository (`lenses/*.json`: the bundled lenses and the others beside them).
fn repository_lenses() -> Vec<(String, String)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../lenses");
    let mut files: Vec<(String, String)> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read_to_string(&p).unwrap())
        })
        .collect();
    files.sort();
    assert!(files.len() >= 7, "{files:?}");
    files
}

/// Issue 28, case 9: a `.zmx` cut at any surface boundary, at any line or inside a line must not load
/// as another lens. Each repository lens is converted to `.zmx` (what `unicac lens convert` writes) and
/// every prefix of the file is read. The only prefixes that load are those cut after the image
/// surface's DISZ 0 line, losing the image surface's DIAM (and CONI): a file without them is a valid
/// lens (the image surface needs no semi-diameter), so such a cut cannot be told apart from a file
/// written that way; the lens it gives has the same surfaces, first-order data and everything else.
#[test]
fn a_zmx_cut_anywhere_is_refused_or_differs_only_in_the_image_surface_aperture() {
    for (name, json_text) in repository_lenses() {
        let spec = json::parse(json_text.as_bytes(), Path::new(&name)).unwrap();
        let text = zmx::to_string(&spec);
        let full = zmx::parse(text.as_bytes(), Path::new("full.zmx")).unwrap().spec;
        let image_line = text.rfind("\nSURF ").unwrap() + 1;
        let image_disz_end =
            image_line + text[image_line..].find("  DISZ 0.0\n").unwrap() + "  DISZ 0.0\n".len();
        let surface_boundaries: Vec<usize> = text.match_indices("\nSURF ").map(|(i, _)| i + 1).collect();
        assert_eq!(surface_boundaries.len(), spec.surfaces.len() + 1, "{name}");
        let mut loaded = 0;
        for cut in (0..text.len()).filter(|&c| text.is_char_boundary(c)) {
            let prefix = &text[..cut];
            match zmx::parse(prefix.as_bytes(), Path::new("cut.zmx")) {
                Err(error) => {
                    let message = error.to_string();
                    assert!(message.starts_with("cut.zmx:"), "{name} cut at {cut}: {message}");
                    if surface_boundaries.contains(&cut) && cut > surface_boundaries[2] {
                        assert!(message.contains("truncated"), "{name} cut at {cut}: {message}");
                    }
                }
                Ok(back) => {
                    loaded += 1;
                    assert!(
                        cut >= image_disz_end,
                        "{name}: cut at byte {cut} (before the image surface's DISZ ends at {image_disz_end}) loads:\n{prefix}"
                    );
                    let mut expected = full.clone();
                    let mut got = back.spec.clone();
                    for s in [&mut expected, &mut got] {
                        let image = s.surfaces.last_mut().unwrap();
                        image.semi_diameter_mm = None;
                        image.conic = 0.0;
                    }
                    assert_eq!(got, expected, "{name} cut at {cut}");
                }
            }
        }
        assert!(
            loaded >= 1,
            "{name}: the whole file is the last prefix that loads"
        );
    }
}

/// The same for the JSON files themselves: any prefix short of the closing brace is a syntax error.
#[test]
fn a_lens_json_cut_anywhere_is_refused() {
    for (name, text) in repository_lenses() {
        let end = text.trim_end().len();
        for cut in (0..end).filter(|&c| text.is_char_boundary(c)) {
            assert!(
                json::parse(&text.as_bytes()[..cut], Path::new("cut.json")).is_err(),
                "{name} cut at {cut} loads"
            );
        }
    }
}

/// The cases the issue names: glass on the image surface, an image surface that is not at DISZ 0 (the
/// surfaces after it are missing), a file that ends inside a record.
#[test]
fn a_zmx_whose_image_surface_cannot_be_one_is_refused() {
    let parse = |text: &str| {
        zmx::parse(text.as_bytes(), Path::new("cut.zmx"))
            .unwrap_err()
            .to_string()
    };
    let glass = ZEMAX_SAMPLE.replace("  CURV 0\n  DISZ 0\n", "  CURV 0\n  DISZ 0\n  GLAS N-BK7\n");
    let message = parse(&glass);
    assert!(
        message.contains("SURF 4") && message.contains("GLAS N-BK7") && message.contains("truncated"),
        "{message}"
    );
    let gap = ZEMAX_SAMPLE.replace("  CURV 0\n  DISZ 0\n", "  CURV 0\n  DISZ 3\n");
    let message = parse(&gap);
    assert!(
        message.contains("SURF 4") && message.contains("DISZ 3") && message.contains("truncated"),
        "{message}"
    );
    let cut = &ZEMAX_SAMPLE[..ZEMAX_SAMPLE.len() - 2];
    let message = parse(cut);
    assert!(
        message.contains("`DISZ`") && message.contains("line break"),
        "{message}"
    );
    // A last line without a line break that is not cut (a hand-edited file) is refused the same way:
    // nothing tells the two apart. Blank trailing lines and a final line break are fine.
    let message = parse(ZEMAX_SAMPLE.trim_end());
    assert!(message.contains("`DISZ 0`"), "{message}");
    zmx::parse(format!("{ZEMAX_SAMPLE}\n  \n").as_bytes(), Path::new("ok.zmx")).unwrap();
}

#[test]
fn a_lens_written_from_its_model_reads_back_as_the_same_model() {
    for name in unicac_optics::builtin::names() {
        let lens = unicac_optics::builtin::lens(name).unwrap();
        let again = Lens::from_spec(&lens.to_spec()).unwrap();
        assert_eq!(format!("{again:?}"), format!("{lens:?}"), "{name}");
        let text = unicac_optics::format::json::to_string(&lens.to_spec());
        let read = Lens::from_spec(
            &unicac_optics::format::json::parse(text.as_bytes(), Path::new("x.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(format!("{read:?}"), format!("{lens:?}"), "{name} through JSON");
    }
}

#[test]
fn an_index_offset_shifts_every_wavelength_and_is_refused_on_air_or_out_of_range() {
    let lens = unicac_optics::builtin::lens("cooke_triplet").unwrap();
    let mut spec = lens.to_spec();
    spec.surfaces[0].index_offset = 0.002;
    let offset = Lens::from_spec(&spec).unwrap();
    for w in [0.45, 0.5876, 0.65] {
        let (a, b) = (
            offset.surfaces[0].medium_after.index(w).unwrap(),
            lens.surfaces[0].medium_after.index(w).unwrap(),
        );
        assert!((a - b - 0.002).abs() < 1e-15, "{w} um: {a} vs {b}");
    }
    assert_eq!(offset.to_spec().surfaces[0].index_offset, 0.002);
    for (surface, value, words) in [(1, 0.002, "air"), (0, 0.5, "within")] {
        let mut bad = lens.to_spec();
        bad.surfaces[surface].index_offset = value;
        let error = Lens::from_spec(&bad).unwrap_err().to_string();
        assert!(
            error.contains(&format!("surfaces[{surface}].index_offset")) && error.contains(words),
            "{error}"
        );
    }
}
