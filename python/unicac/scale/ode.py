"""`unicac-ray ode`: the ODE of many lenses in batches, one Ray task per batch, merged into exactly the
stdout (`--json` or the table) and `--csv` file that `unicac ode LENSES...` writes.

The CLI grades each lens independently and lists them in the order given, so the merged output is the
batches' outputs spliced in batch order: the JSON arrays' elements (as text, never re-serialised, so
every number keeps the CLI's own formatting), the table's and the CSV's rows under one header.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
import tempfile
from pathlib import Path
from typing import Optional, Sequence, TextIO

from unicac.outputs import OutputPlan, require_extension, write_text

from .tasks import fail_once, run_cli

MAX_BATCH = 100_000
# How `unicac ode --json` wraps its list (serde_json's pretty printer, two-space indent).
_JSON_HEAD = '{\n  "lenses": [\n'
_JSON_TAIL = "\n  ]\n}\n"


def parse(argv: Sequence[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="unicac-ray ode", allow_abbrev=False)
    parser.add_argument("lenses", nargs="+", help="lens files (.json, .zmx) or builtin:NAME")
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--csv", type=Path)
    parser.add_argument("--plot", type=Path)
    parser.add_argument("--device")
    parser.add_argument("--gpu-precision")
    parser.add_argument(
        "--batch-size", type=int, help=f"lenses per task (1 to {MAX_BATCH}; default: 4 batches per worker)"
    )
    parser.add_argument(
        "--work-dir", type=Path, help="keep each batch's result here; a restarted driver reuses them"
    )
    args = parser.parse_intermixed_args(list(argv))
    if args.plot is not None:
        parser.error("--plot: not drawn on Ray; run `unicac ode ... --plot` on the merged lenses, or plot the --csv")
    if args.batch_size is not None and not 1 <= args.batch_size <= MAX_BATCH:
        parser.error(f"--batch-size {args.batch_size}: must be 1 to {MAX_BATCH}")
    return args


def check_outputs(args: argparse.Namespace) -> None:
    """--csv and --work-dir against the lens files, before Ray starts (the tasks' own `unicac ode` runs
    write temporary files and never see the user's --csv)."""
    plan = OutputPlan()
    for lens in args.lenses:
        if not lens.startswith("builtin:"):
            plan.input(lens)
    if args.csv is not None:
        require_extension("--csv", args.csv, ["csv"])
        plan.output("--csv", args.csv)
    if args.work_dir is not None:
        plan.output("--work-dir", args.work_dir)
    plan.check()


def batches(lenses: list[str], size: int) -> list[list[str]]:
    return [lenses[i : i + size] for i in range(0, len(lenses), size)]


def ode_task(
    binary: str, lenses: list[str], options: list[str], cwd: str, threads: int, fault_dir: Optional[str], key: str
) -> tuple[str, str]:
    """Ray task: `unicac ode BATCH OPTIONS --csv TMP` in the driver's folder; returns (stdout, csv text)."""
    with tempfile.TemporaryDirectory(prefix="unicac-ray-ode-") as temp:
        csv_path = Path(temp) / "ode.csv"
        stdout = run_cli(binary, ["ode", *lenses, *options, "--csv", str(csv_path)], threads, cwd=cwd)
        csv_text = csv_path.read_text()
    fail_once(fault_dir, key)
    return stdout, csv_text


def splice_json(parts: list[str]) -> str:
    bodies = []
    for text in parts:
        if not (text.startswith(_JSON_HEAD) and text.endswith(_JSON_TAIL)):
            raise ValueError("unicac ode --json printed an unexpected layout; cannot merge its batches")
        bodies.append(text[len(_JSON_HEAD) : -len(_JSON_TAIL)])
    return _JSON_HEAD + ",\n".join(bodies) + _JSON_TAIL


def splice_rows(parts: list[str]) -> str:
    """Header lines of the first part, data rows of all: the table and the CSV have one header line."""
    lines = parts[0].splitlines(keepends=True)[:1]
    for text in parts:
        lines += text.splitlines(keepends=True)[1:]
    return "".join(lines)


def batch_key(lenses: list[str], options: list[str], json_out: bool) -> str:
    text = json.dumps([lenses, options, json_out, os.getcwd()])
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def prepare(binary: str, argv: Sequence[str]) -> tuple[str, argparse.Namespace]:
    args = parse(argv)
    check_outputs(args)
    return binary, args


def run(session, plan: tuple[str, argparse.Namespace], fault_dir: Optional[str], stdout: TextIO) -> int:
    binary, args = plan
    options = []
    if args.device:
        options += ["--device", args.device]
    if args.gpu_precision:
        options += ["--gpu-precision", args.gpu_precision]
    if args.json:
        options.append("--json")
    size = args.batch_size or max(1, math.ceil(len(args.lenses) / (4 * session.workers)))
    groups = batches(args.lenses, size)
    keys = [f"ode-{i:05d}-{batch_key(g, options, args.json)}" for i, g in enumerate(groups)]
    results: list = [None] * len(groups)
    if args.work_dir is not None:
        args.work_dir.mkdir(parents=True, exist_ok=True)
        for i, key in enumerate(keys):
            saved = args.work_dir / f"{key}.json"
            if saved.exists():
                results[i] = tuple(json.loads(saved.read_text()))
    todo = [i for i in range(len(groups)) if results[i] is None]
    calls = [
        (binary, groups[i], options, os.getcwd(), session.cpus_per_task, fault_dir, keys[i]) for i in todo
    ]
    print(
        f"ode: {len(args.lenses)} lenses in {len(groups)} batches of up to {size}, {len(calls)} to run on Ray",
        file=sys.stderr,
    )
    for i, result in zip(todo, session.map(ode_task, calls, "ode")):
        results[i] = result
        if args.work_dir is not None:
            write_text(args.work_dir / f"{keys[i]}.json", json.dumps(list(result)))
    stdouts = [r[0] for r in results]
    if args.csv is not None:
        write_text(args.csv, splice_rows([r[1] for r in results]))
        print(f"wrote {args.csv}", file=sys.stderr)
    stdout.write(splice_json(stdouts) if args.json else splice_rows(stdouts))
    stdout.flush()
    return 0
