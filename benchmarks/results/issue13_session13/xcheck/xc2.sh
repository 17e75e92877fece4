#!/bin/bash
# The scenes of session 10's xcheck not yet rerun, both backend lists; compares each backend's lines to session 10's.
# XCHECK: the binary (/tmp/s13/xcheck.main unless set); writes set1/, set2/ in the current folder.
B1="custom:midpoint:watertight,custom:sah:avx2:watertight,custom:sah:watertight,custom:sbvh:avx2:fast,custom:sbvh:avx2:watertight,custom:sbvh:fast,custom:sbvh:sse2:fast,custom:sbvh:sse2:watertight,custom:sbvh:watertight"
B2="custom:midpoint:fast,custom:sah:avx2:fast,custom:sah:fast,custom:sah:quantized:fast,custom:sah:quantized:watertight,custom:sah:sse2:fast,custom:sah:sse2:watertight"
P=/work/main/benchmarks/results/issue13_session10
for f in "$@"; do n=$(basename $f)
  ${XCHECK:-/tmp/s13/xcheck.main} --rays 170000 --backends $B1 $f > set1/$n.txt 2>&1
  ${XCHECK:-/tmp/s13/xcheck.main} --rays 170000 --backends $B2 $f > set2/$n.txt 2>&1
  for s in 1 2; do d=$([ $s = 1 ] && echo xcheck || echo xcheck_fast)
    if diff -q <(grep -E "^(camera|random|edge-vertex|grazing|shadow|diffuse|total|scene) " set$s/$n.txt | sort) <(grep -E "^(camera|random|edge-vertex|grazing|shadow|diffuse|total|scene) " $P/$d/$n.txt | sort) >/dev/null; then echo "$n set$s: identical, $(grep '^total' set$s/$n.txt)"; else echo "$n set$s: DIFFERS"; fi
  done
done
