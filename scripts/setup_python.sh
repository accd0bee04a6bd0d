#!/usr/bin/env bash
# Creates .venv (once) and installs the pinned PyPI packages of python/requirements-$1.txt into it
# ("runtime": numpy and onnxruntime, for the demo; "dev": everything the tests need, PyTorch included).
# Exports ORT_DYLIB_PATH, the onnxruntime shared library that `unicac bench` loads (the `ort` crate,
# load-dynamic), and UNICAC_PYTHON, the venv's interpreter. Sourced by demo.sh and test.sh after setup.sh.
# pip keeps no download cache (--no-cache-dir): PyTorch's CUDA wheels would take another ~3 GB of disk,
# and the stamp below already skips pip when the requirements are unchanged. Before pip runs, the free
# disk beside the venv is checked against the install's measured peak, so a small disk is named as such
# instead of failing half-way through an install.
set -euo pipefail

requirements_kind=${1:-runtime}
VENV=${VENV:-.venv}
PYTHON=${PYTHON:-python3}
if [ ! -x "$VENV/bin/python" ]; then
  echo "setup: creating $VENV with $("$PYTHON" --version)"
  "$PYTHON" -m venv "$VENV"
fi
stamp="$VENV/.requirements-$requirements_kind.sha256"
wanted=$(cat "python/requirements-$requirements_kind.txt" python/requirements-runtime.txt python/requirements-dev-torch.txt \
  | sha256sum | cut -d' ' -f1)
if [ "$(cat "$stamp" 2>/dev/null)" != "$wanted" ]; then
  # pip unpacks into TMPDIR; /tmp may be a small RAM disk, so its scratch lives beside the venv.
  pip_scratch="$VENV/.pip-scratch"
  rm -rf "$pip_scratch" && mkdir -p "$pip_scratch"
  free_kb=$(df -Pk "$VENV" | awk 'NR == 2 { print $4 }')
  free_gb=$(awk -v kb="$free_kb" 'BEGIN { printf "%.1f", kb / 1048576 }')
  # Measured peaks of a fresh install (the venv's final size plus pip's scratch), with a margin.
  if [ "$requirements_kind" = dev ]; then need_gb=6; else need_gb=1; fi
  if [ "$free_kb" -lt $((need_gb * 1048576)) ]; then
    echo "setup: $free_gb GB free at $VENV, but installing python/requirements-$requirements_kind.txt needs about" \
      "$need_gb GB; free some disk and retry" >&2
    exit 1
  fi
  echo "setup: installing python/requirements-$requirements_kind.txt into $VENV (pip; $free_gb GB free there)"
  pip_install() {
    TMPDIR="$pip_scratch" "$VENV/bin/python" -m pip install --quiet --disable-pip-version-check \
      --no-cache-dir "$@"
  }
  if [ "$requirements_kind" = dev ]; then
    # PyTorch and its CUDA wheels one at a time, without resolving dependencies (see that file): installed
    # they take ~3.9 GB, and a single pip call would also hold all of them downloaded until it ends.
    while read -r pin; do
      case "$pin" in '' | '#'*) continue ;; esac
      pip_install --no-deps "$pin"
    done < python/requirements-dev-torch.txt
  fi
  # pip reports torch's triton as missing once the rest is resolved: left out on purpose (see
  # requirements-dev-torch.txt), so that line is not passed on; anything else pip says is.
  pip_install -r "python/requirements-$requirements_kind.txt" 2> "$pip_scratch/stderr" \
    || { cat "$pip_scratch/stderr" >&2; exit 1; }
  grep -v -e "dependency resolver does not currently take into account" -e "requires triton" \
    "$pip_scratch/stderr" >&2 || true
  rm -rf "$pip_scratch"
  echo "$wanted" > "$stamp"
fi
UNICAC_PYTHON="$(cd "$VENV" && pwd)/bin/python"
export UNICAC_PYTHON
ORT_DYLIB_PATH=$("$UNICAC_PYTHON" -c 'import glob, os, onnxruntime
print(sorted(glob.glob(os.path.join(os.path.dirname(onnxruntime.__file__), "capi", "libonnxruntime.so.*")))[0])')
export ORT_DYLIB_PATH
