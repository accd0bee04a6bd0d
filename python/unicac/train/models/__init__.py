"""The training loop (`Trainer`) and run folders (`RunFolder`)."""

from .trainer import NonFiniteTraining, RunError, RunFolder, Trainer

__all__ = ["NonFiniteTraining", "RunError", "RunFolder", "Trainer"]
