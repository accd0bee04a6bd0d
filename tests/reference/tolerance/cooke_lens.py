"""Shared helpers: the unicac Cooke triplet rebuilt in optiland, as-built perturbations,
ray tracing and polychromatic centroid-referenced RMS spot radii.

The lens is read from the unicac lens JSON (default: lenses/cooke_triplet.json of this repository,
written by `unicac lens convert builtin:cooke_triplet builtin_cooke.json`).

Conventions (the same as unicac's docs/conventions.md and docs/lens-format.md):
- global z along the axis, surface 1 vertex at z = 0, mm;
- field angle (fx, fy) deg -> direction (tan fx, tan fy, 1) normalised (optiland's angle fields);
- a model glass {nd, vd} is n(l) = A + B / l^2 (l in um), B = (nd-1)/(vd (1/lF^2 - 1/lC^2)),
  A = nd - B/ld^2 (unicac's formula), catalogue glasses from optiland's catalogue data;
- semi_diameter_mm -> optiland RadialAperture on the surface (local frame), rays outside are
  dropped from spots (unicac 'clipped').
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field

import warnings

import numpy as np

try:  # numba's pedantic IR warnings from optiland's conic kernel are noise here
    from numba.core.errors import NumbaIRAssumptionWarning

    warnings.filterwarnings("ignore", category=NumbaIRAssumptionWarning)
except Exception:  # noqa: BLE001
    pass
# optiland warns (once per trace) that its scalar paraxial results ignore tilts/decentres; we rely
# only on real rays for perturbed systems (paraxial data come from the centred system), so mute it.
warnings.filterwarnings("ignore", message=".*scalar first-order results ignore.*")

import optiland.backend as be
from optiland.materials import Material
from optiland.materials.base import BaseMaterial
from optiland.optic import Optic
from optiland.physical_apertures import RadialAperture

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_LENS = os.path.join(HERE, "..", "..", "..", "lenses", "cooke_triplet.json")

LAMBDA_F, LAMBDA_D, LAMBDA_C = 0.4861327, 0.5875618, 0.6562725


# --------------------------------------------------------------------------- materials
class CauchyModelGlass(BaseMaterial):
    """unicac model glass n = A + B / l^2 (+ dn, a constant index offset)."""

    def __init__(self, nd: float, vd: float, dn: float = 0.0):
        super().__init__()
        self.nd, self.vd, self.dn = float(nd), float(vd), float(dn)
        self.B = (self.nd - 1.0) / (self.vd * (1.0 / LAMBDA_F**2 - 1.0 / LAMBDA_C**2))
        self.A = self.nd - self.B / LAMBDA_D**2

    def _cache_state(self):
        return (self.A, self.B, self.dn)

    def _calculate_n(self, wavelength, **kwargs):
        w = be.array(wavelength)
        return self.A + self.dn + self.B / (w * w)

    def _calculate_k(self, wavelength, **kwargs):
        return np.zeros_like(np.asarray(wavelength, dtype=float)) if be.is_array_like(wavelength) else 0.0


class OffsetMaterial(BaseMaterial):
    """A catalogue glass with a constant index offset dn at every wavelength."""

    def __init__(self, base: BaseMaterial, dn: float = 0.0):
        super().__init__()
        self.base, self.dn = base, float(dn)

    def _cache_state(self):
        return (id(self.base), self.dn)

    def _calculate_n(self, wavelength, **kwargs):
        return self.base.n(wavelength) + self.dn

    def _calculate_k(self, wavelength, **kwargs):
        return self.base.k(wavelength)


_CATALOGUE_CACHE: dict = {}


def catalogue_glass(name: str, catalogs: list[str]):
    """optiland Material for a unicac glass name ("F2" or "SCHOTT:F2")."""
    if ":" in name:
        cat, glass = name.split(":", 1)
        order = [cat]
    else:
        glass, order = name, list(catalogs) or ["SCHOTT", "CDGM", "OHARA"]
    key = (glass.upper(), tuple(order))
    if key not in _CATALOGUE_CACHE:
        last = None
        for cat in order:
            try:
                _CATALOGUE_CACHE[key] = (Material(glass, reference=cat), cat)
                break
            except Exception as e:  # noqa: BLE001
                last = e
        else:
            raise ValueError(f"glass {name} not found in {order}: {last}")
    return _CATALOGUE_CACHE[key]


# --------------------------------------------------------------------------- lens spec
def load_lens(path: str = DEFAULT_LENS) -> dict:
    with open(path) as f:
        spec = json.load(f)
    if spec.get("format_version") != 1:
        raise ValueError("unicac lens format_version 1 expected")
    if spec.get("object_distance_mm") not in (None,):
        raise ValueError("only objects at infinity are supported here")
    for s in spec["surfaces"]:
        if s.get("type", "standard") != "standard" or s.get("conic", 0.0) != 0.0:
            raise ValueError("only spherical standard surfaces are supported here")
    return spec


def radius_of(surface: dict) -> float:
    if "radius_mm" in surface:
        r = surface["radius_mm"]
        return math.inf if (r is None or r == 0) else float(r)
    c = surface.get("curvature_per_mm", 0.0)
    return math.inf if c == 0 else 1.0 / c


def elements_of(spec: dict) -> list[tuple[int, int]]:
    """(first, last) 1-based surface numbers of each glass element (singlets and cemented groups:
    a run of surfaces whose medium after them is glass, plus the closing surface)."""
    surfs = spec["surfaces"][:-1]
    out, i = [], 0
    while i < len(surfs):
        if _is_glass(surfs[i]):
            j = i
            while j < len(surfs) and _is_glass(surfs[j]):
                j += 1
            out.append((i + 1, j + 1))
            i = j + 1
        else:
            i += 1
    return out


def _is_glass(surface: dict) -> bool:
    m = surface.get("material")
    return m is not None and not (isinstance(m, str) and m.upper() == "AIR")


# --------------------------------------------------------------------------- as-built lens
@dataclass
class AsBuilt:
    """A perturbed lens: per-surface radii and thicknesses, per-element rigid decentre/tilt
    (about the element's front vertex), per-glass-medium index offsets, image distance.

    Surface numbers are 1-based (unicac). Tilts in degrees, R = Ry(tilt_y) Rx(tilt_x) (optiland's
    and unicac's order; positive tilt_x turns the axis towards -y, positive tilt_y towards +x).
    """

    radii: list[float]
    thicknesses: list[float]  # thickness after surface 1..n_surf-1 (last = image distance)
    dn: dict[int, float] = field(default_factory=dict)  # surface number -> index offset after it
    element_decentre: dict[tuple[int, int], tuple[float, float]] = field(default_factory=dict)
    element_tilt_deg: dict[tuple[int, int], tuple[float, float]] = field(default_factory=dict)
    surface_decentre: dict[int, tuple[float, float]] = field(default_factory=dict)
    surface_tilt_deg: dict[int, tuple[float, float]] = field(default_factory=dict)

    @classmethod
    def nominal(cls, spec):
        surfs = spec["surfaces"]
        return cls(
            radii=[radius_of(s) for s in surfs[:-1]],
            thicknesses=[float(s["thickness_mm"]) for s in surfs[:-1]],
        )

    def is_centred(self):
        vals = [v for d in (self.element_decentre, self.element_tilt_deg, self.surface_decentre,
                            self.surface_tilt_deg) for pair in d.values() for v in pair]
        return all(v == 0.0 for v in vals)

    def placements(self):
        """Global vertex position (x, y, z) and (rx, ry) radians of every surface 1..n (image last)."""
        n = len(self.radii) + 1
        z = [0.0]
        for t in self.thicknesses:
            z.append(z[-1] + t)
        pos = [[0.0, 0.0, z[i]] for i in range(n)]
        rot = [[0.0, 0.0] for _ in range(n)]
        for (a, b), (dx, dy) in self.element_decentre.items():
            for s in range(a, b + 1):
                pos[s - 1][0] += dx
                pos[s - 1][1] += dy
        for (a, b), (tx, ty) in self.element_tilt_deg.items():
            if tx == 0.0 and ty == 0.0:
                continue
            rx, ry = math.radians(tx), math.radians(ty)
            piv = list(pos[a - 1])  # pivot: element front vertex (as decentred)
            for s in range(a, b + 1):
                v = [pos[s - 1][k] - piv[k] for k in range(3)]
                # rotate_x(rx) then rotate_y(ry), as optiland's CoordinateSystem.globalize
                y1 = v[1] * math.cos(rx) - v[2] * math.sin(rx)
                z1 = v[1] * math.sin(rx) + v[2] * math.cos(rx)
                x1 = v[0]
                x2 = x1 * math.cos(ry) + z1 * math.sin(ry)
                z2 = -x1 * math.sin(ry) + z1 * math.cos(ry)
                pos[s - 1] = [piv[0] + x2, piv[1] + y1, piv[2] + z2]
                rot[s - 1] = [rx, ry]
        for s, (dx, dy) in self.surface_decentre.items():
            pos[s - 1][0] += dx
            pos[s - 1][1] += dy
        for s, (tx, ty) in self.surface_tilt_deg.items():
            rot[s - 1][0] += math.radians(tx)
            rot[s - 1][1] += math.radians(ty)
        return pos, rot

    def to_dict(self):
        pos, rot = self.placements()
        return {
            "radii_mm": self.radii,
            "thicknesses_mm": self.thicknesses,
            "index_offsets": {str(k): v for k, v in self.dn.items()},
            "element_decentre_mm": {f"{a}-{b}": list(v) for (a, b), v in self.element_decentre.items()},
            "element_tilt_deg": {f"{a}-{b}": list(v) for (a, b), v in self.element_tilt_deg.items()},
            "surface_vertex_global_mm": pos,
            "surface_rx_ry_rad": rot,
        }


def build_optic(spec: dict, asb: AsBuilt | None = None, clip: bool = True) -> Optic:
    """Build the optiland Optic of the (perturbed) lens. Positions/rotations are written to each
    surface's coordinate system directly (optiland's per-surface cs: vertex (x, y, z) global,
    rotation about the vertex), never through set_thickness, so rigid element placements stay."""
    if asb is None:
        asb = AsBuilt.nominal(spec)
    surfs = spec["surfaces"]
    catalogs = spec.get("glass_catalogs", ["SCHOTT", "CDGM", "OHARA"])
    stop = next((i for i, s in enumerate(surfs) if s.get("stop")), 0) + 1
    op = Optic()
    op.surfaces.add(index=0, radius=be.inf, thickness=be.inf)
    for i, s in enumerate(surfs[:-1], start=1):
        kw = dict(index=i, radius=asb.radii[i - 1], thickness=asb.thicknesses[i - 1],
                  is_stop=(i == stop))
        m = s.get("material")
        if m is not None and not (isinstance(m, str) and m.upper() == "AIR"):
            dn = asb.dn.get(i, 0.0)
            if isinstance(m, dict):
                kw["material"] = CauchyModelGlass(m["nd"], m["vd"], dn)
            else:
                base, _ = catalogue_glass(m, catalogs)
                kw["material"] = OffsetMaterial(base, dn) if dn != 0.0 else base
        if clip and s.get("semi_diameter_mm"):
            kw["aperture"] = RadialAperture(r_max=float(s["semi_diameter_mm"]))
        op.surfaces.add(**kw)
    op.surfaces.add(index=len(surfs))
    ap = spec["aperture"]
    if "entrance_pupil_diameter_mm" in ap:
        op.set_aperture(aperture_type="EPD", value=float(ap["entrance_pupil_diameter_mm"]))
    else:
        op.set_aperture(aperture_type="imageFNO", value=float(ap["f_number"]))
    op.fields.set_type(field_type="angle")
    angles = spec["fields"]["angles_deg"]
    for a in angles:
        op.fields.add(y=float(a))
    prim = spec.get("primary_wavelength_index", 1)
    for k, w in enumerate(spec["wavelengths"]):
        op.wavelengths.add(value=float(w["wavelength_um"]), is_primary=(k == prim))
    # placements
    pos, rot = asb.placements()
    for i in range(1, len(surfs) + 1):
        cs = op.surfaces[i].geometry.cs
        cs.x, cs.y, cs.z = pos[i - 1]
        cs.rx, cs.ry = rot[i - 1]
    return op


def max_field_deg(spec):
    return max(abs(a) for a in spec["fields"]["angles_deg"])


# --------------------------------------------------------------------------- aiming
class _FixedStopRadius:
    def __init__(self, r):
        self.r = r

    def calculate_stop_radius(self):
        return self.r


def paraxial_stop_radius(spec, asb: AsBuilt) -> float:
    """Paraxial marginal-ray height at the stop of the *centred* version of the as-built lens
    (unicac: R_stop of real aiming comes from the nominal, centred system's paraxial data)."""
    centred = AsBuilt(radii=asb.radii, thicknesses=asb.thicknesses, dn=asb.dn)
    op = build_optic(spec, centred, clip=False)
    y, _ = op.paraxial.marginal_ray()
    return float(abs(be.to_numpy(y[op.surfaces.stop_index]).ravel()[0]))


def set_aiming(op: Optic, mode: str, r_stop: float | None = None):
    """mode 'paraxial' (optiland default, = unicac paraxial) or 'real' (optiland iterative aimer,
    targets (px, py) * R_stop on the stop in its own frame). With r_stop given, R_stop is that
    value (unicac's convention: paraxial marginal height) instead of optiland's real-marginal-ray
    stop radius."""
    if mode == "paraxial":
        op.ray_tracer.set_aiming("paraxial")
        return
    op.ray_tracer.set_aiming("iterative", max_iter=30, tol=1e-12)
    if r_stop is not None:
        op._unicac_r_stop = r_stop


def _install_stop_radius_patch():
    import optiland.rays.ray_aiming.initialization as init

    if getattr(init, "_unicac_patched", False):
        return
    orig = init.get_stop_radius_strategy

    def patched(optic, aiming_mode):
        r = getattr(optic, "_unicac_r_stop", None)
        if r is not None:
            return _FixedStopRadius(r)
        return orig(optic, aiming_mode)

    init.get_stop_radius_strategy = patched
    init._unicac_patched = True


_install_stop_radius_patch()


# --------------------------------------------------------------------------- tracing / spots
def hexapolar(rings: int = 10):
    pts = [(0.0, 0.0)]
    for i in range(1, rings + 1):
        r = i / rings
        c = 6 * i
        for k in range(c):
            a = 2 * math.pi * k / c
            pts.append((r * math.cos(a), r * math.sin(a)))
    return np.array(pts)


def trace_bundle(op: Optic, spec: dict, field_xy_deg, pupil: np.ndarray, wavelength: float,
                 upto: int | None = None):
    """Trace rays of one field (fx, fy deg) through (px, py) at one wavelength.
    Returns dict of global x, y, z, L, M, N at surface `upto` (default: image) and `ok` mask
    (intensity > 0 and finite)."""
    fmax = max_field_deg(spec)
    hx, hy = field_xy_deg[0] / fmax, field_xy_deg[1] / fmax
    n = len(pupil)
    Hy = np.full(n, hy)
    op.trace_generic(np.full(n, hx), Hy, pupil[:, 0].copy(), pupil[:, 1].copy(), wavelength)
    k = op.surfaces.num_surfaces - 1 if upto is None else upto
    S = op.surfaces
    out = {q: be.to_numpy(getattr(S, q)[k]).ravel().astype(float) for q in ("x", "y", "z", "L", "M", "N")}
    inten = be.to_numpy(S.intensity[-1]).ravel()
    ok = (inten > 0)
    for q in ("x", "y", "z", "L", "M", "N"):
        ok &= np.isfinite(out[q])
    out["ok"] = ok
    return out


def rms_poly(xs, ys, ws):
    """Centroid-referenced RMS radius of pooled rays; ws = per-ray weight (wavelength weight
    shared by that wavelength's arriving rays, as unicac)."""
    W = ws.sum()
    cx, cy = (ws * xs).sum() / W, (ws * ys).sum() / W
    return math.sqrt((ws * ((xs - cx) ** 2 + (ys - cy) ** 2)).sum() / W)


class FieldRays:
    """Rays of one field at all wavelengths after the last lens surface (global), so the RMS on an
    image plane at any z can be computed exactly without re-tracing (the image surface is flat and
    perpendicular to z; refocus moves it along z)."""

    def __init__(self, op, spec, field_xy_deg, pupil, wavelengths, weights):
        last = op.surfaces.num_surfaces - 2  # last lens surface index
        xs, ys, zs, ux, uy, ws = [], [], [], [], [], []
        self.n_traced, self.n_ok = 0, 0
        for w, wt in zip(wavelengths, weights):
            r = trace_bundle(op, spec, field_xy_deg, pupil, w, upto=last)
            ok = r["ok"]
            self.n_traced += len(ok)
            self.n_ok += int(ok.sum())
            if ok.sum() == 0:
                continue
            xs.append(r["x"][ok]); ys.append(r["y"][ok]); zs.append(r["z"][ok])
            ux.append(r["L"][ok] / r["N"][ok]); uy.append(r["M"][ok] / r["N"][ok])
            ws.append(np.full(int(ok.sum()), wt / ok.sum()))
        self.x0 = np.concatenate(xs); self.y0 = np.concatenate(ys); self.z0 = np.concatenate(zs)
        self.ux = np.concatenate(ux); self.uy = np.concatenate(uy); self.w = np.concatenate(ws)

    def rms_at(self, z_image):
        dz = z_image - self.z0
        return rms_poly(self.x0 + self.ux * dz, self.y0 + self.uy * dz, self.w)

    def centroid_at(self, z_image):
        dz = z_image - self.z0
        W = self.w.sum()
        return (float((self.w * (self.x0 + self.ux * dz)).sum() / W),
                float((self.w * (self.y0 + self.uy * dz)).sum() / W))


def field_set(spec, which: str):
    """'lens': the lens's fields along +y; 'cross': on-axis plus every nonzero lens field at
    +y, -y, +x, -x."""
    angles = [float(a) for a in spec["fields"]["angles_deg"]]
    if which == "lens":
        return [(0.0, a) for a in angles]
    out = [(0.0, 0.0)] if 0.0 in angles else []
    for a in angles:
        if a == 0.0:
            continue
        out += [(0.0, a), (0.0, -a), (a, 0.0), (-a, 0.0)]
    return out


# --------------------------------------------------------------------------- unicac export
def asbuilt_to_unicac(spec: dict, asb: AsBuilt, name_suffix: str = "") -> dict:
    """The as-built lens as a unicac lens JSON (format 1): per-surface decentre_x/y_mm and
    tilt_x/y_deg (unicac: decentre, then R = Ry Rx about the vertex; the next vertex on the nominal
    axis at z + thickness), thicknesses taken from the placed vertex z's (so a rigid element tilt's
    tiny z shift of the rear vertex is kept), model glasses with an index offset rewritten as
    {nd + dn, vd'} with the same B (exact for unicac's Cauchy form). A catalogue glass with an
    index offset cannot be written: ValueError."""
    import copy

    out = copy.deepcopy(spec)
    out["name"] = (spec.get("name") or "") + name_suffix
    pos, rot = asb.placements()
    surfs = out["surfaces"]
    for i, s in enumerate(surfs, start=1):
        if i <= len(asb.radii):
            R = asb.radii[i - 1]
            s.pop("radius_mm", None)
            s["curvature_per_mm"] = 0.0 if not math.isfinite(R) else 1.0 / R
            s["thickness_mm"] = pos[i][2] - pos[i - 1][2]
        for key in ("decentre_x_mm", "decentre_y_mm", "tilt_x_deg", "tilt_y_deg"):
            s.pop(key, None)
        x, y = pos[i - 1][0], pos[i - 1][1]
        tx, ty = math.degrees(rot[i - 1][0]), math.degrees(rot[i - 1][1])
        if x:
            s["decentre_x_mm"] = x
        if y:
            s["decentre_y_mm"] = y
        if tx:
            s["tilt_x_deg"] = tx
        if ty:
            s["tilt_y_deg"] = ty
        dn = asb.dn.get(i, 0.0)
        if dn:
            m = s.get("material")
            if isinstance(m, dict):
                g = CauchyModelGlass(m["nd"], m["vd"])
                nd = m["nd"] + dn
                vd = (nd - 1.0) / (g.B * (1.0 / LAMBDA_F**2 - 1.0 / LAMBDA_C**2))
                s["material"] = {"nd": nd, "vd": vd}
            else:
                raise ValueError(f"surface {i}: catalogue glass {m} with an index offset has no unicac form")
    return out
