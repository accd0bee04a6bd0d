"""The ``unicac`` command of the Python package: the Rust CLI itself, run in this process through the
native module (``unicac._native.main``), so ``pip install`` gives the same command as ``cargo build``."""

from __future__ import annotations

import sys

from . import _native


def main(argv: list[str] | None = None) -> int:
    """Runs ``unicac ARGS...`` (``argv`` defaults to ``sys.argv[1:]``) and returns its exit code."""
    args = sys.argv[1:] if argv is None else argv
    return _native.main(["unicac", *args])
