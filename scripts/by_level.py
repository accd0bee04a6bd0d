#!/usr/bin/env python3
"""`unicac bench` reports regrouped by another dataset's ODE levels (LEVELS_PAIRS_CSV: a bench
report's pairs.csv whose `level` column names each lens's level), with 95% percentile bootstrap
intervals over lenses (2,000 seeded resamples). The small benchmark's test lenses were rebuilt as a
one-level dataset of their own (docs/dataset.md, "The as-built bench on the small benchmark"), so their
levels come from the small benchmark's report.

  by_level.py as-built BENCH_PAIRS_CSV UNITS_JSONL LEVELS_PAIRS_CSV
      a `bench --split as_built` report: per method and level the design's and the units' mean PSNR /
      SSIM / LPIPS over design lenses and the change, as built minus design; the ODE of designs and units
  by_level.py paired REPORT_DIR LEVELS_PAIRS_CSV A B
      per level the mean over lenses of method A's and B's per-lens O.P. (lens_op.csv) and mean PSNR
      (pairs.csv), and A minus B
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


def levels_from(levels_pairs: str) -> dict[str, int]:
    return {row["lens_id"]: int(row["level"]) for row in csv.DictReader(open(levels_pairs))}


def level_groups(lenses: list[str], level_of: dict[str, int]):
    """(label, lenses) per level, then all levels."""
    for level in sorted({level_of[lens] for lens in lenses}) + [0]:
        yield ("all" if level == 0 else f"L{level}"), [lens for lens in lenses if level in (0, level_of[lens])]


def as_built(bench_pairs: str, units_jsonl: str, levels_pairs: str) -> None:
    level_of = levels_from(levels_pairs)
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
    print("| level | lenses | ODE design -> units |")
    print("|---|---:|---|")
    for label, group in level_groups(lenses, level_of):
        d = mean(mean(ode[lens]["design"]) for lens in group)
        u = mean(mean(ode[lens]["unit"]) for lens in group)
        print(f"| {label} | {len(group)} | {d:.3f} -> {u:.3f} |")
    print()
    header = " | ".join(f"{name} design -> as built | {name} change [95%]" for _, name, _ in METRICS)
    print(f"| method | level | {header} |")
    print("|---|---|" + "---|---|" * len(METRICS))
    rng = random.Random(1)
    for method in methods:
        for label, group in level_groups(lenses, level_of):
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
            print(f"| {method} | {label} | " + " | ".join(cells) + " |")


def paired(report: str, levels_pairs: str, a: str, b: str) -> None:
    level_of = levels_from(levels_pairs)
    op = {(row["model"], row["lens_id"]): float(row["op"]) for row in csv.DictReader(open(f"{report}/lens_op.csv"))}
    psnr = defaultdict(list)
    for row in csv.DictReader(open(f"{report}/pairs.csv")):
        psnr[(row["model"], row["lens_id"])].append(float(row["psnr_db"]))
    mean_psnr = {key: mean(values) for key, values in psnr.items()}
    lenses = sorted({lens for model, lens in op if model == a})
    if not lenses:
        sys.exit(f"{report}/lens_op.csv: no method {a!r} (methods: {', '.join(sorted({m for m, _ in op}))})")
    for model in (a, b):
        missing = [lens for lens in lenses if (model, lens) not in op or lens not in level_of]
        if missing:
            sys.exit(f"{report}: no O.P. or level of {model} for {', '.join(missing)}")
    rng = random.Random(1)
    print(f"| level | lenses | O.P. {a} | O.P. {b} | O.P. difference [95%] | PSNR {a} | PSNR {b} | PSNR difference [95%] |")
    print("|---|---:|---:|---:|---|---:|---:|---|")
    for label, group in level_groups(lenses, level_of):
        cells = []
        for table, digits in ((op, 3), (mean_psnr, 2)):
            xs, ys = [table[(a, lens)] for lens in group], [table[(b, lens)] for lens in group]
            diffs = [x - y for x, y in zip(xs, ys)]
            lo, hi = interval(diffs, rng)
            cells += [f"{mean(xs):.{digits}f}", f"{mean(ys):.{digits}f}",
                      f"{mean(diffs):+.{digits}f} [{lo:+.{digits}f}, {hi:+.{digits}f}]"]
        print(f"| {label} | {len(group)} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    commands = {"as-built": (as_built, 3), "paired": (paired, 4)}
    if len(sys.argv) < 2 or sys.argv[1] not in commands or len(sys.argv) - 2 != commands[sys.argv[1]][1]:
        sys.exit(__doc__)
    try:
        commands[sys.argv[1]][0](*sys.argv[2:])
    except (OSError, KeyError, ValueError, json.JSONDecodeError) as error:
        sys.exit(f"by_level.py {sys.argv[1]}: {type(error).__name__}: {error} (expects a bench report's pairs.csv / lens_op.csv, "
                 "a dataset's as_built/units.jsonl and a pairs.csv with a level column)")
