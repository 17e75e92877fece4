#!/bin/bash
# One command that regenerates benchmarks/results/: the accelerator table, the
# speed-accuracy study (CSV + text tables) and their plots, and the numerical-stability
# sweep (results/extremes/, ~4 minutes).
#
#   benchmarks/run_study.sh [all|accel|tradeoff|extremes|plots]    (default: all)
#
# Environment: BUILD (build dir, default build-bench), PT_SHARED_SCENES (default
# ../shared/scenes), REPEATS (accel_bench timed repeats, default 5), MPIRUN (a launcher
# prefix for the tradeoff sweep, e.g. "mpirun -np 8 --hostfile hosts": its points are
# spread over the ranks and the reference is rendered by all of them; rows are identical
# to a single-process run).
# Takes ~10 minutes on 2 cores when the machine is otherwise idle: accel_bench ~5 min,
# tradeoff ~5 min with 3 repeats (+2.5 min the first time for the two 4096-spp
# references, which are then cached in results/reference/).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/.." && pwd)
BUILD=${BUILD:-$ROOT/build-bench}
SHARED=${PT_SHARED_SCENES:-$ROOT/../shared/scenes}/cs184
OUT=$HERE/results
STAGE=${1:-all}
REPEATS=${REPEATS:-5}
mkdir -p "$OUT"

cmake -S "$ROOT" -B "$BUILD" -G Ninja >/dev/null
cmake --build "$BUILD" --target scenegen accel_bench tradeoff extremes -j"$(nproc)"

if [[ $STAGE == all || $STAGE == accel ]]; then
  # Generated meshes live in the build dir (90 MB each), not in the repository.
  GEN=$BUILD/generated; mkdir -p "$GEN"
  [[ -f $GEN/sphere-5m.glb ]] || "$BUILD/tools/scenegen" --kind sphere -n 5000000 --seed 1 -o "$GEN/sphere-5m.glb"
  [[ -f $GEN/field-1m.glb ]] || "$BUILD/tools/scenegen" --kind field -n 1000000 --seed 1 -o "$GEN/field-1m.glb"
  [[ -f $GEN/terrain-1m.glb ]] || "$BUILD/tools/scenegen" --kind terrain -n 1000000 --seed 1 -o "$GEN/terrain-1m.glb"
  [[ -f $GEN/sliver-200k.glb ]] || "$BUILD/tools/scenegen" --kind sliver -n 200000 --seed 1 -o "$GEN/sliver-200k.glb"
  "$BUILD/benchmarks/accel_bench" --repeats "$REPEATS" --build-repeats 3 --csv "$OUT/accel.csv" \
    --scene "$ROOT/scenes/cornell.dae" --scene "$SHARED/cow.dae" --scene "$SHARED/CBbunny.dae" \
    --scene "$SHARED/maxplanck.dae" --scene "$GEN/sphere-5m.glb" | tee "$OUT/accel.txt"
  # The issue's two targets on the 5M mesh (2 threads >= 1.8x one thread on diffuse rays;
  # SAH build <= 3x Embree high) are within the machine's run-to-run noise, so they get
  # five independent runs of their own; RESULTS.md reports the medians.
  : > "$OUT/accel_5m_runs.txt"
  for run in 1 2 3 4 5; do
    "$BUILD/benchmarks/accel_bench" --scene "$GEN/sphere-5m.glb" --kinds diffuse --no-course \
      --backends custom:sah,embree:high --repeats 7 --csv "$OUT/accel_5m_run$run.csv" 2>/dev/null \
      | grep -A2 "^thread scaling" | tail -2 | sed "s/^/run $run:/" | tee -a "$OUT/accel_5m_runs.txt"
  done
  # The pathological meshes, without embree:high:count (counting through our
  # intersector is minutes on 1000:1 slivers and adds nothing to the comparison).
  "$BUILD/benchmarks/accel_bench" --repeats 3 --no-course --csv "$OUT/accel_generated.csv" \
    --backends custom:midpoint,custom:sah,embree:high --rays 100000 \
    --scene "$GEN/field-1m.glb" --scene "$GEN/terrain-1m.glb" --scene "$GEN/sliver-200k.glb" | tee "$OUT/accel_generated.txt"
fi

if [[ $STAGE == all || $STAGE == tradeoff ]]; then
  # Three renders per setting, median time: the machine is shared and drifts.
  ${MPIRUN:-} "$BUILD/benchmarks/tradeoff" --repeats 3 --csv "$OUT/tradeoff.csv" --ref-dir "$OUT/reference" \
    --scene "$SHARED/CBspheres_lambertian.dae" --scene "$SHARED/CBbunny.dae" | tee "$OUT/tradeoff.txt"
fi

if [[ $STAGE == all || $STAGE == extremes ]]; then
  # Issue 8: 10M edge/vertex rays and 5M acne points per placement and backend. Exits 1 on
  # a watertight leak, an error-bound false self-hit or a thin-wall leak.
  mkdir -p "$OUT/extremes"
  "$BUILD/benchmarks/extremes" --rays 10000000 --acne 5000000 --scenes "$SHARED" \
    --csv "$OUT/extremes/extremes_10M.csv" | tee "$OUT/extremes/extremes_10M.txt"
  python3 "$HERE/plot/extremes_table.py" "$OUT/extremes/extremes_10M.csv" > "$OUT/extremes/extremes_table.md"
fi

if [[ $STAGE == all || $STAGE == plots ]]; then
  # gnuplot is needed here only, never by the test suite.
  if ! command -v gnuplot >/dev/null; then
    echo "installing gnuplot-nox (plots only)"; apt-get install -y gnuplot-nox >/dev/null
  fi
  if [[ -f $OUT/tradeoff.csv ]]; then
    for sc in $(tail -n +2 "$OUT/tradeoff.csv" | cut -d, -f1 | sort -u); do
      gnuplot -c "$HERE/plot/tradeoff.gp" "$OUT/tradeoff.csv" "$sc" 16 "$OUT/tradeoff_${sc}_image.png" "relative RMSE (image)"
      gnuplot -c "$HERE/plot/tradeoff.gp" "$OUT/tradeoff.csv" "$sc" 17 "$OUT/tradeoff_${sc}_shadow.png" "relative RMSE (cast shadows)"
      gnuplot -c "$HERE/plot/adaptive.gp" "$OUT/tradeoff.csv" "$sc" "$OUT/adaptive_${sc}.png"
    done
  fi
  if [[ -f $OUT/accel.csv ]]; then
    gnuplot -c "$HERE/plot/accel.gp" "$OUT/accel.csv" "$OUT/accel_ratio.png"
    python3 "$HERE/plot/tables.py" accel "$OUT/accel.csv" > "$OUT/accel_table.md"
    [[ -f $OUT/accel_generated.csv ]] && python3 "$HERE/plot/tables.py" accel "$OUT/accel_generated.csv" >> "$OUT/accel_table.md"
  fi
  [[ -f $OUT/tradeoff.csv ]] && python3 "$HERE/plot/tables.py" tradeoff "$OUT/tradeoff.csv" > "$OUT/tradeoff_table.md"
  echo "plots in $OUT"
fi
