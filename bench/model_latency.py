"""CPU latency of exported restoration models (docs/models.md): one 256 x 256 image through each ONNX
file in onnxruntime (what `unicac bench` runs), one thread, best of REPEATS after a warm-up.

    .venv/bin/python bench/model_latency.py MODEL.onnx... [--size 256] [--threads 1] [--repeats 3]

Inputs are built from the graph's declared inputs: batch 1, the image's height and width for the
dynamic axes, the declared size for the fixed ones (e.g. the PSF features' channels), zeros except `lq`
(a seeded random image; latency does not depend on the values).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np
import onnxruntime as ort


def _inputs(session: ort.InferenceSession, size: int) -> dict[str, np.ndarray]:
    feeds = {}
    rng = np.random.default_rng(0)
    for arg in session.get_inputs():
        dims = [d if isinstance(d, int) else None for d in arg.shape]
        # Dynamic axes: batch first, then height and width last (docs/models.md's contract).
        shape = [1 if i == 0 and d is None else (size if d is None else d) for i, d in enumerate(dims)]
        feeds[arg.name] = (rng.random(shape) if arg.name == "lq" else np.zeros(shape)).astype(np.float32)
    return feeds


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("models", nargs="+", type=Path)
    p.add_argument("--size", type=int, default=256)
    p.add_argument("--threads", type=int, default=1)
    p.add_argument("--repeats", type=int, default=3)
    a = p.parse_args(argv)
    if not (16 <= a.size <= 4096 and 1 <= a.threads <= 256 and 1 <= a.repeats <= 100):
        print("model_latency.py: --size 16..4096, --threads 1..256, --repeats 1..100", file=sys.stderr)
        return 2
    print(f"| model | inputs | latency at {a.size} x {a.size}, {a.threads} thread(s), best of {a.repeats} |")
    print("|---|---|---|")
    for path in a.models:
        if not path.is_file():
            print(f"model_latency.py: {path}: no such file", file=sys.stderr)
            return 2
        options = ort.SessionOptions()
        options.intra_op_num_threads = a.threads
        options.inter_op_num_threads = 1
        try:
            session = ort.InferenceSession(str(path), options, providers=["CPUExecutionProvider"])
            feeds = _inputs(session, a.size)
            session.run(None, feeds)  # warm-up
        except Exception as error:  # onnxruntime raises its own types for unreadable or invalid models
            print(f"model_latency.py: {path}: not a runnable ONNX model ({error})", file=sys.stderr)
            return 2
        best = float("inf")
        for _ in range(a.repeats):
            t0 = time.perf_counter()
            session.run(None, feeds)
            best = min(best, time.perf_counter() - t0)
        print(f"| `{path.stem}` | {', '.join(feeds)} | {best:.3f} s |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
