#!/usr/bin/env python3
"""The as-built bench regrouped by another dataset's ODE levels (docs/dataset.md, "As-built split").

`unicac bench --split as_built` reports the change, as built minus design, per level of the dataset it
ran on. The small benchmark's test lenses (docs/reproduce.md) were rebuilt here as a one-level dataset
of their own, so their levels come from the small benchmark's pairs.csv instead. Per method and level:
the design's and the units' mean PSNR / SSIM / LPIPS over design lenses, the change with a 95%
percentile bootstrap interval over design lenses (2,000 seeded resamples), and the ODE of designs and
units (units.jsonl).

Usage: by_level.py BENCH_PAIRS_CSV UNITS_JSONL LEVELS_PAIRS_CSV > table.md
"""

import csv
import json
import random
import sys
from collections import defaultdict
from statistics import mean

RESAMPLES = 2000
METRICS = (("psnr_db", "PSNR", 2), ("ssim", "SSIM", 4), ("lpips", "LPIPS", 4))


def design_of(lens_id: str) -> str:
    return lens_id.rsplit("__", 1)[0]


def interval(values: list[float], rng: random.Random) -> tuple[float, float]:
    means = sorted(mean(rng.choices(values, k=len(values))) for _ in range(RESAMPLES))
    return means[int(0.025 * RESAMPLES)], means[int(0.975 * RESAMPLES) - 1]


def main(bench_pairs: str, units_jsonl: str, levels_pairs: str) -> None:
    level_of = {row["lens_id"]: int(row["level"]) for row in csv.DictReader(open(levels_pairs))}
    # per (method, design lens): metric -> {"design": [...], "unit": [...]}
    scores: dict = defaultdict(lambda: defaultdict(lambda: {"design": [], "unit": []}))
    methods: list[str] = []
    for row in csv.DictReader(open(bench_pairs)):
        if row["model"] not in methods:
            methods.append(row["model"])
        kind = "design" if row["lens_id"].endswith("__d") else "unit"
        for key, _, _ in METRICS:
            if row[key]:
                scores[(row["model"], design_of(row["lens_id"]))][key][kind].append(float(row[key]))
    ode = defaultdict(lambda: {"design": [], "unit": []})
    for line in open(units_jsonl):
        unit = json.loads(line)
        ode[unit["lens_id"]]["design" if unit["unit"] is None else "unit"].append(unit["ode"])
    lenses = sorted({lens for _, lens in scores})
    missing = [lens for lens in lenses if lens not in level_of]
    if missing:
        sys.exit(f"{levels_pairs}: no level for {', '.join(missing)}")
    levels = sorted({level_of[lens] for lens in lenses})

    print("| level | lenses | ODE design -> units |")
    print("|---|---:|---|")
    for level in levels + [0]:
        group = [lens for lens in lenses if level in (0, level_of[lens])]
        d = mean(mean(ode[lens]["design"]) for lens in group)
        u = mean(mean(ode[lens]["unit"]) for lens in group)
        print(f"| {'all' if level == 0 else f'L{level}'} | {len(group)} | {d:.3f} -> {u:.3f} |")
    print()
    header = " | ".join(f"{name} design -> as built | {name} change [95%]" for _, name, _ in METRICS)
    print(f"| method | level | {header} |")
    print("|---|---|" + "---|---|" * len(METRICS))
    rng = random.Random(1)
    for method in methods:
        for level in levels + [0]:
            group = [lens for lens in lenses if level in (0, level_of[lens])]
            cells = []
            for key, _, digits in METRICS:
                per_lens = [scores[(method, lens)][key] for lens in group]
                if not all(s["design"] and s["unit"] for s in per_lens):
                    cells += ["-", "-"]
                    continue
                designs = [mean(s["design"]) for s in per_lens]
                units = [mean(s["unit"]) for s in per_lens]
                changes = [u - d for u, d in zip(units, designs)]
                lo, hi = interval(changes, rng)
                cells += [f"{mean(designs):.{digits}f} -> {mean(units):.{digits}f}",
                          f"{mean(changes):+.{digits}f} [{lo:+.{digits}f}, {hi:+.{digits}f}]"]
            print(f"| {method} | {'all' if level == 0 else f'L{level}'} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
