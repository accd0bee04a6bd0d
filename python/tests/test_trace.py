"""Ray tracing and spots equal the CLI's results for the same inputs."""

from __future__ import annotations

import numpy as np
import pytest

import unicac


def _cli_ray(cli, lens, ray, wavelength_um):
    text = ",".join(repr(float(v)) for v in ray)
    return cli("trace", lens, f"--ray={text}", "--wavelength-um", repr(wavelength_um), "--json")


def test_trace_equals_cli_explicit_rays(cli, cooke):
    rays = np.array(
        [
            [0.0, 2.0, -5.0, 0.0, 0.0, 1.0],
            [1.0, -3.0, -10.0, 0.01, 0.05, 1.0],
            [0.0, 0.0, -5.0, 0.0, 0.2, 1.0],
            [0.0, 30.0, -5.0, 0.0, 0.0, 1.0],  # outside the clear aperture
            [0.0, 0.0, -5.0, 0.0, 0.9, 0.1],  # steep: misses or is clipped
        ]
    )
    wavelength = 0.5876
    xy, status = unicac.trace(cooke, rays[:, :3].copy(), rays[:, 3:].copy(), wavelength)
    assert xy.shape == (5, 2) and xy.dtype == np.float64
    assert status.shape == (5,) and status.dtype == np.int32
    detailed = unicac.trace_detailed(cooke, rays[:, :3].copy(), rays[:, 3:].copy(), wavelength)
    for i, ray in enumerate(rays):
        expected = _cli_ray(cli, "builtin:cooke_triplet", ray, wavelength)
        assert unicac.STATUS_NAMES[status[i]] == expected["status"]
        if expected["status"] == "ok":
            # Same tracer, same f64 arithmetic: bit-identical.
            assert xy[i, 0] == expected["x_mm"] and xy[i, 1] == expected["y_mm"]
            assert detailed["position_mm"][i, 2] == expected["z_mm"]
            assert list(detailed["direction"][i]) == expected["direction"]
            assert detailed["failed_at_surface"][i] == 0
        else:
            assert np.isnan(xy[i]).all()
            assert detailed["failed_at_surface"][i] == expected["failed_at_surface"]
    assert set(unicac.STATUS_NAMES[s] for s in status) >= {"ok"}
    assert (status != 0).any(), "the test set includes failing rays"


@pytest.mark.parametrize("aiming", ["paraxial", "real"])
def test_aimed_rays_equal_cli(cli, cooke, aiming):
    pupil = np.array([[0.0, 1.0], [0.5, -0.5], [0.0, 0.0]])
    starts, dirs = unicac.aim_rays(cooke, 20.0, pupil, aiming=aiming)
    xy, status = unicac.trace(cooke, starts, dirs, virtual_start=True)
    # The Cooke triplet's entrance pupil lies behind its first surface: read as rays that start there,
    # they would have to travel backwards to it.
    _, from_start = unicac.trace(cooke, starts, dirs)
    assert all(unicac.STATUS_NAMES[s] == "missed" for s in from_start)
    for i, (px, py) in enumerate(pupil):
        expected = cli(
            "trace", "builtin:cooke_triplet", "--field-deg", "20", "--pupil", f"{px},{py}",
            "--aim", aiming, "--json",
        )
        assert list(starts[i]) == expected["start_mm"]
        assert unicac.STATUS_NAMES[status[i]] == expected["status"]
        assert xy[i, 0] == expected["x_mm"] and xy[i, 1] == expected["y_mm"]


def test_spots_equal_cli(cli, cooke):
    expected = cli("spot", "builtin:cooke_triplet", "--pupil-sampling", "hexapolar:6", "--aim", "real", "--json")
    got = unicac.spots(cooke, aiming="real", pupil_sampling="hexapolar:6")
    assert len(got) == len(expected["spots"])
    for g, e in zip(got, expected["spots"]):
        points = g.pop("points_mm")
        assert points.shape == (g["rays_ok"], 2)
        assert g == e  # exact: same code and values
    assert got[0]["rms_radius_um"] > 0


def test_status_names():
    assert unicac.STATUS_NAMES == ("ok", "missed", "tir", "clipped", "no_convergence", "invalid_input")
    assert unicac.STATUS_NAMES[unicac.STATUS_OK] == "ok"


def test_invalid_rays_are_statuses_not_errors(cooke):
    starts = np.array([[0.0, 0.0, -5.0], [np.nan, 0.0, -5.0], [0.0, 0.0, -5.0]])
    dirs = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    xy, status = unicac.trace(cooke, starts, dirs)
    assert [unicac.STATUS_NAMES[s] for s in status] == ["ok", "invalid_input", "invalid_input"]
    empty_xy, empty_status = unicac.trace(cooke, np.zeros((0, 3)), np.zeros((0, 3)))
    assert empty_xy.shape == (0, 2) and empty_status.shape == (0,)


def test_rays_that_never_reach_the_lens_are_missed(cli, cooke):
    """A ray pointing away from the lens, and one starting past the image plane, are `missed` at surface
    1 with NaN coordinates (they used to be reported `ok` with the forward ray's image point), as in the
    CLI."""
    starts = np.array([[0.0, 1.0, -5.0], [0.0, 1.0, 1.0e4], [0.0, 1.0, -5.0]])
    dirs = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    xy, status = unicac.trace(cooke, starts, dirs)
    assert [unicac.STATUS_NAMES[s] for s in status] == ["missed", "missed", "ok"]
    assert np.isnan(xy[:2]).all() and np.isfinite(xy[2]).all()
    detailed = unicac.trace_detailed(cooke, starts, dirs)
    assert list(detailed["failed_at_surface"][:2]) == [1, 1]
    expected = _cli_ray(cli, "builtin:cooke_triplet", [0.0, 1.0, -5.0, 0.0, 0.0, -1.0], 0.5876)
    assert expected["status"] == "missed" and expected["failed_at_surface"] == 1


def test_clip_false_lets_rays_through(cooke):
    starts, dirs = np.array([[0.0, 14.0, -5.0]]), np.array([[0.0, 0.0, 1.0]])
    _, clipped = unicac.trace(cooke, starts, dirs)
    _, free = unicac.trace(cooke, starts, dirs, clip=False)
    assert unicac.STATUS_NAMES[clipped[0]] == "clipped"
    assert unicac.STATUS_NAMES[free[0]] != "clipped"


def test_many_rays_match_one_by_one(cooke):
    rng = np.random.default_rng(1)
    n = 5000
    starts = np.column_stack([rng.uniform(-5, 5, n), rng.uniform(-5, 5, n), np.full(n, -5.0)])
    dirs = np.column_stack([rng.normal(0, 0.05, n), rng.normal(0, 0.05, n), np.ones(n)])
    xy, status = unicac.trace(cooke, starts, dirs)
    for i in range(0, n, 997):
        xy1, s1 = unicac.trace(cooke, starts[i : i + 1], dirs[i : i + 1])
        assert s1[0] == status[i]
        np.testing.assert_array_equal(xy1[0], xy[i])
