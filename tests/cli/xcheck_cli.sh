#!/usr/bin/env bash
# xcheck on an instanced scene, in each --instancing mode: what traces the instances, what
# traces the flattened copy, and that the backends agree either way.
# Args: TOOLS_DIR SOURCE_DIR SHARED_SCENES_DIR
set -u
T="$1"
XC="$T/xcheck"
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
fails=0; passes=0
. "$(dirname "$0")/check.sh"

# A small forest: tree prototypes with cut-out leaf cards, placed by EXT_mesh_gpu_instancing.
"$T/scenegen" --kind forest -n 20000 -o "$TMP/forest.glb" >/dev/null || { echo "FAIL scenegen"; exit 1; }
BACKENDS=custom:sah:fast,custom:sah:watertight,custom:midpoint:fast,embree:high

# keep: the reference (Embree here) traces the instances too, so hits are compared by
# instance, geometry and primitive; this is how a scene too large to flatten is checked.
check keep-instances 0 "every backend, the reference too, traces the instances" -- \
  "$XC" "$TMP/forest.glb" --instancing keep --rays 3000 --backends "$BACKENDS" --reference embree:high
grep -q "0 real disagreements" "$TMP/out" || { echo "FAIL keep: real disagreements"; fails=$((fails+1)); }
# Embree is checked against itself only under auto (instances against its flattened copy).
if grep -qE "^camera +embree:high " "$TMP/out"; then echo "FAIL keep checked the reference against itself"; fails=$((fails+1)); fi
# keep with the naive reference, which loops over the instances.
check keep-naive 0 "every backend, the reference too, traces the instances" -- \
  "$XC" "$TMP/forest.glb" --instancing keep --rays 500 --backends custom:sah:watertight --reference naive:watertight
grep -q "0 real disagreements" "$TMP/out" || { echo "FAIL keep-naive: real disagreements"; fails=$((fails+1)); }
# auto: the same backends against the flattened copy.
check auto-flattened-reference 0 "the reference traces the flattened copy" -- \
  "$XC" "$TMP/forest.glb" --rays 3000 --backends "$BACKENDS" --reference embree:high
grep -qE "^camera +embree:high " "$TMP/out" || { echo "FAIL auto did not check Embree's instances"; fails=$((fails+1)); }
check bad-mode 2 "instancing" -- "$XC" "$TMP/forest.glb" --instancing bogus

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]
