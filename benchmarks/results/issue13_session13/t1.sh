#!/bin/bash
# t1.sh FIRST LAST: the one-thread command
OUT=${OUT:-/tmp/s13/t1}; mkdir -p $OUT
S=/work/shared/scenes/cs184; B=/work/main/build/benchmarks/accel_bench
for r in $(seq $1 $2); do
  $B --scene $S/cow.dae --scene $S/CBbunny.dae --scene $S/maxplanck.dae --scene $S/bunny.dae --scene /tmp/gen/sphere5m.glb --rays 200000 --repeats 3 --threads 1 --no-course --backends custom:sah,custom:sah:watertight,custom:sah:sse2,custom:sah:avx2,custom:sah:float,embree:high --csv $OUT/table_run$r.csv > $OUT/table_run$r.txt 2>$OUT/table_run$r.err
done
