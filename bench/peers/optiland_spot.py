#!/usr/bin/env python3
"""optiland (numpy backend) peer of `unicac spot LENS --pupil-sampling random:N --field-deg MAX
--wavelength-um PRIMARY --aim paraxial --json`: one spot diagram of N random pupil rays at the lens's
largest field, primary wavelength, optiland's default (paraxial) aiming, RMS radius about the
centroid of the rays that arrive. The whole process is the measurement (bench/spot_vs_optiland.sh
times it from outside, like the unicac process); the script also prints its own in-process seconds.

Run: bench/.venv-peers/bin/python bench/peers/optiland_spot.py LENS [N]
"""
from __future__ import annotations

import json
import sys
import time
from pathlib import Path

START = time.perf_counter()

import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "reference"))
import make_references as mr  # noqa: E402  (lens reader and optiland builder)


def main() -> None:
    stem = sys.argv[1]
    n_rays = int(sys.argv[2]) if len(sys.argv) > 2 else 1_000_000
    if not 1 <= n_rays <= 1 << 24:
        sys.exit(f"N must be in 1..2^24, got {n_rays}")
    lens = mr.load_lens(ROOT / "lenses" / f"{stem}.json")
    prim = mr.primary_index(lens)
    wl = mr.wavelengths(lens)[prim]
    model = mr.OptilandModel(lens, mr.lens_indices(lens)[prim], wl, asphere_tol=None)
    setup_s = time.perf_counter() - START
    t0 = time.perf_counter()
    rays = model.op.trace(0.0, 1.0, wl, num_rays=n_rays, distribution="random")
    x, y, i = (np.asarray(v) for v in (rays.x, rays.y, rays.i))
    ok = (i > 0) & np.isfinite(x) & np.isfinite(y)
    cx, cy = x[ok].mean(), y[ok].mean()
    rms_um = float(np.sqrt(np.mean((x[ok] - cx) ** 2 + (y[ok] - cy) ** 2)) * 1e3)
    trace_s = time.perf_counter() - t0
    print(json.dumps({
        "lens": stem, "tool": "optiland", "rays": n_rays, "rays_ok": int(ok.sum()),
        "field_deg": max(mr.field_angles(lens)), "wavelength_um": wl, "rms_radius_um": rms_um,
        "import_and_setup_s": round(setup_s, 3), "trace_and_rms_s": round(trace_s, 3),
    }))


if __name__ == "__main__":
    main()
