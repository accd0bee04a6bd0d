#!/usr/bin/env python3
"""Reference PSNR/SSIM values for unicac-metrics (crates/unicac-metrics/tests/reference_values.rs).

Writes references.json next to this script: small deterministic 8-bit test images (a formula-based
reference and seeded-RNG distortions of it) and, for each image pair, BasicSR-convention PSNR and SSIM:

- PSNR: 10 log10(255^2 / MSE), MSE over all pixels and channels after `crop_border` (BasicSR
  `calculate_psnr`); identical images give null with "psnr_infinite": true.
- SSIM: scikit-image `structural_similarity(gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
  data_range=255)`, per channel (2-D calls) and averaged. skimage filters with reflected borders but
  averages the SSIM map only over the region 5 px inside each border, which is exactly BasicSR's 'valid'
  filtering; an independent numpy re-implementation of BasicSR `_ssim` ('valid' 11x11 Gaussian window)
  is computed too and must agree to 1e-10.

Usage: python3 -m venv /tmp/venv-metrics && /tmp/venv-metrics/bin/pip install scikit-image numpy
       /tmp/venv-metrics/bin/python make_metric_references.py
"""

import json
import pathlib

import numpy as np
import skimage
from skimage.metrics import structural_similarity

SEED = 20240611
OUT = pathlib.Path(__file__).with_name("references.json")


def make_images():
    """Named uint8 HxWxC images."""
    rng = np.random.default_rng(SEED)
    h, w = 32, 32
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    channels = [127.5 + 90.0 * np.sin(x / 4.0 + c) * np.cos(y / 6.0 - 0.5 * c) + 30.0 * ((x + y + 3 * c) % 9 < 4)
                for c in range(3)]
    ref = np.clip(np.rint(np.stack(channels, axis=-1)), 0, 255).astype(np.uint8)
    noisy = np.clip(ref.astype(np.float64) + rng.normal(0.0, 12.0, ref.shape), 0, 255).round().astype(np.uint8)
    # 3x3 box blur with edge replication.
    padded = np.pad(ref.astype(np.float64), ((1, 1), (1, 1), (0, 0)), mode="edge")
    blurred = sum(padded[dy:dy + h, dx:dx + w] for dy in range(3) for dx in range(3)) / 9.0
    blurred = np.rint(blurred).astype(np.uint8)
    low_contrast = np.rint(64.0 + 0.5 * ref.astype(np.float64)).astype(np.uint8)
    # A single-channel, non-square pair: uniform noise and a distorted copy.
    gray_ref = rng.integers(0, 256, size=(20, 27, 1), dtype=np.uint8)
    gray_dist = np.clip(gray_ref.astype(np.int64) + rng.integers(-40, 41, size=gray_ref.shape), 0, 255).astype(np.uint8)
    return {
        "ref": ref,
        "noisy": noisy,
        "blurred": blurred,
        "low_contrast": low_contrast,
        "gray_ref": gray_ref,
        "gray_dist": gray_dist,
    }


def crop(img, border):
    return img[border:img.shape[0] - border, border:img.shape[1] - border, :] if border else img


def psnr_basicsr(a, b):
    mse = np.mean((a.astype(np.float64) - b.astype(np.float64)) ** 2)
    return None if mse == 0 else float(10.0 * np.log10(255.0 ** 2 / mse))


def ssim_skimage(a, b):
    per_channel = [float(structural_similarity(a[..., c], b[..., c], gaussian_weights=True, sigma=1.5,
                                               use_sample_covariance=False, data_range=255))
                   for c in range(a.shape[2])]
    if a.shape[2] > 1:
        combined = float(structural_similarity(a, b, gaussian_weights=True, sigma=1.5, use_sample_covariance=False,
                                               data_range=255, channel_axis=2))
        assert abs(combined - np.mean(per_channel)) < 1e-12
    return float(np.mean(per_channel)), per_channel


def ssim_basicsr_numpy(a, b):
    """BasicSR `_ssim` per channel with 'valid' 2-D filtering (cv2.filter2D then [5:-5, 5:-5])."""
    g = np.exp(-((np.arange(11) - 5.0) ** 2) / (2 * 1.5 ** 2))
    g /= g.sum()
    window = np.outer(g, g)
    c1, c2 = (0.01 * 255) ** 2, (0.03 * 255) ** 2

    def valid(img):
        view = np.lib.stride_tricks.sliding_window_view(img, (11, 11))
        return np.einsum("ijkl,kl->ij", view, window)

    values = []
    for c in range(a.shape[2]):
        x, y = a[..., c].astype(np.float64), b[..., c].astype(np.float64)
        mu1, mu2 = valid(x), valid(y)
        s1 = valid(x * x) - mu1 ** 2
        s2 = valid(y * y) - mu2 ** 2
        s12 = valid(x * y) - mu1 * mu2
        m = ((2 * mu1 * mu2 + c1) * (2 * s12 + c2)) / ((mu1 ** 2 + mu2 ** 2 + c1) * (s1 + s2 + c2))
        values.append(m.mean())
    return float(np.mean(values))


def main():
    images = make_images()
    pairs = [
        ("noisy", "ref", 0),
        ("blurred", "ref", 0),
        ("low_contrast", "ref", 0),
        ("noisy", "ref", 4),
        ("ref", "ref", 0),
        ("gray_dist", "gray_ref", 0),
        ("gray_dist", "gray_ref", 2),
    ]
    cases = []
    for image, reference, border in pairs:
        a, b = crop(images[image], border), crop(images[reference], border)
        psnr = psnr_basicsr(a, b)
        ssim, per_channel = ssim_skimage(a, b)
        numpy_ssim = ssim_basicsr_numpy(a, b)
        assert abs(numpy_ssim - ssim) < 1e-10, (image, reference, border, numpy_ssim, ssim)
        cases.append({
            "image": image,
            "reference": reference,
            "crop_border": border,
            "psnr_db": psnr,
            "psnr_infinite": psnr is None,
            "ssim": ssim,
            "ssim_per_channel": per_channel,
            "ssim_basicsr_numpy": numpy_ssim,
        })
    document = {
        "generator": "tests/reference/metrics/make_metric_references.py",
        "versions": {"numpy": np.__version__, "scikit-image": skimage.__version__},
        "seed": SEED,
        "layout": "images are uint8 arrays indexed [row][column][channel]",
        "images": {name: img.tolist() for name, img in images.items()},
        "cases": cases,
    }
    OUT.write_text(json.dumps(document, separators=(",", ":")) + "\n")
    for case in cases:
        print(case["image"], case["reference"], case["crop_border"], case["psnr_db"], case["ssim"])


if __name__ == "__main__":
    main()
