"""A tiny dataset folder laid out as docs/dataset.md describes (what `unicac dataset build` writes),
made in numpy for the reader and training tests: two lenses (train / val), a few crops of frames of
two sizes, Gaussian PSF tables that widen with the field radius, LQ = GT blurred + noise. Its manifests
carry every field of the format, so the one reader (Rust's, through `unicac.DatasetFolder`) accepts it
as it accepts a built dataset."""

from __future__ import annotations

import json
from pathlib import Path
import numpy as np

import unicac

FIELDS = np.linspace(0.0, 1.0, 5)
KERNEL_PX = 7
# A pair's sensor/ISP draws as `pairs.jsonl` records them (the default sensor, no noise seed).
ISP_DRAW = {"white_balance_gains": [2.0, 1.0, 1.6], "white_balance_jitter": 0.0, "noise_seed": None, "isp": True,
            "noise": True, "bit_depth": 10, "black_level_dn": 64.0, "iso": 100.0, "iso_base": 100.0,
            "dn_per_electron_at_base_iso": 0.16, "read_noise_dn_at_base_iso": 0.5}


def _kernels(spread: float) -> np.ndarray:
    """[F, 3, K, K] anisotropic Gaussians (radially elongated along +x, wider per channel and field)."""
    r = np.arange(KERNEL_PX) - KERNEL_PX // 2
    yy, xx = np.meshgrid(r, r, indexing="ij")
    out = np.zeros((len(FIELDS), 3, KERNEL_PX, KERNEL_PX), np.float32)
    for f, radius in enumerate(FIELDS):
        for c in range(3):
            sx = 0.6 + spread * radius * (1 + 0.3 * c)
            sy = 0.6 + 0.3 * spread * radius
            k = np.exp(-0.5 * ((xx - 0.8 * radius) ** 2 / sx**2 + yy**2 / sy**2))
            out[f, c] = k / k.sum()
    return out


def _blur(image: np.ndarray, sigma: float) -> np.ndarray:
    r = np.arange(-3, 4)
    g = np.exp(-0.5 * (r / sigma) ** 2)
    g /= g.sum()
    padded = np.pad(image, ((3, 3), (3, 3), (0, 0)), mode="edge")
    rows = sum(w * padded[:, i : i + image.shape[1]] for i, w in enumerate(g))
    cols = sum(w * rows[i : i + image.shape[0]] for i, w in enumerate(g))
    return cols


def make_dataset(root: Path, *, psf: bool = True, gt_is_lq: bool = False, pairs_per_split: int = 4,
                 crop_px: int = 72, seed: int = 0, misaligned: bool = False, checks: bool = True) -> Path:
    """Writes the folder and returns it. `gt_is_lq`: the GT files are copies of the LQ files (the
    pitfall of a GT folder pointed at the degraded one). `psf=False`: no PSF tables. The pair rows
    carry the checks of aligned pairs (blur explains the error), or with `misaligned` those of a
    `--task full` wide angle (pixels 3 px apart, blur explains 10%); `checks=False`: none (an old
    dataset)."""
    rng = np.random.default_rng(seed)
    root.mkdir(parents=True, exist_ok=True)
    lenses = [("lensA-000000000001", "train", (128, 96), 1.5), ("lensB-000000000002", "val", (100, 100), 2.5)]
    lens_rows, pair_rows = [], []
    for lens_id, split, (fw, fh), spread in lenses:
        table = f"psf/{lens_id}" if psf else ""
        if psf:
            folder = root / table
            folder.mkdir(parents=True, exist_ok=True)
            np.save(folder / "kernels.npy", _kernels(spread))
            meta = {
                "format": "unicac-psf-table", "format_version": 1, "lens_id": lens_id,
                "field_radius_norm": FIELDS.tolist(), "field_deg": (FIELDS * 20).tolist(), "kernel_px": KERNEL_PX,
                "pixel_pitch_um": 2.0, "frame_px": [fw, fh], "relative_illumination": [1.0] * len(FIELDS),
                "distortion": [1.0] * len(FIELDS), "wavelengths_um": [0.55], "channel_weights": [[1.0]] * 3,
                "energy_cut": [[0.0, 0.0, 0.0]] * len(FIELDS), "unicac_version": unicac.__version__,
            }
            (folder / "table.json").write_text(json.dumps(meta))
        lens_rows.append({"lens_id": lens_id, "source": f"{lens_id}.json", "split": split, "level": None, "psf": table,
                          "ode": 0.5, "oiq": 0.5, "u_s": 0.5, "u_c": 0.5, "oiqe": 0.5, "psnr_db": 30.0, "ssim": 0.9,
                          "rms_radius_um": 3.0, "lens_sha256": "0" * 64, "us_level": None, "uc_level": None,
                          "pixel_pitch_um": 2.0})
        for i in range(pairs_per_split):
            pair_id = f"{split}-{i:04d}"
            frame = unicac.chart("dead-leaves", fw, fh, seed=int(rng.integers(1 << 30)))
            gt_frame = unicac.linear_to_srgb(frame)
            x0 = int(rng.integers(fw - crop_px + 1))
            y0 = int(rng.integers(fh - crop_px + 1))
            gt = gt_frame[y0 : y0 + crop_px, x0 : x0 + crop_px]
            lq = np.clip(_blur(gt, spread) + rng.normal(0, 0.01, gt.shape), 0, 1)
            lq_codes = np.round(lq * 255).astype(np.uint8)
            gt_codes = lq_codes if gt_is_lq else np.round(gt * 255).astype(np.uint8)
            for kind, codes in (("lq", lq_codes), ("gt", gt_codes)):
                (root / split / kind).mkdir(parents=True, exist_ok=True)
                unicac.write_image(root / split / kind / f"{pair_id}.png", codes)
            pair_rows.append({
                "pair_id": pair_id, "split": split, "lens_id": lens_id, "image_id": f"img{i}",
                "image_source": f"dead-leaves:{i}:{fw}x{fh}", "lq": f"{split}/lq/{pair_id}.png",
                "gt": f"{split}/gt/{pair_id}.png", "seed": i, "frame_px": [fw, fh], "scene_crop": [0, 0, fw, fh],
                "crop": [x0, y0, crop_px, crop_px], "pixel_pitch_um": 2.0, "distortion": True, "illumination": True,
                "isp_draw": ISP_DRAW, "psf": table, "fov": f"fov/{fw}x{fh}.npy",
                "task": "full" if misaligned else "aligned",
            })
            if checks:
                error = float(np.mean((lq_codes / 255.0 - gt_codes / 255.0) ** 2))
                pair_rows[-1].update({"lq_gt_psnr_db": round(10 * np.log10(1 / max(error, 1e-10)), 4),
                                      "registration_px": 3.0 if misaligned else 0.05,
                                      "blur_share": 0.1 if misaligned else 0.9})
    manifest = {"format": "unicac-dataset", "format_version": 1, "unicac_version": unicac.__version__,
                "settings": {}, "seed": seed, "task": "full" if misaligned else "aligned",
                "comparable_by_ode_level": not misaligned, "frame_px": [128, 96], "stratifications": [],
                "counts": {"lenses": {"train": 1, "val": 1}, "pairs": {"train": pairs_per_split, "val": pairs_per_split},
                           "edges": 0, "train_images": pairs_per_split, "test_images": 0}}
    (root / "dataset.json").write_text(json.dumps(manifest))
    (root / "lenses.jsonl").write_text("".join(json.dumps(r) + "\n" for r in lens_rows))
    (root / "pairs.jsonl").write_text("".join(json.dumps(r) + "\n" for r in pair_rows))
    return root

