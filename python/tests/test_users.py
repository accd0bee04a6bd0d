"""The `unicac` command the package installs (`python -m unicac`, the `unicac.cli:main` entry point) is
the Rust CLI: same output, same exit codes. And `unicac.ode(frame_px=...)` grades as `unicac ode --frame`."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import unicac


def _module(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "unicac", *args], capture_output=True, text=True, timeout=120)


def test_python_m_unicac_prints_the_version_of_the_package():
    done = _module("--version")
    assert done.returncode == 0, done.stderr
    assert done.stdout == f"unicac {unicac.__version__}\n"


def test_python_m_unicac_gives_the_binarys_output_and_exit_codes(cli):
    done = _module("lens", "info", "builtin:cooke_triplet", "--json")
    assert done.returncode == 0, done.stderr
    assert json.loads(done.stdout) == cli("lens", "info", "builtin:cooke_triplet", "--json")
    # An error: one line naming the file, rc 1, nothing on stdout.
    missing = _module("lens", "info", "no-such-lens.json")
    assert missing.returncode == 1
    assert missing.stdout == ""
    assert missing.stderr.startswith("error: ") and "no-such-lens.json" in missing.stderr
    # A usage error: clap's message, rc 2.
    usage = _module("lens", "info")
    assert usage.returncode == 2
    assert "Usage" in usage.stderr


def test_the_entry_point_is_declared_and_runs(repo):
    tomllib = pytest.importorskip("tomllib")
    scripts = tomllib.loads((repo / "python" / "pyproject.toml").read_text())["project"]["scripts"]
    assert scripts["unicac"] == "unicac.cli:main"
    from unicac.cli import main

    assert main(["lens", "list"]) == 0


def test_the_command_stops_quietly_when_its_reader_goes_away():
    # `unicac lens info ... | head -c 1` as a shell runs it: the writer dies of SIGPIPE, no traceback.
    script = f"{sys.executable} -m unicac chart dead-leaves --size 64x48 --out /dev/stdout | head -c 1 >/dev/null"
    done = subprocess.run(["bash", "-o", "pipefail", "-c", script], capture_output=True, text=True, timeout=120)
    assert "Traceback" not in done.stderr and "panicked" not in done.stderr, done.stderr


def test_ode_on_a_frame_matches_the_cli(cli, cooke):
    expected = cli("ode", "builtin:cooke_triplet", "--frame", "64x48", "--pixel-um", "1.5", "--device", "cpu", "--json")
    graded = unicac.ode(cooke, frame_px=(64, 48), pixel_um=1.5)
    for key in ("ode", "oiq", "u_s", "u_c", "rms_radius_um", "pixel_um"):
        assert graded[key] == expected["lenses"][0][key], key
    assert graded["pixel_um"] == 1.5
    with pytest.raises(ValueError, match="pixel_um"):
        unicac.ode(cooke, pixel_um=2.0)
    with pytest.raises(ValueError, match="pixel_um"):
        unicac.ode(cooke, frame_px=(64, 48), pixel_um=-1.0)
