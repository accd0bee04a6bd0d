"""`unicac-ray`: the `unicac` CLI's embarrassingly parallel commands spread over a Ray cluster.

    unicac-ray design  DESIGN-ARGS  [--address A] [--workers N] [--cpus-per-task C] [--unicac-bin PATH]
    unicac-ray ode     ODE-ARGS     [...]
    unicac-ray dataset build DATASET-ARGS [...]
    unicac-ray tolerance TOLERANCE-ARGS [--shards K] [...]

The stage arguments are the CLI's own (`unicac design --help`, ...). --address: a running Ray cluster
(`ray start --head` prints it; `auto` finds the local one); default: a local Ray started for the run with
N x C CPUs. --workers N: tasks in flight at once (1-4096). --cpus-per-task C: CPUs Ray reserves for each
task, also the CLI's thread count (1-256). Paths (inputs, --out) must be the same on every node (a
shared filesystem); the `unicac` binary too (--unicac-bin, $UNICAC_BIN or PATH). docs/scale.md.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys
from typing import Optional, Sequence

STAGES = ("design", "ode", "dataset", "tolerance")


def _driver_options(argv: Sequence[str]) -> tuple[argparse.Namespace, list[str]]:
    parser = argparse.ArgumentParser(add_help=False, allow_abbrev=False)
    parser.add_argument("--address")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--cpus-per-task", type=int, default=1)
    parser.add_argument("--unicac-bin")
    return parser.parse_known_args(list(argv))


def main(argv: Optional[Sequence[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] in ("-h", "--help") or argv[0] not in STAGES:
        print(__doc__, file=sys.stderr)
        if argv and argv[0] not in ("-h", "--help"):
            print(f"unicac-ray: unknown stage {argv[0]!r} (one of {', '.join(STAGES)})", file=sys.stderr)
            return 2
        return 0 if argv else 2
    stage, rest = argv[0], argv[1:]
    options, stage_args = _driver_options(rest)
    from unicac import UnicacError

    from .tasks import FAULT_ENV, CliError, find_cli

    try:
        binary = find_cli(options.unicac_bin)
        stage_module = importlib.import_module(f"{__package__}.{stage}")
        plan = stage_module.prepare(binary, stage_args)  # argument and output errors before Ray starts
        # Imported here so that `unicac-ray --help` and the argument checks work without Ray.
        try:
            from . import session as session_module
        except ImportError as error:
            print(f'unicac-ray: Ray is not installed ({error}); pip install "unicac[ray]"', file=sys.stderr)
            return 1
        fault_dir = os.environ.get(FAULT_ENV)
        # Ray prints its own notices (a worker that died, ...) on stdout: while it runs, stdout is stderr,
        # and the stage writes its results to the real stdout.
        results = sys.stdout
        with contextlib.redirect_stdout(sys.stderr):
            with session_module.Session(options.address, options.workers, options.cpus_per_task) as session:
                return stage_module.run(session, plan, fault_dir, results)
    except (CliError, UnicacError, ValueError) as error:
        print(f"unicac-ray {stage}: {error}", file=sys.stderr)
        return 1
    except OSError as error:
        where = f"{error.filename}: {error.strerror}" if error.filename is not None and error.strerror else str(error)
        print(f"unicac-ray {stage}: {where}", file=sys.stderr)
        return 1
    except Exception as error:  # a task's CLI error arrives wrapped by Ray
        cause = getattr(error, "cause", None)
        if isinstance(cause, CliError):
            print(f"unicac-ray {stage}: {cause}", file=sys.stderr)
            return 1
        raise


if __name__ == "__main__":
    sys.exit(main())
