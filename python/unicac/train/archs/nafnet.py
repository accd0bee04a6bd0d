"""NAFNet (Chen et al., ECCV 2022), sized for 2 CPU cores, with optional prior inputs.

One U-Net of NAF blocks (LayerNorm, depth-wise conv, SimpleGate, simplified channel attention) serves
the prior axis of the paper:

* `NAFNet(prior=None)`: no prior, input `lq` only;
* `NAFNet(prior="fov")`: the field-of-view map (2 channels, docs/models.md) concatenated to the input
  and injected at every encoder scale (the FOV-KPN idea);
* `NAFNet(prior="psf")`: the oracle PSF-feature map (15 channels) likewise;
* `BlindPsfNAFNet`: a small estimator predicts the PSF-feature map from `lq`; the restorer is the
  PSF-prior NAFNet fed that prediction. Training supervises the prediction with the true map.

The simplified channel attention pools globally (adaptive average pooling, exported as
GlobalAveragePool). NAFNet's test-time local converter (TLC), which replaces it by a pooling window
sized from the training patch, is deliberately absent: it caches a shape and breaks dynamic sizes.
"""

from __future__ import annotations

from typing import Optional, Sequence

import torch
from torch import nn

from .common import LayerNorm2d, PriorInjection, pad_to_multiple

PRIOR_CHANNELS = {"fov": 2, "psf": 15}
#: PSF features are in pixels (docs/models.md); this scale brings typical values near unit range.
PSF_FEATURE_SCALE = 0.25


class SimpleGate(nn.Module):
    def forward(self, x: torch.Tensor) -> torch.Tensor:
        a, b = x.chunk(2, dim=1)
        return a * b


class NAFBlock(nn.Module):
    def __init__(self, c: int, expand: int = 2) -> None:
        super().__init__()
        dw = c * expand
        self.norm1 = LayerNorm2d(c)
        self.conv1 = nn.Conv2d(c, dw, 1)
        self.conv2 = nn.Conv2d(dw, dw, 3, padding=1, groups=dw)
        self.sca = nn.Sequential(nn.AdaptiveAvgPool2d(1), nn.Conv2d(dw // 2, dw // 2, 1))
        self.conv3 = nn.Conv2d(dw // 2, c, 1)
        self.norm2 = LayerNorm2d(c)
        self.conv4 = nn.Conv2d(c, 2 * c, 1)
        self.conv5 = nn.Conv2d(c, c, 1)
        self.gate = SimpleGate()
        self.beta = nn.Parameter(torch.zeros(1, c, 1, 1))
        self.gamma = nn.Parameter(torch.zeros(1, c, 1, 1))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        y = self.gate(self.conv2(self.conv1(self.norm1(x))))
        y = self.conv3(y * self.sca(y))
        x = x + y * self.beta
        y = self.conv5(self.gate(self.conv4(self.norm2(x))))
        return x + y * self.gamma


class NAFNet(nn.Module):
    """U-Net of NAF blocks; `lq` [N,3,H,W] (+ prior [N,C,H,W]) -> restored [N,3,H,W] (residual)."""

    def __init__(
        self,
        width: int = 16,
        enc_blocks: Sequence[int] = (1, 1, 2),
        middle_blocks: int = 2,
        dec_blocks: Sequence[int] = (1, 1, 1),
        prior: Optional[str] = None,
    ) -> None:
        super().__init__()
        if len(enc_blocks) != len(dec_blocks):
            raise ValueError("network.enc_blocks and network.dec_blocks must have the same length")
        if prior is not None and prior not in PRIOR_CHANNELS:
            raise ValueError(f"network.prior: '{prior}' is not one of {sorted(PRIOR_CHANNELS)}")
        self.prior = prior
        prior_ch = PRIOR_CHANNELS.get(prior, 0) if prior else 0
        self.intro = nn.Conv2d(3 + prior_ch, width, 3, padding=1)
        self.encoders = nn.ModuleList()
        self.downs = nn.ModuleList()
        widths = []
        c = width
        for n in enc_blocks:
            widths.append(c)
            self.encoders.append(nn.Sequential(*[NAFBlock(c) for _ in range(n)]))
            self.downs.append(nn.Conv2d(c, 2 * c, 2, stride=2))
            c *= 2
        self.middle = nn.Sequential(*[NAFBlock(c) for _ in range(middle_blocks)])
        self.ups = nn.ModuleList()
        self.decoders = nn.ModuleList()
        for n in dec_blocks:
            self.ups.append(nn.Sequential(nn.Conv2d(c, 2 * c, 1, bias=False), nn.PixelShuffle(2)))
            c //= 2
            self.decoders.append(nn.Sequential(*[NAFBlock(c) for _ in range(n)]))
        self.ending = nn.Conv2d(width, 3, 3, padding=1)
        self.injection = PriorInjection(prior_ch, widths) if prior else None
        self.multiple = 2 ** len(enc_blocks)

    def forward(self, lq: torch.Tensor, prior: Optional[torch.Tensor] = None) -> torch.Tensor:
        h, w = lq.shape[-2], lq.shape[-1]
        x = pad_to_multiple(lq, self.multiple)
        if self.injection is not None:
            if prior is None:
                raise ValueError(f"this NAFNet needs its '{self.prior}' input")
            if self.prior == "psf":
                prior = prior * PSF_FEATURE_SCALE
            prior = pad_to_multiple(prior, self.multiple)
            feat = self.intro(torch.cat([x, prior], dim=1))
        else:
            feat = self.intro(x)
        skips = []
        for level, (encoder, down) in enumerate(zip(self.encoders, self.downs)):
            if self.injection is not None:
                feat = self.injection(level, feat, prior)
            feat = encoder(feat)
            skips.append(feat)
            feat = down(feat)
        feat = self.middle(feat)
        for decoder, up, skip in zip(self.decoders, self.ups, reversed(skips)):
            feat = decoder(up(feat) + skip)
        out = self.ending(feat) + x
        return out[:, :, :h, :w]


class BlindPsfNAFNet(nn.Module):
    """Blind PSF prior: `estimator` predicts the PSF-feature map (in px, like the true one) from `lq`,
    and the PSF-prior NAFNet restores with it. `forward(lq)` -> restored; `forward_with_psf(lq)` ->
    (restored, predicted PSF features) for training, where the prediction is supervised."""

    def __init__(self, estimator_width: int = 16, estimator_blocks: Sequence[int] = (1, 1), **restorer) -> None:
        super().__init__()
        self.estimator = NAFNetHead(estimator_width, estimator_blocks, out_channels=PRIOR_CHANNELS["psf"])
        self.restorer = NAFNet(prior="psf", **restorer)

    def forward_with_psf(self, lq: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        psf = self.estimator(lq) / PSF_FEATURE_SCALE
        return self.restorer(lq, psf), psf

    def forward(self, lq: torch.Tensor) -> torch.Tensor:
        return self.forward_with_psf(lq)[0]


class NAFNetHead(nn.Module):
    """A small NAF U-Net mapping an image to `out_channels` maps (no residual): the PSF estimator."""

    def __init__(self, width: int, blocks: Sequence[int], out_channels: int) -> None:
        super().__init__()
        self.intro = nn.Conv2d(3, width, 3, padding=1)
        self.encoders = nn.ModuleList()
        self.downs = nn.ModuleList()
        c = width
        for n in blocks:
            self.encoders.append(nn.Sequential(*[NAFBlock(c) for _ in range(n)]))
            self.downs.append(nn.Conv2d(c, 2 * c, 2, stride=2))
            c *= 2
        self.middle = NAFBlock(c)
        self.ups = nn.ModuleList()
        for _ in blocks:
            self.ups.append(nn.Sequential(nn.Conv2d(c, 2 * c, 1, bias=False), nn.PixelShuffle(2)))
            c //= 2
        self.ending = nn.Conv2d(width, out_channels, 3, padding=1)
        self.multiple = 2 ** len(blocks)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h, w = x.shape[-2], x.shape[-1]
        feat = self.intro(pad_to_multiple(x, self.multiple))
        skips = []
        for encoder, down in zip(self.encoders, self.downs):
            feat = encoder(feat)
            skips.append(feat)
            feat = down(feat)
        feat = self.middle(feat)
        for up, skip in zip(self.ups, reversed(skips)):
            feat = up(feat) + skip
        return self.ending(feat)[:, :, :h, :w]


