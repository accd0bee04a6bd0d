"""PSFs and PSF grids: equal to `unicac psf` (kernels and metadata), float32 with metadata."""

from __future__ import annotations

import numpy as np
import pytest

import unicac


@pytest.mark.parametrize(
    "args, kwargs",
    [
        (["--field-deg", "14"], {"field_deg": 14.0}),
        (["--field-deg", "0", "--wavelength-um", "0.55", "--pixel-um", "1.5"],
         {"field_deg": 0.0, "wavelengths_um": [0.55], "pixel_um": 1.5}),
        (["--field-deg", "10", "--mode", "wave", "--pixel-um", "3"],
         {"field_deg": 10.0, "mode": "wave", "pixel_um": 3.0}),
        # A field off the y axis (what a decentred or tilted lens needs).
        (["--field-deg", "-4", "--field-x-deg", "9"], {"field_deg": -4.0, "field_x_deg": 9.0}),
    ],
)
def test_psf_equals_cli(cli, cooke, tmp_path, args, kwargs):
    out = tmp_path / "psf.exr"
    expected = cli("psf", "builtin:cooke_triplet", *args, "--out", str(out), "--json")
    got = unicac.psf(cooke, **kwargs)
    meta = got.metadata()
    # Every key we report is the CLI's, with the same value (the CLI may add keys of its own, e.g.
    # about its PSF cache).
    assert {key: expected[key] for key in meta} == meta
    assert got.kernels.dtype == np.float32
    assert got.kernels.shape == (len(meta["channels"]), meta["kernel_px"], meta["kernel_px"])
    np.testing.assert_allclose(got.kernels.sum(axis=(1, 2)), 1.0, rtol=1e-5)
    # The CLI's EXR holds the same float32 kernels (a 1-channel "Y" file reads back as grey x 3).
    stored = unicac.read_image(out, linear=True)
    for c in range(got.kernels.shape[0]):
        np.testing.assert_array_equal(stored[:, :, c], got.kernels[c])


def test_psf_attributes(cooke):
    p = unicac.psf(cooke, 5.0, wavelengths_um=[0.5, 0.6])
    assert p.channels == ["R", "G", "B"] and p.mode == "geometric"
    assert p.kernel_px % 2 == 1 and p.pixel_um == 2.0
    assert 0.0 < p.transmission <= 1.0 + 1e-12
    assert p.reference_mm[0] == 0.0 and p.reference_mm[1] > 0.0
    assert "Psf(" in repr(p)


def test_finite_object_distance_changes_the_psf(cooke):
    far = unicac.psf(cooke, 0.0, wavelengths_um=[0.55])
    near = unicac.psf(cooke, 0.0, wavelengths_um=[0.55], object_distance_mm=500.0)
    assert near.kernel_px != far.kernel_px or not np.array_equal(near.kernels, far.kernels)


def test_psf_grid(cooke):
    grid = unicac.psf_grid(cooke, 320, 240, 4, 3)
    k = grid["kernels"]
    assert k.dtype == np.float32 and k.shape[:3] == (3, 4, 3) and k.shape[3] == k.shape[4]
    np.testing.assert_allclose(k.sum(axis=(3, 4)), 1.0, rtol=1e-4)
    assert grid["x_px"].shape == (4,) and grid["y_px"].shape == (3,)
    # Symmetric lens: mirror-image nodes have mirror-image PSFs.
    np.testing.assert_allclose(k[0, 0], k[0, -1][:, :, ::-1], atol=1e-6)


def test_bad_psf_requests(cooke):
    with pytest.raises(ValueError, match="mode"):
        unicac.psf(cooke, 0.0, mode="fourier")
    with pytest.raises(ValueError, match="field_deg"):
        unicac.psf(cooke, 95.0)
    with pytest.raises(ValueError, match="pixel_um"):
        unicac.psf(cooke, 0.0, pixel_um=-1.0)
    with pytest.raises(unicac.UnicacError):
        unicac.psf(cooke, 80.0)  # far outside the field: vignetted or not aimable
