#!/usr/bin/env bash
# Makes the venv's Python import `unicac` from this checkout (python/), with the native module built by
# cargo for the given profile ("test": reuses what `cargo test --workspace` compiled; "release"), the way
# `maturin develop` installs a mixed Rust/Python project: the module next to the Python sources
# (python/unicac/_native.abi3.so) and a .pth file putting python/ on the venv's path.
# (`maturin develop --profile test` cannot be used: cargo builds a test harness for that profile.)
# Sourced after scripts/setup_python.sh (needs VENV); users install with `pip install ./python` instead.
set -euo pipefail
link_profile=${1:-release}
# A wheel installed earlier (pip install ./python) would shadow the checkout.
"$VENV/bin/python" -m pip uninstall --quiet --yes unicac >/dev/null 2>&1 || true
# The venv is never activated: pyo3's build script would see VIRTUAL_ENV change and rebuild.
cargo build --profile "$link_profile" --quiet -p unicac-py -p unicac-cli
link_dir=$([ "$link_profile" = test ] && echo debug || echo "$link_profile")
rm -f python/unicac/_native*.so
cp "target/$link_dir/lib_native.so" python/unicac/_native.abi3.so
link_site=$("$VENV/bin/python" -c 'import sysconfig; print(sysconfig.get_paths()["purelib"])')
echo "$PWD/python" > "$link_site/unicac-dev.pth"
