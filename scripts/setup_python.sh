#!/usr/bin/env bash
# Creates .venv (once) and installs the pinned PyPI packages of python/requirements-$1.txt into it
# ("runtime": numpy and onnxruntime, for the demo; "dev": everything the tests need, PyTorch included).
# Exports ORT_DYLIB_PATH, the onnxruntime shared library that `unicac bench` loads (the `ort` crate,
# load-dynamic), and UNICAC_PYTHON, the venv's interpreter. Sourced by demo.sh and test.sh after setup.sh.
# pip keeps no download cache (--no-cache-dir): PyTorch's CUDA wheels would take another ~3 GB of disk,
# and the stamp below already skips pip when the requirements are unchanged.
set -euo pipefail

requirements_kind=${1:-runtime}
VENV=${VENV:-.venv}
PYTHON=${PYTHON:-python3}
if [ ! -x "$VENV/bin/python" ]; then
  echo "setup: creating $VENV with $("$PYTHON" --version)"
  "$PYTHON" -m venv "$VENV"
fi
stamp="$VENV/.requirements-$requirements_kind.sha256"
wanted=$(cat "python/requirements-$requirements_kind.txt" python/requirements-runtime.txt | sha256sum | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$wanted" ]; then
  echo "setup: installing python/requirements-$requirements_kind.txt into $VENV (pip)"
  "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check --no-cache-dir \
    -r "python/requirements-$requirements_kind.txt"
  echo "$wanted" > "$stamp"
fi
UNICAC_PYTHON="$(cd "$VENV" && pwd)/bin/python"
export UNICAC_PYTHON
ORT_DYLIB_PATH=$("$UNICAC_PYTHON" -c 'import glob, os, onnxruntime
print(sorted(glob.glob(os.path.join(os.path.dirname(onnxruntime.__file__), "capi", "libonnxruntime.so.*")))[0])')
export ORT_DYLIB_PATH
