#!/bin/bash
# exp13b.sh SECONDS: as exp13.sh, variants one (one ray per call) and two (PT_TWO_RAYS: two rays interleaved
# per call), both from the exp/two-rays build; Embree runs two rays per call as two calls.
S=/work/shared/scenes/cs184
end=$(( $(date +%s) + $1 ))
while [ $(date +%s) -lt $end ]; do
  p0=$(./probe 3)
  for v in one two; do for mode in ${MODES:-none pause}; do
    [ $mode != none ] && { taskset -c 1 ./corun $mode & cp=$!; sleep 0.2; }
    if [ $v = two ]; then export PT_TWO_RAYS=1; else unset PT_TWO_RAYS; fi
    taskset -c 0 /tmp/s13/accel_bench.two --scene $S/CBbunny.dae --kinds camera,diffuse --rays 200000 --repeats 3 --threads 1 --no-course --backends custom:sah,embree:high --csv x.csv >/dev/null 2>&1
    [ $mode != none ] && { kill $cp; wait $cp 2>/dev/null; }
    vals=$(awk -F, 'NR>1{printf "%s:%s:%.2f ", $3, $4, $6}' x.csv)
    echo "$(date +%s) $v/$mode $vals"
  done; done
  echo "probe $p0 | $(./probe 3)"
done
