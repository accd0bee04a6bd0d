"""Architectures by config name (`network.type`), wrapped in `Restorer`: one calling convention for the
trainer, the exporter and the tests, whatever prior the network uses.

Each architecture declares, as attributes, what the rest of the code needs to know about it (never
an isinstance or name test):

* `inputs`: the contract inputs it reads (docs/models.md), `lq` first, then any of `fov`, `psf`,
  `psf_code`, `wiener`;
* `predicts`: the map it predicts from `lq` and that training supervises (`psf_code`, `psf`), or None;
* `architecture`: its name in run folders, ONNX metadata and `unicac-train models`."""

from __future__ import annotations

from typing import Any, Optional

import torch
from torch import nn

from .common import INPUT_CHANNELS, MAP_INPUTS
from .discriminator import PatchDiscriminator
from .nafnet import BlindPsfNAFNet, NAFNet
from .restormer import Restormer

#: network.type -> class; keyword arguments come from the rest of the `network` section.
NETWORKS: dict[str, type] = {"NAFNet": NAFNet, "BlindPsfNAFNet": BlindPsfNAFNet, "Restormer": Restormer}

#: Each prior model's control: a model of the same parameter count (within 1%, tested) without the
#: prior. Where the prior adds under 1% of the parameters the plain `nafnet` is that control.
CONTROLS: dict[str, str] = {
    "nafnet-fov": "nafnet",
    "nafnet-psf": "nafnet-psf-control",
    "nafnet-psf-moments": "nafnet",
    "nafnet-psf-blind": "nafnet-psf-blind-control",
    "wiener-nafnet": "nafnet",
}


class Restorer(nn.Module):
    """A restoration network and what it declares (`inputs`, `predicts`, `architecture`).

    `forward(lq, **maps)` restores (maps by input name; the ones it does not read are ignored);
    `training_outputs(lq, **maps)` also returns the map a blind network predicts (`prediction`)."""

    def __init__(self, core: nn.Module) -> None:
        super().__init__()
        self.core = core
        self.inputs: list[str] = list(core.inputs)
        self.predicts: Optional[str] = core.predicts
        self.architecture: str = core.architecture

    @property
    def needs(self) -> list[str]:
        """The maps training needs: the inputs besides `lq`, and the map a blind network predicts."""
        wanted = set(self.inputs[1:]) | ({self.predicts} if self.predicts else set())
        return [name for name in MAP_INPUTS if name in wanted]

    def forward(self, lq: torch.Tensor, **maps: Optional[torch.Tensor]) -> torch.Tensor:
        return self.training_outputs(lq, **maps)["restored"]

    def training_outputs(self, lq: torch.Tensor, **maps: Optional[torch.Tensor]) -> dict[str, torch.Tensor]:
        if self.predicts:
            restored, predicted = self.core.forward_with_prediction(lq)
            return {"restored": restored, "prediction": predicted}
        return {"restored": self.core(lq, **{name: maps.get(name) for name in self.inputs[1:]})}


def build_network(network: dict[str, Any]) -> Restorer:
    """A `Restorer` from a validated `network` config section (`type` plus the class's arguments)."""
    options = dict(network)
    cls = NETWORKS[options.pop("type")]
    return Restorer(cls(**options))


def count_parameters(module: nn.Module) -> int:
    return sum(p.numel() for p in module.parameters())


__all__ = ["CONTROLS", "INPUT_CHANNELS", "MAP_INPUTS", "NETWORKS", "PatchDiscriminator", "Restorer", "build_network",
           "count_parameters"]
