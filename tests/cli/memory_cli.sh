#!/usr/bin/env bash
# Running out of memory or disk as a user meets it: exit status 3 and one line naming the
# stage and the bytes (ulimit -v, a film too large, --max-memory), exit status 2 before the
# scene loads for an output that cannot be written, no partial files, no core dumps, and
# repeated loader notes said once. Args: TOOLS_DIR SOURCE_DIR SHARED_SCENES_DIR
set -u
ulimit -c 0
PT="$1/pathtracer"; GEN="$1/scenegen"; SRC="$2"; SCENE="$SRC/scenes/cornell.dae"
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
fails=0
fail() { echo "FAIL $*"; fails=$((fails+1)); }
ok() { echo "ok   $*"; }
# run NAME WANT_STATUS PATTERN -- command...: the status, the pattern on stderr, and no
# "terminate called" or core dump whatever happens.
run() {
  local name=$1 want=$2 pattern=$3; shift 4
  "$@" >"$TMP/out" 2>"$TMP/err"; local got=$?
  if [ "$got" -ne "$want" ]; then fail "$name: exit $got, expected $want"; sed 's/^/  | /' "$TMP/err" | tail -5; return 1; fi
  if [ -n "$pattern" ] && ! grep -qE -- "$pattern" "$TMP/err"; then
    fail "$name: stderr lacks /$pattern/"; sed 's/^/  | /' "$TMP/err" | tail -5; return 1; fi
  if grep -q "terminate called\|core dumped\|Aborted" "$TMP/err"; then fail "$name: crashed"; return 1; fi
  ok "$name"
}
ms() { date +%s%N | cut -c1-13; }

# A film too large for any machine here: refused at once, before the scene loads.
run film-too-large 3 "out of memory: the film of -r 60000 60000 needs .*GiB" -- \
  "$PT" -r 60000 60000 -f "$TMP/huge.exr" "$SCENE"
grep -q "Collecting primitives" "$TMP/err" && fail "film-too-large: the scene was loaded first"
[ "$(grep -c 'error' "$TMP/err")" -eq 1 ] || fail "film-too-large: not exactly one error line"

# Unwritable outputs: exit 2 naming the path, before the scene loads (so at once).
for spec in "-f|$TMP/nonexistent/dir/x.exr|folder .*nonexistent/dir does not exist" \
            "-f|$TMP/x.xyz|no image writer for the extension '.xyz'" \
            "-f|/proc/x.png|cannot create a file in /proc" \
            "--checkpoint|$TMP/nope/shot.ckpt|--checkpoint .*nope/shot.ckpt: the folder"; do
  IFS='|' read -r flag path pattern <<<"$spec"
  args=(-f "$TMP/ok.png"); [ "$flag" = -f ] && args=()
  t0=$(ms)
  run "unwritable $flag $path" 2 "$pattern" -- "$PT" "${args[@]}" "$flag" "$path" -s 1 -r 16 12 "$SCENE" || continue
  took=$(( $(ms) - t0 ))
  grep -q "Collecting primitives" "$TMP/err" && fail "unwritable $flag $path: the scene was loaded first"
  # The issue's bound is a second; the check allows for a busy machine's start-up.
  [ "$took" -lt 2000 ] || fail "unwritable $flag $path: took $took ms"
done
[ ! -e "$TMP/ok.png" ] || fail "a refused render wrote its image"
# A render that passes the checks leaves no probe file behind.
run probe-removed 0 "" -- "$PT" --integrator=normals -r 16 12 -f "$TMP/ok.png" --checkpoint "$TMP/ok.ckpt" "$SCENE"
ls -A "$TMP" | grep -q probe && fail "a probe file was left behind: $(ls -A "$TMP")"

# The estimate is printed before the build; --max-memory refuses below it and accepts above.
run estimate 0 "Memory estimate: peak [0-9.]+ (MiB|GiB)" -- "$PT" --integrator=normals -r 64 48 -f "$TMP/e.png" "$SCENE"
est=$(grep -oE "Memory estimate: peak [0-9.]+ (MiB|GiB)" "$TMP/err" | awk '{print ($5=="GiB") ? $4 : $4/1024}')
below=$(awk -v e="$est" 'BEGIN{print e*0.8}'); above=$(awk -v e="$est" 'BEGIN{print e*1.25}')
run "max-memory $below refuses (estimate $est GiB)" 3 "out of memory: the estimated peak of .*\(--max-memory $below\); refused before the build" -- \
  "$PT" --max-memory "$below" --integrator=normals -r 64 48 -f "$TMP/refused.png" "$SCENE"
grep -q "Building BVH" "$TMP/err" && fail "--max-memory: refused after the build started"
[ ! -e "$TMP/refused.png" ] || fail "--max-memory: a refused render wrote its image"
run "max-memory $above accepts" 0 "" -- "$PT" --max-memory "$above" --integrator=normals -r 64 48 -f "$TMP/accepted.png" "$SCENE"
[ -s "$TMP/accepted.png" ] || fail "--max-memory: an accepted render wrote no image"
run max-memory-film 3 "film of -r 4000 4000 needs .*\(--max-memory 1\)" -- "$PT" --max-memory 1 -r 4000 4000 "$SCENE"

# Under ulimit -v, a mesh too large for the limit: exit 3, the stage and the bytes named,
# no image, for both backends. The limit is a running render's address space (libraries,
# threads and their malloc arenas, which grow with the core count), read from /proc on
# this machine, plus 300 MB: less than loading and building the 3M-triangle mesh take.
# Where the build fits, the image libraries, mapped before the render under ulimit -v,
# do not: either way the run stops before rendering.
"$PT" --integrator=normals -s 1000000 -r 32 24 -q -f "$TMP/base.png" "$SCENE" >/dev/null 2>&1 &
pid=$!; sleep 2
base_kb=$(awk '/^VmPeak/{print $2}' /proc/$pid/status); kill -9 $pid; wait $pid 2>/dev/null
"$GEN" --kind sphere -n 3000000 --seed 1 -o "$TMP/big.glb" >/dev/null || fail "scenegen"
for accel in custom embree; do
  limit_kb=$(( base_kb + 300 * 1024 ))
  run "ulimit -v $limit_kb, --accel $accel" 3 \
    "^pathtracer: error: out of memory( while (loading the scene|building the BVH): .*[0-9]+ bytes|: the image libraries cannot be mapped .*refused before the render)" -- \
    bash -c "ulimit -v $limit_kb; exec \"$PT\" --accel $accel -r 32 24 -s 1 -f \"$TMP/v.png\" \"$TMP/big.glb\""
  grep '^pathtracer: error' "$TMP/err" | sed 's/^/     /'
  [ "$(grep -c '^pathtracer: error' "$TMP/err")" -eq 1 ] || fail "ulimit -v --accel $accel: not one error line"
  [ ! -e "$TMP/v.png" ] && ! ls -A "$TMP" | grep -q "tmp" || fail "ulimit -v --accel $accel: a file was left: $(ls -A "$TMP")"
done

# xcheck and accel_bench under the same limit: the same one line and status.
run "xcheck under ulimit -v" 3 "^xcheck: error: out of memory while (loading the scene|building the BVHs): .*bytes" -- \
  bash -c "ulimit -v $limit_kb; exec \"$1/xcheck\" --rays 1000 \"$TMP/big.glb\""
BENCH="$1/../benchmarks/accel_bench"
if [ -x "$BENCH" ]; then
  run "accel_bench under ulimit -v" 3 "^accel_bench: error: out of memory while (loading the scene|building the BVHs): .*bytes" -- \
    bash -c "ulimit -v $limit_kb; exec \"$BENCH\" --quick --no-course --scene \"$TMP/big.glb\""
fi

# scenegen under the same kind of limit.
run "scenegen under ulimit -v" 3 "^scenegen: error: out of memory while (generating the mesh|writing the file): .*bytes" -- \
  bash -c "ulimit -v 400000; exec \"$GEN\" --kind sphere -n 20000000 -o \"$TMP/gen.glb\""
grep '^scenegen: error' "$TMP/err" | sed 's/^/     /'
[ ! -e "$TMP/gen.glb" ] && [ ! -e "$TMP/gen.glb.tmp" ] || fail "scenegen left a file"
run "scenegen unwritable -o" 2 "scenegen: error: -o .*nope/x.glb: the folder" -- "$GEN" -n 1000 -o "$TMP/nope/x.glb"

# A disk that fills during the save or a checkpoint: exit 2 naming the file, no partial or
# temporary file, an earlier image untouched; a disk full before the start: exit 2 at once.
# On a 64 KiB tmpfs mounted in a private mount namespace (skipped where none can be made).
cat >"$TMP/disk.sh" <<EOS
set -u
d="$TMP/tiny"
mount -t tmpfs -o size=64k tmpfs "\$d" || exit 77
"$PT" -q --integrator=normals -r 8 6 -f "\$d/x.exr" "$SCENE" >/dev/null 2>&1 || { echo "FAIL small image"; exit 1; }
before=\$(md5sum <"\$d/x.exr")
"$PT" -q --integrator=normals -r 256 192 -f "\$d/x.exr" "$SCENE" >/dev/null 2>"$TMP/e1"; st=\$?
[ \$st -eq 2 ] && grep -q "x.exr: cannot write" "$TMP/e1" && [ "\$(md5sum <"\$d/x.exr")" = "\$before" ] \
  && [ "\$(ls -A "\$d")" = x.exr ] && echo "ok   disk full during the save: exit 2, the earlier image untouched" \
  || { echo "FAIL disk full during the save: status \$st, files: \$(ls -A "\$d")"; cat "$TMP/e1"; }
"$PT" -q --integrator=normals -r 64 48 --checkpoint "\$d/c.ckpt" -f "$TMP/c.png" "$SCENE" >/dev/null 2>"$TMP/e2"; st=\$?
[ \$st -eq 2 ] && grep -q "c.ckpt: cannot write checkpoint: No space left" "$TMP/e2" && [ "\$(ls -A "\$d")" = x.exr ] \
  && echo "ok   disk full during a checkpoint: exit 2, no partial file" \
  || { echo "FAIL disk full during a checkpoint: status \$st, files: \$(ls -A "\$d")"; cat "$TMP/e2"; }
dd if=/dev/zero of="\$d/fill" bs=1k count=100 2>/dev/null
"$PT" -q --integrator=normals -r 64 48 -f "\$d/w.png" "$SCENE" >/dev/null 2>"$TMP/e3"; st=\$?
[ \$st -eq 2 ] && grep -q "w.png: cannot write in .*No space left" "$TMP/e3" && ! grep -q Collecting "$TMP/e3" \
  && echo "ok   disk full before the start: exit 2 before the scene loads" \
  || { echo "FAIL disk full before the start: status \$st"; cat "$TMP/e3"; }
EOS
mkdir "$TMP/tiny"
if unshare -m true 2>/dev/null; then ns=(unshare -m); else ns=(unshare -rm); fi
"${ns[@]}" bash "$TMP/disk.sh" >"$TMP/disk.log" 2>&1; st=$?
if [ $st -eq 77 ] || { [ $st -ne 0 ] && ! grep -q "ok\|FAIL" "$TMP/disk.log"; }; then
  echo "skip disk-full cases: no tmpfs can be mounted here"
else
  cat "$TMP/disk.log"; fails=$((fails + $(grep -c '^FAIL' "$TMP/disk.log")))
fi

# A repeated loader note is said once with its count.
tri="AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA"
mats=""; meshes=""; nodes=""
for i in 0 1 2; do
  sep=$([ $i -gt 0 ] && echo ,)
  mats+="$sep{\"pbrMetallicRoughness\":{\"baseColorTexture\":{}}}"
  meshes+="$sep{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"material\":$i}]}"
  nodes+="$sep{\"mesh\":$i}"
done
echo "{\"asset\":{\"version\":\"2.0\"},\"buffers\":[{\"uri\":\"data:application/octet-stream;base64,$tri\",\"byteLength\":36}],\"bufferViews\":[{\"buffer\":0,\"byteLength\":36}],\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":3,\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,0]}],\"materials\":[$mats],\"meshes\":[$meshes],\"nodes\":[$nodes],\"scenes\":[{\"nodes\":[0,1,2]}]}" >"$TMP/repeat.gltf"
run notes-once 0 "Note: tinygltf: 'index' property is missing in TextureInfo. \\(3 times\\)" -- \
  "$PT" -r 8 6 -s 1 -f "$TMP/rep.png" "$TMP/repeat.gltf"
[ "$(grep -c "index' property is missing" "$TMP/err")" -eq 1 ] || fail "notes-once: the note is printed more than once"

[ $fails -eq 0 ] || { echo "$fails failure(s)"; exit 1; }
