"""Pictures in docs/ that are made from the code stay current with it."""

from __future__ import annotations

import subprocess
import sys


def test_architecture_picture_is_current(repo):
    result = subprocess.run(
        [sys.executable, str(repo / "scripts" / "architecture_svg.py"), "--check"],
        capture_output=True, text=True,
    )
    assert result.returncode == 0, result.stdout + result.stderr
