"""Ray overhead per task and the 1 -> 2 local worker speed-up of `unicac-ray ode` (docs/performance.md).

    python bench/ray_scale.py [LENS ...]      (UNICAC_BIN or --unicac-bin: the unicac binary)

Prints: a local Ray's start-up time; the overhead per task (no-op tasks through unicac-ray's Session, one
worker); `unicac ode` on the lenses with 1 thread (the serial reference); unicac-ray ode with 1 and 2
workers (1 lens per task, 1 thread each) and the speed-up. Also the load average, since the machine may be
shared."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import ray

from unicac.scale.ode import batches, ode_task
from unicac.scale.session import Session
from unicac.scale.tasks import find_cli

LENSES = sys.argv[1:] or [
    "builtin:cooke_triplet", "lenses/double_gauss.json", "lenses/singlet.json", "builtin:petzval",
    "lenses/achromat.json", "builtin:wide_angle",
]  # fmt: skip


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
    print(f"load average after: {os.getloadavg()}")
    ray.shutdown()


if __name__ == "__main__":
    main()
