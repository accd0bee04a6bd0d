#!/usr/bin/env bash
# Coverage-guided fuzzing of unicac's parsers with cargo-fuzz (libFuzzer) on nightly Rust.
#   bash scripts/fuzz.sh                 # every target, 60 s each
#   bash scripts/fuzz.sh TARGET SECONDS  # one target (zmx, lens_json, image, psf_cache, lens_model)
#   bash scripts/fuzz.sh all SECONDS     # every target, SECONDS each
# The committed seeds are in fuzz/seeds/TARGET; the working corpus grows in fuzz/corpus/TARGET (not
# committed). Crashes land in fuzz/artifacts/TARGET; each one found becomes a regression test (a normal
# `cargo test` test on stable). Prints, per target, the executions, the coverage and the speed.
# Do not pause a run (SIGSTOP): libFuzzer's -timeout is wall-clock time, so a paused input is reported
# as a timeout (seen 2026-12-02: the reported input ran in 56 ms).
# Needs: rustup's nightly toolchain and `cargo install cargo-fuzz`.
# Built with -O (release, no debug assertions), without AddressSanitizer by default (`--sanitizer
# none`): the unicac crates have no `unsafe` block; the lens targets and the PSF-cache reader reach
# `unsafe` code only inside serde_json, sha2, pulp and rayon, and the image decoders the `image` target
# reaches forbid it (png, exr, fdeflate, miniz_oxide, weezl: `#![forbid(unsafe_code)]`) or confine it to
# byte casts of plain sample types (tiff, image, half, lebe, checked 2026-12-02). Without ASan the
# targets run hundreds of times faster (the image target: ~10,000 executions/s against tens); panics,
# timeouts and the RSS limit are caught either way. FUZZ_SANITIZER=address restores ASan for any target.
set -euo pipefail
cd "$(dirname "$0")/.."

TARGETS=(zmx lens_json image psf_cache lens_model)
target="${1:-all}"
seconds="${2:-60}"
if ! cargo +nightly fuzz --version >/dev/null 2>&1; then
    echo "needs nightly Rust and cargo-fuzz: rustup toolchain install nightly && cargo install cargo-fuzz" >&2
    exit 2
fi
if [[ "$target" == all ]]; then
    selected=("${TARGETS[@]}")
else
    selected=("$target")
fi

run_one() {
    local name="$1"
    local corpus="fuzz/corpus/$name"
    mkdir -p "$corpus" "fuzz/artifacts/$name" fuzz/logs
    # Not inside the artifacts folder: cargo-fuzz prints every file there as a failing input.
    local log="fuzz/logs/$name.log"
    # -max_len: big enough for the seed lens files and small images; -rss_limit_mb: an allocation a
    # hostile header asks for beyond 2 GB is a finding, not a crash of the machine.
    set +e
    local sanitizer=${FUZZ_SANITIZER:-none}
    # One target folder per sanitizer: switching flags in one would rebuild every dependency.
    # lens_model builds its inputs from raw bytes (`arbitrary`) and has no seed folder.
    local seeds=()
    [[ -d "fuzz/seeds/$name" ]] && seeds=("fuzz/seeds/$name")
    cargo +nightly fuzz run -O --sanitizer "$sanitizer" --target-dir "fuzz/target-$sanitizer" --fuzz-dir fuzz "$name" "$corpus" "${seeds[@]}" -- \
        -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 -timeout=10 \
        -print_final_stats=1 >"$log" 2>&1
    local rc=$?
    set -e
    local executions coverage speed
    executions=$(grep -E '^stat::number_of_executed_units' "$log" | awk '{print $2}' | tail -1)
    coverage=$(grep -oE 'cov: [0-9]+' "$log" | tail -1 | awk '{print $2}')
    speed=$(grep -E '^stat::average_exec_per_sec' "$log" | awk '{print $2}' | tail -1)
    echo "$name ($sanitizer sanitizer): rc $rc, ${executions:-?} executions in ${seconds} s (${speed:-?}/s), coverage ${coverage:-?} edges, corpus $(ls "$corpus" | wc -l) inputs"
    if [[ $rc -ne 0 ]]; then
        echo "  crash or error: see $log and fuzz/artifacts/$name" >&2
        return 1
    fi
}

status=0
for name in "${selected[@]}"; do
    run_one "$name" || status=1
done
exit $status
