#!/usr/bin/env python3
"""Reference values for every lenses/*.json from optiland and ray-optics.

Each lens is rebuilt in both tools through their Python APIs, once per
wavelength, with constant-index media (indices from optiland's catalogue data
or the unicac model-glass formula), then traced with explicitly defined rays.
See README.md next to this file for conventions and how to refresh.

Usage: python make_references.py [lens-name ...]
"""
from __future__ import annotations

import json
import math
import os
import sys
import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


def offline_rii_database() -> None:
    """ray-optics' opticalglass downloads the refractiveindex.info database on first
    import unless $refractiveindexinfodb points at one: point it at the copy bundled
    with optiland (no network here; only constant-index media are used anyway)."""
    if os.getenv("refractiveindexinfodb"):
        return
    import optiland.database as odb

    src = Path(odb.__file__).parent
    dst = Path(tempfile.gettempdir()) / "unicac-rii-database"
    dst.mkdir(exist_ok=True)
    for name, target in (("catalog-nk.yml", "catalog-nk.yml"), ("data", "data-nk")):
        link = dst / name
        if not link.exists():
            link.symlink_to(src / target)
    os.environ["refractiveindexinfodb"] = str(dst)
LENS_DIR = HERE.parents[1] / "lenses"
LAMBDA_F, LAMBDA_D, LAMBDA_C = 0.4861327, 0.5875618, 0.6562725
PUPIL_POINTS = [(0, 0), (0, 1), (0, -1), (1, 0), (0, 0.5), (0.7, 0.7), (-0.3, 0.8)]
AIMED_POINTS = [(0, 0), (0, 1), (0, -1), (1, 0)]
HEX_RINGS = 6
START_GAP_MM = 10.0  # rays start this far in front of min(surface 1, entrance pupil)
ASPHERE_TOL = 1e-15  # optiland Newton-Raphson tolerance (floored at round-off by optiland)


# ---------------------------------------------------------------- lens reader
def load_lens(path: Path) -> dict:
    """Read a unicac lens file (format_version 1) into a plain dict."""
    lens = json.loads(path.read_text())
    if lens.get("format_version") != 1:
        raise ValueError(f"{path}: unknown format_version")
    if lens.get("object_distance_mm") is not None:
        raise ValueError(f"{path}: only objects at infinity are supported here")
    for s in lens["surfaces"]:
        if "radius_mm" in s:
            r = s["radius_mm"]
            s["curvature_per_mm"] = 0.0 if not r else 1.0 / r
    lens["name_stem"] = path.stem
    return lens


def stop_index(lens: dict) -> int:
    """0-based index of the stop surface (surface 1 if none is flagged)."""
    flags = [i for i, s in enumerate(lens["surfaces"]) if s.get("stop")]
    return flags[0] if flags else 0


def field_angles(lens: dict) -> list[float]:
    return [float(a) for a in lens["fields"]["angles_deg"]]


def wavelengths(lens: dict) -> list[float]:
    return [w["wavelength_um"] for w in lens["wavelengths"]]


def primary_index(lens: dict) -> int:
    return lens.get("primary_wavelength_index", 1)


# ---------------------------------------------------------------- indices
def model_glass_index(nd: float, vd: float, wl_um: float) -> float:
    """unicac model glass: n = A + B / lambda^2 through nd with Abbe number vd."""
    b = (nd - 1.0) / (vd * (1.0 / LAMBDA_F**2 - 1.0 / LAMBDA_C**2))
    a = nd - b / LAMBDA_D**2
    return a + b / wl_um**2


def catalog_index(spec: str, catalogs: list[str], wl_um: float) -> float:
    """Index of a catalogue glass from optiland's refractiveindex.info data."""
    from optiland.materials import Material

    if ":" in spec:
        cat, name = spec.split(":", 1)
        return float(np.ravel(Material(name, reference=cat.lower()).n(wl_um))[0])
    errors = []
    for cat in catalogs:
        try:
            return float(np.ravel(Material(spec, reference=cat.lower()).n(wl_um))[0])
        except Exception as exc:  # try the next catalogue
            errors.append(f"{cat}: {exc}")
    raise ValueError(f"glass {spec!r} not found: {errors}")


def medium_index(material, catalogs: list[str], wl_um: float) -> float:
    if material is None or (isinstance(material, str) and material.upper() == "AIR"):
        return 1.0
    if isinstance(material, dict):
        return model_glass_index(material["nd"], material["vd"], wl_um)
    return catalog_index(material, catalogs, wl_um)


def lens_indices(lens: dict) -> list[list[float]]:
    """[wavelength][surface]: index of the medium after each surface."""
    cats = lens.get("glass_catalogs") or ["SCHOTT", "CDGM", "OHARA"]
    return [[medium_index(s.get("material"), cats, wl) for s in lens["surfaces"]]
            for wl in wavelengths(lens)]


def vertex_z(lens: dict) -> list[float]:
    """Global z of every vertex, surface 1 at 0."""
    z, out = 0.0, []
    for s in lens["surfaces"]:
        out.append(z)
        z += s.get("thickness_mm", 0.0)
    return out


# ---------------------------------------------------------------- ray sets
def hexapolar_pupil(rings: int = HEX_RINGS) -> list[tuple[float, float]]:
    pts = [(0.0, 0.0)]
    for i in range(1, rings + 1):
        r = i / rings
        for k in range(6 * i):
            a = 2.0 * math.pi * k / (6 * i)
            pts.append((r * math.cos(a), r * math.sin(a)))
    return pts


def pupil_rays(field_deg: float, pupil, epd: float, z_ep: float, z_start: float):
    """Start points on the plane z_start and the common direction (0, sin F, cos F)
    of rays through (px, py) * EPD/2 on the paraxial entrance-pupil plane."""
    f = math.radians(field_deg)
    d = np.array([0.0, math.sin(f), math.cos(f)])
    p = np.array(pupil, dtype=float).reshape(-1, 2) * epd / 2.0
    s = (z_start - z_ep) / d[2]
    starts = np.column_stack([p[:, 0] + s * d[0], p[:, 1] + s * d[1],
                              np.full(len(p), z_start)])
    return starts, np.tile(d, (len(p), 1))


# ---------------------------------------------------------------- optiland
class OptilandModel:
    """One lens at one wavelength in optiland, constant-index media."""

    name = "optiland"

    def __init__(self, lens: dict, indices: list[float], wl_um: float,
                 asphere_tol: float | None = ASPHERE_TOL):
        from optiland import optic
        from optiland.materials import IdealMaterial

        self.lens, self.wl = lens, wl_um
        op = optic.Optic()
        op.surfaces.add(index=0, radius=np.inf, thickness=np.inf)
        surfs = lens["surfaces"]
        for i, s in enumerate(surfs, start=1):
            c = s.get("curvature_per_mm", 0.0)
            kw = dict(index=i, radius=np.inf if c == 0 else 1.0 / c,
                      thickness=s.get("thickness_mm", 0.0) if i < len(surfs) else 0.0,
                      is_stop=bool(s.get("stop")), conic=s.get("conic", 0.0))
            if i < len(surfs):
                n = indices[i - 1]
                kw["material"] = "air" if n == 1.0 else IdealMaterial(n)
            if s.get("type") == "even_asphere":
                kw.update(surface_type="even_asphere",
                          coefficients=list(s.get("aspheric_coefficients", [])))
            op.surfaces.add(**kw)
        for surf in op.surfaces:  # tighten the asphere intersection (default 1e-10)
            if asphere_tol is not None and hasattr(surf.geometry, "tol"):
                surf.geometry.tol = asphere_tol
        ap = lens["aperture"]
        if "entrance_pupil_diameter_mm" in ap:
            op.set_aperture("EPD", ap["entrance_pupil_diameter_mm"])
        else:
            op.set_aperture("imageFNO", ap["f_number"])
        op.fields.set_type("angle")
        for a in field_angles(lens):
            op.fields.add(y=a)
        op.wavelengths.add(value=wl_um, is_primary=True)
        self.op = op

    def first_order(self) -> dict:
        from importlib.metadata import version

        pa, z = self.op.paraxial, vertex_z(self.lens)
        z_img, z_last = z[-1], z[-2]
        fo = {
            "efl_mm": float(pa.f2()),
            "bfl_mm": float(z_img + pa.F2() - z_last),
            "ffl_mm": float(pa.F1()),
            "epd_mm": float(pa.EPD()),
            "entrance_pupil_z_mm": float(pa.EPL()),
            "exit_pupil_z_mm": float(z_img + pa.XPL()),
            "exit_pupil_diameter_mm": float(pa.XPD()),
            "f_number": float(pa.FNO()),
            "total_track_mm": float(z_img),
            "paraxial_image_heights_mm": [self.paraxial_image_height(a)
                                          for a in field_angles(self.lens)],
            "stop_marginal_height_mm": float(np.ravel(pa.marginal_ray()[0][stop_index(self.lens) + 1])[0]),
        }
        fo["tool_version"] = version("optiland")
        return fo

    def paraxial_image_height(self, angle: float) -> float:
        """Paraxial chief ray: slope tan(F) through the entrance-pupil centre."""
        pa = self.op.paraxial
        u = math.tan(math.radians(angle))
        y, _ = pa.trace_generic(-u * float(pa.EPL()), u, 0.0, self.wl)
        return float(np.ravel(y[-1])[0])

    def trace(self, starts: np.ndarray, dirs: np.ndarray):
        """Per-surface intercepts [n_rays, n_surfaces, 3] (surface 1..image) and ok mask."""
        from optiland.rays import RealRays

        n = len(starts)
        rays = RealRays(starts[:, 0].copy(), starts[:, 1].copy(), starts[:, 2].copy(),
                        dirs[:, 0].copy(), dirs[:, 1].copy(), dirs[:, 2].copy(),
                        np.ones(n), np.full(n, self.wl))
        sg = self.op.surfaces
        sg.trace(rays)
        pts = np.stack([np.asarray(sg.x)[1:].T, np.asarray(sg.y)[1:].T,
                        np.asarray(sg.z)[1:].T], axis=-1)
        ok = np.all(np.isfinite(pts), axis=(1, 2)) & (np.asarray(sg.intensity)[-1] > 0)
        return pts, ok


# ---------------------------------------------------------------- ray-optics
class RayOpticsModel:
    """One lens at one wavelength in ray-optics, constant-index media."""

    name = "rayoptics"

    def __init__(self, lens: dict, indices: list[float], wl_um: float):
        offline_rii_database()
        from opticalglass.opticalmedium import ConstantIndex
        from rayoptics.elem.profiles import EvenPolynomial
        from rayoptics.environment import FieldSpec, OpticalModel, PupilSpec, WvlSpec

        self.lens, self.wl = lens, wl_um
        opm = OpticalModel()
        opm.radius_mode = False
        sm, osp = opm["seq_model"], opm["optical_spec"]
        ap = lens["aperture"]
        if "entrance_pupil_diameter_mm" in ap:
            osp["pupil"] = PupilSpec(osp, key=["object", "epd"], value=ap["entrance_pupil_diameter_mm"])
        else:
            osp["pupil"] = PupilSpec(osp, key=["image", "f/#"], value=ap["f_number"])
        angles = field_angles(lens)
        fmax = max(abs(a) for a in angles) or 1.0
        osp["fov"] = FieldSpec(osp, key=["object", "angle"], value=fmax,
                               flds=[a / fmax for a in angles], is_relative=True)
        osp["wvls"] = WvlSpec([(wl_um * 1e3, 1.0)], ref_wl=0)
        sm.gaps[0].thi = 1e10  # ray-optics' stand-in for an object at infinity
        for i, s in enumerate(lens["surfaces"][:-1]):
            n = indices[i]
            medium = ConstantIndex(n, f"n{n:.6f}") if n != 1.0 else "air"
            c = s.get("curvature_per_mm", 0.0)
            sm.add_surface([c, s.get("thickness_mm", 0.0), medium])
            if s.get("type") == "even_asphere" or s.get("conic", 0.0):
                # EvenPolynomial coefs[i] multiplies r^(2i+2), as in the unicac format
                coefs = list(s.get("aspheric_coefficients", []))
                sm.ifcs[sm.cur_surface].profile = EvenPolynomial(c=c, cc=s.get("conic", 0.0),
                                                                 coefs=coefs)
            if s.get("stop"):
                sm.set_stop()
        if not any(s.get("stop") for s in lens["surfaces"]):
            sm.stop_surface = 1
        opm.update_model()
        self.opm, self.sm = opm, sm

    def first_order(self) -> dict:
        from importlib.metadata import version

        pd = self.opm["analysis_results"]["parax_data"]
        fod, ax, pr = pd.fod, pd.ax_ray, pd.pr_ray
        z = vertex_z(self.lens)
        angles = field_angles(self.lens)
        fmax = max(abs(a) for a in angles) or 1.0
        img_ht = pr[-1][0]
        return {
            "efl_mm": float(fod.efl),
            "bfl_mm": float(fod.bfl),
            "ffl_mm": float(fod.ffl),
            "epd_mm": float(2 * fod.enp_radius),
            "entrance_pupil_z_mm": float(fod.enp_dist),
            # fod.exp_dist is measured from the paraxial focus, not the image surface
            # when the two differ; use the chief ray at the image surface instead.
            "exit_pupil_z_mm": float(z[-1] - pr[-1][0] / pr[-1][1]),
            "exit_pupil_diameter_mm": float(2 * fod.exp_radius),
            "f_number": float(fod.fno),
            "total_track_mm": float(z[-1]),
            # pr_ray is the paraxial chief ray of the largest field; heights of the
            # other fields are scaled by tan(F)/tan(Fmax) (paraxial linearity).
            "paraxial_image_heights_mm": [
                float(img_ht * math.tan(math.radians(a)) / math.tan(math.radians(fmax)))
                for a in angles],
            "stop_marginal_height_mm": float(ax[self.sm.stop_surface][0]),
            "tool_version": version("rayoptics"),
        }

    def path_from_plane(self, z_start: float):
        """The model's path with the object surface moved to the plane z = z_start
        (only the object->surface-1 transform changes; the model is not touched)."""
        path = list(self.sm.path(wl=self.wl * 1e3))
        first = list(path[0])
        first[2] = (np.identity(3), np.array([0.0, 0.0, -z_start]))
        return iter([tuple(first)] + path[1:])

    def trace(self, starts: np.ndarray, dirs: np.ndarray):
        from rayoptics.raytr.raytrace import trace_raw
        from rayoptics.raytr.traceerror import TraceError

        nsurf = len(self.lens["surfaces"])
        pts = np.full((len(starts), nsurf, 3), np.nan)
        ok = np.zeros(len(starts), dtype=bool)
        zv = np.array(vertex_z(self.lens))
        for k, (p, d) in enumerate(zip(starts, dirs)):
            try:
                ray, _, _ = trace_raw(self.path_from_plane(float(p[2])),
                                      np.array([p[0], p[1], 0.0]), d.copy(),
                                      self.wl * 1e3, eps=1e-15)
            except TraceError:
                continue
            seg = np.array([r[0] for r in ray[1:nsurf + 1]])
            seg[:, 2] += zv  # local sag -> global z
            pts[k], ok[k] = seg, True
        return pts, ok


# ---------------------------------------------------------------- analyses
def start_plane(aim: dict) -> float:
    return min(0.0, aim["entrance_pupil_z_mm"]) - START_GAP_MM


def clipped(lens: dict, pts: np.ndarray) -> np.ndarray:
    sd = np.array([s.get("semi_diameter_mm", np.inf) for s in lens["surfaces"]])
    r = np.hypot(pts[..., 0], pts[..., 1])
    return np.any(r > sd[None, :] * (1 + 1e-12), axis=1)


def ray_records(model, aim: dict) -> list[dict]:
    out = []
    for f in field_angles(model.lens):
        starts, dirs = pupil_rays(f, PUPIL_POINTS, aim["epd_mm"], aim["entrance_pupil_z_mm"],
                                  start_plane(aim))
        pts, ok = model.trace(starts, dirs)
        for (px, py), s, d, p, good in zip(PUPIL_POINTS, starts, dirs, pts, ok):
            rec = {"field_deg": f, "wavelength_um": model.wl, "pupil": [px, py],
                   "start_mm": s.tolist(), "direction": d.tolist(), "ok": bool(good)}
            if good:
                rec.update(x_mm=float(p[-1, 0]), y_mm=float(p[-1, 1]), z_mm=float(p[-1, 2]))
            out.append(rec)
    return out


def spot_records(model, aim: dict) -> list[dict]:
    out, pupil = [], hexapolar_pupil()
    for f in field_angles(model.lens):
        starts, dirs = pupil_rays(f, pupil, aim["epd_mm"], aim["entrance_pupil_z_mm"],
                                  start_plane(aim))
        pts, ok = model.trace(starts, dirs)
        good = ok & ~clipped(model.lens, np.nan_to_num(pts, nan=np.inf))
        xy = pts[good, -1, :2]
        c = xy.mean(axis=0)
        rms = math.sqrt(np.mean(np.sum((xy - c) ** 2, axis=1))) * 1000.0
        out.append({"field_deg": f, "wavelength_um": model.wl, "rays_traced": len(pupil),
                    "rays_ok": int(good.sum()), "centroid_x_mm": float(c[0]),
                    "centroid_y_mm": float(c[1]), "rms_radius_um": rms})
    return out


def aim_at_stop(model, f: float, target: np.ndarray, z0: float, guess: np.ndarray):
    """Newton iteration on the start point so the ray hits `target` on the stop."""
    si = stop_index(model.lens)
    rad = math.radians(f)
    d = np.array([[0.0, math.sin(rad), math.cos(rad)]])
    p = guess.astype(float).copy()
    h = 1e-7 * max(1.0, abs(target).max())
    for _ in range(30):
        trial = np.array([[p[0], p[1], z0], [p[0] + h, p[1], z0], [p[0], p[1] + h, z0]])
        pts, ok = model.trace(trial, np.repeat(d, 3, axis=0))
        if not ok.all():
            return None
        xy = pts[:, si, :2]
        err = xy[0] - target
        if np.abs(err).max() < 1e-13:
            return p, d[0], pts[0]
        jac = np.column_stack([(xy[1] - xy[0]) / h, (xy[2] - xy[0]) / h])
        p = p - np.linalg.solve(jac, err)
    return None


def aimed_records(model, aim: dict) -> list[dict]:
    out = []
    r_stop = aim["stop_marginal_height_mm"]
    z0 = start_plane(aim)
    for f in field_angles(model.lens):
        for px, py in AIMED_POINTS:
            s, _ = pupil_rays(f, [(px, py)], aim["epd_mm"], aim["entrance_pupil_z_mm"], z0)
            res = aim_at_stop(model, f, np.array([px, py]) * r_stop, z0, s[0, :2])
            rec = {"field_deg": f, "wavelength_um": model.wl, "pupil": [px, py], "ok": res is not None}
            if res is not None:
                p, d, pts = res
                rec.update(start_mm=[float(p[0]), float(p[1]), z0], direction=d.tolist(),
                           stop_xy_mm=pts[stop_index(model.lens), :2].tolist(),
                           x_mm=float(pts[-1, 0]), y_mm=float(pts[-1, 1]), z_mm=float(pts[-1, 2]))
            out.append(rec)
    return out


def common_aiming(lens: dict) -> dict:
    """Pupil data that defines every traced ray, for both tools: optiland's exact
    infinite-conjugate paraxial values at the primary wavelength."""
    prim = primary_index(lens)
    fo = OptilandModel(lens, lens_indices(lens)[prim], wavelengths(lens)[prim]).first_order()
    return {k: fo[k] for k in ("epd_mm", "entrance_pupil_z_mm", "stop_marginal_height_mm")}


def reference_for(lens: dict, tool_cls, aim: dict) -> dict:
    idx = lens_indices(lens)
    wls = wavelengths(lens)
    prim = primary_index(lens)
    models = [tool_cls(lens, idx[i], wl) for i, wl in enumerate(wls)]
    fo = models[prim].first_order()
    rays, spots = [], []
    for m in models:  # every wavelength is aimed with the primary-wavelength pupil
        rays += ray_records(m, aim)
        spots += spot_records(m, aim)
    return {"lens": lens["name_stem"], "tool": tool_cls.name, "tool_version": fo.pop("tool_version"),
            "wavelengths_um": wls, "primary_wavelength_index": prim,
            "indices": idx, "first_order": fo, "aiming": aim, "rays": rays, "spots": spots,
            "real_aimed": aimed_records(models[prim], aim)}


# ---------------------------------------------------------------- comparison
def max_differences(a: dict, b: dict) -> dict:
    fo = {k: abs(a["first_order"][k] - b["first_order"][k]) for k in a["first_order"]
          if isinstance(a["first_order"][k], float)}
    fo["paraxial_image_heights_mm"] = max(abs(x - y) for x, y in zip(
        a["first_order"]["paraxial_image_heights_mm"], b["first_order"]["paraxial_image_heights_mm"]))

    def maxdiff(ra, rb, keys):
        vals = [abs(np.subtract(p[k], q[k])).max() for p, q in zip(ra, rb)
                if p.get("ok", True) and q.get("ok", True) for k in keys]
        return float(max(vals)) if vals else 0.0

    return {
        "first_order": fo,
        "ray_start_mm": maxdiff(a["rays"], b["rays"], ["start_mm"]),
        "ray_image_mm": maxdiff(a["rays"], b["rays"], ["x_mm", "y_mm"]),
        "ray_ok_mismatch": sum(p["ok"] != q["ok"] for p, q in zip(a["rays"], b["rays"])),
        "spot_centroid_mm": maxdiff(a["spots"], b["spots"], ["centroid_x_mm", "centroid_y_mm"]),
        "spot_rms_um": maxdiff(a["spots"], b["spots"], ["rms_radius_um"]),
        "spot_count_mismatch": sum(p["rays_ok"] != q["rays_ok"] for p, q in zip(a["spots"], b["spots"])),
        "aimed_image_mm": maxdiff(a["real_aimed"], b["real_aimed"], ["x_mm", "y_mm"]),
    }


def main(names: list[str]) -> None:
    paths = sorted(LENS_DIR.glob("*.json"))
    if names:
        paths = [p for p in paths if p.stem in names]
    summary = {}
    for path in paths:
        lens = load_lens(path)
        refs, aim = {}, common_aiming(lens)
        for tool in (OptilandModel, RayOpticsModel):
            refs[tool.name] = reference_for(lens, tool, aim)
            out = HERE / tool.name / f"{path.stem}.json"
            out.parent.mkdir(exist_ok=True)
            out.write_text(json.dumps(refs[tool.name], indent=1) + "\n")
        diff = max_differences(refs["optiland"], refs["rayoptics"])
        summary[path.stem] = diff
        fo_max = max(diff["first_order"].items(), key=lambda kv: kv[1])
        print(f"{path.stem:15s} first-order max |d| {fo_max[1]:.2e} ({fo_max[0]}), "
              f"ray start {diff['ray_start_mm']:.2e}, ray image {diff['ray_image_mm']:.2e} mm, "
              f"spot centroid {diff['spot_centroid_mm']:.2e} mm, rms {diff['spot_rms_um']:.2e} um, "
              f"aimed {diff['aimed_image_mm']:.2e} mm, ok-mismatch {diff['ray_ok_mismatch']}/"
              f"{diff['spot_count_mismatch']}")
    (HERE / "differences.json").write_text(json.dumps(summary, indent=1) + "\n")


if __name__ == "__main__":
    main(sys.argv[1:])
