"""ONNX export of a run's latest checkpoint, following docs/models.md:

inputs `lq` [N,3,H,W] (+ `fov` [N,2,H,W], `psf` [N,15,H,W], `psf_code` [N,50,H,W], `wiener` [N,3,H,W]
as the network uses them), output `restored` [N,3,H,W]; N, H and W dynamic; opset 17; metadata
`unicac_contract` (1, or 2 for a model with a contract-2 input), `architecture`, `inputs`,
`config_sha256`, `unicac_version`, and `psf_basis_sha256` / `wiener_nsr` for the models that need
them. A run that keeps EMA weights is exported from them. The exported file is checked in
onnxruntime against PyTorch at two image sizes before it is moved into place (atomic); without
onnxruntime the export fails, naming the flag that skips the check (`--no-check`).
"""

from __future__ import annotations

import os
import tempfile
import warnings
from pathlib import Path
from typing import Any, Optional

import numpy as np
import torch
from torch import nn

from unicac.outputs import write_bytes

from .archs import INPUT_CHANNELS, Restorer, build_network
from .models.trainer import RunError, RunFolder, _unicac_version

#: The newest contract version (docs/models.md); a model is written with the lowest that has its inputs.
CONTRACT_VERSION = "2"
CONTRACT_OF_INPUT = {"lq": 1, "fov": 1, "psf": 1, "psf_code": 2, "wiener": 2}
OPSET = 17
#: Parity sizes checked after export (H, W): unlike each other and not multiples of 8.
CHECK_SIZES = ((40, 56), (37, 61))
PARITY_TOLERANCE = 1e-4


class ExportError(RuntimeError):
    pass


class _OnnxModule(nn.Module):
    """Positional inputs in the order of `restorer.inputs`."""

    def __init__(self, restorer: Restorer) -> None:
        super().__init__()
        self.restorer = restorer

    def forward(self, *tensors: torch.Tensor) -> torch.Tensor:
        named = dict(zip(self.restorer.inputs, tensors))
        return self.restorer(named.pop("lq"), **named)


def contract_version(inputs: list[str]) -> str:
    return str(max(CONTRACT_OF_INPUT[name] for name in inputs))


def load_run(run_dir: "os.PathLike[str] | str") -> tuple[Restorer, dict[str, Any], dict[str, Any]]:
    """The run's network with its latest weights (the EMA weights when the run keeps them; eval mode),
    its config and checkpoint."""
    run = RunFolder(run_dir)
    config = run.load_config()
    state = run.load_checkpoint()
    net = build_network(config["network"])
    saved = state.get("architecture")
    if saved is not None and saved != net.architecture:
        raise RunError(f"{run.checkpoint}: holds a {saved} network, but the run's {run.config.name} describes {net.architecture}")
    try:
        if "net_ema" in state:
            prefix = "module."
            net.load_state_dict({k[len(prefix):]: v for k, v in state["net_ema"].items() if k.startswith(prefix)})
        else:
            net.load_state_dict(state["net"])
    except RuntimeError as error:
        # torch lists every missing or mismatched key, one per line after a heading: show the first.
        lines = [line.strip() for line in str(error).strip().splitlines() if line.strip()]
        reason = lines[1] if len(lines) > 1 else lines[0]
        raise RunError(f"{run.checkpoint}: its weights do not fit the network of the run's {run.config.name} ({reason})") from error
    net.eval()
    return net, config, state


def example_inputs(inputs: list[str], height: int, width: int, batch: int = 1, seed: int = 0) -> list[torch.Tensor]:
    generator = torch.Generator().manual_seed(seed)
    tensors = []
    for name in inputs:
        t = torch.rand(batch, INPUT_CHANNELS[name], height, width, generator=generator)
        if name == "fov":
            t = t * 2 - 1
        elif name == "psf":
            t = (t - 0.5) * 6
        elif name == "psf_code":
            t = (t - 0.5) * 4
        tensors.append(t)
    return tensors


def onnx_graph(net: Restorer) -> Any:
    """`net` as an ONNX ModelProto (no metadata). The exporter names a parameter's initializer after it,
    except where it folds a reshaped parameter into a constant (`onnx::Mul_N`): `onnx_weights` maps those
    back."""
    import onnx

    module = _OnnxModule(net).eval()
    names = list(net.inputs)
    dynamic = {name: {0: "N", 2: "H", 3: "W"} for name in names + ["restored"]}
    args = tuple(example_inputs(names, 48, 64))
    with tempfile.TemporaryDirectory() as scratch:
        raw = Path(scratch) / "model.onnx"
        # The TorchScript exporter: exact here and fast (seconds). torch >= 2.9 deprecates it for the
        # torch.export-based one (dynamo=True), which on torch 2.15 takes ~50 s per NAFNet and
        # specialises the Restormer's H/W; revisit when the legacy path is removed.
        with torch.no_grad(), warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            torch.onnx.export(module, args, str(raw), input_names=names, output_names=["restored"],
                              dynamic_axes=dynamic, opset_version=OPSET, dynamo=False)
        return onnx.load(str(raw))


def export_network(net: Restorer, out: Path, metadata: dict[str, str], check: bool = True) -> dict[str, Any]:
    """Writes `net` to `out` (ONNX, docs/models.md); returns {"path", "bytes", "parity": max |diff| per
    checked size} (`check=False`: no parity check, "parity" empty)."""
    import onnx

    model = onnx_graph(net)
    del model.metadata_props[:]
    for key, value in metadata.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(model)
    data = model.SerializeToString()
    out = Path(out)
    report: dict[str, Any] = {"path": str(out), "bytes": len(data), "parity": {}}
    if check:
        report["parity"] = check_parity(net, data)
    write_bytes(out, data)
    return report


def check_parity(net: Restorer, onnx_bytes: bytes, sizes: tuple[tuple[int, int], ...] = CHECK_SIZES) -> dict[str, float]:
    """Max |onnxruntime - PyTorch| at each size; raises ExportError above PARITY_TOLERANCE, or when
    onnxruntime is missing (an unchecked export would pass for a checked one)."""
    try:
        import onnxruntime as ort
    except ImportError as error:
        raise ExportError(
            f"the onnxruntime parity check cannot run: onnxruntime is not importable ({error}); install it "
            "(pip install onnxruntime, or the `train` extra) or pass --no-check to export unchecked"
        ) from error
    session = ort.InferenceSession(onnx_bytes, providers=["CPUExecutionProvider"])
    results = {}
    for height, width in sizes:
        tensors = example_inputs(net.inputs, height, width, batch=2, seed=height)
        with torch.no_grad():
            expected = _OnnxModule(net)(*tensors).float().numpy()
        got = session.run(["restored"], {name: t.numpy() for name, t in zip(net.inputs, tensors)})[0]
        if got.shape != expected.shape:
            raise ExportError(f"onnxruntime returned {got.shape} at {height} x {width}, PyTorch {expected.shape}")
        diff = float(np.abs(got - expected).max())
        if not diff <= PARITY_TOLERANCE:
            raise ExportError(f"onnxruntime differs from PyTorch by {diff:.2e} at {height} x {width} (limit {PARITY_TOLERANCE})")
        results[f"{height}x{width}"] = diff
    return results


def export_run(run_dir: "os.PathLike[str] | str", out: "os.PathLike[str] | str", check: bool = True) -> dict[str, Any]:
    """`unicac-train export RUN_DIR --out MODEL.onnx`."""
    net, config, state = load_run(run_dir)
    metadata = {
        "unicac_contract": contract_version(net.inputs),
        "architecture": net.architecture,
        "inputs": ",".join(net.inputs),
        "config_sha256": str(state.get("config_sha256", "")),
        "unicac_version": _unicac_version(),
        "name": str(config["name"]),
        "iterations": str(state.get("iteration", "")),
    }
    if "psf_code" in net.inputs:
        basis = state.get("psf_basis_sha256")
        if not basis:
            raise ExportError(f"{run_dir}: the checkpoint records no psf_basis_sha256, which a psf_code model needs")
        metadata["psf_basis_sha256"] = str(basis)
    if "wiener" in net.inputs:
        metadata["wiener_nsr"] = repr(float(config["datasets"]["train"]["wiener_nsr"]))
    if "net_ema" in state:
        metadata["weights"] = "ema"
    report = export_network(net, Path(out), metadata, check=check)
    report.update({"architecture": net.architecture, "inputs": net.inputs, "iterations": state.get("iteration")})
    return report


def read_metadata(path: "os.PathLike[str] | str") -> dict[str, str]:
    import onnx

    model = onnx.load(str(path))
    return {entry.key: entry.value for entry in model.metadata_props}


