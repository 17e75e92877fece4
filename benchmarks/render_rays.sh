#!/usr/bin/env bash
# Our BVH against Embree on the rays a render traces (benchmarks/RESULTS.md, "What bounds
# the end-to-end ratio"): each Cornell box is rendered once at the efficiency harness's
# 480x360 (1 spp, 5 bounces, --lights mesh, 1 thread) with every ray recorded
# (pathtracer --record-rays), and accel_bench traces the recorded closest-hit and any-hit
# rays through both backends, at 1 thread and at all.
# Usage: benchmarks/render_rays.sh [--quick] [BUILD_DIR] [OUT_DIR] [REPEATS]
# --quick: the repository's Cornell box at 32x24, one repeat, 1 thread (the suite's smoke run).
set -eu
QUICK=0
[ "${1:-}" = --quick ] && { QUICK=1; shift; }
BUILD=${1:-build}; OUT=${2:-$(mktemp -d)}; REPEATS=${3:-5}
SRC=$(cd "$(dirname "$0")/.." && pwd)
SHARED="$SRC/../shared/scenes/cs184"
RES="480 360"; THREADS="1 $(nproc)"; SCENES=()
if [ $QUICK = 1 ]; then
  RES="32 24"; THREADS=1; REPEATS=1; SCENES=("$SRC/scenes/cornell.dae")
else
  for s in CBspheres_lambertian CBbunny CBgems; do
    if [ -f "$SHARED/$s.dae" ]; then SCENES+=("$SHARED/$s.dae")
    else echo "render_rays: $SHARED/$s.dae absent (../shared/scenes), skipped" >&2; fi
  done
  SCENES+=("$SRC/scenes/cornell_materials.dae")
fi
mkdir -p "$OUT"

echo "| scene | rays | tests / nodes per ray | threads | ours Mrays/s | Embree Mrays/s | ours / Embree |"
echo "|---|---|---|---:|---:|---:|---:|"
for scene in "${SCENES[@]}"; do
  name=$(basename "$scene" .dae)
  # shellcheck disable=SC2086  # RES is two words
  "$BUILD/tools/pathtracer" -q -t 1 -s 1 -m 5 -r $RES --lights mesh --record-rays "$OUT/$name.rays" \
    --record-rays-max 2000000 -f "$OUT/$name.png" "$scene" >"$OUT/$name.render" 2>&1
  # shellcheck disable=SC2086  # THREADS is a list
  "$BUILD/benchmarks/accel_bench" --scene "$scene" --ray-record "$OUT/$name.rays" \
    --backends custom:sah,embree:high --kinds render-closest,render-shadow --rays 2000000 \
    --repeats "$REPEATS" --threads $THREADS --no-course --csv "$OUT/$name.csv" >"$OUT/$name.out" 2>"$OUT/$name.err"
  # CSV columns: scene,triangles,backend,ray_kind,threads,mrays_per_s,ratio_to_embree,tests_per_ray,nodes_per_ray,...
  awk -F, -v n="$name" 'NR > 1 { k = $4 "," $5; if ($3 ~ /^custom/) { c[k] = $6; r[k] = $7; t[k] = $8 " / " $9 }
                                  else if ($3 == "embree:high") e[k] = $6
                                  if (!(k in seen)) { seen[k] = 1; order[++m] = k } }
    END { for (i = 1; i <= m; i++) { split(order[i], p, ",");
            printf "| %s | %s | %s | %s | %.3f | %.3f | %.2f |\n", n, p[1], t[order[i]], p[2], c[order[i]],
                   e[order[i]], r[order[i]] } }' "$OUT/$name.csv"
done
