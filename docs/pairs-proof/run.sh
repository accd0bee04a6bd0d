#!/usr/bin/env bash
# Issue 30's proof: a NAFNet trained 300 iterations on the 100-degree wide angle's pairs alone, tested on
# five other lenses' test pairs; once with --task full (GT undistorted, unshaded), once with --task aligned.
set -euo pipefail
cd "$(dirname "$0")/../.." && out=${1:?usage: docs/pairs-proof/run.sh OUT} && mkdir -p "$out" && here=$PWD && cd "$out"
U=${UNICAC_BIN:-$here/target/release/unicac}
PY=${PYTHON:-$here/.venv/bin/python}
common=(--images dead-leaves:8:320x240 --test-images dead-leaves:2:256x192 --frame 256x192 --crop 128x96)
for task in full aligned; do
  [ -f T-$task/dataset.json ] || $U dataset build --lenses $here/lenses/wide_angle_100.json builtin:singlet \
    "${common[@]}" --levels 1 --test-lenses-per-level 1 --val-lenses 0 --pairs-per-lens 16 --seed 5 --task $task --out T-$task
  $U dataset info T-$task > info-T-$task.txt
done
[ -f E/dataset.json ] || $U dataset build --lenses builtin:achromat builtin:cooke_triplet builtin:double_gauss builtin:petzval \
  builtin:phone_asphere builtin:wide_angle "${common[@]}" --levels 5 --test-lenses-per-level 1 --val-lenses 0 \
  --pairs-per-lens 2 --seed 6 --task aligned --out E
$U dataset info E > info-E.txt
for task in full aligned; do
  if [ ! -f m-$task.onnx ]; then
    $PY -m unicac.train train --config $here/docs/pairs-proof/nafnet-300.yml --dataset T-$task --iters 300 --patch-px 64 \
      --allow-misaligned --out run-$task > train-$task.log 2>&1 || { tail -5 train-$task.log; exit 1; }
    $PY -m unicac.train export run-$task --out m-$task.onnx
  fi
done
rm -rf bench-E
$U bench --dataset E --model trained-on-full-pairs=m-full.onnx --model trained-on-aligned-pairs=m-aligned.onnx --out bench-E
cat bench-E/tables.md
