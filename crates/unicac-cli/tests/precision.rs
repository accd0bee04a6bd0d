//! 16-bit images keep their precision through `unicac simulate` when the sensor chain is off
//! (issue 11, part 2): with --no-isp --no-noise the output is the optics alone, and must equal a float
//! computation of the same blur (the library's `LensSimulator::apply` on the decoded input, sRGB-encoded
//! and rounded to 16 bits) within one 16-bit code; a smooth ramp must stay smooth (its row-wise second
//! difference shows no quantisation steps). Before the fix a 10-bit sensor read-out was still applied:
//! ~440 distinct codes on the ramp, steps of 145-209 codes.

use std::path::{Path, PathBuf};
use std::process::Command;
use unicac_image::io::{read_image, write_tiff, SampleDepth};
use unicac_image::{color, Planar};
use unicac_sim::{LensSimulator, SimulationSettings};

const LENS: &str = "builtin:cooke_triplet";
const WIDTH: usize = 512;
const HEIGHT: usize = 384;

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("unicac-precision-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// 16-bit sRGB codes of an RGB image whose code at (x, y) is `code(x)`.
fn coded_image(code: impl Fn(usize) -> f64) -> Planar {
    Planar::from_fn(WIDTH, HEIGHT, 3, |_, x, _| (code(x).round() / 65535.0) as f32)
}

/// Runs simulate with the sensor chain and the geometric effects off; returns the output's 16-bit codes.
fn simulate_codes(input: &Planar, dir: &Path, extra: &[&str]) -> Vec<i64> {
    let path = dir.join("input.tif");
    write_tiff(&path, input, SampleDepth::Sixteen).unwrap();
    let out = dir.join("out");
    let mut args = vec![
        "simulate",
        LENS,
        path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--no-isp",
        "--no-noise",
        "--no-illumination",
        "--no-distortion",
        "--no-cache",
    ];
    args.extend_from_slice(extra);
    let output = Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(&args)
        .output()
        .unwrap();
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let written: Vec<PathBuf> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert_eq!(written.len(), 1, "{written:?}");
    let loaded = read_image(&written[0]).unwrap();
    assert_eq!(loaded.bit_depth, 16);
    loaded
        .image
        .data
        .iter()
        .map(|v| (f64::from(*v) * 65535.0).round() as i64)
        .collect()
}

/// The same blur computed here in float: decode, `LensSimulator::apply`, encode, round to 16 bits.
fn float_codes(input: &Planar) -> Vec<i64> {
    let lens = unicac_optics::builtin::lens("cooke_triplet").unwrap();
    let settings = SimulationSettings {
        distortion: false,
        illumination: false,
        cache: None,
        ..Default::default()
    };
    let sim = LensSimulator::new(&lens, WIDTH, HEIGHT, None, settings).unwrap();
    let blurred = sim.apply(&color::srgb_to_linear(input)).unwrap();
    color::linear_to_srgb(&blurred)
        .data
        .iter()
        .map(|v| (f64::from(v.clamp(0.0, 1.0)) * 65535.0).round() as i64)
        .collect()
}

fn worst_difference(a: &[i64], b: &[i64]) -> i64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).max().unwrap()
}

#[test]
fn a_16_bit_ramp_keeps_full_precision_with_the_sensor_chain_off() {
    let dir = scratch("ramp");
    let ramp = coded_image(|x| 10_000.0 + 45_000.0 * x as f64 / (WIDTH - 1) as f64);
    let ours = simulate_codes(&ramp, &dir, &[]);
    let reference = float_codes(&ramp);
    let worst = worst_difference(&ours, &reference);
    println!("ramp: worst difference from the float blur {worst} codes");
    assert!(
        worst <= 1,
        "{worst} codes from the float computation of the same blur"
    );
    let mut distinct = ours[..WIDTH * HEIGHT].to_vec();
    distinct.sort_unstable();
    distinct.dedup();
    println!("ramp: {} distinct codes in the red plane", distinct.len());
    assert!(
        distinct.len() >= WIDTH - 2,
        "only {} distinct codes",
        distinct.len()
    );
    // Row-wise second difference of the green plane, away from the borders: a linear ramp in code
    // values stays smooth (sRGB curvature and blur give a few codes at most; a 10-bit step is ~150).
    let green = &ours[WIDTH * HEIGHT..2 * WIDTH * HEIGHT];
    let margin = 32;
    let mut steepest = 0;
    for y in margin..HEIGHT - margin {
        let row = &green[y * WIDTH..(y + 1) * WIDTH];
        for x in margin..WIDTH - margin {
            steepest = steepest.max((row[x + 1] - 2 * row[x] + row[x - 1]).abs());
        }
    }
    println!("ramp: largest row-wise second difference {steepest} codes");
    assert!(
        steepest <= 3,
        "second difference {steepest} codes: quantisation steps"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_16_bit_flat_field_stays_flat_with_the_sensor_chain_off() {
    let dir = scratch("flat");
    let flat = coded_image(|_| 30_000.0);
    let ours = simulate_codes(&flat, &dir, &[]);
    let worst = worst_difference(&ours, &float_codes(&flat));
    println!("flat: worst difference from the float blur {worst} codes");
    assert!(worst <= 1, "{worst} codes");
    let spread = ours.iter().map(|c| (c - 30_000).abs()).max().unwrap();
    assert!(spread <= 1, "a flat field came back {spread} codes off");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_sensor_bit_depth_is_a_flag_and_sets_the_read_out_quantisation() {
    // With the ISP on and noise off the read-out digitises: the flag decides its depth.
    let dir = scratch("bits");
    let ramp = coded_image(|x| 10_000.0 + 45_000.0 * x as f64 / (WIDTH - 1) as f64);
    let distinct = |extra: &[&str]| {
        let path = dir.join("input.tif");
        write_tiff(&path, &ramp, SampleDepth::Sixteen).unwrap();
        let out = dir.join(format!("out{}", extra.join("")));
        let mut args = vec![
            "simulate",
            LENS,
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(&["--no-isp", "--no-cache", "--seed", "1"]);
        args.extend_from_slice(extra);
        let output = Command::new(env!("CARGO_BIN_EXE_unicac"))
            .args(&args)
            .output()
            .unwrap();
        assert!(
            output.status.success(),
            "{}",
            String::from_utf8_lossy(&output.stderr)
        );
        let stderr = String::from_utf8_lossy(&output.stderr).to_string();
        let written = std::fs::read_dir(&out).unwrap().next().unwrap().unwrap().path();
        let loaded = read_image(&written).unwrap();
        let mut codes: Vec<u32> = loaded
            .image
            .plane(1)
            .iter()
            .map(|v| (v * 65535.0).round() as u32)
            .collect();
        codes.sort_unstable();
        codes.dedup();
        (codes.len(), stderr)
    };
    let (eight, stderr) = distinct(&["--sensor-bits", "8"]);
    assert!(
        stderr.contains("8 bits"),
        "the read-out depth is announced: {stderr}"
    );
    let (fourteen, _) = distinct(&["--sensor-bits", "14"]);
    println!("distinct green codes with noise: 8-bit read-out {eight}, 14-bit {fourteen}");
    assert!(fourteen > eight, "{fourteen} vs {eight}");
    let bad = Command::new(env!("CARGO_BIN_EXE_unicac"))
        .args(["simulate", LENS, "x.png", "--out", "o", "--sensor-bits", "17"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--sensor-bits"));
    std::fs::remove_dir_all(&dir).ok();
}
