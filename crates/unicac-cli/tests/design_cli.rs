//! `unicac design` through the real binary: the command line that checks outside the project call, the
//! files it writes (unicac JSON and .zmx, read back by `unicac lens info`), resume, and clear errors.

use serde_json::Value;
use std::path::PathBuf;
use std::process::{Command, Output};

fn unicac(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(args)
        .output()
        .expect("run unicac")
}

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-design-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    dir
}

#[test]
fn design_writes_zmx_and_json_lenses_and_resumes() {
    let out = scratch("lib");
    let out_text = out.to_str().unwrap();
    let args = [
        "design",
        "--elements",
        "2",
        "--half-fov-deg",
        "20",
        "--f-number",
        "4",
        "--stop",
        "middle",
        "--focal-length-mm",
        "50",
        "--count",
        "2",
        "--seed",
        "3",
        "--time-budget-s",
        "20",
        "--out",
        out_text,
        "--json",
    ];
    let run = unicac(&args);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    let summary: Value = serde_json::from_slice(&run.stdout).unwrap();
    let lenses = summary["lenses"].as_array().unwrap();
    assert!(!lenses.is_empty(), "no lens within 20 s");
    for lens in lenses {
        for key in ["json", "zmx"] {
            let path = out.join(lens[key].as_str().unwrap());
            let info = unicac(&["lens", "info", path.to_str().unwrap(), "--json"]);
            assert!(info.status.success(), "{}", String::from_utf8_lossy(&info.stderr));
            let info: Value = serde_json::from_slice(&info.stdout).unwrap();
            let efl = info["efl_mm"].as_f64().unwrap();
            assert!((efl - 50.0).abs() < 0.5, "{key}: efl {efl}");
        }
        assert!(out
            .join(lens["json"].as_str().unwrap().replace(".json", ".report.json"))
            .exists());
    }
    let manifest = std::fs::read_to_string(out.join("manifest.csv")).unwrap();
    assert_eq!(manifest.lines().count(), lenses.len() + 1);
    // Rerunning the finished job keeps the library as it is.
    let again = unicac(&args);
    assert!(again.status.success());
    assert_eq!(
        std::fs::read_to_string(out.join("manifest.csv")).unwrap(),
        manifest
    );
}

#[test]
fn design_rejects_bad_specifications_clearly() {
    let out = scratch("bad");
    let out_text = out.to_str().unwrap();
    let base = [
        "design",
        "--half-fov-deg",
        "20",
        "--f-number",
        "4",
        "--out",
        out_text,
    ];
    let run = unicac(&[&base[..], &["--elements", "7", "--stop", "front"]].concat());
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("elements"));
    let run = unicac(&[&base[..], &["--elements", "2", "--stop", "sideways"]].concat());
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("front, middle or back"));
    let run = unicac(
        &[
            &base[..],
            &["--elements", "2", "--stop", "front", "--sensor", "36"],
        ]
        .concat(),
    );
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("WIDTHxHEIGHT"));
    let run = unicac(
        &[
            &base[..],
            &[
                "--elements",
                "2",
                "--stop",
                "front",
                "--evaluations-per-spec",
                "0",
            ],
        ]
        .concat(),
    );
    assert!(!run.status.success());
    assert!(String::from_utf8_lossy(&run.stderr).contains("--evaluations-per-spec: 0 must lie in"));
    assert!(!out.exists(), "a refused run made its output folder");
}

#[test]
fn list_specs_gives_the_run_order_and_one_cell_grids_select_each_spec() {
    let out = scratch("list");
    let out_text = out.to_str().unwrap();
    let list = |extra: &[&str]| -> Vec<Value> {
        let run = unicac(&[&["design", "--out", out_text, "--list-specs"][..], extra].concat());
        assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
        String::from_utf8_lossy(&run.stdout)
            .lines()
            .map(|l| serde_json::from_str(l).unwrap())
            .collect()
    };
    let grid = list(&[
        "--grid",
        "--grid-elements",
        "2,1",
        "--grid-half-fov-deg",
        "30,20",
        "--grid-f-numbers",
        "4",
        "--grid-stops",
        "middle,front",
        "--sensor",
        "36x24",
    ]);
    let slugs: Vec<&str> = grid.iter().map(|s| s["slug"].as_str().unwrap()).collect();
    // The run order: by elements (stable), within that half field then F-number then stop as given; a
    // singlet has no middle stop; with --sensor the focal length follows the half field.
    assert_eq!(
        slugs,
        [
            "e1_h30_f4_front_f37p47",
            "e1_h20_f4_front_f59p437",
            "e2_h30_f4_middle_f37p47",
            "e2_h30_f4_front_f37p47",
            "e2_h20_f4_middle_f59p437",
            "e2_h20_f4_front_f59p437",
        ]
    );
    // Each line's grid values, given back as a one-cell grid, select exactly that spec.
    for spec in &grid {
        let cell = list(&[
            "--grid",
            "--grid-elements",
            &spec["grid_elements"].to_string(),
            "--grid-half-fov-deg",
            &spec["grid_half_fov_deg"].to_string(),
            "--grid-f-numbers",
            &spec["grid_f_numbers"].to_string(),
            "--grid-stops",
            spec["grid_stops"].as_str().unwrap(),
            "--sensor",
            "36x24",
        ]);
        assert_eq!(cell.len(), 1);
        assert_eq!(cell[0]["slug"], spec["slug"]);
    }
    assert!(!out.exists(), "--list-specs wrote {}", out.display());
}
