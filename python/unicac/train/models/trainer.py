"""The training loop: one restoration network, its losses, seeded and deterministic on CPU.

Run folder (`--out RUN_DIR`):

    config.yml               the resolved config (every default filled in)
    run.json                 architecture, inputs, config_sha256, unicac version, parameters
    checkpoints/latest.pt    full state after the last saved iteration (atomic: temp file + rename)
    log.csv, log.jsonl       training loss / lr / it/s every print_freq iterations, validation PSNR/SSIM
    curves.png               the curves

Reproducibility: weights are initialised from `manual_seed`; sample k of the stream is a pure function
of (manual_seed, k) (see `data`); `torch.use_deterministic_algorithms(True)`. A run resumed from a
checkpoint therefore reaches bit-identical weights to an uninterrupted run on the same machine and
thread count (tests/test_train.py checks equality, tolerance 0).

Distributed (torchrun): when WORLD_SIZE > 1 the process group is initialised (gloo on CPU), the model
is wrapped in DistributedDataParallel, rank r takes its own slice of every iteration's samples, and
only rank 0 validates, logs and writes checkpoints.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any, Optional

import torch
import torch.nn.functional as F
from torch import nn
from torch.utils.data import DataLoader

from .. import config as config_mod
from ..archs import PatchDiscriminator, Restorer, build_network, count_parameters
from ..archs.nafnet import PSF_FEATURE_SCALE
from ..data import IterationSampler, build_train_set, build_val_set, collate
from ..files import atomic_write, atomic_write_bytes, clean_temporaries
from ..logger import Progress, RunLog
from ..losses import LPIPS, gan_loss, pixel_loss
from ..metrics import psnr, ssim


class RunError(RuntimeError):
    """A run folder that cannot be started or resumed as asked (the message says why)."""


def _unicac_version() -> str:
    try:
        import unicac

        return str(unicac.__version__)
    except Exception:  # noqa: BLE001 - the version is provenance only
        return "unknown"


class RunFolder:
    """The files of a run (see the module docs)."""

    def __init__(self, path: "os.PathLike[str] | str") -> None:
        self.path = Path(path)
        self.config = self.path / "config.yml"
        self.info = self.path / "run.json"
        self.checkpoint = self.path / "checkpoints" / "latest.pt"

    def load_config(self) -> dict[str, Any]:
        if not self.config.is_file():
            raise RunError(f"{self.path}: not a unicac-train run folder (no config.yml)")
        return config_mod.load(self.config)

    def load_checkpoint(self) -> dict[str, Any]:
        if not self.checkpoint.is_file():
            raise RunError(f"{self.path}: no checkpoint yet ({self.checkpoint} is missing)")
        return torch.load(self.checkpoint, map_location="cpu", weights_only=True)


class TrainingView(nn.Module):
    """`forward` = the restorer's training outputs (what DistributedDataParallel wraps)."""

    def __init__(self, restorer: Restorer) -> None:
        super().__init__()
        self.restorer = restorer

    def forward(self, lq: torch.Tensor, fov: Optional[torch.Tensor], psf: Optional[torch.Tensor]) -> dict[str, torch.Tensor]:
        return self.restorer.training_outputs(lq, fov, psf)


def _distributed() -> tuple[int, int]:
    """(rank, world size); initialises the process group under torchrun (WORLD_SIZE > 1)."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        return 0, 1
    import torch.distributed as dist

    if not dist.is_initialized():
        dist.init_process_group("gloo")
    return dist.get_rank(), dist.get_world_size()


def load_generator_weights(source: str) -> dict[str, torch.Tensor]:
    """Generator weights from a run folder (its latest checkpoint) or a checkpoint file."""
    path = Path(source)
    if path.is_dir():
        return RunFolder(path).load_checkpoint()["net"]
    if not path.is_file():
        raise RunError(f"path.pretrain_network_g: {path} is neither a run folder nor a checkpoint file")
    state = torch.load(path, map_location="cpu", weights_only=True)
    return state["net"] if "net" in state else state


class Trainer:
    """Prepares everything a run needs (and fails on bad input) before the first iteration."""

    def __init__(self, config: dict[str, Any], run_dir: "os.PathLike[str] | str", resume: bool = False,
                 quiet: bool = False) -> None:
        self.config = config
        self.run = RunFolder(run_dir)
        self.rank, self.world = _distributed()
        self.quiet = quiet or self.rank != 0
        self.config_sha256 = config_mod.sha256(config)
        seed = config["manual_seed"]
        torch.use_deterministic_algorithms(True)
        torch.manual_seed(seed)  # same initial weights on every rank

        self.net = build_network(config["network"])
        self.view: nn.Module = TrainingView(self.net)
        losses = config["train"]["losses"]
        self.lpips = LPIPS(losses["perceptual"]["net"]) if losses["perceptual"]["weight"] > 0 else None
        self.use_gan = losses["gan"]["weight"] > 0
        if self.net.predicts_psf and losses["psf"]["weight"] <= 0:
            raise config_mod.ConfigError("train.losses.psf.weight: a blind-PSF network needs a positive PSF supervision weight")
        self.discriminator = PatchDiscriminator(losses["gan"]["width"]) if self.use_gan else None
        pretrain = config["path"]["pretrain_network_g"]
        if pretrain and not resume:
            try:
                self.net.load_state_dict(load_generator_weights(pretrain))
            except RuntimeError as error:
                raise RunError(f"path.pretrain_network_g: {pretrain} does not fit {self.net.architecture}: {error}") from error

        optim = config["train"]["optim"]
        kind = torch.optim.AdamW if optim["type"] == "AdamW" else torch.optim.Adam
        self.optimizer = kind(self.net.parameters(), lr=optim["lr"], weight_decay=optim["weight_decay"], betas=tuple(optim["betas"]))
        total = config["train"]["total_iter"]
        sched = config["train"]["scheduler"]
        if sched["type"] == "CosineAnnealingLR":
            self.scheduler: Any = torch.optim.lr_scheduler.CosineAnnealingLR(self.optimizer, T_max=total, eta_min=sched["eta_min"])
        else:
            self.scheduler = torch.optim.lr_scheduler.LambdaLR(self.optimizer, lambda _: 1.0)
        self.optimizer_d = (
            torch.optim.Adam(self.discriminator.parameters(), lr=losses["gan"]["lr"], betas=(0.5, 0.99))
            if self.discriminator is not None else None
        )

        data = config["datasets"]
        self.train_set = build_train_set(data["train"], seed, self.net.needs_fov, self.net.needs_psf)
        self.val_set = build_val_set(data["val"], self.net.needs_fov, self.net.needs_psf) if self.rank == 0 else None

        self.start_iter = 0
        if resume:
            self._resume()
        elif self.run.checkpoint.exists():
            raise RunError(f"{self.run.path}: already holds a run (checkpoints/latest.pt); pass --resume to continue it, or another --out")
        if self.world > 1:
            from torch.nn.parallel import DistributedDataParallel

            self.view = DistributedDataParallel(self.view)
            if self.discriminator is not None:
                self.discriminator = DistributedDataParallel(self.discriminator)  # type: ignore[assignment]
        self.log = RunLog(self.run.path, resume_iter=self.start_iter if resume else None)

    # -- state -----------------------------------------------------------------------------------

    def _state(self, iteration: int) -> dict[str, Any]:
        state = {
            "iteration": iteration,
            "net": self.net.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "scheduler": self.scheduler.state_dict(),
            "config_sha256": self.config_sha256,
            "architecture": self.net.architecture,
            "inputs": self.net.inputs,
            "torch_rng": torch.get_rng_state(),
        }
        if self.discriminator is not None and self.optimizer_d is not None:
            disc = self.discriminator.module if hasattr(self.discriminator, "module") else self.discriminator
            state["discriminator"] = disc.state_dict()
            state["optimizer_d"] = self.optimizer_d.state_dict()
        return state

    def save_checkpoint(self, iteration: int) -> None:
        if self.rank != 0:
            return
        state = self._state(iteration)
        atomic_write(self.run.checkpoint, lambda handle: torch.save(state, handle))
        self.log.flush()

    def _resume(self) -> None:
        if not self.run.checkpoint.is_file():
            raise RunError(f"--resume: {self.run.path} holds no checkpoint to resume (checkpoints/latest.pt)")
        clean_temporaries(self.run.checkpoint.parent)
        state = self.run.load_checkpoint()
        if state.get("config_sha256") != self.config_sha256:
            raise RunError(
                f"--resume: the config differs from the one {self.run.path} was started with "
                f"(compare with {self.run.config}); resume with the same config"
            )
        self.net.load_state_dict(state["net"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.scheduler.load_state_dict(state["scheduler"])
        if self.discriminator is not None and self.optimizer_d is not None:
            self.discriminator.load_state_dict(state["discriminator"])
            self.optimizer_d.load_state_dict(state["optimizer_d"])
        torch.set_rng_state(state["torch_rng"])
        self.start_iter = int(state["iteration"])

    def _write_run_info(self) -> None:
        if self.rank != 0:
            return
        self.run.path.mkdir(parents=True, exist_ok=True)
        config_mod.dump(self.config, self.run.config)
        info = {
            "name": self.config["name"],
            "architecture": self.net.architecture,
            "inputs": self.net.inputs,
            "params": count_parameters(self.net),
            "config_sha256": self.config_sha256,
            "unicac_version": _unicac_version(),
            "world_size": self.world,
        }
        atomic_write_bytes(self.run.info, (json.dumps(info, indent=2) + "\n").encode())

    # -- loop ------------------------------------------------------------------------------------

    def _losses(self, batch: dict[str, torch.Tensor], iteration: int) -> tuple[torch.Tensor, torch.Tensor]:
        losses = self.config["train"]["losses"]
        out = self.view(batch["lq"], batch.get("fov"), batch.get("psf"))
        restored = out["restored"]
        loss = losses["pixel"]["weight"] * pixel_loss(losses["pixel"]["type"], restored, batch["gt"])
        if "psf_pred" in out:
            loss = loss + losses["psf"]["weight"] * F.l1_loss(out["psf_pred"] * PSF_FEATURE_SCALE, batch["psf"] * PSF_FEATURE_SCALE)
        if self.lpips is not None:
            loss = loss + losses["perceptual"]["weight"] * self.lpips(restored.clamp(0, 1), batch["gt"])
        if self.discriminator is not None and iteration >= losses["gan"]["start_iter"]:
            loss = loss + losses["gan"]["weight"] * gan_loss(self.discriminator(restored), real=True)
        return loss, restored

    def _step(self, batch: dict[str, torch.Tensor], iteration: int) -> float:
        self.net.train()
        if self.discriminator is not None:
            self.discriminator.requires_grad_(False)
        loss, restored = self._losses(batch, iteration)
        self.optimizer.zero_grad(set_to_none=True)
        loss.backward()
        clip = self.config["train"]["grad_clip"]
        if clip:
            torch.nn.utils.clip_grad_norm_(self.net.parameters(), clip)
        self.optimizer.step()
        self.scheduler.step()
        if self.discriminator is not None and self.optimizer_d is not None and iteration >= self.config["train"]["losses"]["gan"]["start_iter"]:
            self.discriminator.requires_grad_(True)
            d_loss = gan_loss(self.discriminator(batch["gt"]), real=True) + gan_loss(self.discriminator(restored.detach()), real=False)
            self.optimizer_d.zero_grad(set_to_none=True)
            d_loss.backward()
            self.optimizer_d.step()
        return float(loss.detach())

    @torch.no_grad()
    def validate(self) -> dict[str, float]:
        """Mean PSNR (dB) / SSIM of the restored and of the unrestored validation images (fixed set)."""
        assert self.val_set is not None
        self.net.eval()
        scores: dict[str, list[torch.Tensor]] = {"psnr_db": [], "ssim": [], "input_psnr_db": [], "input_ssim": []}
        loader = DataLoader(self.val_set, batch_size=1, shuffle=False, num_workers=0, collate_fn=collate)
        for batch in loader:
            restored = self.net(batch["lq"], batch.get("fov"), batch.get("psf")).clamp(0, 1)
            scores["psnr_db"].append(psnr(restored, batch["gt"]))
            scores["ssim"].append(ssim(restored, batch["gt"]))
            scores["input_psnr_db"].append(psnr(batch["lq"], batch["gt"]))
            scores["input_ssim"].append(ssim(batch["lq"], batch["gt"]))
        self.net.train()
        return {key: float(torch.cat(values).mean()) for key, values in scores.items()}

    def train(self, stop_after: Optional[int] = None) -> dict[str, Any]:
        """Runs iterations start .. total_iter (or stops after iteration `stop_after`, as a kill would,
        without a final checkpoint); returns the last validation scores."""
        cfg = self.config
        total = cfg["train"]["total_iter"]
        every_val, every_ckpt, every_log = cfg["val"]["val_freq"], cfg["logger"]["save_checkpoint_freq"], cfg["logger"]["print_freq"]
        self._write_run_info()
        train_cfg = cfg["datasets"]["train"]
        batch = train_cfg["batch_size"]
        sampler = IterationSampler(self.start_iter, total, batch, self.rank, self.world)
        loader = DataLoader(self.train_set, batch_size=batch, sampler=sampler, num_workers=train_cfg["num_workers"],
                            collate_fn=collate, drop_last=False)
        progress = Progress(self.start_iter, total, every_log, enabled=not self.quiet)
        recent: list[float] = []
        last_val: dict[str, Any] = {}
        t0 = time.perf_counter()
        iteration = self.start_iter
        for iteration, data in enumerate(loader, start=self.start_iter + 1):
            recent.append(self._step(data, iteration - 1))
            progress.update(iteration, recent[-1])
            if self.rank == 0 and (iteration % every_log == 0 or iteration == total):
                self.log.add(iter=iteration, kind="train", loss=sum(recent) / len(recent), lr=self.scheduler.get_last_lr()[0],
                             it_per_s=progress.rate(iteration), seconds=time.perf_counter() - t0)
                recent = []
            if self.rank == 0 and (iteration % every_val == 0 or iteration == total):
                last_val = self.validate()
                self.log.add(iter=iteration, kind="val", psnr_db=last_val["psnr_db"], ssim=last_val["ssim"],
                             seconds=time.perf_counter() - t0)
                progress.message(
                    f"iter {iteration}: val PSNR {last_val['psnr_db']:.2f} dB, SSIM {last_val['ssim']:.4f} "
                    f"(input {last_val['input_psnr_db']:.2f} dB, {last_val['input_ssim']:.4f})"
                )
            if stop_after is not None and iteration >= stop_after:
                return last_val
            if iteration % every_ckpt == 0 or iteration == total:
                self.save_checkpoint(iteration)
        if self.rank == 0:
            self.log.flush()
            self.log.plot()
            if last_val:
                info = json.loads(self.run.info.read_text())
                info["final_validation"] = last_val
                info["iterations"] = iteration
                atomic_write_bytes(self.run.info, (json.dumps(info, indent=2) + "\n").encode())
        return last_val
