"""The training-pair generator: deterministic per seed and worker, images or charts, optical priors;
the PyTorch wrapper only when torch is installed (and torch is never imported otherwise)."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

import unicac
from unicac.dataset import PairGenerator, fit_kernels, to_chw

LENSES = ["builtin:cooke_triplet", "builtin:phone_asphere"]


@pytest.fixture(scope="module")
def generator():
    return PairGenerator(LENSES, patch_px=32, frame_px=(96, 64), seed=7, with_field_map=True, with_psf=True)


def test_pairs_have_the_documented_shapes(generator):
    pair = generator.pair(0)
    assert pair["degraded"].shape == pair["sharp"].shape == (32, 32, 3)
    assert pair["degraded"].dtype == pair["sharp"].dtype == np.float32
    assert 0.0 <= pair["sharp"].min() and pair["sharp"].max() <= 1.0
    assert pair["field_map"].shape == (32, 32, 3)
    assert np.abs(pair["field_map"][..., :2]).max() <= 1.0 + 1e-6
    assert pair["psf"].ndim == 3 and pair["psf"].shape[0] == 3
    np.testing.assert_allclose(pair["psf"].sum(axis=(1, 2)), 1.0, rtol=1e-4)
    assert pair["lens"] in LENSES


def test_deterministic_per_seed_and_index(generator):
    again = PairGenerator(LENSES, patch_px=32, frame_px=(96, 64), seed=7, with_field_map=True, with_psf=True)
    for index in (0, 3):
        a, b = generator.pair(index), again.pair(index)
        np.testing.assert_array_equal(a["degraded"], b["degraded"])
        np.testing.assert_array_equal(a["sharp"], b["sharp"])
        assert a["origin_px"] == b["origin_px"] and a["lens"] == b["lens"]
    other = PairGenerator(LENSES, patch_px=32, frame_px=(96, 64), seed=8)
    assert not np.array_equal(other.pair(0)["sharp"], generator.pair(0)["sharp"])
    assert not np.array_equal(generator.pair(1)["sharp"], generator.pair(0)["sharp"])


def test_workers_share_the_indices(generator):
    one = [p["index"] for p in generator.iter_pairs(0, 1, stop=6)]
    w0 = list(generator.iter_pairs(0, 2, stop=6))
    w1 = list(generator.iter_pairs(1, 2, stop=6))
    assert one == list(range(6))
    assert [p["index"] for p in w0] == [0, 2, 4] and [p["index"] for p in w1] == [1, 3, 5]
    np.testing.assert_array_equal(w1[0]["degraded"], generator.pair(1)["degraded"])
    with pytest.raises(ValueError, match="worker"):
        next(generator.iter_pairs(2, 2))


def test_folder_of_images(tmp_path):
    for i in range(3):
        unicac.write_image(tmp_path / f"img{i}.png", unicac.chart("dead-leaves", 120, 90, seed=i))
    (tmp_path / "notes.txt").write_text("not an image")
    gen = PairGenerator(["builtin:cooke_triplet"], tmp_path, patch_px=24, frame_px=(64, 48), seed=1)
    assert len(gen.image_paths) == 3
    pair = gen.pair(5)
    assert pair["degraded"].shape == (24, 24, 3)
    small = PairGenerator(["builtin:cooke_triplet"], tmp_path, patch_px=24, frame_px=(200, 48))
    with pytest.raises(ValueError, match="smaller than frame_px"):
        small.pair(0)


def test_generator_argument_checks(tmp_path):
    with pytest.raises(ValueError, match="lenses"):
        PairGenerator([])
    with pytest.raises(ValueError, match="patch_px"):
        PairGenerator(LENSES, patch_px=100, frame_px=(64, 48))
    with pytest.raises(ValueError, match="charts"):
        PairGenerator(LENSES, charts=("stripes",))
    with pytest.raises(ValueError, match="no .* files"):
        PairGenerator(LENSES, tmp_path)
    with pytest.raises(unicac.LensError):
        PairGenerator(["builtin:nope"])


def test_generator_pickles_without_its_caches(generator):
    import pickle

    generator.pair(0)
    clone = pickle.loads(pickle.dumps(generator))
    np.testing.assert_array_equal(clone.pair(2)["degraded"], generator.pair(2)["degraded"])


def test_importing_the_dataset_module_does_not_import_torch():
    code = "import sys, unicac, unicac.dataset; print('torch' in sys.modules)"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout.strip() == "False"


def test_fixed_psf_size():
    gen = PairGenerator(LENSES, patch_px=16, frame_px=(64, 48), seed=3, with_psf=True, psf_px=9)
    sizes = {gen.pair(i)["psf"].shape for i in range(4)}
    assert sizes == {(3, 9, 9)}
    with pytest.raises(ValueError, match="psf_px"):
        PairGenerator(LENSES, with_psf=True, psf_px=8)
    k = np.zeros((3, 5, 5), np.float32)
    k[:, 2, 2] = 1.0
    assert fit_kernels(k, 9).shape == (3, 9, 9) and fit_kernels(k, 9)[0, 4, 4] == 1.0
    assert fit_kernels(k, 3)[0, 1, 1] == 1.0


def test_to_chw():
    x = np.arange(24, dtype=np.float32).reshape(2, 4, 3)
    assert to_chw(x).shape == (3, 2, 4) and to_chw(x).flags.c_contiguous


def _torch_or_skip():
    try:
        import torch  # noqa: F401
    except ImportError:
        message = "torch is not installed (pip install 'unicac[train]'): PyTorch wrapper tests skipped"
        print(message)
        pytest.skip(message)
    return torch


def test_torch_map_style_dataset(generator):
    torch = _torch_or_skip()
    from unicac.dataset import torch_dataset

    dataset = torch_dataset(generator, length=4)
    assert len(dataset) == 4
    item = dataset[1]
    assert item["degraded"].shape == (3, 32, 32) and item["degraded"].dtype == torch.float32
    np.testing.assert_array_equal(item["degraded"].numpy(), to_chw(generator.pair(1)["degraded"]))


def test_torch_iterable_dataset_with_workers(generator):
    torch = _torch_or_skip()
    from torch.utils.data import DataLoader

    from unicac.dataset import torch_dataset

    fixed = PairGenerator(LENSES, patch_px=32, frame_px=(96, 64), seed=7, with_field_map=True,
                          with_psf=True, psf_px=15)
    loader = DataLoader(torch_dataset(fixed), batch_size=2, num_workers=2)
    batches = []
    for batch in loader:
        batches.append(batch)
        if len(batches) == 2:
            break
    indices = sorted(int(i) for b in batches for i in b["index"])
    assert indices == [0, 1, 2, 3]
    assert batches[0]["sharp"].shape == (2, 3, 32, 32)
    assert batches[0]["psf"].shape == (2, 3, 15, 15)
    first = next(b for b in batches if 0 in [int(i) for i in b["index"]])
    row = [int(i) for i in first["index"]].index(0)
    np.testing.assert_array_equal(first["degraded"][row].numpy(), to_chw(fixed.pair(0)["degraded"]))


def _psnr_db(a: np.ndarray, b: np.ndarray) -> float:
    return float(10 * np.log10(1.0 / np.mean((a.astype(np.float64) - b) ** 2)))


def test_aligned_pairs_of_a_distorting_lens_differ_by_blur_and_full_ones_do_not():
    """Issue 30 on the fly: the 100-degree wide angle (-33% distortion at the corner, strong fall-off) is
    nearly sharp, so its aligned pairs are close; with `task="full"` the target is the undistorted,
    unshaded scene and the same patches are far apart."""
    from pathlib import Path

    lens = str(Path(__file__).resolve().parents[2] / "lenses" / "wide_angle_100.json")
    psnr = {}
    for task in ("aligned", "full"):
        generator = PairGenerator([lens], patch_px=48, frame_px=(192, 144), seed=3, isp=False, noise=False, task=task)
        psnr[task] = np.mean([_psnr_db(p["degraded"], p["sharp"]) for p in map(generator.pair, range(6))])
    assert psnr["aligned"] > 25.0 and psnr["aligned"] > psnr["full"] + 5.0, psnr
    with pytest.raises(ValueError, match="task: 'undistort' is not one of"):
        PairGenerator([lens], task="undistort")
