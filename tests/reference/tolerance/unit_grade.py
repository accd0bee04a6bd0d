#!/usr/bin/env python
"""Rebuild unicac `tolerance` units in optiland from trials.jsonl "changes" and grade them with
unicac's definitions (as stated in the brief), then compare with unicac's per-trial score.

Unit (1-based surface numbers, lens = builtin_cooke.json):
  radius     c -> c / (1 + v)
  thickness  gap after surface k += v; every later lens vertex moves with it; the image surface
             stays at its nominal z (the last gap absorbs it)
  index      medium after surface k: n(l) -> n(l) + v at every wavelength
  element_decentre_x/y, element_tilt_x/y (deg) on [first, last]: rigid body, R = Ry(ty) Rx(tx)
             about the element's front vertex (0, 0, z_first) after the thickness changes, then
             (dx, dy); each vertex v -> p + R (v - p) + (dx, dy, 0); axis -> R e_z (cs.rx, cs.ry)
Grading:
  field points and weights from run.json (angle fields, direction (tan x, tan y, 1)); real aiming
  for every unit, R_stop = paraxial marginal height at the stop (--rstop: unit_centred = the unit's
  centred system with the placed vertex z's, as unicac [default]; nominal = the nominal lens, as the
  brief said; centred = radius/thickness/index errors only); pupil = cell
  centres of an N x N grid over [-1,1]^2 inside the unit disc; semi-diameters clip (image never);
  polychromatic RMS about the pooled centroid, ray weight = w_lambda / n_arriving(lambda);
  back-focus compensator: image shift s minimising sum_j W_j RMS_j(s)^2 (exact: quadratic in s);
  rms_mean = sum W_j RMS_j / sum W_j; boresight = |centroid of the axis point| at the refocused plane.
"""
from __future__ import annotations

import argparse
import glob
import json
import math
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import cooke_lens as cl  # noqa: E402
import optiland.backend as be  # noqa: E402
from optiland.optic import Optic  # noqa: E402
from optiland.physical_apertures import RadialAperture  # noqa: E402


def grid_pupil(n):
    c = -1.0 + (2.0 * np.arange(n) + 1.0) / n
    # unicac's loop order is irrelevant for the RMS; keep row-major (y outer, x inner)
    pts = [(x, y) for y in c for x in c if x * x + y * y <= 1.0]
    return np.array(pts)


class Unit:
    """Per-surface placements of a unit built from a list of unicac changes."""

    def __init__(self, spec, changes, pivot="front", image_fixed=True, order="RyRx"):
        surfs = spec["surfaces"]
        self.spec = spec
        self.n = len(surfs)  # including image
        self.curv = [float(s.get("curvature_per_mm", 0.0)) for s in surfs]
        self.t_nom = [float(s["thickness_mm"]) for s in surfs[:-1]]
        self.dn = {}
        dt = [0.0] * (self.n - 1)
        el_dec, el_tilt = {}, {}
        s_dec, s_tilt = {}, {}
        for ch in changes:
            k, (a, b), v = ch["kind"], ch["surfaces"], float(ch["value"])
            if k == "radius":
                assert a == b
                self.curv[a - 1] = self.curv[a - 1] / (1.0 + v)
            elif k == "thickness":
                assert a == b
                dt[a - 1] += v
            elif k == "index":
                assert a == b
                self.dn[a] = self.dn.get(a, 0.0) + v
            elif k in ("element_decentre_x", "element_decentre_y"):
                d = el_dec.setdefault((a, b), [0.0, 0.0])
                d[0 if k.endswith("x") else 1] += v
            elif k in ("element_tilt_x", "element_tilt_y"):
                d = el_tilt.setdefault((a, b), [0.0, 0.0])
                d[0 if k.endswith("x") else 1] += v
            elif k in ("surface_decentre_x", "surface_decentre_y"):
                assert a == b
                d = s_dec.setdefault(a, [0.0, 0.0])
                d[0 if k.endswith("x") else 1] += v
            elif k in ("surface_tilt_x", "surface_tilt_y"):
                assert a == b
                d = s_tilt.setdefault(a, [0.0, 0.0])
                d[0 if k.endswith("x") else 1] += v
            else:
                raise ValueError(f"unknown change kind {k}")
        self.dt = dt
        # vertex z: nominal stack + thickness changes; the image stays at its nominal z
        z_nom = [0.0]
        for t in self.t_nom:
            z_nom.append(z_nom[-1] + t)
        z = [0.0]
        for i, t in enumerate(self.t_nom):
            z.append(z[-1] + t + dt[i])
        if image_fixed:
            z[-1] = z_nom[-1]
        self.z_image_nominal = z_nom[-1]
        pos = [np.array([0.0, 0.0, z[i]]) for i in range(self.n)]
        rot = [[0.0, 0.0] for _ in range(self.n)]
        elements = set(el_dec) | set(el_tilt)
        for (a, b) in sorted(elements):
            dx, dy = el_dec.get((a, b), (0.0, 0.0))
            tx, ty = el_tilt.get((a, b), (0.0, 0.0))
            rx, ry = math.radians(tx), math.radians(ty)
            Rx = np.array([[1, 0, 0], [0, math.cos(rx), -math.sin(rx)], [0, math.sin(rx), math.cos(rx)]])
            Ry = np.array([[math.cos(ry), 0, math.sin(ry)], [0, 1, 0], [-math.sin(ry), 0, math.cos(ry)]])
            R = Ry @ Rx if order == "RyRx" else Rx @ Ry
            if pivot == "front":
                piv = pos[a - 1].copy()
            elif pivot == "rear":
                piv = pos[b - 1].copy()
            else:  # mid-point of the element's vertices
                piv = 0.5 * (pos[a - 1] + pos[b - 1])
            for s in range(a, b + 1):
                pos[s - 1] = piv + R @ (pos[s - 1] - piv) + np.array([dx, dy, 0.0])
                ax = R @ np.array([0.0, 0.0, 1.0])  # the axis as unicac's from_frame reads it
                rot[s - 1] = [math.atan2(-ax[1], math.hypot(ax[0], ax[2])), math.atan2(ax[0], ax[2])]
        for s, (dx, dy) in s_dec.items():
            pos[s - 1] = pos[s - 1] + np.array([dx, dy, 0.0])
        for s, (tx, ty) in s_tilt.items():
            rot[s - 1] = [rot[s - 1][0] + math.radians(tx), rot[s - 1][1] + math.radians(ty)]
        self.pos, self.rot = pos, rot
        self.has_surface_terms = bool(s_dec or s_tilt)

    def optic(self, clip=True, centred=False):
        spec = self.spec
        surfs = spec["surfaces"]
        catalogs = spec.get("glass_catalogs", ["SCHOTT"])
        stop = next((i for i, s in enumerate(surfs) if s.get("stop")), 0) + 1
        op = Optic()
        op.surfaces.add(index=0, radius=be.inf, thickness=be.inf)
        for i, s in enumerate(surfs[:-1], start=1):
            c = self.curv[i - 1]
            kw = dict(index=i, radius=(be.inf if c == 0 else 1.0 / c),
                      thickness=float(self.pos[i][2] - self.pos[i - 1][2]), is_stop=(i == stop))
            m = s.get("material")
            if m is not None and not (isinstance(m, str) and m.upper() == "AIR"):
                dn = self.dn.get(i, 0.0)
                if isinstance(m, dict):
                    kw["material"] = cl.CauchyModelGlass(m["nd"], m["vd"], dn)
                else:
                    base, _ = cl.catalogue_glass(m, catalogs)
                    kw["material"] = cl.OffsetMaterial(base, dn) if dn != 0.0 else base
            if clip and s.get("semi_diameter_mm"):
                kw["aperture"] = RadialAperture(r_max=float(s["semi_diameter_mm"]))
            op.surfaces.add(**kw)
        op.surfaces.add(index=len(surfs))
        op.set_aperture(aperture_type="EPD", value=float(spec["aperture"]["entrance_pupil_diameter_mm"]))
        op.fields.set_type(field_type="angle")
        for a in spec["fields"]["angles_deg"]:
            op.fields.add(y=float(a))
        prim = spec.get("primary_wavelength_index", 1)
        for k, w in enumerate(spec["wavelengths"]):
            op.wavelengths.add(value=float(w["wavelength_um"]), is_primary=(k == prim))
        for i in range(1, self.n + 1):
            cs = op.surfaces[i].geometry.cs
            if centred:  # the unit's centred system: vertex z's as placed (thicknesses = z differences)
                cs.x, cs.y, cs.z = 0.0, 0.0, float(self.pos[i - 1][2])
                cs.rx, cs.ry = 0.0, 0.0
            else:
                cs.x, cs.y, cs.z = (float(v) for v in self.pos[i - 1])
                cs.rx, cs.ry = self.rot[i - 1]
        return op


def nominal_rstop(spec):
    u = Unit(spec, [])
    op = u.optic(clip=False)
    y, _ = op.paraxial.marginal_ray()
    return float(abs(be.to_numpy(y[op.surfaces.stop_index]).ravel()[0]))


def unit_centred_rstop(spec, changes):
    """paraxial marginal height at the stop of the unit's centred system: every change applied, then
    decentres and tilts dropped, the thicknesses being the placed vertices' z differences (so an
    element tilt's rear-vertex z shift t (cos - 1) counts), as unicac's lens does after apply()."""
    op = Unit(spec, changes).optic(clip=False, centred=True)
    y, _ = op.paraxial.marginal_ray()
    return float(abs(be.to_numpy(y[op.surfaces.stop_index]).ravel()[0]))


def centred_rstop(spec, changes):
    """paraxial marginal height at the stop of the centred perturbed unit (radii/thickness/index)."""
    keep = [c for c in changes if c["kind"] in ("radius", "thickness", "index")]
    op = Unit(spec, keep).optic(clip=False)
    y, _ = op.paraxial.marginal_ray()
    return float(abs(be.to_numpy(y[op.surfaces.stop_index]).ravel()[0]))


class Grader:
    def __init__(self, spec, run, rstop=None, aim="real"):
        self.spec = spec
        self.fields = [tuple(fp["field_deg"]) for fp in run["field_points"]]
        self.fw = np.array([fp["weight"] for fp in run["field_points"]], float)
        self.pupil = grid_pupil(run["grading"]["pupil_grid"])
        self.waves = [w["wavelength_um"] for w in spec["wavelengths"]]
        self.wts = [w.get("weight", 1.0) for w in spec["wavelengths"]]
        self.rstop = nominal_rstop(spec) if rstop is None else rstop
        self.aim = aim

    def field_rays(self, op, f):
        """Rays of one field at the (nominal-z) image plane: global x, y, slopes ux, uy, weights."""
        xs, ys, uxs, uys, ws = [], [], [], [], []
        n_ok = []
        for w, wt in zip(self.waves, self.wts):
            r = cl.trace_bundle(op, self.spec, f, self.pupil, w)  # to the image surface
            ok = r["ok"]
            n_ok.append(int(ok.sum()))
            if ok.sum() == 0:
                continue
            xs.append(r["x"][ok]); ys.append(r["y"][ok])
            uxs.append(r["L"][ok] / r["N"][ok]); uys.append(r["M"][ok] / r["N"][ok])
            ws.append(np.full(int(ok.sum()), wt / ok.sum()))
        return dict(x=np.concatenate(xs), y=np.concatenate(ys), ux=np.concatenate(uxs),
                    uy=np.concatenate(uys), w=np.concatenate(ws), n_ok=n_ok)

    @staticmethod
    def moments(b):
        W = b["w"].sum()
        m = lambda a: (b["w"] * a).sum() / W  # noqa: E731
        cx, cy, cux, cuy = m(b["x"]), m(b["y"]), m(b["ux"]), m(b["uy"])
        dx, dy, dux, duy = b["x"] - cx, b["y"] - cy, b["ux"] - cux, b["uy"] - cuy
        A = m(dx * dx + dy * dy)
        B = m(dx * dux + dy * duy)
        C = m(dux * dux + duy * duy)
        return A, B, C, (cx, cy, cux, cuy)

    def grade(self, unit, clip=True, compensate=True):
        op = unit.optic(clip=clip)
        if self.aim == "real":
            cl.set_aiming(op, "real", self.rstop)
        else:
            cl.set_aiming(op, "paraxial")
        bundles = [self.field_rays(op, f) for f in self.fields]
        mom = [self.moments(b) for b in bundles]
        if compensate:
            num = sum(w * B for w, (A, B, C, _) in zip(self.fw, mom))
            den = sum(w * C for w, (A, B, C, _) in zip(self.fw, mom))
            s = -num / den
        else:
            s = 0.0
        rms = [math.sqrt(max(A + 2 * B * s + C * s * s, 0.0)) * 1e3 for (A, B, C, _) in mom]
        rms_mean = float(np.dot(self.fw, rms) / self.fw.sum())
        axis = [j for j, f in enumerate(self.fields) if f == (0.0, 0.0)][0]
        cx, cy, cux, cuy = mom[axis][3]
        bore = math.hypot(cx + cux * s, cy + cuy * s) * 1e3
        return {"focus_shift_mm": float(s), "rms_um": rms, "rms_mean_um": rms_mean,
                "rms_max_um": max(rms), "boresight_um": bore,
                "rays_ok": [b["n_ok"] for b in bundles]}


def compare(u_score, o_score):
    out = {}
    for k in ("focus_shift_mm", "rms_mean_um", "rms_max_um", "boresight_um"):
        a, b = u_score[k], o_score[k]
        out[k] = {"unicac": a, "optiland": b, "abs": abs(a - b), "rel": abs(a - b) / max(abs(a), 1e-300)}
    ra, rb = np.array(u_score["rms_um"]), np.array(o_score["rms_um"])
    out["rms_um"] = {"abs": float(np.max(np.abs(ra - rb))), "rel": float(np.max(np.abs(ra - rb) / ra)),
                     "per_field_abs": list(np.abs(ra - rb))}
    return out


def main(argv=None):
    p = argparse.ArgumentParser()
    p.add_argument("--run", required=True, help="a `unicac tolerance` run folder")
    p.add_argument("--lens", default=cl.DEFAULT_LENS)
    p.add_argument("--trials", default="0-39", help="range a-b or comma list")
    p.add_argument("--out", required=True)
    p.add_argument("--rstop", choices=["nominal", "centred", "unit_centred"], default="unit_centred")
    a = p.parse_args(argv)
    spec = cl.load_lens(a.lens)
    run = json.load(open(os.path.join(a.run, "run.json")))
    summ = json.load(open(os.path.join(a.run, "summary.json")))
    chunks = sorted(glob.glob(os.path.join(a.run, "trials", "[0-9]*.jsonl")))
    trials = [json.loads(l) for c in chunks for l in open(c) if l.strip()]
    if "-" in a.trials:
        lo, hi = (int(x) for x in a.trials.split("-"))
        want = list(range(lo, hi + 1))
    else:
        want = [int(x) for x in a.trials.split(",")]
    g = Grader(spec, run)
    res = {"rstop_nominal_mm": g.rstop, "pupil_rays": len(g.pupil), "rstop_mode": a.rstop}
    t0 = time.time()
    nom = g.grade(Unit(spec, []))
    res["nominal"] = {"optiland": nom, "cmp": compare(summ["nominal"], nom), "t_s": time.time() - t0}
    print("nominal", {k: (v["abs"], v["rel"]) for k, v in res["nominal"]["cmp"].items()}, flush=True)
    rows = []
    by_trial = {t["trial"]: t for t in trials}
    for k in want:
        t = by_trial[k]
        t1 = time.time()
        if a.rstop == "centred":
            g.rstop = centred_rstop(spec, t["changes"])
        elif a.rstop == "unit_centred":
            g.rstop = unit_centred_rstop(spec, t["changes"])
        o = g.grade(Unit(spec, t["changes"]))
        c = compare(t["score"], o)
        rows.append({"trial": k, "optiland": o, "cmp": c, "t_s": time.time() - t1})
        print(k, f"{time.time() - t1:.1f}s", {q: f"{v['abs']:.2e}/{v['rel']:.2e}" for q, v in c.items()},
              flush=True)
    res["trials"] = rows
    qs = ("focus_shift_mm", "rms_um", "rms_mean_um", "rms_max_um", "boresight_um")
    res["max_over_trials"] = {q: {"abs": max(r["cmp"][q]["abs"] for r in rows),
                                  "rel": max(r["cmp"][q]["rel"] for r in rows)} for q in qs}
    res["elapsed_s"] = time.time() - t0
    json.dump(res, open(a.out, "w"), indent=1)
    print(json.dumps(res["max_over_trials"], indent=1))


if __name__ == "__main__":
    main()
