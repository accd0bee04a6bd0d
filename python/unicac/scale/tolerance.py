"""`unicac-ray tolerance`: one Ray task per shard, all writing into one run folder.

`unicac tolerance LENS --spec TOL --trials N --seed S --out RUN --shard I/K` makes the chunk files (64 units
each) whose index is I-1 modulo K; K shards in one folder equal the single run byte for byte
(docs/tolerancing.md). So the driver runs:

1. shard 1/K alone: it writes `run.json` first, so the other shards find the folder theirs;
2. shards 2..K as Ray tasks, `--workers` at a time;
3. the single-machine command itself, unsharded, on the driver: it finds every chunk present, grades
   nothing, writes `summary.json` and `yield.png` and prints the CLI's own table.

Every step is the CLI resuming into the folder, so a killed task or a restarted driver redoes only missing
chunks. The folder must be on a filesystem every node sees.
"""

from __future__ import annotations

import argparse
import sys
from typing import Optional, Sequence, TextIO

from .tasks import fail_once, run_cli

MAX_SHARDS = 10_000


class Plan:
    def __init__(self, binary: str, argv: Sequence[str]):
        parser = argparse.ArgumentParser(prog="unicac-ray tolerance", allow_abbrev=False, add_help=False)
        parser.add_argument("--shard")
        parser.add_argument("--shards", type=int, help=f"shards (1 to {MAX_SHARDS}; default 4 per worker)")
        known, self.rest = parser.parse_known_args(list(argv))
        if known.shard:
            parser.error("--shard is set by the driver (--shards)")
        if known.shards is not None and not 1 <= known.shards <= MAX_SHARDS:
            parser.error(f"--shards {known.shards}: must be 1 to {MAX_SHARDS}")
        if not self.rest:
            parser.error("give the `unicac tolerance` arguments: LENS --spec TOL.json --out RUN ...")
        self.binary = binary
        self.shards: Optional[int] = known.shards


def prepare(binary: str, argv: Sequence[str]) -> Plan:
    return Plan(binary, argv)


def shard_task(binary: str, args: list[str], index: int, shards: int, threads: int, fault_dir: Optional[str]) -> int:
    """Ray task: `unicac tolerance ARGS --shard I/N` (resumes: chunks present are skipped)."""
    run_cli(binary, ["tolerance", *args, "--shard", f"{index}/{shards}"], threads)
    fail_once(fault_dir, f"tolerance-shard-{index}-of-{shards}")
    return index


def run(session, plan: Plan, fault_dir: Optional[str], stdout: TextIO) -> int:
    shards = plan.shards or min(MAX_SHARDS, 4 * session.workers)
    threads = session.cpus_per_task
    print(f"tolerance: {shards} shards; shard 1 writes the run record first", file=sys.stderr)
    session.map(shard_task, [(plan.binary, plan.rest, 1, shards, threads, fault_dir)], "tolerance shard 1")
    calls = [(plan.binary, plan.rest, i, shards, threads, fault_dir) for i in range(2, shards + 1)]
    session.map(shard_task, calls, "tolerance shards")
    # The unsharded CLI: checks that every chunk is present, writes the summary and prints the table.
    stdout.write(run_cli(plan.binary, ["tolerance", *plan.rest], threads))
    stdout.flush()
    return 0
