#!/usr/bin/env python3
"""optiland's image simulation (ImageSimulationEngine, numpy backend) timed on a unicac lens.

The engine's defaults: 3 wavelengths (0.65, 0.55, 0.45 um), a 5 x 5 grid of FFT (wave-optics) PSFs of
128 x 128 samples per wavelength, 3 eigen-PSFs, padding 64 px, distortion warp per wavelength. The lens
is built as in tests/reference (constant-index media at the primary wavelength, so no lateral colour:
the timing is what is compared). The fields are scaled by 1/sqrt(2) (see main). The input is a seeded random RGB image of WIDTHxHEIGHT. One run is
timed end to end (engine.run), the first PSF evaluation included, as a user would see it.

`--equal-work` gives the engine unicac's spectral sampling instead of its defaults: the 31 wavelengths
unicac integrates (0.40-0.70 um) and a 4 x 4 PSF grid per wavelength (16 PSFs against unicac's 17
radial ones, so optiland still does slightly less). The engine maps one wavelength to one channel, so
the 31 wavelengths run as 11 engine runs (10 of three wavelengths on the image's three channels, one of
a single wavelength on one channel); the reported seconds are their sum.

Run: bench/.venv-peers/bin/python bench/peers/optiland_image_simulation.py [LENS] [WIDTHxHEIGHT] [--equal-work]
Prints one JSON object.
"""
from __future__ import annotations

import json
import sys
import time
from importlib.metadata import version
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "tests" / "reference"))
import make_references as mr  # noqa: E402  (lens reader and optiland builder)


def main() -> None:
    equal_work = "--equal-work" in sys.argv
    args = [a for a in sys.argv[1:] if a != "--equal-work"]
    name = args[0] if args else "phone_asphere"
    width, height = map(int, (args[1] if len(args) > 1 else "1000x750").split("x"))
    mr.offline_rii_database()
    lens = mr.load_lens(ROOT / "lenses" / f"{name}.json")
    # The engine samples normalised fields on a square [-1, 1]^2 grid, so its corners sit at sqrt(2)
    # times the largest field, where this lens passes no rays; scale the fields so the grid's corner
    # is the lens's largest field (the image's half-diagonal, as in unicac's default mapping).
    lens["fields"]["angles_deg"] = [a / 2**0.5 for a in mr.field_angles(lens)]
    primary = mr.wavelengths(lens)[mr.primary_index(lens)]
    model = mr.OptilandModel(lens, mr.lens_indices(lens)[mr.primary_index(lens)], primary)
    op = model.op
    if equal_work:
        # unicac's visible_wavelengths_um(31), in groups of at most three (one per channel).
        spectrum = [round(0.4 + 0.3 * i / 30, 6) for i in range(31)]
        groups = [spectrum[i:i + 3] for i in range(0, 31, 3)]
        config = {"psf_grid_shape": (4, 4)}
    else:
        groups = [[0.65, 0.55, 0.45]]
        config = {}
    # The engine asks for PSFs at its wavelengths: declare them (same constant indices).
    for wl in sorted({wl for group in groups for wl in group} - {primary}):
        op.wavelengths.add(value=wl)
    from optiland.analysis.image_simulation import ImageSimulationEngine

    image = np.random.default_rng(7).random((height, width, 3))
    seconds = 0.0
    finite = True
    for group in groups:
        engine = ImageSimulationEngine(op, config | {"wavelengths": group})
        start = time.perf_counter()
        # A lone wavelength takes one channel as a grey (H, W) image: the engine maps one wavelength per channel.
        out = engine.run(image if len(group) == 3 else image[:, :, 0])
        seconds += time.perf_counter() - start
        finite &= bool(np.isfinite(np.asarray(out)).all())
    print(json.dumps({
        "tool": "optiland", "version": version("optiland"), "numpy": np.__version__,
        "lens": name, "width": width, "height": height, "seconds": round(seconds, 2),
        "engine_runs": len(groups), "wavelengths_um": [wl for group in groups for wl in group],
        "config": engine.config | {"distortion_reference": None, "wavelengths": "see wavelengths_um"},
        "finite": finite,
    }, default=str))


if __name__ == "__main__":
    main()
