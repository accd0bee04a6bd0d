#!/usr/bin/env bash
# End-to-end spot diagram of N random pupil rays (default 1,000,000) at the largest field and the
# primary wavelength, paraxial aiming: the `unicac spot` process against the optiland process
# (bench/peers/optiland_spot.py), whole-process wall time, best of RUNS (default 3) each, run back to
# back in one session (docs/performance.md). optiland comes from the venv of bench/trace_vs_optiland.sh.
# Usage: bash bench/spot_vs_optiland.sh [N] [RUNS]   (needs target/release/unicac)
set -euo pipefail
cd "$(dirname "$0")/.."
rays=${1:-1000000}
runs=${2:-3}
venv=bench/.venv-peers
unicac=target/release/unicac
if [ ! -x "$venv/bin/python" ]; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q optiland==0.6.3
fi
[ -x "$unicac" ] || { echo "build it first: cargo build --release -p unicac-cli" >&2; exit 1; }
wall() { local t0 t1; t0=$(date +%s.%N); "$@" >/dev/null 2>&1; t1=$(date +%s.%N); echo "$t1 - $t0" | bc; }
best() { sort -g | head -1; }
echo "# machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), $(date -u +%Y-%m-%dT%H:%MZ), load $(cut -d' ' -f1-3 /proc/loadavg)"
for lens in cooke_triplet phone_asphere; do
  read -r field wl < <("$venv/bin/python" -c "
import json; l = json.load(open('lenses/$lens.json'))
print(max(l['fields']['angles_deg']), l['wavelengths'][l.get('primary_wavelength_index', 0)]['wavelength_um'])")
  cmd=("$unicac" spot "lenses/$lens.json" --pupil-sampling "random:$rays" --field-deg "$field"
       --wavelength-um "$wl" --aim paraxial --device cpu --json)
  u=$(for _ in $(seq "$runs"); do wall "${cmd[@]}"; done | best)
  o=$(for _ in $(seq "$runs"); do wall "$venv/bin/python" bench/peers/optiland_spot.py "$lens" "$rays"; done | best)
  echo "{\"lens\": \"$lens\", \"rays\": $rays, \"field_deg\": $field, \"unicac_s\": $u, \"optiland_s\": $o, \"ratio\": $(echo "scale=2; $o / $u" | bc)}"
  "${cmd[@]}" | "$venv/bin/python" -c "import json,sys; s=json.load(sys.stdin)['spots'][0]; print('#  unicac RMS', s['rms_radius_um'], 'um, ok', s['rays_ok'])"
  "$venv/bin/python" bench/peers/optiland_spot.py "$lens" "$rays" 2>/dev/null | sed 's/^/#  optiland /'
done
