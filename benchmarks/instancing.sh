#!/usr/bin/env bash
# Instances at production scale: memory and speed of our two-level BVH against Embree's
# instances, and against flattening where both fit (benchmarks/RESULTS.md, "Instances").
#  1. memory: a forest of 10^7 placements of 256 tree prototypes, 10^10 instanced
#     triangles (scenegen --kind forest), rendered by pathtracer with each backend
#     (64x48, 1 spp, all threads): peak RSS (/usr/bin/time), and the accelerator's own
#     bytes per instance from its summary line;
#  2. speed: accel_bench on the same camera, shadow and diffuse rays through both
#     backends, at 1 thread and all, on that forest and on a small one (5*10^4
#     placements, 2*10^6 instanced triangles), with build times;
#  3. instances against flattening: the small forest again with --instancing=flatten.
# Usage: benchmarks/instancing.sh [--quick] [BUILD_DIR] [OUT_DIR] [RAYS] [REPEATS]
# --quick: 10^5 instanced triangles, 2000 rays, one repeat (the test suite's smoke run).
set -eu
QUICK=0
[ "${1:-}" = --quick ] && { QUICK=1; shift; }
BUILD=${1:-build}; OUT=${2:-$(mktemp -d)}; RAYS=${3:-200000}; REPEATS=${4:-3}
BIG=10000000000; SMALL=2000000
[ $QUICK = 1 ] && { BIG=100000; SMALL=20000; RAYS=2000; REPEATS=1; }
[ -x /usr/bin/time ] || { echo "instancing: needs /usr/bin/time (apt-get install time)" >&2; exit 2; }
mkdir -p "$OUT"
"$BUILD/tools/scenegen" --kind forest -n $BIG -o "$OUT/forest_big.glb"
"$BUILD/tools/scenegen" --kind forest -n $SMALL -o "$OUT/forest_small.glb"

echo "## memory: render of forest_big, 64x48, 1 spp"
printf "| backend | peak RSS MiB | accelerator MiB | accelerator bytes per instance | render s |\n|---|---:|---:|---:|---:|\n"
for b in custom embree; do
  /usr/bin/time -f "%M" -o "$OUT/rss_$b" "$BUILD/tools/pathtracer" --accel $b -r 64 48 -s 1 \
    -f "$OUT/forest_big_$b.png" "$OUT/forest_big.glb" >"$OUT/render_$b.out" 2>&1
  # "[PathTracer] Accelerator ...: ..., N instances placing ..., X MiB".
  acc=$(grep '\[PathTracer\] Accelerator' "$OUT/render_$b.out")
  mib=$(echo "$acc" | grep -o '[0-9.]* MiB$' | awk '{print $1}')
  inst=$(echo "$acc" | grep -o '[0-9]* instances placing' | awk '{print $1}')
  secs=$(grep -o 'Render time [0-9.]*' "$OUT/render_$b.out" | awk '{print $3}')
  awk -v b=$b -v rss="$(cat "$OUT/rss_$b")" -v mib="$mib" -v inst="$inst" -v s="$secs" \
    'BEGIN { printf "| %s | %.0f | %.1f | %.1f | %s |\n", b, rss / 1024, mib, (inst > 0 ? mib * 1048576 / inst : 0), s }'
done

bench() {  # scene csv [extra accel_bench options]
  local scene=$1 csv=$2; shift 2
  /usr/bin/time -f "%M" -o "$csv.rss" "$BUILD/benchmarks/accel_bench" --scene "$scene" \
    --backends custom:sah,embree:high --rays "$RAYS" --repeats "$REPEATS" --threads 1 "$(nproc)" \
    --no-course --csv "$csv" "$@" >"$csv.out" 2>"$csv.err"
}
bench "$OUT/forest_big.glb" "$OUT/big.csv"
bench "$OUT/forest_small.glb" "$OUT/small.csv"
bench "$OUT/forest_small.glb" "$OUT/small_flat.csv" --instancing flatten

echo
echo "## speed: Mrays/s, ours / Embree's (same rays, same run), build ms"
printf "| scene | rays | threads | custom Mrays/s | embree Mrays/s | custom / embree | build ms custom / embree |\n"
printf "|---|---|---:|---:|---:|---:|---:|\n"
for f in big small small_flat; do
  awk -F, -v f=$f 'NR > 1 { k = $4 "," $5; if ($3 ~ /^custom/) { c[k] = $6; cb = $10 } else if ($3 == "embree:high") { e[k] = $6; eb = $10 }
                            if (!(k in seen)) { seen[k] = 1; order[++n] = k } }
    END { for (i = 1; i <= n; i++) { split(order[i], p, ",");
            printf "| %s | %s | %s | %.3f | %.3f | %.2f | %.0f / %.0f |\n", f, p[1], p[2], c[order[i]], e[order[i]],
                   (e[order[i]] > 0 ? c[order[i]] / e[order[i]] : 0), cb, eb } }' "$OUT/$f.csv"
done

echo
echo "## instances against flattening (forest_small): accelerator MiB and peak RSS of the run (both backends held)"
printf "| mode | custom MiB | embree MiB | peak RSS MiB |\n|---|---:|---:|---:|\n"
for f in small small_flat; do
  awk -F, -v f=$f -v rss="$(cat "$OUT/$f.csv.rss")" 'NR > 1 { if ($3 ~ /^custom/) c = $11; else if ($3 == "embree:high") e = $11 }
    END { printf "| %s | %.1f | %.1f | %.0f |\n", (f == "small" ? "instances" : "flattened"), c / 1048576, e / 1048576, rss / 1024 }' "$OUT/$f.csv"
done
echo "outputs in $OUT"
