#!/usr/bin/env bash
# The main job on an embedded lens, no user data: first-order data, spot diagram, ray fans and layout
# of the built-in Cooke triplet, pictures written to out/.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh
cargo build --release -q -p unicac-cli
unicac=target/release/unicac
lens=${1:-builtin:cooke_triplet}
mkdir -p out
$unicac lens info "$lens"
$unicac spot "$lens" --plot out/spot.png
$unicac fan "$lens" --plot out/fan.png
$unicac layout "$lens" --plot out/layout.svg
echo "pictures: out/spot.png out/fan.png out/layout.svg"
