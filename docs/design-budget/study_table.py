"""The convergence study's table and picture from what `study.sh OUT EVALUATIONS` has done.

Per specification and seed: the best kept spherical design (smallest mean RMS spot radius) with its RMS
at fields 0 / 0.7 / 1, merit, largest distortion and flags, and how the run stopped; per specification
the mean and spread over the seeds done; `OUT/convergence.png`: best mean RMS (top) and that design's
merit (bottom) against evaluations spent, one line per seed (from each library's
`state/<spec>.rounds.jsonl`). Runs not finished (a library with a round trace but no summary yet) are
listed apart with their best so far and the evaluations spent, and drawn dashed; they are left out of
the per-specification statistics.

    python3 docs/design-budget/study_table.py OUT EVALUATIONS > OUT/table.md
"""

import json
import statistics
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def best_design(library: Path) -> dict:
    rows = [json.loads(line) for line in (library / "manifest.jsonl").read_text().splitlines() if line.strip()]
    spherical = [r for r in rows if not r["aspheric"]]
    best = min(spherical, key=lambda r: r["rms_mean_um"])
    report = json.loads((library / "lenses" / f"{best['id']}.report.json").read_text())
    best["rms_fields_um"] = report["verification"]["rms_um"]
    return best


def rounds(library: Path, slug: str) -> list[dict]:
    path = library / "state" / f"{slug}.rounds.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()] if path.exists() else []


def unfinished_runs(out_dir: Path) -> list[tuple[str, int, list[dict]]]:
    """(spec name, seed, round trace) of every library without a summary whose trace has rounds."""
    found = []
    for library in sorted(p for p in out_dir.glob("*-seed*") if p.is_dir()):
        if (out_dir / f"{library.name}.json").exists():
            continue
        traces = sorted((library / "state").glob("*.rounds.jsonl"))
        trace = rounds(library, traces[0].name.removesuffix(".rounds.jsonl")) if traces else []
        if trace:
            spec_name, seed = library.name.rsplit("-seed", 1)
            found.append((spec_name, int(seed), trace))
    return found


def main(out: str, evaluations: str) -> None:
    out_dir, limit = Path(out), int(evaluations)
    runs: dict[str, list[tuple[int, dict, dict, list[dict]]]] = {}
    for summary_path in sorted(out_dir.glob("*-seed*.json")):
        name = summary_path.stem
        spec_name, seed = name.rsplit("-seed", 1)
        summary = json.loads(summary_path.read_text())["specs"][0]
        library = out_dir / name
        runs.setdefault(spec_name, []).append(
            (int(seed), summary, best_design(library), rounds(library, summary["spec"])))
    print(f"Evaluation budget {limit:,} per specification (`--evaluations-per-spec`), count 4.\n")
    print("| spec | seed | best mean RMS (um) | RMS at 0 / 0.7 / 1 (um) | merit | max distortion (%) | flags | rounds | stop | evaluations | wall (s) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for spec_name, items in runs.items():
        for seed, summary, best, _ in sorted(items, key=lambda item: item[0]):
            fields = " / ".join(f"{v:.1f}" for v in best["rms_fields_um"])
            flags = ", ".join(best.get("flags") or []) or "-"
            print(f"| {spec_name} | {seed} | {best['rms_mean_um']:.1f} | {fields} | {best['merit']:.4g} | "
                  f"{best['distortion_max_percent']:.2f} | {flags} | {summary['rounds']} | {summary['stop_reason']} | "
                  f"{summary['evaluations']:,} | {summary['elapsed_s']:.0f} |")
    unfinished = unfinished_runs(out_dir)
    if unfinished:
        print("\nNot finished (best so far from the round trace):\n")
        print("| spec | seed | best mean RMS so far (um) | merit | rounds | evaluations so far |")
        print("|---|---|---|---|---|---|")
        for spec_name, seed, trace in unfinished:
            last = trace[-1]
            print(f"| {spec_name} | {seed} | {last['best_rms_mean_um']:.1f} | {last['best_merit']:.4g} | "
                  f"{last['round'] + 1} | {last['evaluations']:,} |")
    print("\n| spec | seeds done | best mean RMS over seeds: mean, sd, min-max (um) | good bar (um) |")
    print("|---|---|---|---|")
    for spec_name, items in runs.items():
        values = [best["rms_mean_um"] for _, _, best, _ in items]
        spread = statistics.stdev(values) if len(values) > 1 else 0.0
        bar = items[0][1]["good_rms_um"]
        print(f"| {spec_name} | {len(values)} | {statistics.mean(values):.1f}, {spread:.1f}, "
              f"{min(values):.1f}-{max(values):.1f} | {bar:.1f} |")
    if not runs:
        return
    unfinished_by_spec: dict[str, list[tuple[int, list[dict]]]] = {}
    for spec_name, seed, trace in unfinished:
        unfinished_by_spec.setdefault(spec_name, []).append((seed, trace))
    fig, axes = plt.subplots(2, len(runs), figsize=(4 * len(runs), 6.6), dpi=110, squeeze=False)
    for column, (spec_name, items) in enumerate(runs.items()):
        for row, key in enumerate(("best_rms_mean_um", "best_merit")):
            ax = axes[row][column]
            lines = [(seed, trace, "-", "") for seed, _, _, trace in items]
            lines += [(seed, trace, "--", ", so far") for seed, trace in unfinished_by_spec.get(spec_name, [])]
            for seed, trace, style, note in sorted(lines, key=lambda line: line[0]):
                points = [(r["evaluations"] / 1e6, r[key]) for r in trace if r[key]]
                if points:
                    ax.step([p[0] for p in points], [p[1] for p in points], where="post", linestyle=style,
                            label=f"seed {seed}{note}")
            if row == 0:
                ax.axhline(items[0][1]["good_rms_um"], color="grey", linestyle="--", linewidth=1)
                ax.set_title(spec_name, fontsize=9)
                ax.legend(fontsize=7)
            ax.set_xlabel("merit evaluations (millions)")
            ax.set_yscale("log")
    axes[0][0].set_ylabel("best mean RMS spot radius (um)\n(dashed: the good bar)")
    axes[1][0].set_ylabel("merit of the best design")
    fig.tight_layout()
    fig.savefig(out_dir / "convergence.png")


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit("usage: study_table.py OUT EVALUATIONS")
    main(*sys.argv[1:3])
