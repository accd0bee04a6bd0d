"""Restormer (Zamir et al., CVPR 2022) in the official layout, at a size for 2 CPU cores: transformer
blocks whose attention runs across channels (MDTA: a C/heads x C/heads map per head), so its cost is
linear in the pixel count and the graph holds no size-dependent mask or window (unlike Swin), and the
gated-dconv feed-forward (GDFN). Input `lq` only; output `lq` + residual.

As the official `Restormer` (basicsr/models/archs/restormer_arch.py): bias-free patch embedding and
output convolutions, "WithBias" LayerNorm with eps 1e-5, 3x3 + PixelUnshuffle down / PixelShuffle up;
the decoder levels below the top concatenate the skip and reduce it with a 1x1 convolution, while the
full-resolution level keeps the concatenation at 2 x dim ("NO 1x1 conv to reduce channels"): its
decoder blocks, the refinement blocks and the output convolution all run at 2 x dim. Only the depth
differs (levels, blocks, dim are configuration; the official model is 4 levels, dim 48)."""

from __future__ import annotations

from typing import Sequence

import torch
import torch.nn.functional as F
from torch import nn

from .common import LayerNorm2d, pad_to_multiple


class ChannelAttention(nn.Module):
    """Multi-Dconv head transposed attention: queries/keys/values from 1x1 + 3x3 depth-wise convs,
    attention over channels with a learnt temperature per head."""

    def __init__(self, dim: int, heads: int) -> None:
        super().__init__()
        self.heads = heads
        self.temperature = nn.Parameter(torch.ones(heads, 1, 1))
        self.qkv = nn.Conv2d(dim, dim * 3, 1, bias=False)
        self.qkv_dw = nn.Conv2d(dim * 3, dim * 3, 3, padding=1, groups=dim * 3, bias=False)
        self.project = nn.Conv2d(dim, dim, 1, bias=False)

    #: Set by `receptive.local_paths` while measuring the receptive field: the attention map (a function
    #: of the whole image) is then held constant, leaving the network's local paths.
    local_paths = False

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        n, c, h, w = x.shape
        q, k, v = self.qkv_dw(self.qkv(x)).chunk(3, dim=1)
        # N x heads x C/heads x HW: the sizes come from the traced shape, nothing is cached.
        q = q.reshape(n, self.heads, c // self.heads, h * w)
        k = k.reshape(n, self.heads, c // self.heads, h * w)
        v = v.reshape(n, self.heads, c // self.heads, h * w)
        q = F.normalize(q, dim=-1)
        k = F.normalize(k, dim=-1)
        attention = torch.softmax((q @ k.transpose(-2, -1)) * self.temperature, dim=-1)
        if self.local_paths:
            attention = attention.detach()
        out = (attention @ v).reshape(n, c, h, w)
        return self.project(out)


class GatedFeedForward(nn.Module):
    def __init__(self, dim: int, expansion: float) -> None:
        super().__init__()
        hidden = int(dim * expansion)
        self.project_in = nn.Conv2d(dim, hidden * 2, 1, bias=False)
        self.dw = nn.Conv2d(hidden * 2, hidden * 2, 3, padding=1, groups=hidden * 2, bias=False)
        self.project_out = nn.Conv2d(hidden, dim, 1, bias=False)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        a, b = self.dw(self.project_in(x)).chunk(2, dim=1)
        return self.project_out(F.gelu(a) * b)


#: The official Restormer's LayerNorm eps (NAFNet's is 1e-6).
LAYER_NORM_EPS = 1e-5


class TransformerBlock(nn.Module):
    def __init__(self, dim: int, heads: int, expansion: float) -> None:
        super().__init__()
        self.norm1 = LayerNorm2d(dim, eps=LAYER_NORM_EPS)
        self.attention = ChannelAttention(dim, heads)
        self.norm2 = LayerNorm2d(dim, eps=LAYER_NORM_EPS)
        self.ffn = GatedFeedForward(dim, expansion)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = x + self.attention(self.norm1(x))
        return x + self.ffn(self.norm2(x))


class Restormer(nn.Module):
    """Encoder-decoder of transformer blocks; level i has width `dim * 2**i` and `heads[i]` heads; the
    full-resolution decoder and the refinement run at `2 * dim` (see the module docs)."""

    inputs: tuple[str, ...] = ("lq",)
    predicts = None
    architecture = "restormer"

    def __init__(
        self,
        dim: int = 24,
        blocks: Sequence[int] = (1, 2, 2),
        heads: Sequence[int] = (1, 2, 4),
        refinement_blocks: int = 1,
        expansion: float = 2.66,
    ) -> None:
        super().__init__()
        if len(blocks) != len(heads):
            raise ValueError("network.blocks and network.heads must have the same length")
        if len(blocks) < 2:
            raise ValueError("network.blocks: a Restormer has at least 2 levels")
        levels = len(blocks)
        self.intro = nn.Conv2d(3, dim, 3, padding=1, bias=False)
        self.encoders = nn.ModuleList()
        self.downs = nn.ModuleList()
        for i in range(levels):
            c = dim * 2**i
            self.encoders.append(nn.Sequential(*[TransformerBlock(c, heads[i], expansion) for _ in range(blocks[i])]))
            if i < levels - 1:
                self.downs.append(nn.Sequential(nn.Conv2d(c, c // 2, 3, padding=1, bias=False), nn.PixelUnshuffle(2)))
        self.ups = nn.ModuleList()
        self.reduce = nn.ModuleList()
        self.decoders = nn.ModuleList()
        for i in reversed(range(levels - 1)):
            c = dim * 2 ** (i + 1)
            self.ups.append(nn.Sequential(nn.Conv2d(c, c * 2, 3, padding=1, bias=False), nn.PixelShuffle(2)))
            # After the concatenation the features have c channels: levels below the top reduce them to
            # c / 2; the top (i = 0) keeps all c = 2 x dim.
            self.reduce.append(nn.Conv2d(c, c // 2, 1, bias=False) if i > 0 else nn.Identity())
            width = c // 2 if i > 0 else c
            self.decoders.append(nn.Sequential(*[TransformerBlock(width, heads[i], expansion) for _ in range(blocks[i])]))
        self.refinement = nn.Sequential(*[TransformerBlock(2 * dim, heads[0], expansion) for _ in range(refinement_blocks)])
        self.ending = nn.Conv2d(2 * dim, 3, 3, padding=1, bias=False)
        self.multiple = 2 ** (levels - 1)

    def forward(self, lq: torch.Tensor, **_: torch.Tensor) -> torch.Tensor:
        h, w = lq.shape[-2], lq.shape[-1]
        x = pad_to_multiple(lq, self.multiple)
        feat = self.intro(x)
        skips = []
        for i, encoder in enumerate(self.encoders):
            feat = encoder(feat)
            if i < len(self.downs):
                skips.append(feat)
                feat = self.downs[i](feat)
        for up, reduce, decoder, skip in zip(self.ups, self.reduce, self.decoders, reversed(skips)):
            feat = decoder(reduce(torch.cat([up(feat), skip], dim=1)))
        out = self.ending(self.refinement(feat)) + x
        return out[:, :, :h, :w]
