#!/usr/bin/env bash
# Command-line behaviour of pathtracer as a user meets it: help, exit statuses, messages,
# whole-or-nothing output files. Args: TOOLS_DIR SOURCE_DIR SHARED_SCENES_DIR
set -u
PT="$1/pathtracer"; SRC="$2"
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
fails=0; passes=0
check() {  # check NAME EXPECTED_STATUS PATTERN -- command...
  local name=$1 want=$2 pattern=$3; shift 4
  "$@" >"$TMP/out" 2>"$TMP/err"; local got=$?
  if [ "$got" -ne "$want" ]; then
    echo "FAIL $name: exit $got, expected $want"; sed 's/^/  | /' "$TMP/err" | tail -5; fails=$((fails+1)); return
  fi
  if [ -n "$pattern" ] && ! grep -qE -- "$pattern" "$TMP/out" "$TMP/err"; then
    echo "FAIL $name: output lacks /$pattern/"; sed 's/^/  | /' "$TMP/err" | tail -5; fails=$((fails+1)); return
  fi
  echo "ok   $name"; passes=$((passes+1))
}

check help 0 "--embree-quality" -- "$PT" --help
for opt in -s -l -t -m -o -a -H -f -r -p --integrator --accel --bvh --leaf-size --triangle \
           --embree-quality --embree-robust --embree-count --camera --seed --rr --only; do
  grep -qE -- "^ +$opt[ ,]" "$TMP/out" || { echo "FAIL help does not document $opt"; fails=$((fails+1)); }
done
check missing-scene 2 "error: $TMP/nope.dae: no such file" -- "$PT" "$TMP/nope.dae"
check directory-scene 2 "is a directory" -- "$PT" "$TMP"
echo "hello" > "$TMP/scene.obj"
check unknown-format 2 "scene.obj: unknown scene format" -- "$PT" "$TMP/scene.obj"
echo "<COLLADA><library_geometries><geometry" > "$TMP/broken.dae"
check malformed-dae 2 "broken.dae" -- "$PT" "$TMP/broken.dae"
check bad-resolution 2 "-r 0 -5" -- "$PT" -r 0 -5 "$SRC/scenes/cornell.dae"
check bad-samples 2 "-s" -- "$PT" -s 0 "$SRC/scenes/cornell.dae"
check bad-accel 2 "--accel" -- "$PT" --accel=octree "$SRC/scenes/cornell.dae"
check bad-cell 2 "-p" -- "$PT" -r 10 10 -p 20 0 5 5 "$SRC/scenes/cornell.dae"
check no-scene 2 "scene" -- "$PT"

# A good render writes the file, says where, and leaves no temporary file behind.
check render-normals 0 "Wrote $TMP/c.png" -- "$PT" --integrator=normals -r 64 48 -f "$TMP/c.png" "$SRC/scenes/cornell.dae"
[ -s "$TMP/c.png" ] || { echo "FAIL render-normals wrote no image"; fails=$((fails+1)); }
grep -q "\[PathTracer\] Collecting primitives... Done!" "$TMP/err" || { echo "FAIL course line 'Collecting primitives' missing"; fails=$((fails+1)); }
grep -q "\[PathTracer\] Rendering... 100%!" "$TMP/err" || { echo "FAIL course line 'Rendering... 100%!' missing"; fails=$((fails+1)); }
grep -q "\[PathTracer\] BVH traced" "$TMP/out" || { echo "FAIL course line 'BVH traced' missing on stdout"; fails=$((fails+1)); }
check render-exr 0 "Wrote" -- "$PT" --integrator=normals -r 32 24 -f "$TMP/c.exr" "$SRC/scenes/cornell.dae"
check unwritable-output 2 "/nonexistent/dir/x.png" -- "$PT" --integrator=normals -r 16 12 -f /nonexistent/dir/x.png "$SRC/scenes/cornell.dae"
check bad-extension 2 "x.nope" -- "$PT" --integrator=normals -r 16 12 -f "$TMP/x.nope" "$SRC/scenes/cornell.dae"
# The EXR keeps the AOVs as float channels.
if command -v oiiotool >/dev/null; then
  info=$(oiiotool --info -v "$TMP/c.exr" 2>&1)
  for ch in R G B N.X albedo.R Z samples variance cost.nodes cost.tests nan; do
    echo "$info" | grep -q -- "$ch" || { echo "FAIL EXR lacks channel $ch"; fails=$((fails+1)); }
  done
fi
# Adaptive sampling writes the course's NAME_rate.png; --cost writes the cost maps.
check adaptive-rate 0 "Wrote $TMP/a_rate.png" -- "$PT" -q -r 32 24 -s 64 -a 16 0.05 --cost -f "$TMP/a.png" "$SRC/scenes/cornell.dae"
for f in a.png a_rate.png a_nodes.png a_tests.png; do
  [ -s "$TMP/$f" ] || { echo "FAIL $f not written"; fails=$((fails+1)); }
done
check bad-adaptive 2 "-a" -- "$PT" -a 0 0.05 "$SRC/scenes/cornell.dae"
# -p renders one cell only: pixels outside it stay black.
check cell 0 "Wrote" -- "$PT" -q -r 40 30 -s 4 -p 10 10 8 8 -f "$TMP/cell.exr" "$SRC/scenes/cornell.dae"
# Ctrl-C: the finished pixels are written, marked partial, exit status 130.
"$PT" -s 4096 -r 200 150 -t 1 -f "$TMP/int.exr" "$SRC/scenes/cornell.dae" >"$TMP/int.out" 2>"$TMP/int.err" &
pid=$!; sleep 3; kill -INT $pid; wait $pid; st=$?
if [ "$st" -ne 130 ] || ! grep -q "partial" "$TMP/int.out" || [ ! -s "$TMP/int.exr" ]; then
  echo "FAIL interrupt: exit $st, expected 130 with a partial image"; tail -3 "$TMP/int.err"; fails=$((fails+1))
else
  echo "ok   interrupt-writes-partial"; passes=$((passes+1))
fi
leftovers=$(ls -A "$TMP" | grep -c '\.tmp' || true)
[ "$leftovers" -eq 0 ] || { echo "FAIL temporary files left behind: $(ls -A "$TMP")"; fails=$((fails+1)); }

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]
