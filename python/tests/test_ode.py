"""ODE and OIQE equal `unicac ode --json`."""

from __future__ import annotations

import numpy as np

import unicac


def test_ode_equals_cli(cli):
    expected = cli("ode", "builtin:cooke_triplet", "--json")["lenses"][0]
    got = unicac.ode(unicac.load_lens("builtin:cooke_triplet"))
    for report in (expected, got):
        report.pop("times")  # wall-clock seconds
    assert got == expected
    assert 0.0 < got["ode"] < 1.0


def test_oiqe_of_psf():
    delta = np.zeros((5, 5), np.float32)
    delta[2, 2] = 1.0
    sharp = unicac.oiqe_of_psf(delta)
    blur = unicac.oiqe_of_psf(np.ones((9, 9), np.float32))
    assert 0.0 <= blur["oiqe"] < sharp["oiqe"] <= 1.0
    assert sharp["mtf50_sagittal_cy_per_px"] > blur["mtf50_sagittal_cy_per_px"]

