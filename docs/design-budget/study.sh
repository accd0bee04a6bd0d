#!/usr/bin/env bash
# Issue 32's convergence study (docs/design.md, "Convergence at a fixed evaluation budget"): the four
# specifications x five seeds, each designed into its own library with `--evaluations-per-spec`, so
# every figure is reproducible on any machine and under any load. Rerun the same command to resume
# (each library resumes, finished ones are skipped). Runs go LANES at a time, one thread each.
#
#   bash docs/design-budget/study.sh OUT EVALUATIONS [LANES] [SEEDS]
#   python3 docs/design-budget/study_table.py OUT EVALUATIONS   # table + picture from what is done
set -euo pipefail
out=${1:?usage: study.sh OUT EVALUATIONS [LANES] [SEEDS]}
evaluations=${2:?usage: study.sh OUT EVALUATIONS [LANES] [SEEDS]}
lanes=${3:-2}
seeds=${4:-1,2,3,4,5}
unicac=${UNICAC_BIN:-target/release/unicac}
[ -x "$unicac" ] || { echo "study.sh: no unicac binary at $unicac (cargo build --release -p unicac-cli, or set UNICAC_BIN)" >&2; exit 2; }
case $evaluations in ''|*[!0-9]*|0*) echo "study.sh: EVALUATIONS must be a whole number >= 1 without leading zeros, not '$evaluations'" >&2; exit 2 ;; esac
case $lanes in ''|*[!0-9]*|0) echo "study.sh: LANES must be a whole number >= 1, not '$lanes'" >&2; exit 2 ;; esac
mkdir -p "$out"
# elements half-field F/# stop: the Cooke spec, then the issue's three harder ones.
specs=("3 20 5 middle" "4 30 3 middle" "5 30 2 front" "6 40 2 middle")
jobs=()
for seed in ${seeds//,/ }; do
  for spec in "${specs[@]}"; do jobs+=("$spec $seed"); done
done
run_one() {   # run_one ELEMENTS HALF_FOV F_NUMBER STOP SEED
  local name="e$1_h$2_f$3_$4-seed$5"
  [ -f "$out/$name.json" ] && return 0   # done (the summary is written last, atomically)
  RAYON_NUM_THREADS=1 "$unicac" design --elements "$1" --half-fov-deg "$2" --f-number "$3" --stop "$4" \
    --count 4 --seed "$5" --evaluations-per-spec "$evaluations" --out "$out/$name" --json \
    > "$out/$name.json.part" 2> "$out/$name.log"
  mv "$out/$name.json.part" "$out/$name.json"
  echo "$(date -u +%H:%M:%S) done $name: $(grep -o 'best mean RMS spot [0-9.]* um' "$out/$name.log" | tail -1)"
}
export -f run_one
export out evaluations unicac
printf '%s\n' "${jobs[@]}" | xargs -P "$lanes" -L 1 bash -c 'run_one "$@"' _
