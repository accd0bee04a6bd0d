#!/usr/bin/env bash
# Builds the Python package `unicac` into .venv and runs its tests (python/tests), ending with one line
# "unicac-python: N passed, N failed, N skipped". Called by scripts/test.sh after the cargo tests.
#
# The extension is built by cargo with the `test` profile (optimised, see Cargo.toml), which reuses
# everything `cargo test --workspace` has just compiled (only the bindings crate itself is new), and
# linked into the venv by scripts/link_python_package.sh. Users install with `pip install ./python`.
set -euo pipefail
cd "$(dirname "$0")/.."

VENV=.venv
source scripts/setup_python.sh dev   # the venv with the pinned test packages (idempotent)
source scripts/link_python_package.sh test

log=$(mktemp)
status=0
UNICAC_BIN="$PWD/target/debug/unicac" "$VENV/bin/python" -m pytest python/tests -q -rs -p no:cacheprovider \
  2>&1 | tee "$log" || status=$?
tail -n 1 "$log" | awk '{
  for (i = 1; i < NF; i++) {
    n = $i; w = $(i + 1); gsub(/[,.]/, "", w)
    if (w == "passed") p = n; else if (w == "failed" || w ~ /^error/) f += n; else if (w == "skipped") s = n
  }
  printf "unicac-python: %d passed, %d failed, %d skipped\n", p, f, s }'
rm -f "$log"
exit "$status"
