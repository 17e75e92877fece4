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
leftovers=$(ls -A "$TMP" | grep -c '\.tmp' || true)
[ "$leftovers" -eq 0 ] || { echo "FAIL temporary files left behind: $(ls -A "$TMP")"; fails=$((fails+1)); }

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]
