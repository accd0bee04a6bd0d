"""PSNR / SSIM of a trained run on a built dataset's test split, per ODE level, against the
unrestored input (the docs/models.md table):

    python -m unicac.train.evaluate RUN_DIR --dataset DIR [--split test] [--max-pairs N] [--json]

Whole test images (no crop), in manifest order (with `--max-pairs` below the split's size: spread over
its lenses, as validation); levels from `lenses.jsonl` (1 = mildest). Metrics as in
validation (`unicac.train.metrics`: RGB, no border crop)."""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from typing import Any

import torch

from unicac.dataset import DatasetFolder, to_chw

from .data.datasets import spread_over_lenses
from .export import load_run
from .metrics import psnr, ssim

MAX_PAIRS = 1_000_000


@torch.no_grad()
def evaluate(run_dir: str, dataset: str, split: str = "test", max_pairs: int = MAX_PAIRS) -> dict[str, Any]:
    net, config, state = load_run(run_dir)
    folder = DatasetFolder(dataset)
    maps = net.inputs[1:]
    rows = folder.check_split(split, need_psf=any(m in ("psf", "psf_code", "wiener") for m in maps))
    if len(rows) > max_pairs:
        rows = spread_over_lenses(rows, max_pairs)
    levels = {lens["lens_id"]: lens.get("level") for lens in folder.lenses()}
    scores: dict[Any, list[list[float]]] = defaultdict(list)
    for row in rows:
        pair = folder.load(row, fov="fov" in maps, psf="psf" in maps, psf_code="psf_code" in maps,
                           wiener="wiener" in maps, wiener_nsr=config["datasets"]["train"]["wiener_nsr"])
        lq = torch.from_numpy(to_chw(pair["lq"]))[None]
        gt = torch.from_numpy(to_chw(pair["gt"]))[None]
        given = {name: torch.from_numpy(to_chw(pair[name]) if name == "wiener" else pair[name])[None] for name in maps}
        restored = net(lq, **given).clamp(0, 1)
        values = [float(psnr(restored, gt)), float(ssim(restored, gt)), float(psnr(lq, gt)), float(ssim(lq, gt))]
        scores[levels.get(row["lens_id"])].append(values)
        scores["all"].append(values)
    out: dict[str, Any] = {"run": run_dir, "architecture": net.architecture, "iterations": state.get("iteration"), "levels": {}}
    for level, values in sorted(scores.items(), key=lambda kv: (kv[0] == "all", str(kv[0]))):
        t = torch.tensor(values, dtype=torch.float64).mean(0).tolist()
        out["levels"][str(level)] = {"pairs": len(values), "psnr_db": t[0], "ssim": t[1], "input_psnr_db": t[2], "input_ssim": t[3]}
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m unicac.train.evaluate", description=__doc__.split("\n\n")[0])
    p.add_argument("run_dir")
    p.add_argument("--dataset", required=True)
    p.add_argument("--split", default="test", choices=("train", "val", "test"))
    p.add_argument("--max-pairs", type=int, default=MAX_PAIRS, help=f"at most this many pairs (1..{MAX_PAIRS})")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    if not 1 <= args.max_pairs <= MAX_PAIRS:
        p.error(f"--max-pairs: {args.max_pairs} is outside 1..{MAX_PAIRS}")
    from .cli import run_command

    return run_command(p.prog, _report, args)


def _report(args: argparse.Namespace) -> int:
    report = evaluate(args.run_dir, args.dataset, args.split, args.max_pairs)
    if args.json:
        print(json.dumps(report))
        return 0
    print(f"{report['run']} ({report['architecture']}, {report['iterations']} iterations), split {args.split}")
    for level, s in report["levels"].items():
        print(f"  level {level:>4}: {s['pairs']:4d} pairs  PSNR {s['psnr_db']:6.2f} dB (input {s['input_psnr_db']:6.2f})  "
              f"SSIM {s['ssim']:.4f} (input {s['input_ssim']:.4f})")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
