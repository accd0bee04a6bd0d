"""Lenses: loading from every source, first-order data equal to `unicac lens info --json`."""

from __future__ import annotations

import math

import pytest

import unicac


def test_builtin_lenses_load():
    names = unicac.builtin_lenses()
    assert "cooke_triplet" in names and len(names) >= 5
    for name in names:
        lens = unicac.load_lens(f"builtin:{name}")
        assert lens.num_surfaces >= 2
        assert lens.source == f"builtin:{name}"


def test_json_and_zmx_files_load_the_same_lens(repo, tmp_path, cli):
    lens = unicac.load_lens(repo / "lenses" / "cooke_triplet.json")
    zmx = tmp_path / "cooke.zmx"
    lens.save(zmx)
    again = unicac.load_lens(str(zmx))
    a, b = lens.first_order(), again.first_order()
    assert math.isclose(a["efl_mm"], b["efl_mm"], rel_tol=1e-9)
    assert lens.num_surfaces == again.num_surfaces
    assert again.first_order() == cli("lens", "info", str(zmx), "--json")


@pytest.mark.parametrize("name", ["singlet", "cooke_triplet", "double_gauss", "wide_angle", "phone_asphere"])
def test_first_order_equals_cli_lens_info(cli, name):
    source = f"builtin:{name}"
    expected = cli("lens", "info", source, "--json")
    got = unicac.load_lens(source).first_order()
    assert set(got) == set(expected)
    # Same code, same f64 values, JSON round trip on both sides: exact equality.
    assert got == expected


def test_lens_file_equals_cli_for_a_path(cli, repo):
    path = str(repo / "lenses" / "petzval.json")
    assert unicac.load_lens(path).first_order() == cli("lens", "info", path, "--json")


def test_properties(cooke):
    assert cooke.primary_wavelength_um in cooke.wavelengths_um
    assert cooke.field_angles_deg[0] == 0.0
    assert cooke.object_distance_mm is None
    near = cooke.with_object_distance(1000.0)
    assert near.object_distance_mm == 1000.0
    assert "cooke" in repr(cooke).lower()


def test_missing_and_invalid_files_raise_lens_error(tmp_path):
    with pytest.raises(unicac.LensError, match="No such file"):
        unicac.load_lens(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{ not json")
    with pytest.raises(unicac.LensError):
        unicac.load_lens(bad)
    with pytest.raises(unicac.LensError, match="no bundled lens"):
        unicac.load_lens("builtin:nope")
    with pytest.raises(unicac.LensError):
        unicac.load_lens(tmp_path / "lens.txt")
    assert issubclass(unicac.LensError, unicac.UnicacError)
