"""NAFNet (Chen et al., ECCV 2022) with optional prior inputs: the paper's prior axis.

One U-Net of NAF blocks (LayerNorm, depth-wise conv, SimpleGate, simplified channel attention),
numerically identical to the official `NAFNet` at the same widths and depths (docs/models.md), serves:

* `NAFNet(prior=None)`: no prior, input `lq` only;
* `NAFNet(prior="fov")`: the field-of-view map (2 channels) as input channels and added (1x1
  projection) at every encoder scale: FoV coordinates as positional channels;
* `NAFNet(prior="psf_code")`: the dense PSF code (50 channels: the dataset's PCA coefficients of the
  true kernel at each pixel, and its azimuth) likewise;
* `NAFNet(prior="psf")`: the 15 PSF moments likewise (the ablation of the code);
* `NAFNet(prior="wiener")`: physics plus learning: the field-varying Wiener estimate as a second input
  image and the base of the residual, with the output convolution zero-initialised, so the untrained
  network returns exactly the Wiener estimate and learns a refinement of it;
* `BlindPsfNAFNet`: an estimator predicts the PSF code (or moments) from `lq`; the prior NAFNet
  restores with the prediction. Training supervises the prediction with the true map.

`prior_control=True` builds the control of a prior model: the same network and parameter count with
the prior replaced by something carrying no information about the lens (a learned constant map; for
`wiener`, `lq` itself), so "the prior helps" is not "more parameters help".

The simplified channel attention pools globally (adaptive average pooling, exported as
GlobalAveragePool). NAFNet's test-time local converter (TLC), which replaces it by a pooling window
sized from the training patch, is deliberately absent: it caches a shape and breaks dynamic sizes.
"""

from __future__ import annotations

from typing import Optional, Sequence

import torch
from torch import nn

from .common import INPUT_CHANNELS, LayerNorm2d, PriorInjection, pad_to_multiple

PRIORS = ("fov", "psf", "psf_code", "wiener")
#: PSF moments are in pixels (docs/models.md); this scale brings typical values near unit range. The
#: code is whitened (unit variance) and needs none.
PRIOR_SCALE = {"psf": 0.25}
PSF_FEATURE_SCALE = PRIOR_SCALE["psf"]
#: The architecture name of each prior (ONNX metadata `architecture`, `unicac-train models`).
ARCHITECTURE = {None: "nafnet", "fov": "nafnet-fov", "psf_code": "nafnet-psf", "psf": "nafnet-psf-moments",
                "wiener": "wiener-nafnet"}


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
    """U-Net of NAF blocks; `lq` [N,3,H,W] (+ its prior map [N,C,H,W]) -> restored [N,3,H,W] (residual).

    Declares `inputs` (the contract inputs it reads, `lq` first), `architecture` and `predicts` (None:
    it predicts no prior)."""

    inputs: tuple[str, ...] = ("lq",)
    predicts: Optional[str] = None

    def __init__(
        self,
        width: int = 16,
        enc_blocks: Sequence[int] = (1, 1, 2),
        middle_blocks: int = 2,
        dec_blocks: Sequence[int] = (1, 1, 1),
        prior: Optional[str] = None,
        prior_control: bool = False,
    ) -> None:
        super().__init__()
        if len(enc_blocks) != len(dec_blocks):
            raise ValueError("network.enc_blocks and network.dec_blocks must have the same length")
        if prior is not None and prior not in PRIORS:
            raise ValueError(f"network.prior: '{prior}' is not one of {list(PRIORS)}")
        if prior_control and prior is None:
            raise ValueError("network.prior_control: a control replaces a prior; set network.prior")
        self.prior = prior
        self.prior_control = prior_control
        self.inputs = ("lq",) if prior is None or prior_control else ("lq", prior)
        self.architecture = ARCHITECTURE[prior] + ("-control" if prior_control else "")
        prior_ch = INPUT_CHANNELS[prior] if prior else 0
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
        # The Wiener estimate is an image: it enters at the input only; the maps condition every scale.
        self.injection = PriorInjection(prior_ch, widths) if prior and prior != "wiener" else None
        # The control's stand-in for a map: a learned constant per channel (no information on the lens).
        self.stand_in = nn.Parameter(torch.zeros(1, prior_ch, 1, 1)) if prior_control and prior != "wiener" else None
        if prior == "wiener":
            # Starts as exactly its residual base (the Wiener estimate, or lq for the control).
            nn.init.zeros_(self.ending.weight)
            nn.init.zeros_(self.ending.bias)
        self.multiple = 2 ** len(enc_blocks)

    def _prior_map(self, lq: torch.Tensor, given: Optional[torch.Tensor]) -> Optional[torch.Tensor]:
        if self.prior is None:
            return None
        if self.prior_control:
            if self.prior == "wiener":
                return lq
            assert self.stand_in is not None
            return self.stand_in.expand(lq.shape[0], -1, lq.shape[2], lq.shape[3])
        if given is None:
            raise ValueError(f"this NAFNet needs its '{self.prior}' input")
        return given * PRIOR_SCALE[self.prior] if self.prior in PRIOR_SCALE else given

    def forward(self, lq: torch.Tensor, **maps: Optional[torch.Tensor]) -> torch.Tensor:
        h, w = lq.shape[-2], lq.shape[-1]
        x = pad_to_multiple(lq, self.multiple)
        prior = self._prior_map(lq, maps.get(self.prior) if self.prior else None)
        base = x
        if prior is not None:
            prior = pad_to_multiple(prior, self.multiple)
            feat = self.intro(torch.cat([x, prior], dim=1))
            if self.prior == "wiener":
                base = prior
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
        out = self.ending(feat) + base
        return out[:, :, :h, :w]


class BlindPsfNAFNet(nn.Module):
    """Blind PSF prior: `estimator` predicts the `target` map (the PSF code, or the moments in px) from
    `lq`, and the prior NAFNet restores with it. `forward(lq)` -> restored; `forward_with_prediction(lq)`
    -> (restored, predicted map) for training, where the prediction is supervised with the true map.

    `prior_control=True` is the control: the same networks, trained without the supervision, so the
    estimator is capacity only (it predicts nothing the trainer checks)."""

    inputs: tuple[str, ...] = ("lq",)

    def __init__(self, estimator_width: int = 16, estimator_blocks: Sequence[int] = (1, 1, 1),
                 target: str = "psf_code", prior_control: bool = False, **restorer) -> None:
        super().__init__()
        if target not in ("psf_code", "psf"):
            raise ValueError(f"network.target: '{target}' is not one of ['psf_code', 'psf']")
        self.target = target
        self.predicts: Optional[str] = None if prior_control else target
        self.architecture = ("nafnet-psf-blind" if target == "psf_code" else "nafnet-psf-moments-blind") + (
            "-control" if prior_control else "")
        self.estimator = NAFNetHead(estimator_width, estimator_blocks, out_channels=INPUT_CHANNELS[target])
        self.restorer = NAFNet(prior=target, **restorer)

    def forward_with_prediction(self, lq: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        predicted = self.estimator(lq) / PRIOR_SCALE.get(self.target, 1.0)
        return self.restorer(lq, **{self.target: predicted}), predicted

    def forward(self, lq: torch.Tensor, **_: Optional[torch.Tensor]) -> torch.Tensor:
        return self.forward_with_prediction(lq)[0]


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
