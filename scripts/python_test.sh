#!/usr/bin/env bash
# Builds the Python package `unicac` into .venv and runs its tests (python/tests), ending with one line
# "unicac-python: N passed, N failed, N skipped". Called by scripts/test.sh after the cargo tests.
#
# The extension is built by cargo with the `test` profile (optimised, see Cargo.toml), which reuses
# everything `cargo test --workspace` has just compiled (only the bindings crate itself is new), and is
# installed the way `maturin develop` installs a mixed Rust/Python project: the module next to the
# Python sources (python/unicac/_native.abi3.so) and a .pth file putting python/ on the venv's path.
# (`maturin develop --profile test` cannot be used: cargo builds a test harness for that profile.)
# Users install with `pip install ./python` (a maturin release build of the same crate).
set -euo pipefail
cd "$(dirname "$0")/.."

VENV=.venv
source scripts/setup_python.sh dev   # the venv with the pinned test packages (idempotent)
# A wheel installed earlier (pip install ./python) would shadow the build under test.
"$VENV/bin/python" -m pip uninstall --quiet --yes unicac >/dev/null 2>&1 || true

# The venv is never activated: pyo3's build script would see VIRTUAL_ENV change and rebuild.
cargo build --profile test --quiet -p unicac-py -p unicac-cli
rm -f python/unicac/_native*.so
cp target/debug/lib_native.so python/unicac/_native.abi3.so
site=$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
echo "$PWD/python" > "$site/unicac-dev.pth"

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
