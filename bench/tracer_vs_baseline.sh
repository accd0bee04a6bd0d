#!/usr/bin/env bash
# The batch tracer against the one issue 18 measured ("81 M/s on spheres, 21 M/s on 12 even aspheres":
# commit 39f2781, the last before the SIMD lane tracer), on this machine, in one session.
# Both trees build the same small example (below): 1,000,000 rays of `unicac_trace::workload` (half on
# axis, half at the largest field), traced by `TraceSystem::trace_chunk` (what `trace_rays` runs) in
# rayon chunks of 2048 rays, statuses allocated outside the timed region, median of 15 runs after one
# warm-up, on 1 and on 2 threads. The two binaries run interleaved ROUNDS times (default 8) because
# this VM's speed drifts by 10-50% from process to process; each round prints one JSON line per
# binary and thread count, then the medians over the rounds and the per-round ratios.
# Usage: bash bench/tracer_vs_baseline.sh [ROUNDS] [LENS...]   (LENS: cooke_triplet, phone_asphere)
# Builds in git worktrees under ${TMPDIR:-/tmp}/unicac-tracer-baseline (HEAD and 39f2781; a minute or
# two each the first time); the working tree is not touched.
set -euo pipefail
cd "$(dirname "$0")/.."
rounds=${1:-8}
shift || true
case $rounds in
  ''|*[!0-9]*|0) echo "ROUNDS must be a positive integer, got '$rounds'" >&2; exit 2 ;;
esac
lenses=("$@")
[ ${#lenses[@]} -gt 0 ] || lenses=(cooke_triplet phone_asphere)
base=${TMPDIR:-/tmp}/unicac-tracer-baseline
baseline_commit=39f2781
mkdir -p "$base"

example='use rayon::prelude::*;
use std::time::Instant;
use unicac_optics::examples;
use unicac_trace::workload::axis_and_edge_rays;
use unicac_trace::{Clipping, RayStatus, TraceSystem};

fn main() {
    let name = std::env::args().nth(1).expect("lens name");
    let lens = examples::lens(&name).unwrap();
    let system = TraceSystem::new(&lens, lens.primary_wavelength_um(), Clipping::Apertures).unwrap();
    let rays = axis_and_edge_rays(&lens, 1_000_000, 12345).unwrap();
    let surfaces = lens.surfaces.len();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut statuses = vec![RayStatus::Ok; rays.len()];
        let mut times: Vec<f64> = (0..16)
            .map(|_| {
                let mut batch = rays.to_vec();
                let start = Instant::now();
                pool.install(|| {
                    batch
                        .par_chunks_mut(2048)
                        .zip(statuses.par_chunks_mut(2048))
                        .for_each(|(rays, statuses)| system.trace_chunk(rays, statuses))
                });
                start.elapsed().as_secs_f64()
            })
            .skip(1)
            .collect();
        times.sort_by(f64::total_cmp);
        let ok = statuses.iter().filter(|s| s.is_ok()).count();
        println!(
            "{{\"lens\": \"{name}\", \"threads\": {threads}, \"rays_ok\": {ok}, \"m_ray_surfaces_per_s\": {:.1}}}",
            (rays.len() * surfaces) as f64 / times[7] / 1e6
        );
    }
}'

build() { # build NAME COMMIT -> path of the binary
  local tree=$base/$1 target=$base/$1-target
  if [ ! -d "$tree" ]; then git worktree add --detach -f "$tree" "$2" >/dev/null 2>&1; fi
  git -C "$tree" checkout -q --detach "$2"
  printf '%s\n' "$example" > "$tree/crates/unicac-trace/examples/same_workload.rs"
  (cd "$tree" && CARGO_TARGET_DIR=$target cargo build -q --release -p unicac-trace --example same_workload) >&2
  echo "$target/release/examples/same_workload"
}
head=$(git rev-parse --short HEAD)
new=$(build head "$head")
old=$(build baseline "$baseline_commit")
echo "# machine: $(nproc) cores, $(lscpu | sed -n 's/^Model name: *//p'), $(date -u +%Y-%m-%dT%H:%MZ), load $(cut -d' ' -f1-3 /proc/loadavg); HEAD $head vs $baseline_commit"
log=$(mktemp)
for lens in "${lenses[@]}"; do
  for _ in $(seq "$rounds"); do
    "$old" "$lens" | sed "s/^{/{\"tree\": \"$baseline_commit\", /" | tee -a "$log"
    "$new" "$lens" | sed "s/^{/{\"tree\": \"$head\", /" | tee -a "$log"
  done
done
python3 - "$log" "$baseline_commit" "$head" <<'EOF'
import json, statistics, sys
rows = [json.loads(line) for line in open(sys.argv[1])]
old, new = sys.argv[2], sys.argv[3]
for lens in dict.fromkeys(r["lens"] for r in rows):
    for threads in (1, 2):
        pick = lambda tree: [r["m_ray_surfaces_per_s"] for r in rows
                             if r["lens"] == lens and r["threads"] == threads and r["tree"] == tree]
        a, b = pick(old), pick(new)
        # Each round ran the two binaries seconds apart: its ratio is the least disturbed by the drift.
        ratios = sorted(y / x for x, y in zip(a, b))
        print(json.dumps({"lens": lens, "threads": threads, "rounds": len(a),
                          "baseline_median": statistics.median(a), "baseline_range": [min(a), max(a)],
                          "head_median": statistics.median(b), "head_range": [min(b), max(b)],
                          "round_ratio_median": round(statistics.median(ratios), 2),
                          "round_ratio_range": [round(ratios[0], 2), round(ratios[-1], 2)]}))
EOF
rm -f "$log"
