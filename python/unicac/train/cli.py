"""`unicac-train`: train restoration models, export them to ONNX, list the architectures.

    unicac-train train --config CFG.yml --out RUN_DIR [--resume]
    unicac-train train --model NAME --dataset DIR --iters N --out RUN_DIR [--resume]
        [--patch-px N] [--batch N] [--time-budget-s S] [--device cpu|cuda|auto] [--amp ...]
        [--init-from RUN] [--allow-small-patch] [--allow-small-receptive-field] [--allow-misaligned]
    unicac-train train --resume --out RUN_DIR [--time-budget-s S]   (the run's own config)
    unicac-train export RUN_DIR --out MODEL.onnx
    unicac-train models [--json] [--receptive-field]

Bad input (config keys, dataset folders, run folders, output paths, missing LPIPS weights) exits with
status 1 and one line naming the key, flag, folder or file (2: a command-line usage error). Outputs
follow the output-file policy of every unicac command (`unicac.outputs`): checked against the inputs
before any work, extensions that name the format, atomic writes."""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path
from typing import Any, Optional

from unicac.outputs import OutputPlan, require_extension

from . import config as config_mod

#: Limit of --iters (as train.total_iter).
MAX_ITERS = 100_000_000


def _in(flag: str, value: Optional[float], low: float, high: float) -> None:
    if value is not None and not low <= value <= high:
        raise config_mod.ConfigError(f"{flag}: {value} is outside {low:g}..{high:g}")


def _config_from_args(args: argparse.Namespace) -> dict[str, Any]:
    if args.config and args.model:
        raise config_mod.ConfigError("give --config or --model, not both")
    if not args.config and not args.model and not args.resume:
        raise config_mod.ConfigError("give --config CFG.yml, or --model NAME with --dataset DIR (or --resume --out RUN)")
    if args.config or args.model:
        path = Path(args.config) if args.config else config_mod.shipped(args.model)
    else:
        path = Path(args.out) / "config.yml"  # --resume alone: the run's own resolved config
        if not path.is_file():
            raise config_mod.ConfigError(f"--resume: {args.out} is not a unicac-train run folder (no config.yml)")
    config = config_mod.load(path)
    if args.dataset is None and args.model and not args.resume:
        raise config_mod.ConfigError("--model needs --dataset DIR (a `unicac dataset build` folder)")
    config = copy.deepcopy(config)
    train, data = config["train"], config["datasets"]["train"]
    if args.dataset is not None:
        for split in ("train", "val"):
            config["datasets"][split]["type"] = "unicac"
            config["datasets"][split]["dataroot"] = str(args.dataset)
    _in("--iters", args.iters, 1, MAX_ITERS)
    _in("--patch-px", args.patch_px, 16, 4096)
    _in("--batch", args.batch, 1, 1024)
    _in("--workers", args.workers, 0, 64)
    _in("--time-budget-s", args.time_budget_s, 1, 10**9)
    overrides = [(train, "total_iter", args.iters), (data, "patch_px", args.patch_px), (data, "batch_size", args.batch),
                 (data, "num_workers", args.workers), (train, "time_budget_s", args.time_budget_s),
                 (train, "device", args.device), (train, "amp", args.amp), (train, "channels_last", args.channels_last),
                 (train, "compile", args.compile),
                 (config["path"], "pretrain_network_g", args.init_from)]
    for section, key, value in overrides:
        if value is not None:
            section[key] = value
    if args.init_from is not None and not Path(args.init_from).exists():
        raise config_mod.ConfigError(f"--init-from: {args.init_from} is neither a run folder, a checkpoint nor an ONNX file")
    train["allow_small_patch"] = bool(args.allow_small_patch or train["allow_small_patch"])
    train["allow_small_receptive_field"] = bool(args.allow_small_receptive_field or train["allow_small_receptive_field"])
    train["allow_misaligned"] = bool(args.allow_misaligned or train["allow_misaligned"])
    return config_mod.validate(config)


def _train_outputs(args: argparse.Namespace, config: dict[str, Any]) -> OutputPlan:
    """The run folder and its files against what the run reads (config, datasets, lenses, images,
    pretrained weights): no output is an input or lies inside an input folder."""
    from .models import RunError, RunFolder

    out = Path(args.out)
    if out.exists() and not out.is_dir():
        raise RunError(f"--out {out}: not a folder (a run folder is written there)")
    plan = OutputPlan()
    if args.config:
        plan.input(args.config)
    for data in config["datasets"].values():
        if data["type"] == "unicac" and data["dataroot"]:
            plan.input_folder(data["dataroot"])
        if data["type"] == "onthefly":
            for lens in data["lenses"]:
                if not lens.startswith("builtin:"):
                    plan.input(lens)
            if data["images"]:
                plan.input_folder(data["images"])
    pretrain = config["path"]["pretrain_network_g"]
    if pretrain:
        (plan.input_folder if Path(pretrain).is_dir() else plan.input)(pretrain)
    plan.output("--out", out)
    for path in RunFolder(out).outputs(resume=args.resume):
        plan.output("--out", path)
    return plan


def _train(args: argparse.Namespace) -> int:
    from .models import Trainer

    config = _config_from_args(args)
    _train_outputs(args, config).check()
    trainer = Trainer(config, args.out, resume=args.resume, quiet=args.quiet)
    scores = trainer.train()
    if trainer.rank == 0:
        stopped = " (stopped by --time-budget-s; --resume continues)" if trainer.stopped_by_budget else ""
        summary = {"run": str(args.out), "architecture": trainer.net.architecture,
                   "stopped_by_time_budget": trainer.stopped_by_budget, **scores}
        print(json.dumps(summary) if args.json else
              f"{args.out}: {trainer.net.architecture}, val PSNR {scores.get('psnr_db', float('nan')):.2f} dB "
              f"(input {scores.get('input_psnr_db', float('nan')):.2f} dB), SSIM {scores.get('ssim', float('nan')):.4f}{stopped}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from .export import basis_beside, export_run

    require_extension("--out", args.out, ["onnx"])
    OutputPlan().input_folder(args.run_dir).output("--out", args.out).output("--out", basis_beside(args.out)).check()
    report = export_run(args.run_dir, args.out, check=not args.no_check)
    if not report["parity"]:
        print("unicac-train: warning: --no-check: the onnxruntime parity check was skipped", file=sys.stderr)
    if args.json:
        print(json.dumps(report))
    else:
        parity = ", ".join(f"{k}: {v:.1e}" for k, v in report["parity"].items()) or "not checked"
        print(f"{report['path']}: {report['architecture']} (inputs {','.join(report['inputs'])}), "
              f"{report['bytes'] / 1e6:.2f} MB, onnxruntime vs PyTorch max diff {parity}")
        if "psf_basis" in report:
            print(f"{report['psf_basis']}: its PSF basis (give it to `unicac dataset build --psf-basis-from`)")
    return 0


def model_table(receptive_field: bool = False) -> list[dict[str, Any]]:
    """The shipped models: name, ONNX inputs, learned or not, parameter count, the equal-size control
    of a prior model, config path; with `receptive_field` the measured receptive field (px)."""
    from .archs import CONTROLS, build_network, count_parameters
    from .archs.receptive import receptive_field_px

    rows: list[dict[str, Any]] = [{
        "name": "wiener", "inputs": ["lq", "psf"], "learned": False, "params": 0, "config": None,
        "note": "field-varying Wiener deconvolution with the true PSF table: `unicac bench --method wiener`",
    }]
    for path in sorted(config_mod.CONFIG_DIR.glob("*.yml")):
        config = config_mod.load(path)
        net = build_network(config["network"])
        row = {"name": path.stem, "inputs": net.inputs, "learned": True, "params": count_parameters(net),
               "config": str(path), "architecture": net.architecture, "predicts": net.predicts,
               "control": CONTROLS.get(path.stem)}
        if receptive_field:
            row["receptive_field_px"], row["receptive_field_exact"] = receptive_field_px(net)
        rows.append(row)
    return rows


def _models(args: argparse.Namespace) -> int:
    rows = model_table(args.receptive_field)
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    for row in rows:
        field = ""
        if "receptive_field_px" in row:
            field = f"  receptive field {'' if row['receptive_field_exact'] else '>='}{row['receptive_field_px']} px"
        control = f"  control {row['control']}" if row.get("control") else ""
        print(f"{row['name']:<26} inputs {','.join(row['inputs']):<12} params {row['params']:>10,}  "
              f"{'learned' if row['learned'] else 'classical'}{field}{control}  {row['config'] or row.get('note', '')}")
    return 0


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="unicac-train", description="Train restoration models on unicac data; export to ONNX.")
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="train from a config, or from a shipped model's config")
    t.add_argument("--config", help="a YAML config (BasicSR-shaped keys)")
    t.add_argument("--model", help="a shipped model (see `unicac-train models`)")
    t.add_argument("--dataset", help="a `unicac dataset build` folder (replaces the config's dataroot)")
    t.add_argument("--iters", type=int, help=f"iterations (replaces train.total_iter; 1..{MAX_ITERS})")
    t.add_argument("--patch-px", type=int, help="training patch side in px (replaces datasets.train.patch_px; 16..4096); "
                   "at least twice the dataset's largest PSF kernel")
    t.add_argument("--batch", type=int, help="patches per iteration (replaces datasets.train.batch_size; 1..1024)")
    t.add_argument("--workers", type=int, help="data-loader worker processes (replaces datasets.train.num_workers; 0..64)")
    t.add_argument("--time-budget-s", type=float, help="stop this session cleanly after S seconds of training "
                   "(a checkpoint you can export; --resume continues)")
    t.add_argument("--device", choices=("auto", "cpu", "cuda"), help="replaces train.device (auto: cuda when available)")
    t.add_argument("--amp", choices=("auto", "off", "bf16", "fp16"), help="mixed precision (replaces train.amp; auto: "
                   "bf16 or fp16 on a GPU, off on CPU)")
    t.add_argument("--channels-last", choices=("auto", "on", "off"), help="replaces train.channels_last (auto: on for cuda)")
    t.add_argument("--compile", choices=("on", "off"), help="torch.compile the training step (replaces train.compile; "
                   "default off): about a minute of compiling, then 1.2-1.6x faster steps on CPU (nafnet, wiener-nafnet "
                   "at 128 and 256 px); needs a C++ compiler")
    t.add_argument("--init-from", help="a finished run folder, a checkpoint or an exported model (.onnx, e.g. "
                   "models/bench-small/NAME.onnx) whose weights start this run (replaces path.pretrain_network_g: "
                   "fine-tuning)")
    t.add_argument("--allow-small-patch", action="store_true", help="warn instead of refusing a patch under twice "
                   "the dataset's largest PSF kernel")
    t.add_argument("--allow-small-receptive-field", action="store_true", help="warn instead of refusing a network "
                   "whose receptive field is narrower than the dataset's largest PSF kernel")
    t.add_argument("--allow-misaligned", action="store_true", help="warn instead of refusing training pairs whose "
                   "LQ-GT error is dominated by misregistration or shading rather than blur (dataset build --task full)")
    t.add_argument("--out", required=True, help="run folder (config, checkpoints, logs, curves)")
    t.add_argument("--resume", action="store_true", help="continue the run in --out from its latest checkpoint "
                   "(alone: with the run's own config)")
    t.add_argument("--quiet", action="store_true", help="no progress output")
    t.add_argument("--json", action="store_true", help="print the final summary as JSON")
    t.set_defaults(run=_train)
    e = sub.add_parser("export", help="export a run's latest checkpoint to ONNX (docs/models.md)")
    e.add_argument("run_dir", help="a run folder written by `unicac-train train`")
    e.add_argument("--out", required=True, help="the ONNX file to write")
    e.add_argument("--no-check", action="store_true", help="skip the onnxruntime parity check (without it, a missing "
                   "onnxruntime is an error)")
    e.add_argument("--json", action="store_true")
    e.set_defaults(run=_export)
    m = sub.add_parser("models", help="list the architectures")
    m.add_argument("--json", action="store_true")
    m.add_argument("--receptive-field", action="store_true", help="also measure each network's receptive field (seconds each)")
    m.set_defaults(run=_models)
    return p


def user_error_message(error: BaseException) -> Optional[str]:
    """The one-line message of an error caused by the input (a config key, a folder, a file, an
    output path, the environment), or None for a bug (which keeps its traceback)."""
    from unicac import UnicacError
    from unicac.dataset import DatasetFolderError

    from .export import ExportError
    from .losses import LpipsWeightsError
    from .models import RunError

    if isinstance(error, OSError):
        if error.filename is not None and error.strerror:
            return f"{error.filename}: {error.strerror}"
        return str(error)
    if isinstance(error, (config_mod.ConfigError, DatasetFolderError, RunError, UnicacError, ExportError, LpipsWeightsError)):
        return str(error)
    return None


def run_command(prog: str, command: Any, args: Any) -> int:
    """`command(args)` with the exit codes of docs/reliability.md: a user error is one line on stderr
    and exit code 1; an interruption 130; anything else is a bug and keeps its traceback."""
    try:
        return int(command(args))
    except KeyboardInterrupt:
        resumable = getattr(args, "run", None) is _train
        print(f"{prog}: interrupted{' (the same command with --resume continues the run)' if resumable else ''}", file=sys.stderr)
        return 130
    except Exception as error:
        message = user_error_message(error)
        if message is None:
            raise
        print(f"{prog}: error: {message}", file=sys.stderr)
        return 1


def main(argv: Optional[list[str]] = None) -> int:
    args = parser().parse_args(argv)
    return run_command("unicac-train", args.run, args)


if __name__ == "__main__":
    sys.exit(main())
