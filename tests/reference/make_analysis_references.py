#!/usr/bin/env python3
"""Reference values of the lens analyses (`unicac analysis`, crates/unicac-analysis) from optiland.

Each lens is rebuilt in optiland as make_references.py does (the file's surfaces, aperture and fields,
the refractive indices unicac uses), with two differences: one system carries all wavelengths (a
tabulated material gives each medium its index at each of them), so that every wavelength is aimed
through the primary wavelength's paraxial pupil, as in unicac; and the file's clear semi-diameters
become optiland RadialApertures, so that both tools vignette the same rays. Written per lens
to analysis/<lens>.json:

- `fft_mtf`: optiland's FFTMTF (scalar, "chief_ray" reference sphere) per field and wavelength, with
  num_rays=128 and grid_size=256 (the pupil sampled at 128 points across, zero-padded twice: the MTF
  is then the pupil autocorrelation at 128 lags, no aliasing). Its frequency axis (per field and
  direction, from real marginal rays) and its tangential and sagittal MTF.
- `geometric_mtf`: per field and wavelength, optiland's GeometricMTF (spot histogram of 257 bins,
  unscaled) at 64 frequencies up to its cutoff, and the exact ray MTF |mean exp(-2 pi i nu y)| of the
  rays that optiland traces through unicac's pupil grid (128 x 128 cell centres inside the disc).
- `through_focus`: primary wavelength, FFTMTF (as above) with the image surface moved by each focus
  shift (as optiland's ThroughFocus analyses move it), linearly interpolated at one frequency, and the
  RMS spot radius about the centroid of the grid rays.
- `field_curvature`: optiland's FieldCurvature (parabasal ray pairs, delta 1e-5) per wavelength at 11
  fields; `distortion`: optiland's Distortion (f-tan, chief ray, plate scale from the near-axis real
  chief ray), primary wavelength, same fields.
- `relative_illumination`: optiland 0.6.3 has no relative-illumination analysis, so it is computed here
  from optiland's rays with the formula of docs/analysis.md: T(F) cos F sin F h'(0)^2 / (h h'), T the
  arriving fraction of the grid rays (all wavelengths, equal weights), h the chief-ray height, h' by
  central differences (1e-4 rad).
- `encircled_energy`: optiland's grid rays of all wavelengths (equal weights, shared within a
  wavelength), fraction within r of the weighted centroid, at 41 radii, and the 50% / 80% radii.

Run (optiland 0.6.3 in any venv, e.g. the one of tests/reference/README.md):
    python tests/reference/make_analysis_references.py [lens ...]     (~1 min per lens)
"""
from __future__ import annotations

import json
import math
import sys
from importlib.metadata import version
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import make_references as mr  # noqa: E402

LENSES = ["cooke_triplet", "double_gauss", "phone_asphere"]
GRID = 128          # pupil samples per axis, both tools
FFT_GRID = 256      # optiland's zero-padded FFT size (2 x GRID)
GEOMETRIC_POINTS = 64
CURVE_FIELDS = 11
SLOPE_STEP_RAD = 1e-4


def tabulated_material(table: dict[float, float]):
    """An optiland material with the given index at each of the lens's wavelengths (the indices unicac
    uses), so one system carries every wavelength and its pupil comes from the primary one, as in
    unicac (per-wavelength systems would each get their own entrance pupil)."""
    import optiland.backend as be
    from optiland.materials.base import BaseMaterial

    wls = np.array(sorted(table))
    ns = np.array([table[w] for w in wls])

    class Tabulated(BaseMaterial):
        def _cache_state(self):
            return tuple(ns.tolist())

        def _calculate_n(self, wavelength, **kwargs):
            w = np.asarray(be.to_numpy(wavelength), dtype=float)
            nearest = np.abs(w[..., None] - wls).argmin(axis=-1)
            if np.abs(w - wls[nearest]).max(initial=0.0) > 1e-9:
                raise ValueError(f"no index tabulated at {w}")
            return be.array(ns[nearest])

        def _calculate_k(self, wavelength, **kwargs):
            return be.zeros_like(be.array(np.asarray(be.to_numpy(wavelength), dtype=float)))

    return Tabulated()


def optic_for(lens: dict, idx: list[list[float]], wls: list[float], prim: int):
    """The lens in optiland with every wavelength (primary flagged), tabulated indices, and the file's
    semi-diameters as RadialApertures; otherwise as make_references.OptilandModel."""
    from optiland import optic
    from optiland.physical_apertures import RadialAperture

    op = optic.Optic()
    op.surfaces.add(index=0, radius=np.inf, thickness=np.inf)
    surfs = lens["surfaces"]
    for i, s in enumerate(surfs, start=1):
        c = s.get("curvature_per_mm", 0.0)
        kw = dict(index=i, radius=np.inf if c == 0 else 1.0 / c,
                  thickness=s.get("thickness_mm", 0.0) if i < len(surfs) else 0.0,
                  is_stop=bool(s.get("stop")), conic=s.get("conic", 0.0))
        if i < len(surfs):
            column = {wl: row[i - 1] for wl, row in zip(wls, idx)}
            kw["material"] = "air" if all(n == 1.0 for n in column.values()) else tabulated_material(column)
            if s.get("semi_diameter_mm") is not None:
                kw["aperture"] = RadialAperture(r_max=float(s["semi_diameter_mm"]))
        if s.get("type") == "even_asphere":
            kw.update(surface_type="even_asphere", coefficients=list(s.get("aspheric_coefficients", [])))
        op.surfaces.add(**kw)
    for surf in op.surfaces:
        if hasattr(surf.geometry, "tol"):
            surf.geometry.tol = mr.ASPHERE_TOL
    ap = lens["aperture"]
    if "entrance_pupil_diameter_mm" in ap:
        op.set_aperture("EPD", ap["entrance_pupil_diameter_mm"])
    else:
        op.set_aperture("imageFNO", ap["f_number"])
    op.fields.set_type("angle")
    for a in mr.field_angles(lens):
        op.fields.add(y=a)
    for k, wl in enumerate(wls):
        op.wavelengths.add(value=wl, is_primary=(k == prim))
    return op


def cell_grid(n: int = GRID):
    c = -1.0 + (np.arange(n) + 0.5) * 2.0 / n
    px, py = np.meshgrid(c, c)
    inside = px**2 + py**2 <= 1.0
    return px[inside], py[inside], int(inside.sum())


def grid_rays(op, h: float, wl: float):
    """Image points of the arriving grid rays, and how many cells the disc holds."""
    px, py, cells = cell_grid()
    rays = op.trace_generic(Hx=np.zeros_like(px), Hy=np.full_like(px, h), Px=px, Py=py, wavelength=wl)
    x, y = np.asarray(rays.x), np.asarray(rays.y)
    ok = (np.asarray(rays.i) > 0) & np.isfinite(x) & np.isfinite(y)
    return np.column_stack([x[ok], y[ok]]), cells


def fft_mtf(op, h: float, wl: float) -> dict:
    from optiland.mtf import FFTMTF

    m = FFTMTF(op, fields=[(0.0, h)], wavelength=wl, num_rays=GRID, grid_size=FFT_GRID)
    return {"step_tangential_cy_mm": float(m.freq_tang[0][1]), "step_sagittal_cy_mm": float(m.freq_sag[0][1]),
            "tangential": [float(v) for v in m.mtf[0][0][:GRID]],
            "sagittal": [float(v) for v in m.mtf[0][1][:GRID]]}


def exact_ray_mtf(points: np.ndarray, axis: int, freqs: np.ndarray) -> list[float]:
    u = points[:, axis] - points[:, axis].mean()
    return [float(abs(np.mean(np.exp(-2j * math.pi * f * u)))) for f in freqs]


def geometric(op, h: float, wl: float) -> dict:
    from optiland.mtf import GeometricMTF

    g = GeometricMTF(op, fields=[(0.0, h)], wavelength=wl, num_rays=GRID, distribution="uniform",
                     num_points=256, scale=False)
    pick = np.linspace(0, 255, GEOMETRIC_POINTS).round().astype(int)
    freqs = np.asarray(g.freq)[pick]
    points, _ = grid_rays(op, h, wl)
    return {"frequencies_cy_mm": freqs.tolist(),
            "optiland_tangential": [float(v) for v in np.asarray(g.mtf[0][0])[pick]],
            "optiland_sagittal": [float(v) for v in np.asarray(g.mtf[0][1])[pick]],
            "exact_tangential": exact_ray_mtf(points, 1, freqs),
            "exact_sagittal": exact_ray_mtf(points, 0, freqs)}


def rms_um(points: np.ndarray) -> float:
    c = points.mean(axis=0)
    return float(math.sqrt(np.mean(np.sum((points - c) ** 2, axis=1))) * 1e3)


def through_focus(op, lens: dict, wl: float, fmax: float) -> dict:
    fno = float(op.paraxial.FNO())
    unit = wl * 1e-3 * fno**2
    shifts = [k * unit for k in (-4, -2, 0, 2, 4)]
    frequency = round(1.0 / (wl * 1e-3 * fno) / 4.0)
    z0 = float(op.image_surface.geometry.cs.z)
    out = []
    for f in mr.field_angles(lens):
        h = f / fmax if fmax else 0.0
        t, s, rms = [], [], []
        for dz in shifts:
            op.image_surface.geometry.cs.z = z0 + dz
            m = fft_mtf(op, h, wl)
            lag = np.arange(GRID)
            t.append(float(np.interp(frequency, lag * m["step_tangential_cy_mm"], m["tangential"])))
            s.append(float(np.interp(frequency, lag * m["step_sagittal_cy_mm"], m["sagittal"])))
            rms.append(rms_um(grid_rays(op, h, wl)[0]))
        op.image_surface.geometry.cs.z = z0
        out.append({"field_deg": f, "tangential": t, "sagittal": s, "rms_spot_um": rms})
    return {"wavelength_um": wl, "frequency_cy_mm": frequency, "focus_shifts_mm": shifts, "fields": out}


def chief_height(op, h: float, wl: float) -> float:
    rays = op.trace_generic(Hx=0.0, Hy=h, Px=0.0, Py=0.0, wavelength=wl)
    return float(np.ravel(rays.y)[0])


def relative_illumination(lens: dict, idx: list, wls: list[float], prim: int, fields: list[float]) -> dict:
    # The derivative at the largest field needs a ray beyond it: these systems get one more field, 1%
    # further out, which only changes the normalisation H = F / fmax.
    op = optic_for(lens, idx, wls, prim)
    fmax = 1.01 * max(abs(f) for f in fields)
    op.fields.add(y=fmax)
    ops = [op] * len(wls)
    step_h = SLOPE_STEP_RAD / math.radians(fmax)

    def transmission(h):
        return np.mean([len(grid_rays(op, h, wl)[0]) / grid_rays(op, h, wl)[1] for op, wl in zip(ops, wls)])

    def slope(h):
        return (chief_height(ops[prim], h + step_h, wls[prim]) - chief_height(ops[prim], h - step_h, wls[prim])) \
            / (2 * SLOPE_STEP_RAD)

    t0, s0 = transmission(0.0), slope(0.0)
    ri, vig = [], []
    for f in fields:
        h = f / fmax
        v = transmission(h) / t0
        a = math.radians(f)
        mapping = 1.0 if f == 0 else math.cos(a) * math.sin(a) * s0**2 / (chief_height(ops[prim], h, wls[prim]) * slope(h))
        ri.append(v * mapping)
        vig.append(v)
    return {"fields_deg": fields, "relative_illumination": ri, "vignetting": vig}


def encircled(ops: list, wls: list[float], fields: list[float], fmax: float) -> list[dict]:
    out = []
    for f in fields:
        h = f / fmax
        groups = [grid_rays(op, h, wl)[0] for op, wl in zip(ops, wls)]
        weights = np.concatenate([np.full(len(g), 1.0 / len(g)) for g in groups])
        points = np.concatenate(groups)
        weights /= weights.sum()
        c = (points * weights[:, None]).sum(axis=0)
        d = np.hypot(points[:, 0] - c[0], points[:, 1] - c[1]) * 1e3
        order = np.argsort(d)
        d, cum = d[order], np.cumsum(weights[order])
        radii = np.linspace(0.0, d[-1], 41)
        energy = [float(cum[np.searchsorted(d, r, side="right") - 1]) if r >= d[0] else 0.0 for r in radii]
        r_at = lambda q: float(d[min(np.searchsorted(cum, q - 1e-12), len(d) - 1)])  # noqa: E731
        out.append({"field_deg": f, "radii_um": radii.tolist(), "energy": energy,
                    "radius_50_um": r_at(0.5), "radius_80_um": r_at(0.8)})
    return out


def reference(name: str) -> dict:
    from optiland.analysis import Distortion, FieldCurvature

    lens = mr.load_lens(mr.LENS_DIR / f"{name}.json")
    idx, wls, prim = mr.lens_indices(lens), mr.wavelengths(lens), mr.primary_index(lens)
    ops = [optic_for(lens, idx, wls, prim)] * len(wls)
    fields = mr.field_angles(lens)
    fmax = max(abs(f) for f in fields)
    out = {"lens": name, "tool": "optiland", "tool_version": version("optiland"), "numpy": np.__version__,
           "pupil_grid": GRID, "wavelengths_um": wls, "primary_wavelength_index": prim,
           "fft_mtf": [], "geometric_mtf": []}
    for f in fields:
        for op, wl in zip(ops, wls):
            out["fft_mtf"].append({"field_deg": f, "wavelength_um": wl} | fft_mtf(op, f / fmax, wl))
            out["geometric_mtf"].append({"field_deg": f, "wavelength_um": wl} | geometric(op, f / fmax, wl))
    out["through_focus"] = through_focus(ops[prim], lens, wls[prim], fmax)
    curve_h = np.linspace(1e-10, 1, CURVE_FIELDS)
    curve_fields = (curve_h * fmax).tolist()
    out["field_curvature"] = []
    fc = FieldCurvature(ops[prim], num_points=CURVE_FIELDS)
    for k, wl in enumerate(wls):
        out["field_curvature"].append({"wavelength_um": wl, "fields_deg": (np.linspace(0, 1, CURVE_FIELDS) * fmax).tolist(),
                                       "tangential_mm": [float(v) for v in fc.data[k][0]],
                                       "sagittal_mm": [float(v) for v in fc.data[k][1]]})
    d = Distortion(ops[prim], wavelengths=[wls[prim]], num_points=CURVE_FIELDS, distortion_type="f-tan")
    out["distortion"] = {"wavelength_um": wls[prim], "fields_deg": curve_fields,
                         "distortion_percent": [float(v) for v in d.data[0]]}
    ri_fields = (np.linspace(0, 1, CURVE_FIELDS) * fmax).tolist()
    out["relative_illumination"] = relative_illumination(lens, idx, wls, prim, ri_fields)
    out["encircled_energy"] = encircled(ops, wls, fields, fmax)
    return out


def compact(value):
    """Floats to 12 significant digits (the tightest tolerance, 1e-9, needs 10)."""
    if isinstance(value, float):
        return float(f"{value:.12g}")
    if isinstance(value, list):
        return [compact(v) for v in value]
    if isinstance(value, dict):
        return {k: compact(v) for k, v in value.items()}
    return value


def dumps(ref: dict) -> str:
    """Indented JSON with every list of numbers on one line."""
    import re

    text = json.dumps(compact(ref), indent=1)
    return re.sub(r"\[\s+([-+0-9.eE,\s]+?)\s+\]", lambda m: "[" + re.sub(r"\s+", "", m.group(1)) + "]", text)


def main(names: list[str]) -> None:
    mr.offline_rii_database()
    for name in names or LENSES:
        ref = reference(name)
        path = HERE / "analysis" / f"{name}.json"
        path.write_text(dumps(ref) + "\n")
        print(f"wrote {path.relative_to(HERE.parents[1])}")


if __name__ == "__main__":
    main(sys.argv[1:])
