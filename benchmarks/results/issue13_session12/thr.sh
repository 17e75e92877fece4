#!/bin/bash
# thr.sh FIRST LAST : the thread study, runs FIRST..LAST, the five scenes, waiting for cores
# threads_raw/: the same with "--wait-for-cores 3" removed (WAIT=0 does it). threads_isa/ and threads_variants/: BACKENDS set
# to the backends their summary.txt names.
OUT=${OUT:-/tmp/s12/thr}; mkdir -p $OUT
S=/work/shared/scenes/cs184; B=/work/main/build/benchmarks/accel_bench
for r in $(seq $1 $2); do
  s=$(date +%s)
  $B --scene $S/cow.dae --scene $S/CBbunny.dae --scene $S/maxplanck.dae --scene $S/bunny.dae --scene /tmp/gen/sphere5m.glb --rays 200000 --repeats 5 --threads 1 2 --no-course --wait-for-cores ${WAIT:-3} ${EXTRA} --backends ${BACKENDS:-custom:sah,embree:high} --csv $OUT/threads_run$r.csv > $OUT/threads_run$r.txt 2>$OUT/threads_run$r.err
  echo "run $r: $(( $(date +%s) - s )) s" >> $OUT/times.txt
done
