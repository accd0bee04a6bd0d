"""What a Ray task does: run the `unicac` CLI on its part of the work, and the fault-injection hook.

These are plain functions (Ray wraps them in `session.Session.map`), so they can be called and tested
without Ray. A task is idempotent: it writes only inside its own part folder, atomically, and a rerun
(Ray's retry after a killed worker, or a restarted driver) resumes or redoes the same work.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Optional, Sequence, TextIO

# Ray retries a task whose worker died this many times (a CLI error is not retried: it would fail again).
MAX_RETRIES = 3
# Environment variable naming a folder: each task kills its own worker once, mid-task (after its work,
# before reporting it done), leaving a marker file there so that the retry runs through. Tests only.
FAULT_ENV = "UNICAC_RAY_FAULT_ONCE_DIR"


class CliError(RuntimeError):
    """The `unicac` CLI refused the work (bad input): not retried, its message shown to the user."""


def find_cli(explicit: Optional[str] = None) -> str:
    """The `unicac` binary: --unicac-bin, else $UNICAC_BIN, else `unicac` on PATH."""
    for candidate in (explicit, os.environ.get("UNICAC_BIN")):
        if candidate:
            if not (Path(candidate).is_file() and os.access(candidate, os.X_OK)):
                raise CliError(f"--unicac-bin / UNICAC_BIN {candidate}: not an executable file")
            return str(Path(candidate).resolve())
    found = shutil.which("unicac")
    if found is None:
        raise CliError(
            "the unicac CLI is not on PATH: install it (cargo install --path crates/unicac-cli) "
            "or give --unicac-bin / UNICAC_BIN"
        )
    return found


def run_cli(binary: str, args: Sequence[str], threads: int, cwd: Optional[str] = None) -> str:
    """Runs `unicac ARGS` with `threads` worker threads; returns stdout, raises CliError on failure."""
    env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
    done = subprocess.run(
        [binary, *args], capture_output=True, text=True, cwd=cwd, env=env, check=False
    )
    if done.returncode != 0:
        raise CliError(cli_failure(args[0] if args else "", done.returncode, done.stderr))
    return done.stdout


def cli_failure(command: str, returncode: int, stderr: str) -> str:
    """One line: the CLI's own error (the last line it printed; progress lines come before it), not
    the arguments the driver added (--shard, temporary files)."""
    if returncode < 0:
        return f"unicac {command} was killed by signal {-returncode}"
    lines = [line.strip() for line in stderr.splitlines() if line.strip()]
    message = lines[-1] if lines else f"exit code {returncode}, no message"
    return f"unicac {command}: {message.removeprefix('error: ')}"



def fail_once(fault_dir: Optional[str], key: str) -> None:
    """The fault-injection hook: the first time `key` gets here, kill this worker process."""
    if not fault_dir:
        return
    marker = Path(fault_dir) / key
    if marker.exists():
        return
    marker.parent.mkdir(parents=True, exist_ok=True)
    marker.write_text("killed once\n")
    os._exit(1)  # a dead worker, not an exception: Ray's retry path for lost tasks


def shard_task(
    binary: str, command: list[str], args: list[str], index: int, shards: int, threads: int, fault_dir: Optional[str]
) -> int:
    """Ray task: `unicac COMMAND ARGS --shard I/N` (the CLI resumes: the parts already there are skipped)."""
    run_cli(binary, [*command, *args, "--shard", f"{index}/{shards}"], threads)
    fail_once(fault_dir, f"{'-'.join(command)}-shard-{index}-of-{shards}")
    return index


def run_sharded(
    session,
    binary: str,
    command: list[str],
    args: list[str],
    shard_args: list[str],
    shards: Optional[int],
    fault_dir: Optional[str],
    why_first: str,
    stdout: TextIO,
) -> int:
    """`shards` parts (default four per worker): shard 1/N alone (`why_first` says what it does that the
    others need), shards 2..N as tasks (`args` + `shard_args`), then the unsharded command on the driver,
    which finds every part present, writes what only the whole run writes and prints the CLI's own
    output to `stdout`."""
    count = shards or min(MAX_SHARDS, 4 * session.workers)
    name = " ".join(command)
    print(f"{name}: {count} shards; shard 1 {why_first} first", file=sys.stderr)
    threads = session.cpus_per_task
    calls = [(binary, command, [*args, *shard_args], i, count, threads, fault_dir) for i in range(1, count + 1)]
    session.map(shard_task, calls[:1], f"{name} shard 1 ({why_first})")
    session.map(shard_task, calls[1:], f"{name} shards")
    stdout.write(run_cli(binary, [*command, *args], threads))
    stdout.flush()
    return 0


#: Most shards of a sharded stage (the CLI's own limit, `--shard I/N`).
MAX_SHARDS = 10_000


def parse_shards(parser, argv: Sequence[str], set_by_driver: Sequence[str] = ()) -> tuple[Optional[int], list[str]]:
    """The driver's `--shards K` (1..MAX_SHARDS, None: the default) and the stage's own arguments; `--shard`
    and the flags in `set_by_driver` are the driver's to set and are refused."""
    parser.add_argument("--shard")
    for flag in set_by_driver:
        parser.add_argument(flag)
    parser.add_argument("--shards", type=int, help=f"shards (1 to {MAX_SHARDS}; default 4 per worker)")
    known, rest = parser.parse_known_args(list(argv))
    taken = ["--shard", *set_by_driver]
    if any(getattr(known, flag.lstrip("-").replace("-", "_")) for flag in taken):
        verb = "is" if len(taken) == 1 else "are"
        parser.error(f"{' and '.join(taken)} {verb} set by the driver (--shards, --cpus-per-task)")
    if known.shards is not None and not 1 <= known.shards <= MAX_SHARDS:
        parser.error(f"--shards {known.shards}: must be 1 to {MAX_SHARDS}")
    return known.shards, rest

