#!/bin/bash
# exp13.sh SECONDS: base and wideonly kernels (and Embree) traced on CPU 0, vCPU 1 idle or running a pause loop,
# with the probe before and after each set. One-core episodes (probe < 1.4) put the pause loop on our sibling thread.
S=/work/shared/scenes/cs184
end=$(( $(date +%s) + $1 ))
while [ $(date +%s) -lt $end ]; do
  p0=$(./probe 3)
  for v in ${VARIANTS:-base wideonly}; do for mode in ${MODES:-none pause}; do
    [ $mode != none ] && { taskset -c 1 ./corun $mode & cp=$!; sleep 0.2; }
    taskset -c 0 /tmp/s13/accel_bench.$v --scene $S/CBbunny.dae --kinds camera,diffuse --rays 200000 --repeats 3 --threads 1 --no-course --backends custom:sah,embree:high --csv x.csv >/dev/null 2>&1
    [ $mode != none ] && { kill $cp; wait $cp 2>/dev/null; }
    vals=$(awk -F, 'NR>1{printf "%s:%s:%.2f ", $3, $4, $6}' x.csv)
    echo "$(date +%s) $v/$mode $vals"
  done; done
  echo "probe $p0 | $(./probe 3)"
done
