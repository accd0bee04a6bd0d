#!/usr/bin/env bash
# Ray-surface throughput of unicac's f64 tracer beside optiland (numpy backend), same lenses and
# workload, run back to back in one session (docs/performance.md). Creates its own venv with pinned
# peers under bench/.venv-peers (PyPI only).
set -euo pipefail
cd "$(dirname "$0")/.."
venv=bench/.venv-peers
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q optiland==0.6.3
fi
echo "# machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), $(date -u +%Y-%m-%dT%H:%MZ)"
echo "# unicac (cargo run --release -p unicac-trace --example throughput)"
cargo run --release -q -p unicac-trace --example throughput
echo "# optiland $("$venv/bin/python" -c 'import optiland, numpy; print(optiland.__version__ if hasattr(optiland, "__version__") else "", "numpy", numpy.__version__)')"
"$venv/bin/python" bench/peers/optiland_throughput.py
