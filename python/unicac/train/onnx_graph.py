"""An ONNX graph of a restoration network (the contract of docs/models.md: inputs in the order of
`restorer.inputs`, output `restored`, N/H/W dynamic, opset 17) and its check against PyTorch in
onnxruntime. Shared by `export` (writing a run's model) and `onnx_weights` (reading one back)."""

from __future__ import annotations

import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from .archs import INPUT_CHANNELS, Restorer

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
