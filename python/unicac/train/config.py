"""Training configs: BasicSR-shaped YAML (name, manual_seed, network, datasets.train/val,
train.optim/scheduler/losses/total_iter, val, logger), validated before anything trains.

Every key is checked against the schema below: an unknown key, a wrong type, a number that is not
finite (`.nan`, `.inf`) or a value out of its stated range raises `ConfigError` naming the key
(`train.optim.lr: ...`); every number has both limits. Missing optional keys take
the defaults written here, so a run's `config.yml` (the resolved config, saved in the run folder)
lists every setting that shaped it.
"""

from __future__ import annotations

import copy
import hashlib
import inspect
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

CONFIG_DIR = Path(__file__).with_name("configs")

#: Limits of the loss weights, gradient clipping and frame sides (every number has a stated range).
MAX_LOSS_WEIGHT = 1e3
MAX_GRAD_CLIP = 1e6
MAX_FRAME_SIDE_PX = 8192


class ConfigError(ValueError):
    """A config key that is unknown, of the wrong type or out of range (the message names the key)."""


@dataclass(frozen=True)
class Field:
    types: tuple[type, ...]
    default: Any = None
    low: Optional[float] = None  # inclusive limits for numbers (and list lengths: see `items`)
    high: Optional[float] = None
    choices: Optional[tuple[Any, ...]] = None
    items: Optional[tuple[type, ...]] = None  # element types of a list
    required: bool = False


def _f(types: Any, default: Any = None, **kw: Any) -> Field:
    return Field(types if isinstance(types, tuple) else (types,), default, **kw)


_DATA = {
    "type": _f(str, "unicac", choices=("unicac", "onthefly")),
    # unicac: a built dataset folder (`unicac dataset build`).
    "dataroot": _f((str, type(None))),
    "split": _f(str, "train", choices=("train", "val", "test")),
    # onthefly: the lenses (paths or builtin:NAME) and sharp images (a folder, or None for charts).
    "lenses": _f(list, [], items=(str,)),
    "images": _f((str, type(None))),
    "charts": _f(list, ["dead-leaves"], items=(str,)),
    "frame_px": _f(list, [256, 192], items=(int,)),  # [width, height], 16..MAX_FRAME_SIDE_PX each
    "isp": _f(bool, True),
    "noise": _f(bool, True),
    # onthefly: what a pair asks the model to undo (as `unicac dataset build --task`).
    "task": _f(str, "aligned", choices=("aligned", "full")),
    "seed": _f(int, 0, low=0, high=2**63 - 1),
    "patch_px": _f(int, 64, low=16, high=4096),
    "batch_size": _f(int, 4, low=1, high=1024),
    "num_workers": _f(int, 0, low=0, high=64),
    "use_flip": _f(bool, True),
    "use_rot": _f(bool, True),
    # validation: the first `max_pairs` pairs of the split, centre crops of `crop_px` (None: whole image).
    "max_pairs": _f(int, 8, low=1, high=100_000),
    "crop_px": _f((int, type(None)), 128, low=16, high=8192),
    # The noise-to-signal ratio of the Wiener estimate a `wiener` model takes (as `unicac bench --wiener-nsr`).
    "wiener_nsr": _f((float, int), 0.01, low=1e-9, high=100),
    # Training only: the share of samples that are slanted-edge charts imaged through a training lens's
    # PSF table (the bench's OIQE edges, made for training lenses: unicac.table_edge_pairs) instead of
    # patches of its pairs; 0 = pairs only.
    "edge_share": _f((float, int), 0.0, low=0, high=1),
}

SCHEMA: dict[str, Any] = {
    "name": _f(str, required=True),
    "manual_seed": _f(int, 0, low=0, high=2**63 - 1),
    "network": _f(dict, required=True),  # checked against the architecture's signature
    "datasets": {"train": dict(_DATA), "val": dict(_DATA)},
    "path": {
        # A run folder or checkpoint whose generator weights initialise this run (GAN fine-tuning).
        "pretrain_network_g": _f((str, type(None))),
    },
    "train": {
        "total_iter": _f(int, 1000, low=1, high=100_000_000),
        "grad_clip": _f((float, int, type(None)), None, low=0, high=MAX_GRAD_CLIP),
        # Stop cleanly (checkpoint, validation) once this many seconds of training have passed in this
        # session; --resume continues. A session setting: not part of the config hash.
        "time_budget_s": _f((float, int, type(None)), None, low=1, high=10**9),
        # cpu, cuda or auto (cuda when available); mixed precision and channels_last where it helps.
        "device": _f(str, "auto", choices=("auto", "cpu", "cuda")),
        "amp": _f(str, "auto", choices=("auto", "off", "bf16", "fp16")),
        "channels_last": _f(str, "auto", choices=("auto", "on", "off")),
        # torch.compile of the training step (Inductor: fused kernels; needs a C++ compiler on CPU). About
        # a minute of compiling first, then 1.2-1.6x the steps per second of eager steps on 2 CPU cores at
        # 128 and 256 px (docs/models.md). A session setting: rounding differs slightly from eager steps.
        "compile": _f(str, "off", choices=("off", "on")),
        # Exponential moving average of the generator's weights (validated and exported when set).
        "ema_decay": _f((float, type(None)), None, low=0.0, high=0.999999),
        # Refuse (false) or only warn (true): a patch under twice the dataset's largest PSF kernel, a
        # receptive field under it. Session settings: not part of the config hash.
        "allow_small_patch": _f(bool, False),
        "allow_small_receptive_field": _f(bool, False),
        # Refuse (false) or only warn (true): training pairs whose LQ-GT error is dominated by
        # misregistration or shading rather than blur (the pairs' checks, docs/dataset.md).
        "allow_misaligned": _f(bool, False),
        "optim": {
            "type": _f(str, "AdamW", choices=("Adam", "AdamW")),
            "lr": _f((float, int), 1e-3, low=0, high=1),
            "weight_decay": _f((float, int), 0.0, low=0, high=1),
            "betas": _f(list, [0.9, 0.9], items=(float, int)),  # two numbers in [0, 1)
        },
        "scheduler": {
            "type": _f(str, "CosineAnnealingLR", choices=("CosineAnnealingLR", "constant")),
            "eta_min": _f((float, int), 1e-6, low=0, high=1),
        },
        "losses": {
            "pixel": {"type": _f(str, "L1Loss", choices=("L1Loss", "CharbonnierLoss")), "weight": _f((float, int), 1.0, low=0, high=MAX_LOSS_WEIGHT)},
            # L1 between the restored and true images' spectra (losses.frequency_loss).
            "frequency": {"weight": _f((float, int), 0.0, low=0, high=MAX_LOSS_WEIGHT)},
            # Blind PSF prior: L1 between predicted and true PSF-feature maps.
            "psf": {"weight": _f((float, int), 0.0, low=0, high=MAX_LOSS_WEIGHT)},
            # LPIPS (VGG16 or AlexNet weights from `unicac weights fetch lpips`).
            "perceptual": {"weight": _f((float, int), 0.0, low=0, high=MAX_LOSS_WEIGHT), "net": _f(str, "vgg16", choices=("vgg16", "alexnet"))},
            "gan": {
                "weight": _f((float, int), 0.0, low=0, high=MAX_LOSS_WEIGHT),
                "start_iter": _f(int, 0, low=0, high=100_000_000),
                "lr": _f((float, int), 1e-4, low=0, high=1),
                "width": _f(int, 32, low=4, high=512),
            },
        },
    },
    "val": {"val_freq": _f(int, 500, low=1, high=100_000_000)},
    "logger": {
        "print_freq": _f(int, 10, low=1, high=100_000_000),
        "save_checkpoint_freq": _f(int, 500, low=1, high=100_000_000),
    },
}


def _check_value(key: str, field: Field, value: Any) -> Any:
    # YAML 1.1 reads an unquoted on / off as a boolean: where a field's words are on and off, take it so.
    if isinstance(value, bool) and field.choices is not None and {"on", "off"} <= set(field.choices):
        value = "on" if value else "off"
    # bool is an int in Python: refuse it where a number is expected, and ints where a bool is.
    ok = isinstance(value, field.types) and not (isinstance(value, bool) and bool not in field.types)
    if not ok:
        names = " or ".join("null" if t is type(None) else t.__name__ for t in field.types)
        raise ConfigError(f"{key}: expected {names}, got {type(value).__name__} ({value!r})")
    if field.choices is not None and value not in field.choices:
        raise ConfigError(f"{key}: '{value}' is not one of {list(field.choices)}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ConfigError(f"{key}: {value} is not a finite number")
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        if field.low is not None and value < field.low:
            raise ConfigError(f"{key}: {value} is below the limit {field.low}")
        if field.high is not None and value > field.high:
            raise ConfigError(f"{key}: {value} is above the limit {field.high}")
    if field.items is not None:
        for i, item in enumerate(value):
            if not isinstance(item, field.items) or isinstance(item, bool):
                names = " or ".join(t.__name__ for t in field.items)
                raise ConfigError(f"{key}[{i}]: expected {names}, got {type(item).__name__} ({item!r})")
            if isinstance(item, float) and not math.isfinite(item):
                raise ConfigError(f"{key}[{i}]: {item} is not a finite number")
    return copy.deepcopy(value)


def _resolve(schema: dict[str, Any], given: Any, prefix: str) -> dict[str, Any]:
    if not isinstance(given, dict):
        raise ConfigError(f"{prefix or 'config'}: expected a mapping, got {type(given).__name__}")
    for key in given:
        if key not in schema:
            where = f"{prefix}.{key}" if prefix else str(key)
            raise ConfigError(f"{where}: unknown key (known here: {', '.join(sorted(schema))})")
    out: dict[str, Any] = {}
    for key, spec in schema.items():
        where = f"{prefix}.{key}" if prefix else key
        if isinstance(spec, dict):
            out[key] = _resolve(spec, given.get(key, {}) if given.get(key) is not None else {}, where)
        elif key in given:
            out[key] = _check_value(where, spec, given[key])
        elif spec.required:
            raise ConfigError(f"{where}: required key is missing")
        else:
            out[key] = copy.deepcopy(spec.default)
    return out


def _check_network(network: dict[str, Any]) -> None:
    from .archs import NETWORKS
    from .archs.nafnet import PRIORS

    kind = network.get("type")
    if kind not in NETWORKS:
        raise ConfigError(f"network.type: '{kind}' is not one of {sorted(NETWORKS)}")
    parameters = inspect.signature(NETWORKS[kind].__init__).parameters
    accepts_more = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters.values())
    known = {name: p for name, p in parameters.items() if name != "self" and p.kind is not inspect.Parameter.VAR_KEYWORD}
    if accepts_more:  # BlindPsfNAFNet forwards the rest to its NAFNet restorer
        from .archs.nafnet import NAFNet

        known.update({n: p for n, p in inspect.signature(NAFNet.__init__).parameters.items() if n not in ("self", "prior")})
    for key, value in network.items():
        if key == "type":
            continue
        if key not in known:
            raise ConfigError(f"network.{key}: unknown key for {kind} (known: {', '.join(sorted(known))})")
        default = known[key].default
        if key == "prior" and value is not None and value not in PRIORS:
            raise ConfigError(f"network.prior: {value!r} is not one of null, {', '.join(repr(p) for p in PRIORS)}")
        if key == "target" and value not in ("psf_code", "psf"):
            raise ConfigError(f"network.target: {value!r} is not one of 'psf_code', 'psf'")
        if default is None or default is inspect.Parameter.empty:
            continue
        expected = (list, tuple) if isinstance(default, (list, tuple)) else (type(default),)
        if isinstance(default, float):
            expected = (float, int)
        if not isinstance(value, expected) or isinstance(value, bool) != isinstance(default, bool):
            raise ConfigError(f"network.{key}: expected {type(default).__name__}, got {type(value).__name__} ({value!r})")
        if isinstance(value, (list, tuple)) and not all(isinstance(v, int) and not isinstance(v, bool) and 0 <= v <= 64 for v in value):
            raise ConfigError(f"network.{key}: expected a list of block counts (integers 0..64), got {value!r}")
        if isinstance(value, int) and not isinstance(value, bool) and not 0 <= value <= 4096:
            raise ConfigError(f"network.{key}: {value} is outside 0..4096")
        if isinstance(value, float) and not 0 < value <= 64:  # also refuses NaN
            raise ConfigError(f"network.{key}: {value} is outside (0, 64]")


def validate(config: Any) -> dict[str, Any]:
    """The resolved config (defaults filled in), or `ConfigError` naming the first bad key."""
    resolved = _resolve(SCHEMA, config, "")
    _check_network(resolved["network"])
    for split in ("train", "val"):
        data = resolved["datasets"][split]
        if len(data["frame_px"]) != 2 or not all(16 <= side <= MAX_FRAME_SIDE_PX for side in data["frame_px"]):
            raise ConfigError(
                f"datasets.{split}.frame_px: expected [width, height] of 16..{MAX_FRAME_SIDE_PX} px each, got {data['frame_px']}"
            )
    perceptual = resolved["train"]["losses"]["perceptual"]
    if perceptual["weight"] > 0:
        from .losses import MIN_SIDE_PX

        if resolved["datasets"]["train"]["patch_px"] < MIN_SIDE_PX[perceptual["net"]]:
            raise ConfigError(
                f"datasets.train.patch_px: {resolved['datasets']['train']['patch_px']} px is below the "
                f"{MIN_SIDE_PX[perceptual['net']]} px that the {perceptual['net']} perceptual loss needs"
            )
    betas = resolved["train"]["optim"]["betas"]
    if len(betas) != 2 or not all(0 <= beta < 1 for beta in betas):
        raise ConfigError(f"train.optim.betas: expected two numbers in [0, 1), got {betas}")
    return resolved


def load(path: "os.PathLike[str] | str") -> dict[str, Any]:
    """Reads and validates a YAML config file (errors name the file and the key)."""
    import yaml

    path = Path(path)
    try:
        raw = yaml.safe_load(path.read_text())
    except OSError as error:
        raise ConfigError(f"{path}: cannot read the config ({error.strerror})") from error
    except yaml.YAMLError as error:
        raise ConfigError(f"{path}: not valid YAML ({error})") from error
    try:
        return validate(raw)
    except ConfigError as error:
        raise ConfigError(f"{path}: {error}") from error


def shipped(model: str) -> Path:
    """The shipped config of a model name (`unicac-train models` lists them)."""
    path = CONFIG_DIR / f"{model}.yml"
    if not path.is_file():
        names = ", ".join(sorted(p.stem for p in CONFIG_DIR.glob("*.yml")))
        raise ConfigError(f"--model: unknown model '{model}' (shipped: {names})")
    return path


#: Settings of one session, not of the run: a resumed run may change them (left out of the hash).
SESSION_KEYS = ("time_budget_s", "allow_small_patch", "allow_small_receptive_field", "allow_misaligned", "compile")


def without_session(config: dict[str, Any]) -> dict[str, Any]:
    """The config with the session settings (`SESSION_KEYS`) at their defaults: what a run folder keeps."""
    run = copy.deepcopy(config)
    for key in SESSION_KEYS:
        if key in run.get("train", {}):
            run["train"][key] = SCHEMA["train"][key].default
    return run


#: Loss terms the schema gained after runs had been trained with it: hashed only when used (a positive
#: weight), so that a run started before a term existed still resumes under the newer schema (whose
#: resolved config holds the term at weight 0) and keeps its hash in checkpoints and ONNX metadata.
HASHED_ONLY_WHEN_USED = ("frequency",)
#: Dataset keys added the same way, hashed only when not 0.
DATASET_KEYS_HASHED_ONLY_WHEN_USED = ("edge_share",)


def sha256(config: dict[str, Any]) -> str:
    """Hash of the resolved config (canonical JSON) without the session settings (`SESSION_KEYS`) and
    the unused later loss terms and dataset keys (`HASHED_ONLY_WHEN_USED`,
    `DATASET_KEYS_HASHED_ONLY_WHEN_USED`), recorded in checkpoints and ONNX metadata."""
    run = without_session(config)
    losses = run.get("train", {}).get("losses", {})
    for term in HASHED_ONLY_WHEN_USED:
        if term in losses and not losses[term].get("weight"):
            del losses[term]
    for split in run.get("datasets", {}).values():
        for key in DATASET_KEYS_HASHED_ONLY_WHEN_USED:
            if isinstance(split, dict) and key in split and not split[key]:
                del split[key]
    return hashlib.sha256(json.dumps(run, sort_keys=True, separators=(",", ":")).encode()).hexdigest()


def dump(config: dict[str, Any], path: Path) -> None:
    import yaml

    from unicac.outputs import write_bytes

    write_bytes(path, yaml.safe_dump(config, sort_keys=False).encode())
