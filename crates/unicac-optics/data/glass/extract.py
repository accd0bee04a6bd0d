#!/usr/bin/env python3
"""Extract the SCHOTT, CDGM and OHARA glass catalogues to compact JSON.

Source: the refractiveindex.info database (CC0 1.0) as shipped inside the
optiland 0.6.3 wheel.  Usage (see README.md for the full recipe):

    python3 extract.py /tmp/optiland-wheel/unpacked

The argument is the directory the wheel was unzipped into (it contains
``optiland/``).  Writes schott.json, cdgm.json and ohara.json next to this
script and prints a summary.  Requires PyYAML.
"""

import collections
import json
import sys
from pathlib import Path

import yaml

SOURCE = "refractiveindex.info database as shipped in optiland 0.6.3 wheel"
LICENSE = "CC0 1.0"
GLASS_DIR = Path("optiland/database/data-nk/glass")
CATALOGS = {"schott": "SCHOTT", "cdgm": "CDGM", "ohara": "OHARA"}
# Sub-folders holding further vendor products (file stem = product name).
# Any other sub-folder (e.g. schott/BK7/Lane.yml) holds a literature
# measurement of a glass whose vendor data is already in the catalogue.
PRODUCT_SUBDIRS = {"infrared", "misc", "obsolete"}
OUT_DIR = Path(__file__).resolve().parent


def numbers(text):
    """Space-separated numbers from a yml field, as floats, in order."""
    return [float(tok) for tok in str(text).split()]


def optional_float(specs, key):
    value = specs.get(key)
    return None if value is None else float(value)


def read_glass(path):
    """Return (glass dict, None) or (None, reason it was skipped)."""
    with open(path, encoding="utf-8") as fh:
        doc = yaml.safe_load(fh)
    formulas = [d for d in doc["DATA"] if d["type"].startswith("formula")]
    if not formulas:
        kinds = "+".join(d["type"].strip() for d in doc["DATA"])
        return None, f"no dispersion formula ({kinds} only)"
    if len(formulas) > 1:
        raise ValueError(f"{path}: several formula entries")
    entry = formulas[0]  # any "tabulated k" entry is dropped: n only
    specs = doc.get("SPECS") or {}
    return {
        "name": path.stem,
        "formula": int(entry["type"].split()[1]),
        "coefficients": numbers(entry["coefficients"]),
        "wavelength_range_um": numbers(entry["wavelength_range"]),
        "nd": optional_float(specs, "nd"),
        "vd": optional_float(specs, "Vd"),
    }, None


def catalogue_files(cat_dir):
    """Yield (path, skip reason or None) for every yml of one catalogue."""
    for path in sorted(cat_dir.rglob("*.yml")):
        rel = path.relative_to(cat_dir)
        if len(rel.parts) > 1 and rel.parts[0] not in PRODUCT_SUBDIRS:
            yield path, "literature variant; vendor catalogue file used instead"
        else:
            yield path, None


def write_catalog(catalog, rel_dir, glasses):
    head = json.dumps({"catalog": catalog,
                       "source": f"{SOURCE}, path {rel_dir.as_posix()}",
                       "license": LICENSE})
    rows = ",\n".join("  " + json.dumps(g) for g in glasses)
    out = OUT_DIR / f"{catalog.lower()}.json"
    out.write_text(f'{head[:-1]},\n "glasses": [\n{rows}\n]}}\n', encoding="utf-8")
    return out


def extract(wheel_root):
    for key, catalog in CATALOGS.items():
        rel_dir = GLASS_DIR / key
        glasses, skipped = [], []
        for path, reason in catalogue_files(wheel_root / rel_dir):
            glass = None
            if reason is None:
                glass, reason = read_glass(path)
            if glass:
                glasses.append(glass)
            else:
                skipped.append((path.relative_to(wheel_root / rel_dir), reason))
        names = [g["name"].upper() for g in glasses]
        dupes = [n for n, c in collections.Counter(names).items() if c > 1]
        if dupes:
            raise ValueError(f"{catalog}: duplicate names {dupes}")
        glasses.sort(key=lambda g: g["name"])
        out = write_catalog(catalog, rel_dir, glasses)

        formulas = collections.Counter(g["formula"] for g in glasses)
        no_ndvd = [g["name"] for g in glasses if g["nd"] is None or g["vd"] is None]
        print(f"{catalog}: {len(glasses)} glasses -> {out.name} "
              f"({out.stat().st_size} bytes); formulas "
              f"{dict(sorted(formulas.items()))}")
        print(f"  without nd/vd: {', '.join(no_ndvd) or '-'}")
        for rel, why in skipped:
            print(f"  skipped {rel.as_posix()}: {why}")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    extract(Path(sys.argv[1]))
