"""The Python tools under hostile input (issue 28, docs/reliability.md): the output-file policy shared
with the Rust commands, numbers that are not finite, and user errors as one line with exit code 1.

Each case is a regression test of a defect found by trying the tools as a careless user would. Tiny
datasets (fake_dataset.py) and a few iterations: the file runs in well under a minute on 2 cores."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import unicac
from fake_dataset import make_dataset
from unicac.outputs import OutputPlan, copy_file, write_bytes, write_with

# -- the output-file policy (unicac-io through unicac._native) -------------------------------------


def test_the_python_policy_is_the_rust_one(tmp_path):
    """The messages are unicac_io's own (crates/unicac-io/src/plan.rs tests the same strings)."""
    (tmp_path / "sub").mkdir()
    source = tmp_path / "a.png"
    source.write_bytes(b"x")
    with pytest.raises(unicac.OutputError, match="--out .*would overwrite the input"):
        OutputPlan().input(source).output("--out", tmp_path / "sub" / ".." / "a.png").check()
    os.link(source, tmp_path / "hard.png")
    with pytest.raises(unicac.OutputError):
        OutputPlan().input(source).output("--plot", tmp_path / "hard.png").check()
    dataset = tmp_path / "dataset"
    (dataset / "test").mkdir(parents=True)
    with pytest.raises(unicac.OutputError, match="lies inside the input folder"):
        OutputPlan().input_folder(dataset).output("--out", dataset / "test" / "new" / "r.onnx").check()
    OutputPlan().input_folder(dataset).output("--out", tmp_path / "dataset-report").check()
    with pytest.raises(unicac.OutputError, match="same file"):
        OutputPlan().output("--csv", tmp_path / "o" / "a.csv").output("--csv", tmp_path / "o" / "." / "a.csv").check()
    with pytest.raises(unicac.OutputError) as refused:
        unicac.require_extension("--out", "k.png", ["exr"])
    assert str(refused.value) == "--out k.png: the extension must be .exr (the format written)"
    assert unicac.require_extension("--out", "m.ONNX", ["onnx"]) == "onnx"
    assert isinstance(refused.value, unicac.UnicacError)


def test_python_writes_are_atomic_and_clean_up_after_killed_writers(tmp_path):
    target = tmp_path / "out" / "a.bin"
    write_bytes(target, b"first")
    assert target.read_bytes() == b"first"
    assert oct(target.stat().st_mode & 0o777) == oct(0o666 & ~_umask())

    def failing(handle):
        handle.write(b"half")
        raise RuntimeError("encoder failed")

    with pytest.raises(RuntimeError):
        write_with(target, failing)
    assert target.read_bytes() == b"first" and sorted(os.listdir(target.parent)) == ["a.bin"]
    with pytest.raises(FileNotFoundError) as missing:
        unicac.write_atomically(tmp_path / "absent" / "x.bin", b"x")
    assert missing.value.filename == str(tmp_path / "absent" / "x.bin") and missing.value.strerror
    copy_file(target, tmp_path / "copy.bin")
    assert (tmp_path / "copy.bin").read_bytes() == b"first"
    # A process id above the kernel's maximum (4194304) is never alive: a killed writer's debris.
    dead = target.parent / ".a.bin.tmp-4294967-0.bin"
    dead.write_bytes(b"partial")
    assert [Path(p) for p in unicac.clean_stale_temporaries(target.parent)] == [dead]


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


# -- unicac.dataset: manifests that do not match dataset.json ---------------------------------------


def test_a_damaged_pairs_manifest_is_named_not_half_read(tmp_path):
    from unicac.dataset import DatasetFolder, DatasetFolderError

    root = make_dataset(tmp_path / "ds", pairs_per_split=2, psf=False)
    pairs = (root / "pairs.jsonl").read_text().splitlines(keepends=True)
    (root / "pairs.jsonl").write_text("".join(pairs[:-1]))  # one val row lost: was read as a smaller dataset
    with pytest.raises(DatasetFolderError, match=r"pairs.jsonl: 1 val pairs, but dataset.json counts 2"):
        DatasetFolder(root)
    row = json.loads(pairs[0])
    del row["crop"]
    (root / "pairs.jsonl").write_text(json.dumps(row) + "\n" + "".join(pairs[1:]))
    with pytest.raises(DatasetFolderError, match=r"pairs.jsonl: line 1: missing field `crop`"):
        DatasetFolder(root)  # was a KeyError traceback when the pair was loaded
    (root / "pairs.jsonl").write_text("[1, 2]\n" + "".join(pairs[1:]))
    with pytest.raises(DatasetFolderError, match=r"pairs.jsonl: line 1: invalid type: sequence"):
        DatasetFolder(root)
    (root / "dataset.json").unlink()
    (root / "dataset.json").mkdir()
    with pytest.raises(DatasetFolderError) as unreadable:
        DatasetFolder(root)
    assert str(unreadable.value).count(str(root)) == 1, unreadable.value  # the path once


def test_the_folder_reader_reads_a_built_dataset_as_the_cli_does(cli, tmp_path):
    from unicac.dataset import DatasetFolder, DatasetFolderError

    root = tmp_path / "built"
    cli("dataset", "build", "--lenses", "builtin:achromat", "builtin:cooke_triplet", "builtin:petzval",
        "--images", "dead-leaves:2:80x60", "--test-images", "dead-leaves:1", "--frame", "64x48", "--levels", "1",
        "--test-lenses-per-level", "1", "--val-lenses", "1", "--pairs-per-lens", "1", "--crop", "32x24",
        "--seed", "5", "--out", str(root))
    folder = DatasetFolder(root)
    on_disk = [json.loads(line) for line in (root / "pairs.jsonl").read_text().splitlines()]
    assert folder.pairs() == on_disk  # every field, as written
    assert [row["lens_id"] for row in folder.lenses()] == [
        json.loads(line)["lens_id"] for line in (root / "lenses.jsonl").read_text().splitlines()]
    info = cli("dataset", "info", str(root), "--json")
    expected = {row["lens_id"]: row for row in info["pair_checks"] if row["split"] == "train"}
    got = folder.pair_checks("train")
    assert got.keys() == expected.keys() and got
    for lens_id, checks in got.items():
        assert checks == {k: v for k, v in expected[lens_id].items() if k != "lens_id"}
    assert folder.path("test/lq") == root / "test" / "lq"
    for bad in ("../outside", "/etc/passwd", "", "./a"):
        with pytest.raises(DatasetFolderError, match="must be relative to the dataset folder"):
            folder.path(bad)
    assert isinstance(DatasetFolderError("x"), unicac.DatasetError)  # catchable as the package's own kind


# -- unicac-train ----------------------------------------------------------------------------------

torch = pytest.importorskip("torch", reason="torch is not installed (pip install './python[train]')")
yaml = pytest.importorskip("yaml", reason="pyyaml is not installed (pip install './python[train]')")

from unicac.train import config as config_mod  # noqa: E402
from unicac.train.cli import main as cli_main  # noqa: E402
from unicac.train.models import NonFiniteTraining, Trainer  # noqa: E402
from unicac.train.models import trainer as trainer_mod  # noqa: E402

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    return make_dataset(tmp_path_factory.mktemp("data") / "ds", pairs_per_split=2)


def tiny(dataset: Path, model: str = "nafnet", iters: int = 2) -> dict:
    config = config_mod.load(config_mod.shipped(model))
    for split in ("train", "val"):
        config["datasets"][split]["dataroot"] = str(dataset)
    config["datasets"]["train"].update(patch_px=24, batch_size=1)
    config["datasets"]["val"].update(max_pairs=1, crop_px=32)
    config["train"]["total_iter"] = iters
    config["val"]["val_freq"] = 1000
    config["logger"].update(print_freq=1, save_checkpoint_freq=2)
    return config_mod.validate(config)


@pytest.fixture(scope="module")
def run(tmp_path_factory, dataset):
    """A finished two-iteration NAFNet run."""
    folder = tmp_path_factory.mktemp("runs") / "run"
    Trainer(tiny(dataset), folder, quiet=True).train()
    return folder


def snapshot(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith("unicac-train: error: "), err
    return err


def test_export_never_overwrites_an_input_or_misnames_its_format(tmp_path, run, dataset, capsys):
    """`export RUN --out X` overwrote the run's checkpoint or config, a dataset's dataset.json, or
    wrote ONNX under a .png name, with exit code 0."""
    before_run, before_data = snapshot(run), snapshot(dataset)
    cases = [
        (run / "checkpoints" / "latest.pt", "--out .*latest.pt: the extension must be .onnx"),
        (run / "config.yml", "the extension must be .onnx"),
        (dataset / "dataset.json", "the extension must be .onnx"),
        (tmp_path / "model.png", "model.png: the extension must be .onnx"),
        (run / "model.onnx", "lies inside the input folder"),
        (run / "checkpoints" / ".." / "m.onnx", "lies inside the input folder"),
    ]
    for out, message in cases:
        assert cli_main(["export", str(run), "--out", str(out), "--no-check"]) == 1, out
        assert re.search(message, one_error_line(capsys)), out
    assert snapshot(run) == before_run and snapshot(dataset) == before_data
    assert not (tmp_path / "model.png").exists()
    assert cli_main(["export", str(run), "--out", str(tmp_path / "m.onnx"), "--no-check"]) == 0
    assert (tmp_path / "m.onnx").stat().st_size > 0 and not [p for p in tmp_path.iterdir() if p.name.startswith(".")]


def test_train_out_never_lands_in_an_input(tmp_path, dataset, capsys):
    before = snapshot(dataset)
    common = ["train", "--model", "nafnet", "--dataset", str(dataset), "--iters", "1"]
    assert cli_main(common + ["--out", str(dataset)]) == 1
    assert "would overwrite the input" in one_error_line(capsys)
    assert cli_main(common + ["--out", str(dataset / "runs" / "a")]) == 1
    assert "lies inside the input folder" in one_error_line(capsys)
    (tmp_path / "file").write_text("x")
    assert cli_main(common + ["--out", str(tmp_path / "file")]) == 1
    assert "not a folder" in one_error_line(capsys)
    # A config kept as the run folder's config.yml, given to a fresh run: it would be overwritten.
    (tmp_path / "r").mkdir()
    config_mod.dump(tiny(dataset), tmp_path / "r" / "config.yml")
    assert cli_main(["train", "--config", str(tmp_path / "r" / "config.yml"), "--out", str(tmp_path / "r")]) == 1
    assert "would overwrite the input" in one_error_line(capsys)
    assert snapshot(dataset) == before and not (dataset / "runs").exists()


def test_a_resumed_run_reads_its_own_config_without_rewriting_it(tmp_path, dataset, capsys):
    folder = tmp_path / "run"
    config = tiny(dataset, iters=4)
    Trainer(config, folder, quiet=True).train(stop_after=3)  # checkpoint at 2, then "killed"
    saved = folder / "config.yml"
    stamp = saved.stat().st_mtime_ns
    assert cli_main(["train", "--config", str(saved), "--out", str(folder), "--resume", "--quiet", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["architecture"] == "nafnet"
    assert saved.stat().st_mtime_ns == stamp
    assert torch.load(folder / "checkpoints" / "latest.pt", weights_only=True)["iteration"] == 4


@pytest.mark.parametrize(("key", "value", "message"), [
    ("train.losses.pixel.weight", float("nan"), r"train\.losses\.pixel\.weight: nan is not a finite number"),
    ("train.optim.lr", float("inf"), r"train\.optim\.lr: inf is not a finite number"),
    ("train.grad_clip", float("-inf"), r"train\.grad_clip: -inf is not a finite number"),
    ("train.optim.betas", [float("nan"), 0.9], r"train\.optim\.betas\[0\]: nan is not a finite number"),
    ("train.optim.betas", [1.5, 0.9], r"train\.optim\.betas: expected two numbers in \[0, 1\)"),
    ("train.optim.weight_decay", 1e300, r"train\.optim\.weight_decay: 1e\+300 is above the limit"),
    ("train.losses.psf.weight", 1e9, r"train\.losses\.psf\.weight: 1000000000\.0 is above the limit"),
    ("datasets.train.frame_px", [16, 100000], r"datasets\.train\.frame_px: expected \[width, height\] of 16\.\.8192"),
    ("datasets.train.seed", 2**70, r"datasets\.train\.seed: .* is above the limit"),
])
def test_every_number_of_a_config_is_finite_and_in_range(tmp_path, dataset, capsys, key, value, message):
    """A NaN loss weight trained and saved NaN weights with exit code 0."""
    raw = yaml.safe_load(config_mod.shipped("nafnet").read_text())
    node = raw
    *parents, last = key.split(".")
    for part in parents:
        node = node.setdefault(part, {})
    node[last] = value
    path = tmp_path / "bad.yml"
    path.write_text(yaml.safe_dump(raw))  # YAML spells these .nan / .inf, as a user would
    with pytest.raises(config_mod.ConfigError, match=message):
        config_mod.load(path)
    out = tmp_path / "run"
    assert cli_main(["train", "--config", str(path), "--dataset", str(dataset), "--out", str(out)]) == 1
    assert key.split(".")[-1] in one_error_line(capsys) and not out.exists()


def test_network_numbers_are_finite():
    raw = yaml.safe_load(config_mod.shipped("restormer").read_text())
    raw["network"]["expansion"] = float("nan")
    with pytest.raises(config_mod.ConfigError, match=r"network\.expansion: nan is outside"):
        config_mod.validate(raw)


def test_a_loss_that_turns_nan_stops_training_and_keeps_the_last_good_checkpoint(tmp_path, dataset, monkeypatch, capsys):
    real = trainer_mod.pixel_loss
    calls = {"n": 0}

    def turns_nan(kind, restored, target):
        calls["n"] += 1
        loss = real(kind, restored, target)
        return loss * float("nan") if calls["n"] >= 4 else loss

    monkeypatch.setattr(trainer_mod, "pixel_loss", turns_nan)
    folder = tmp_path / "run"
    with pytest.raises(NonFiniteTraining, match=r"iteration 4: the training loss is nan .*keeps the last good state \(iteration 2\)"):
        Trainer(tiny(dataset, iters=6), folder, quiet=True).train()
    state = torch.load(folder / "checkpoints" / "latest.pt", weights_only=True)
    assert state["iteration"] == 2 and all(bool(torch.isfinite(v).all()) for v in state["net"].values())
    calls["n"] = 0
    config_mod.dump(tiny(dataset, iters=6), tmp_path / "c.yml")
    assert cli_main(["train", "--config", str(tmp_path / "c.yml"), "--out", str(tmp_path / "cli"), "--quiet"]) == 1
    assert "the training loss is nan" in one_error_line(capsys)


def test_weights_that_are_not_finite_are_never_saved(tmp_path, dataset):
    trainer = Trainer(tiny(dataset), tmp_path / "run", quiet=True)
    with torch.no_grad():
        next(trainer.net.parameters()).fill_(float("inf"))
    with pytest.raises(NonFiniteTraining, match="weights are not finite; training stopped before any checkpoint"):
        trainer.save_checkpoint(1)
    assert not (tmp_path / "run" / "checkpoints" / "latest.pt").exists()


def test_bad_runs_and_configs_are_one_line_with_exit_code_1(tmp_path, run, dataset, capsys):
    """Each printed a traceback (or named a path twice) before."""
    (tmp_path / "empty").mkdir()
    broken = tmp_path / "broken"
    shutil.copytree(run, broken)
    (broken / "checkpoints" / "latest.pt").write_bytes(b"PK\x03\x04 truncated")
    other = tmp_path / "other"
    shutil.copytree(run, other)
    fov_config = tiny(dataset, "nafnet-fov")
    config_mod.dump(fov_config, other / "config.yml")  # a run folder of another model
    wider = tmp_path / "wider"
    shutil.copytree(run, wider)
    wide_config = tiny(dataset)
    wide_config["network"]["width"] = 8  # the same architecture, other shapes
    config_mod.dump(wide_config, wider / "config.yml")
    (tmp_path / "empty.yml").write_text("")
    (tmp_path / "types.yml").write_text("name: x\nnetwork: {type: NAFNet}\ntrain: {total_iter: many}\n")
    export = ["export", "--no-check", "--out", str(tmp_path / "m.onnx")]
    cases = [
        (export + [str(tmp_path / "missing")], "missing: no such run folder"),
        (export + [str(tmp_path / "empty")], "empty: not a unicac-train run folder (no config.yml)"),
        (export + [str(broken)], "latest.pt: not a readable PyTorch checkpoint"),
        (export + [str(other)], "holds a nafnet network, but the run's config.yml describes nafnet-fov"),
        (export + [str(wider)], "its weights do not fit the network of the run's config.yml (size mismatch for"),
        (["train", "--config", str(tmp_path / "empty.yml"), "--out", str(tmp_path / "r")], "config: expected a mapping"),
        (["train", "--config", str(tmp_path / "types.yml"), "--out", str(tmp_path / "r")], "train.total_iter: expected int, got str"),
        (["train", "--config", str(tmp_path / "absent.yml"), "--out", str(tmp_path / "r")], "absent.yml: cannot read the config"),
        (["train", "--model", "nafnet", "--dataset", str(tmp_path / "empty"), "--out", str(tmp_path / "r")],
         "empty: not a unicac dataset"),
    ]
    for argv, message in cases:
        assert cli_main(argv) == 1, argv
        line = one_error_line(capsys)
        assert message in line, (argv, line)
        for path in (tmp_path / "missing", tmp_path / "empty", broken, other, wider):
            assert line.count(str(path)) <= 1, line
    assert not (tmp_path / "r").exists() and not (tmp_path / "m.onnx").exists()
    with pytest.raises(SystemExit) as usage:
        cli_main(["export", str(run)])
    assert usage.value.code == 2


def test_damaged_lpips_weights_are_one_line(tmp_path, dataset, monkeypatch, capsys):
    """A truncated or incomplete weights file gave a zipfile/KeyError traceback."""
    folder = tmp_path / "cache" / "weights" / "lpips"
    folder.mkdir(parents=True)
    monkeypatch.setenv("UNICAC_CACHE_DIR", str(tmp_path / "cache"))
    argv = ["train", "--model", "nafnet-gan", "--dataset", str(dataset), "--iters", "1", "--out", str(tmp_path / "r")]
    (folder / "vgg16.npz").write_bytes(b"PK\x03\x04 truncated")
    assert cli_main(argv) == 1
    assert "vgg16.npz: not a readable LPIPS weights file" in one_error_line(capsys)
    np.savez(folder / "vgg16.npz", conv0=np.zeros(1, np.float32))
    assert cli_main(argv) == 1
    line = one_error_line(capsys)
    assert "vgg16.npz: LPIPS weights: 'conv0.weight' is missing" in line and line.count("vgg16.npz") == 1, line
    assert not (tmp_path / "r").exists()


def test_onthefly_config_errors_name_the_key(tmp_path):
    from unicac.dataset import DatasetFolderError
    from unicac.train.data import build_train_set

    raw = yaml.safe_load(config_mod.shipped("nafnet").read_text())
    raw["datasets"] = {"train": {"type": "onthefly", "lenses": ["builtin:cooke_triplet"], "images": str(tmp_path / "none")}}
    config = config_mod.validate(raw)
    with pytest.raises(DatasetFolderError, match=r"datasets\.train\.images: .*none is not a folder"):
        build_train_set(config["datasets"]["train"], 0)


def test_the_command_line_prints_no_traceback(tmp_path):
    """The installed entry point end to end: one line on stderr, exit code 1."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    done = subprocess.run([sys.executable, "-m", "unicac.train", "export", str(tmp_path / "nothing"), "--out",
                           str(tmp_path / "m.onnx")], env=env, capture_output=True, text=True)
    assert done.returncode == 1 and done.stderr.strip().count("\n") == 0 and "Traceback" not in done.stderr, done.stderr


# -- unicac-ray (the checks before Ray starts; Ray itself need not be installed) ---------------------


def test_ray_ode_outputs_are_checked_before_ray_starts(tmp_path, capsys):
    from conftest import _cli_path
    from unicac.scale import cli as ray_cli

    binary = _cli_path()
    if binary is None or not binary.exists():
        pytest.skip("the unicac CLI is not built (cargo build -p unicac-cli, or set UNICAC_BIN)")
    lens = tmp_path / "l.json"
    lens.write_text("{}")
    for csv, message in ((lens, "the extension must be .csv"), (tmp_path / "o.png", "o.png: the extension must be .csv")):
        assert ray_cli.main(["ode", str(lens), "--csv", str(csv), "--unicac-bin", str(binary)]) == 1
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1, err
    copy = tmp_path / "l.csv"
    os.link(lens, copy)
    assert ray_cli.main(["ode", str(lens), "--csv", str(copy), "--unicac-bin", str(binary)]) == 1
    assert "would overwrite the input" in capsys.readouterr().err
    assert lens.read_text() == "{}"


def test_a_failed_cli_task_is_reported_as_the_cli_said_it():
    from unicac.scale.tasks import cli_failure

    stderr = "grading 3 lenses\n[=====     ] 1/3\nerror: --out d: lies inside the input folder i\n"
    assert cli_failure("dataset", 1, stderr) == "unicac dataset: --out d: lies inside the input folder i"
    assert cli_failure("ode", -9, "") == "unicac ode was killed by signal 9"
