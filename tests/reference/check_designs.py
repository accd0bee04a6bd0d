#!/usr/bin/env python3
"""Independent check of designed lenses against the classic Cooke triplet (issue 11, part 4), in
optiland from the .zmx files that `unicac design` writes (and lenses/cooke_triplet.json converted to .zmx
by `unicac lens convert`): d-line RMS spot radius about the centroid at 0, 14 and 20 deg (hexapolar, 6
rings, rays through the paraxial entrance pupil, as make_references.py) and the smallest air gap between
neighbouring surfaces over the heights the beams use (every ray of F, d, C at the three fields, each
surface pair checked from the axis to the larger beam height of the two). unicac is not used here.

Usage: python check_designs.py COOKE.zmx DESIGN.zmx [DESIGN.zmx ...]   (prints one JSON object)
"""
from __future__ import annotations

import json
import math
import sys

import numpy as np

import make_references as mr

FIELDS_DEG = [0.0, 14.0, 20.0]
WAVELENGTHS_UM = [mr.LAMBDA_F, mr.LAMBDA_D, mr.LAMBDA_C]


def trace(optic, starts, dirs, wl):
    from optiland.rays import RealRays

    n = len(starts)
    rays = RealRays(starts[:, 0].copy(), starts[:, 1].copy(), starts[:, 2].copy(),
                    dirs[:, 0].copy(), dirs[:, 1].copy(), dirs[:, 2].copy(), np.ones(n), np.full(n, wl))
    sg = optic.surface_group
    sg.trace(rays)
    x, y = np.asarray(sg.x), np.asarray(sg.y)
    ok = np.all(np.isfinite(x), axis=0) & (np.asarray(sg.intensity)[-1] > 0)
    return x, y, ok


def check(path: str) -> dict:
    from optiland.fileio import load_zemax_file

    optic = load_zemax_file(path)
    pa = optic.paraxial
    epd, z_ep = float(pa.EPD()), float(pa.EPL())
    z_start = min(0.0, z_ep) - 10.0
    surfaces = list(optic.surface_group.surfaces)
    heights = np.zeros(len(surfaces))
    rms = []
    for wl in WAVELENGTHS_UM:
        for f in FIELDS_DEG:
            starts, dirs = mr.pupil_rays(f, mr.hexapolar_pupil(), epd, z_ep, z_start)
            x, y, ok = trace(optic, starts, dirs, wl)
            heights = np.maximum(heights, np.nanmax(np.hypot(x[:, ok], y[:, ok]), axis=1))
            if wl == mr.LAMBDA_D:
                xy = np.column_stack([x[-1, ok], y[-1, ok]])
                c = xy.mean(axis=0)
                rms.append(math.sqrt(np.mean(np.sum((xy - c) ** 2, axis=1))) * 1000.0)
    gaps = []
    for i in range(1, len(surfaces) - 2):
        a, b = surfaces[i], surfaces[i + 1]
        n = float(np.ravel(a.material_post.n(mr.LAMBDA_D))[0])
        if n != 1.0:
            continue
        r = np.linspace(0.0, max(heights[i], heights[i + 1]), 201)
        za = float(np.ravel(a.geometry.cs.z)[0]) + np.asarray(a.geometry.sag(np.zeros_like(r), r))
        zb = float(np.ravel(b.geometry.cs.z)[0]) + np.asarray(b.geometry.sag(np.zeros_like(r), r))
        gaps.append(float(np.min(zb - za)))
    return {"file": path, "rms_d_um": rms, "mean_rms_d_um": float(np.mean(rms)),
            "smallest_air_gap_over_beams_mm": min(gaps), "efl_mm": float(pa.f2())}


def main(paths: list[str]) -> None:
    from importlib.metadata import version

    cooke, designs = check(paths[0]), [check(p) for p in paths[1:]]
    best = min(designs, key=lambda d: d["mean_rms_d_um"]) if designs else None
    print(json.dumps({"tool": f"optiland {version('optiland')}", "cooke_triplet": cooke,
                      "designs": designs, "best": best,
                      "best_beats_cooke": bool(best and best["mean_rms_d_um"] < cooke["mean_rms_d_um"]),
                      "every_gap_at_least_0.1_mm": all(d["smallest_air_gap_over_beams_mm"] >= 0.1 - 1e-9
                                                       for d in designs)}, indent=1))


if __name__ == "__main__":
    main(sys.argv[1:])
