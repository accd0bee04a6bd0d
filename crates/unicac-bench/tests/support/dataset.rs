//! A tiny dataset following docs/dataset.md, written by the tests: 3 test lenses at levels 1..3 with
//! Gaussian PSFs of growing width, 2 pairs each (48 x 40 px frames), one slanted-edge patch per lens.

use std::path::Path;

use unicac_dataset::manifest::{write_json, write_jsonl, Counts, DatasetManifest, IspRecord};
use unicac_dataset::row_counts;
use unicac_dataset::{EdgeRow, FrameCrop, LensRow, PairRow, PsfTable, PsfTableMeta};
use unicac_image::io::{write_png, SampleDepth};
use unicac_image::Planar;

pub const FRAME: [usize; 2] = [48, 40];
const K: usize = 7;
pub const SIGMAS_PX: [f64; 3] = [0.6, 1.0, 1.6];
pub const EDGE_PX: usize = 64;

fn gaussian(sigma: f64) -> Vec<f32> {
    let h = (K / 2) as f64;
    let raw: Vec<f64> = (0..K * K)
        .map(|i| {
            let (x, y) = ((i % K) as f64 - h, (i / K) as f64 - h);
            (-(x * x + y * y) / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let sum: f64 = raw.iter().sum();
    raw.iter().map(|v| (v / sum) as f32).collect()
}

/// `image` convolved with `kernel` (K x K), borders replicated.
pub fn blur(image: &Planar, kernel: &[f32]) -> Planar {
    let h = (K / 2) as isize;
    Planar::from_fn(image.width, image.height, image.channels, |c, x, y| {
        let mut sum = 0.0;
        for ky in 0..K {
            for kx in 0..K {
                let sx = (x as isize + kx as isize - h).clamp(0, image.width as isize - 1) as usize;
                let sy = (y as isize + ky as isize - h).clamp(0, image.height as isize - 1) as usize;
                sum += kernel[ky * K + kx] * image.get(c, sx, sy);
            }
        }
        sum
    })
}

fn scene(seed: usize) -> Planar {
    let values = super::values(FRAME[0] * FRAME[1] * 3, seed as u64 + 10, 1.0);
    // Smooth-ish texture: a few sinusoids plus a little noise, in [0.1, 0.9].
    Planar::from_fn(FRAME[0], FRAME[1], 3, |c, x, y| {
        let (xf, yf) = (x as f32, y as f32);
        let v = 0.5
            + 0.25 * ((xf * (0.3 + 0.1 * c as f32) + seed as f32).sin() * (yf * 0.21).cos())
            + 0.1 * values[(c * FRAME[1] + y) * FRAME[0] + x];
        v.clamp(0.1, 0.9)
    })
}

fn quantised(image: &Planar) -> Planar {
    let mut out = image.clone();
    out.data
        .iter_mut()
        .for_each(|v| *v = (v.clamp(0.0, 1.0) * 255.0).round() / 255.0);
    out
}

/// Writes the dataset into `dir`; with `test_split = false` every pair is in `train`.
pub fn write(dir: &Path, test_split: bool) {
    let split = if test_split { "test" } else { "train" };
    let frame = FrameCrop::full(FRAME[0], FRAME[1]);
    let fov = unicac_dataset::fov_map(frame).unwrap();
    let fov_rel = format!("fov/{}x{}.npy", FRAME[0], FRAME[1]);
    unicac_dataset::npy::write_f32(&dir.join(&fov_rel), &[2, FRAME[1], FRAME[0]], &fov.data).unwrap();
    let mut lenses = Vec::new();
    let mut pairs = Vec::new();
    let mut edges = Vec::new();
    for (i, sigma) in SIGMAS_PX.iter().enumerate() {
        let lens_id = format!("lens{i}");
        let psf_rel = format!("psf/{lens_id}");
        // The same kernel at every field: a shift-invariant lens, so the rendered pairs are exact.
        let kernel = gaussian(*sigma);
        let radii = vec![0.0, 0.5, 1.0];
        let mut kernels = Vec::new();
        for _ in &radii {
            for _ in 0..3 {
                kernels.extend(&kernel);
            }
        }
        let table = PsfTable {
            meta: PsfTableMeta {
                format: unicac_dataset::psf_table::TABLE_FORMAT.into(),
                format_version: 1,
                lens_id: lens_id.clone(),
                field_radius_norm: radii.clone(),
                field_deg: vec![0.0, 10.0, 20.0],
                kernel_px: K,
                pixel_um: 2.0,
                frame_px: FRAME,
                relative_illumination: vec![1.0; 3],
                distortion: vec![1.0; 3],
                wavelengths_um: vec![0.55],
                channel_weights: vec![vec![1.0]; 3],
                energy_cut: vec![[0.0; 3]; 3],
                unicac_version: "test".into(),
            },
            kernels,
        };
        std::fs::create_dir_all(dir.join(&psf_rel)).unwrap();
        table.write(&dir.join(&psf_rel)).unwrap();
        let level = i as u32 + 1;
        lenses.push(LensRow {
            lens_id: lens_id.clone(),
            source: format!("{lens_id}.json"),
            lens_sha256: "0".repeat(64),
            scores: unicac_dataset::OdeScores {
                ode: 0.9 - 0.2 * i as f64,
                oiq: 0.8,
                u_s: 0.9,
                u_c: 0.9,
                oiqe: 0.5,
                psnr_db: 30.0,
                ssim: 0.9,
                rms_radius_um: 1.0 + 1.5 * i as f64 + 0.3 * (i * i) as f64,
            },
            split: split.into(),
            level: test_split.then_some(level),
            us_level: test_split.then_some(3 - i as u32),
            uc_level: test_split.then_some(level),
            pixel_um: 2.0,
            psf: psf_rel.clone(),
        });
        for j in 0..2 {
            let pair_id = format!("{lens_id}_p{j}");
            let gt = quantised(&scene(10 * i + j));
            let lq = quantised(&blur(&gt, &kernel));
            let (lq_rel, gt_rel) = (
                format!("{split}/lq/{pair_id}.png"),
                format!("{split}/gt/{pair_id}.png"),
            );
            for (rel, image) in [(&lq_rel, &lq), (&gt_rel, &gt)] {
                std::fs::create_dir_all(dir.join(rel).parent().unwrap()).unwrap();
                write_png(dir.join(rel), image, SampleDepth::Eight).unwrap();
            }
            pairs.push(PairRow {
                pair_id,
                split: split.into(),
                lens_id: lens_id.clone(),
                image_id: format!("scene{j}"),
                image_source: format!("dead-leaves:{j}:48x40"),
                lq: lq_rel,
                gt: gt_rel,
                seed: j as u64,
                frame_px: FRAME,
                scene_crop: [0, 0, FRAME[0], FRAME[1]],
                crop: [0, 0, FRAME[0], FRAME[1]],
                pixel_um: 2.0,
                distortion: false,
                illumination: false,
                task: unicac_dataset::manifest::PairTask::Aligned,
                isp_draw: IspRecord {
                    white_balance_gains: [1.0; 3],
                    white_balance_jitter: 0.0,
                    noise_seed: None,
                    isp: false,
                    noise: false,
                    sensor: unicac_image::isp::SensorNoise {
                        bit_depth: 8,
                        black_level_dn: 0.0,
                        iso: 100.0,
                        iso_base: 100.0,
                        dn_per_electron_at_base_iso: 1.0,
                        read_noise_dn_at_base_iso: 0.0,
                    },
                },
                psf: psf_rel.clone(),
                fov: fov_rel.clone(),
                check: None,
            });
        }
        if test_split {
            // A 5-deg slanted edge (tones 0.2 / 0.8, linear), blurred by the lens, sRGB-encoded.
            let edge = unicac_image::charts::slanted_edge(EDGE_PX, EDGE_PX, 5.0, 0.2, 0.8).unwrap();
            let blurred = blur(&edge, &kernel);
            let encoded = unicac_image::color::linear_to_srgb(&blurred);
            let rgb = Planar::from_fn(EDGE_PX, EDGE_PX, 3, |_, x, y| encoded.get(0, x, y));
            let sharp = unicac_image::color::linear_to_srgb(&edge);
            let sharp = Planar::from_fn(EDGE_PX, EDGE_PX, 3, |_, x, y| sharp.get(0, x, y));
            let edge_id = format!("{lens_id}_edge");
            let (lq_rel, gt_rel) = (
                format!("edges/lq/{edge_id}.png"),
                format!("edges/gt/{edge_id}.png"),
            );
            for (rel, image) in [(&lq_rel, &rgb), (&gt_rel, &sharp)] {
                std::fs::create_dir_all(dir.join(rel).parent().unwrap()).unwrap();
                write_png(dir.join(rel), image, SampleDepth::Sixteen).unwrap();
            }
            edges.push(EdgeRow {
                edge_id,
                lens_id: lens_id.clone(),
                level: Some(level),
                field_fraction: 0.0,
                field_deg: 0.0,
                channel: "G".into(),
                direction: "sagittal".into(),
                lq: lq_rel,
                gt: gt_rel,
                size_px: EDGE_PX,
                slant_deg: 5.0,
                pixel_um: 2.0,
            });
        }
    }
    // The PSF basis (docs/models.md, `psf_code`): fitted here on every lens's table (the fixture has no
    // training split).
    let tables: Vec<unicac_dataset::psf_basis::FitTable> = lenses
        .iter()
        .map(|l| unicac_dataset::psf_basis::FitTable {
            dir: dir.join(&l.psf),
            held_out: false,
        })
        .collect();
    unicac_dataset::PsfBasis::fit(&tables, 0.95, "test")
        .unwrap()
        .write(&dir.join(unicac_dataset::psf_basis::BASIS_RELATIVE))
        .unwrap();
    write_jsonl(&dir.join("lenses.jsonl"), &lenses).unwrap();
    write_jsonl(&dir.join("pairs.jsonl"), &pairs).unwrap();
    write_jsonl(&dir.join("edges.jsonl"), &edges).unwrap();
    let manifest = DatasetManifest {
        format: unicac_dataset::FORMAT_NAME.into(),
        format_version: unicac_dataset::FORMAT_VERSION,
        unicac_version: "test".into(),
        settings: serde_json::json!({}),
        seed: 0,
        frame_px: FRAME,
        stratifications: Vec::new(),
        // The counts a build records: bench refuses manifests that disagree with them.
        counts: Counts {
            lenses: row_counts::per_split(lenses.iter().map(|l| l.split.as_str())),
            pairs: row_counts::per_split(pairs.iter().map(|p| p.split.as_str())),
            edges: edges.len(),
            ..Counts::default()
        },
        task: unicac_dataset::manifest::PairTask::Aligned,
        comparable_by_ode_level: true,
    };
    write_json(&dir.join("dataset.json"), &manifest).unwrap();
}
