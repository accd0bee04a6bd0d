"""The training loop: one restoration network, its losses, seeded and deterministic on CPU.

Run folder (`--out RUN_DIR`):

    config.yml               the resolved config (every default filled in)
    run.json                 architecture, inputs, config_sha256, unicac version, parameters
    checkpoints/latest.pt    full state after the last saved iteration (atomic: temp file + rename);
                             a loss or weight that turns NaN/inf stops the run before it is saved
    log.csv, log.jsonl       training loss / lr / it/s every print_freq iterations, validation PSNR/SSIM
    curves.png               the curves
    .lock                    held (flock) by the process training the run: a second process training
                             the same folder is refused rather than interleaving its checkpoints

Reproducibility: weights are initialised from `manual_seed`; sample k of the stream is a pure function
of (manual_seed, k) (see `data`); `torch.use_deterministic_algorithms(True)`. A run resumed from a
checkpoint therefore reaches bit-identical weights to an uninterrupted run on the same machine and
thread count (tests/test_train.py checks equality, tolerance 0), on CPU; on CUDA the ops without a
deterministic kernel warn instead of failing, so equality there is not promised.

Checks before the first iteration (docs/models.md): a patch smaller than twice the dataset's largest
PSF kernel, or a network whose receptive field is narrower than that kernel, is refused (with
`train.allow_small_patch` / `train.allow_small_receptive_field`: a warning). Training pairs whose
LQ-GT error is dominated by misregistration or shading rather than blur (their recorded checks,
docs/dataset.md "Pair checks": a `dataset build --task full` set of a distorting lens) are refused,
naming the lenses (with `train.allow_misaligned`: a warning).

Device: `train.device` (auto = cuda when available), mixed precision `train.amp` (auto = bf16 on a
GPU that has it, else fp16 with a gradient scaler; off on CPU) and `train.channels_last` (auto = on
for cuda); `train.compile: on` runs the training step through torch.compile (a session setting: after a
minute of compiling, faster steps on CPU, with rounding that differs slightly from eager steps, so a
resumed run is bit-identical to an uninterrupted one only with the same setting).
`train.time_budget_s` stops the session cleanly: a checkpoint and a validation at the iteration
reached, exportable as it is; `--resume` continues.

Distributed (torchrun): when WORLD_SIZE > 1 the process group is initialised (gloo on CPU), the model
is wrapped in DistributedDataParallel, rank r takes its own slice of every iteration's samples, and
only rank 0 validates, logs and writes checkpoints.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import os
import pickle
import shutil
import sys
import time
from pathlib import Path
from typing import Any, Optional

import torch
import torch.nn.functional as F
from torch import nn
from torch.utils.data import DataLoader

from unicac.dataset import PSF_BASIS_FILES, copy_psf_basis
from unicac.outputs import clean_stale_temporaries, write_bytes, write_with

from .. import config as config_mod
from ..archs import PatchDiscriminator, Restorer, build_network, count_parameters
from ..archs.nafnet import PRIOR_SCALE
from ..archs.receptive import receptive_field_px
from ..data import IterationSampler, build_train_set, build_val_set, collate
from ..logger import LOG_FILES, SEVERE_SCORES, VALIDATION_LOG_FIELDS, Progress, RunLog
from ..losses import LPIPS, MIN_SIDE_PX, frequency_loss, gan_loss, pixel_loss
from ..metrics import psnr, ssim


class RunError(RuntimeError):
    """A run folder that cannot be started or resumed as asked (the message says why)."""


class NonFiniteTraining(RunError):
    """A loss or the weights became NaN or infinite: the run stops, its last checkpoint kept."""


def load_checkpoint_file(path: Path) -> dict[str, Any]:
    """A checkpoint's state (a dict holding `net`), or RunError naming the file."""
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except (OSError, EOFError, RuntimeError, ValueError, pickle.UnpicklingError) as error:
        # torch's messages run over many lines; the first says what failed.
        text = str(error).strip()
        reason = text.splitlines()[0].split(". ")[0] if text else type(error).__name__
        raise RunError(f"{path}: not a readable PyTorch checkpoint ({reason})") from error
    if not isinstance(state, dict):
        raise RunError(f"{path}: not a checkpoint (holds a {type(state).__name__}, not a state dict)")
    return state


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
        self.lock = self.path / ".lock"
        #: A psf_code model's PSF basis, kept with the run (its dataset may not outlive it).
        self.psf_basis = self.path / "psf_basis"

    def outputs(self, resume: bool) -> list[Path]:
        """The files a run writes here (a resumed run keeps the config.yml it was started with)."""
        files = [self.info, self.checkpoint, self.lock] + [self.path / name for name in LOG_FILES]
        files += [self.psf_basis / name for name in PSF_BASIS_FILES]
        return files if resume else [self.config] + files

    def hold(self) -> Any:
        """Makes the folder and takes its lock for as long as the returned handle lives (the kernel
        releases it when the process ends, SIGKILL included); refuses a folder another process holds."""
        self.path.mkdir(parents=True, exist_ok=True)
        handle = open(self.lock, "a")
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            handle.close()
            raise RunError(f"{self.path}: another process is training this run; wait for it to end, or "
                           "train into another --out") from None
        return handle

    def load_config(self) -> dict[str, Any]:
        if not self.path.is_dir():
            raise RunError(f"{self.path}: no such run folder")
        if not self.config.is_file():
            raise RunError(f"{self.path}: not a unicac-train run folder (no config.yml)")
        return config_mod.load(self.config)

    def load_checkpoint(self) -> dict[str, Any]:
        if not self.checkpoint.is_file():
            raise RunError(f"{self.checkpoint}: missing (the run has saved no checkpoint yet)")
        state = load_checkpoint_file(self.checkpoint)
        if "net" not in state:
            raise RunError(f"{self.checkpoint}: not a unicac-train checkpoint (no 'net' weights)")
        return state


class TrainingView(nn.Module):
    """`forward` = the restorer's training outputs (what DistributedDataParallel wraps)."""

    def __init__(self, restorer: Restorer) -> None:
        super().__init__()
        self.restorer = restorer

    def forward(self, lq: torch.Tensor, **maps: torch.Tensor) -> dict[str, torch.Tensor]:
        return self.restorer.training_outputs(lq, **maps)


#: C++ compilers Inductor can build CPU kernels with (it reads CXX first).
CPP_COMPILERS = ("g++", "clang++", "c++")


def require_cpp_compiler(setting: str) -> None:
    """Refuses `setting` (a torch.compile request, named as the user gave it) without a C++ compiler:
    checked before any work, where Inductor would fail only at the first step, with a long trace."""
    compiler = os.environ.get("CXX") or next(filter(shutil.which, CPP_COMPILERS), None)
    if compiler is None or shutil.which(compiler) is None:
        found = f"CXX={compiler} is not a program" if compiler else f"none of {', '.join(CPP_COMPILERS)} found"
        raise config_mod.ConfigError(
            f"{setting} needs a C++ compiler for torch.compile's kernels ({found}); install one (Debian: "
            "apt-get install g++) or leave compiling off")


def _compiled(view: nn.Module, quiet: bool) -> nn.Module:
    """`view` through torch.compile (`train.compile: on`): the training step's forward and backward as
    Inductor's fused kernels, compiled at the first step. Validation and export keep the eager network."""
    if not quiet:
        sys.stderr.write("unicac-train: compiling the training step (torch.compile) at the first iteration: "
                         "about a minute\n")
    return torch.compile(view)


def _warn(message: str) -> None:
    sys.stderr.write(f"unicac-train: warning: {message}\n")


def select_device(train: dict[str, Any]) -> tuple[torch.device, Optional[torch.dtype], bool]:
    """(device, autocast dtype or None, channels_last) from `train.device/amp/channels_last`."""
    asked = train["device"]
    if asked == "cuda" and not torch.cuda.is_available():
        raise config_mod.ConfigError("train.device: cuda was asked for, but torch sees no CUDA device (use cpu or auto)")
    cuda = asked == "cuda" or (asked == "auto" and torch.cuda.is_available())
    device = torch.device("cuda" if cuda else "cpu")
    amp = train["amp"]
    if amp == "auto":
        amp = ("bf16" if torch.cuda.is_bf16_supported() else "fp16") if cuda else "off"
    if amp == "fp16" and not cuda:
        raise config_mod.ConfigError("train.amp: fp16 autocast needs a CUDA device; use bf16 or off on CPU")
    dtype = {"off": None, "bf16": torch.bfloat16, "fp16": torch.float16}[amp]
    channels_last = train["channels_last"] == "on" or (train["channels_last"] == "auto" and cuda)
    return device, dtype, channels_last


def _distributed(cuda: bool) -> tuple[int, int]:
    """(rank, world size); initialises the process group under torchrun (WORLD_SIZE > 1): gloo on CPU,
    nccl with one GPU per process (LOCAL_RANK) on CUDA."""
    world = int(os.environ.get("WORLD_SIZE", "1"))
    if world <= 1:
        return 0, 1
    import torch.distributed as dist

    if cuda:
        torch.cuda.set_device(int(os.environ.get("LOCAL_RANK", "0")))
    if not dist.is_initialized():
        dist.init_process_group("nccl" if cuda else "gloo")
    return dist.get_rank(), dist.get_world_size()


def load_generator_weights(source: str, net: Restorer, wiener_nsr: float) -> dict[str, torch.Tensor]:
    """Generator weights from a run folder (its latest checkpoint), a checkpoint file or an exported
    model (`.onnx`: `onnx_weights`, checked against the file)."""
    path = Path(source)
    if path.is_dir():
        return RunFolder(path).load_checkpoint()["net"]
    if not path.is_file():
        raise RunError(f"path.pretrain_network_g: {path} is neither a run folder, a checkpoint nor an ONNX file")
    if path.suffix.lower() == ".onnx":
        from ..onnx_weights import OnnxWeightsError, load_onnx_weights

        try:
            return load_onnx_weights(net, path, wiener_nsr=wiener_nsr)
        except OnnxWeightsError as error:
            raise RunError(f"path.pretrain_network_g: {error}") from error
    state = load_checkpoint_file(path)
    return state["net"] if "net" in state else state


class Trainer:
    """Prepares everything a run needs (and fails on bad input) before the first iteration."""

    def __init__(self, config: dict[str, Any], run_dir: "os.PathLike[str] | str", resume: bool = False,
                 quiet: bool = False) -> None:
        self.config = config
        self.run = RunFolder(run_dir)
        self.resumed = resume
        self.saved_iter: Optional[int] = None  # the iteration of the checkpoint on disk
        train = config["train"]
        if train["device"] != "cpu":
            # cuBLAS needs this for deterministic matrix products; it is read when CUDA starts.
            os.environ.setdefault("CUBLAS_WORKSPACE_CONFIG", ":4096:8")
        self.device, self.amp_dtype, self.channels_last = select_device(train)
        if train["compile"] == "on":
            require_cpp_compiler("train.compile: on")
        self.rank, self.world = _distributed(self.device.type == "cuda")
        if self.device.type == "cuda" and self.world > 1:
            self.device = torch.device("cuda", torch.cuda.current_device())
        self.quiet = quiet or self.rank != 0
        self.config_sha256 = config_mod.sha256(config)
        seed = config["manual_seed"]
        torch.use_deterministic_algorithms(True, warn_only=self.device.type == "cuda")
        torch.manual_seed(seed)  # same initial weights on every rank

        self.net = build_network(config["network"])
        losses = train["losses"]
        self.lpips = LPIPS(losses["perceptual"]["net"]) if losses["perceptual"]["weight"] > 0 else None
        crop = config["datasets"]["val"]["crop_px"]
        if self.lpips is not None and crop is not None and crop < MIN_SIDE_PX[self.lpips.net] and self.rank == 0:
            _warn(f"datasets.val.crop_px: {crop} px is below the {MIN_SIDE_PX[self.lpips.net]} px that LPIPS-"
                  f"{self.lpips.net} takes: validation logs no LPIPS")
        self._check_losses(losses, resume)
        self.discriminator = PatchDiscriminator(losses["gan"]["width"]) if losses["gan"]["weight"] > 0 else None
        pretrain = config["path"]["pretrain_network_g"]
        if pretrain and not resume:
            weights = load_generator_weights(pretrain, self.net, config["datasets"]["train"]["wiener_nsr"])
            try:
                self.net.load_state_dict(weights)
            except RuntimeError as error:
                raise RunError(f"path.pretrain_network_g: {pretrain} does not fit {self.net.architecture}: {error}") from error
        self.ema: Optional[torch.optim.swa_utils.AveragedModel] = None
        if train["ema_decay"] is not None:
            self.ema = torch.optim.swa_utils.AveragedModel(
                self.net, multi_avg_fn=torch.optim.swa_utils.get_ema_multi_avg_fn(train["ema_decay"]))
        memory = torch.channels_last if self.channels_last else torch.contiguous_format
        for module in (self.net, self.ema, self.lpips, self.discriminator):
            if module is not None:
                module.to(self.device, memory_format=memory)
        self.view: nn.Module = TrainingView(self.net)

        optim = train["optim"]
        kind = torch.optim.AdamW if optim["type"] == "AdamW" else torch.optim.Adam
        self.optimizer = kind(self.net.parameters(), lr=optim["lr"], weight_decay=optim["weight_decay"], betas=tuple(optim["betas"]))
        total = train["total_iter"]
        sched = train["scheduler"]
        if sched["type"] == "CosineAnnealingLR":
            self.scheduler: Any = torch.optim.lr_scheduler.CosineAnnealingLR(self.optimizer, T_max=total, eta_min=sched["eta_min"])
        else:
            self.scheduler = torch.optim.lr_scheduler.LambdaLR(self.optimizer, lambda _: 1.0)
        self.optimizer_d = (
            torch.optim.Adam(self.discriminator.parameters(), lr=losses["gan"]["lr"], betas=(0.5, 0.99))
            if self.discriminator is not None else None
        )
        # fp16 gradients underflow without loss scaling; bf16 has float32's range and needs none.
        self.scaler = torch.amp.GradScaler("cuda") if self.amp_dtype == torch.float16 else None

        data = config["datasets"]
        needs = self.net.needs
        self.train_set = build_train_set(data["train"], seed, needs)
        self.val_set = build_val_set(data["val"], needs) if self.rank == 0 else None
        self.recipe = self._check_recipe()

        self.start_iter = 0
        self.wall_time_s = 0.0
        self.stopped_by_budget = False
        if resume:
            self._resume()
        elif self.run.checkpoint.exists():
            raise RunError(f"{self.run.path}: already holds a run (checkpoints/latest.pt); pass --resume to continue it, or another --out")
        if self.world > 1:
            from torch.nn.parallel import DistributedDataParallel

            self.view = DistributedDataParallel(self.view)
            if self.discriminator is not None:
                self.discriminator = DistributedDataParallel(self.discriminator)  # type: ignore[assignment]
        if train["compile"] == "on":
            self.view = _compiled(self.view, quiet=self.quiet)
        self.log = RunLog(self.run.path, resume_iter=self.start_iter if resume else None)

    # -- checks ----------------------------------------------------------------------------------

    def _check_losses(self, losses: dict[str, Any], resume: bool) -> None:
        arch = self.net.architecture
        if self.net.predicts and losses["psf"]["weight"] <= 0:
            raise config_mod.ConfigError(f"train.losses.psf.weight: {arch} predicts the {self.net.predicts} map and needs a positive supervision weight")
        if not self.net.predicts and losses["psf"]["weight"] > 0:
            raise config_mod.ConfigError(f"train.losses.psf.weight: {arch} predicts no PSF map; set it to 0")
        gan = losses["gan"]
        if gan["weight"] > 0 and not self.config["path"]["pretrain_network_g"] and gan["start_iter"] == 0 and not resume:
            raise config_mod.ConfigError(
                "path.pretrain_network_g: a GAN fine-tunes a trained generator: give --init-from RUN (a finished "
                "nafnet run); to train from scratch instead, set train.losses.gan.start_iter > 0 (pixel-loss warm-up)"
            )

    def _check_recipe(self) -> dict[str, Any]:
        """The recipe's numbers (recorded in run.json), after the patch and receptive-field checks."""
        train, data = self.config["train"], self.config["datasets"]["train"]
        patch = data["patch_px"]
        recipe: dict[str, Any] = {
            "patch_px": patch, "batch_size": data["batch_size"], "total_iter": train["total_iter"],
            "device": str(self.device), "amp": str(self.amp_dtype).replace("torch.", "") if self.amp_dtype else "off",
            "channels_last": self.channels_last, "compile": train["compile"],  # this session's
            "largest_kernel_px": None, "receptive_field_px": None,
            "receptive_field_exact": None, "psf_basis_sha256": None, "pair_checks": None,
            "dataset_lenses_sha256": None,
        }
        if "psf_code" in self.net.needs and data["type"] == "unicac":
            recipe["psf_basis_sha256"] = self.train_set.folder.psf_basis()["sha256"]
        if data["type"] != "unicac":
            return recipe  # on-the-fly lenses: their kernels are not known before they are traced
        folder = self.train_set.folder
        # Which library, grading and split the model learned from: a rebuilt dataset (the `small` scale
        # designs by evaluations, the same everywhere) can be matched to the run by this digest.
        recipe["dataset_lenses_sha256"] = hashlib.sha256((folder.root / "lenses.jsonl").read_bytes()).hexdigest()
        recipe["pair_checks"] = self._check_alignment(folder, data["split"])
        kernel = folder.largest_kernel_px(data["split"])
        if kernel is None:
            return recipe
        recipe["largest_kernel_px"] = kernel
        where = f"{folder.root}/psf/*/table.json"
        if patch < 2 * kernel:
            message = (f"datasets.train.patch_px: {patch} px is less than twice the dataset's largest PSF kernel "
                       f"({kernel} px, {where}): such patches cannot hold a blurred detail and the context it came "
                       f"from; use --patch-px {2 * kernel} or more")
            if not train["allow_small_patch"]:
                raise config_mod.ConfigError(message + " (--allow-small-patch trains anyway)")
            _warn(message)
        side = 32
        while side < 2 * kernel:
            side *= 2
        key = json.dumps(self.config["network"], sort_keys=True)
        width, exact = receptive_field_px(self.net, start_side_px=side, key=key, enough_px=kernel)
        recipe["receptive_field_px"], recipe["receptive_field_exact"] = width, exact
        if width < kernel:
            message = (f"network: {self.net.architecture}'s receptive field is {width} px, narrower than the dataset's "
                       f"largest PSF kernel ({kernel} px, {where}); it cannot undo blur wider than it sees: give it "
                       "more levels or blocks (e.g. the 4-level configs, `unicac-train models --receptive-field`)")
            if not train["allow_small_receptive_field"]:
                raise config_mod.ConfigError(message + " (--allow-small-receptive-field trains anyway)")
            _warn(message)
        return recipe

    def _check_alignment(self, folder: Any, split: str) -> dict[str, Any]:
        """The training pairs' input-vs-target error from their recorded checks; refuses (or warns with
        `train.allow_misaligned`) when a lens's pairs are dominated by misregistration or shading."""
        checks = folder.pair_checks(split)
        measured = [c for c in checks.values() if c["checked"]]
        summary: dict[str, Any] = {
            "task": folder.manifest.get("task", "full"),
            "lenses": len(checks),
            "measured_lenses": len(measured),
            "mean_lq_gt_psnr_db": (sum(c["mean_lq_gt_psnr_db"] for c in measured) / len(measured)) if measured else None,
            "flagged": sorted(lens for lens, c in checks.items() if c["flag"]),
        }
        if not measured:
            _warn(f"{folder.root}/pairs.jsonl: the {split} pairs carry no checks (a dataset built before they were "
                  "recorded): whether input and target correspond pixel for pixel is not known")
            return summary
        if summary["flagged"]:
            named = "; ".join(f"{lens}: {checks[lens]['flag']}" for lens in summary["flagged"][:5])
            more = len(summary["flagged"]) - 5
            message = (f"{folder.root}: the {split} pairs of {len(summary['flagged'])} of {len(checks)} lenses differ by "
                       f"more than blur ({named}{f'; and {more} more' if more > 0 else ''}); a model trained on them "
                       "learns to move and brighten pixels, not to remove blur: rebuild with `unicac dataset build "
                       "--task aligned`")
            if not self.config["train"]["allow_misaligned"]:
                raise config_mod.ConfigError(message + " (--allow-misaligned trains anyway)")
            _warn(message)
        return summary

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
            "psf_basis_sha256": self.recipe["psf_basis_sha256"],
            "wall_time_s": self.wall_time_s,
            "torch_rng": torch.get_rng_state(),
        }
        if self.ema is not None:
            state["net_ema"] = self.ema.state_dict()
        if self.scaler is not None:
            state["grad_scaler"] = self.scaler.state_dict()
        if self.discriminator is not None and self.optimizer_d is not None:
            disc = self.discriminator.module if hasattr(self.discriminator, "module") else self.discriminator
            state["discriminator"] = disc.state_dict()
            state["optimizer_d"] = self.optimizer_d.state_dict()
        return state

    def save_checkpoint(self, iteration: int) -> None:
        # Every rank holds the same weights (DDP), so every rank reaches the same verdict.
        if not all(bool(torch.isfinite(p).all()) for p in self.net.parameters()):
            raise NonFiniteTraining(f"iteration {iteration}: the network's weights are not finite; {self._kept()}")
        self.saved_iter = iteration
        if self.rank != 0:
            return
        state = self._state(iteration)
        write_with(self.run.checkpoint, lambda handle: torch.save(state, handle))
        self.log.flush()
        self.log.plot()  # curves a stopped run still shows

    def _resume(self) -> None:
        if not self.run.checkpoint.is_file():
            raise RunError(f"--resume: {self.run.path} holds no checkpoint to resume (checkpoints/latest.pt)")
        clean_stale_temporaries(self.run.checkpoint.parent)
        state = self.run.load_checkpoint()
        if state.get("config_sha256") != self.config_sha256:
            raise RunError(f"--resume: the config differs from {self.run.config}, the one this run was started with")
        self.net.load_state_dict(state["net"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.scheduler.load_state_dict(state["scheduler"])
        if self.ema is not None:
            self.ema.load_state_dict(state["net_ema"])
        if self.scaler is not None and "grad_scaler" in state:
            self.scaler.load_state_dict(state["grad_scaler"])
        if self.discriminator is not None and self.optimizer_d is not None:
            self.discriminator.load_state_dict(state["discriminator"])
            self.optimizer_d.load_state_dict(state["optimizer_d"])
        torch.set_rng_state(state["torch_rng"])
        self.start_iter = int(state["iteration"])
        self.saved_iter = self.start_iter
        self.wall_time_s = float(state.get("wall_time_s", 0.0))

    def _write_run_info(self, **extra: Any) -> None:
        if self.rank != 0:
            return
        if not (self.resumed and self.run.config.is_file()):  # a resumed run's config is an input
            config_mod.dump(config_mod.without_session(self.config), self.run.config)
        info = {
            "name": self.config["name"],
            "architecture": self.net.architecture,
            "inputs": self.net.inputs,
            "params": count_parameters(self.net),
            "config_sha256": self.config_sha256,
            "unicac_version": _unicac_version(),
            "world_size": self.world,
            "recipe": self.recipe,
            **extra,
        }
        write_bytes(self.run.info, (json.dumps(info, indent=2) + "\n").encode())
        if self.recipe["psf_basis_sha256"]:
            copy_psf_basis(self.train_set.folder.psf_basis_dir, self.run.psf_basis)

    # -- loop ------------------------------------------------------------------------------------

    def _autocast(self) -> Any:
        if self.amp_dtype is None:
            return contextlib.nullcontext()
        return torch.autocast(device_type=self.device.type, dtype=self.amp_dtype)

    def _to_device(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        memory = torch.channels_last if self.channels_last else torch.contiguous_format
        return {key: (value.to(self.device, non_blocking=True, memory_format=memory) if value.dim() == 4 else value)
                for key, value in batch.items()}

    def _maps(self, batch: dict[str, torch.Tensor]) -> dict[str, torch.Tensor]:
        return {name: batch[name] for name in self.net.inputs[1:]}

    def _prediction_loss(self, predicted: torch.Tensor, true: torch.Tensor) -> torch.Tensor:
        scale = PRIOR_SCALE.get(self.net.predicts or "", 1.0)
        return F.l1_loss(predicted.float() * scale, true * scale)

    def _losses(self, batch: dict[str, torch.Tensor], iteration: int) -> tuple[torch.Tensor, torch.Tensor]:
        losses = self.config["train"]["losses"]
        with self._autocast():
            out = self.view(batch["lq"], **self._maps(batch))
        restored = out["restored"].float()
        loss = losses["pixel"]["weight"] * pixel_loss(losses["pixel"]["type"], restored, batch["gt"])
        if losses["frequency"]["weight"] > 0:
            loss = loss + losses["frequency"]["weight"] * frequency_loss(restored, batch["gt"])
        if "prediction" in out:
            loss = loss + losses["psf"]["weight"] * self._prediction_loss(out["prediction"], batch[self.net.predicts])
        if self.lpips is not None:
            loss = loss + losses["perceptual"]["weight"] * self.lpips(restored.clamp(0, 1), batch["gt"])
        if self.discriminator is not None and iteration >= losses["gan"]["start_iter"]:
            loss = loss + losses["gan"]["weight"] * gan_loss(self.discriminator(restored), real=True)
        return loss, restored

    def _step(self, batch: dict[str, torch.Tensor], iteration: int) -> float:
        batch = self._to_device(batch)
        self.net.train()
        if self.discriminator is not None:
            self.discriminator.requires_grad_(False)
        loss, restored = self._losses(batch, iteration)
        self._stop_unless_finite("training loss", loss, iteration + 1)
        self.optimizer.zero_grad(set_to_none=True)
        clip = self.config["train"]["grad_clip"]
        if self.scaler is not None:
            self.scaler.scale(loss).backward()
            self.scaler.unscale_(self.optimizer)
            if clip:
                torch.nn.utils.clip_grad_norm_(self.net.parameters(), clip)
            self.scaler.step(self.optimizer)
            self.scaler.update()
        else:
            loss.backward()
            if clip:
                torch.nn.utils.clip_grad_norm_(self.net.parameters(), clip)
            self.optimizer.step()
        self.scheduler.step()
        if self.ema is not None:
            self.ema.update_parameters(self.net)
        if self.discriminator is not None and self.optimizer_d is not None and iteration >= self.config["train"]["losses"]["gan"]["start_iter"]:
            self.discriminator.requires_grad_(True)
            d_loss = gan_loss(self.discriminator(batch["gt"]), real=True) + gan_loss(self.discriminator(restored.detach()), real=False)
            self._stop_unless_finite("discriminator loss", d_loss, iteration + 1)
            self.optimizer_d.zero_grad(set_to_none=True)
            d_loss.backward()
            self.optimizer_d.step()
        return float(loss.detach())

    def _kept(self) -> str:
        if self.saved_iter is None:
            return "training stopped before any checkpoint was saved"
        return f"training stopped; {self.run.checkpoint} keeps the last good state (iteration {self.saved_iter})"

    def _stop_unless_finite(self, what: str, value: torch.Tensor, iteration: int) -> None:
        """Raises NonFiniteTraining when `value` is NaN or infinite on any rank (all ranks stop together:
        one rank stopping alone would leave the others waiting in the next all-reduce)."""
        bad = torch.tensor(0.0 if bool(torch.isfinite(value.detach()).all()) else 1.0)
        if self.world > 1:
            import torch.distributed as dist

            dist.all_reduce(bad, op=dist.ReduceOp.MAX)
        if bad.item():
            raise NonFiniteTraining(
                f"iteration {iteration}: the {what} is {float(value.detach().float().mean())} "
                f"(train.optim.lr, train.grad_clip and the train.losses weights set its scale); {self._kept()}"
            )

    @property
    def evaluated(self) -> Restorer:
        """The network validation and export use: the EMA weights when the run keeps them."""
        return self.ema.module if self.ema is not None else self.net  # type: ignore[return-value]

    def _log_validation(self, iteration: int, t0: float, progress: Progress) -> dict[str, float]:
        """Validates, logs the scores as iteration `iteration`'s `val` row and reports them."""
        scores = self.validate()
        self.log.add(iter=iteration, kind="val", seconds=time.perf_counter() - t0,
                     **{key: scores.get(key) for key in VALIDATION_LOG_FIELDS})
        predicted = (f", {self.net.predicts} L1 {scores['prediction_l1']:.4f} (zeros "
                     f"{scores['prediction_l1_zero']:.4f})") if "prediction_l1" in scores else ""
        perceptual = f", LPIPS {scores['lpips']:.4f}" if "lpips" in scores else ""
        if "severe_psnr_db" in scores:
            perceptual += f"; severe levels {scores['severe_psnr_db']:.2f} dB"
            perceptual += f" (Wiener {scores['severe_wiener_psnr_db']:.2f})" if "severe_wiener_psnr_db" in scores else ""
        wiener = f"; Wiener estimate {scores['wiener_psnr_db']:.2f} dB" if "wiener_psnr_db" in scores else ""
        wiener += f", LPIPS {scores['wiener_lpips']:.4f}" if "wiener_lpips" in scores else ""
        progress.message(
            f"iter {iteration}: val PSNR {scores['psnr_db']:.2f} dB, SSIM {scores['ssim']:.4f}{perceptual} "
            f"(input {scores['input_psnr_db']:.2f} dB, {scores['input_ssim']:.4f}){predicted}{wiener}"
        )
        return scores

    @torch.no_grad()
    def validate(self) -> dict[str, float]:
        """Mean PSNR (dB) / SSIM of the restored and of the unrestored validation images (fixed set);
        with a perceptual loss also the restored images' LPIPS (`lpips`, the loss's own net); for a network
        that refines the Wiener estimate, that estimate's own scores (`wiener_psnr_db`, `wiener_lpips`: the
        line it should stay above); for a blind network the L1 error of its predicted map
        (`prediction_l1`) and that of predicting zeros (`prediction_l1_zero`: the code's mean, or no
        moments). The same scores over the validation pairs of lenses in the severe test levels
        (`severe_pairs`) as `severe_<score>`."""
        assert self.val_set is not None
        net = self.evaluated
        net.eval()
        scores: dict[str, list[torch.Tensor]] = {"psnr_db": [], "ssim": [], "input_psnr_db": [], "input_ssim": []}
        if net.predicts:
            scores.update(prediction_l1=[], prediction_l1_zero=[])
        refines_wiener = "wiener" in net.inputs
        if refines_wiener:
            scores.update(wiener_psnr_db=[])
        if self.lpips is not None:
            scores.update(lpips=[], **({"wiener_lpips": []} if refines_wiener else {}))
        severe_flags = getattr(self.val_set, "severe", None) or []
        severe: dict[str, list[torch.Tensor]] = {key: [] for key in SEVERE_SCORES if key in scores}
        # Validation draws nothing from the training's random stream (its DataLoader would).
        with torch.random.fork_rng(devices=[]):
            loader = DataLoader(self.val_set, batch_size=1, shuffle=False, num_workers=0, collate_fn=collate)
            for batch in loader:
                before = {key: len(values) for key, values in scores.items()}
                index = int(batch["index"][0])
                batch = self._to_device(batch)
                with self._autocast():
                    out = net.training_outputs(batch["lq"], **self._maps(batch))
                restored_here = out["restored"].float().clamp(0, 1)  # on the device, for LPIPS
                restored, gt, lq = restored_here.cpu(), batch["gt"].cpu(), batch["lq"].cpu()
                scores["psnr_db"].append(psnr(restored, gt))
                scores["ssim"].append(ssim(restored, gt))
                scores["input_psnr_db"].append(psnr(lq, gt))
                scores["input_ssim"].append(ssim(lq, gt))
                wiener = batch["wiener"].float().clamp(0, 1) if refines_wiener else None
                if wiener is not None:
                    scores["wiener_psnr_db"].append(psnr(wiener.cpu(), gt))
                if self.lpips is not None and min(gt.shape[-2:]) >= MIN_SIDE_PX[self.lpips.net]:
                    scores["lpips"].append(self.lpips(restored_here, batch["gt"]).view(1).cpu())
                    if wiener is not None:
                        scores["wiener_lpips"].append(self.lpips(wiener, batch["gt"]).view(1).cpu())
                if "prediction" in out:
                    true = batch[net.predicts].float()
                    scores["prediction_l1"].append((out["prediction"].float() - true).abs().mean().view(1).cpu())
                    scores["prediction_l1_zero"].append(true.abs().mean().view(1).cpu())
                if index < len(severe_flags) and severe_flags[index]:
                    for key in severe:
                        severe[key].extend(scores[key][before[key]:])
        self.net.train()
        # (LPIPS skips whole validation images smaller than its net takes; none at all: no LPIPS.)
        scores.update({f"severe_{key}": values for key, values in severe.items()})
        return {key: float(torch.cat(values).double().mean()) for key, values in scores.items() if values}

    def _budget_spent(self, t0: float) -> bool:
        """Whether this session's time budget is spent (rank 0 decides for every rank)."""
        budget = self.config["train"]["time_budget_s"]
        if budget is None:
            return False
        spent = torch.tensor([float(time.perf_counter() - t0 >= budget)])
        if self.world > 1:
            import torch.distributed as dist

            dist.broadcast(spent, src=0)
        return bool(spent.item())

    def train(self, stop_after: Optional[int] = None) -> dict[str, Any]:
        """Runs iterations start .. total_iter (or stops after iteration `stop_after`, as a kill would,
        without a final checkpoint; or when `train.time_budget_s` is spent, with a checkpoint and a
        validation); returns the last validation scores. The run folder is held (`RunFolder.hold`)
        from the first write to the return."""
        lock = self.run.hold() if self.rank == 0 else None
        try:
            return self._train_session(stop_after)
        finally:
            if lock is not None:
                lock.close()

    def _train_session(self, stop_after: Optional[int]) -> dict[str, Any]:
        cfg = self.config
        total = cfg["train"]["total_iter"]
        every_val, every_ckpt, every_log = cfg["val"]["val_freq"], cfg["logger"]["save_checkpoint_freq"], cfg["logger"]["print_freq"]
        self._write_run_info()
        train_cfg = cfg["datasets"]["train"]
        batch = train_cfg["batch_size"]
        sampler = IterationSampler(self.start_iter, total, batch, self.rank, self.world)
        loader = DataLoader(self.train_set, batch_size=batch, sampler=sampler, num_workers=train_cfg["num_workers"],
                            collate_fn=collate, drop_last=False, pin_memory=self.device.type == "cuda")
        progress = Progress(self.start_iter, total, every_log, enabled=not self.quiet)
        recent: list[float] = []
        last_val: dict[str, Any] = {}
        t0 = time.perf_counter()
        wall_before = self.wall_time_s
        iteration = self.start_iter
        if self.rank == 0 and self.start_iter == 0 and total > 0:
            # The curve's starting point: what the network does before training (for wiener-nafnet, the
            # Wiener estimate itself), so a curve shows how much training added.
            self._log_validation(0, t0, progress)
        for iteration, data in enumerate(loader, start=self.start_iter + 1):
            recent.append(self._step(data, iteration - 1))
            self.wall_time_s = wall_before + time.perf_counter() - t0
            progress.update(iteration, recent[-1])
            if self.rank == 0 and (iteration % every_log == 0 or iteration == total):
                self.log.add(iter=iteration, kind="train", loss=sum(recent) / len(recent), lr=self.scheduler.get_last_lr()[0],
                             it_per_s=progress.rate(iteration), seconds=time.perf_counter() - t0)
                recent = []
            out_of_time = iteration < total and self._budget_spent(t0)
            if self.rank == 0 and (iteration % every_val == 0 or iteration == total or out_of_time):
                last_val = self._log_validation(iteration, t0, progress)
            if stop_after is not None and iteration >= stop_after:
                return last_val
            if iteration % every_ckpt == 0 or iteration == total or out_of_time:
                self.save_checkpoint(iteration)
            if out_of_time:
                self.stopped_by_budget = True
                progress.message(f"iter {iteration}: time budget ({cfg['train']['time_budget_s']} s) spent; "
                                 "checkpoint written (export it, or continue with --resume)")
                break
        if self.rank == 0:
            self.log.flush()
            self.log.plot()
            info = json.loads(self.run.info.read_text())
            info.update(iterations=iteration, wall_time_s=round(self.wall_time_s, 3),
                        stopped_by_time_budget=self.stopped_by_budget)
            if last_val:
                info["final_validation"] = last_val
            write_bytes(self.run.info, (json.dumps(info, indent=2) + "\n").encode())
        return last_val
