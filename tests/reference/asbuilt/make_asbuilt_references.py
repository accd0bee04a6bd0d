"""Reference traces of decentred and tilted lenses from optiland (issue 36).

Builds as-built variants of lenses/cooke_triplet.json and lenses/double_gauss.json (the decentres and
tilts in VARIANTS below), writes each as a unicac lens file `lenses/<variant>.json` here, builds the same
system in optiland 0.6.3 through its Python API (per-surface dx, dy, rx, ry: the semantics of
docs/lens-format.md, "Decentres and tilts") with constant-index media, traces explicitly defined rays
and writes `<variant>.json`:

- `rays`: for every wavelength, every field of FIELDS_DEG (x and y object-space angles; direction
  (tan fx, tan fy, 1) normalised, optiland's angle fields) and pupil point of PUPIL_POINTS, the start
  point and direction and the global intercepts (`intercepts_mm`): on every surface (surface 1 ..
  image) at the primary wavelength, on the image surface only at the others;
- `spots`: per wavelength and field, a hexapolar pupil (6 rings, 127 rays) traced without clipping,
  the centroid and RMS radius about it on the image surface.

Rays start on the plane z = min(0, z_EP) - 10 mm and pass through (px, py) EPD/2 on the paraxial
entrance-pupil plane of the nominal (centred) lens: the same explicit rays for both tools, so no
aiming enters the comparison. No clear apertures clip (decentred apertures are not compared).

Run (see ../README.md for the venv; optiland 0.6.3 only):
    python tests/reference/asbuilt/make_asbuilt_references.py
"""

from __future__ import annotations

import copy
import json
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
import make_references as mr  # noqa: E402  (the shared lens reader, indices and optiland model)

FIELDS_DEG = [(0.0, 0.0), (0.0, 1.0), (0.0, -1.0), (0.7, 0.0), (0.5, 0.5)]  # fractions of the max field
PUPIL_POINTS = [(0, 0), (0, 1), (0, -1), (1, 0), (-1, 0), (0.7, 0.7), (-0.3, 0.8)]

# variant -> (base lens, {surface index (0-based): placement})
VARIANTS = {
    "cooke_decentred": ("cooke_triplet", {
        2: {"decentre_y_mm": 0.05},
        3: {"decentre_x_mm": -0.03, "decentre_y_mm": 0.02},
    }),
    "cooke_tilted": ("cooke_triplet", {
        0: {"tilt_x_deg": 0.2},
        4: {"tilt_y_deg": -0.3},
        6: {"tilt_x_deg": 0.5, "tilt_y_deg": 0.4},  # the image surface (a tilted sensor)
    }),
    "cooke_mixed": ("cooke_triplet", {
        1: {"decentre_x_mm": 0.1, "tilt_x_deg": -0.5, "tilt_y_deg": 1.0},
        3: {"decentre_y_mm": -0.04, "tilt_x_deg": 0.3},  # the stop
        5: {"decentre_x_mm": 0.02, "decentre_y_mm": 0.03, "tilt_x_deg": 2.0, "tilt_y_deg": -1.5},
    }),
    "double_gauss_mixed": ("double_gauss", {
        0: {"decentre_y_mm": 0.05, "tilt_x_deg": 0.1},
        3: {"decentre_x_mm": -0.02, "tilt_y_deg": 0.25},
        7: {"decentre_x_mm": 0.03, "decentre_y_mm": -0.01, "tilt_x_deg": -0.2, "tilt_y_deg": 0.15},
        10: {"tilt_y_deg": -0.4},
    }),
}


class PlacedOptilandModel(mr.OptilandModel):
    """`make_references.OptilandModel` with each surface's decentre and tilt set on its coordinate
    system (optiland: x = dx, y = dy, rx, ry in radians; z stays the nominal vertex)."""

    def __init__(self, lens: dict, indices: list[float], wl_um: float):
        super().__init__(lens, indices, wl_um)
        for i, s in enumerate(lens["surfaces"], start=1):
            cs = self.op.surfaces[i].geometry.cs
            cs.x = s.get("decentre_x_mm", 0.0)
            cs.y = s.get("decentre_y_mm", 0.0)
            cs.rx = math.radians(s.get("tilt_x_deg", 0.0))
            cs.ry = math.radians(s.get("tilt_y_deg", 0.0))


def field_direction(fx_deg: float, fy_deg: float) -> np.ndarray:
    d = np.array([math.tan(math.radians(fx_deg)), math.tan(math.radians(fy_deg)), 1.0])
    return d / np.linalg.norm(d)


def rays_through_pupil(d: np.ndarray, pupil, aim: dict) -> np.ndarray:
    """Start points on the start plane of rays along d through (px, py) EPD/2 on the pupil plane."""
    z_ep, z0 = aim["entrance_pupil_z_mm"], mr.start_plane(aim)
    p = np.array(pupil, dtype=float).reshape(-1, 2) * aim["epd_mm"] / 2.0
    s = (z0 - z_ep) / d[2]
    return np.column_stack([p[:, 0] + s * d[0], p[:, 1] + s * d[1], np.full(len(p), z0)])


def fields(lens: dict) -> list[tuple[float, float]]:
    top = max(abs(a) for a in mr.field_angles(lens))
    return [(fx * top, fy * top) for fx, fy in FIELDS_DEG]


def reference(name: str, lens: dict) -> dict:
    idx, wls = mr.lens_indices(lens), mr.wavelengths(lens)
    nominal = copy.deepcopy(lens)
    for s in nominal["surfaces"]:
        for key in ("decentre_x_mm", "decentre_y_mm", "tilt_x_deg", "tilt_y_deg"):
            s.pop(key, None)
    aim = mr.common_aiming(nominal)
    rays, spots = [], []
    primary = wls[mr.primary_index(lens)]
    for wl, n in zip(wls, idx):
        model = PlacedOptilandModel(lens, n, wl)
        for fx, fy in fields(lens):
            d = field_direction(fx, fy)
            starts = rays_through_pupil(d, PUPIL_POINTS, aim)
            pts, ok = model.trace(starts, np.tile(d, (len(starts), 1)))
            for (px, py), s, p, good in zip(PUPIL_POINTS, starts, pts, ok):
                rec = {"field_deg": [fx, fy], "wavelength_um": wl, "pupil": [px, py],
                       "start_mm": s.tolist(), "direction": d.tolist(), "ok": bool(good)}
                if good:
                    rec["intercepts_mm"] = (p if wl == primary else p[-1:]).tolist()
                rays.append(rec)
            pupil = mr.hexapolar_pupil()
            starts = rays_through_pupil(d, pupil, aim)
            pts, ok = model.trace(starts, np.tile(d, (len(starts), 1)))
            xy = pts[ok, -1, :2]
            c = xy.mean(axis=0)
            rms = math.sqrt(np.mean(np.sum((xy - c) ** 2, axis=1))) * 1000.0
            spots.append({"field_deg": [fx, fy], "wavelength_um": wl, "rays_traced": len(pupil),
                          "rays_ok": int(ok.sum()), "centroid_mm": c.tolist(), "rms_radius_um": rms})
    from importlib.metadata import version

    return {"lens": name, "tool": "optiland", "tool_version": version("optiland"),
            "indices": idx, "aiming": aim, "fields_deg": [list(f) for f in fields(lens)],
            "rays": rays, "spots": spots}


def main() -> None:
    (HERE / "lenses").mkdir(exist_ok=True)
    for name, (base, placements) in VARIANTS.items():
        text = (mr.LENS_DIR / f"{base}.json").read_text()
        lens_file = json.loads(text)
        lens_file["name"] = f"{lens_file.get('name', base)}, as built ({name})"
        for i, placement in placements.items():
            lens_file["surfaces"][i].update(placement)
        (HERE / "lenses" / f"{name}.json").write_text(json.dumps(lens_file, indent=2) + "\n")
        lens = mr.load_lens(HERE / "lenses" / f"{name}.json")
        ref = reference(name, lens)
        (HERE / f"{name}.json").write_text(json.dumps(ref) + "\n")
        worst = max(s["rms_radius_um"] for s in ref["spots"])
        print(f"{name}: {len(ref['rays'])} rays, {len(ref['spots'])} spots, largest RMS {worst:.3f} um")


if __name__ == "__main__":
    main()
