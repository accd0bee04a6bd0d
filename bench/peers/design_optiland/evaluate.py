"""Grade every final design the same way with unicac (read-only use of the release binary).

Per lens: polychromatic RMS spot radius (F, d, C equally weighted, every ray about the field's
polychromatic centroid; unicac spot, hexapolar:10, auto aiming) at 0, 0.7 and 1 of the image height,
EFL, F/#, distortion and total track (unicac lens info), edge relative illumination (unicac analysis
illumination), and unicac design's default constraints (docs/design.md) recomputed from the file with the
design's rules: semi-diameters = traced beam heights (unicac lens info on a copy without semi-diameters)
x 1.02, an element's surfaces share the larger.

usage: evaluate.py [KEYS]   -> results.json, table printed
"""
import csv
import glob
import json
import math
import os
import re
import subprocess
import sys

from common import F_MM, SPECS, field_angles

D = os.path.dirname(os.path.abspath(__file__))
U = os.environ.get("UNICAC_BIN", "unicac")
TMP = os.path.join(D, "eval-tmp")


def run(args):
    env = dict(os.environ, RAYON_NUM_THREADS="1", OMP_NUM_THREADS="1")
    return subprocess.run([U] + args, capture_output=True, text=True, env=env, check=True).stdout


def sag(c, r):
    q = 1 - (c * r) ** 2
    if q < 0:
        return None
    return c * r * r / (1 + math.sqrt(q))


def grade(path, spec, label):
    os.makedirs(TMP, exist_ok=True)
    lens = json.load(open(path))
    for s in lens["surfaces"]:
        s.pop("semi_diameter_mm", None)
    tmp = os.path.join(TMP, label + ".json")
    json.dump(lens, open(tmp, "w"), indent=1)
    f = F_MM
    angles = field_angles(spec)
    fargs = []
    for a in angles:
        fargs += ["--field-deg", f"{a:.12g}"]
    spot = json.loads(run(["spot", tmp, "--json"] + fargs))
    info = json.loads(run(["lens", "info", "--json", tmp]))
    ri = json.loads(run(["analysis", "illumination", "--json", "--field-deg", f"{angles[-1]:.12g}", tmp]))
    rms, failed = [], 0
    for a in angles:
        rows = [s for s in spot["spots"] if abs(s["field_deg"] - a) < 1e-9]
        assert len(rows) == 3, rows
        failed += sum(r["rays_traced"] - r["rays_ok"] for r in rows)
        # pooled rays, equal weight per wavelength (each wavelength's weight shared by its arriving rays)
        cx = sum(r["centroid_x_mm"] for r in rows) / 3
        cy = sum(r["centroid_y_mm"] for r in rows) / 3
        ms = sum((r["rms_radius_um"] / 1000) ** 2 + (r["centroid_x_mm"] - cx) ** 2 + (r["centroid_y_mm"] - cy) ** 2
                 for r in rows) / 3
        rms.append(1000 * math.sqrt(ms))
    dist = {round(d["field_deg"], 6): d["distortion_percent"] for d in info["distortion"]}
    # constraint checks (f = 50 mm defaults)
    surfs = lens["surfaces"]
    n = len(surfs) - 1  # without image
    h = info["clear_semi_diameters_mm"][:n]
    glass = [s.get("material") not in (None, "AIR", "air") for s in surfs[:n]]
    stop = [bool(s.get("stop")) for s in surfs[:n]]
    semi = []
    for i in range(n):
        if stop[i]:
            semi.append(h[i] * 1.02)
        elif glass[i]:
            semi.append(max(h[i], h[i + 1]) * 1.02)
        else:
            semi.append(max(h[i], h[i - 1]) * 1.02)
    c = [s.get("curvature_per_mm", 0.0) for s in surfs[:n]]
    t = [s["thickness_mm"] for s in surfs[:n]]
    viol = []

    def check(name, ok, value):
        if not ok:
            viol.append(f"{name}={value:.4g}")

    tol = 0.002
    for i in range(n):
        if not stop[i]:
            check(f"slope[{i}]", c[i] * semi[i] <= math.sin(math.radians(55)) + 0.005, abs(c[i] * semi[i]))
        if i == n - 1:
            check("bfd", t[i] >= 5.0 - tol, t[i])
            continue
        if glass[i]:
            check(f"glass_ct[{i}]", 1.0 - tol <= t[i] <= 10.0 + tol, t[i])
            s1, s2 = sag(c[i], semi[i]), sag(c[i + 1], semi[i])
            edge = None if s1 is None or s2 is None else t[i] + s2 - s1
            check(f"glass_edge[{i}]", edge is not None and edge >= 0.7 - tol, -1 if edge is None else edge)
        else:
            check(f"air_ct[{i}]", 0.1 - tol <= t[i] <= 20.0 + tol, t[i])
            reach = min(semi[i], semi[i + 1])
            gaps = []
            for k in (0.25, 0.5, 0.75, 1.0):
                s1, s2 = sag(c[i], reach * k), sag(c[i + 1], reach * k)
                if s1 is not None and s2 is not None:
                    gaps.append(t[i] + s2 - s1)
            g = min(gaps) if gaps else -1
            check(f"air_edge[{i}]", g >= 0.1 - tol, g)
    track = info["total_track_mm"] + 0.0
    check("track", track <= f * (1.6 + 0.25 * spec["elements"]) + tol, track)
    check("efl", abs(info["efl_mm"] / f - 1) <= 0.01, info["efl_mm"])
    for a in angles[1:]:
        d = dist[round(a, 6)] if round(a, 6) in dist else None
        if d is None:
            d = min(info["distortion"], key=lambda r: abs(r["field_deg"] - a))["distortion_percent"]
        check(f"distortion@{a:.1f}", abs(d) <= 5.05, d)
    check("edge_RI", ri["relative_illumination"][0] >= 0.25 - 0.005, ri["relative_illumination"][0])
    check("rays", failed == 0, failed)
    dfull = min(info["distortion"], key=lambda r: abs(r["field_deg"] - angles[-1]))["distortion_percent"]
    return {
        "label": label, "file": path, "rms_um": rms, "rms_mean_um": sum(rms) / 3,
        "efl_mm": info["efl_mm"], "f_number": info["f_number"], "working_f_number": info["working_f_number"],
        "distortion_full_percent": dfull, "total_track_mm": track, "edge_ri": ri["relative_illumination"][0],
        "bfd_mm": t[-1], "aiming": spot.get("auto_aiming", {}).get("aiming", spot["aiming"]),
        "violations": viol, "constraints_met": not viol,
    }


def cpu_from_time(path):
    try:
        txt = open(path).read()
    except FileNotFoundError:
        return None
    m = re.findall(r"([0-9.]+) s user", txt)
    return float(m[-1]) if m else None


def wall_from_time(path):
    try:
        txt = open(path).read()
    except FileNotFoundError:
        return None
    m = re.findall(r"([0-9.]+) s wall", txt)
    return float(m[-1]) if m else None


def main():
    keys = sys.argv[1] if len(sys.argv) > 1 else "abcd"
    out = {}
    for key in keys:
        spec = SPECS[key]
        rows = []
        lib = os.path.join(D, f"unicac-{key}")
        man = os.path.join(lib, "manifest.jsonl")
        if os.path.exists(man):
            ms = [json.loads(l) for l in open(man) if l.strip()]
            if ms:
                best = min(ms, key=lambda r: r["rms_mean_um"])
                lf = best.get("json") or best.get("lens_json") or best.get("file")
                if lf is None:
                    lf = next(v for k, v in best.items() if isinstance(v, str) and v.endswith(".json"))
                lf = lf if os.path.isabs(lf) else os.path.join(lib, lf)
                if not os.path.exists(lf):
                    lf = os.path.join(lib, "lenses", os.path.basename(lf))
                g = grade(lf, spec, f"unicac-{key}")
                g.update(tool="unicac design", wall_s=wall_from_time(os.path.join(D, "logs", f"unicac-{key}.stderr")),
                         manifest_rms_mean_um=best["rms_mean_um"], designs_kept=len(ms),
                         cpu_s=cpu_from_time(os.path.join(D, "logs", f"unicac-{key}.stderr")))
                rep = lf[:-5] + ".report.json"
                if os.path.exists(rep):
                    r = json.load(open(rep))
                    chk = r.get("checks") or r.get("terms", {}).get("checks") or []
                    g["report_all_checks_met"] = all(cc.get("met", True) for cc in chk) if chk else None
                rows.append(g)
        for m, name in (("de", "optiland DE + LS"), ("da", "optiland DA + LS"),
                        ("de5", "optiland DE(popsize 5) + LS")):
            lf = os.path.join(D, "optiland", f"optiland-{m}-{key}.json")
            if not os.path.exists(lf):
                continue
            g = grade(lf, spec, f"optiland-{m}-{key}")
            sm = json.load(open(lf[:-5] + ".summary.json"))
            g.update(tool=name, wall_s=sm["wall_s"], evals=sm["global_evals"] + sm["local_evals"],
                     global_evals=sm["global_evals"], local_evals=sm["local_evals"],
                     optiland_merit=sm["final_merit"], global_status=sm["global_status"],
                     cpu_s=cpu_from_time(os.path.join(D, "logs", f"optiland-{m}-{key}.log")))
            rows.append(g)
        out[key] = {"flags": f"{spec}", "rows": rows}
        print(f"\nspec {key}: {spec}")
        for g in rows:
            print(f"  {g['tool']:18s} wall {g['wall_s'] or float('nan'):6.1f} s cpu {g.get('cpu_s') or float('nan'):6.1f} s RMS "
                  + " / ".join(f"{v:.1f}" for v in g["rms_um"])
                  + f"  mean {g['rms_mean_um']:.1f} um  EFL {g['efl_mm']:.3f}  F/{g['f_number']:.3f}  "
                  f"dist {g['distortion_full_percent']:+.2f}%  track {g['total_track_mm']:.2f}  RI {g['edge_ri']:.2f}  "
                  f"ok={g['constraints_met']} {' '.join(g['violations'])}")
    prev = {}
    p = os.path.join(D, "results.json")
    if os.path.exists(p):
        prev = json.load(open(p))
    prev.update(out)
    json.dump(prev, open(p, "w"), indent=1)


if __name__ == "__main__":
    main()
