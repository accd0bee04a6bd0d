"""`unicac.train`: restoration networks trained on unicac data (install with
`pip install "./python[train]"`), laid out as BasicSR users expect:

* `archs`: NAFNet (no prior, FoV prior, oracle PSF prior, blind PSF prior), a small Restormer, the
  PatchGAN discriminator;
* `data`: patches of a built dataset or of on-the-fly simulated pairs, with their FoV / PSF maps,
  augmented consistently; a sample order that survives resumption;
* `losses`: pixel, PSF-feature supervision, LPIPS (weights from `unicac weights fetch lpips`), GAN;
* `models`: the trainer (seeded, deterministic on CPU, atomic checkpoints, `--resume`, torchrun);
* `configs`: one shipped YAML config per model (`unicac-train models`);
* `export`: ONNX following docs/models.md, checked against PyTorch in onnxruntime.

Command line: `unicac-train train | export | models` (`unicac.train.cli`).
"""

from .config import ConfigError, load, validate

__all__ = ["ConfigError", "load", "validate"]
