"""results.json -> markdown table (printed)."""
import json

from common import SPECS, flags

r = json.load(open("results.json"))
print("| spec | tool | wall s | CPU s | RMS 0 / 0.7 / 1 field (um) | mean RMS (um) | EFL (mm) | F/# | distortion at full field | total track (mm) | edge RI | constraints met |")
print("|---|---|---|---|---|---|---|---|---|---|---|---|")
for key in "abcd":
    if key not in r:
        continue
    for g in r[key]["rows"]:
        viol = "yes" if g["constraints_met"] else "no: " + ", ".join(g["violations"][:4]) + (" ..." if len(g["violations"]) > 4 else "")
        cpu = f"{g['cpu_s']:.0f}" if g.get("cpu_s") else "-"
        rms = " / ".join(f"{v:,.1f}" for v in g["rms_um"])
        print(f"| ({key}) {flags(SPECS[key]).replace('--', '').replace('half-fov-deg', 'hfov')} | {g['tool']} | {g['wall_s']:.0f} | {cpu} | {rms} | **{g['rms_mean_um']:,.1f}** | "
              f"{g['efl_mm']:.3f} | {g['f_number']:.2f} | {g['distortion_full_percent']:+.2f} % | {g['total_track_mm']:.1f} | {g['edge_ri']:.2f} | {viol} |")
