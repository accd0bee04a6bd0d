#!/usr/bin/env python3
"""A unicac lens file (lenses/*.json) as a DeepLens (deeplens-core 2.5.6) GeoLens, for the side-by-side
of bench/simulate_vs_deeplens.sh.

Mapping (DeepLens' native JSON, read by GeoLens.read_lens_json):
- each optical surface -> `Spheric` (`c`, `r` = clear semi-diameter, `d_next` = thickness, `mat2`) or,
  with a conic or even-asphere terms, `Aspheric` (`k`, `ai` from r^2 with `use_ai2`); a flat stop in air
  -> `Aperture`; the stop flag -> `is_aperture`;
- materials: air; a catalogue name (DeepLens looks it up in its bundled SCHOTT/CDGM AGF files); a model
  glass {nd, vd} -> DeepLens' "nd/vd" Cauchy model n = A + B / lambda^2 (unicac's model-glass formula,
  but with the F/d/C lines rounded to 486.1/587.6/656.3 nm: indices differ by ~1e-6);
- the image surface -> the sensor: its distance is the last `d_next`, `r_sensor` its semi-diameter;
- the object at infinity (points at depth -1e8 mm for PSFs), `primary_wvln` the file's primary.

Every surface of the bundled lenses has a semi-diameter, which DeepLens uses as a hard clip, as unicac
does. Usage from the peers: `from deeplens_lens import geolens; lens = geolens("cooke_triplet")`.
"""
from __future__ import annotations

import json
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def deeplens_dict(name: str) -> dict:
    spec = json.loads((ROOT / "lenses" / f"{name}.json").read_text())
    if spec.get("object_distance_mm") is not None:
        raise ValueError(f"{name}: only objects at infinity are converted")
    surfaces = spec["surfaces"]
    out = []
    for i, s in enumerate(surfaces[:-1]):
        c = s.get("curvature_per_mm")
        if c is None:
            r = s.get("radius_mm")
            c = 0.0 if not r else 1.0 / r
        material = s.get("material")
        if material is None or (isinstance(material, str) and material.lower() == "air"):
            mat2 = "air"
        elif isinstance(material, dict):
            mat2 = f"{material['nd']}/{material['vd']}"
        else:
            mat2 = material.split(":")[-1]
        previous = surfaces[i - 1].get("material") if i > 0 else None
        if "semi_diameter_mm" not in s:
            raise ValueError(f"{name}: surface {i + 1} has no semi-diameter (DeepLens needs one)")
        entry = {"r": s["semi_diameter_mm"], "d_next": s.get("thickness_mm", 0.0)}
        flat_stop_in_air = s.get("stop") and c == 0.0 and mat2 == "air" and previous in (None, "air", "AIR")
        if flat_stop_in_air:
            entry["type"] = "Aperture"
        elif s.get("type") == "even_asphere" or s.get("conic", 0.0):
            entry.update(type="Aspheric", c=c, k=s.get("conic", 0.0), mat2=mat2,
                         ai=list(s.get("aspheric_coefficients", [])) or [0.0], use_ai2=True)
        else:
            entry.update(type="Spheric", c=c, mat2=mat2)
        entry["is_aperture"] = bool(s.get("stop"))
        out.append(entry)
    waves = spec["wavelengths"]
    primary = waves[spec.get("primary_wavelength_index", 0)]["wavelength_um"]
    aperture = spec["aperture"]
    data = {"info": f"unicac lenses/{name}.json", "primary_wvln": primary,
            "r_sensor": surfaces[-1]["semi_diameter_mm"], "surfaces": out}
    if "entrance_pupil_diameter_mm" in aperture:
        data["enpd"] = aperture["entrance_pupil_diameter_mm"]
    return data


def geolens(name: str, dtype=None):
    """The lens loaded by DeepLens (float64 unless `dtype` says otherwise)."""
    import torch
    from deeplens import GeoLens

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / f"{name}.json"
        path.write_text(json.dumps(deeplens_dict(name)))
        return GeoLens(filename=str(path), device="cpu", dtype=dtype or torch.float64)


if __name__ == "__main__":
    import sys

    print(json.dumps(deeplens_dict(sys.argv[1] if len(sys.argv) > 1 else "cooke_triplet"), indent=1))
