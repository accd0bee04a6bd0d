"""The receptive field of a restoration network, measured: the width (px) of the input region that
one output pixel depends on through the network's local paths (its convolutions, down- and
up-sampling, per-pixel gates and norms).

A blur `K` px wide can only be undone by a network that sees at least `K` px around each pixel; the
trainer compares this width with the dataset's largest PSF kernel (docs/models.md).

Measured, not derived: one output pixel at the centre of a copy of the network (weights redrawn
positive, so no path cancels by chance) is differentiated with respect to the inputs, and the support
of the non-zero gradient is the receptive field. In float64: the gradient decays geometrically towards
the field's edge, and float32 loses its outer rows to underflow (a 4-level NAFNet measures 144 px in
float32, 160 px in float64). Global operations are made local first
(`local_paths`): NAFNet's simplified channel attention multiplies by a global average (it becomes
the per-pixel value) and Restormer's channel attention mixes every pixel through its attention map
(held constant): they carry global statistics, not spatial support. The input grows until the
support stops short of its border, up to `MAX_SIDE_PX` (beyond which the result is a lower bound).
"""

from __future__ import annotations

import contextlib
import copy
from typing import Iterator

import torch
from torch import nn

from .common import INPUT_CHANNELS

#: Largest input side the measurement tries (px); a wider field is reported as at least this.
MAX_SIDE_PX = 1024


@contextlib.contextmanager
def local_paths(module: nn.Module) -> Iterator[nn.Module]:
    """`module` with its global operations made local (see the module docs); restored on exit."""
    from .restormer import ChannelAttention

    swapped = []
    for parent in module.modules():
        for name, child in parent.named_children():
            if isinstance(child, nn.AdaptiveAvgPool2d):
                swapped.append((parent, name, child))
                setattr(parent, name, nn.Identity())
            if isinstance(child, ChannelAttention):
                child.local_paths = True
    try:
        yield module
    finally:
        for parent, name, child in swapped:
            setattr(parent, name, child)
        for child in module.modules():
            if isinstance(child, ChannelAttention):
                child.local_paths = False


def _support(restorer: nn.Module, side: int) -> tuple[int, bool]:
    """(width of the gradient's support, whether it reaches the input's border) at an input of `side` px."""
    generator = torch.Generator().manual_seed(0)
    inputs = {name: torch.rand(1, INPUT_CHANNELS[name], side, side, generator=generator, dtype=torch.float64)
              for name in restorer.inputs}
    lq = inputs.pop("lq").requires_grad_(True)
    maps = {name: t.requires_grad_(True) for name, t in inputs.items()}
    out = restorer(lq, **maps)
    centre = side // 2
    out[0, :, centre, centre].sum().backward()
    grads = [lq.grad] + [t.grad for t in maps.values() if t.grad is not None]
    support = torch.zeros(side, side, dtype=torch.bool)
    for g in grads:
        support |= (g[0] != 0).any(dim=0)
    rows = torch.nonzero(support.any(dim=1)).flatten()
    cols = torch.nonzero(support.any(dim=0)).flatten()
    if rows.numel() == 0:
        return 1, False
    width = int(max(rows.max() - rows.min(), cols.max() - cols.min())) + 1
    touches = bool(rows.min() == 0 or cols.min() == 0 or rows.max() == side - 1 or cols.max() == side - 1)
    return width, touches


_CACHE: dict[tuple[str, int, int], tuple[int, bool]] = {}


def receptive_field_px(restorer: nn.Module, start_side_px: int = 128, key: str = "",
                       enough_px: int = MAX_SIDE_PX + 1) -> tuple[int, bool]:
    """(receptive-field width in px, exact): `exact` is False when the support still reached the
    border of the input (the width is then a lower bound): at `MAX_SIDE_PX`, or once the width reached
    `enough_px` (all a check needs to know). A non-empty `key` (e.g. the network config) caches the
    result for this process."""
    if key and (key, start_side_px, enough_px) in _CACHE:
        return _CACHE[(key, start_side_px, enough_px)]
    probe = copy.deepcopy(restorer).double().cpu().eval()
    generator = torch.Generator().manual_seed(1)
    with torch.no_grad():
        for p in probe.parameters():
            p.copy_(0.05 + 0.1 * torch.rand(p.shape, generator=generator, dtype=torch.float64))
    side = max(32, start_side_px)
    with local_paths(probe):
        while True:
            width, touches = _support(probe, side)
            if not touches or side >= MAX_SIDE_PX or width >= enough_px:
                break
            side = min(2 * side, MAX_SIDE_PX)
    result = (width, not touches)
    if key:
        _CACHE[(key, start_side_px, enough_px)] = result
    return result
