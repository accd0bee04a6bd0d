#!/usr/bin/env python3
"""Write the classic lenses of lenses/*.json from optiland's sample systems.

Run with the reference venv (see tests/reference/README.md):
    /work/venv-ref/bin/python lenses/tools/from_optiland.py

Each optiland sample (optiland 0.6.3, MIT licence) is read surface by surface.
Wavelengths become F, d, C; the three fields become 0, 0.7 and 1.0 of the
sample's largest field; glasses that are not in optiland's SCHOTT, CDGM or
OHARA data become model glasses {nd, vd} computed from the glass optiland
uses. Semi-diameters are not in the samples: they are sized from a trace of
the full pupil (rays aimed at the paraxial entrance pupil) of all fields and
wavelengths, plus 2 % rounded up to 0.001 mm. optiland has no phone lens: the
phone lens is entered by hand below from DeepLens (see its provenance string).
"""
from __future__ import annotations

import importlib
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "reference"))
import make_references as mr  # noqa: E402  (shared lens reader and optiland builder)
import stop_aiming  # noqa: E402  (explicitly stop-aimed rays, for the 100-degree wide angle)

WAVELENGTHS = [mr.LAMBDA_F, mr.LAMBDA_D, mr.LAMBDA_C]
UNICAC_CATALOGS = ("schott", "cdgm", "ohara")
LICENCE = "optiland sample systems are MIT-licensed (optiland 0.6.3, Kramer Harrison)"

SAMPLES = {
    "singlet": ("optiland.samples.simple", "Edmund_49_847",
                "Edmund Optics stock plano-convex singlet #49-847 (N-SF11)"),
    "achromat": ("optiland.samples.simple", "CementedAchromat",
                 "Milton Laikin, Lens Design, 4th ed., CRC Press 2007, p. 45"),
    "cooke_triplet": ("optiland.samples.objectives", "CookeTriplet",
                      "no source cited by optiland (the classic 50 mm F/5 Cooke triplet)"),
    "double_gauss": ("optiland.samples.objectives", "DoubleGauss",
                     "no source cited by optiland (classic F/5 double Gauss)"),
    "petzval": ("optiland.samples.objectives", "PetzvalLens",
                "Milton Laikin, Lens Design, 4th ed., CRC Press 2007, p. 75"),
    # WideAngle100FOV (Laikin p. 108, 50 deg half field) loses rays with paraxial
    # (unaimed) entrance-pupil aiming, so the 30 deg reverse telephoto is used.
    "wide_angle": ("optiland.samples.objectives", "ReverseTelephoto",
                   "no source cited by optiland (reverse-telephoto / retrofocus, 30 deg half field)"),
}

# Six-element plastic phone lens, entered by hand from DeepLens (MIT licence):
# github.com/singer-yang/DeepLens, lenses/cellphone/cellphone68deg.json at commit
# c803ecaa3d1ff8e5f16ef0ca1fc6bdf93a00dc4d. Per surface: curvature (1/mm),
# distance to the next vertex (d_next), conic k, coefficients of r^2..r^12,
# medium after the surface (DeepLens material name).
PHONE_STOP = {"semi_aperture_mm": 1.0, "d_next": 0.10000000149011612}
PHONE_SURFACES = [
    (0.05959999933838844, 0.8649999722838402, 7.409999847412109,
     [0.021311480551958084, -0.018954070284962654, -0.0016032600542530417,
      -0.0004797200090251863, -0.00032509840093553066, -0.0003486395871732384], "pmma"),
    (-0.04659999907016754, 0.3490000367164612, 10.149999618530273,
     [-0.06371335685253143, -0.018928850069642067, 0.0008296900196000934,
      0.00018603999342303723, 2.039419996435754e-05, -1.8416010789223947e-05], None),
    (-0.05270000174641609, 0.7979999780654907, 3.119999885559082,
     [-0.11747190356254578, 0.0007665000157430768, 0.001187979942187667,
      1.4870000086375512e-05, -1.5086699931998737e-05, -5.52691972188768e-07], "okp4"),
    (-0.0272000003606081, 0.17100000381469727, -10.029999732971191,
     [-0.0734446570277214, -0.007422800175845623, -0.0016431600088253617,
      -0.00018428999464958906, -1.3033700270170812e-05, -3.0923879421607126e-06], None),
    (0.03720000013709068, 0.8429999351501465, 0.6499999761581421,
     [0.09783822298049927, -0.0010136299533769488, 0.0002303100045537576,
      4.9369999032933265e-05, 4.578900188789703e-06, 3.3777018870750908e-06], "coc"),
    (-0.0406000018119812, 0.6340000629425049, -2.8499999046325684,
     [-0.05480308085680008, 4.312999953981489e-05, 0.0003990400000475347,
      3.733999983523972e-05, 3.28009991790168e-06, -1.9050889932259452e-06], None),
    (-0.045099999755620956, 0.4529998302459717, 2.3499999046325684,
     [-0.1011132001876831, -0.015854740515351295, -0.0007796299760229886,
      -6.674999895039946e-05, -5.041899839852704e-06, 9.539179472994874e-07], "polycarb"),
    (-0.013199999928474426, 0.4739999771118164, -84.93000030517578,
     [-0.0014881399692967534, 0.0008201400050893426, -0.0009465200128033757,
      -0.00010758999997051433, -7.264200121426256e-06, -8.331419962814834e-07], None),
    (-0.015200000256299973, 0.7130002975463867, -16.809999465942383,
     [0.02898400090634823, -0.007466960232704878, 7.139999979699496e-06,
      9.579999641573522e-06, -1.54467998072505e-05, -4.1690859688969795e-06], "coc"),
    (-0.051600001752376556, 0.7339997291564941, 5.369999885559082,
     [-0.06753210723400116, 0.0013035000301897526, -0.00041229999624192715,
      -8.183000318240374e-05, -2.115599954777281e-06, 3.851267138088588e-06], None),
    (-0.07240000367164612, 0.9850001335144043, 2.009999990463257,
     [-0.03637365996837616, -0.006304440088570118, -0.0006099399761296809,
      -1.739000072120689e-05, 2.873699941119412e-06, 7.782929856148257e-07], "coc"),
    (0.07779999822378159, 0.9747519493103027, 10.899999618530273,
     [0.06531669944524765, -0.007904729805886745, -0.00013874999422114342,
      1.3240000043879263e-05, 1.920400109156617e-06, -2.598040111934097e-07], None),
]
# DeepLens deeplens/optics/materials_data.json MATERIAL_TABLE: [nd, Vd]
PHONE_PLASTICS = {"pmma": (1.4918, 57.44), "okp4": (1.6328, 23.34),
                  "coc": (1.5337, 56.22), "polycarb": (1.5855, 29.91)}
PHONE_HALF_FOV_DEG = 28.0  # atan(3.565 mm half-diagonal / 6.53 mm EFL), rounded down
PHONE_PROVENANCE = (
    "Six-element plastic mobile-phone lens designed with DeepLens by Xinge Yang: "
    "github.com/singer-yang/DeepLens lenses/cellphone/cellphone68deg.json (commit c803ecaa), "
    "MIT licence (c) 2022 Xinge Yang. Not a patent example: no verifiable patent table with "
    "even aspheres was reachable offline (ray-optics' US 7,535,658 phone lens uses odd-order "
    "terms). Stop 1.0 mm semi-aperture 0.1 mm before the first lens (EPD 2.0 mm), 12 even "
    "aspheres, image at DeepLens' d_sensor. DeepLens' surfaces carry an r^2 term, which paraxial "
    "traces (optiland, ray-optics, Zemax) ignore; each asphere was therefore rewritten with "
    "curvature c + 2 a2, conic -1 and r^4..r^20 terms least-squares fitted to the DeepLens sag "
    "over 1.05x the used semi-diameter (max sag residual < 1e-8 mm). Plastics (PMMA, OKP4, "
    "COC, polycarbonate) as model glasses with DeepLens' nd/Vd. Half field 28 deg from its "
    "3.565 mm image half-diagonal. Entered by hand in lenses/tools/from_optiland.py."
)


# ---------------------------------------------------------------- conversion
def material_spec(material):
    """unicac material for an optiland material: None (air), 'CAT:NAME' or {nd, vd}."""
    name = getattr(material, "name", None)
    filename = getattr(material, "filename", None)
    if filename is None:  # air (IdealMaterial n=1) in the samples
        n = float(np.ravel(material.n(mr.LAMBDA_D))[0])
        if n != 1.0:
            raise ValueError(f"unexpected ideal material n={n}")
        return None
    catalog = Path(filename).parent.name.lower()
    if catalog in UNICAC_CATALOGS:
        return f"{catalog.upper()}:{name}"
    nd, nf, nc = (float(np.ravel(material.n(w))[0]) for w in (mr.LAMBDA_D, mr.LAMBDA_F, mr.LAMBDA_C))
    return {"nd": round(nd, 6), "vd": round((nd - 1.0) / (nf - nc), 4),
            "label": f"{name} ({catalog.upper()}) as model glass"}


def surface_dict(surface, is_image: bool) -> dict:
    geo = surface.geometry
    radius = float(getattr(geo, "radius", np.inf))
    out = {"curvature_per_mm": 0.0 if math.isinf(radius) else 1.0 / radius}
    k = float(getattr(geo, "k", 0.0) or 0.0)
    coeffs = getattr(geo, "coefficients", None)
    if coeffs is not None and len(coeffs):
        out = {"type": "even_asphere", **out, "conic": k,
               "aspheric_coefficients": [float(c) for c in coeffs]}
    elif k:
        out["conic"] = k
    out["thickness_mm"] = 0.0 if is_image else float(surface.thickness)
    if not is_image:
        mat = material_spec(surface.material_post)
        if mat is not None:
            label = mat.pop("label") if isinstance(mat, dict) else None
            out["material"] = mat
            if label:
                out["label"] = label
    if surface.is_stop:
        out["stop"] = True
    return out


def aperture_dict(optic) -> dict:
    kind = type(optic.aperture).__name__
    value = float(optic.aperture.value if hasattr(optic.aperture, "value") else optic.aperture._value)
    if kind == "EPDAperture":
        return {"entrance_pupil_diameter_mm": value}
    if kind == "ImageFNOAperture":
        return {"f_number": value}
    raise ValueError(f"unsupported aperture {kind}")


def lens_skeleton(name, provenance, aperture, max_field, surfaces, catalogs) -> dict:
    return {
        "format_version": 1,
        "name": name,
        "provenance": provenance,
        "object_distance_mm": None,
        "aperture": aperture,
        "fields": {"angles_deg": [0.0, round(0.7 * max_field, 10), max_field]},
        "field_weights": [1.0, 1.0, 1.0],
        "wavelengths": [{"wavelength_um": w, "weight": 1.0} for w in WAVELENGTHS],
        "primary_wavelength_index": 1,
        "glass_catalogs": catalogs,
        "surfaces": surfaces,
    }


def from_sample(stem: str) -> dict:
    return from_sample_class(*SAMPLES[stem])


def from_sample_class(module: str, cls_name: str, source: str, scale: float = 1.0) -> dict:
    optic = getattr(importlib.import_module(module), cls_name)()
    surfs = list(optic.surfaces)[1:]
    surfaces = [scaled(surface_dict(s, i == len(surfs) - 1), scale) for i, s in enumerate(surfs)]
    cats = sorted({m.split(":")[0] for m in (s.get("material") for s in surfaces)
                   if isinstance(m, str)}) or ["SCHOTT"]
    max_field = float(max(abs(f.y) for f in optic.fields.fields))
    provenance = (f"optiland sample {module}.{cls_name} (optiland 0.6.3); source: {source}. "
                  f"{LICENCE}. Converted by lenses/tools/from_optiland.py: wavelengths set to F,d,C, "
                  f"fields to 0/0.7/1.0 of the sample's maximum, semi-diameters sized from a "
                  f"full-pupil trace (+2 %).")
    aperture = aperture_dict(optic)
    if "entrance_pupil_diameter_mm" in aperture:
        aperture["entrance_pupil_diameter_mm"] *= scale
    return lens_skeleton(f"{cls_name} (optiland sample)", provenance, aperture,
                         max_field, surfaces, cats)


def scaled(surface: dict, scale: float) -> dict:
    """A surface with every length multiplied by `scale` (1 leaves the values untouched)."""
    if scale == 1.0:
        return surface
    surface["curvature_per_mm"] /= scale
    surface["thickness_mm"] = round(surface["thickness_mm"] * scale, 9)
    if "aspheric_coefficients" in surface:
        surface["aspheric_coefficients"] = [a / scale ** (2 * i + 1) for i, a in
                                            enumerate(surface["aspheric_coefficients"])]
    return surface


def phone_lens() -> dict:
    surfaces = [{"curvature_per_mm": 0.0, "thickness_mm": PHONE_STOP["d_next"], "stop": True}]
    for c, t, k, coeffs, mat in PHONE_SURFACES:
        s = {"type": "even_asphere", "curvature_per_mm": c, "conic": k,
             "aspheric_coefficients": coeffs, "thickness_mm": t}
        if mat is not None:
            nd, vd = PHONE_PLASTICS[mat]
            s["material"] = {"nd": nd, "vd": vd}
            s["label"] = mat.upper()
        surfaces.append(s)
    surfaces.append({"curvature_per_mm": 0.0, "thickness_mm": 0.0})
    lens = lens_skeleton("Six-element plastic phone lens (DeepLens cellphone68deg)",
                         PHONE_PROVENANCE,
                         {"entrance_pupil_diameter_mm": 2 * PHONE_STOP["semi_aperture_mm"]},
                         PHONE_HALF_FOV_DEG, surfaces, [])
    heights, _ = full_pupil_heights(lens)
    for s, h in zip(lens["surfaces"], heights):
        if s.get("type") == "even_asphere":
            s.update(refit_without_r2(s, 1.05 * h))
    return lens


def refit_without_r2(s: dict, r_max: float) -> dict:
    """Same sag with no r^2 term: curvature c + 2 a2 (the paraxial curvature, which
    optiland's and ray-optics' paraxial traces read from the curvature only), conic -1,
    and r^4..r^20 fitted by least squares to the original sag on [0, r_max]."""
    c, k, a = s["curvature_per_mm"], s["conic"], s["aspheric_coefficients"]
    r = np.linspace(0.0, r_max, 4000)
    sag = c * r**2 / (1 + np.sqrt(1 - (1 + k) * c**2 * r**2))
    sag += sum(ai * r ** (2 * i + 2) for i, ai in enumerate(a))
    c_new = c + 2.0 * a[0]
    powers = np.arange(4, 22, 2)
    scale = r_max ** powers.astype(float)
    basis = (r[:, None] ** powers) / scale
    coef, *_ = np.linalg.lstsq(basis, sag - c_new * r**2 / 2, rcond=None)
    coef = coef / scale
    residual = np.abs(sag - c_new * r**2 / 2 - (r[:, None] ** powers) @ coef).max()
    if residual > 1e-8:
        raise SystemExit(f"asphere refit residual {residual:.2e} mm")
    return {"curvature_per_mm": c_new, "conic": -1.0,
            "aspheric_coefficients": [0.0, *map(float, coef)]}


# ---------------------------------------------------------------- semi-diameters
def full_pupil_heights(lens: dict) -> tuple[np.ndarray, int]:
    """Max ray height per surface over all fields/wavelengths, and the number of failed rays."""
    lens = dict(lens, name_stem="sizing")
    idx = mr.lens_indices(lens)
    pupil = mr.hexapolar_pupil() + [(math.cos(a), math.sin(a))
                                    for a in np.linspace(0, 2 * math.pi, 72, endpoint=False)]
    heights, failed = np.zeros(len(lens["surfaces"])), 0
    prim = mr.primary_index(lens)
    fo = mr.OptilandModel(lens, idx[prim], mr.wavelengths(lens)[prim]).first_order()
    for i, wl in enumerate(mr.wavelengths(lens)):
        model = mr.OptilandModel(lens, idx[i], wl)
        for f in mr.field_angles(lens):
            starts, dirs = mr.pupil_rays(f, pupil, fo["epd_mm"], fo["entrance_pupil_z_mm"],
                                         mr.start_plane(fo))
            pts, ok = model.trace(starts, dirs)
            failed += int((~ok).sum())
            heights = np.maximum(heights, np.nanmax(np.hypot(pts[ok, :, 0], pts[ok, :, 1]), axis=0))
    return heights, failed


def add_semi_diameters(lens: dict) -> int:
    heights, failed = full_pupil_heights(lens)
    for s, h in zip(lens["surfaces"], heights):
        s["semi_diameter_mm"] = math.ceil(h * 1.02 * 1000.0) / 1000.0
    return failed


def write_lens(stem: str, lens: dict) -> None:
    failed = add_semi_diameters(lens)
    path = ROOT / "lenses" / f"{stem}.json"
    path.write_text(json.dumps(lens, indent=2) + "\n")
    print(f"{stem:15s} {len(lens['surfaces']):2d} surfaces, failed full-pupil rays: {failed} -> {path}")
    if failed:
        raise SystemExit(f"{stem}: {failed} rays failed in optiland")


# ---------------------------------------------------------------- 100-degree wide angle
INCH_MM = 25.4
WIDE_100_SOURCE = ("Milton Laikin, Lens Design, 4th ed., CRC Press 2007, p. 108 "
                   "(100-degree retrofocus wide angle, 50 deg half field, F/4)")


def wide_angle_100() -> dict:
    """optiland's WideAngle100FOV scaled from inches to mm (EFL 16.67 mm, F/4, 50 deg
    half field; stop surface 9 of 20). Its pupil moves far off the paraxial one at
    wide fields, so its semi-diameters are sized from explicitly stop-aimed rays
    (tests/reference/stop_aiming.py), not from paraxially aimed ones."""
    lens = from_sample_class("optiland.samples.objectives", "WideAngle100FOV", WIDE_100_SOURCE,
                             scale=INCH_MM)
    lens["provenance"] = lens["provenance"].replace(
        "semi-diameters sized from a full-pupil trace (+2 %).",
        "all lengths scaled by 25.4 (the sample is in inches), semi-diameters sized from a "
        "full-pupil trace of rays aimed at the stop (real ray aiming, +2 %).")
    return lens


def add_stop_aimed_semi_diameters(lens: dict) -> int:
    """Semi-diameters from rays aimed at the stop (hexapolar + 72 rim rays, every field
    and wavelength), +2 % rounded up to 0.001 mm; returns the number of rays that failed."""
    lens = dict(lens, name_stem="sizing")
    idx = mr.lens_indices(lens)
    aim = mr.common_aiming(lens)
    pupil = mr.hexapolar_pupil() + [(math.cos(a), math.sin(a))
                                    for a in np.linspace(0, 2 * math.pi, 72, endpoint=False)]
    heights, failed = np.zeros(len(lens["surfaces"])), 0
    for i, wl in enumerate(mr.wavelengths(lens)):
        model = mr.OptilandModel(lens, idx[i], wl)
        for f in mr.field_angles(lens):
            rays = stop_aiming.aim_rays(model, lens, aim, f, pupil)
            ok, pts = rays["ok"], rays["points"]
            failed += int((~ok).sum())
            heights = np.maximum(heights, np.nanmax(np.hypot(pts[ok, :, 0], pts[ok, :, 1]), axis=0))
    for s, h in zip(lens["surfaces"], heights):
        s["semi_diameter_mm"] = math.ceil(h * 1.02 * 1000.0) / 1000.0
    return failed


def main(stems: list[str]) -> None:
    if stems == ["wide_angle_100"]:
        lens = wide_angle_100()
        failed = add_stop_aimed_semi_diameters(lens)
        if failed:
            raise SystemExit(f"wide_angle_100: {failed} stop-aimed rays failed in optiland")
        path = ROOT / "lenses" / "wide_angle_100.json"
        path.write_text(json.dumps(lens, indent=2) + "\n")
        print(f"wide_angle_100 {len(lens['surfaces']):2d} surfaces -> {path}")
        return
    for stem in SAMPLES:
        write_lens(stem, from_sample(stem))
    write_lens("phone_asphere", phone_lens())


if __name__ == "__main__":
    main(sys.argv[1:])
