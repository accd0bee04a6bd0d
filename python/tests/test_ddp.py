"""Training with torchrun (docs/scale.md): a 2-process gloo DDP run equals one process with the same
global batch, its checkpoint (written by rank 0 only) loads in one process and exports to ONNX.

Skipped only when torch (or pyyaml) is not importable."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

torch = pytest.importorskip("torch", reason="torch is not installed (pip install './python[train]')")
pytest.importorskip("yaml", reason="pyyaml is not installed (pip install './python[train]')")

from fake_dataset import make_dataset  # noqa: E402
from unicac.train import config as config_mod  # noqa: E402
from unicac.train.archs import build_network  # noqa: E402

ITERATIONS = 3
# Weights after 3 Adam steps (lr 1e-3): DDP averages the two ranks' mean-loss gradients in float32, one
# process averages the same two samples in one mean; the summation order differs, so the weights may
# differ by float32 rounding carried through Adam's update (observed: max |difference| 2.8e-7, largest
# weight change from the start 2.0e-3; 2026-12-01, 2 shared cores).
WEIGHT_ATOL = 1e-5


def config_file(tmp_path: Path, dataset: Path, batch_per_process: int, name: str) -> Path:
    config = config_mod.load(config_mod.shipped("nafnet"))
    for split in ("train", "val"):
        config["datasets"][split]["dataroot"] = str(dataset)
    config["datasets"]["train"].update(patch_px=24, batch_size=batch_per_process, num_workers=0)
    config["datasets"]["val"].update(max_pairs=2, crop_px=32)
    config["train"]["total_iter"] = ITERATIONS
    config["val"]["val_freq"] = ITERATIONS
    config["logger"].update(print_freq=1, save_checkpoint_freq=ITERATIONS)
    path = tmp_path / f"{name}.yml"
    config_mod.dump(config_mod.validate(config), path)
    return path


def run(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    # One thread per process: 2 processes on 2 shared cores, and the same arithmetic in both runs.
    env = dict(os.environ, OMP_NUM_THREADS="1")
    done = subprocess.run(args, capture_output=True, text=True, cwd=cwd, env=env, timeout=600, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return done


def test_two_process_ddp_equals_one_process_with_the_global_batch(tmp_path):
    dataset = make_dataset(tmp_path / "data")
    one = tmp_path / "one"
    two = tmp_path / "two"
    run([sys.executable, "-m", "unicac.train", "train", "--config",
         str(config_file(tmp_path, dataset, 2, "global")), "--out", str(one), "--quiet"], tmp_path)
    run([sys.executable, "-m", "torch.distributed.run", "--standalone", "--nproc_per_node", "2",
         "-m", "unicac.train", "train", "--config", str(config_file(tmp_path, dataset, 1, "per-rank")),
         "--out", str(two), "--quiet"], tmp_path)  # fmt: skip

    a = torch.load(one / "checkpoints" / "latest.pt", weights_only=True)
    b = torch.load(two / "checkpoints" / "latest.pt", weights_only=True)
    assert a["iteration"] == b["iteration"] == ITERATIONS
    assert json.loads((two / "run.json").read_text())["world_size"] == 2
    # Rank 0 alone wrote the run folder: one checkpoint, no leftovers of a second writer.
    assert sorted(p.name for p in (two / "checkpoints").iterdir()) == ["latest.pt"]
    config = config_mod.load(two / "config.yml")
    torch.manual_seed(config["manual_seed"])  # the initial weights, as the trainer makes them
    initial = build_network(config["network"]).state_dict()
    worst = max(float((value - b["net"][name]).abs().max()) for name, value in a["net"].items())
    moved = max(float((value - initial[name]).abs().max()) for name, value in a["net"].items())
    print(f"DDP (2 x batch 1) vs one process (batch 2), {ITERATIONS} steps: max |weight difference| "
          f"{worst:.3e}; largest weight change from the start {moved:.3e}")
    assert worst <= WEIGHT_ATOL
    assert moved >= 100 * WEIGHT_ATOL  # training moved the weights far more than the runs differ

    # The checkpoint loads in one process (no DDP "module." prefixes) ...
    net = build_network(config["network"])
    net.load_state_dict(b["net"])
    # ... and exports to ONNX, checked against PyTorch in onnxruntime by the exporter.
    pytest.importorskip("onnxruntime")
    model = tmp_path / "ddp.onnx"
    done = run([sys.executable, "-m", "unicac.train", "export", str(two), "--out", str(model), "--json"], tmp_path)
    report = json.loads(done.stdout.strip().splitlines()[-1])
    assert model.is_file() and report["iterations"] == ITERATIONS
    assert report["parity"] and max(report["parity"].values()) <= 1e-4
