"""Architectures by config name (`network.type`), wrapped in `Restorer`: one calling convention for the
trainer, the exporter and the tests, whatever prior the network uses."""

from __future__ import annotations

from typing import Any, Optional

import torch
from torch import nn

from .discriminator import PatchDiscriminator
from .nafnet import BlindPsfNAFNet, NAFNet
from .restormer import Restormer

#: network.type -> class; keyword arguments come from the rest of the `network` section.
NETWORKS: dict[str, type] = {"NAFNet": NAFNet, "BlindPsfNAFNet": BlindPsfNAFNet, "Restormer": Restormer}


class Restorer(nn.Module):
    """A restoration network and the ONNX inputs it uses (`lq`, then any of `fov`, `psf`).

    `forward(lq, fov=None, psf=None)` restores; `training_outputs(lq, fov, psf)` also returns the
    predicted PSF features of a blind-PSF network (supervised during training)."""

    def __init__(self, core: nn.Module, inputs: list[str], architecture: str) -> None:
        super().__init__()
        self.core = core
        self.inputs = inputs
        self.architecture = architecture
        self.predicts_psf = isinstance(core, BlindPsfNAFNet)

    @property
    def needs_psf(self) -> bool:
        """Whether training needs the true PSF-feature map (as input or as supervision)."""
        return "psf" in self.inputs or self.predicts_psf

    @property
    def needs_fov(self) -> bool:
        return "fov" in self.inputs

    def forward(self, lq: torch.Tensor, fov: Optional[torch.Tensor] = None, psf: Optional[torch.Tensor] = None) -> torch.Tensor:
        return self.training_outputs(lq, fov, psf)["restored"]

    def training_outputs(
        self, lq: torch.Tensor, fov: Optional[torch.Tensor] = None, psf: Optional[torch.Tensor] = None
    ) -> dict[str, torch.Tensor]:
        if self.predicts_psf:
            restored, predicted = self.core.forward_with_psf(lq)
            return {"restored": restored, "psf_pred": predicted}
        if "fov" in self.inputs:
            return {"restored": self.core(lq, fov)}
        if "psf" in self.inputs:
            return {"restored": self.core(lq, psf)}
        return {"restored": self.core(lq)}


def build_network(network: dict[str, Any]) -> Restorer:
    """A `Restorer` from a validated `network` config section (`type` plus the class's arguments)."""
    options = dict(network)
    kind = options.pop("type")
    cls = NETWORKS[kind]
    core = cls(**options)
    prior = options.get("prior")
    inputs = ["lq"] + ([prior] if kind == "NAFNet" and prior else [])
    architecture = kind.lower() + (f"-{prior}" if kind == "NAFNet" and prior else "")
    return Restorer(core, inputs, architecture)


def count_parameters(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())


__all__ = ["NETWORKS", "PatchDiscriminator", "Restorer", "build_network", "count_parameters"]
