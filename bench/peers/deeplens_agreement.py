#!/usr/bin/env python3
"""The same lens in DeepLens (deeplens-core 2.5.6, float64) as in unicac: refractive indices, RMS spot
radius on unicac's pupil grid, and the geometric PSF, printed as one JSON object for
bench/simulate_vs_deeplens.sh to set beside unicac's numbers.

- indices: DeepLens' materials (bundled AGF catalogues; "nd/vd" Cauchy for model glasses) at the lens
  file's wavelengths;
- RMS spot: the cell centres of a GRID x GRID square grid inside the paraxial entrance pupil (unicac's
  `grid:N` sampling with `--aim paraxial`), direction (0, sin F, cos F), traced by DeepLens to its
  sensor; RMS radius about the centroid of the rays DeepLens keeps (its surfaces clip at their
  semi-diameters, as unicac's);
- PSF: DeepLens' `psf_geometric` (2^20 random rays, bilinear splatting onto the pixel grid, centred on
  the chief ray) at the field and pixel pitch given, with its second-moment radius.

Run: .venv-deeplens/bin/python bench/peers/deeplens_agreement.py LENS FIELD_DEG PIXEL_UM KERNEL_PX [GRID]
"""
from __future__ import annotations

import json
import math
import sys
from importlib.metadata import version
from pathlib import Path

import torch

sys.path.insert(0, str(Path(__file__).resolve().parent))
from deeplens_lens import ROOT, geolens  # noqa: E402


def rms_spot_um(lens, field_deg: float, wavelength: float, grid: int, r_ep: float) -> dict:
    from deeplens.light.ray import Ray

    z_ep, _ = lens.get_entrance_pupil(paraxial=True)
    c = -1.0 + (torch.arange(grid, dtype=torch.float64) + 0.5) * 2.0 / grid
    py, px = torch.meshgrid(c, c, indexing="ij")
    inside = px**2 + py**2 <= 1.0
    px, py = px[inside], py[inside]
    f = math.radians(field_deg)
    d = torch.tensor([0.0, math.sin(f), math.cos(f)], dtype=torch.float64).expand(len(px), 3).clone()
    o = torch.stack([px * r_ep, py * r_ep, torch.full_like(px, float(z_ep))], dim=-1)
    # Start 10 mm before the first vertex, on the line through the pupil point.
    o = o - d * ((float(z_ep) + 10.0) / d[:, 2:3])
    ray = Ray(o, d, wavelength, device="cpu")
    ray = lens.trace2sensor(ray)
    valid = ray.is_valid > 0
    xy = ray.o[..., :2][valid]
    centroid = xy.mean(dim=0)
    rms = torch.sqrt(((xy - centroid) ** 2).sum(dim=-1).mean()) * 1e3
    return {"field_deg": field_deg, "wavelength_um": wavelength, "rays_traced": int(len(px)),
            "rays_ok": int(valid.sum()), "rms_radius_um": float(rms),
            "centroid_y_mm": float(centroid[1])}


def psf(lens, field_deg: float, wavelength: float, pixel_um: float, kernel_px: int) -> dict:
    w, h = lens.sensor_size
    res = round(2 * w / (pixel_um * 1e-3)) // 2
    lens.set_sensor_res((res, res))
    y = float(lens.foclen) * math.tan(math.radians(field_deg)) / (lens.sensor_size[1] / 2)
    torch.manual_seed(0)
    kernel = lens.psf_geometric(torch.tensor([0.0, y, -1e8], dtype=torch.float64), ks=kernel_px,
                                wvln=wavelength, spp=1 << 20).double()
    size = kernel.shape[-1]
    coordinate = (torch.arange(size, dtype=torch.float64) - (size - 1) / 2) * lens.pixel_size * 1e3
    total = kernel.sum()
    cy = (kernel.sum(dim=1) * coordinate).sum() / total
    cx = (kernel.sum(dim=0) * coordinate).sum() / total
    second = (kernel * ((coordinate[None, :] - cx) ** 2 + (coordinate[:, None] - cy) ** 2)).sum() / total
    return {"field_deg": field_deg, "wavelength_um": wavelength, "pixel_um": float(lens.pixel_size * 1e3),
            "kernel_px": size, "peak": float(kernel.max() / total), "second_moment_radius_um": float(second.sqrt()),
            "kernel": kernel.tolist()}


def main() -> None:
    name, field, pixel_um, kernel_px = sys.argv[1], float(sys.argv[2]), float(sys.argv[3]), int(sys.argv[4])
    grid = int(sys.argv[5]) if len(sys.argv) > 5 else 256
    torch.set_num_threads(2)
    spec = json.loads((ROOT / "lenses" / f"{name}.json").read_text())
    waves = [w["wavelength_um"] for w in spec["wavelengths"]]
    primary = waves[spec.get("primary_wavelength_index", 0)]
    fields = spec["fields"]["angles_deg"]
    lens = geolens(name)
    # unicac's entrance pupil: the file's diameter, or EFL / F# (DeepLens sizes its own pupil from the
    # stop's semi-diameter, slightly larger than the paraxial marginal height in these files).
    aperture = spec["aperture"]
    r_ep = aperture["entrance_pupil_diameter_mm"] / 2 if "entrance_pupil_diameter_mm" in aperture \
        else float(lens.foclen) / aperture["f_number"] / 2
    indices = [[float(s.mat2.ior(w)) for s in lens.surfaces if hasattr(s, "mat2")] for w in waves]
    out = {"tool": "deeplens", "version": version("deeplens-core"), "torch": torch.__version__, "lens": name,
           "foclen_mm": float(lens.foclen), "indices": {str(w): row for w, row in zip(waves, indices)},
           "entrance_pupil_radius_mm": r_ep,
           "spots": [rms_spot_um(lens, f, primary, grid, r_ep) for f in fields],
           "psf": psf(lens, field, primary, pixel_um, kernel_px)}
    print(json.dumps(out))


if __name__ == "__main__":
    main()
