"""The weights of an exported model (`unicac-train export`, e.g. `models/bench-small/NAME.onnx`) back
in its network, so that a shipped model can be fine-tuned (`--init-from MODEL.onnx`) without the run
folder it came from.

The exporter names most initializers after their parameters, but folds a reshaped parameter (a channel
LayerNorm's weight viewed as [1, C, 1, 1]) into an anonymous constant (`onnx::Mul_N`). Rather than guess
which parameter each of those is, the network is exported once with every parameter element set to its
own index (1, 2, 3, ... in float32, exact below 2^24): each initializer of that export then names, by its
values, the parameter elements it holds (a second export with every index plus one tells them from the
graph's own constants). The file must have the same graph (initializer names and
shapes), else the architecture or the exporter differs and the file is refused. The loaded network is
checked against the file in onnxruntime, as export checks it.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np
import torch

from .archs import Restorer
from .onnx_graph import ExportError, check_parity, onnx_graph

#: Elements a network may have for the index export: float32 holds every integer up to 2^24 exactly.
MAX_ELEMENTS = 2**24 - 1


class OnnxWeightsError(RuntimeError):
    pass


def _initializers(model: Any) -> dict[str, np.ndarray]:
    from onnx import numpy_helper

    return {init.name: numpy_helper.to_array(init) for init in model.graph.initializer}


def _index_map(net: Restorer) -> dict[str, tuple[str, np.ndarray]]:
    """Initializer name -> (state-dict key, the element offsets within that parameter it holds, in the
    initializer's own order)."""

    state = net.state_dict()
    keys = [key for key, value in state.items() if value.is_floating_point()]
    total = sum(state[key].numel() for key in keys)
    if total > MAX_ELEMENTS:
        raise OnnxWeightsError(f"the network has {total} weights, more than the {MAX_ELEMENTS} the index export can tell apart")
    bounds = []
    start = 1
    for key in keys:
        bounds.append((start, key))
        start += state[key].numel()

    def export_marked(shift: int) -> dict[str, np.ndarray]:
        marked = {key: torch.arange(first + shift, first + shift + state[key].numel(), dtype=torch.float32)
                  .reshape(state[key].shape) for first, key in bounds}
        net.load_state_dict({**state, **marked})
        return _initializers(onnx_graph(net))

    saved = {key: value.clone() for key, value in state.items()}
    try:
        exported, shifted = export_marked(0), export_marked(1)
    finally:
        net.load_state_dict(saved)
    starts = np.array([first for first, _ in bounds])
    mapping: dict[str, tuple[str, np.ndarray]] = {}
    for name, values in exported.items():
        flat = values.reshape(-1)
        # Parameter elements move with the markers; the graph's own constants do not.
        if (not np.issubdtype(flat.dtype, np.floating) or flat.size == 0 or name not in shifted
                or not np.array_equal(shifted[name].reshape(-1), flat + 1) or flat.min() < 1):
            continue
        first, key = bounds[int(np.searchsorted(starts, flat[0], side="right")) - 1]
        offsets = flat.astype(np.int64) - first
        if offsets.min() < 0 or offsets.max() >= state[key].numel():
            continue
        mapping[name] = (key, offsets)
    return mapping


def load_onnx_weights(net: Restorer, path: "os.PathLike[str] | str", wiener_nsr: float | None = None) -> dict[str, torch.Tensor]:
    """The state dict of `net` with the weights of the exported model at `path` (checked: same
    architecture, same graph, every parameter found once, outputs equal to onnxruntime's)."""
    import onnx

    path = Path(path)
    try:
        model = onnx.load(str(path))
    except Exception as error:  # onnx raises DecodeError and friends
        raise OnnxWeightsError(f"{path}: not an ONNX file ({error})") from error
    metadata = {entry.key: entry.value for entry in model.metadata_props}
    if metadata.get("architecture") != net.architecture:
        raise OnnxWeightsError(f"{path}: its architecture is {metadata.get('architecture')!r}, the config's network is "
                               f"{net.architecture!r}")
    try:
        file_nsr = float(metadata["wiener_nsr"]) if "wiener_nsr" in metadata else None
    except ValueError:
        raise OnnxWeightsError(f"{path}: its metadata wiener_nsr {metadata['wiener_nsr']!r} is not a number") from None
    if wiener_nsr is not None and file_nsr is not None and file_nsr != float(wiener_nsr):
        raise OnnxWeightsError(f"{path}: trained on Wiener estimates with NSR {metadata['wiener_nsr']}, the config's "
                               f"datasets.train.wiener_nsr is {wiener_nsr}")
    given = _initializers(model)
    mapping = _index_map(net)
    state = {key: value.clone() for key, value in net.state_dict().items()}
    filled = {key: np.zeros(value.numel(), dtype=bool) for key, value in state.items() if value.is_floating_point()}
    for name, (key, offsets) in mapping.items():
        if name not in given or given[name].size != offsets.size:
            raise OnnxWeightsError(f"{path}: has no initializer {name!r} of {offsets.size} values as this network's export "
                                   "does: exported from another network layout or exporter version")
        flat = state[key].view(-1)
        flat[torch.from_numpy(offsets)] = torch.from_numpy(given[name].reshape(-1).astype(np.float32))
        filled[key][offsets] = True
    missing = [key for key, done in filled.items() if not done.all()]
    if missing:
        raise OnnxWeightsError(f"{path}: holds no values for {', '.join(missing[:5])}"
                               + (f" and {len(missing) - 5} more" if len(missing) > 5 else ""))
    _check_against_file(net, state, model.SerializeToString(), path)
    return state


def _check_against_file(net: Restorer, state: dict[str, torch.Tensor], data: bytes, path: Path) -> None:
    saved = {key: value.clone() for key, value in net.state_dict().items()}
    net.load_state_dict(state)
    was_training = net.training
    net.eval()
    try:
        check_parity(net, data, sizes=((40, 56),))
    except ExportError as error:
        raise OnnxWeightsError(f"{path}: the network with its weights does not reproduce the file: {error}") from error
    finally:
        net.load_state_dict(saved)
        net.train(was_training)
