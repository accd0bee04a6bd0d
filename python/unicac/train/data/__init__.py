"""Training and validation data: patches of a built dataset or of on-the-fly simulated pairs, with the
FoV / PSF-feature maps a model uses, augmented consistently (module `augment`), in an order that is a pure
function of (seed, sample number) so that a resumed run sees exactly the batches of an uninterrupted
one (`IterationSampler`)."""

from .datasets import IterationSampler, build_train_set, build_val_set, collate

__all__ = ["IterationSampler", "build_train_set", "build_val_set", "collate"]
