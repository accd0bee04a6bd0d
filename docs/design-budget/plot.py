"""Best mean RMS spot radius against time from a design library's convergence trace
(`DIR/state/<spec>.rounds.jsonl`, docs/design.md). Usage: python plot.py TRACE.jsonl OUT.png TITLE"""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(trace: str, out: str, title: str) -> None:
    rounds = [json.loads(line) for line in open(trace) if line.strip()]
    points = [(r["elapsed_s"], r["best_rms_mean_um"], r["curriculum"]) for r in rounds if r["best_rms_mean_um"]]
    fig, ax = plt.subplots(figsize=(7, 4), dpi=110)
    ax.step([p[0] for p in points], [p[1] for p in points], where="post", color="tab:blue", label="best kept design")
    for curriculum, marker, label in [(False, "o", "round: the spec itself"), (True, "^", "round: from F/4 (curriculum)")]:
        chosen = [p for p in points if p[2] == curriculum]
        ax.scatter([p[0] for p in chosen], [p[1] for p in chosen], s=10, marker=marker, label=label)
    ax.axvline(420, color="grey", linestyle="--", linewidth=1)
    ax.text(425, ax.get_ylim()[1] * 0.97, "420 s", va="top", fontsize=8, color="grey")
    ax.set_xlabel("seconds since the run started on the spec")
    ax.set_ylabel("mean RMS spot radius (um)")
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out)


if __name__ == "__main__":
    main(*sys.argv[1:4])
