#!/bin/bash
# Issue 6 closing-note renders: 480x360, 64 spp, as the write-ups show.
PT=${PT:-"$(dirname "$0")/../build/tools/pathtracer"}
S=${PT_SHARED_SCENES:-"$(dirname "$0")/../../shared/scenes"}/cs184
OUT=${1:-"$(dirname "$0")/results/renders"}; mkdir -p "$OUT"; PT=$(realpath "$PT"); S=$(realpath "$S"); cd "$OUT"
for sc in CBspheres_lambertian CBbunny banana; do
  /usr/bin/time -f "$sc wall %e s" $PT -q -r 480 360 -s 64 -l 4 -m 5 -f $sc.png $S/$sc.dae > $sc.log 2>&1
done
for only in direct indirect; do
  $PT -q -r 480 360 -s 64 -l 4 -m 5 --only=$only -f CBspheres_$only.png $S/CBspheres_lambertian.dae > CBspheres_$only.log 2>&1
done
for m in 0 1 2 3 100; do
  $PT -q -r 480 360 -s 64 -l 4 -m $m -f CBbunny_m$m.png $S/CBbunny.dae > CBbunny_m$m.log 2>&1
done
echo "renders in $OUT"
