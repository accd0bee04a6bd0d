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
from typing import Optional, Sequence, TextIO

from .tasks import parse_shards, run_sharded

class Plan:
    def __init__(self, binary: str, argv: Sequence[str]):
        parser = argparse.ArgumentParser(prog="unicac-ray tolerance", allow_abbrev=False, add_help=False)
        self.shards: Optional[int]
        self.shards, self.rest = parse_shards(parser, argv)
        if not self.rest:
            parser.error("give the `unicac tolerance` arguments: LENS --spec TOL.json --out RUN ...")
        self.binary = binary


def prepare(binary: str, argv: Sequence[str]) -> Plan:
    return Plan(binary, argv)


def run(session, plan: Plan, fault_dir: Optional[str], stdout: TextIO) -> int:
    # The unsharded CLI at the end finds every chunk, writes the summary and prints the table.
    return run_sharded(
        session, plan.binary, ["tolerance"], plan.rest, [], plan.shards, fault_dir, "writes the run record", stdout
    )
