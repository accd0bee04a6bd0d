#!/usr/bin/env python3
"""DeepLens' spatially varying image simulation (`GeoLens.render(method="psf_map")`, deeplens-core
2.5.6, float32 as its psf_map path requires) timed on a unicac lens (bench/peers/deeplens_lens.py) and
an image file, for bench/simulate_vs_deeplens.sh.

The sensor gets the image's pixel count and unicac's default frame: the lens's largest field on the
image's half-diagonal at its paraxial height (EFL tan F), so both tools blur with the same pixel pitch.
The object is at infinity (depth -1e8 mm). Defaults are DeepLens': a 10 x 10 PSF grid, 64 px kernels,
8192 rays per PSF, R/G/B at 0.656/0.587/0.486 um, inverse-distortion warp on a 128 x 128 grid.
`--grid G --kernel-px K --spp S` set the PSF grid, kernel size and rays per PSF (the script's equal-work
row). Timed: `render` alone (the image in memory, the lens loaded), as `seconds`.

Run: .venv-deeplens/bin/python bench/peers/deeplens_image_simulation.py LENS IMAGE.png [--grid G]
     [--kernel-px K] [--spp S]
Prints one JSON object.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from importlib.metadata import version
from pathlib import Path

import cv2
import numpy as np
import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from deeplens_lens import ROOT, geolens  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("lens")
    parser.add_argument("image")
    parser.add_argument("--grid", type=int, default=10)
    parser.add_argument("--kernel-px", type=int, default=64)
    parser.add_argument("--spp", type=int, default=8192)
    args = parser.parse_args()
    torch.set_num_threads(2)
    picture = cv2.imread(args.image, cv2.IMREAD_UNCHANGED)
    if picture is None:
        raise SystemExit(f"{args.image}: not an image cv2 can read")
    scale = 65535.0 if picture.dtype == np.uint16 else 255.0
    rgb = cv2.cvtColor(picture, cv2.COLOR_BGR2RGB).astype(np.float32) / scale
    height, width = rgb.shape[:2]
    image = torch.from_numpy(rgb).permute(2, 0, 1)[None].contiguous()
    spec = json.loads((ROOT / "lenses" / f"{args.lens}.json").read_text())
    max_field = max(abs(a) for a in spec["fields"]["angles_deg"])
    lens = geolens(args.lens, dtype=torch.float32)
    half_diagonal = float(lens.foclen) * math.tan(math.radians(max_field))
    lens.r_sensor = half_diagonal
    lens.set_sensor_res((width, height))
    torch.manual_seed(0)
    start = time.perf_counter()
    with torch.no_grad():
        out = lens.render(image, depth=-1e8, method="psf_map", psf_grid=(args.grid, args.grid),
                          psf_ks=args.kernel_px, psf_spp=args.spp)
    seconds = time.perf_counter() - start
    print(json.dumps({
        "tool": "deeplens", "version": version("deeplens-core"), "torch": torch.__version__,
        "lens": args.lens, "width": width, "height": height, "seconds": round(seconds, 2),
        "pixel_um": round(float(lens.pixel_size) * 1e3, 4), "psf_grid": args.grid, "kernel_px": args.kernel_px,
        "spp": args.spp, "wavelengths_um": list(lens.wvln_rgb), "psfs": 3 * args.grid**2,
        "finite": bool(torch.isfinite(out).all()),
    }))


if __name__ == "__main__":
    main()
