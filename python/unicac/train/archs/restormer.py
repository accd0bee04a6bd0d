"""A small Restormer (Zamir et al., CVPR 2022): transformer blocks whose attention runs across
channels (MDTA: a C/heads x C/heads map per head), so its cost is linear in the pixel count and the
graph holds no size-dependent mask or window (unlike Swin), and the gated-dconv feed-forward (GDFN).
Input `lq` only; output `lq` + residual."""

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


class TransformerBlock(nn.Module):
    def __init__(self, dim: int, heads: int, expansion: float) -> None:
        super().__init__()
        self.norm1 = LayerNorm2d(dim)
        self.attention = ChannelAttention(dim, heads)
        self.norm2 = LayerNorm2d(dim)
        self.ffn = GatedFeedForward(dim, expansion)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = x + self.attention(self.norm1(x))
        return x + self.ffn(self.norm2(x))


class Restormer(nn.Module):
    """Encoder-decoder of transformer blocks; level i has width `dim * 2**i` and `heads[i]` heads."""

    def __init__(
        self,
        dim: int = 24,
        blocks: Sequence[int] = (1, 2, 2),
        heads: Sequence[int] = (1, 2, 4),
        refinement_blocks: int = 1,
        expansion: float = 2.0,
    ) -> None:
        super().__init__()
        if len(blocks) != len(heads):
            raise ValueError("network.blocks and network.heads must have the same length")
        levels = len(blocks)
        self.intro = nn.Conv2d(3, dim, 3, padding=1)
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
            self.reduce.append(nn.Conv2d(c, c // 2, 1, bias=False))
            self.decoders.append(nn.Sequential(*[TransformerBlock(c // 2, heads[i], expansion) for _ in range(blocks[i])]))
        self.refinement = nn.Sequential(*[TransformerBlock(dim, heads[0], expansion) for _ in range(refinement_blocks)])
        self.ending = nn.Conv2d(dim, 3, 3, padding=1)
        self.multiple = 2 ** (levels - 1)

    def forward(self, lq: torch.Tensor) -> torch.Tensor:
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
