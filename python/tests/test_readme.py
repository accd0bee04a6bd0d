"""The Python examples of README.md and python/README.md run as written."""

from __future__ import annotations

import re

import pytest

BLOCK = re.compile(r"```python\n(.*?)```", re.DOTALL)


def _blocks(path):
    return BLOCK.findall(path.read_text())


@pytest.mark.parametrize("readme", ["README.md", "python/README.md"])
def test_readme_python_examples_run(repo, tmp_path, monkeypatch, readme):
    blocks = _blocks(repo / readme)
    assert blocks, f"{readme} has no python example"
    monkeypatch.chdir(tmp_path)  # examples may write files
    namespace: dict = {}
    for block in blocks:  # blocks of one README share a namespace, like one session
        exec(compile(block, f"{readme} example", "exec"), namespace)
