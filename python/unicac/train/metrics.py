"""Validation metrics on float images in [0, 1] (N x 3 x H x W), RGB, no border crop:

* PSNR (dB) = 10 log10(1 / MSE) per image, averaged over images;
* SSIM (Wang et al. 2004): Gaussian window 11 x 11, sigma 1.5, K1 = 0.01, K2 = 0.03, data range 1,
  'valid' windows, mean over the three channels, as BasicSR's `calculate_ssim` per channel.

Both are deterministic (fixed-order reductions in float64)."""

from __future__ import annotations

import torch
import torch.nn.functional as F


def psnr(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Per-image PSNR (dB), shape [N]; images are clamped to [0, 1] first."""
    x, y = x.clamp(0, 1).double(), y.clamp(0, 1).double()
    mse = (x - y).pow(2).flatten(1).mean(1)
    return 10 * torch.log10(1.0 / mse.clamp_min(1e-12))


def _gaussian(size: int = 11, sigma: float = 1.5) -> torch.Tensor:
    coords = torch.arange(size, dtype=torch.float64) - (size - 1) / 2
    g = torch.exp(-(coords**2) / (2 * sigma**2))
    g = g / g.sum()
    return g[:, None] * g[None, :]


def ssim(x: torch.Tensor, y: torch.Tensor) -> torch.Tensor:
    """Per-image SSIM, shape [N] (images of at least 11 x 11 px)."""
    x, y = x.clamp(0, 1).double(), y.clamp(0, 1).double()
    c = x.shape[1]
    window = _gaussian().to(x.device).expand(c, 1, 11, 11).contiguous()
    blur = lambda t: F.conv2d(t, window, groups=c)  # noqa: E731
    mu_x, mu_y = blur(x), blur(y)
    sxx = blur(x * x) - mu_x**2
    syy = blur(y * y) - mu_y**2
    sxy = blur(x * y) - mu_x * mu_y
    c1, c2 = 0.01**2, 0.03**2
    value = ((2 * mu_x * mu_y + c1) * (2 * sxy + c2)) / ((mu_x**2 + mu_y**2 + c1) * (sxx + syy + c2))
    return value.flatten(1).mean(1)
