#!/bin/bash
# Normal-shaded 640x480 EXRs per ISA, compared with idiff -fail 0 against avx512.
S=/work/shared/scenes/cs184; P=/work/main/build/tools/pathtracer
for sc in bunny CBbunny; do for tri in fast watertight; do for bvh in sah sbvh; do
  for isa in avx512 avx2 sse2; do $P --integrator normals --accel custom --bvh $bvh --triangle $tri --isa $isa -s 1 -r 640 480 -f ${sc}_${tri}_${bvh}_$isa.exr $S/$sc.dae >/dev/null 2>&1 || echo "render failed $sc $tri $bvh $isa"; done
  for isa in avx2 sse2; do r=$(idiff -fail 0 -warn 0 ${sc}_${tri}_${bvh}_avx512.exr ${sc}_${tri}_${bvh}_$isa.exr >/dev/null 2>&1 && echo PASS || echo FAIL); echo "$sc $tri $bvh avx512 vs $isa: $r"; done
done; done; done
