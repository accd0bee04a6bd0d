#!/usr/bin/env python3
"""Reference refractive indices computed by optiland's own material classes.

Run inside a venv with optiland==0.6.3 (see README.md):

    /tmp/venv-glass/bin/python make_glass_reference.py

Writes, next to this script:
- optiland_indices.json: catalogue glasses via optiland.materials.MaterialFile,
  the evaluation class behind optiland.materials.Material, opened on the exact
  database file (README.md explains why the name is not looked up);
- optiland_abbe_indices.json: model glasses via optiland.materials.AbbeMaterial.
Catalogue indices are relative to air at the catalogue reference temperature
(no thermal correction), as optiland returns them when no temperature is given.
"""

import importlib.metadata
import importlib.resources
import json
import warnings
from pathlib import Path

from optiland.materials import AbbeMaterial, Material, MaterialFile

OUT_DIR = Path(__file__).resolve().parent
VERSION = importlib.metadata.version("optiland")
GLASS_DB = Path(str(importlib.resources.files("optiland.database"))) / "data-nk/glass"

# Visible wavelengths (um): 0.4, F, 0.55, d, C, 0.7.
VISIBLE = [0.4, 0.4861327, 0.55, 0.5875618, 0.6562725, 0.7]
# The SCHOTT IRG chalcogenides are only specified from 1 um to 12 um.
INFRARED = [1.064, 2.0, 4.0, 10.0]

# (catalog dir, glass, wavelengths); comments give the formula number.
GLASSES = [
    # classic-lens SCHOTT glasses (SK16 is not in the database)
    ("schott", "N-BK7", VISIBLE),   # 2
    ("schott", "N-SK16", VISIBLE),  # 2
    ("schott", "N-SF2", VISIBLE),   # 2
    ("schott", "SF5", VISIBLE),     # 2
    ("schott", "N-SF5", VISIBLE),   # 2
    ("schott", "N-LAK9", VISIBLE),  # 2
    ("schott", "F2", VISIBLE),      # 2, name also exists in CDGM
    ("schott", "N-LASF9", VISIBLE),  # 2
    ("schott", "ZERODUR", VISIBLE),  # 2, no nd/vd in SPECS (misc/ sub-folder)
    ("schott", "IRG22", INFRARED),   # 2 with 5 coefficients (infrared/)
    ("schott", "IRG23", INFRARED),   # 1, the only formula-1 glass
    ("cdgm", "H-K9L", VISIBLE),      # 2
    ("cdgm", "D-FK61", VISIBLE),     # 2, resonance terms not sorted
    ("cdgm", "H-ZF52", VISIBLE),     # 2, range starts at 0.4047
    ("cdgm", "F2", VISIBLE),         # 3, range ends at 1.014
    ("cdgm", "H-ZLAF52", VISIBLE),   # 3
    ("ohara", "S-BSL7", VISIBLE),    # 2
    ("ohara", "S-LAH66", VISIBLE),   # 2
    ("ohara", "S-FPL51", VISIBLE),   # 2
    ("ohara", "S-TIH6", VISIBLE),    # 2
    ("ohara", "BSL7", VISIBLE),      # 3
    ("ohara", "BAH27", VISIBLE),     # 3
]

# Model glasses (nd, Vd) for AbbeMaterial, valid 0.38-0.75 um (polynomial).
ABBE_GLASSES = [(1.5168, 64.17), (1.67271, 32.25), (1.691, 54.71), (1.84666, 23.78)]
ABBE_MODELS = ["polynomial", "buchdahl"]


def generator(cls):
    return f"optiland {VERSION} (optiland.materials.{cls.__name__}), make_glass_reference.py"


def index(material, wavelength):
    return float(material.n(wavelength)[0])


def glass_file(catalog, name):
    """The database file of exactly this glass (may be in a sub-folder)."""
    (path,) = (GLASS_DB / catalog).rglob(f"{name}.yml")
    return path


def check_name_lookup(catalog, name, path):
    """Report when optiland's name lookup would pick a different file."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        found = Path(Material(name, catalog=catalog).filename)
    if found != path:
        print(f"  note: Material({name!r}, catalog={catalog!r}) resolves to "
              f"{found.relative_to(GLASS_DB)}, not {path.relative_to(GLASS_DB)}")


def catalogue_indices():
    rows = []
    for catalog, name, wavelengths in GLASSES:
        path = glass_file(catalog, name)
        check_name_lookup(catalog, name, path)
        material = MaterialFile(str(path))
        lo, hi = material.spectral_range("n")
        rows += [{"catalog": catalog.upper(), "name": name, "wavelength_um": w,
                  "n": index(material, w)}
                 for w in wavelengths if lo <= w <= hi]
    return rows


def abbe_indices():
    rows = []
    for model in ABBE_MODELS:
        for nd, vd in ABBE_GLASSES:
            material = AbbeMaterial(nd, vd, model=model)
            rows += [{"model": model, "nd": nd, "vd": vd, "wavelength_um": w,
                      "n": index(material, w)} for w in VISIBLE]
    return rows


def write(filename, generator, key, rows):
    body = ",\n".join("  " + json.dumps(r) for r in rows)
    text = f'{{"generator": {json.dumps(generator)},\n "{key}": [\n{body}\n]}}\n'
    (OUT_DIR / filename).write_text(text, encoding="utf-8")
    print(f"{filename}: {len(rows)} values")


if __name__ == "__main__":
    warnings.simplefilter("error")  # any optiland warning aborts the run
    write("optiland_indices.json", generator(MaterialFile), "indices",
          catalogue_indices())
    write("optiland_abbe_indices.json", generator(AbbeMaterial), "indices",
          abbe_indices())
