"""`unicac-ray dataset build`: one Ray task per shard, all writing into one dataset folder.

`unicac dataset build ... --shard I/N` renders the pairs, PSF table and edge set of each lens in use whose
rank is I-1 modulo N (whole lenses: each PSF map is traced once) and writes the same manifests as every other shard; N shards in one folder equal the single run
byte for byte (docs/dataset.md). Every shard grades every lens (the levels need all grades), from the
grade cache in `OUT/.cache/ode` when another run has filled it. So the driver runs:

1. shard 1/N alone: it grades the library (the serial part: the ODE of the library before sampling) and
   fills the cache;
2. shards 2..N as Ray tasks, `--workers` at a time, each reading the grades from the cache;
3. the single-machine command itself, unsharded, on the driver: it finds every file present, renders
   nothing, writes `dataset.json` (the mark of a complete dataset) and prints the CLI's own summary.

Every step is the CLI resuming into the folder, so a killed task or a restarted driver redoes only
missing files. The folder must be on a filesystem every node sees.
"""

from __future__ import annotations

import argparse
from typing import Optional, Sequence, TextIO

from .tasks import parse_shards, run_sharded

class Plan:
    def __init__(self, binary: str, argv: Sequence[str]):
        argv = list(argv)
        if not argv or argv[0] != "build":
            argparse.ArgumentParser(prog="unicac-ray dataset").error(
                "only `dataset build` runs on Ray (info and plot are instant)"
            )
        parser = argparse.ArgumentParser(prog="unicac-ray dataset build", allow_abbrev=False, add_help=False)
        self.shards: Optional[int]
        self.shards, self.rest = parse_shards(parser, argv[1:], ["--threads"])
        self.binary = binary


def prepare(binary: str, argv: Sequence[str]) -> Plan:
    return Plan(binary, argv)


def run(session, plan: Plan, fault_dir: Optional[str], stdout: TextIO) -> int:
    # The unsharded CLI at the end checks that every file is present and writes dataset.json and the summary.
    threads = ["--threads", str(session.cpus_per_task)]
    return run_sharded(
        session, plan.binary, ["dataset", "build"], plan.rest, threads, plan.shards, fault_dir, "grades the library",
        stdout,
    )
