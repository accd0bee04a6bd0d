"""Image simulation, charts and image files: equal to `unicac simulate` / `unicac chart`."""

from __future__ import annotations

import numpy as np
import pytest

import unicac

LENS = "builtin:phone_asphere"


@pytest.fixture(scope="module")
def chart_png(cli, tmp_path_factory):
    path = tmp_path_factory.mktemp("chart") / "leaves.png"
    cli("chart", "dead-leaves", "--size", "160x120", "--seed", "3", "--out", str(path))
    return path


def test_chart_equals_cli(chart_png, tmp_path):
    stored = unicac.read_image(chart_png)
    assert stored.dtype == np.uint16 and stored.shape == (120, 160, 3)
    ours = tmp_path / "ours.png"
    unicac.write_image(ours, unicac.chart("dead-leaves", 160, 120, seed=3))
    np.testing.assert_array_equal(unicac.read_image(ours), stored)


@pytest.mark.parametrize("flags", [[], ["--no-noise"], ["--no-isp", "--no-distortion"], ["--no-illumination"]])
def test_simulate_equals_cli(cli, chart_png, tmp_path, flags):
    out = tmp_path / "out"
    cli("simulate", LENS, str(chart_png), "--out", str(out), "--seed", "11", *flags)
    expected = unicac.read_image(out / "leaves.png")
    image = unicac.read_image(chart_png)
    got = unicac.simulate(
        unicac.load_lens(LENS), image, seed=11,
        noise="--no-noise" not in flags, isp="--no-isp" not in flags,
        distortion="--no-distortion" not in flags, illumination="--no-illumination" not in flags,
    )
    assert got.dtype == np.uint16 and got.shape == image.shape
    np.testing.assert_array_equal(got, expected)  # same pipeline, same seed: identical codes


def test_simulate_float_input_equals_cli_exr(cli, chart_png, tmp_path):
    out = tmp_path / "out"
    cli("simulate", LENS, str(chart_png), "--out", str(out), "--seed", "5", "--format", "exr")
    expected = unicac.read_image(out / "leaves.exr")
    linear = unicac.read_image(chart_png, linear=True)
    got = unicac.simulate(unicac.load_lens(LENS), linear, seed=5)
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, expected)  # the CLI writes float32 EXR: identical


def test_uint8_in_uint8_out():
    lens = unicac.load_lens(LENS)
    image = (unicac.linear_to_srgb(unicac.chart("checkerboard", 96, 64)) * 255).round().astype(np.uint8)
    out = unicac.simulate(lens, image, seed=1)
    assert out.dtype == np.uint8 and out.shape == image.shape


def test_simulator_reuse_and_determinism():
    lens = unicac.load_lens(LENS)
    sim = unicac.Simulator(lens, 128, 96)
    image = unicac.chart("dead-leaves", 128, 96, seed=2)
    a = sim.simulate(image, seed=4)
    b = sim.simulate(image, seed=4)
    c = sim.simulate(image, seed=5)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)
    np.testing.assert_array_equal(a, unicac.simulate(lens, image, seed=4))
    assert sim.kernel_px % 2 == 1 and sim.pixel_um > 0 and sim.half_diagonal_mm > 0
    degraded, target = sim.render_pair(image, seed=4)
    assert degraded.dtype == target.dtype == np.float32
    np.testing.assert_array_equal(target, unicac.isp_target(image))
    field = sim.field_map()
    assert field.shape == (96, 128, 3)
    assert field[48, 64, 2] < 1.0 and field[0, 0, 2] > field[48, 64, 2]
    with pytest.raises(ValueError, match="prepared for 96 x 128"):
        sim.simulate(unicac.chart("dead-leaves", 64, 64))


def test_read_write_image_round_trips(tmp_path):
    image = unicac.chart("siemens-star", 64, 48)
    for name in ("a.exr", "a.png", "a.tif"):
        unicac.write_image(tmp_path / name, image)
    np.testing.assert_array_equal(unicac.read_image(tmp_path / "a.exr"), image)
    png = unicac.read_image(tmp_path / "a.png", linear=True)
    np.testing.assert_allclose(png, image, atol=2e-4)
    codes = unicac.read_image(tmp_path / "a.png")
    unicac.write_image(tmp_path / "b.png", codes)
    np.testing.assert_array_equal(unicac.read_image(tmp_path / "b.png"), codes)
    with pytest.raises(ValueError, match="extension"):
        unicac.write_image(tmp_path / "a.bmp", image)
    with pytest.raises(unicac.ImageError):
        unicac.read_image(tmp_path / "missing.png")


def test_simulation_errors():
    lens = unicac.load_lens(LENS)
    with pytest.raises(unicac.SimulationError):
        unicac.Simulator(lens, 1, 1)  # 1 pixel: too small to simulate
    with pytest.raises(unicac.SimulationError, match="pixel pitch"):
        unicac.Simulator(lens, 64, 64, pixel_um=-2.0)
    with pytest.raises(ValueError, match="kind"):
        unicac.chart("stripes", 10, 10)
    with pytest.raises(ValueError, match="at most"):
        unicac.Simulator(lens, 100_000, 100_000)
    with pytest.raises(ValueError, match="positive"):
        unicac.chart("dead-leaves", 0, 10)


def test_simulator_image_pass_on_the_gpu_matches_the_cpu():
    """`device="gpu"`: the blur, warp and shading on the GPU within 2e-6 of the CPU path (docs/gpu.md),
    or, without an adapter, the CPU path itself and a RuntimeWarning saying so."""
    lens = unicac.load_lens(LENS)
    rng = np.random.default_rng(5)
    raw = rng.random((120, 160, 3), dtype=np.float32)
    cpu = unicac.Simulator(lens, 160, 120, device="cpu").optics(raw)
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        gpu = unicac.Simulator(lens, 160, 120, device="gpu").optics(raw)
    fell_back = any("CPU" in str(w.message) for w in caught)
    if fell_back:
        np.testing.assert_array_equal(gpu, cpu)
    else:
        assert np.abs(gpu - cpu).max() <= 2e-6



def test_a_decentred_unit_simulates_over_the_whole_image_plane(cli, repo, chart_png, tmp_path):
    # A built unit (decentred and tilted surfaces): PSFs over the image plane, not one radius turned.
    unit = str(repo / "tests/reference/asbuilt/lenses/cooke_mixed.json")
    out = tmp_path / "out"
    cli("simulate", unit, str(chart_png), "--out", str(out), "--seed", "2", "--device", "cpu")
    sim = unicac.Simulator(unicac.load_lens(unit), 160, 120, device="cpu")
    got = sim.simulate(unicac.read_image(chart_png), seed=2)
    np.testing.assert_array_equal(got, unicac.read_image(out / "leaves.png"))
    # Left and right of the axis the kernels are not mirror images of each other, as they are for the
    # design (the asymmetry a build adds).
    left, right = sim.psf_at(30.0, 59.5), sim.psf_at(129.0, 59.5)
    assert np.abs(left - right[:, :, ::-1]).sum() > 1e-3
    design = unicac.Simulator(unicac.load_lens("builtin:cooke_triplet"), 160, 120, device="cpu")
    assert design.pixel_um == pytest.approx(sim.pixel_um)  # the unit renders on its design's sensor
    field = sim.field_map()
    assert field.shape == (120, 160, 3) and field[0, 0, 2] > field[60, 80, 2]
