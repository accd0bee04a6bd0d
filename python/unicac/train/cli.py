"""`unicac-train`: train restoration models, export them to ONNX, list the architectures.

    unicac-train train --config CFG.yml --out RUN_DIR [--resume]
    unicac-train train --model NAME --dataset DIR --iters N --out RUN_DIR [--resume]
    unicac-train export RUN_DIR --out MODEL.onnx
    unicac-train models [--json]

Bad input (config keys, dataset folders, run folders, missing LPIPS weights) exits with status 2 and
one line naming the key, folder or file."""

from __future__ import annotations

import argparse
import copy
import json
import sys
from pathlib import Path
from typing import Any, Optional

from . import config as config_mod

#: Limit of --iters (as train.total_iter).
MAX_ITERS = 100_000_000


def _config_from_args(args: argparse.Namespace) -> dict[str, Any]:
    if args.config and args.model:
        raise config_mod.ConfigError("give --config or --model, not both")
    if not args.config and not args.model:
        raise config_mod.ConfigError("give --config CFG.yml, or --model NAME with --dataset DIR")
    path = Path(args.config) if args.config else config_mod.shipped(args.model)
    config = config_mod.load(path)
    if args.dataset is None and args.model and not args.resume:
        raise config_mod.ConfigError("--model needs --dataset DIR (a `unicac dataset build` folder)")
    config = copy.deepcopy(config)
    if args.dataset is not None:
        for split in ("train", "val"):
            config["datasets"][split]["type"] = "unicac"
            config["datasets"][split]["dataroot"] = str(args.dataset)
    if args.iters is not None:
        if not 1 <= args.iters <= MAX_ITERS:
            raise config_mod.ConfigError(f"--iters: {args.iters} is outside 1..{MAX_ITERS}")
        config["train"]["total_iter"] = args.iters
    return config_mod.validate(config)


def _train(args: argparse.Namespace) -> int:
    from .models import Trainer

    config = _config_from_args(args)
    trainer = Trainer(config, args.out, resume=args.resume, quiet=args.quiet)
    scores = trainer.train()
    if trainer.rank == 0:
        summary = {"run": str(args.out), "architecture": trainer.net.architecture, **scores}
        print(json.dumps(summary) if args.json else
              f"{args.out}: {trainer.net.architecture}, val PSNR {scores.get('psnr_db', float('nan')):.2f} dB "
              f"(input {scores.get('input_psnr_db', float('nan')):.2f} dB), SSIM {scores.get('ssim', float('nan')):.4f}")
    return 0


def _export(args: argparse.Namespace) -> int:
    from .export import export_run

    report = export_run(args.run_dir, args.out, check=not args.no_check)
    if args.json:
        print(json.dumps(report))
    else:
        parity = ", ".join(f"{k}: {v:.1e}" for k, v in report["parity"].items()) or "not checked"
        print(f"{report['path']}: {report['architecture']} (inputs {','.join(report['inputs'])}), "
              f"{report['bytes'] / 1e6:.2f} MB, onnxruntime vs PyTorch max diff {parity}")
    return 0


def model_table() -> list[dict[str, Any]]:
    """The shipped models: name, ONNX inputs, learned or not, parameter count, config path."""
    from .archs import build_network, count_parameters

    rows: list[dict[str, Any]] = [{
        "name": "wiener", "inputs": ["lq", "psf"], "learned": False, "params": 0, "config": None,
        "note": "field-varying Wiener deconvolution with the true PSF table: `unicac bench --method wiener`",
    }]
    for path in sorted(config_mod.CONFIG_DIR.glob("*.yml")):
        config = config_mod.load(path)
        net = build_network(config["network"])
        rows.append({"name": path.stem, "inputs": net.inputs, "learned": True, "params": count_parameters(net),
                     "config": str(path), "architecture": net.architecture})
    return rows


def _models(args: argparse.Namespace) -> int:
    rows = model_table()
    if args.json:
        print(json.dumps(rows, indent=2))
        return 0
    for row in rows:
        print(f"{row['name']:<18} inputs {','.join(row['inputs']):<8} params {row['params']:>9,}  "
              f"{'learned' if row['learned'] else 'classical'}  {row['config'] or row.get('note', '')}")
    return 0


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="unicac-train", description="Train restoration models on unicac data; export to ONNX.")
    sub = p.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train", help="train from a config, or from a shipped model's config")
    t.add_argument("--config", help="a YAML config (BasicSR-shaped keys)")
    t.add_argument("--model", help="a shipped model (see `unicac-train models`)")
    t.add_argument("--dataset", help="a `unicac dataset build` folder (replaces the config's dataroot)")
    t.add_argument("--iters", type=int, help=f"iterations (replaces train.total_iter; 1..{MAX_ITERS})")
    t.add_argument("--out", required=True, help="run folder (config, checkpoints, logs, curves)")
    t.add_argument("--resume", action="store_true", help="continue the run in --out from its latest checkpoint")
    t.add_argument("--quiet", action="store_true", help="no progress output")
    t.add_argument("--json", action="store_true", help="print the final summary as JSON")
    t.set_defaults(run=_train)
    e = sub.add_parser("export", help="export a run's latest checkpoint to ONNX (docs/models.md)")
    e.add_argument("run_dir", help="a run folder written by `unicac-train train`")
    e.add_argument("--out", required=True, help="the ONNX file to write")
    e.add_argument("--no-check", action="store_true", help="skip the onnxruntime parity check")
    e.add_argument("--json", action="store_true")
    e.set_defaults(run=_export)
    m = sub.add_parser("models", help="list the architectures")
    m.add_argument("--json", action="store_true")
    m.set_defaults(run=_models)
    return p


def main(argv: Optional[list[str]] = None) -> int:
    args = parser().parse_args(argv)
    from unicac.dataset import DatasetFolderError

    from .models import RunError

    try:
        return int(args.run(args))
    except (config_mod.ConfigError, DatasetFolderError, RunError, FileNotFoundError) as error:
        message = str(error)
        print(f"unicac-train: error: {message}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("unicac-train: interrupted (resume with --resume)", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
