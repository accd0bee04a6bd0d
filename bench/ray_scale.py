"""Ray overhead per task and the 1 -> 2 local worker speed-up of `unicac-ray ode` (docs/performance.md).

    python bench/ray_scale.py [LENS ...]      (UNICAC_BIN or --unicac-bin: the unicac binary)

Prints: a local Ray's start-up time; the overhead per task (no-op tasks through unicac-ray's Session, one
worker); `unicac ode` on the lenses with 1 thread (the serial reference); unicac-ray ode with 1 and 2
workers (1 lens per task, 1 thread each) and the speed-up; then the same for `dataset build` (DATASET_ARGS:
the CLI with 1 and 2 threads, unicac-ray with 1 and 2 workers, 4 shards, 1 thread per task; the outputs
are checked equal byte for byte). Also the load average, since the machine may be shared."""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import ray

from unicac.scale import dataset as ray_dataset
from unicac.scale.ode import batches, ode_task
from unicac.scale.session import Session
from unicac.scale.tasks import find_cli

LENSES = sys.argv[1:] or [
    "builtin:cooke_triplet", "lenses/double_gauss.json", "lenses/singlet.json", "builtin:petzval",
    "lenses/achromat.json", "builtin:wide_angle",
]  # fmt: skip

DATASET_ARGS = [
    "--lenses", "builtin:achromat", "builtin:cooke_triplet", "builtin:double_gauss", "builtin:petzval",
    "builtin:wide_angle", "builtin:singlet", "--images", "dead-leaves:8:640x480", "--test-images",
    "dead-leaves:2", "--frame", "640x480", "--levels", "2", "--test-lenses-per-level", "1",
    "--val-lenses", "1", "--pairs-per-lens", "4", "--crop", "256x256", "--seed", "1",
]  # fmt: skip


def folder_bytes(root: Path) -> dict:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*"))
            if p.is_file() and not p.relative_to(root).parts[0].startswith(".")}


def dataset_speed(binary: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        outputs = {}
        for threads in (1, 2):
            out = Path(tmp) / f"cli{threads}"
            t = time.perf_counter()
            subprocess.run([binary, "dataset", "build", *DATASET_ARGS, "--threads", str(threads), "--out", str(out)],
                           capture_output=True, check=True)
            took = time.perf_counter() - t
            outputs[f"cli{threads}"] = out
            print(f"unicac dataset build, {threads} thread(s): {took:.1f} s")
            if threads == 1:
                serial = took
        for workers in (1, 2):
            out = Path(tmp) / f"ray{workers}"
            session = Session(None, workers, 1).__enter__()
            plan = ray_dataset.prepare(binary, ["build", *DATASET_ARGS, "--shards", "4", "--out", str(out)])
            t = time.perf_counter()
            with open(os.devnull, "w") as sink:
                ray_dataset.run(session, plan, None, sink)
            took = time.perf_counter() - t
            outputs[f"ray{workers}"] = out
            print(f"unicac-ray dataset build, {workers} worker(s), 4 shards: {took:.1f} s "
                  f"(serial CLI / this = {serial / took:.2f})")
        reference = folder_bytes(outputs["cli1"])
        same = all(folder_bytes(out) == reference for out in outputs.values())
        print(f"dataset outputs identical across the 4 runs: {same}")


def noop(i: int) -> int:
    return i


def main() -> None:
    binary = find_cli()
    print(f"load average before: {os.getloadavg()}")
    t = time.perf_counter()
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    print(f"ray.init (local, 2 CPUs): {time.perf_counter() - t:.1f} s")
    for workers in (1, 2):
        session = Session(None, workers, 1).__enter__()
        session.map(noop, [(i,) for i in range(4)], "warm-up")
        t = time.perf_counter()
        session.map(noop, [(i,) for i in range(50)], "noop")
        print(f"no-op task, {workers} worker(s): {(time.perf_counter() - t) / 50 * 1e3:.1f} ms per task")
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    t = time.perf_counter()
    subprocess.run([binary, "ode", *LENSES], capture_output=True, env=env, check=True)
    serial = time.perf_counter() - t
    print(f"unicac ode, {len(LENSES)} lenses, 1 thread: {serial:.1f} s")
    for workers in (1, 2):
        session = Session(None, workers, 1).__enter__()
        calls = [(binary, group, [], os.getcwd(), 1, None, f"b{i}") for i, group in enumerate(batches(LENSES, 1))]
        t = time.perf_counter()
        session.map(ode_task, calls, "ode")
        took = time.perf_counter() - t
        print(f"unicac-ray ode, {workers} worker(s): {took:.1f} s (serial CLI / this = {serial / took:.2f})")
    print(f"load average after ode: {os.getloadavg()}")
    dataset_speed(binary)
    print(f"load average after: {os.getloadavg()}")
    ray.shutdown()


if __name__ == "__main__":
    main()
