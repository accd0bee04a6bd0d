"""ONNX export of a run's latest checkpoint, following docs/models.md:

inputs `lq` [N,3,H,W] (+ `fov` [N,2,H,W], `psf` [N,15,H,W], `psf_code` [N,50,H,W], `wiener` [N,3,H,W]
as the network uses them), output `restored` [N,3,H,W]; N, H and W dynamic; opset 17; metadata
`unicac_contract` (1, or 2 for a model with a contract-2 input), `architecture`, `inputs`,
`config_sha256`, `unicac_version`, and `psf_basis_sha256` / `wiener_nsr` for the models that need
them; a `psf_code` model's PSF basis is written beside it (`NAME.basis/`, the folder `unicac dataset
build --psf-basis-from` takes). A run that keeps EMA weights is exported from them. The exported file
is checked in onnxruntime against PyTorch at two image sizes before it is moved into place (atomic);
without onnxruntime the export fails, naming the flag that skips the check (`--no-check`).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from unicac.dataset import basis_sha256, copy_psf_basis, dataset_basis_dir
from unicac.outputs import write_bytes

from .archs import Restorer, build_network
from .models.trainer import RunError, RunFolder, _unicac_version
from .onnx_graph import ExportError, check_parity, onnx_graph

__all__ = ["CONTRACT_VERSION", "ExportError", "check_parity", "contract_version", "export_network", "export_run",
           "load_run", "onnx_graph", "read_metadata"]

#: The newest contract version (docs/models.md); a model is written with the lowest that has its inputs.
CONTRACT_VERSION = "2"
CONTRACT_OF_INPUT = {"lq": 1, "fov": 1, "psf": 1, "psf_code": 2, "wiener": 2}


def contract_version(inputs: list[str]) -> str:
    return str(max(CONTRACT_OF_INPUT[name] for name in inputs))


def load_run(run_dir: "os.PathLike[str] | str") -> tuple[Restorer, dict[str, Any], dict[str, Any]]:
    """The run's network with its latest weights (the EMA weights when the run keeps them; eval mode),
    its config and checkpoint."""
    run = RunFolder(run_dir)
    config = run.load_config()
    state = run.load_checkpoint()
    net = build_network(config["network"])
    saved = state.get("architecture")
    if saved is not None and saved != net.architecture:
        raise RunError(f"{run.checkpoint}: holds a {saved} network, but the run's {run.config.name} describes {net.architecture}")
    try:
        if "net_ema" in state:
            prefix = "module."
            net.load_state_dict({k[len(prefix):]: v for k, v in state["net_ema"].items() if k.startswith(prefix)})
        else:
            net.load_state_dict(state["net"])
    except RuntimeError as error:
        # torch lists every missing or mismatched key, one per line after a heading: show the first.
        lines = [line.strip() for line in str(error).strip().splitlines() if line.strip()]
        reason = lines[1] if len(lines) > 1 else lines[0]
        raise RunError(f"{run.checkpoint}: its weights do not fit the network of the run's {run.config.name} ({reason})") from error
    net.eval()
    return net, config, state


def export_network(net: Restorer, out: Path, metadata: dict[str, str], check: bool = True) -> dict[str, Any]:
    """Writes `net` to `out` (ONNX, docs/models.md); returns {"path", "bytes", "parity": max |diff| per
    checked size} (`check=False`: no parity check, "parity" empty)."""
    import onnx

    model = onnx_graph(net)
    del model.metadata_props[:]
    for key, value in metadata.items():
        entry = model.metadata_props.add()
        entry.key, entry.value = key, value
    onnx.checker.check_model(model)
    data = model.SerializeToString()
    out = Path(out)
    report: dict[str, Any] = {"path": str(out), "bytes": len(data), "parity": {}}
    if check:
        report["parity"] = check_parity(net, data)
    write_bytes(out, data)
    return report


def export_run(run_dir: "os.PathLike[str] | str", out: "os.PathLike[str] | str", check: bool = True) -> dict[str, Any]:
    """`unicac-train export RUN_DIR --out MODEL.onnx`."""
    net, config, state = load_run(run_dir)
    metadata = {
        "unicac_contract": contract_version(net.inputs),
        "architecture": net.architecture,
        "inputs": ",".join(net.inputs),
        "config_sha256": str(state.get("config_sha256", "")),
        "unicac_version": _unicac_version(),
        "name": str(config["name"]),
        "iterations": str(state.get("iteration", "")),
    }
    basis_source = None
    if "psf_code" in net.inputs:
        basis = state.get("psf_basis_sha256")
        if not basis:
            raise ExportError(f"{run_dir}: the checkpoint records no psf_basis_sha256, which a psf_code model needs")
        metadata["psf_basis_sha256"] = str(basis)
        basis_source = _run_basis(Path(run_dir), config, str(basis))
        if basis_beside(out).exists() and not basis_beside(out).is_dir():
            raise ExportError(f"--out {out}: {basis_beside(out)} is a file; the model's PSF basis folder goes there")
    if "wiener" in net.inputs:
        metadata["wiener_nsr"] = repr(float(config["datasets"]["train"]["wiener_nsr"]))
    if "net_ema" in state:
        metadata["weights"] = "ema"
    report = export_network(net, Path(out), metadata, check=check)
    report.update({"architecture": net.architecture, "inputs": net.inputs, "iterations": state.get("iteration")})
    if basis_source is not None:
        copy_psf_basis(basis_source, basis_beside(out))
        report["psf_basis"] = str(basis_beside(out))
    return report


def basis_beside(model: "os.PathLike[str] | str") -> Path:
    """Where a psf_code model's PSF basis is written: `NAME.basis/` beside `NAME.onnx` (what `unicac
    dataset build --psf-basis-from` takes, so a new test set speaks the model's code)."""
    return Path(model).with_suffix(".basis")


def _run_basis(run_dir: Path, config: dict[str, Any], sha: str) -> Path:
    """The PSF basis a psf_code run trained with: the copy the run keeps, else its dataset's, whichever
    records `sha`; ExportError when neither does (the model would be unusable on any new dataset)."""
    dataroot = config["datasets"]["train"].get("dataroot")
    candidates = [RunFolder(run_dir).psf_basis] + ([dataset_basis_dir(dataroot)] if dataroot else [])
    for folder in candidates:
        if basis_sha256(folder) == sha:
            return folder
    raise ExportError(
        f"{run_dir}: the PSF basis {sha} this psf_code model was trained with is in neither "
        f"{' nor '.join(str(c) for c in candidates)}; without it the model runs on no new dataset"
    )


def read_metadata(path: "os.PathLike[str] | str") -> dict[str, str]:
    import onnx

    model = onnx.load(str(path))
    return {entry.key: entry.value for entry in model.metadata_props}


