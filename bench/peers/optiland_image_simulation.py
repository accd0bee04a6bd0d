#!/usr/bin/env python3
"""optiland's image simulation (ImageSimulationEngine, numpy backend) timed on a unicac lens.

The engine's defaults: 3 wavelengths (0.65, 0.55, 0.45 um), a 5 x 5 grid of FFT (wave-optics) PSFs of
128 x 128 samples per wavelength, 3 eigen-PSFs, padding 64 px, distortion warp per wavelength. The lens
is built as in tests/reference (constant-index media at the primary wavelength, so no lateral colour:
the timing is what is compared). The fields are scaled by 1/sqrt(2) (see main). The input is a seeded random RGB image of WIDTHxHEIGHT. One run is
timed end to end (engine.run), the first PSF evaluation included, as a user would see it.

Run: bench/.venv-peers/bin/python bench/peers/optiland_image_simulation.py [LENS] [WIDTHxHEIGHT]
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
    name = sys.argv[1] if len(sys.argv) > 1 else "phone_asphere"
    width, height = map(int, (sys.argv[2] if len(sys.argv) > 2 else "1000x750").split("x"))
    mr.offline_rii_database()
    lens = mr.load_lens(ROOT / "lenses" / f"{name}.json")
    # The engine samples normalised fields on a square [-1, 1]^2 grid, so its corners sit at sqrt(2)
    # times the largest field, where this lens passes no rays; scale the fields so the grid's corner
    # is the lens's largest field (the image's half-diagonal, as in unicac's default mapping).
    lens["fields"]["angles_deg"] = [a / 2**0.5 for a in mr.field_angles(lens)]
    primary = mr.wavelengths(lens)[mr.primary_index(lens)]
    model = mr.OptilandModel(lens, mr.lens_indices(lens)[mr.primary_index(lens)], primary)
    op = model.op
    # The engine asks for PSFs at 0.65, 0.55 and 0.45 um: declare them (same constant indices).
    for wl in (0.65, 0.45):
        op.wavelengths.add(value=wl)
    op.wavelengths.add(value=0.55)
    from optiland.analysis.image_simulation import ImageSimulationEngine

    image = np.random.default_rng(7).random((height, width, 3))
    engine = ImageSimulationEngine(op)
    start = time.perf_counter()
    out = engine.run(image)
    seconds = time.perf_counter() - start
    print(json.dumps({
        "tool": "optiland", "version": version("optiland"), "numpy": np.__version__,
        "lens": name, "width": width, "height": height, "seconds": round(seconds, 2),
        "config": engine.config | {"distortion_reference": None},
        "finite": bool(np.isfinite(np.asarray(out)).all()),
    }, default=str))


if __name__ == "__main__":
    main()
