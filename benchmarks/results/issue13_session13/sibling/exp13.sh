#!/bin/bash
# exp13.sh SECONDS: each variant's kernel (and Embree) traced on CPU 0, vCPU 1 idle or running a pause loop
# (session 12's corun.c), with the probe before and after each set. Variant V runs /tmp/s13/accel_bench.V;
# V+two runs the same binary with PT_TWO_RAYS=1 (branch exp/two-rays: two rays per call).
# exp13.log: VARIANTS="base wideonly" exp13.sh 2400 (stopped after ~6 min).
# ../two_rays/exp13b.log: the first form of this script with the exp/two-rays build, labels one and two
# (what VARIANTS="two two+two" runs now).
S=/work/shared/scenes/cs184
end=$(( $(date +%s) + $1 ))
while [ $(date +%s) -lt $end ]; do
  p0=$(./probe 3)
  for v in ${VARIANTS:-base wideonly}; do for mode in ${MODES:-none pause}; do
    [ $mode != none ] && { taskset -c 1 ./corun $mode & cp=$!; sleep 0.2; }
    if [ "${v%+two}" != "$v" ]; then export PT_TWO_RAYS=1; else unset PT_TWO_RAYS; fi
    taskset -c 0 /tmp/s13/accel_bench.${v%+two} --scene $S/CBbunny.dae --kinds camera,diffuse --rays 200000 --repeats 3 --threads 1 --no-course --backends custom:sah,embree:high --csv x.csv >/dev/null 2>&1
    [ $mode != none ] && { kill $cp; wait $cp 2>/dev/null; }
    vals=$(awk -F, 'NR>1{printf "%s:%s:%.2f ", $3, $4, $6}' x.csv)
    echo "$(date +%s) $v/$mode $vals"
  done; done
  echo "probe $p0 | $(./probe 3)"
done
