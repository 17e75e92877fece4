#!/bin/bash
# One command that regenerates the core of benchmarks/results/: the one-thread accelerator
# runs (results/accel/), the speed-accuracy study (CSV + text tables) and their plots, and
# the numerical-stability sweep (results/extremes/, ~4 minutes). Each section of
# RESULTS.md gives its own command; this script runs those of the sections named here.
#
#   benchmarks/run_study.sh [all|accel|tradeoff|extremes|plots]    (default: all)
#
# Environment: BUILD (build dir, default build-bench), PT_SHARED_SCENES (default
# ../shared/scenes), MPIRUN (a launcher
# prefix for the tradeoff sweep, e.g. "mpirun -np 8 --hostfile hosts": its points are
# spread over the ranks and the reference is rendered by all of them; rows are identical
# to a single-process run).
# Takes ~15 minutes on 2 cores when the machine is otherwise idle: accel_bench ~10 min,
# tradeoff ~5 min with 3 repeats (+2.5 min the first time for the two 4096-spp
# references, which are then cached in results/reference/).
set -euo pipefail
HERE=$(cd "$(dirname "$0")" && pwd)
ROOT=$(cd "$HERE/.." && pwd)
BUILD=${BUILD:-$ROOT/build-bench}
SHARED=${PT_SHARED_SCENES:-$ROOT/../shared/scenes}/cs184
OUT=$HERE/results
STAGE=${1:-all}
mkdir -p "$OUT"

cmake -S "$ROOT" -B "$BUILD" -G Ninja >/dev/null
cmake --build "$BUILD" --target scenegen accel_bench tradeoff extremes -j"$(nproc)"

if [[ $STAGE == all || $STAGE == accel ]]; then
  # RESULTS.md, "Accelerators": three one-thread runs on the five scenes. The generated
  # mesh lives in the build dir (90 MB), not in the repository.
  GEN=$BUILD/generated; mkdir -p "$GEN" "$OUT/accel"
  [[ -f $GEN/sphere5m.glb ]] || "$BUILD/tools/scenegen" --kind sphere -n 5000000 --seed 1 -o "$GEN/sphere5m.glb"
  for run in 1 2 3; do
    "$BUILD/benchmarks/accel_bench" --scene "$SHARED/cow.dae" --scene "$SHARED/CBbunny.dae" \
      --scene "$SHARED/maxplanck.dae" --scene "$SHARED/bunny.dae" --scene "$GEN/sphere5m.glb" \
      --rays 200000 --repeats 3 --threads 1 --no-course \
      --backends custom:sah,custom:sah:watertight,custom:sah:sse2,custom:sah:avx2,custom:sah:float,embree:high \
      --csv "$OUT/accel/one_thread_run$run.csv" | tee "$OUT/accel/one_thread_run$run.txt"
  done
  python3 "$HERE/plot/tables.py" runs "$OUT"/accel/one_thread_run{1,2,3}.csv > "$OUT/accel/one_thread_table.md"
fi

if [[ $STAGE == all || $STAGE == tradeoff ]]; then
  # Three renders per setting, median time: the machine is shared and drifts.
  ${MPIRUN:-} "$BUILD/benchmarks/tradeoff" --repeats 3 --csv "$OUT/tradeoff.csv" --ref-dir "$OUT/reference" \
    --scene "$SHARED/CBspheres_lambertian.dae" --scene "$SHARED/CBbunny.dae" | tee "$OUT/tradeoff.txt"
fi

if [[ $STAGE == all || $STAGE == extremes ]]; then
  # 10M edge/vertex rays and 5M acne points per placement and backend. Exits 1 on
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
  if compgen -G "$OUT/accel/one_thread_run*.csv" >/dev/null; then
    python3 -c "import matplotlib" 2>/dev/null || apt-get install -y python3-matplotlib >/dev/null
    python3 "$HERE/plot/accel_ratio.py" "$OUT"/accel/one_thread_run*.csv "$OUT"/accel/threads_wait/run*.csv \
      -o "$OUT/accel_ratio.png"
  fi
  [[ -f $OUT/tradeoff.csv ]] && python3 "$HERE/plot/tables.py" tradeoff "$OUT/tradeoff.csv" > "$OUT/tradeoff_table.md"
  echo "plots in $OUT"
fi
