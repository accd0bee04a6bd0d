"""Building blocks shared by the architectures: channel LayerNorm, padding to a multiple inside the
graph, the prior injection (FoV / PSF maps added at every encoder scale), and the model inputs of
docs/models.md with their channel counts.

Every block works at any H and W: nothing caches a shape or bakes a size into the graph (the NAFNet
TLC pooling and Swin attention masks are the counter-examples, see docs/models.md)."""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import nn


#: The contract's inputs (docs/models.md) and their channels; `psf_code` = 3 x 16 coefficients + cos, sin.
INPUT_CHANNELS = {"lq": 3, "fov": 2, "psf": 15, "psf_code": 50, "wiener": 3}
#: The maps besides `lq`, in the order a model lists them.
MAP_INPUTS = ("fov", "psf", "psf_code", "wiener")


class LayerNorm2d(nn.Module):
    """LayerNorm over the channels of an N x C x H x W tensor (per pixel), as NAFNet and Restormer use."""

    def __init__(self, channels: int, eps: float = 1e-6) -> None:
        super().__init__()
        self.weight = nn.Parameter(torch.ones(channels))
        self.bias = nn.Parameter(torch.zeros(channels))
        self.eps = eps

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        mean = x.mean(1, keepdim=True)
        var = (x - mean).pow(2).mean(1, keepdim=True)
        y = (x - mean) / torch.sqrt(var + self.eps)
        return y * self.weight.view(1, -1, 1, 1) + self.bias.view(1, -1, 1, 1)


def pad_to_multiple(x: torch.Tensor, multiple: int) -> torch.Tensor:
    """Reflect-pads the bottom and right of `x` to multiples of `multiple` (computed from the traced
    shape, so an exported graph pads whatever size it is given)."""
    h, w = x.shape[-2], x.shape[-1]
    pad_h = (multiple - h % multiple) % multiple
    pad_w = (multiple - w % multiple) % multiple
    if torch.compiler.is_compiling() and pad_h == pad_w == 0:
        # Under torch.compile the shape is known, so a pad of nothing can go; it must: Inductor (PyTorch
        # 2.15) gets the strides of its backward wrong on the blind PSF control's estimator output.
        return x
    # Replicate (not reflect): reflect fails when the pad exceeds the side, replicate never does.
    return F.pad(x, (0, pad_w, 0, pad_h), mode="replicate")


class PriorInjection(nn.Module):
    """Adds a 1x1 projection of a prior map (FoV or PSF features), average-pooled to each scale, to the
    features of that scale: the map conditions every level, not only the first convolution."""

    def __init__(self, prior_channels: int, widths: list[int]) -> None:
        super().__init__()
        self.projections = nn.ModuleList(nn.Conv2d(prior_channels, w, 1) for w in widths)

    def forward(self, level: int, features: torch.Tensor, prior: torch.Tensor) -> torch.Tensor:
        factor = 2**level
        pooled = F.avg_pool2d(prior, factor) if factor > 1 else prior
        return features + self.projections[level](pooled)
