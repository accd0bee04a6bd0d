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
wanted=$(cat "python/requirements-$requirements_kind.txt" python/requirements-runtime.txt python/requirements-dev-cuda.txt \
  | sha256sum | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$wanted" ]; then
  # pip unpacks into TMPDIR; /tmp may be a small RAM disk, so its scratch lives beside the venv.
  pip_scratch="$VENV/.pip-scratch"
  rm -rf "$pip_scratch" && mkdir -p "$pip_scratch"
  free_gb=$(df -Pk "$VENV" | awk 'NR == 2 { printf "%.1f", $4 / 1048576 }')
  echo "setup: installing python/requirements-$requirements_kind.txt into $VENV (pip; $free_gb GB free there)"
  pip_install() {
    TMPDIR="$pip_scratch" "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check \
      --no-cache-dir "$@"
  }
  if [ "$requirements_kind" = dev ]; then
    # PyTorch's CUDA wheels one at a time: installed they take ~3 GB, and a single pip call would also
    # hold all of them downloaded until it ends.
    while read -r pin; do
      case "$pin" in '' | '#'*) continue ;; esac
      pip_install --no-deps "$pin"
    done < python/requirements-dev-cuda.txt
  fi
  pip_install -r "python/requirements-$requirements_kind.txt"
  rm -rf "$pip_scratch"
  echo "$wanted" > "$stamp"
fi
UNICAC_PYTHON="$(cd "$VENV" && pwd)/bin/python"
export UNICAC_PYTHON
ORT_DYLIB_PATH=$("$UNICAC_PYTHON" -c 'import glob, os, onnxruntime
print(sorted(glob.glob(os.path.join(os.path.dirname(onnxruntime.__file__), "capi", "libonnxruntime.so.*")))[0])')
export ORT_DYLIB_PATH
