#!/usr/bin/env bash
# Image simulation, whole process and cold (no PSF cache): `unicac simulate` against optiland's
# ImageSimulationEngine (bench/peers/optiland_image_simulation.py), back to back in one session
# (docs/performance.md, issue 18 part 4). Rows:
#   cooke_triplet 256x256    both tools at their defaults
#   phone_asphere 1000x750   optiland at its defaults (3 wavelengths, 5 x 5 PSFs)
#   phone_asphere 1000x750   optiland with unicac's spectral sampling (--equal-work: 31 wavelengths,
#                            4 x 4 PSFs per wavelength)
# unicac: best of RUNS (default 2); optiland: one run per row (the equal-work row takes minutes), its
# process wall time and its engine.run time from the same run. optiland comes from the venv of
# bench/trace_vs_optiland.sh, or OPTILAND_VENV (a venv with optiland==0.6.3).
# Usage: bash bench/simulate_vs_optiland.sh [RUNS]   (needs target/release/unicac)
set -euo pipefail
cd "$(dirname "$0")/.."
runs=${1:-2}
venv=${OPTILAND_VENV:-bench/.venv-peers}
unicac=$PWD/target/release/unicac
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q optiland==0.6.3
fi
[ -x "$unicac" ] || { echo "build it first: cargo build --release -p unicac-cli" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
wall() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N); echo "$t1 - $t0" | bc; }
best() { sort -g | head -1; }
echo "# machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), $(date -u +%Y-%m-%dT%H:%MZ), load $(cut -d' ' -f1-3 /proc/loadavg)"
row() {   # row LENS WxH [--equal-work]
  local lens=$1 size=$2 mode=${3:-}
  local image=$work/dead-leaves-$size.png
  [ -f "$image" ] || "$unicac" chart dead-leaves --size "$size" --seed 7 --out "$image" >/dev/null
  local u t0 t1 json
  u=$(for k in $(seq "$runs"); do
        wall "$unicac" simulate "builtin:$lens" "$image" --out "$work/out-$k" --no-cache --device cpu
        rm -rf "$work/out-$k"
      done | best)
  t0=$(date +%s.%N)
  json=$("$venv/bin/python" bench/peers/optiland_image_simulation.py "$lens" "$size" $mode 2>/dev/null)
  t1=$(date +%s.%N)
  "$venv/bin/python" - "$lens" "$size" "${mode:-defaults}" "$u" "$(echo "$t1 - $t0" | bc)" "$json" <<'PY'
import json, sys
lens, size, mode, u, o, peer = sys.argv[1:]
engine = json.loads(peer)
print(json.dumps({"lens": lens, "size": size, "optiland_mode": mode, "unicac_process_s": float(u),
                  "optiland_process_s": round(float(o), 2), "optiland_engine_s": engine["seconds"],
                  "optiland_engine_runs": engine.get("engine_runs", 1), "optiland_finite": engine["finite"],
                  "ratio_process": round(float(o) / float(u), 1),
                  "ratio_engine_only": round(engine["seconds"] / float(u), 1)}))
PY
}
row cooke_triplet 256x256
row phone_asphere 1000x750
row phone_asphere 1000x750 --equal-work
