#!/bin/bash
# One command that regenerates benchmarks/results/: the accelerator table and the
# speed-accuracy study (CSV + text tables) and their plots.
#
#   benchmarks/run_study.sh [all|accel|tradeoff|plots]    (default: all)
#
# Environment: BUILD (build dir, default build-bench), PT_SHARED_SCENES (default
# ../shared/scenes), REPEATS (accel_bench timed repeats, default 5).
# Takes ~10-15 minutes on 2 cores when the machine is otherwise idle (tradeoff ~6-8 min
# including the two 4096-spp references, which are then cached; accel_bench ~4-6 min).
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
cmake --build "$BUILD" --target scenegen accel_bench tradeoff -j"$(nproc)"

if [[ $STAGE == all || $STAGE == accel ]]; then
  # Generated meshes live in the build dir (90 MB each), not in the repository.
  GEN=$BUILD/generated; mkdir -p "$GEN"
  [[ -f $GEN/sphere-5m.glb ]] || "$BUILD/tools/scenegen" --kind sphere -n 5000000 --seed 1 -o "$GEN/sphere-5m.glb"
  [[ -f $GEN/field-1m.glb ]] || "$BUILD/tools/scenegen" --kind field -n 1000000 --seed 1 -o "$GEN/field-1m.glb"
  [[ -f $GEN/sliver-1m.glb ]] || "$BUILD/tools/scenegen" --kind sliver -n 1000000 --seed 1 -o "$GEN/sliver-1m.glb"
  "$BUILD/benchmarks/accel_bench" --repeats "$REPEATS" --build-repeats 3 --csv "$OUT/accel.csv" \
    --scene "$ROOT/scenes/cornell.dae" --scene "$SHARED/cow.dae" --scene "$SHARED/CBbunny.dae" \
    --scene "$SHARED/maxplanck.dae" --scene "$GEN/sphere-5m.glb" --scene "$GEN/field-1m.glb" \
    --scene "$GEN/sliver-1m.glb" | tee "$OUT/accel.txt"
fi

if [[ $STAGE == all || $STAGE == tradeoff ]]; then
  "$BUILD/benchmarks/tradeoff" --csv "$OUT/tradeoff.csv" --ref-dir "$OUT/reference" \
    --scene "$SHARED/CBspheres_lambertian.dae" --scene "$SHARED/CBbunny.dae" | tee "$OUT/tradeoff.txt"
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
  [[ -f $OUT/accel.csv ]] && gnuplot -c "$HERE/plot/accel.gp" "$OUT/accel.csv" "$OUT/accel_ratio.png"
  echo "plots in $OUT"
fi
