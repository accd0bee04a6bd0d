//! `unicac bench` end to end on a tiny dataset fixture (tests/support/dataset.rs) with tiny ONNX models
//! built in the test (tests/support/mod.rs). Tests that need onnxruntime skip with a printed reason when
//! ORT_DYLIB_PATH is unset, and fail under CI.

mod support;

use std::path::{Path, PathBuf};

use unicac_bench::run::{
    read_rgb, run_bench, run_onnx, run_onnx_batch, run_onnx_with, BenchSettings, InputMaps,
};
use unicac_bench::tiling::Tiling;
use unicac_bench::{BenchError, Benchmark, ClassicalMethod, Metric, Split};
use unicac_dataset::FrameCrop;
use unicac_image::Planar;
use unicac_io::progress::Silent;
use unicac_metrics::{psnr_pyiqa, ssim_pyiqa, PYIQA_PSNR_CAP_DB};
use unicac_onnx::contract::{load_model, ModelInput};

fn write_model(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn settings(dataset: &Path, out: &Path) -> BenchSettings {
    BenchSettings {
        dataset: dataset.to_path_buf(),
        models: Vec::new(),
        methods: Vec::new(),
        out: out.to_path_buf(),
        split: Split::Test,
        benchmarks: Benchmark::ALL.to_vec(),
        metrics: None,
        weights_dir: None,
        cache_root: None,
        tiling: Tiling::default(),
        threads: 1,
        save_images: false,
        wiener_nsr: 0.01,
        memory_limit_bytes: None,
        onnxruntime: unicac_onnx::ort_library::Search::from_environment(None),
    }
}

#[test]
fn contract_violations_are_refused_by_name() {
    let dir = support::scratch("contract");
    let text = write_model(&dir, "notes.onnx", b"this is not a model\n");
    let error = load_model(&text).unwrap_err();
    assert!(matches!(error, unicac_onnx::OnnxError::NotOnnx { .. }), "{error}");
    assert!(error.to_string().contains("notes.onnx"), "{error}");
    let bad_out = write_model(&dir, "out.onnx", &support::wrong_output_model());
    let error = load_model(&bad_out).unwrap_err().to_string();
    assert!(error.contains("`out`, not `restored`"), "{error}");
    let bad_in = write_model(&dir, "in.onnx", &support::wrong_input_model());
    let error = load_model(&bad_in).unwrap_err().to_string();
    assert!(error.contains("input `image` is not in the contract"), "{error}");
    let (contract, ..) = load_model(&write_model(&dir, "fov.onnx", &support::conv_model(true))).unwrap();
    assert_eq!(contract.inputs, vec![ModelInput::Lq, ModelInput::Fov]);
}

#[test]
fn bad_inputs_are_refused_before_any_work() {
    let dir = support::scratch("refusals");
    let dataset = dir.join("train_only");
    support::dataset::write(&dataset, false);
    let error = run_bench(&settings(&dataset, &dir.join("out")), &Silent)
        .unwrap_err()
        .to_string();
    assert!(error.contains("no `test` split"), "{error}");
    assert!(!dir.join("out").exists(), "nothing may be written");
    // A model file that is not ONNX is refused even before the dataset is read.
    let mut s = settings(&dir.join("missing"), &dir.join("out"));
    s.models = vec![("m".into(), write_model(&dir, "bad.onnx", b"nope"))];
    let error = run_bench(&s, &Silent).unwrap_err().to_string();
    assert!(
        error.contains("bad.onnx") && error.contains("not an ONNX model"),
        "{error}"
    );
    // A folder that is not a dataset: the dataset's own error, kind kept.
    match run_bench(&settings(&dir.join("missing"), &dir.join("out")), &Silent).unwrap_err() {
        BenchError::Dataset(unicac_dataset::DatasetError::NotADataset { .. }) => {}
        other => panic!("expected the dataset's NotADataset, got {other:?}"),
    }
    let mut s = settings(&dataset, &dir.join("out"));
    s.tiling = Tiling {
        tile_px: Some(32),
        overlap_px: 20,
    };
    // The library names the setting in its own words; the CLI says `--tile-overlap`.
    match run_bench(&s, &Silent).unwrap_err() {
        BenchError::InvalidParameter(p) => assert_eq!(p.field, "overlap_px", "{p}"),
        other => panic!("expected a parameter error, got {other}"),
    }
}

#[test]
fn a_model_asking_for_a_missing_input_is_refused_by_name() {
    if support::ort_or_skip().is_none() {
        return;
    }
    let dir = support::scratch("missing_input");
    let dataset = dir.join("data");
    support::dataset::write(&dataset, true);
    // Drop the PSF tables from the manifest: the dataset no longer provides `psf`.
    let pairs = std::fs::read_to_string(dataset.join("pairs.jsonl")).unwrap();
    std::fs::write(
        dataset.join("pairs.jsonl"),
        pairs.replace("\"psf\":\"psf/lens0\"", "\"psf\":\"\""),
    )
    .unwrap();
    let mut s = settings(&dataset, &dir.join("out"));
    s.models = vec![(
        "psfnet".into(),
        write_model(&dir, "psf.onnx", &support::psf_model()),
    )];
    let error = run_bench(&s, &Silent).unwrap_err().to_string();
    assert!(
        error.contains("psfnet") && error.contains("input `psf`"),
        "{error}"
    );
}

#[test]
fn tiled_inference_equals_untiled_within_1e5() {
    let Some(runtime) = support::ort_or_skip() else {
        return;
    };
    let dir = support::scratch("tiling");
    let path = write_model(&dir, "conv.onnx", &support::conv_model(true));
    let (contract, _, bytes) = load_model(&path).unwrap();
    let mut session = runtime.session(&bytes, 1, "conv").unwrap();
    let (w, h) = (101, 70);
    let noise = support::values(3 * w * h, 7, 0.5);
    let lq = Planar::from_fn(w, h, 3, |c, x, y| 0.5 + noise[(c * h + y) * w + x]);
    let fov = unicac_dataset::fov_map(FrameCrop::full(w, h)).unwrap();
    let fov = Planar {
        width: w,
        height: h,
        channels: 2,
        data: fov.data,
    };
    let whole = run_onnx(&mut session, &contract, &lq, Some(&fov), None, Tiling::default()).unwrap();
    for (tile, overlap) in [(32, 8), (48, 12), (40, 15)] {
        let tiled = run_onnx(
            &mut session,
            &contract,
            &lq,
            Some(&fov),
            None,
            Tiling {
                tile_px: Some(tile),
                overlap_px: overlap,
            },
        )
        .unwrap();
        let worst = whole
            .data
            .iter()
            .zip(&tiled.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(
            worst < 1e-5,
            "tile {tile} overlap {overlap}: max difference {worst}"
        );
    }
}

#[test]
fn a_model_returning_gt_scores_the_top_values() {
    let Some(runtime) = support::ort_or_skip() else {
        return;
    };
    let dir = support::scratch("gt_model");
    let dataset = dir.join("data");
    support::dataset::write(&dataset, true);
    let gt = read_rgb(&dataset.join("test/gt/lens1_p0.png")).unwrap();
    let lq = read_rgb(&dataset.join("test/lq/lens1_p0.png")).unwrap();
    let path = write_model(&dir, "gt.onnx", &support::gt_model(&gt));
    let (contract, _, bytes) = load_model(&path).unwrap();
    let mut session = runtime.session(&bytes, 1, "gt").unwrap();
    let restored = run_onnx(&mut session, &contract, &lq, None, None, Tiling::default()).unwrap();
    let psnr = psnr_pyiqa(&restored, &gt).unwrap();
    let ssim = ssim_pyiqa(&restored, &gt).unwrap();
    assert!(
        psnr.is_finite() && (psnr - PYIQA_PSNR_CAP_DB).abs() < 1e-9,
        "{psnr}"
    );
    assert!(ssim.is_finite() && (ssim - 1.0).abs() < 1e-12, "{ssim}");
    // Tiled, the constant-GT model still returns GT: tiles carry their own positions.
    let _ = restored;
}

fn read_json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// A restoration in which no edge can be found has destroyed the edges the input held: it scores OIQE
/// 0 there (each patch named under its failures), never the mean of the edges it kept.
#[test]
fn a_restoration_that_destroys_the_edges_scores_oiqe_zero() {
    let Some(_) = support::ort_or_skip() else { return };
    let dir = support::scratch("destroyed_edges");
    let dataset = dir.join("data");
    support::dataset::write(&dataset, true);
    let out = dir.join("report");
    let mut s = settings(&dataset, &out);
    s.metrics = Some(vec![Metric::Psnr, Metric::Oiqe]);
    s.models = vec![(
        "flat".into(),
        write_model(&dir, "flat.onnx", &support::flat_model()),
    )];
    let (report, _) = run_bench(&s, &Silent).unwrap();
    let edges = std::fs::read_to_string(dataset.join("edges.jsonl")).unwrap();
    let flat = report.models.iter().find(|m| m.name == "flat").unwrap();
    assert_eq!(flat.failures.len(), edges.lines().count());
    assert!(
        flat.failures
            .iter()
            .all(|f| f.contains("scored as a zero MTF, OIQE 0")),
        "{:?}",
        flat.failures
    );
    let json = read_json(&out.join("results.json"));
    let overall = json["overall"].as_array().unwrap();
    let oiqe = |model: &str| overall.iter().find(|r| r["model"] == model).unwrap()["oiqe"].as_f64();
    assert_eq!(oiqe("flat"), Some(0.0));
    assert!(oiqe("identity").unwrap() > 0.1);
}

#[test]
fn full_run_reports_rows_overall_analysis_and_files() {
    let Some(_) = support::ort_or_skip() else { return };
    let dir = support::scratch("full_run");
    let dataset = dir.join("data");
    support::dataset::write(&dataset, true);
    let out = dir.join("report");
    let mut s = settings(&dataset, &out);
    s.models = vec![
        (
            "id".into(),
            write_model(&dir, "identity.onnx", &support::identity_model()),
        ),
        (
            "conv".into(),
            write_model(&dir, "conv.onnx", &support::conv_model(true)),
        ),
    ];
    s.methods = vec![ClassicalMethod::Wiener];
    s.save_images = true;
    let (report, written) = run_bench(&s, &Silent).unwrap();
    let json = read_json(&out.join("results.json"));
    // The library the models ran on, and how it was found.
    let library = json["onnxruntime"]["library"].as_str().unwrap();
    assert!(Path::new(library).is_file(), "{}", json["onnxruntime"]);
    assert!(json["onnxruntime"]["found_by"].is_string());
    let rows = json["rows"].as_array().unwrap();
    // 4 methods x 3 benchmarks x 3 levels.
    assert_eq!(rows.len(), 4 * 3 * 3);
    for key in [
        "model",
        "benchmark",
        "level",
        "pairs",
        "psnr_db",
        "ssim",
        "lpips",
        "oiqe",
        "fid",
        "clipiqa",
        "op",
        "op_terms",
    ] {
        assert!(rows[0].get(key).is_some(), "rows lack `{key}`");
    }
    assert!(rows[0]["lpips"].is_null() && rows[0]["fid"].is_null() && rows[0]["clipiqa"].is_null());
    assert_eq!(rows[0]["op_terms"], serde_json::json!(["psnr", "ssim", "oiqe"]));
    let overall = json["overall"].as_array().unwrap();
    assert_eq!(overall.len(), 4);
    let mut ranks: Vec<u64> = overall.iter().map(|r| r["rank"].as_u64().unwrap()).collect();
    ranks.sort();
    assert_eq!(ranks, vec![1, 2, 3, 4]);
    let analysis = &json["analysis"];
    assert_eq!(analysis["lenses"], 3);
    assert!(
        analysis["r2_ode"].as_f64().is_some() && analysis["r2_rms"].as_f64().is_some(),
        "{analysis}"
    );
    // The identity model through onnxruntime scores exactly what comparing LQ with GT gives.
    let csv = std::fs::read_to_string(out.join("pairs.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next(),
        Some("model,pair_id,lens_id,level,psnr_db,ssim,lpips,clipiqa")
    );
    let rows_of = |model: &str| -> Vec<Vec<String>> {
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>())
            .filter(|f| f[0] == model)
            .collect()
    };
    let (id, identity) = (rows_of("id"), rows_of("identity"));
    assert_eq!(id.len(), 6);
    for (a, b) in id.iter().zip(&identity) {
        assert_eq!(a[1..], b[1..], "identity model vs identity method");
        let lq = read_rgb(&dataset.join(format!("test/lq/{}.png", a[1]))).unwrap();
        let gt = read_rgb(&dataset.join(format!("test/gt/{}.png", a[1]))).unwrap();
        let psnr: f64 = a[4].parse().unwrap();
        let ssim: f64 = a[5].parse().unwrap();
        assert!((psnr - psnr_pyiqa(&lq, &gt).unwrap()).abs() < 1e-5);
        assert!((ssim - ssim_pyiqa(&lq, &gt).unwrap()).abs() < 1e-5);
    }
    // Wiener with the true PSFs beats the unrestored input.
    let op = |model: &str| {
        overall.iter().find(|r| r["model"] == model).unwrap()["psnr_db"]
            .as_f64()
            .unwrap()
    };
    assert!(
        op("wiener") > op("identity") + 0.5,
        "wiener {} vs identity {}",
        op("wiener"),
        op("identity")
    );
    // OIQE of restored edges: Wiener sharpens the blurred edges.
    let oiqe = |model: &str| {
        overall.iter().find(|r| r["model"] == model).unwrap()["oiqe"]
            .as_f64()
            .unwrap()
    };
    assert!(
        oiqe("wiener") > oiqe("identity"),
        "{} vs {}",
        oiqe("wiener"),
        oiqe("identity")
    );
    for name in [
        "tables.md",
        "tables/ode.tex",
        "tables/us.tex",
        "ranking_trend.png",
        "metric_psnr.png",
        "analysis.png",
        "images/conv/lens0_p0.png",
    ] {
        assert!(out.join(name).is_file(), "{name} missing");
    }
    assert!(written.len() >= 10);
    // The tables name the dataset by its folder, never by the machine's path.
    let tables = std::fs::read_to_string(out.join("tables.md")).unwrap();
    let heading = tables.lines().next().unwrap();
    let folder = dataset.file_name().unwrap().to_string_lossy().into_owned();
    assert_eq!(heading, format!("# unicac bench: dataset `{folder}`"));
    let cost = report
        .models
        .iter()
        .find(|m| m.name == "conv")
        .unwrap()
        .cost
        .clone()
        .unwrap();
    // conv: 4x5x3x3 + 4 + 3x4x3x3 + 3 parameters; MACs 256^2 x (4 x 45 + 3 x 36).
    assert_eq!(cost.params, 295);
    assert!(
        (cost.macs_g - 65536.0 * 288.0 / 1e9).abs() < 1e-12,
        "{}",
        cost.macs_g
    );
}

#[test]
fn contract_2_inputs_are_checked_by_name_and_version() {
    let dir = support::scratch("contract2");
    let sha = "ab".repeat(32);
    let (contract, ..) = load_model(&write_model(
        &dir,
        "v2.onnx",
        &support::wiener_code_model(&sha, "2"),
    ))
    .unwrap();
    assert_eq!(
        contract.inputs,
        vec![ModelInput::Lq, ModelInput::PsfCode, ModelInput::Wiener]
    );
    assert_eq!(contract.psf_basis_sha256.as_deref(), Some(sha.as_str()));
    assert_eq!(contract.wiener_nsr, None);
    let error = load_model(&write_model(
        &dir,
        "v1.onnx",
        &support::wiener_code_model(&sha, "1"),
    ))
    .unwrap_err()
    .to_string();
    assert!(
        error.contains("input `psf_code` needs contract 2") && error.contains("v1.onnx"),
        "{error}"
    );
    let error = load_model(&write_model(
        &dir,
        "nosha.onnx",
        &support::wiener_code_model("", "2"),
    ))
    .unwrap_err()
    .to_string();
    assert!(error.contains("psf_basis_sha256"), "{error}");
    let error = load_model(&write_model(
        &dir,
        "v3.onnx",
        &support::wiener_code_model(&sha, "3"),
    ))
    .unwrap_err()
    .to_string();
    assert!(error.contains("newer than this reader's 2"), "{error}");
}

#[test]
fn a_contract_2_model_gets_the_wiener_estimate_and_the_code_of_its_basis() {
    let Some(_) = support::ort_or_skip() else { return };
    let dir = support::scratch("contract2_run");
    let dataset = dir.join("data");
    support::dataset::write(&dataset, true);
    let basis = unicac_dataset::psf_basis::read_dataset_basis(&dataset).unwrap();
    let out = dir.join("report");
    let mut s = settings(&dataset, &out);
    s.metrics = Some(vec![Metric::Psnr, Metric::Ssim]);
    s.methods = vec![ClassicalMethod::Wiener];
    // A version-1 model next to it still benchmarks.
    s.models = vec![
        (
            "v2".into(),
            write_model(
                &dir,
                "v2.onnx",
                &support::wiener_code_model(&basis.meta.sha256, "2"),
            ),
        ),
        (
            "v1".into(),
            write_model(&dir, "v1.onnx", &support::identity_model()),
        ),
    ];
    let (report, _) = run_bench(&s, &Silent).unwrap();
    assert!(
        report.models.iter().all(|m| m.failures.is_empty()),
        "{:?}",
        report.models
    );
    // The model returns its `wiener` input: it scores exactly what the Wiener method scores, pair by
    // pair (the same function, the same noise-to-signal ratio).
    let csv = std::fs::read_to_string(out.join("pairs.csv")).unwrap();
    let rows_of = |model: &str| -> Vec<Vec<String>> {
        csv.lines()
            .skip(1)
            .map(|l| l.split(',').map(str::to_string).collect::<Vec<_>>())
            .filter(|f| f[0] == model)
            .collect()
    };
    let (v2, wiener, v1, identity) = (
        rows_of("v2"),
        rows_of("wiener"),
        rows_of("v1"),
        rows_of("identity"),
    );
    assert_eq!(v2.len(), 6);
    for (a, b) in v2.iter().zip(&wiener) {
        assert_eq!(a[1..], b[1..], "v2 model vs wiener method");
    }
    for (a, b) in v1.iter().zip(&identity) {
        assert_eq!(a[1..], b[1..], "v1 model vs identity method");
    }
    // A model trained with another basis is refused before any work, naming both bases.
    let other = dir.join("other");
    std::fs::create_dir_all(&other).unwrap();
    let mut s = settings(&dataset, &other.join("report"));
    s.models = vec![(
        "stranger".into(),
        write_model(
            &other,
            "stranger.onnx",
            &support::wiener_code_model(&"cd".repeat(32), "2"),
        ),
    )];
    let error = run_bench(&s, &Silent).unwrap_err().to_string();
    assert!(
        error.contains("stranger") && error.contains(&"cd".repeat(32)) && error.contains(&basis.meta.sha256),
        "{error}"
    );
    assert!(!other.join("report").exists());
}

#[test]
fn a_batch_of_images_restores_as_each_image_alone() {
    let Some(runtime) = support::ort_or_skip() else {
        return;
    };
    let dir = support::scratch("batch");
    let path = write_model(&dir, "conv.onnx", &support::conv_model(true));
    let (contract, _, bytes) = load_model(&path).unwrap();
    assert!(contract.dynamic_batch, "N is symbolic in the graph");
    let mut session = runtime.session(&bytes, 1, "conv").unwrap();
    let (w, h) = (40, 28);
    let images: Vec<(Planar, Planar)> = (0..3)
        .map(|seed| {
            let noise = support::values(3 * w * h, 11 + seed, 0.5);
            let lq = Planar::from_fn(w, h, 3, |c, x, y| 0.5 + noise[(c * h + y) * w + x]);
            let fov = Planar::from_fn(w, h, 2, |c, x, y| {
                (c as f32 + 1.0) * (x + seed as usize * y) as f32 / 100.0
            });
            (lq, fov)
        })
        .collect();
    let maps = |fov| InputMaps {
        fov: Some(fov),
        ..InputMaps::default()
    };
    let batch: Vec<(&Planar, InputMaps)> = images.iter().map(|(lq, fov)| (lq, maps(fov))).collect();
    let batched = run_onnx_batch(&mut session, &contract, &batch).unwrap();
    assert_eq!(batched.len(), 3);
    for ((lq, fov), batched) in images.iter().zip(batched) {
        let alone = run_onnx_with(&mut session, &contract, lq, &maps(fov), Tiling::default()).unwrap();
        let batched = batched.unwrap();
        let worst = alone
            .data
            .iter()
            .zip(&batched.data)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(worst < 1e-6, "batched differs from alone by {worst}");
    }
    // Images of two sizes are not one batch.
    let small = Planar::new(20, 20, 3);
    let fov = Planar::new(20, 20, 2);
    let mixed = vec![batch[0], (&small, maps(&fov))];
    assert!(run_onnx_batch(&mut session, &contract, &mixed).is_err());
}

#[test]
fn a_model_fixed_at_one_image_per_run_is_known_from_its_graph() {
    use unicac_onnx::builder::{Dim, GraphBuilder};
    let dims = [Dim::Fixed(1), Dim::Fixed(3), Dim::Named("H"), Dim::Named("W")];
    let mut g = GraphBuilder::new("fixed_batch");
    g.input("lq", &dims).output("restored", &dims);
    g.node("Identity", &["lq"], &["restored"], &[]);
    let dir = support::scratch("fixed-batch");
    let path = write_model(&dir, "fixed.onnx", &g.to_bytes());
    let (contract, _, _) = load_model(&path).unwrap();
    assert!(!contract.dynamic_batch);
    let path = write_model(&dir, "free.onnx", &support::identity_model());
    assert!(load_model(&path).unwrap().0.dynamic_batch);
}
