#!/usr/bin/env bash
# What textured renders cost against another build of pathtracer (a baseline binary):
# render time and peak resident memory of DamagedHelmet, BoomBox and the twelve-texture
# helmet (made by scene_memory --write-helmet12), 400x400, 16 spp, 2 threads, each
# round running the baseline, then this build's trilinear, stochastic and nearest filters.
# Prints per scene and filter the median and range of the per-round time ratio
# (this build / baseline, "Render time" lines) and the median peak RSS of each.
# Usage: benchmarks/texture_cost.sh [--quick] BASELINE_PATHTRACER [BUILD_DIR] [ROUNDS]
# --quick: one round at 64x64, 1 spp (the test suite's smoke run). Exits 77 without the
# shared scenes.
set -eu
size=(-r 400 400 -s 16)
[ "${1:-}" = --quick ] && { size=(-r 64 64 -s 1); shift; set -- "$1" "${2:-build}" 1; }
BASE=${1:?usage: texture_cost.sh [--quick] BASELINE_PATHTRACER [BUILD_DIR] [ROUNDS]}
BUILD=${2:-build}; ROUNDS=${3:-5}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
G=${PT_SHARED_SCENES:-$ROOT/../shared/scenes}/gltf
PT=$BUILD/tools/pathtracer
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
[ -e "$G/DamagedHelmet.glb" ] || { echo "texture_cost: $G not found; skipped"; exit 77; }
[ -x /usr/bin/time ] || { echo "texture_cost: needs /usr/bin/time (apt-get install time)" >&2; exit 2; }
"$BUILD/benchmarks/scene_memory" --write-helmet12 "$TMP/Helmet12.glb" >/dev/null
scenes=("$G/DamagedHelmet.glb" "$G/BoomBox/BoomBox.gltf" "$TMP/Helmet12.glb")
for r in $(seq "$ROUNDS"); do
  for s in "${scenes[@]}"; do
    for v in baseline trilinear stochastic nearest; do
      # This build with the baseline's integrator (the course's fixed roulette, independent
      # samples), so that the ratio is the textures' cost alone.
      if [ $v = baseline ]; then cmd=("$BASE"); else cmd=("$PT" --texture-filter $v --rr 0.65 --sampler independent); fi
      /usr/bin/time -f "%M" -o "$TMP/rss" "${cmd[@]}" -q "${size[@]}" -t 2 -f "$TMP/x.png" "$s" >"$TMP/out" 2>/dev/null
      echo "$(basename "$s") $v $(grep -o 'Render time [0-9.]*' "$TMP/out" | awk '{print $3}') $(cat "$TMP/rss")"
    done
  done
done > "$TMP/runs"
printf "| scene | filter | time / baseline, median (range) | peak RSS MB: baseline | this build |\n|---|---|---|---:|---:|\n"
awk -v rounds="$ROUNDS" '
  function median(a, n,   i, j, t) { for (i = 2; i <= n; i++) for (j = i; j > 1 && a[j-1] > a[j]; j--) { t = a[j]; a[j] = a[j-1]; a[j-1] = t }
                                     return n % 2 ? a[(n+1)/2] : (a[n/2] + a[n/2+1]) / 2 }
  { k = $1 SUBSEP $2; n[k]++; t[k, n[k]] = $3; m[k, n[k]] = $4; if (!($1 in seen)) { seen[$1] = 1; order[++ns] = $1 } }
  END {
    for (i = 1; i <= ns; i++) {
      s = order[i]; b = s SUBSEP "baseline"
      for (r = 1; r <= n[b]; r++) mb[r] = m[b, r] / 1000
      base_rss = median(mb, n[b])
      split("trilinear stochastic nearest", fs, " ")
      for (f = 1; f <= 3; f++) {
        k = s SUBSEP fs[f]; lo = 1e9; hi = 0
        for (r = 1; r <= n[k]; r++) { q[r] = t[k, r] / t[b, r]; if (q[r] < lo) lo = q[r]; if (q[r] > hi) hi = q[r]; mm[r] = m[k, r] / 1000 }
        printf "| %s | %s | %.3f (%.3f-%.3f) | %.0f | %.0f |\n", s, fs[f], median(q, n[k]), lo, hi, base_rss, median(mm, n[k])
      }
    }
  }' "$TMP/runs"
