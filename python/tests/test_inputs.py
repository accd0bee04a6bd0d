"""Wrong dtype, shape or memory layout raises a clear Python exception naming the argument, never a
crash; any strides are accepted and give the same results as contiguous input."""

from __future__ import annotations

import numpy as np
import pytest

import unicac

RAYS = np.array([[0.0, 1.0, -5.0], [0.5, -1.0, -5.0], [0.0, 0.0, -5.0]])
DIRS = np.array([[0.0, 0.0, 1.0], [0.0, 0.01, 1.0], [0.0, 0.1, 1.0]])


@pytest.mark.parametrize(
    "starts, error, pattern",
    [
        (RAYS.astype(np.float32), TypeError, "starts: expected a float64 array of shape \\(N, 3\\), got a float32"),
        (RAYS.astype(np.int64), TypeError, "starts: .*int64"),
        (RAYS.astype(">f8"), TypeError, "starts: .*non-native byte order"),
        (RAYS[:, :2].copy(), ValueError, "starts: .*shape \\(3, 2\\)"),
        (RAYS.ravel(), ValueError, "starts: .*shape \\(9,\\)"),
        (RAYS[None], ValueError, "starts: .*shape \\(1, 3, 3\\)"),
        (RAYS.tolist(), TypeError, "starts: expected a numpy array, got list"),
        (None, TypeError, "starts: expected a numpy array, got NoneType"),
    ],
)
def test_trace_rejects_bad_starts(cooke, starts, error, pattern):
    with pytest.raises(error, match=pattern):
        unicac.trace(cooke, starts, DIRS)


def test_trace_rejects_mismatched_lengths_and_bad_wavelength(cooke):
    with pytest.raises(ValueError, match="same length"):
        unicac.trace(cooke, RAYS, DIRS[:2].copy())
    with pytest.raises(ValueError, match="wavelength_um"):
        unicac.trace(cooke, RAYS, DIRS, -0.5)
    with pytest.raises(TypeError):
        unicac.trace("builtin:cooke_triplet", RAYS, DIRS)


def test_misaligned_buffer_is_a_value_error(cooke):
    raw = np.zeros(RAYS.size * 8 + 1, np.uint8)
    misaligned = raw[1:].view(np.float64).reshape(RAYS.shape)
    misaligned[...] = RAYS
    assert not misaligned.flags.aligned
    with pytest.raises(ValueError, match="aligned"):
        unicac.trace(cooke, misaligned, DIRS)


def test_any_strides_give_the_same_result(cooke):
    expected = unicac.trace(cooke, RAYS, DIRS)
    fortran = np.asfortranarray(RAYS)
    wide = np.zeros((3, 6))
    wide[:, ::2] = RAYS
    strided = wide[:, ::2]
    for starts in (fortran, strided):
        assert not starts.flags.c_contiguous
        xy, status = unicac.trace(cooke, starts, DIRS)
        np.testing.assert_array_equal(xy, expected[0])
        np.testing.assert_array_equal(status, expected[1])
    backwards = RAYS.copy()[::-1]  # negative strides
    xy, status = unicac.trace(cooke, backwards, DIRS[::-1])
    np.testing.assert_array_equal(xy, expected[0][::-1])


def test_image_inputs():
    lens = unicac.load_lens("builtin:cooke_triplet")
    sim = unicac.Simulator(lens, 48, 32)
    image = unicac.chart("dead-leaves", 48, 32, seed=1)
    expected = sim.simulate(image, seed=2)
    np.testing.assert_array_equal(sim.simulate(np.asfortranarray(image), seed=2), expected)
    bigger = unicac.chart("dead-leaves", 96, 32, seed=1)
    bigger[:, ::2] = image
    np.testing.assert_array_equal(sim.simulate(bigger[:, ::2], seed=2), expected)
    for bad, error, pattern in [
        (image.astype(np.float64), TypeError, "image: expected an H x W x 3 array .* got a float64"),
        (image.astype(np.int16), TypeError, "image: .*int16"),
        (image[:, :, :2], ValueError, "image: .*shape \\(32, 48, 2\\)"),
        (image[:, :, 0], ValueError, "image: .*shape \\(32, 48\\)"),
        (np.zeros((0, 48, 3), np.float32), ValueError, "image"),
        ("picture.png", TypeError, "image: expected a numpy array, got str"),
    ]:
        with pytest.raises(error, match=pattern):
            sim.simulate(bad)
    nan = image.copy()
    nan[0, 0, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        sim.simulate(nan)
    with pytest.raises(TypeError, match="raw: expected a float32"):
        sim.optics(image.astype(np.float64))


def test_isp_inputs():
    with pytest.raises(ValueError, match="mosaic: expected a float32 array of shape \\(H, W\\)"):
        unicac.demosaic(np.zeros((4, 4, 3), np.float32))
    with pytest.raises(TypeError, match="rgb"):
        unicac.mosaic_rggb(np.zeros((4, 4, 3), np.float64))
    with pytest.raises(ValueError, match="kernel: expected a square kernel of odd size"):
        unicac.oiqe_of_psf(np.ones((4, 4), np.float32))
    with pytest.raises(ValueError, match="positive sum"):
        unicac.oiqe_of_psf(np.zeros((5, 5), np.float32))
    with pytest.raises(TypeError, match="linear"):
        unicac.linear_to_srgb(np.zeros(3))
    with pytest.raises(ValueError, match="gains_rgb"):
        unicac.perturb_white_balance((1.0, 1.0), 0.1, 1)
    with pytest.raises(OverflowError):
        unicac.isp_draw(-1)


def test_pupil_and_fields_are_checked(cooke):
    with pytest.raises(ValueError, match="pupil"):
        unicac.aim_rays(cooke, 0.0, np.zeros((3, 3)))
    with pytest.raises(ValueError, match="aiming"):
        unicac.aim_rays(cooke, 0.0, np.zeros((1, 2)), aiming="perfect")
    with pytest.raises(ValueError, match="pupil_sampling"):
        unicac.spots(cooke, pupil_sampling="spiral:3")
    with pytest.raises(ValueError, match="fields_deg"):
        unicac.spots(cooke, fields_deg=[100.0])
