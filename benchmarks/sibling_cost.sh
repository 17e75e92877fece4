#!/usr/bin/env bash
# What a busy neighbour costs each backend: one-thread traces of CBbunny's camera and
# diffuse rays on one CPU, alone and beside each load of sibling_load on another, in
# interleaved rounds. Our kernel issues ~3.5-4 instructions per cycle, about twice
# Embree's, so a neighbour sharing the core's issue slots costs it more
# (accel/DECISIONS.md, "sibling thread's cost").
#
#   benchmarks/sibling_cost.sh [ROUNDS] [MODES]      (default 3 rounds; "pause fp chase stream")
#
# The trace runs on the first CPU this process may use; the load on that CPU's SMT sibling
# if the machine shows one (/sys/.../thread_siblings_list), else on the next CPU (on a VM
# whose vCPUs the host may place on one core's two hardware threads, that is the case
# worth measuring). Prints, per mode, each backend's Mrays/s relative to its own "alone"
# rounds. Environment: BUILD (default build), PT_SHARED_SCENES.
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
BUILD=${BUILD:-$HERE/../build}
SCENE=${PT_SHARED_SCENES:-$HERE/../../shared/scenes}/cs184/CBbunny.dae
ROUNDS=${1:-3}
MODES=${2:-pause fp chase stream}
BENCH=$BUILD/benchmarks/accel_bench LOAD=$BUILD/benchmarks/sibling_load
[ -x "$BENCH" ] && [ -x "$LOAD" ] || { echo "sibling_cost: build accel_bench and sibling_load first ($BUILD)" >&2; exit 2; }
[ -f "$SCENE" ] || { echo "sibling_cost: $SCENE not found (set PT_SHARED_SCENES)" >&2; exit 2; }

cpus=($(taskset -pc $$ | sed 's/.*: //' | tr ',' '\n' | while IFS=- read a b; do seq "$a" "${b:-$a}"; done))
[ ${#cpus[@]} -ge 2 ] || { echo "sibling_cost: needs two CPUs, this process may use ${cpus[*]}" >&2; exit 2; }
trace=${cpus[0]}
load=$(tr ',' '\n' < /sys/devices/system/cpu/cpu$trace/topology/thread_siblings_list | grep -vx "$trace" | head -1 || true)
how="its SMT sibling"
[ -n "$load" ] || { load=${cpus[1]}; how="the next CPU (no SMT sibling shown)"; }
echo "sibling_cost: traces on CPU $trace, load on CPU $load, $how; $ROUNDS rounds of: alone $MODES"

tmp=$(mktemp -d)
trap 'rm -rf "$tmp"; kill $(jobs -p) 2>/dev/null || true' EXIT
for r in $(seq "$ROUNDS"); do
  for mode in alone $MODES; do
    pid=""
    if [ "$mode" != alone ]; then taskset -c "$load" "$LOAD" "$mode" & pid=$!; sleep 0.2; fi
    taskset -c "$trace" "$BENCH" --scene "$SCENE" --kinds camera,diffuse --rays 200000 --repeats 3 \
      --threads 1 --no-course --backends custom:sah,embree:high --csv "$tmp/$mode.$r.csv" >/dev/null 2>&1
    [ -z "$pid" ] || { kill "$pid"; wait "$pid" 2>/dev/null || true; }
  done
done

python3 - "$tmp" "$ROUNDS" alone $MODES <<'PY'
import csv, statistics, sys
tmp, rounds, modes = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
def mrays(mode):
    out = {}
    for r in range(1, rounds + 1):
        for row in csv.DictReader(open(f"{tmp}/{mode}.{r}.csv")):
            out.setdefault((row["backend"], row["ray_kind"]), []).append(float(row["mrays_per_s"]))
    return {k: statistics.median(v) for k, v in out.items()}
alone = mrays("alone")
keys = sorted(alone)
print(f"{'load':8} " + " ".join(f"{b + ' ' + k:>28}" for b, k in keys))
print(f"{'alone':8} " + " ".join(f"{alone[x]:>22.2f} Mray/s" for x in keys))
for m in modes[1:]:
    v = mrays(m)
    print(f"{m:8} " + " ".join(f"{v[x] / alone[x]:>28.2f}" for x in keys))
PY
