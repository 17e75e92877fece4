#!/bin/bash
# final_thr.sh N : the thread study, N runs, the issue's five scenes
OUT=/work/main/benchmarks/results/issue13_session11${SUB:+/$SUB}; mkdir -p $OUT
S=/work/shared/scenes/cs184; B=/work/main/build/benchmarks/accel_bench
for r in $(seq $1); do
  $B --scene $S/cow.dae --scene $S/CBbunny.dae --scene $S/maxplanck.dae --scene $S/bunny.dae --scene /tmp/gen/sphere5m.glb --rays 200000 --repeats 5 --threads 1 2 --no-course ${EXTRA} --backends custom:sah,embree:high --csv $OUT/threads_run$r.csv > $OUT/threads_run$r.txt 2>/dev/null
done
