#!/usr/bin/env bash
# A render's own rays, recorded by pathtracer --record-rays, traced by accel_bench and
# checked by xcheck (--ray-record): what a user runs, with its exit statuses and messages.
# Args: TOOLS_DIR SOURCE_DIR SHARED_SCENES_DIR
set -u
T="$1"; SRC="$2"
PT="$T/pathtracer"; XC="$T/xcheck"; AB="$T/../benchmarks/accel_bench"
SCENE="$SRC/scenes/cornell.dae"
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
fails=0; passes=0
. "$(dirname "$0")/check.sh"

render() {  # render OUT.rays [more pathtracer flags]
  local out=$1; shift
  "$PT" -q -t 1 -s 4 -m 3 -r 32 24 --record-rays "$out" -f "$TMP/img.png" "$@" "$SCENE" >/dev/null 2>&1
}
check record 0 "Recorded [0-9]+ closest-hit and [0-9]+ any-hit rays to .*a.rays" -- \
  "$PT" -t 1 -s 4 -m 3 -r 32 24 --record-rays "$TMP/a.rays" -f "$TMP/img.png" "$SCENE"
render "$TMP/b.rays"
if cmp -s "$TMP/a.rays" "$TMP/b.rays"; then echo "ok   one-thread-records-the-same-file"; passes=$((passes+1))
else echo "FAIL two 1-thread renders recorded different files"; fails=$((fails+1)); fi
# The cap: 40 bytes of header and 32 a ray, 100 of each kind.
render "$TMP/c.rays" --record-rays-max 100
size=$(stat -c %s "$TMP/c.rays")
if [ "$size" -eq $((40 + 32 * 200)) ]; then echo "ok   record-rays-max"; passes=$((passes+1))
else echo "FAIL --record-rays-max 100: $size bytes"; fails=$((fails+1)); fi
# The memory estimate counts a full record, so an impossible cap is refused before the build.
check record-too-big 3 "ray record 715.26 GiB" -- \
  "$PT" -r 32 24 --record-rays "$TMP/big.rays" --record-rays-max 4000000000 --max-memory 1 -f "$TMP/img3.png" "$SCENE"
grep -q "refused before the build" "$TMP/err" || { echo "FAIL record-too-big was not refused before the build"; fails=$((fails+1)); }
check unwritable 2 "--record-rays $TMP/no/x.rays: the folder" -- \
  "$PT" -r 32 24 --record-rays "$TMP/no/x.rays" -f "$TMP/img2.png" "$SCENE"
# Refused before the render: no image either.
[ ! -e "$TMP/img2.png" ] && [ ! -e "$TMP/no" ] || { echo "FAIL unwritable record left something"; fails=$((fails+1)); }

check xcheck-render-rays 0 "0 real disagreements" -- \
  "$XC" "$SCENE" --ray-record "$TMP/a.rays" --kinds render-closest,render-shadow --backends custom:sah:fast,embree:high
grep -q "render-shadow" "$TMP/out" || { echo "FAIL xcheck lists no render-shadow row"; fails=$((fails+1)); }
check xcheck-no-record 2 "render-closest rays come from a ray record" -- "$XC" "$SCENE" --kinds render-closest
printf 'hello' > "$TMP/text.rays"
check xcheck-not-a-record 2 "text.rays: not a ray record" -- "$XC" "$SCENE" --ray-record "$TMP/text.rays" --kinds render-closest
head -c 1000 "$TMP/a.rays" > "$TMP/cut.rays"
check xcheck-cut-record 2 "cut.rays: 960 bytes of rays, the header counts" -- \
  "$XC" "$SCENE" --ray-record "$TMP/cut.rays" --kinds render-closest
check xcheck-other-scene 2 "a.rays: recorded in a scene of 14 primitives" -- \
  "$XC" "$SRC/scenes/cornell_materials.dae" --ray-record "$TMP/a.rays" --kinds render-closest

if [ -x "$AB" ]; then
  check accel-bench-render-rays 0 "render-closest" -- \
    "$AB" --scene "$SCENE" --ray-record "$TMP/a.rays" --kinds render-closest,render-shadow --quick --no-course \
    --backends custom:sah --threads 1
  grep -qE "custom:sah.* render-shadow +1 " "$TMP/out" || { echo "FAIL accel_bench has no render-shadow row"; fails=$((fails+1)); }
else
  echo "skip accel_bench (benchmarks not built)"
fi

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]
