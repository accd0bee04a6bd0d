"""The training loop (`Trainer`) and run folders (`RunFolder`)."""

from .trainer import RunError, RunFolder, Trainer

__all__ = ["RunError", "RunFolder", "Trainer"]
