"""`unicac-ray design`: one Ray task per specification of the grid, merged into one lens library.

The single-machine `unicac design` designs the specifications one after the other into one library and
appends each accepted lens to the manifest; lens ids are numbered per specification
(`<spec>_s001`, ...). So a library is the concatenation, in the CLI's specification order, of the
libraries each specification would make on its own. The driver asks the CLI for that order
(`--list-specs`), runs each specification as a one-cell grid into its own part library
(`OUT/.unicac-ray/design/<spec>/`, resumable by the CLI itself), and merges: lens files and search
checkpoints copied, manifest rows appended in specification order after the rows OUT already had.

Byte-for-byte: every file equals the single run's except the manifests' `elapsed_s` column, which is
wall-clock time (two single-machine runs differ there too). With `--time-budget-s T` each specification
gets T / (number of specifications), its share on one machine; budgeted runs stop by the clock and are
reproducible only up to where it stopped them (docs/design.md), on one machine as on Ray.
`--evaluations-per-spec N` (passed on unchanged: it is per specification already) stops by the work
done instead, so a budgeted Ray library equals the single machine's too.
"""

from __future__ import annotations

import argparse
import json
import shutil
import sys
import tempfile
from pathlib import Path
from typing import Optional, Sequence, TextIO

from unicac.outputs import copy_file, write_text

from .tasks import fail_once, run_cli

PARTS = Path(".unicac-ray") / "design"
DONE = ".done"
# Options the driver replaces (the specification selection) or reads; the rest go to the CLI verbatim.
_SELECTION = ["--elements", "--half-fov-deg", "--f-number", "--stop"]
_GRID = ["--grid-elements", "--grid-half-fov-deg", "--grid-f-numbers", "--grid-stops"]


def parse(argv: Sequence[str]) -> tuple[argparse.Namespace, list[str]]:
    """Splits `unicac design` arguments into what the driver needs and the rest (passed on unchanged)."""
    parser = argparse.ArgumentParser(prog="unicac-ray design", allow_abbrev=False, add_help=False)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--time-budget-s", type=float)
    parser.add_argument("--grid", action="store_true")
    parser.add_argument("--list-specs", action="store_true")
    for name in _SELECTION + _GRID:
        parser.add_argument(name)
    known, rest = parser.parse_known_args(list(argv))
    if known.list_specs:
        raise SystemExit("unicac-ray design: --list-specs is the CLI's own (run `unicac design --list-specs`)")
    return known, rest


def list_specs(binary: str, argv: Sequence[str]) -> list[dict]:
    """The specifications `unicac design ARGV` would design, in its order (validates ARGV too)."""
    text = run_cli(binary, ["design", *argv, "--list-specs"], threads=1)
    return [json.loads(line) for line in text.splitlines() if line.strip()]


def cell_args(rest: Sequence[str], spec: dict, part: Path, budget_s: Optional[float]) -> list[str]:
    """`unicac design` arguments designing exactly `spec` into `part`."""
    args = list(rest) + [
        "--grid",
        "--grid-elements", str(spec["grid_elements"]),
        "--grid-half-fov-deg", repr(float(spec["grid_half_fov_deg"])),
        "--grid-f-numbers", repr(float(spec["grid_f_numbers"])),
        "--grid-stops", spec["grid_stops"],
        "--out", str(part),
    ]  # fmt: skip
    if budget_s is not None:
        args += ["--time-budget-s", repr(budget_s)]
    return args


def design_task(binary: str, args: list[str], part: str, threads: int, fault_dir: Optional[str]) -> str:
    """Ray task: design one specification into its part library (resumed if a try was killed)."""
    if not is_done(Path(part), args):
        run_cli(binary, ["design", *args], threads)
        fail_once(fault_dir, "design-" + Path(part).name)
        write_text(Path(part) / DONE, json.dumps(args) + "\n")
    return part


def is_done(part: Path, args: list[str]) -> bool:
    """Whether `part` was finished with exactly these arguments (a rerun with others resumes it)."""
    marker = part / DONE
    return marker.exists() and marker.read_text() == json.dumps(args) + "\n"


class Manifest:
    """A library's manifest as the CLI writes it: JSON lines and CSV lines, row for row."""

    def __init__(self, directory: Path):
        self.directory = directory
        jsonl, csv = directory / "manifest.jsonl", directory / "manifest.csv"
        self.exists = jsonl.exists()
        self.json_lines = [l for l in jsonl.read_text().splitlines() if l.strip()] if self.exists else []
        csv_lines = csv.read_text().splitlines() if csv.exists() else []
        self.header = csv_lines[0] if csv_lines else None
        self.csv_lines = csv_lines[1:]
        if len(self.csv_lines) != len(self.json_lines):
            raise ValueError(
                f"{directory}: manifest.csv has {len(self.csv_lines)} rows, manifest.jsonl {len(self.json_lines)}"
            )
        try:
            self.rows = [json.loads(l) for l in self.json_lines]
        except json.JSONDecodeError as error:
            raise ValueError(f"{jsonl}: a row is not valid JSON ({error.msg})") from error

    def indices_for(self, slug: str) -> list[int]:
        return [i for i, row in enumerate(self.rows) if row["spec"] == slug]

    def write(self, json_lines: list[str], csv_lines: list[str], header: str) -> None:
        # The CSV first: a reader of manifest.jsonl (the CLI's resume) then never lists a row missing in the CSV.
        write_text(self.directory / "manifest.csv", "".join(f"{l}\n" for l in [header, *csv_lines]))
        write_text(self.directory / "manifest.jsonl", "".join(f"{l}\n" for l in json_lines))


def seed_part(out: Path, library: Manifest, slug: str, part: Path) -> None:
    """Creates the part library of `slug` holding what OUT already has of it, so the CLI resumes there."""
    if part.exists():
        return
    staging = Path(tempfile.mkdtemp(prefix=f".{slug}.", dir=part.parent))
    (staging / "lenses").mkdir()
    (staging / "state").mkdir()
    indices = library.indices_for(slug)
    if indices:
        for i in indices:
            lens_id = library.rows[i]["id"]
            for file in (out / "lenses").glob(f"{lens_id}.*"):
                shutil.copyfile(file, staging / "lenses" / file.name)
        Manifest(staging).write(
            [library.json_lines[i] for i in indices], [library.csv_lines[i] for i in indices], library.header or ""
        )
    state = out / "state" / f"{slug}.json"
    if state.exists():
        shutil.copyfile(state, staging / "state" / state.name)
    staging.rename(part)


def merge(out: Path, specs: list[dict]) -> Manifest:
    """Copies every part's lenses and checkpoints into OUT and writes the manifest as the CLI would have:
    OUT's rows in their order, less the ones a part dropped (the CLI keeps the `count` best and removes a
    replaced lens), then each part's new rows in specification order."""
    library = Manifest(out)
    parts = [Manifest(out / PARTS / spec["slug"]) for spec in specs]
    slugs = {spec["slug"] for spec in specs}
    listed = {row["id"] for part in parts for row in part.rows}
    dropped = [r["id"] for r in library.rows if r["spec"] in slugs and r["id"] not in listed]
    kept = [i for i, r in enumerate(library.rows) if r["id"] not in dropped]
    json_lines = [library.json_lines[i] for i in kept]
    csv_lines = [library.csv_lines[i] for i in kept]
    known = {library.rows[i]["id"] for i in kept}
    header = library.header
    for spec, part in zip(specs, parts):
        for sub in ("lenses", "state"):
            for file in sorted((part.directory / sub).glob("*")):
                if not file.name.startswith("."):
                    copy_file(file, out / sub / file.name)
        header = header or part.header
        for i, row in enumerate(part.rows):
            if row["id"] not in known:
                json_lines.append(part.json_lines[i])
                csv_lines.append(part.csv_lines[i])
                known.add(row["id"])
    if header is not None and (library.exists or json_lines):
        library.write(json_lines, csv_lines, header)
    # Files of dropped lenses go after the manifest no longer lists them (as the CLI removes them).
    for lens_id in dropped:
        for extension in ("json", "zmx", "png", "report.json"):
            (out / "lenses" / f"{lens_id}.{extension}").unlink(missing_ok=True)
    return Manifest(out)


class Plan:
    """A checked `unicac-ray design` request: the CLI's specifications in its order, before Ray starts."""

    def __init__(self, binary: str, argv: Sequence[str]):
        self.binary = binary
        self.known, self.rest = parse(argv)
        self.specs = list_specs(binary, argv)


def prepare(binary: str, argv: Sequence[str]) -> Plan:
    return Plan(binary, argv)


def run(session, plan: Plan, fault_dir: Optional[str], stdout: TextIO) -> int:
    binary, known, rest, specs = plan.binary, plan.known, plan.rest, plan.specs
    out: Path = known.out
    for sub in ("lenses", "state", PARTS):
        (out / sub).mkdir(parents=True, exist_ok=True)
    library = Manifest(out)
    budget = None if known.time_budget_s is None else known.time_budget_s / max(len(specs), 1)
    calls = []
    for spec in specs:
        part = out / PARTS / spec["slug"]
        seed_part(out, library, spec["slug"], part)
        args = cell_args(rest, spec, part, budget)
        if not is_done(part, args):
            calls.append((binary, args, str(part), session.cpus_per_task, fault_dir))
    print(
        f"design: {len(specs)} specifications, {len(specs) - len(calls)} already done, "
        f"{len(calls)} to run on Ray",
        file=sys.stderr,
    )
    session.map(design_task, calls, "design")
    merged = merge(out, specs)
    print(f"{len(merged.rows)} lenses in {out}; manifest: {out / 'manifest.csv'}", file=sys.stderr)
    if known.json:
        stdout.write(json.dumps({"specs": [s["slug"] for s in specs], "lenses": merged.rows}, indent=2) + "\n")
    return 0
