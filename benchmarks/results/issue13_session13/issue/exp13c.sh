#!/bin/bash
# exp13c.sh SECONDS: ipc wide/narrow loops and our kernel (CBbunny camera, diffuse) on CPU 0, vCPU 1 idle or
# running a pause loop; probe before and after each set.
S=/work/shared/scenes/cs184
end=$(( $(date +%s) + $1 ))
while [ $(date +%s) -lt $end ]; do
  p0=$(./probe 3)
  for mode in none pause; do
    [ $mode != none ] && { taskset -c 1 ./corun $mode & cp=$!; sleep 0.2; }
    w=$(taskset -c 0 ./ipc wide 0.2); n=$(taskset -c 0 ./ipc narrow 0.2)
    taskset -c 0 /tmp/s13/accel_bench.wideonly --scene $S/CBbunny.dae --kinds camera,diffuse --rays 200000 --repeats 3 --threads 1 --no-course --backends custom:sah,embree:high --csv x.csv >/dev/null 2>&1
    w2=$(taskset -c 0 ./ipc wide 0.2)
    [ $mode != none ] && { kill $cp; wait $cp 2>/dev/null; }
    vals=$(awk -F, 'NR>1{printf "%s:%s:%.2f ", $3, $4, $6}' x.csv)
    echo "$(date +%s) $mode ipc:wide:$w ipc:narrow:$n ipc:wide2:$w2 $vals"
  done
  echo "probe $p0 | $(./probe 3)"
done
