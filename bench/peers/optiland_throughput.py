#!/usr/bin/env python3
"""optiland (numpy backend) real-ray throughput on unicac lens files.

For cooke_triplet.json and phone_asphere.json: 1,000,000 rays (seed 12345),
half on axis and half at the largest field, uniform over the paraxial entrance
pupil disc, primary wavelength, aimed like tests/reference (no ray aiming).
optiland's default Newton tolerance for aspheres (1e-10) is kept. Only
optiland's SurfaceGroup.trace is timed (record=False): one warm-up, then
the median of 3 runs. Prints one JSON object per lens.

Run: /work/venv-ref/bin/python bench/peers/optiland_throughput.py
"""
from __future__ import annotations

import json
import os
import statistics
import sys
import time
from importlib.metadata import version
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "reference"))
import make_references as mr  # noqa: E402  (lens reader and optiland builder)

LENSES = ["cooke_triplet", "phone_asphere"]
N_RAYS = 1_000_000
SEED = 12345
RUNS = 3
THREAD_VARS = ["OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
               "NUMEXPR_NUM_THREADS"]


def uniform_disc(rng: np.random.Generator, n: int) -> np.ndarray:
    r = np.sqrt(rng.random(n))
    a = 2.0 * np.pi * rng.random(n)
    return np.column_stack([r * np.cos(a), r * np.sin(a)])


def ray_set(lens: dict, fo: dict) -> tuple[np.ndarray, np.ndarray]:
    """Half the rays on axis, half at the largest field, seeded."""
    rng = np.random.default_rng(SEED)
    half = N_RAYS // 2
    fields = [0.0, max(mr.field_angles(lens))]
    starts, dirs = [], []
    for f, n in zip(fields, (half, N_RAYS - half)):
        s, d = mr.pupil_rays(f, uniform_disc(rng, n), fo["epd_mm"],
                             fo["entrance_pupil_z_mm"], mr.start_plane(fo))
        starts.append(s)
        dirs.append(d)
    return np.concatenate(starts), np.concatenate(dirs)


def timed_trace(model, starts: np.ndarray, dirs: np.ndarray) -> float:
    from optiland.rays import RealRays

    rays = RealRays(starts[:, 0].copy(), starts[:, 1].copy(), starts[:, 2].copy(),
                    dirs[:, 0].copy(), dirs[:, 1].copy(), dirs[:, 2].copy(),
                    np.ones(len(starts)), np.full(len(starts), model.wl))
    t0 = time.perf_counter()
    model.op.surfaces.trace(rays, record=False)
    return time.perf_counter() - t0


def bench(stem: str) -> dict:
    lens = mr.load_lens(ROOT / "lenses" / f"{stem}.json")
    prim = mr.primary_index(lens)
    wl = mr.wavelengths(lens)[prim]
    # optiland's default asphere tolerance (1e-10), not the references' tighter one
    model = mr.OptilandModel(lens, mr.lens_indices(lens)[prim], wl, asphere_tol=None)
    starts, dirs = ray_set(lens, model.first_order())
    timed_trace(model, starts, dirs)  # warm-up
    seconds = statistics.median(timed_trace(model, starts, dirs) for _ in range(RUNS))
    surfaces = len(lens["surfaces"])  # surface 1 .. image surface
    return {
        "lens": stem, "rays": N_RAYS, "surfaces_traced_per_ray": surfaces,
        "seconds": seconds,
        "ray_surface_intersections_per_s": N_RAYS * surfaces / seconds,
        "numpy_version": np.__version__, "optiland_version": version("optiland"),
        "backend": "numpy", "wavelength_um": wl, "seed": SEED,
        "threads": {v: os.environ.get(v) for v in THREAD_VARS},
        "cpu_count": os.cpu_count(),
    }


def main() -> None:
    for stem in LENSES:
        print(json.dumps(bench(stem)), flush=True)


if __name__ == "__main__":
    main()
