"""`unicac-ray` (docs/scale.md): the Ray-built results equal the single-process CLI's byte for byte, a
task killed once is retried with the result unchanged, and a driver resumes a half-finished folder.

One local Ray (2 CPUs) serves the whole module: its start-up is the slow part on 2 shared cores."""

from __future__ import annotations

import json
import re
import subprocess
from pathlib import Path

import pytest

ray = pytest.importorskip("ray")

from unicac.scale import cli as ray_cli  # noqa: E402
from unicac.scale.tasks import FAULT_ENV  # noqa: E402

from conftest import REPO, _cli_path  # noqa: E402

# Three lenses, two batches: the ODE takes 0.3-0.4 s a lens on an idle core (docs/performance.md).
ODE_LENSES = ["builtin:cooke_triplet", "lenses/double_gauss.json", "lenses/singlet.json"]
# A two-spec grid of singlets: each spec designs in a few seconds without a time budget, so the run is
# deterministic (same seed, same lenses) and can be compared byte for byte.
DESIGN_GRID = [
    "--grid", "--grid-elements", "1", "--grid-half-fov-deg", "20", "--grid-f-numbers", "4",
    "--count", "1", "--seed", "2",
]  # fmt: skip


@pytest.fixture(scope="module")
def binary() -> str:
    path = _cli_path()
    if path is None or not path.exists():
        pytest.skip("the unicac CLI is not built (cargo build -p unicac-cli, or set UNICAC_BIN)")
    return str(path)


@pytest.fixture(scope="module")
def local_ray():
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    yield
    ray.shutdown()


def run_cli(binary: str, *args: str) -> str:
    done = subprocess.run([binary, *args], capture_output=True, text=True, cwd=REPO, check=False)
    assert done.returncode == 0, done.stderr
    return done.stdout


def run_driver(binary: str, capsys, monkeypatch, *args: str) -> str:
    monkeypatch.chdir(REPO)
    capsys.readouterr()
    status = ray_cli.main([*args, "--workers", "2", "--unicac-bin", binary])
    captured = capsys.readouterr()
    assert status == 0, captured.err
    return captured.out


def test_ray_ode_equals_the_cli_with_every_task_killed_once(binary, local_ray, tmp_path, capsys, monkeypatch):
    expected_json = run_cli(binary, "ode", *ODE_LENSES, "--json", "--csv", str(tmp_path / "cli.csv"))
    faults = tmp_path / "faults"
    monkeypatch.setenv(FAULT_ENV, str(faults))
    got_json = run_driver(
        binary, capsys, monkeypatch, "ode", *ODE_LENSES, "--json", "--csv", str(tmp_path / "ray.csv"), "--batch-size", "2"
    )
    # Two batches (2 + 1 lenses), each killed once after its work and retried by Ray.
    assert len(list(faults.iterdir())) == 2
    # Equal but for the per-stage wall-clock seconds (`times`), which differ between any two runs.
    assert mask_times(got_json) == mask_times(expected_json)
    assert got_json.count('"times"') == len(ODE_LENSES)
    assert (tmp_path / "ray.csv").read_bytes() == (tmp_path / "cli.csv").read_bytes()


def test_ode_outputs_splice_as_the_cli_prints_them():
    from unicac.scale.ode import splice_json, splice_rows

    table = "lens   ODE\na  0.7\nb  0.6\nc  0.5\n"
    head, *rows = table.splitlines(keepends=True)
    assert splice_rows([head + rows[0] + rows[1], head + rows[2]]) == table
    one = '{\n  "lenses": [\n    {\n      "lens": "a"\n    }\n  ]\n}\n'
    two = '{\n  "lenses": [\n    {\n      "lens": "b"\n    },\n    {\n      "lens": "c"\n    }\n  ]\n}\n'
    merged = splice_json([one, two])
    assert [l["lens"] for l in json.loads(merged)["lenses"]] == ["a", "b", "c"]
    assert merged == json.dumps({"lenses": [{"lens": x} for x in "abc"]}, indent=2) + "\n"
    with pytest.raises(ValueError, match="unexpected layout"):
        splice_json(['{"lenses": []}'])


def mask_times(text: str) -> str:
    return re.sub(r'"times": \{[^}]*\}', '"times": T', text)


def library_files(directory: Path) -> dict[str, bytes]:
    """Every file of a lens library but the driver's own parts folder; the manifests' `elapsed_s` (wall-clock
    seconds, different between any two runs) replaced by a placeholder."""
    files = {}
    for path in sorted(directory.rglob("*")):
        relative = path.relative_to(directory).as_posix()
        if path.is_dir() or relative.startswith(".unicac-ray") or relative.startswith("state/"):
            continue
        data = path.read_bytes()
        if relative == "manifest.jsonl":
            data = re.sub(rb'"elapsed_s":[^,}]*', b'"elapsed_s":T', data)
        elif relative == "manifest.csv":
            lines = data.decode().splitlines()
            column = lines[0].split(",").index("elapsed_s")
            masked = [lines[0]] + [",".join(f[:column] + ["T"] + f[column + 1 :]) for f in (l.split(",") for l in lines[1:])]
            data = "\n".join(masked).encode()
        files[relative] = data
    return files


def test_ray_design_equals_the_cli_and_resumes_a_half_finished_library(binary, local_ray, tmp_path, capsys, monkeypatch):
    both = [*DESIGN_GRID, "--grid-stops", "front,back"]
    reference = tmp_path / "cli"
    run_cli(binary, "design", *both, "--out", str(reference))
    expected = library_files(reference)
    assert sum(name.endswith(".zmx") for name in expected) == 2, sorted(expected)

    # A folder the single-machine CLI had started (the front-stop spec only), finished on Ray with every
    # task killed once.
    half = tmp_path / "half"
    run_cli(binary, "design", *DESIGN_GRID, "--grid-stops", "front", "--out", str(half))
    monkeypatch.setenv(FAULT_ENV, str(tmp_path / "faults"))
    run_driver(binary, capsys, monkeypatch, "design", *both, "--out", str(half))
    assert len(list((tmp_path / "faults").iterdir())) == 2
    assert library_files(half) == expected

    # A fresh Ray run, and a rerun of it: the finished parts are not redone and nothing changes.
    monkeypatch.delenv(FAULT_ENV)
    fresh = tmp_path / "ray"
    run_driver(binary, capsys, monkeypatch, "design", *both, "--out", str(fresh))
    assert library_files(fresh) == expected
    manifest = (fresh / "manifest.jsonl").read_bytes()
    run_driver(binary, capsys, monkeypatch, "design", *both, "--out", str(fresh))
    assert (fresh / "manifest.jsonl").read_bytes() == manifest


def test_ray_driver_rejects_bad_arguments_before_starting_ray(binary, capsys):
    with pytest.raises(SystemExit):
        ray_cli.main(["ode", "builtin:cooke_triplet", "--plot", "x.png", "--unicac-bin", binary])
    assert "--plot" in capsys.readouterr().err
    status = ray_cli.main(["design", "--elements", "9", "--half-fov-deg", "20", "--f-number", "4",
                           "--stop", "front", "--out", "/nonexistent/x", "--unicac-bin", binary])
    assert status == 1
    assert "elements" in capsys.readouterr().err
    assert ray_cli.main(["render", "--unicac-bin", binary]) == 2


# Four built-in lenses: the fewest a 2-level dataset with one validation lens accepts.
DATASET_ARGS = [
    "--lenses", "builtin:achromat", "builtin:cooke_triplet", "builtin:double_gauss", "builtin:petzval",
    "--images", "dead-leaves:2:80x60", "--test-images", "dead-leaves:1", "--frame", "64x48",
    "--levels", "2", "--test-lenses-per-level", "1", "--val-lenses", "1", "--pairs-per-lens", "2",
    "--crop", "32x24", "--seed", "3",
]  # fmt: skip


def folder_files(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_ray_dataset_equals_the_cli_with_every_task_killed_once(binary, local_ray, tmp_path, capsys, monkeypatch):
    reference = tmp_path / "cli"
    run_cli(binary, "dataset", "build", *DATASET_ARGS, "--out", str(reference))
    expected = {k: v for k, v in folder_files(reference).items() if not k.startswith(".")}
    assert any(name.startswith("test/lq/") for name in expected)

    monkeypatch.setenv(FAULT_ENV, str(tmp_path / "faults"))
    out = tmp_path / "ray"
    summary = run_driver(binary, capsys, monkeypatch, "dataset", "build", *DATASET_ARGS, "--shards", "3",
                         "--out", str(out))
    assert "built" in summary or "complete" in summary, summary
    assert len(list((tmp_path / "faults").iterdir())) >= 2   # shards 2 and 3 ran as tasks, each killed once
    got = {k: v for k, v in folder_files(out).items() if not k.startswith(".")}
    assert sorted(got) == sorted(expected)
    for name, data in expected.items():
        assert got[name] == data, name


# 130 units: three chunk files (64 + 64 + 2) over three shards; a coarse pupil keeps it to seconds.
TOLERANCE_ARGS = [
    "tolerance", "builtin:cooke_triplet", "--spec", "docs/tolerancing/textbook.json",
    "--trials", "130", "--seed", "3", "--pupil-grid", "16",
]  # fmt: skip


def test_ray_tolerance_equals_the_cli_with_every_task_killed_once(binary, local_ray, tmp_path, capsys, monkeypatch):
    reference = tmp_path / "cli"
    expected_table = run_cli(binary, *TOLERANCE_ARGS, "--out", str(reference))
    monkeypatch.setenv(FAULT_ENV, str(tmp_path / "faults"))
    out = tmp_path / "ray"
    table = run_driver(binary, capsys, monkeypatch, *TOLERANCE_ARGS, "--shards", "3", "--out", str(out))
    assert table == expected_table and "rms_mean_um" in table
    assert len(list((tmp_path / "faults").iterdir())) == 3   # every shard ran as a task, each killed once
    assert folder_files(out) == folder_files(reference)
    assert len(list((out / "trials").iterdir())) == 3
