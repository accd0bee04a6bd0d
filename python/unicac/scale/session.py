"""Starting (or joining) Ray and running tasks through it, at most `workers` at a time, with progress."""

from __future__ import annotations

import sys
import time
from typing import Any, Callable, Optional, Sequence

import ray

from .tasks import MAX_RETRIES

# Stated limits of the driver's count flags.
MAX_WORKERS = 4096
MAX_CPUS_PER_TASK = 256


class Session:
    """`ray.init` on `address` (None: a local Ray with workers x cpus_per_task CPUs, stopped afterwards)."""

    owned = False

    def __init__(self, address: Optional[str], workers: int, cpus_per_task: int):
        if not 1 <= workers <= MAX_WORKERS:
            raise ValueError(f"--workers {workers}: must be 1 to {MAX_WORKERS}")
        if not 1 <= cpus_per_task <= MAX_CPUS_PER_TASK:
            raise ValueError(f"--cpus-per-task {cpus_per_task}: must be 1 to {MAX_CPUS_PER_TASK}")
        self.address = address
        self.workers = workers
        self.cpus_per_task = cpus_per_task

    def __enter__(self) -> "Session":
        # A Ray already started in this process (a notebook, the tests) is used as it is, and left running.
        self.owned = not ray.is_initialized()
        if not self.owned:
            return self
        if self.address:
            ray.init(address=self.address, log_to_driver=False)
        else:
            ray.init(
                num_cpus=self.workers * self.cpus_per_task,
                include_dashboard=False,
                log_to_driver=False,
            )
        return self

    def __exit__(self, *exc: Any) -> None:
        if self.owned:
            ray.shutdown()

    def map(self, function: Callable[..., Any], calls: Sequence[tuple], label: str) -> list:
        """Runs function(*call) for every call as Ray tasks, `workers` in flight; results in call order."""
        remote = ray.remote(function).options(num_cpus=self.cpus_per_task, max_retries=MAX_RETRIES)
        results: list = [None] * len(calls)
        pending: dict = {}
        next_call = 0
        done = 0
        start = time.monotonic()
        progress = Progress(label, len(calls))
        while done < len(calls):
            while next_call < len(calls) and len(pending) < self.workers:
                pending[remote.remote(*calls[next_call])] = next_call
                next_call += 1
            ready, _ = ray.wait(list(pending), num_returns=1)
            for ref in ready:
                index = pending.pop(ref)
                results[index] = ray.get(ref)
                done += 1
                progress.update(done, time.monotonic() - start)
        progress.finish()
        return results


class Progress:
    """`label [=====>   ] k/n elapsed` on stderr: redrawn in place on a terminal, one line per task else."""

    def __init__(self, label: str, total: int):
        self.label, self.total = label, total
        self.tty = sys.stderr.isatty()

    def update(self, done: int, elapsed_s: float) -> None:
        width = 30
        filled = width * done // max(self.total, 1)
        line = f"{self.label} [{'=' * filled}{' ' * (width - filled)}] {done}/{self.total} {elapsed_s:.1f} s"
        if self.tty:
            sys.stderr.write("\r" + line)
        else:
            sys.stderr.write(line + "\n")
        sys.stderr.flush()

    def finish(self) -> None:
        if self.tty:
            sys.stderr.write("\n")

            sys.stderr.flush()
