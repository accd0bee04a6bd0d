//! Issue 28, the bench / design / simulate / lens-file half, through the real binary: outputs never land
//! in an input folder, a report folder holds one run, every float option has a checked range, memory and
//! file sizes have stated limits checked before any work, and a cut lens file is never another lens.
//! Each test failed (or panicked, or hung) before its fix.

use std::process::Command;

#[path = "support/rel.rs"]
mod rel;

use rel::{dataset, files, ok, refused, s, scratch};

/// Case 4: `dataset plot DS --out DS/test/lq/X.png` overwrote a dataset image (rc 0).
#[test]
fn dataset_plot_never_writes_into_the_dataset() {
    let ds = dataset();
    let lq = std::fs::read_dir(ds.join("test/lq"))
        .unwrap()
        .next()
        .unwrap()
        .unwrap()
        .path();
    let before = std::fs::read(&lq).unwrap();
    refused(
        &["dataset", "plot", s(ds), "--out", s(&lq)],
        &["--out", "inside the input folder"],
    );
    assert_eq!(std::fs::read(&lq).unwrap(), before);
    let inside = ds.join("levels.png");
    refused(
        &["dataset", "plot", s(ds), "--out", s(&inside)],
        &["--out", "inside the input folder"],
    );
    assert!(!inside.exists());
    let out = scratch("plot");
    refused(
        &["dataset", "plot", s(ds), "--out", s(&out.join("levels.jpg"))],
        &["--out", ".png or .svg"],
    );
    ok(&["dataset", "plot", s(ds), "--out", s(&out.join("levels.png"))]);
}

/// Case 7: a reused report folder kept the previous run's pictures and images beside the new results.
#[test]
fn a_reused_report_folder_holds_the_new_run_only() {
    let ds = dataset();
    let root = scratch("reuse");
    let report = root.join("report");
    ok(&[
        "bench",
        "--dataset",
        s(ds),
        "--method",
        "wiener",
        "--save-images",
        "--metrics",
        "psnr,ssim",
        "--out",
        s(&report),
    ]);
    let first = files(&report);
    assert!(first.iter().any(|f| f.starts_with("images/wiener/")), "{first:?}");
    ok(&[
        "bench",
        "--dataset",
        s(ds),
        "--metrics",
        "psnr",
        "--benchmarks",
        "ode",
        "--out",
        s(&report),
    ]);
    let second = files(&report);
    assert!(!second.iter().any(|f| f.starts_with("images/")), "{second:?}");
    let results = std::fs::read_to_string(report.join("results.json")).unwrap();
    assert!(!results.contains("\"wiener\""), "{results}");
    // A third run's files are exactly the second's: nothing of the first remains.
    ok(&[
        "bench",
        "--dataset",
        s(ds),
        "--metrics",
        "psnr",
        "--benchmarks",
        "ode",
        "--out",
        s(&report),
    ]);
    assert_eq!(files(&report), second);
    // A folder holding the user's files is refused before any work, and left as it was.
    let mine = root.join("mine");
    std::fs::create_dir_all(&mine).unwrap();
    std::fs::write(mine.join("notes.txt"), b"mine").unwrap();
    refused(
        &["bench", "--dataset", s(ds), "--out", s(&mine)],
        &["--out", "notes.txt", "not part of a bench report"],
    );
    assert_eq!(files(&mine), ["notes.txt"]);
}

/// `bench` checked `--out` only when writing the report, after all the work.
#[test]
fn bench_checks_its_report_folder_before_any_work() {
    let ds = dataset();
    let root = scratch("out-first");
    let file = root.join("file");
    std::fs::write(&file, b"x").unwrap();
    refused(
        &["bench", "--dataset", s(ds), "--out", s(&file)],
        &["--out", "not a folder"],
    );
    refused(
        &["bench", "--dataset", s(ds), "--out", s(&file.join("report"))],
        &["file"],
    );
    assert_eq!(std::fs::read(&file).unwrap(), b"x");
}

/// Case 10: `--wiener-nsr NaN` gave rc 0 and an empty Wiener row that was still ranked.
#[test]
fn bench_float_options_have_checked_ranges() {
    let ds = dataset();
    let out = scratch("nsr").join("report");
    for nsr in ["NaN", "0", "-1", "inf", "1e300"] {
        refused(
            &[
                "bench",
                "--dataset",
                s(ds),
                "--method",
                "wiener",
                &format!("--wiener-nsr={nsr}"),
                "--out",
                s(&out),
            ],
            &["--wiener-nsr", "(0, 100]"],
        );
    }
    for gb in ["NaN", "0", "-2", "inf"] {
        refused(
            &[
                "bench",
                "--dataset",
                s(ds),
                &format!("--max-memory-gb={gb}"),
                "--out",
                s(&out),
            ],
            &["--max-memory-gb"],
        );
    }
    assert!(!out.exists());
}

/// A frame the dataset allows aborted on allocation: the memory a run needs is estimated from the
/// largest test pair before any work and refused with the figure and the flags that lower it.
#[test]
fn bench_refuses_a_run_beyond_the_memory_limit_with_the_figure() {
    let ds = dataset();
    let out = scratch("memory").join("report");
    let message = refused(
        &[
            "bench",
            "--dataset",
            s(ds),
            "--max-memory-gb",
            "0.001",
            "--out",
            s(&out),
        ],
        &["64 x 48 px", "GB", "--max-memory-gb allows", "--frame"],
    );
    assert!(message.contains("0.3 GB"), "{message}");
    assert!(!out.exists());
}

/// Case 10 and the Duration panic: every float option of `design` has a checked range, checked
/// before the library folder is made.
#[test]
fn design_float_options_have_checked_ranges() {
    let out = scratch("design").join("lib");
    let base = [
        "design",
        "--elements",
        "2",
        "--half-fov-deg",
        "20",
        "--f-number",
        "4",
        "--stop",
        "front",
        "--out",
        s(&out),
    ];
    for (extra, expected) in [
        (&["--max-rms-um", "NaN"][..], &["--max-rms-um", "NaN"][..]),
        (&["--max-rms-um=-1"], &["--max-rms-um"]),
        (
            &["--focal-length-mm", "1e-300"],
            &["--focal-length-mm", "[1, 10000] mm"],
        ),
        (&["--focal-length-mm", "NaN"], &["--focal-length-mm"]),
        (&["--focal-length-mm", "1e300"], &["--focal-length-mm"]),
        (
            &["--time-budget-s", "1e300"],
            &["--time-budget-s", "MAX_TIME_BUDGET_S"],
        ),
        (&["--time-budget-s", "NaN"], &["--time-budget-s"]),
        (&["--min-air-edge-mm", "inf"], &["--min-air-edge-mm"]),
        (
            &["--min-glass-edge-mm", "1e9"],
            &["--min-glass-edge-mm", "longest track"],
        ),
        (&["--sensor", "1e-300x1e-300"], &["--sensor"]),
        (&["--sensor", "infxinf"], &["--sensor"]),
        (&["--count", "0"], &["--count"]),
    ] {
        refused(&[&base[..], extra].concat(), expected);
        assert!(!out.exists(), "{extra:?} made the library folder");
    }
    refused(
        &["design", "--grid", "--grid-half-fov-deg", "NaN", "--out", s(&out)],
        &["--grid-half-fov-deg"],
    );
}

/// `simulate --sensor-bits 1..6` was advertised and always failed (black level 64 DN >= white level).
#[test]
fn simulate_accepts_exactly_the_sensor_depths_that_work() {
    let dir = scratch("bits");
    let image = dir.join("e.png");
    ok(&["chart", "slanted-edge", "--size", "48x32", "--out", s(&image)]);
    refused(
        &[
            "simulate",
            "builtin:cooke_triplet",
            s(&image),
            "--out",
            s(&dir.join("o6")),
            "--sensor-bits",
            "6",
            "--device",
            "cpu",
            "--no-cache",
        ],
        &["--sensor-bits", "7..=16"],
    );
    let help = String::from_utf8_lossy(&ok(&["simulate", "--help"]).stdout).into_owned();
    assert!(help.contains("(7-16;"), "{help}");
    ok(&[
        "simulate",
        "builtin:cooke_triplet",
        s(&image),
        "--out",
        s(&dir.join("o7")),
        "--sensor-bits",
        "7",
        "--device",
        "cpu",
        "--no-cache",
    ]);
    assert!(dir.join("o7/e.png").is_file());
}

/// Case 9 as the issue found it: the double Gauss (12 surfaces, EFL 100 mm) converted to .zmx and cut
/// before SURF 9 loaded as an 8-surface lens with EFL -133.65 mm, rc 0.
#[test]
fn a_zmx_cut_at_a_surface_boundary_is_refused() {
    let dir = scratch("zmx");
    let zmx = dir.join("dg.zmx");
    ok(&["lens", "convert", "builtin:double_gauss", s(&zmx)]);
    let text = std::fs::read_to_string(&zmx).unwrap();
    let info = String::from_utf8_lossy(&ok(&["lens", "info", s(&zmx), "--json"]).stdout).into_owned();
    assert!(info.contains("\"efl_mm\": 100"), "{info}");
    for k in 3..=12 {
        let cut = dir.join(format!("cut{k}.zmx"));
        std::fs::write(&cut, &text[..text.find(&format!("\nSURF {k}\n")).unwrap() + 1]).unwrap();
        refused(&["lens", "info", s(&cut)], &["cut", "truncated"]);
    }
    let mid = dir.join("mid.zmx");
    std::fs::write(&mid, &text[..text.len() - 3]).unwrap();
    refused(&["lens", "info", s(&mid)], &["mid.zmx", "without a line break"]);
}

/// `lens info /dev/zero` ate memory; a FIFO hung; files had no size cap.
#[test]
fn lens_and_image_inputs_are_regular_files_within_a_stated_size() {
    let dir = scratch("inputs");
    refused(
        &["lens", "info", "/dev/zero"],
        &["/dev/zero", "not a regular file (a character device)"],
    );
    refused(&["lens", "info", s(&dir)], &["not a regular file (a folder)"]);
    let fifo = dir.join("lens.json");
    if Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|st| st.success())
    {
        refused(&["lens", "info", s(&fifo)], &["a FIFO"]);
        refused(&["mtf", s(&fifo)], &["a FIFO"]);
    }
    let big = dir.join("big.zmx");
    std::fs::File::create(&big).unwrap().set_len(17 << 20).unwrap();
    refused(&["lens", "info", s(&big)], &["big.zmx", "MAX_LENS_FILE_BYTES"]);
    let image = dir.join("e.png");
    ok(&["chart", "slanted-edge", "--size", "48x32", "--out", s(&image)]);
    refused(
        &["metrics", "/dev/zero", s(&image)],
        &["/dev/zero", "not a regular file"],
    );
    refused(
        &[
            "simulate",
            "builtin:singlet",
            "/dev/zero",
            "--out",
            s(&dir.join("o")),
            "--format",
            "png",
            "--device",
            "cpu",
        ],
        &["/dev/zero", "a character device"],
    );
}

/// Found while probing: `simulate --pixel-um 1e-300` panicked ("attempt to add with overflow" sizing
/// the kernel) and `--pixel-um 1e300` made an image of one enormous pixel with rc 0.
#[test]
fn simulate_pixel_pitch_has_a_stated_range() {
    let dir = scratch("pitch");
    let image = dir.join("e.png");
    ok(&["chart", "slanted-edge", "--size", "48x32", "--out", s(&image)]);
    for pitch in ["1e-300", "1e300", "NaN", "-1", "0"] {
        refused(
            &[
                "simulate",
                "builtin:singlet",
                s(&image),
                "--out",
                s(&dir.join("o")),
                &format!("--pixel-um={pitch}"),
                "--device",
                "cpu",
                "--no-cache",
            ],
            &["pixel_um", "[0.001, 100000] um"],
        );
    }
    refused(
        &[
            "psf",
            "builtin:singlet",
            "--field-deg",
            "0",
            "--pixel-um=1e-300",
            "--out",
            s(&dir.join("k.exr")),
            "--device",
            "cpu",
            "--no-cache",
        ],
        &["[0.001, 100000] um"],
    );
}
