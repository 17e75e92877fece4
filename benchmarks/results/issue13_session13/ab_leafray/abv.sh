#!/bin/bash
# abv.sh TAG N VARIANTS...: alternate binaries $BIN/accel_bench.VARIANT (BIN: /tmp/s13 unless set), 1 thread
S=/work/shared/scenes/cs184; tag=$1; n=$2; shift 2
for i in $(seq 1 $n); do for v in "$@"; do
  ${BIN:-/tmp/s13}/accel_bench.$v --scene $S/cow.dae --scene $S/CBbunny.dae --scene $S/bunny.dae ${EXTRA} --rays 200000 --repeats 3 --threads 1 --no-course --backends ${BACKENDS:-custom:sah,custom:sah:avx2,embree:high} --csv ${tag}_${v}_$i.csv > /dev/null 2>${tag}_${v}_$i.err
done; done
