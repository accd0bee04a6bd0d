#!/usr/bin/env bash
# Sets up and runs every check: formatting, clippy (warnings are errors) and all tests.
# Test binaries are built with optimisation (profile.test in Cargo.toml).
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
source scripts/setup_python.sh dev   # PyTorch, onnx, onnxruntime (ORT_DYLIB_PATH for the bench tests), ...
# One clean build: incremental caches would only take disk (several GB for the optimised test profile).
export CARGO_INCREMENTAL=0
# A first build of the tests takes ~4.6 GB (measured on a clean clone): a smaller disk is named here,
# not by a linker error ten minutes in.
if [ ! -d target/debug/deps ]; then
  free_kb=$(df -Pk . | awk 'NR == 2 { print $4 }')
  if [ "$free_kb" -lt $((5 * 1048576)) ]; then
    echo "test: $(awk -v kb="$free_kb" 'BEGIN { printf "%.1f", kb / 1048576 }') GB free here, but building the tests" \
      "needs about 5 GB; free some disk and retry" >&2
    exit 1
  fi
fi
cargo fmt --all -- --check
cargo clippy --workspace --all-targets --quiet -- -D warnings
# The totals line is printed whether or not a test failed (so CI's log always ends with the counts);
# the script still fails when cargo test did.
cargo_status=0
# Examples are type-checked by clippy above; linking them here would only take time and disk.
( status=0
  cargo test --workspace --lib --bins --tests --quiet --no-fail-fast || status=$?
  cargo test --workspace --doc --quiet --no-fail-fast || status=$?
  exit "$status" ) 2>&1 | tee /tmp/unicac-test.log || cargo_status=$?
# One closing line with the totals over every test binary.
awk '/^test result:/ { for (i = 1; i <= NF; i++) { if ($(i+1) ~ /^passed/) p += $i; if ($(i+1) ~ /^failed/) f += $i; if ($(i+1) ~ /^ignored/) s += $i } }
     END { printf "unicac: %d passed, %d failed, %d skipped\n", p, f, s; exit (f > 0) }' /tmp/unicac-test.log
if [ "$cargo_status" -ne 0 ]; then
    echo "cargo test failed (exit $cargo_status)" >&2
    exit "$cargo_status"
fi
bash scripts/python_test.sh   # builds the Python package on the test artifacts, runs python/tests
