//! PSNR and SSIM against scikit-image / BasicSR reference values
//! (`tests/reference/metrics/make_metric_references.py`, see the README there).
//!
//! Tolerances: PSNR 1e-9 dB, SSIM 1e-6 (mean and per channel).

use std::path::PathBuf;

use serde_json::Value;
use unicac_image::Planar;
use unicac_metrics::{psnr, ssim, FullReferenceOptions, ValueRange, PSNR_CAP_DB};

const PSNR_TOLERANCE_DB: f64 = 1e-9;
const SSIM_TOLERANCE: f64 = 1e-6;

fn references() -> Value {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/reference/metrics/references.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap()
}

/// A `[row][column][channel]` uint8 array as a Planar, scaled by `scale`.
fn planar(array: &Value, scale: f32) -> Planar {
    let rows = array.as_array().unwrap();
    let (h, w, c) = (
        rows.len(),
        rows[0].as_array().unwrap().len(),
        rows[0][0].as_array().unwrap().len(),
    );
    Planar::from_fn(w, h, c, |ch, x, y| {
        array[y][x][ch].as_u64().unwrap() as f32 * scale
    })
}

#[test]
fn psnr_and_ssim_match_the_references() {
    let refs = references();
    let cases = refs["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 7);
    let (mut worst_psnr, mut worst_ssim) = (0.0f64, 0.0f64);
    for case in cases {
        let image = planar(&refs["images"][case["image"].as_str().unwrap()], 1.0);
        let reference = planar(&refs["images"][case["reference"].as_str().unwrap()], 1.0);
        let crop_border = case["crop_border"].as_u64().unwrap() as usize;
        let options = FullReferenceOptions {
            crop_border,
            range: ValueRange::Byte,
        };
        let label = format!("{} vs {} crop {crop_border}", case["image"], case["reference"]);

        let p = psnr(&image, &reference, &options).unwrap();
        if case["psnr_infinite"].as_bool().unwrap() {
            assert!(p.capped && p.db == PSNR_CAP_DB, "{label}");
        } else {
            let expected = case["psnr_db"].as_f64().unwrap();
            assert!(!p.capped);
            assert!(
                (p.db - expected).abs() < PSNR_TOLERANCE_DB,
                "{label}: PSNR {} vs {expected}",
                p.db
            );
            worst_psnr = worst_psnr.max((p.db - expected).abs());
        }

        let s = ssim(&image, &reference, &options).unwrap();
        let expected = case["ssim"].as_f64().unwrap();
        assert!(
            (s.mean - expected).abs() < SSIM_TOLERANCE,
            "{label}: SSIM {} vs {expected}",
            s.mean
        );
        assert!(
            (s.mean - case["ssim_basicsr_numpy"].as_f64().unwrap()).abs() < SSIM_TOLERANCE,
            "{label}"
        );
        worst_ssim = worst_ssim.max((s.mean - expected).abs());
        for (got, want) in s
            .per_channel
            .iter()
            .zip(case["ssim_per_channel"].as_array().unwrap())
        {
            let want = want.as_f64().unwrap();
            assert!(
                (got - want).abs() < SSIM_TOLERANCE,
                "{label}: channel SSIM {got} vs {want}"
            );
            worst_ssim = worst_ssim.max((got - want).abs());
        }
    }
    println!("worst PSNR difference {worst_psnr:.3e} dB, worst SSIM difference {worst_ssim:.3e}");
}

#[test]
fn unit_range_input_agrees_with_byte_input() {
    // The same images stored in [0, 1] (as f32, so v / 255 is rounded): within 1e-5 dB and 1e-7.
    let refs = references();
    let images = &refs["images"];
    let unit = FullReferenceOptions {
        crop_border: 0,
        range: ValueRange::Unit,
    };
    let byte = FullReferenceOptions {
        crop_border: 0,
        range: ValueRange::Byte,
    };
    let (a, b) = (planar(&images["noisy"], 1.0), planar(&images["ref"], 1.0));
    let (au, bu) = (
        planar(&images["noisy"], 1.0 / 255.0),
        planar(&images["ref"], 1.0 / 255.0),
    );
    assert!((psnr(&au, &bu, &unit).unwrap().db - psnr(&a, &b, &byte).unwrap().db).abs() < 1e-5);
    assert!((ssim(&au, &bu, &unit).unwrap().mean - ssim(&a, &b, &byte).unwrap().mean).abs() < 1e-7);
}
