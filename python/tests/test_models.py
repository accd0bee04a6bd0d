"""Issue 31's models and recipe: the PSF basis and code (against numpy), the Wiener input, wiener-nafnet's
start, equal-size controls, the architecture registry, receptive fields, the patch / receptive-field
checks, the time budget (stop, export, resume), GAN fine-tuning with EMA, the blind model's logged
prediction error, CPU mixed precision, and export failing without onnxruntime. Tiny tensors and a
few iterations. Skipped only when torch is not importable."""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

torch = pytest.importorskip("torch", reason="torch is not installed (pip install './python[train]')")
pytest.importorskip("yaml", reason="pyyaml is not installed (pip install './python[train]')")

import unicac  # noqa: E402
from fake_dataset import FIELDS, KERNEL_PX, make_dataset  # noqa: E402
from unicac.dataset import DatasetFolder  # noqa: E402
from unicac.train import config as config_mod  # noqa: E402
from unicac.train.archs import CONTROLS, build_network, count_parameters  # noqa: E402
from unicac.train.archs.receptive import receptive_field_px  # noqa: E402
from unicac.train.cli import main as cli_main  # noqa: E402
from unicac.train.data import augment as augment_mod  # noqa: E402
from unicac.train.models import Trainer  # noqa: E402

torch.set_num_threads(1)


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    root = make_dataset(tmp_path_factory.mktemp("data") / "ds")
    unicac.psf_basis(root)
    return root


def tiny_config(model: str, dataset: Path, iters: int = 4, **train) -> dict:
    config = config_mod.load(config_mod.shipped(model))
    for split in ("train", "val"):
        config["datasets"][split]["dataroot"] = str(dataset)
    config["datasets"]["train"].update(patch_px=24, batch_size=2)
    config["datasets"]["val"].update(max_pairs=2, crop_px=32)
    config["train"].update(total_iter=iters, **train)
    config["val"]["val_freq"] = 2
    config["logger"].update(print_freq=1, save_checkpoint_freq=2)
    return config_mod.validate(config)


def _checkpoint(run: Path) -> dict:
    return torch.load(run / "checkpoints" / "latest.pt", weights_only=True)


# -- the PSF basis and code ------------------------------------------------------------------------

def _prepared(kernel: np.ndarray) -> np.ndarray:
    """A table kernel as the basis sees it: averaged with its mirror image about its radius (rows)."""
    return 0.5 * (kernel + kernel[::-1, :])


def test_psf_basis_matches_numpy_svd(dataset):
    """The Rust fit against LAPACK (numpy's SVD of the centred training kernels): the same explained
    share (1e-9), the same components (|cos| > 1 - 1e-6) and coefficient scales (1e-6 relative)."""
    meta = unicac.psf_basis(dataset)
    folder = DatasetFolder(dataset)
    train_tables = sorted({row["psf"] for row in folder.pairs("train")})
    assert meta["kernel_px"] == KERNEL_PX and meta["fit_kernels"] == len(FIELDS) * len(train_tables)
    components = np.load(dataset / "psf" / "basis" / "components.npy")
    mean = np.load(dataset / "psf" / "basis" / "mean.npy")
    assert components.shape == (3, 16, KERNEL_PX, KERNEL_PX) and mean.shape == (3, KERNEL_PX, KERNEL_PX)
    for c in range(3):
        x = np.stack([_prepared(k[c]).ravel() for t in train_tables for k in np.load(dataset / t / "kernels.npy")]).astype(np.float64)
        np.testing.assert_allclose(mean[c].ravel(), x.mean(axis=0), atol=1e-7)
        centred = x - x.mean(axis=0)
        _, singular, vt = np.linalg.svd(centred, full_matrices=False)
        m = meta["components"][c]
        assert 1 <= m <= 16
        explained = (singular[:m] ** 2).sum() / (singular**2).sum()
        assert abs(explained - meta["explained"][c]) < 1e-9
        assert explained >= meta["energy_share_target"] or m == min(16, int((singular > 1e-12 * singular[0]).sum()))
        for i in range(m):
            cos = float(components[c, i].ravel().astype(np.float64) @ vt[i])
            assert abs(cos) > 1 - 1e-6, (c, i, cos)
            std = singular[i] / np.sqrt(len(x))
            assert abs(std - meta["coefficient_std"][c][i]) <= 1e-6 * std
        assert not components[c, m:].any()
    assert meta["explained_held_out"] is not None and len(meta["sha256"]) == 64
    # Asked again, the stored basis is read back (the same numbers).
    assert unicac.psf_basis(dataset) == meta


def test_psf_code_follows_flips_and_transposes(dataset):
    """The code map of a flipped / transposed crop equals the map computed at the mirrored / transposed
    position (coefficients exactly kept, azimuth channels changed as the FoV map's)."""
    folder = DatasetFolder(dataset)
    row = folder.pairs("train")[0]
    radii, codes = unicac.psf_field_codes(folder.path(row["psf"]), folder.psf_basis_dir)
    assert radii.shape == (len(FIELDS),) and codes.shape == (len(FIELDS), 48)
    fw, fh = row["frame_px"]
    x0, y0, w, h = 10, 6, 20, 14
    code = unicac.psf_code_map(radii, codes, fw, fh, x0, y0, w, h)
    assert code.shape == (50, h, w) and np.isfinite(code).all()
    np.testing.assert_allclose(augment_mod.hflip_code(code), unicac.psf_code_map(radii, codes, fw, fh, fw - x0 - w, y0, w, h), atol=1e-5)
    np.testing.assert_allclose(augment_mod.vflip_code(code), unicac.psf_code_map(radii, codes, fw, fh, x0, fh - y0 - h, w, h), atol=1e-5)
    sq = 64
    code_sq = unicac.psf_code_map(radii, codes, sq, sq, x0, y0, w, h)
    np.testing.assert_allclose(augment_mod.transpose_code(code_sq), unicac.psf_code_map(radii, codes, sq, sq, y0, x0, h, w), atol=1e-5)
    # The azimuth channels are the FoV map's direction.
    fov = unicac.fov_map(fw, fh, x0, y0, w, h)
    radius = np.hypot(fov[0], fov[1])
    np.testing.assert_allclose(code[48], fov[0] / radius, atol=1e-5)
    np.testing.assert_allclose(code[49], fov[1] / radius, atol=1e-5)
    # The data path serves the same map.
    pair = folder.load(row, window=(3, 5, 16, 12), psf_code=True)
    cx, cy = row["crop"][:2]
    np.testing.assert_array_equal(pair["psf_code"], unicac.psf_code_map(radii, codes, fw, fh, cx + 3, cy + 5, 16, 12))


def test_a_dataset_without_a_basis_names_the_fix(tmp_path):
    root = make_dataset(tmp_path / "nobasis", pairs_per_split=1)
    with pytest.raises(unicac.dataset.DatasetFolderError, match="unicac dataset build"):
        DatasetFolder(root).psf_basis()
    assert cli_main(["train", "--model", "nafnet-psf", "--dataset", str(root), "--iters", "2", "--patch-px", "24",
                     "--out", str(tmp_path / "run")]) == 1
    assert not (tmp_path / "run").exists()


# -- the Wiener input and wiener-nafnet ---------------------------------------------------------------

def test_wiener_input_is_the_bench_function(dataset):
    """On a whole pair the data path's `wiener` is `unicac.wiener_restore` (the bench's function); on a
    window it is that estimate of the window grown by one kernel width, cut."""
    folder = DatasetFolder(dataset)
    row = folder.pairs("train")[1]
    table = folder.path(row["psf"])
    fw, fh = row["frame_px"]
    cx, cy = row["crop"][:2]
    whole = folder.load(row, wiener=True)
    direct = unicac.wiener_restore(whole["lq"], table, fw, fh, cx, cy)
    np.testing.assert_array_equal(whole["wiener"], direct)
    assert whole["wiener"].shape == whole["lq"].shape and 0 <= whole["wiener"].min() and whole["wiener"].max() <= 1
    window = (20, 24, 30, 28)
    part = folder.load(row, window=window, wiener=True)["wiener"]
    x, y, w, h = window
    grown = whole["lq"][y - KERNEL_PX : y + h + KERNEL_PX, x - KERNEL_PX : x + w + KERNEL_PX]
    expected = unicac.wiener_restore(np.ascontiguousarray(grown), table, fw, fh, cx + x - KERNEL_PX, cy + y - KERNEL_PX)
    np.testing.assert_array_equal(part, expected[KERNEL_PX : KERNEL_PX + h, KERNEL_PX : KERNEL_PX + w])
    # (That it sharpens a blur its table describes is the bench's test: crates/unicac-bench/tests/bench.rs.
    # This fixture blurs with another kernel than its tables hold.)
    assert np.abs(whole["wiener"] - whole["lq"]).mean() > 1e-3
    with pytest.raises(ValueError, match="lq"):
        unicac.wiener_restore(np.full((8, 8, 3), np.nan, np.float32), table, fw, fh)


def test_an_untrained_wiener_nafnet_returns_its_wiener_input():
    torch.manual_seed(0)
    net = build_network(config_mod.load(config_mod.shipped("wiener-nafnet"))["network"])
    g = torch.Generator().manual_seed(1)
    lq, wiener = torch.rand(2, 3, 37, 45, generator=g), torch.rand(2, 3, 37, 45, generator=g)
    with torch.no_grad():
        assert torch.equal(net(lq, wiener=wiener), wiener)
    # One step later it refines: the output moves away from the estimate.
    optimiser = torch.optim.AdamW(net.parameters(), 1e-3)
    torch.nn.functional.l1_loss(net(lq, wiener=wiener), (wiener + 0.1).clamp(0, 1)).backward()
    optimiser.step()
    with torch.no_grad():
        assert not torch.equal(net(lq, wiener=wiener), wiener)


# -- registry, controls, receptive fields -----------------------------------------------------------

SHIPPED = {  # name: (inputs, predicts, architecture)
    "nafnet": (["lq"], None, "nafnet"),
    "nafnet-fov": (["lq", "fov"], None, "nafnet-fov"),
    "nafnet-psf": (["lq", "psf_code"], None, "nafnet-psf"),
    "nafnet-psf-control": (["lq"], None, "nafnet-psf-control"),
    "nafnet-psf-moments": (["lq", "psf"], None, "nafnet-psf-moments"),
    "nafnet-psf-blind": (["lq"], "psf_code", "nafnet-psf-blind"),
    "nafnet-psf-blind-control": (["lq"], None, "nafnet-psf-blind-control"),
    "wiener-nafnet": (["lq", "wiener"], None, "wiener-nafnet"),
    "restormer": (["lq"], None, "restormer"),
    "nafnet-gan": (["lq"], None, "nafnet"),
}


def test_architectures_declare_their_inputs_and_predictions():
    assert {p.stem for p in config_mod.CONFIG_DIR.glob("*.yml")} == set(SHIPPED)
    for name, (inputs, predicts, architecture) in SHIPPED.items():
        net = build_network(config_mod.load(config_mod.shipped(name))["network"])
        assert (net.inputs, net.predicts, net.architecture) == (inputs, predicts, architecture), name


def test_each_prior_model_has_a_control_of_equal_size():
    """`prior helps` must not be `more parameters help`: each prior model's control (no prior) has the
    same parameter count within 1%."""
    priors = [n for n, (inputs, predicts, _) in SHIPPED.items() if len(inputs) > 1 or predicts]
    assert sorted(priors) == sorted(CONTROLS)
    for prior, control in CONTROLS.items():
        a = count_parameters(build_network(config_mod.load(config_mod.shipped(prior))["network"]))
        b = count_parameters(build_network(config_mod.load(config_mod.shipped(control))["network"]))
        assert abs(a - b) <= 0.01 * a, (prior, a, control, b)
        assert build_network(config_mod.load(config_mod.shipped(control))["network"]).inputs == ["lq"]


def _naf_field(enc, middle, dec):
    """The analytic receptive field of a NAFNet: 3x3 intro and ending (+2 each), one 3x3 depth-wise conv
    per block (+2 x scale), a 2x2 stride-2 down convolution per level (+1 x scale)."""
    width = 2 + 2
    for level, n in enumerate(enc):
        width += 2 * 2**level * n + 2**level
    width += 2 * 2 ** len(enc) * middle
    for level, n in enumerate(dec):
        width += 2 * 2 ** (len(dec) - 1 - level) * n
    return width + 1


@pytest.mark.parametrize("enc,middle,dec", [([1, 1, 2], 2, [1, 1, 1]), ([1, 1, 1, 2], 2, [1, 1, 1, 1]), ([0], 0, [0])])
def test_receptive_field_matches_the_analytic_width(enc, middle, dec):
    net = build_network({"type": "NAFNet", "width": 4, "enc_blocks": enc, "middle_blocks": middle, "dec_blocks": dec})
    assert receptive_field_px(net, start_side_px=32) == (_naf_field(enc, middle, dec), True)
    # The prior paths do not widen it (the map's injections are 1x1 after average pooling).
    code = build_network({"type": "NAFNet", "width": 4, "enc_blocks": enc, "middle_blocks": middle, "dec_blocks": dec,
                          "prior": "psf_code"})
    assert receptive_field_px(code, start_side_px=32)[0] >= _naf_field(enc, middle, dec)


def test_receptive_field_of_a_restormer_is_local_paths_only():
    net = build_network({"type": "Restormer", "dim": 4, "blocks": [1, 1], "heads": [1, 1], "refinement_blocks": 0})
    width, exact = receptive_field_px(net, start_side_px=32)
    # The convolutions alone: intro 3x3 (+2), two depth-wise 3x3 per block (+4 x scale), down 3x3 at
    # full resolution (+2), up 3x3 at half (+4), ending 3x3 (+2): 2 + 4 + 2 + 8 + 4 + 4 + 2 = 26 px
    # plus the pixel (un)shuffles' alignment; the attention map's global reach is excluded.
    assert exact and 26 <= width <= 32, width


# -- the recipe checks, the budget, resume ----------------------------------------------------------

def test_a_patch_under_twice_the_largest_kernel_is_refused_or_warned(tmp_path, capsys, monkeypatch):
    import fake_dataset

    monkeypatch.setattr(fake_dataset, "KERNEL_PX", 11)  # 2 x 11 = 22 px: above the 16 px minimum patch
    wide = make_dataset(tmp_path / "wide", pairs_per_split=1)
    args = ["train", "--model", "nafnet", "--dataset", str(wide), "--iters", "1", "--batch", "1"]
    assert cli_main(args + ["--patch-px", "16", "--out", str(tmp_path / "r1")]) == 1
    err = capsys.readouterr().err
    assert "16 px is less than twice the dataset's largest PSF kernel (11 px" in err and "--patch-px 22" in err, err
    assert "--allow-small-patch" in err and not (tmp_path / "r1").exists()
    assert cli_main(args + ["--patch-px", "16", "--allow-small-patch", "--quiet", "--out", str(tmp_path / "r2")]) == 0
    assert "warning: datasets.train.patch_px: 16 px" in capsys.readouterr().err
    recipe = json.loads((tmp_path / "r2" / "run.json").read_text())["recipe"]
    assert recipe["patch_px"] == 16 and recipe["batch_size"] == 1 and recipe["largest_kernel_px"] == 11
    assert recipe["receptive_field_px"] >= 11
    lenses_digest = hashlib.sha256((wide / "lenses.jsonl").read_bytes()).hexdigest()
    assert recipe["dataset_lenses_sha256"] == lenses_digest
    # The session's --allow-small-patch is not the run's: the saved config does not carry it.
    assert config_mod.load(tmp_path / "r2" / "config.yml")["train"]["allow_small_patch"] is False


def test_a_network_narrower_than_the_kernel_is_refused(tmp_path, dataset, capsys):
    config = tiny_config("nafnet", dataset)
    config["network"].update(enc_blocks=[0], middle_blocks=0, dec_blocks=[0])  # receptive field 6 px < 7 px
    config = config_mod.validate(config)
    with pytest.raises(config_mod.ConfigError, match=r"receptive field is 6 px, narrower than the dataset's largest PSF kernel \(7 px"):
        Trainer(config, tmp_path / "r", quiet=True)
    config["train"]["allow_small_receptive_field"] = True
    Trainer(config, tmp_path / "r", quiet=True)
    assert "warning: network: nafnet's receptive field is 6 px" in capsys.readouterr().err


def test_the_time_budget_stops_with_an_exportable_checkpoint_and_resume_equals_straight(tmp_path, dataset):
    pytest.importorskip("onnxruntime")
    config = tiny_config("nafnet", dataset, iters=5)
    Trainer(config, tmp_path / "straight", quiet=True).train()
    budgeted = json.loads(json.dumps(config))
    budgeted["train"]["time_budget_s"] = 1e-9  # spent after the first iteration (the schema's floor is 1 s)
    assert config_mod.sha256(budgeted) == config_mod.sha256(config), "a session setting is not part of the run"
    trainer = Trainer(budgeted, tmp_path / "budget", quiet=True)
    scores = trainer.train()
    assert trainer.stopped_by_budget and _checkpoint(tmp_path / "budget")["iteration"] == 1
    assert scores and "psnr_db" in scores
    info = json.loads((tmp_path / "budget" / "run.json").read_text())
    assert info["stopped_by_time_budget"] and info["iterations"] == 1 and info["wall_time_s"] > 0
    assert cli_main(["export", str(tmp_path / "budget"), "--out", str(tmp_path / "budget.onnx")]) == 0
    # --resume alone takes the run's own config; the final weights equal an uninterrupted run's.
    assert cli_main(["train", "--resume", "--quiet", "--out", str(tmp_path / "budget")]) == 0
    a, b = _checkpoint(tmp_path / "straight"), _checkpoint(tmp_path / "budget")
    assert a["iteration"] == b["iteration"] == 5
    for name in a["net"]:
        assert torch.equal(a["net"][name], b["net"][name]), name


def test_recipe_flags_reach_the_run_config(tmp_path, dataset):
    assert cli_main(["train", "--model", "nafnet-fov", "--dataset", str(dataset), "--iters", "2", "--patch-px", "32",
                     "--batch", "3", "--device", "cpu", "--amp", "off", "--channels-last", "off", "--quiet",
                     "--out", str(tmp_path / "run")]) == 0
    config = config_mod.load(tmp_path / "run" / "config.yml")
    assert config["datasets"]["train"]["patch_px"] == 32 and config["datasets"]["train"]["batch_size"] == 3
    assert config["train"]["total_iter"] == 2 and config["train"]["device"] == "cpu"
    for bad, message in ((["--patch-px", "8"], "--patch-px: 8 is outside"), (["--batch", "0"], "--batch: 0 is outside"),
                         (["--time-budget-s", "0"], "--time-budget-s: 0 is outside")):
        assert cli_main(["train", "--model", "nafnet", "--dataset", str(dataset), "--out", str(tmp_path / "x"), *bad]) == 1


def test_cpu_mixed_precision_and_channels_last_train(tmp_path, dataset):
    config = tiny_config("nafnet-psf", dataset, iters=2, amp="bf16", channels_last="on", device="cpu")
    trainer = Trainer(config, tmp_path / "run", quiet=True)
    assert trainer.amp_dtype == torch.bfloat16 and trainer.channels_last
    scores = trainer.train()
    assert np.isfinite(scores["psnr_db"])
    if not torch.cuda.is_available():
        with pytest.raises(config_mod.ConfigError, match="train.device: cuda"):
            Trainer(tiny_config("nafnet", dataset, device="cuda"), tmp_path / "cuda", quiet=True)
        with pytest.raises(config_mod.ConfigError, match="fp16 autocast needs a CUDA device"):
            Trainer(tiny_config("nafnet", dataset, amp="fp16"), tmp_path / "fp16", quiet=True)


# -- the blind model, the GAN, export ----------------------------------------------------------------

def test_the_blind_model_logs_its_code_prediction_error(tmp_path, dataset):
    run = tmp_path / "blind"
    trainer = Trainer(tiny_config("nafnet-psf-blind", dataset), run, quiet=True)
    scores = trainer.train()
    assert scores["prediction_l1"] > 0 and scores["prediction_l1_zero"] > 0
    rows = [json.loads(line) for line in (run / "log.jsonl").read_text().splitlines()]
    assert all(r["prediction_l1"] is not None for r in rows if r["kind"] == "val")
    # Its control trains without the PSF maps' supervision and logs no prediction.
    control = Trainer(tiny_config("nafnet-psf-blind-control", dataset), tmp_path / "control", quiet=True)
    assert "prediction_l1" not in control.train()


def test_gan_fine_tunes_a_trained_run_with_an_ema_generator(tmp_path, dataset, monkeypatch):
    from unicac.train.losses import ALEXNET_CONVS

    rng = np.random.default_rng(0)
    arrays = {}
    for i, (o, c, k, _, _) in enumerate(ALEXNET_CONVS):
        arrays[f"conv{i}.weight"] = rng.normal(0, 0.05, (o, c, k, k)).astype(np.float32)
        arrays[f"conv{i}.bias"] = np.zeros(o, np.float32)
        arrays[f"lin{i}.weight"] = np.abs(rng.normal(0, 0.1, (1, o, 1, 1))).astype(np.float32)
    folder = tmp_path / "cache" / "weights" / "lpips"
    folder.mkdir(parents=True)
    np.savez(folder / "alexnet.npz", **arrays)
    monkeypatch.setenv("UNICAC_CACHE_DIR", str(tmp_path / "cache"))
    Trainer(tiny_config("nafnet", dataset, iters=2), tmp_path / "nafnet", quiet=True).train()

    def gan_config(**path):
        config = config_mod.load(config_mod.shipped("nafnet-gan"))
        for split in ("train", "val"):
            config["datasets"][split]["dataroot"] = str(dataset)
        config["datasets"]["train"].update(patch_px=64, batch_size=2)
        config["datasets"]["val"].update(max_pairs=2, crop_px=32)
        config["train"]["total_iter"] = 3
        config["val"]["val_freq"] = 2
        config["logger"].update(print_freq=1, save_checkpoint_freq=2)
        config["train"]["losses"]["perceptual"]["net"] = "alexnet"
        config["train"]["losses"]["gan"]["width"] = 8
        config["path"].update(path)
        return config_mod.validate(config)

    with pytest.raises(config_mod.ConfigError, match="--init-from RUN"):
        Trainer(gan_config(), tmp_path / "scratch", quiet=True)
    trainer = Trainer(gan_config(pretrain_network_g=str(tmp_path / "nafnet")), tmp_path / "gan", quiet=True)
    start = _checkpoint(tmp_path / "nafnet")["net"]
    assert all(torch.equal(start[k], v) for k, v in trainer.net.state_dict().items())
    trainer.train()
    state = _checkpoint(tmp_path / "gan")
    ema = {k[len("module."):]: v for k, v in state["net_ema"].items() if k.startswith("module.")}
    assert set(ema) == set(state["net"]) and any(not torch.equal(ema[k], state["net"][k]) for k in ema)
    pytest.importorskip("onnxruntime")
    from unicac.train.export import load_run, read_metadata

    net, _, _ = load_run(tmp_path / "gan")
    assert all(torch.equal(net.state_dict()[k], ema[k]) for k in ema)
    assert cli_main(["export", str(tmp_path / "gan"), "--out", str(tmp_path / "gan.onnx")]) == 0
    assert read_metadata(tmp_path / "gan.onnx")["weights"] == "ema"


def test_export_fails_loudly_without_onnxruntime(tmp_path, dataset, monkeypatch, capsys):
    Trainer(tiny_config("wiener-nafnet", dataset, iters=1), tmp_path / "run", quiet=True).train()
    monkeypatch.setitem(sys.modules, "onnxruntime", None)  # `import onnxruntime` raises ImportError
    assert cli_main(["export", str(tmp_path / "run"), "--out", str(tmp_path / "m.onnx")]) == 1
    err = capsys.readouterr().err
    assert "parity check cannot run" in err and "--no-check" in err
    assert not (tmp_path / "m.onnx").exists()
    assert cli_main(["export", str(tmp_path / "run"), "--out", str(tmp_path / "m.onnx"), "--no-check"]) == 0
    assert "parity check was skipped" in capsys.readouterr().err
    from unicac.train.export import read_metadata

    meta = read_metadata(tmp_path / "m.onnx")
    assert meta["unicac_contract"] == "2" and meta["inputs"] == "lq,wiener" and float(meta["wiener_nsr"]) == 0.01


def test_a_psf_code_model_exports_its_basis(tmp_path, dataset):
    pytest.importorskip("onnxruntime")
    from unicac.train.export import read_metadata

    Trainer(tiny_config("nafnet-psf", dataset, iters=1), tmp_path / "run", quiet=True).train()
    assert cli_main(["export", str(tmp_path / "run"), "--out", str(tmp_path / "m.onnx")]) == 0
    meta = read_metadata(tmp_path / "m.onnx")
    assert meta["unicac_contract"] == "2" and meta["inputs"] == "lq,psf_code"
    assert meta["psf_basis_sha256"] == unicac.psf_basis(dataset)["sha256"]
    # The basis travels with the run and the model (`m.basis/`, what `dataset build --psf-basis-from`
    # takes), byte for byte the dataset's: the model stays usable when its dataset is gone.
    from unicac.dataset import PSF_BASIS_FILES

    for folder in (tmp_path / "run" / "psf_basis", tmp_path / "m.basis"):
        for name in PSF_BASIS_FILES:
            assert (folder / name).read_bytes() == (dataset / "psf" / "basis" / name).read_bytes(), (folder, name)
    # Without the run's copy the dataset's serves; with neither the export names both places.
    (tmp_path / "run" / "psf_basis" / "basis.json").unlink()
    assert cli_main(["export", str(tmp_path / "run"), "--out", str(tmp_path / "n.onnx"), "--no-check"]) == 0
    assert (tmp_path / "n.basis" / "basis.json").is_file()
    config = (tmp_path / "run" / "config.yml").read_text().replace(str(dataset), str(tmp_path / "gone"))
    (tmp_path / "run" / "config.yml").write_text(config)
    assert cli_main(["export", str(tmp_path / "run"), "--out", str(tmp_path / "o.onnx"), "--no-check"]) == 1
    assert not (tmp_path / "o.onnx").exists() and not (tmp_path / "o.basis").exists()
