#!/usr/bin/env bash
# The documented benchmark run of docs/bench.md ("A documented run"): a lens library (the bundled lenses,
# the 100-degree wide angle and the designs of a seeded `unicac design` run of the Cooke specification)
# -> `unicac dataset build` (3 ODE levels, 1024 x 768 frames, blur and sensor chain, no distortion or
# shading so that the levels measure aberration) -> `unicac bench` of the unrestored input, Wiener
# deconvolution and the committed small NAFNet. About 4 minutes on 2 cores.
#
#   bash bench/documented_run.sh [OUT]        (default OUT: out/documented-run)
#
# Needs the release binary's set-up (scripts/setup.sh, scripts/setup_python.sh runtime) and the LPIPS
# weights (`unicac weights fetch lpips`, done here).
set -euo pipefail
out=$(realpath -m "${1:-$(dirname "$0")/../out/documented-run}")   # relative to where it is called
cd "$(dirname "$0")/.."
# The folder is replaced, so it must be new, empty, or an earlier run of this script (never, say, `.`).
if [ -e "$out" ] && [ ! -f "$out/.documented-run" ] && [ -n "$(ls -A "$out" 2>/dev/null)" ]; then
  echo "documented_run.sh: $out exists and is not an earlier run of this script; give a new folder" >&2
  exit 2
fi
source scripts/setup.sh
source scripts/setup_python.sh runtime
cargo build --release -q -p unicac-cli
unicac=target/release/unicac
rm -rf "$out"
mkdir -p "$out"
touch "$out/.documented-run"
$unicac design --elements 3 --half-fov-deg 20 --f-number 5 --focal-length-mm 50 --stop middle \
    --count 3 --seed 1 --time-budget-s 300 --out "$out/designs"
$unicac dataset build --lenses builtin:achromat builtin:cooke_triplet builtin:double_gauss builtin:petzval \
    builtin:phone_asphere builtin:singlet builtin:wide_angle lenses/wide_angle_100.json \
    "$out"/designs/lenses/*.zmx \
    --images dead-leaves:4:1024x768 --test-images dead-leaves:3:1024x768 --frame 1024x768 \
    --levels 3 --test-lenses-per-level 2 --val-lenses 1 --pairs-per-lens 2 --seed 1 \
    --no-distortion --no-illumination --out "$out/dataset"
$unicac dataset plot "$out/dataset" --out "$out/dataset-levels.png"
$unicac weights fetch lpips --python "$UNICAC_PYTHON"
$unicac bench --dataset "$out/dataset" --method wiener --model nafnet-small=models/nafnet-small.onnx \
    --out "$out/bench"
cat "$out/bench/tables.md"
