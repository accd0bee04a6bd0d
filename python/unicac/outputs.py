"""Output files of the Python tools (`unicac-train`, `unicac-ray`), by the rule every Rust command
follows: the output-file policy of ``crates/unicac-io``, called through ``unicac._native`` (one
implementation for both languages; docs/reliability.md).

* :class:`OutputPlan`: a run's inputs, input folders and outputs, checked together before any work:
  an output is never an input (compared by file identity), never inside an input folder, never
  another output's path;
* :func:`require_extension`: an output's extension names the format written;
* :func:`write_bytes`, :func:`write_with`, :func:`write_text`, :func:`copy_file`: a file appears
  complete or not at all (a dot-named temporary sibling, synced, renamed over the target);
* :func:`clean_stale_temporaries`: the temporaries of killed writers are removed by the next run.

Refusals raise :class:`unicac.OutputError`; failed writes raise ``OSError`` with ``filename`` set.
"""

from __future__ import annotations

import io
import os
from pathlib import Path
from typing import Any, BinaryIO, Callable, Union

from ._native import OutputError, clean_stale_temporaries, require_extension
from ._native import check_outputs as _check_outputs
from ._native import write_atomically as _write_atomically

PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "OutputError",
    "OutputPlan",
    "clean_stale_temporaries",
    "copy_file",
    "require_extension",
    "write_bytes",
    "write_text",
    "write_with",
]


class OutputPlan:
    """The inputs and outputs of one run (``unicac_io::OutputPlan``), checked by :meth:`check`."""

    def __init__(self) -> None:
        self._inputs: list[str] = []
        self._folders: list[str] = []
        self._outputs: list[tuple[str, str]] = []

    def input(self, path: PathLike) -> "OutputPlan":
        """A file the run reads."""
        self._inputs.append(os.fspath(path))
        return self

    def input_folder(self, path: PathLike) -> "OutputPlan":
        """A folder the run reads as a whole (a dataset, a run folder): no output may lie inside it."""
        self._folders.append(os.fspath(path))
        return self

    def output(self, flag: str, path: PathLike) -> "OutputPlan":
        """A file (or folder) the run writes, with the flag that named it, for messages."""
        self._outputs.append((flag, os.fspath(path)))
        return self

    def check(self) -> None:
        """Raises :class:`OutputError` naming the flag and the paths of the first conflict."""
        _check_outputs(self._outputs, self._inputs, self._folders)


def write_bytes(path: PathLike, data: bytes) -> None:
    """Writes ``data`` to ``path`` atomically, creating its folder."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    _write_atomically(path, data)


def write_text(path: PathLike, text: str) -> None:
    write_bytes(path, text.encode("utf-8"))


def write_with(path: PathLike, fill: Callable[[BinaryIO], Any]) -> None:
    """Writes what ``fill`` writes into a binary file object to ``path`` atomically. The content is
    collected in memory first, so a ``fill`` that fails leaves ``path`` as it was."""
    buffer = io.BytesIO()
    fill(buffer)
    write_bytes(path, buffer.getvalue())


def copy_file(source: PathLike, target: PathLike) -> None:
    """Copies ``source`` to ``target`` atomically; a target already equal is left untouched."""
    data = Path(source).read_bytes()
    target = Path(target)
    if target.is_file() and target.stat().st_size == len(data) and target.read_bytes() == data:
        return
    write_bytes(target, data)
