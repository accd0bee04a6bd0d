"""Shared setup: the unicac design specifications rebuilt as optiland problems.

Mirrors crates/unicac-design/src/{spec.rs,params.rs,merit.rs} as far as optiland 0.6.3 can express it:
layout (stop plane before element 1 / after element floor(N/2) / after the last), EPD = f/F#,
fields 0, 0.7, 1 of the image height (angle = atan(h tan(half FOV))), F/d/C with d primary,
variables = every curvature but the last lens surface's (|c| f <= 4) and every glass (1-10 mm) and air
(0.1-20 mm) thickness but the image distance; solves: last lens surface curvature by optiland's
marginal_ray_angle solve (EFL = f exactly), image distance by optiland's quick_focus solve (on-axis
real-ray focus, in place of unicac's paraxial focus + defocus variable). Glasses are fixed (optiland
cannot vary a dispersive glass continuously inside its scipy global optimisers).
"""
from __future__ import annotations

import json
import math
import time
import warnings

warnings.filterwarnings("ignore")
import numpy as np  # noqa: E402

import optiland.backend as be  # noqa: E402
from optiland.materials import Material  # noqa: E402
from optiland.optic import Optic  # noqa: E402
from optiland.optimization import OptimizationProblem  # noqa: E402
from optiland.optimization.operand.operand import operand_registry  # noqa: E402

LF, LD, LC = 0.4861327, 0.5875618, 0.6562725
CROWN, FLINT = "N-LAK9", "N-SF5"  # SCHOTT; nd/Vd 1.691/54.7 and 1.673/32.2

SPECS = {
    # name: elements, half fov, F#, stop, glass pattern (C crown / F flint, element order)
    "a": dict(elements=3, hfov=20.0, fno=5.0, stop="middle", glasses="CFC"),
    "b": dict(elements=4, hfov=30.0, fno=3.0, stop="middle", glasses="CFFC"),
    "c": dict(elements=5, hfov=30.0, fno=2.0, stop="front", glasses="CFCFC"),
    "d": dict(elements=6, hfov=40.0, fno=2.0, stop="middle", glasses="CCFFCC"),
}
F_MM = 50.0


def flags(spec):
    return (f"--elements {spec['elements']} --half-fov-deg {spec['hfov']:g} "
            f"--f-number {spec['fno']:g} --stop {spec['stop']}")


def field_angles(spec):
    t = math.tan(math.radians(spec["hfov"]))
    return [math.degrees(math.atan(h * t)) for h in (0.0, 0.7, 1.0)]


def layout(spec):
    """List of surfaces (kind, element index): kind in stop / front / back."""
    E = spec["elements"]
    stop_before = {"front": 0, "middle": E // 2, "back": E}[spec["stop"]]
    out = []
    for e in range(E + 1):
        if e == stop_before:
            out.append(("stop", None))
        if e < E:
            out.append(("front", e))
            out.append(("back", e))
    return out


_MAT = {}


def glass(name):
    if name not in _MAT:
        _MAT[name] = Material(name, reference="SCHOTT")
    return _MAT[name]


class _UpdateSemiApertures:
    """Appended to the solve list: refresh optiland's paraxial semi-apertures (|y_marginal| + |y_chief|)
    after every change, so the edge_thickness operands see the current beam."""

    def __init__(self, optic):
        self.optic = optic

    def apply(self):
        self.optic.updater.update_paraxial()


def _bfd(optic):
    """Last lens surface vertex to image plane (mm)."""
    z = optic.surfaces.positions
    return be.ravel(z)[-1] - be.ravel(z)[-2]


def _register():
    if "unicac_bfd" not in operand_registry:
        operand_registry.register("unicac_bfd", _bfd)


def build(spec, curv=None, thick=None):
    """Optic of the spec. curv/thick: values per layout surface (None -> flat, lower bound)."""
    f = F_MM
    lay = layout(spec)
    op = Optic()
    op.surfaces.add(index=0, radius=be.inf, thickness=be.inf)
    for i, (kind, e) in enumerate(lay, start=1):
        c = 0.0 if curv is None else curv[i - 1]
        if kind == "front":
            t = 1.0 if thick is None else thick[i - 1]
            g = CROWN if spec["glasses"][e] == "C" else FLINT
            op.surfaces.add(index=i, radius=(be.inf if c == 0 else 1.0 / c), thickness=t, material=glass(g))
        else:
            t = 0.1 if thick is None else thick[i - 1]
            if i == len(lay):
                t = 40.0 if thick is None else thick[i - 1]
            op.surfaces.add(index=i, radius=(be.inf if c == 0 else 1.0 / c), thickness=t,
                            is_stop=(kind == "stop"))
    op.surfaces.add(index=len(lay) + 1)
    op.set_aperture(aperture_type="EPD", value=f / spec["fno"])
    op.fields.set_type(field_type="angle")
    for a in field_angles(spec):
        op.fields.add(y=a)
    for w in (LF, LD, LC):
        op.wavelengths.add(value=w, is_primary=(w == LD))
    return op


def last_lens_surface(spec):
    lay = layout(spec)
    return max(i for i, (k, _) in enumerate(lay, start=1) if k != "stop")


def add_solves(op, spec):
    f = F_MM
    epd = f / spec["fno"]
    op.solves.add("marginal_ray_angle", last_lens_surface(spec), -(epd / 2) / f)
    op.solves.add("quick_focus")
    op.solves.solves.append(_UpdateSemiApertures(op))
    op.updater.update()


def make_problem(spec, rings=3):
    """optiland OptimizationProblem mirroring unicac's merit as far as optiland expresses it."""
    _register()
    f = F_MM
    s = f / 50.0
    op = build(spec)
    add_solves(op, spec)
    lay = layout(spec)
    n = len(lay)
    efl_surf = last_lens_surface(spec)
    prob = OptimizationProblem()
    cmax = 4.0 / f
    for i, (kind, e) in enumerate(lay, start=1):
        if kind != "stop" and i != efl_surf:
            prob.add_variable(op, "reciprocal_radius", surface_number=i, min_val=-cmax, max_val=cmax)
        if i != n:  # every gap but the image distance
            lo, hi = (1.0 * s, 10.0 * s) if kind == "front" else (0.1 * s, 20.0 * s)
            prob.add_variable(op, "thickness", surface_number=i, min_val=lo, max_val=hi)
    angles = field_angles(spec)
    hmax = spec["hfov"]
    # spot: mean over fields of RMS^2 in um^2 (optiland pools F, d, C about the d centroid)
    for a in angles:
        prob.add_operand("rms_spot_size", target=0.0, weight=1000.0 / math.sqrt(3.0),
                         input_data={"optic": op, "surface_number": -1, "Hx": 0.0, "Hy": a / hmax,
                                     "num_rays": rings, "wavelength": "all"})
    # EFL (solved exactly; kept as a guard), weight 1e4 per mm
    prob.add_operand("f2", target=f, weight=1e4 / 1.0 * (50.0 / f) * 0.0 + 100.0, input_data={"optic": op})
    # total track <= f (1.6 + 0.25 N)
    prob.add_operand("total_track", max_val=f * (1.6 + 0.25 * spec["elements"]), weight=1e4 * 50 / f,
                     input_data={"optic": op})
    # back focal distance >= 5 mm (custom operand registered in optiland's operand registry)
    prob.add_operand("unicac_bfd", min_val=5.0 * s, weight=1e4 * 50 / f, input_data={"optic": op})
    # edge thickness at optiland's paraxial semi-apertures: glass >= 0.7, air >= 0.1 (lens-lens gaps)
    for i, (kind, e) in enumerate(lay, start=1):
        if i == n:
            continue
        if kind == "front":
            prob.add_operand("edge_thickness", min_val=0.7 * s, weight=1e4 * 50 / f,
                             input_data={"optic": op, "surface_number": i})
        else:
            prob.add_operand("edge_thickness", min_val=0.1 * s, weight=1e4 * 50 / f,
                             input_data={"optic": op, "surface_number": i})
    # distortion |d| <= 5 % at fields 0.7 and 1: chief-ray image height within f tan(a) (1 +- 0.05),
    # weight 200 per % as unicac
    for a in angles[1:]:
        ideal = f * math.tan(math.radians(a))
        prob.add_operand("real_y_intercept", min_val=ideal * 0.95, max_val=ideal * 1.05,
                         weight=200.0 / (0.01 * ideal),
                         input_data={"optic": op, "surface_number": -1, "Hx": 0.0, "Hy": a / hmax,
                                     "Px": 0.0, "Py": 0.0, "wavelength": LD})
    return op, prob


def export_unicac(op, spec, name, path):
    """optiland optic -> unicac lens JSON (format 1); semi-diameters left to unicac (traced beams)."""
    lay = layout(spec)
    z = [float(v) for v in be.to_numpy(op.surfaces.positions).ravel()]
    surfs = []
    for i, (kind, e) in enumerate(lay, start=1):
        g = op.surfaces[i].geometry
        R = float(be.to_numpy(g.radius)) if hasattr(g, "radius") else math.inf
        c = 0.0 if not math.isfinite(R) else 1.0 / R
        d = {"curvature_per_mm": c, "thickness_mm": z[i + 1] - z[i]}
        if kind == "front":
            d["material"] = "SCHOTT:" + (CROWN if spec["glasses"][e] == "C" else FLINT)
        if kind == "stop":
            d["stop"] = True
        surfs.append(d)
    surfs.append({"curvature_per_mm": 0.0, "thickness_mm": 0.0})
    lens = {
        "format_version": 1,
        "name": name,
        "object_distance_mm": None,
        "aperture": {"entrance_pupil_diameter_mm": F_MM / spec["fno"]},
        "fields": {"angles_deg": field_angles(spec)},
        "field_weights": [1.0, 1.0, 1.0],
        "wavelengths": [{"wavelength_um": w, "weight": 1.0} for w in (LF, LD, LC)],
        "primary_wavelength_index": 1,
        "glass_catalogs": ["SCHOTT"],
        "surfaces": surfs,
    }
    with open(path, "w") as fh:
        json.dump(lens, fh, indent=1)
    return lens
