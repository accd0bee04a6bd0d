"""Shared fixtures: the repository, the `unicac` CLI the results are compared with, lenses."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any

import pytest

import unicac

REPO = Path(__file__).resolve().parents[2]


def _cli_path() -> Path | None:
    explicit = os.environ.get("UNICAC_BIN")
    if explicit:
        return Path(explicit)
    candidates = [REPO / "target" / "debug" / "unicac", REPO / "target" / "release" / "unicac"]
    existing = [p for p in candidates if p.exists()]
    # The newest build is the one that matches the sources best.
    return max(existing, key=lambda p: p.stat().st_mtime) if existing else None


@pytest.fixture(scope="session")
def repo() -> Path:
    return REPO


@pytest.fixture(scope="session")
def cli():
    """Runs the `unicac` CLI; returns parsed JSON when `--json` is among the arguments."""
    path = _cli_path()
    if path is None or not path.exists():
        pytest.skip("the unicac CLI is not built (cargo build -p unicac-cli, or set UNICAC_BIN)")

    def run(*args: str) -> Any:
        done = subprocess.run([str(path), *args], capture_output=True, text=True, cwd=REPO)
        if done.returncode != 0:
            raise AssertionError(f"unicac {' '.join(args)} failed: {done.stderr}")
        return json.loads(done.stdout) if "--json" in args else done.stdout

    return run


@pytest.fixture(scope="session")
def cooke() -> unicac.Lens:
    return unicac.load_lens("builtin:cooke_triplet")
