#!/usr/bin/env python3
"""Extract the camera / observer spectral responses shipped with unicac-psf.

Source: the `colour-science` PyPI package (BSD-3-Clause), see README.md in
this folder for provenance, licence and the exact regeneration commands.

Writes into the folder containing this script:

  default_rgb.csv          Nikon D5100, "Nikon 5100 (NPL)" (the default camera)
  sigma_sdmerill_npl.csv   "Sigma SDMerill (NPL)"
  cie1931_2deg.csv         CIE 1931 2-degree colour matching functions

Every file is sampled on 400..700 nm in 10 nm steps. Values are copied as
stored in the package (no normalisation here), rounded to 6 decimals. Grid
points that are source samples are copied directly; any other grid point
inside the source range would be linearly interpolated (none are with
colour-science 0.4.7). Grid points outside the source range are omitted, never
extrapolated: the Sigma data end at 680 nm, so that file stops at 680 nm.
"""

from pathlib import Path

import numpy as np

import colour
from colour.characterisation import MSDS_CAMERA_SENSITIVITIES

EXPECTED_COLOUR_VERSION = "0.4.7"
GRID_NM = np.arange(400, 701, 10)
OUT_DIR = Path(__file__).resolve().parent

# (output file, header columns, colour-science object)
OUTPUTS = [
    ("default_rgb.csv", ("r", "g", "b"),
     MSDS_CAMERA_SENSITIVITIES["Nikon 5100 (NPL)"]),
    ("sigma_sdmerill_npl.csv", ("r", "g", "b"),
     MSDS_CAMERA_SENSITIVITIES["Sigma SDMerill (NPL)"]),
    ("cie1931_2deg.csv", ("x", "y", "z"),
     colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]),
]


def resample(msds):
    """Return (wavelengths, values[n, 3]) on GRID_NM, limited to the source range."""
    src_wl = msds.wavelengths
    src = msds.values
    wl = GRID_NM[(GRID_NM >= src_wl[0]) & (GRID_NM <= src_wl[-1])]
    out = np.column_stack([np.interp(wl, src_wl, src[:, i]) for i in range(3)])
    interpolated = [w for w in wl if not np.any(np.isclose(src_wl, w))]
    missing = [int(w) for w in GRID_NM if w not in wl]
    print(f"{msds.name}: source {src_wl[0]:g}..{src_wl[-1]:g} nm "
          f"step {msds.shape.interval:g}; interpolated at {interpolated or 'none'}; "
          f"omitted (outside source) {missing or 'none'}")
    return wl, out


def main():
    if colour.__version__ != EXPECTED_COLOUR_VERSION:
        print(f"warning: colour-science {colour.__version__}, "
              f"README documents {EXPECTED_COLOUR_VERSION}")
    for filename, columns, msds in OUTPUTS:
        wl, values = resample(msds)
        lines = [",".join(("wavelength_nm",) + columns)]
        for w, row in zip(wl, values):
            lines.append(f"{int(w)}," + ",".join(f"{v:.6f}" for v in row))
        (OUT_DIR / filename).write_text("\n".join(lines) + "\n")
        print(f"  wrote {filename} ({len(wl)} rows)")


if __name__ == "__main__":
    main()
