#!/usr/bin/env bash
# The as-built bench of docs/dataset.md ("As-built split"): the bundled lenses (lenses/) as a
# 2-level dataset with 2 units per test lens built within the textbook tolerances, benchmarked
# with Wiener and two shipped models (held-out lenses for them). Usage, from the repository after
# a release build and the Python setup (for onnxruntime): bash docs/as-built-bench/run.sh OUT_DIR
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:?give an output folder}
mkdir -p "$out" && cd "$out"
U=$repo/target/release/unicac
export ORT_DYLIB_PATH=$repo/.venv/lib/python3.11/site-packages/onnxruntime/capi/libonnxruntime.so.1.31.1
$U dataset build --lenses "$repo/lenses" --images dead-leaves:8:512x384 --test-images dead-leaves:4:512x384 \
  --out ds --levels 2 --test-lenses-per-level 3 --val-lenses 1 --pairs-per-lens 2 --crop 256x256 \
  --as-built 2 --tolerances "$repo/docs/tolerancing/textbook.json"
$U bench --dataset ds --split as_built --method wiener \
  --model nafnet-3000="$repo/models/bench-small/nafnet-3000.onnx" \
  --model wiener-nafnet-3000="$repo/models/bench-small/wiener-nafnet-3000.onnx" \
  --metrics psnr,ssim,lpips --threads 2 --out bench-as-built
