#!/bin/bash
# Runs unicac design and optiland's DE and DA side by side (same machine load), 420 s each.
# usage: run_spec.sh KEY   (a, b, c, d as in common.SPECS)
set -u
KEY=$1; BUDGET=${BUDGET:-420}
D=${OUT:-$PWD/design-vs-optiland}
U=${UNICAC_BIN:-unicac}
PY=${OPTILAND_PYTHON:-python}
FLAGS=$(cd $D && $PY -c "from common import SPECS, flags; print(flags(SPECS['$KEY']))")
export OMP_NUM_THREADS=1 RAYON_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 NUMBA_NUM_THREADS=1
mkdir -p $D/logs $D/optiland
echo "$(date -u +%FT%TZ) spec $KEY: unicac design $FLAGS --time-budget-s $BUDGET --count 4 --seed 1" | tee -a $D/logs/commands.log
( /usr/bin/time -f "%e s wall %U s user" nice -n 5 $U design $FLAGS --time-budget-s $BUDGET --count 4 --seed 1 \
    --out $D/unicac-$KEY --json > $D/logs/unicac-$KEY.json 2> $D/logs/unicac-$KEY.stderr ) &
P1=$!
( cd $D && /usr/bin/time -f "%e s wall %U s user" nice -n 5 $PY run_optiland.py $KEY de $BUDGET $D/optiland 1 \
    > $D/logs/optiland-de-$KEY.log 2>&1 ) &
P2=$!
( cd $D && /usr/bin/time -f "%e s wall %U s user" nice -n 5 $PY run_optiland.py $KEY da $BUDGET $D/optiland 1 \
    > $D/logs/optiland-da-$KEY.log 2>&1 ) &
P3=$!
wait $P1 $P2 $P3
echo "$(date -u +%FT%TZ) spec $KEY done" | tee -a $D/logs/commands.log
