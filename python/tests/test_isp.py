"""The ISP steps one by one compose to the simulator's chain."""

from __future__ import annotations

import numpy as np
import pytest

import unicac


def test_steps_compose_to_simulate():
    lens = unicac.load_lens("builtin:cooke_triplet")
    sim = unicac.Simulator(lens, 96, 64)
    truth = unicac.chart("dead-leaves", 96, 64, seed=9)
    raw = unicac.isp_unprocess(truth, seed=21)
    degraded = unicac.isp_process(sim.optics(raw), seed=21)
    expected, target = sim.render_pair(truth, seed=21)
    np.testing.assert_array_equal(degraded, expected)
    np.testing.assert_array_equal(unicac.isp_target(truth), target)


def test_process_by_hand_equals_isp_process():
    rgb = unicac.chart("dead-leaves", 40, 30, seed=1)
    draw = unicac.isp_draw(8)
    gains = draw["gains"]
    mosaic = unicac.mosaic_rggb(rgb)
    assert mosaic.shape == (30, 40)
    dn = unicac.read_out(mosaic, noise_seed=draw["noise_seed"])
    assert dn.shape == (30, 40) and float(dn.max()) <= 1023 and np.all(dn == np.round(dn))
    balanced = unicac.apply_white_balance_mosaic(unicac.subtract_black_level(dn), gains)
    out = unicac.linear_to_srgb(np.clip(unicac.demosaic(balanced), 0.0, 1.0))
    np.testing.assert_array_equal(out, unicac.isp_process(rgb, seed=8))


def test_single_steps():
    rgb = unicac.chart("checkerboard", 32, 32)
    gains = (2.0, 1.0, 1.5)
    np.testing.assert_allclose(
        unicac.apply_white_balance(unicac.invert_white_balance(rgb, gains), gains), rgb, rtol=1e-6
    )
    assert unicac.perturb_white_balance(gains, 0.1, 3) == unicac.perturb_white_balance(gains, 0.1, 3)
    assert unicac.perturb_white_balance(gains, 0.0, 3) == gains
    bilinear = unicac.demosaic(unicac.mosaic_rggb(rgb), method="bilinear")
    assert bilinear.shape == rgb.shape
    noiseless = unicac.read_out(rgb, bit_depth=12, black_level_dn=0.0)
    np.testing.assert_allclose(noiseless / 4095.0, rgb, atol=0.5 / 4095 + 1e-7)
    x = np.linspace(0, 1, 11, dtype=np.float32)
    np.testing.assert_allclose(unicac.srgb_to_linear(unicac.linear_to_srgb(x)), x, atol=1e-6)
    assert set(np.unique(unicac.quantise(x, 1))) <= {0.0, 1.0}
    assert unicac.isp_draw(1, noise=False)["noise_seed"] is None
    np.testing.assert_allclose(unicac.isp_draw(1, isp=False)["gains"], (2.0, 1.0, 1.8), rtol=1e-7)


def test_isp_errors():
    with pytest.raises(ValueError, match="method"):
        unicac.demosaic(np.zeros((4, 4), np.float32), method="ahd")
    with pytest.raises(unicac.ImageError, match="bit"):
        unicac.quantise(np.zeros(3, np.float32), 0)
    with pytest.raises(unicac.ImageError):
        unicac.apply_white_balance(np.zeros((4, 4, 3), np.float32), (0.0, 1.0, 1.0))
    with pytest.raises(unicac.ImageError):
        unicac.read_out(np.zeros((4, 4), np.float32), bit_depth=20)
