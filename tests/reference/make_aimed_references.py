#!/usr/bin/env python3
"""Stop-aimed reference rays and spots from optiland for lenses with strong pupil
aberration (issue 11, part 1): the ray of pupil point (px, py) is the one that
crosses the stop surface at (px, py) * R_stop (docs/conventions.md, `real`
aiming), found here by Newton iteration on the start point with optiland's real
trace (tests/reference/stop_aiming.py), never by unicac.

Writes tests/reference/aimed/<lens>.json:
- `aiming`: optiland's paraxial EPD, entrance-pupil z and R_stop (primary wavelength);
- `rays`: per field and wavelength, pupil points (0,0), (0,1), (0,-1), (1,0), (0,0.5),
  (0.7,0.7): start point, direction, stop intercept, image intercept;
- `spots`: per field and wavelength, hexapolar pupil (6 rings, as make_references.py),
  stop-aimed, clipped by the file's semi-diameters: rays_ok, centroid, RMS radius (um).

Usage (venv of tests/reference/README.md): python make_aimed_references.py [lens ...]
(default: wide_angle_100).
"""
from __future__ import annotations

import json
import math
import sys
from importlib.metadata import version
from pathlib import Path

import numpy as np

import make_references as mr
import stop_aiming

HERE = Path(__file__).resolve().parent
RAY_POINTS = [(0, 0), (0, 1), (0, -1), (1, 0), (0, 0.5), (0.7, 0.7)]
FIELDS_DEG = [0.0, 20.0, 35.0, 50.0]


def references(lens: dict) -> dict:
    idx = mr.lens_indices(lens)
    aim = mr.common_aiming(lens)
    rays, spots = [], []
    pupil = mr.hexapolar_pupil()
    for i, wl in enumerate(mr.wavelengths(lens)):
        model = mr.OptilandModel(lens, idx[i], wl)
        for f in FIELDS_DEG:
            r = stop_aiming.aim_rays(model, lens, aim, f, RAY_POINTS)
            for k, (px, py) in enumerate(RAY_POINTS):
                rec = {"field_deg": f, "wavelength_um": wl, "pupil": [px, py], "ok": bool(r["ok"][k])}
                if rec["ok"]:
                    p = r["points"][k]
                    rec.update(start_mm=r["start"][k].tolist(), direction=r["direction"][k].tolist(),
                               stop_xy_mm=p[r["stop"], :2].tolist(),
                               x_mm=float(p[-1, 0]), y_mm=float(p[-1, 1]))
                rays.append(rec)
            s = stop_aiming.aim_rays(model, lens, aim, f, pupil)
            good = s["ok"] & ~mr.clipped(lens, np.nan_to_num(s["points"], nan=np.inf))
            xy = s["points"][good, -1, :2]
            c = xy.mean(axis=0)
            rms = math.sqrt(np.mean(np.sum((xy - c) ** 2, axis=1))) * 1000.0
            spots.append({"field_deg": f, "wavelength_um": wl, "rays_traced": len(pupil),
                          "rays_ok": int(good.sum()), "rays_aimed": int(s["ok"].sum()),
                          "centroid_x_mm": float(c[0]), "centroid_y_mm": float(c[1]),
                          "rms_radius_um": rms})
    return {"lens": lens["name_stem"], "tool": "optiland", "tool_version": version("optiland"),
            "method": "stop-aimed by Newton on optiland's real trace (stop_aiming.py), "
                      f"stop residual < {stop_aiming.TOLERANCE_MM} mm",
            "wavelengths_um": mr.wavelengths(lens), "indices": idx, "aiming": aim,
            "rays": rays, "spots": spots}


def main(names: list[str]) -> None:
    out_dir = HERE / "aimed"
    out_dir.mkdir(exist_ok=True)
    for name in names or ["wide_angle_100"]:
        lens = mr.load_lens(mr.LENS_DIR / f"{name}.json")
        ref = references(lens)
        (out_dir / f"{name}.json").write_text(json.dumps(ref, indent=1) + "\n")
        for s in ref["spots"]:
            if s["wavelength_um"] == mr.LAMBDA_D:
                print(f"{name} {s['field_deg']:5.1f} deg d: RMS {s['rms_radius_um']:.6f} um, "
                      f"{s['rays_ok']}/{s['rays_traced']} rays")
        marginal = next(r for r in ref["rays"] if r["field_deg"] == 0.0 and r["pupil"] == [0, 1]
                        and r["wavelength_um"] == mr.LAMBDA_D)
        print(f"{name} on-axis marginal ray (d): start y {marginal['start_mm'][1]:.6f} mm, "
              f"stop y {marginal['stop_xy_mm'][1]:.10f} mm (R_stop {ref['aiming']['stop_marginal_height_mm']:.10f})")


if __name__ == "__main__":
    main(sys.argv[1:])
