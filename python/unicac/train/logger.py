"""What a run writes besides checkpoints: `log.csv` / `log.jsonl` (one row per logged iteration or
validation), `curves.png` (loss and validation PSNR/SSIM over iterations) and a progress bar with
loss and it/s (on a terminal; plain lines every `print_freq` iterations otherwise)."""

from __future__ import annotations

import csv
import io
import json
import sys
import time
from pathlib import Path
from typing import Any, Optional

from unicac.outputs import write_bytes, write_with

#: The files a run's log writes into the run folder.
JSONL, CSV, CURVES = "log.jsonl", "log.csv", "curves.png"
LOG_FILES = (JSONL, CSV, CURVES)
#: A `val` row's scores (Trainer.validate; empty where the run does not compute them).
VALIDATION_LOG_FIELDS = ["psnr_db", "ssim", "lpips", "prediction_l1", "wiener_psnr_db", "wiener_lpips"]
#: Scores also logged over the validation pairs of severe-level lenses alone, as `severe_<score>`.
SEVERE_SCORES = ["psnr_db", "input_psnr_db", "lpips", "wiener_psnr_db", "wiener_lpips"]
VALIDATION_LOG_FIELDS += [f"severe_{key}" for key in SEVERE_SCORES]
LOG_FIELDS = ["iter", "kind", "loss", "lr", "it_per_s", *VALIDATION_LOG_FIELDS, "seconds"]


class RunLog:
    """Rows kept in memory and rewritten atomically (the log of a resumed run continues the old one,
    truncated to the resumed iteration so that no row is counted twice)."""

    def __init__(self, folder: Path, resume_iter: Optional[int] = None) -> None:
        self.folder = folder
        self.rows: list[dict[str, Any]] = []
        jsonl = folder / JSONL
        if resume_iter is not None and jsonl.exists():
            for line in jsonl.read_text().splitlines():
                if line.strip():
                    row = json.loads(line)
                    if row["iter"] <= resume_iter:
                        self.rows.append(row)

    def add(self, **row: Any) -> None:
        self.rows.append({key: row.get(key) for key in LOG_FIELDS})

    def flush(self) -> None:
        text = "".join(json.dumps(row) + "\n" for row in self.rows)
        write_bytes(self.folder / JSONL, text.encode())
        buffer = io.StringIO()
        writer = csv.DictWriter(buffer, fieldnames=LOG_FIELDS)
        writer.writeheader()
        for row in self.rows:
            writer.writerow({k: ("" if v is None else v) for k, v in row.items()})
        write_bytes(self.folder / CSV, buffer.getvalue().encode())

    def plot(self) -> Optional[Path]:
        """`curves.png`: training loss (left), validation PSNR / SSIM (middle; the Wiener estimate's PSNR
        dashed for a network that refines it) and, for runs with a perceptual loss, validation LPIPS
        (right; the Wiener estimate's dashed) against iteration; the same over the severe-level pairs
        alone in purple. Needs matplotlib (in the `train` extra); returns None without it."""
        try:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            return None
        train = [r for r in self.rows if r["kind"] == "train"]
        val = [r for r in self.rows if r["kind"] == "val"]
        perceptual = [r for r in val if r.get("lpips") is not None]
        figure, axes = plt.subplots(1, 3 if perceptual else 2, figsize=(15 if perceptual else 10, 3.6))
        left, right = axes[0], axes[1]
        left.plot([r["iter"] for r in train], [r["loss"] for r in train], lw=1)
        left.set_xlabel("iteration")
        left.set_ylabel("training loss")
        left.set_yscale("log")
        left.grid(alpha=0.3)
        if val:
            right.plot([r["iter"] for r in val], [r["psnr_db"] for r in val], "o-", color="C1", label="PSNR")
            _reference(right, val, "wiener_psnr_db", "C1")
            _severe(right, val, "psnr_db", "C4")
            right.set_ylabel("validation PSNR (dB)")
            twin = right.twinx()
            twin.plot([r["iter"] for r in val], [r["ssim"] for r in val], "s--", color="C2", label="SSIM")
            twin.set_ylabel("validation SSIM")
            # One legend for both axes of the panel (PSNR, the Wiener reference, SSIM).
            handles = right.get_legend_handles_labels()[0] + twin.get_legend_handles_labels()[0]
            right.legend(handles, [h.get_label() for h in handles], loc="best", fontsize=8)
        right.set_xlabel("iteration")
        right.grid(alpha=0.3)
        if perceptual:
            axis = axes[2]
            axis.plot([r["iter"] for r in perceptual], [r["lpips"] for r in perceptual], "o-", color="C3", label="restored")
            _reference(axis, perceptual, "wiener_lpips", "C3")
            _severe(axis, perceptual, "lpips", "C4")
            axis.legend(loc="best", fontsize=8)
            axis.set_xlabel("iteration")
            axis.set_ylabel("validation LPIPS (lower is better)")
            axis.grid(alpha=0.3)
        figure.tight_layout()
        path = self.folder / CURVES
        write_with(path, lambda handle: figure.savefig(handle, format="png", dpi=100))
        plt.close(figure)
        return path


def _series(axis: Any, rows: list[dict[str, Any]], key: str, style: str, color: str, label: str) -> bool:
    """Plots `key` against iteration over the rows that logged it; whether there were any."""
    points = [(r["iter"], r[key]) for r in rows if r.get(key) is not None]
    if points:
        axis.plot(*zip(*points), style, color=color, label=label)
    return bool(points)


def _severe(axis: Any, rows: list[dict[str, Any]], key: str, color: str) -> None:
    """The score over the severe-level validation pairs (triangles) and, when logged, the Wiener
    estimate's there (dotted)."""
    _series(axis, rows, f"severe_{key}", "^-", color, "severe levels")
    _series(axis, rows, f"severe_wiener_{key}", ":", color, "severe levels, Wiener estimate")


def _reference(axis: Any, rows: list[dict[str, Any]], key: str, color: str) -> None:
    """The Wiener estimate's score as a dashed line (the network starts from it and should stay on the
    better side of it)."""
    if _series(axis, rows, key, ":", color, "Wiener estimate"):
        axis.legend(loc="best", fontsize=8)


class Progress:
    """`iter/total loss it/s` on one refreshed line when stderr is a terminal, else a line every
    `every` iterations."""

    def __init__(self, start: int, total: int, every: int, enabled: bool = True) -> None:
        self.total, self.every, self.enabled = total, every, enabled
        self.tty = sys.stderr.isatty()
        self.t0 = time.perf_counter()
        self.start = start

    def rate(self, iteration: int) -> float:
        done = iteration - self.start
        return done / max(time.perf_counter() - self.t0, 1e-9)

    def update(self, iteration: int, loss: float) -> None:
        if not self.enabled:
            return
        if not self.tty and iteration % self.every and iteration != self.total:
            return
        width = 30
        filled = int(width * iteration / max(self.total, 1))
        bar = "#" * filled + "-" * (width - filled)
        line = f"[{bar}] {iteration}/{self.total} loss {loss:.4f} {self.rate(iteration):.2f} it/s"
        if self.tty:
            sys.stderr.write("\r" + line + ("\n" if iteration == self.total else ""))
        else:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()

    def message(self, text: str) -> None:
        if self.enabled:
            sys.stderr.write(("\n" if self.tty else "") + text + "\n")
            sys.stderr.flush()
