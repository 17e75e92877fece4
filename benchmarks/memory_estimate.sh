#!/usr/bin/env bash
# How close pathtracer's "Memory estimate: peak" comes to the peak it then reaches: for
# each scene and backend, one render at 800x600, 1 spp, the estimate read from the log and
# the measured peak from /usr/bin/time (maximum resident set size, the kernel's VmHWM).
# Scenes: a course mesh, a textured glTF, a 2M instanced field, the 5M sphere and a 20M
# sphere (the generated ones are made first with scenegen).
# Usage: benchmarks/memory_estimate.sh [--quick] [BUILD_DIR]   (default BUILD_DIR: build)
# --quick: the course mesh and a 200k sphere only (the test suite's smoke run).
set -eu
quick=0
[ "${1:-}" = --quick ] && { quick=1; shift; }
BUILD=${1:-build}
ROOT=$(cd "$(dirname "$0")/.." && pwd)
SHARED=${PT_SHARED_SCENES:-$ROOT/../shared/scenes}
PT=$BUILD/tools/pathtracer; GEN=$BUILD/tools/scenegen
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
[ -x /usr/bin/time ] || { echo "memory_estimate: needs /usr/bin/time (apt-get install time)" >&2; exit 2; }

scenes=()
add() { [ -e "$1" ] && scenes+=("$1") || echo "memory_estimate: skipping $1 (not found)" >&2; }
gen() {  # gen KIND N NAME: a generated mesh, kept in /tmp between runs
  local f=/tmp/memory_estimate_$3.glb
  [ -s "$f" ] || "$GEN" --kind "$1" -n "$2" --seed 1 -o "$f" >/dev/null
  scenes+=("$f")
}
add "$SHARED/cs184/CBbunny.dae"
if [ $quick -eq 1 ]; then
  gen sphere 200000 sphere200k
else
  add "$SHARED/gltf/DamagedHelmet.glb"
  gen field 2000000 field2m
  gen sphere 5000000 sphere5m
  gen sphere 20000000 sphere20m
fi

printf "| scene | triangles | backend | estimate MiB | measured peak MiB | error |\n|---|---:|---|---:|---:|---:|\n"
worst=0
for s in "${scenes[@]}"; do
  for accel in custom embree; do
    /usr/bin/time -f "%M" -o "$TMP/rss" "$PT" --accel "$accel" -q -r 800 600 -s 1 -f "$TMP/out.png" "$s" \
      >/dev/null 2>"$TMP/err" || { echo "memory_estimate: $s --accel $accel failed" >&2; tail -3 "$TMP/err" >&2; exit 1; }
    est=$(grep -oE "Memory estimate: peak [0-9.]+ (KiB|MiB|GiB)" "$TMP/err" |
          awk '{v=$4; u=$5; print (u=="GiB") ? v*1024 : (u=="KiB") ? v/1024 : v}')
    tris=$(grep -oE "Building BVH from [0-9]+" "$TMP/err" | awk '{print $4}')
    meas=$(awk '{print $1/1024}' "$TMP/rss")
    err=$(awk -v e="$est" -v m="$meas" 'BEGIN{printf "%+.1f", 100*(e-m)/m}')
    printf "| %s | %s | %s | %.0f | %.0f | %s %% |\n" "$(basename "$s")" "$tris" "$accel" "$est" "$meas" "$err"
    worst=$(awk -v w="$worst" -v e="$err" 'BEGIN{a = e < 0 ? -e : e; print (a > w ? a : w)}')
  done
done
echo
echo "largest error: $worst % (the bound: 25 %)"
awk -v w="$worst" 'BEGIN{exit !(w <= 25)}'
