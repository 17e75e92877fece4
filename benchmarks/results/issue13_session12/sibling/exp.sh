#!/bin/bash
# exp.sh SECONDS: ours and Embree traced on CPU 0 beside each co-runner on CPU 1, with the probe before and after
# exp.log: exp.sh 1800. exp2.log: MODES="none pause chase" exp.sh 900.
B=/work/main/build/benchmarks/accel_bench; S=/work/shared/scenes/cs184
end=$(( $(date +%s) + $1 ))
while [ $(date +%s) -lt $end ]; do
  p0=$(./probe 3)
  for mode in ${MODES:-none fp chase l2 stream}; do
    [ $mode != none ] && { taskset -c 1 ./corun $mode & cp=$!; sleep 0.2; }
    taskset -c 0 $B --scene $S/CBbunny.dae --kinds camera,diffuse --rays 200000 --repeats 3 --threads 1 --no-course --backends custom:sah,embree:high --csv /tmp/s12/corun/x.csv >/dev/null 2>&1
    [ $mode != none ] && { kill $cp; wait $cp 2>/dev/null; }
    vals=$(awk -F, 'NR>1{printf "%s:%s:%.2f ", $3, $4, $6}' /tmp/s12/corun/x.csv)
    echo "$(date +%s) $mode $vals"
  done
  echo "probe $p0 | $(./probe 3)"
done
