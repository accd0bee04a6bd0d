"""Does the data path keep up with training? Samples per second of one data-loader worker against
the time of one training step, on CPU (the figures in docs/models.md):

    python -m unicac.train.throughput --lenses builtin:cooke_triplet builtin:phone_asphere \\
        [--dataset DIR] [--frame 512x384] [--patch 64] [--batch 4] [--samples 20]

Measures, in this process (one worker): on-the-fly patches rendered as a window (what training uses)
and as a whole frame cut afterwards (the old way), patches of a built dataset when --dataset is
given, and one optimiser step of each shipped model at the same batch and patch size.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import torch

from unicac import _native
from unicac.dataset import DatasetFolder, PairGenerator

from . import config as config_mod
from .archs import build_network
from .data.datasets import FolderPatches

MAX_SAMPLES = 10_000


def _rate(make, samples: int) -> float:
    make(0)  # warm-up: traces the lens's PSFs once (cached per process afterwards)
    t0 = time.perf_counter()
    for k in range(1, samples + 1):
        make(k)
    return samples / (time.perf_counter() - t0)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m unicac.train.throughput", description=__doc__.split("\n\n")[0])
    p.add_argument("--lenses", nargs="+", default=["builtin:cooke_triplet"])
    p.add_argument("--dataset")
    p.add_argument("--frame", default="512x384")
    p.add_argument("--patch", type=int, default=64)
    p.add_argument("--batch", type=int, default=4)
    p.add_argument("--samples", type=int, default=20, help=f"samples per measurement (1..{MAX_SAMPLES})")
    args = p.parse_args(argv)
    if not 1 <= args.samples <= MAX_SAMPLES:
        p.error(f"--samples: {args.samples} is outside 1..{MAX_SAMPLES}")
    width, height = (int(v) for v in args.frame.lower().split("x"))
    generator = PairGenerator(args.lenses, patch_px=args.patch, frame_px=(width, height), seed=0)
    rows = [("on the fly, window render", _rate(generator.pair, args.samples))]

    def whole_frame(k: int) -> None:
        rng = np.random.default_rng([0, k])
        simulator, _ = generator._simulator(0)
        frame = _native.chart("dead-leaves", width, height, seed=int(rng.integers(1 << 62)))
        simulator.render_pair(frame, seed=k)

    rows.append(("on the fly, whole frame (before)", _rate(whole_frame, max(2, args.samples // 4))))
    if args.dataset:
        folder = DatasetFolder(args.dataset)
        options = {"patch_px": args.patch, "use_flip": True, "use_rot": True}
        patches = FolderPatches(folder, folder.check_split("train"), options, 0, fov=True, psf=True)
        rows.append(("built dataset (with fov + psf maps)", _rate(patches.__getitem__, args.samples)))
    print(f"data: one worker, {args.patch} px patches, {width} x {height} frames")
    for name, rate in rows:
        print(f"  {name:<38} {rate:8.1f} samples/s")
    print(f"training step: batch {args.batch} x {args.patch} px, {torch.get_num_threads()} threads")
    for path in sorted(config_mod.CONFIG_DIR.glob("*.yml")):
        net = build_network(config_mod.load(path)["network"])
        optimiser = torch.optim.AdamW(net.parameters(), 1e-4)
        x = {k: torch.rand(args.batch, c, args.patch, args.patch) for k, c in (("lq", 3), ("fov", 2), ("psf", 15))}

        def step() -> None:
            out = net.training_outputs(x["lq"], x["fov"], x["psf"])
            out["restored"].mean().backward()
            optimiser.step()
            optimiser.zero_grad()

        step()
        t0 = time.perf_counter()
        for _ in range(3):
            step()
        seconds = (time.perf_counter() - t0) / 3
        print(f"  {path.stem:<18} {seconds * 1000:7.0f} ms/step = {args.batch / seconds:7.1f} samples/s needed")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
