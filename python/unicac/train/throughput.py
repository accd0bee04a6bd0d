"""Training throughput on this machine: samples per second of each shipped model's training step, and
of the data sources that feed it (the figures in docs/models.md):

    python -m unicac.train.throughput [--patches 128 256] [--batch 4] [--models nafnet restormer ...]
        [--lenses builtin:cooke_triplet ...] [--dataset DIR] [--frame 512x384] [--samples 20]
        [--steps 3] [--compile on|off] [--gpu-tflops T --paper-iters 200000 --paper-batch 32] [--json]

Per model and patch size: the mean time of `--steps` optimiser steps (forward, L1 loss, backward,
AdamW) after one warm-up step, as samples/s, and the training FLOPs of one sample (the forward
pass's, counted by `torch.utils.flop_counter` in multiply-adds x 2, times 3 for the backward pass).
With `--gpu-tflops T` it projects the paper's recipe (`--paper-iters` x `--paper-batch` samples of
256 px) onto a GPU sustaining T TFLOP/s: an estimate whose basis (FLOPs, T) is printed with it.
With `--lenses`, also on-the-fly pair rendering (one worker) at each patch size; with `--dataset`,
patches of a built dataset (with the maps each model needs). Timings are of this process on this
machine: run it on an idle one.
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any, Callable

import torch

from . import config as config_mod
from .archs import INPUT_CHANNELS, build_network, count_parameters

MAX_SAMPLES = 10_000
MAX_BATCH = 256
MAX_STEPS = 1_000
#: The paper scale (scripts/reproduce.sh --scale paper): NAFNet's official recipe, 256 px patches.
PAPER_PATCH_PX = 256


def _rate(make: Callable[[int], Any], samples: int) -> float:
    make(0)  # warm-up: traces the lens's PSFs once (cached per process afterwards)
    t0 = time.perf_counter()
    for k in range(1, samples + 1):
        make(k)
    return samples / (time.perf_counter() - t0)


def _inputs(net: Any, batch: int, patch: int) -> dict[str, torch.Tensor]:
    generator = torch.Generator().manual_seed(0)
    names = ["lq", *net.needs]
    return {name: torch.rand(batch, INPUT_CHANNELS[name], patch, patch, generator=generator) for name in names}


def forward_flops(net: Any, patch: int) -> int:
    """FLOPs (multiply-adds x 2) of one forward pass of one `patch` x `patch` sample."""
    from torch.utils.flop_counter import FlopCounterMode

    x = _inputs(net, 1, patch)
    counter = FlopCounterMode(display=False)
    with counter, torch.no_grad():
        net.training_outputs(x.pop("lq"), **x)
    return int(counter.get_total_flops())


def step_seconds(net: Any, batch: int, patch: int, steps: int, compile_step: bool = False) -> float:
    """Mean seconds of one optimiser step (after a warm-up step, which compiles the step when
    `compile_step`: what `train.compile: on` runs)."""
    optimiser = torch.optim.AdamW(net.parameters(), 1e-4)
    forward = net.training_outputs
    if compile_step:
        torch.compiler.reset()  # a graph for this size alone, as a training run has
        forward = torch.compile(forward)
    x = _inputs(net, batch, patch)
    gt = torch.rand(batch, 3, patch, patch)

    def step() -> None:
        maps = {k: v for k, v in x.items() if k != "lq"}
        out = forward(x["lq"], **maps)
        loss = torch.nn.functional.l1_loss(out["restored"], gt)
        if "prediction" in out:
            loss = loss + torch.nn.functional.l1_loss(out["prediction"], maps[net.predicts])
        loss.backward()
        optimiser.step()
        optimiser.zero_grad()

    step()
    t0 = time.perf_counter()
    for _ in range(steps):
        step()
    return (time.perf_counter() - t0) / steps


def _data_rates(args: argparse.Namespace) -> list[dict[str, Any]]:
    from unicac.dataset import DatasetFolder, PairGenerator

    from .data.datasets import FolderPatches

    rows = []
    width, height = (int(v) for v in args.frame.lower().split("x"))
    for patch in args.patches:
        if args.lenses:
            generator = PairGenerator(args.lenses, patch_px=patch, frame_px=(width, height), seed=0)
            rows.append({"source": f"on the fly, {width} x {height} frames", "patch_px": patch,
                         "samples_per_s": _rate(generator.pair, args.samples)})
        if args.dataset:
            folder = DatasetFolder(args.dataset)
            options = {"patch_px": patch, "use_flip": True, "use_rot": True, "wiener_nsr": 0.01}
            for maps, label in (((), "lq, gt"), (("fov", "psf_code"), "+ fov, psf_code"), (("wiener",), "+ wiener")):
                patches = FolderPatches(folder, folder.check_split("train", need_psf=bool(maps)), options, 0, maps)
                rows.append({"source": f"built dataset ({label})", "patch_px": patch,
                             "samples_per_s": _rate(patches.__getitem__, args.samples)})
    return rows


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m unicac.train.throughput", description=__doc__.split("\n\n")[0])
    p.add_argument("--patches", type=int, nargs="+", default=[128, 256], help="patch sides (px, 16..1024)")
    p.add_argument("--batch", type=int, default=4, help=f"samples per step (1..{MAX_BATCH})")
    p.add_argument("--models", nargs="+", help="shipped models to time (default: all, `unicac-train models`)")
    p.add_argument("--steps", type=int, default=3, help=f"timed steps per model and size (1..{MAX_STEPS})")
    p.add_argument("--lenses", nargs="*", default=[], help="also time on-the-fly rendering through these lenses")
    p.add_argument("--dataset", help="also time patches of this built dataset")
    p.add_argument("--frame", default="512x384", help=f"on-the-fly frame (WIDTHxHEIGHT, 16..{config_mod.MAX_FRAME_SIDE_PX} px each)")
    p.add_argument("--samples", type=int, default=20, help=f"samples per data measurement (1..{MAX_SAMPLES})")
    p.add_argument("--gpu-tflops", type=float, help="project the paper's recipe onto a GPU sustaining this many TFLOP/s")
    p.add_argument("--paper-iters", type=int, default=200_000)
    p.add_argument("--paper-batch", type=int, default=32)
    p.add_argument("--compile", choices=("on", "off"), default="off",
                   help="time the step through torch.compile, as `unicac-train train --compile on` runs it")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    if not 1 <= args.samples <= MAX_SAMPLES:
        p.error(f"--samples: {args.samples} is outside 1..{MAX_SAMPLES}")
    if not 1 <= args.steps <= MAX_STEPS:
        p.error(f"--steps: {args.steps} is outside 1..{MAX_STEPS}")
    if not 1 <= args.batch <= MAX_BATCH:
        p.error(f"--batch: {args.batch} is outside 1..{MAX_BATCH}")
    try:
        width, height = (int(v) for v in args.frame.lower().split("x"))
    except ValueError:
        p.error(f"--frame: {args.frame!r} is not WIDTHxHEIGHT (e.g. 512x384)")
    if not all(16 <= side <= config_mod.MAX_FRAME_SIDE_PX for side in (width, height)):
        p.error(f"--frame: {width}x{height} is outside 16..{config_mod.MAX_FRAME_SIDE_PX} px per side")
    if any(not 16 <= s <= 1024 for s in args.patches):
        p.error(f"--patches: each side must be in 16..1024, got {args.patches}")
    if args.gpu_tflops is not None and not args.gpu_tflops > 0:
        p.error("--gpu-tflops: must be positive")
    from .cli import run_command

    return run_command(p.prog, _measure, args)


def _measure(args: argparse.Namespace) -> int:
    if args.compile == "on":
        from .models.trainer import require_cpp_compiler

        require_cpp_compiler("--compile on")
    names = args.models or sorted(path.stem for path in config_mod.CONFIG_DIR.glob("*.yml"))
    configs = {name: config_mod.load(config_mod.shipped(name)) for name in names}  # bad names fail first
    report: dict[str, Any] = {"threads": torch.get_num_threads(), "batch": args.batch, "compile": args.compile,
                              "data": _data_rates(args), "models": []}
    for name, config in configs.items():
        torch.manual_seed(0)
        net = build_network(config["network"])
        row: dict[str, Any] = {"model": name, "params": count_parameters(net), "sizes": {}}
        for patch in args.patches:
            seconds = step_seconds(net, args.batch, patch, args.steps, compile_step=args.compile == "on")
            flops = 3 * forward_flops(net, patch)
            row["sizes"][str(patch)] = {"step_s": seconds, "samples_per_s": args.batch / seconds, "train_gflops_per_sample": flops / 1e9}
        if args.gpu_tflops:
            flops = 3 * forward_flops(net, PAPER_PATCH_PX) * args.paper_iters * args.paper_batch
            row["paper_recipe_gpu_hours_estimate"] = flops / (args.gpu_tflops * 1e12) / 3600
        report["models"].append(row)
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    for row in report["data"]:
        print(f"data {row['source']:<38} {row['patch_px']:4d} px {row['samples_per_s']:8.1f} samples/s (one worker)")
    compiled = ", torch.compile" if args.compile == "on" else ""
    print(f"training step: batch {args.batch}, {report['threads']} threads{compiled}")
    for row in report["models"]:
        sizes = "  ".join(f"{p} px: {v['samples_per_s']:6.2f} samples/s ({v['train_gflops_per_sample']:.1f} GFLOP/sample)"
                          for p, v in row["sizes"].items())
        print(f"  {row['model']:<26} {row['params']:>10,} params  {sizes}")
        if "paper_recipe_gpu_hours_estimate" in row:
            print(f"    estimate: {args.paper_iters:,} iterations x batch {args.paper_batch} x {PAPER_PATCH_PX} px at "
                  f"{args.gpu_tflops:g} TFLOP/s sustained = {row['paper_recipe_gpu_hours_estimate']:.1f} GPU hours "
                  "(training FLOPs = 3 x forward FLOPs)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
