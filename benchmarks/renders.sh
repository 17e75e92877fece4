#!/bin/bash
# The course scenes at 480x360, 64 spp, as the course write-ups show them.
PT=${PT:-"$(dirname "$0")/../build/tools/pathtracer"}
S=${PT_SHARED_SCENES:-"$(dirname "$0")/../../shared/scenes"}/cs184
OUT=${1:-"$(dirname "$0")/results/renders"}; mkdir -p "$OUT"; PT=$(realpath "$PT"); S=$(realpath "$S"); cd "$OUT"
# RENDERS=materials runs only the materials section below.
if [ "${RENDERS:-all}" != materials ]; then
for sc in CBspheres_lambertian CBbunny banana; do
  /usr/bin/time -f "$sc wall %e s" $PT -q -r 480 360 -s 64 -l 4 -m 5 -f $sc.png $S/$sc.dae > $sc.log 2>&1
done
for only in direct indirect; do
  $PT -q -r 480 360 -s 64 -l 4 -m 5 --only=$only -f CBspheres_$only.png $S/CBspheres_lambertian.dae > CBspheres_$only.log 2>&1
done
for m in 0 1 2 3 100; do
  $PT -q -r 480 360 -s 64 -l 4 -m $m -f CBbunny_m$m.png $S/CBbunny.dae > CBbunny_m$m.log 2>&1
done
fi

# Materials, environment light and thin lens; a contact sheet of all of them
# (materials_sheet.png, left to right, top to bottom: CBgems glass, the project's
# Cornell box with mirror/glass/gold spheres, the same through a thin lens, DamagedHelmet,
# BoomBox and Suzanne under a procedural sky; last row: the MIS equal-time comparison).
# cornell_materials_mesh.png is the materials box under --lights=mesh.
G=$(dirname "$S")/gltf
SRC=$(realpath "$(dirname "$PT")/../..")
# A sky gradient with a small sun, made here (no downloads): 256x128 half EXR.
oiiotool --pattern constant:color=4000,3600,3000 3x3 3 \
  --pattern fill:top=0.25,0.4,0.9:bottom=0.8,0.75,0.7 256x128 3 --paste +80+30 -d half -o sky.exr
CAM="--cam-pos 0 -3.9 0.85 --cam-target 0 0 0.75 --cam-up 0 0 1 --fov 42"
r() { local name=$1; shift; /usr/bin/time -f "$name wall %e s" $PT -q "$@" -f $name.png > $name.log 2>&1; }
# Sample counts: the light that reaches a diffuse wall through a mirror or glass from the
# panel (a caustic: wall -> sphere -> panel) is found only by the BSDF sample at the
# sphere, and is added in full there (no light sampling can find it; no clamping, which
# would darken it). At 128 spp these rare, bright paths leave white fireflies on the
# walls; 2048 spp (CBgems: 512) gives a picture a user would accept. They converge, not
# hidden: the estimate is unbiased at any count.
r gems_glass -r 320 240 -s 512 -m 8 $S/CBgems.dae
r cornell_materials -r 320 240 -s 2048 -m 8 $CAM $SRC/scenes/cornell_materials.dae
r cornell_dof -r 320 240 -s 2048 -m 8 $CAM -b 0.15 -d 4.25 $SRC/scenes/cornell_materials.dae
r cornell_materials_mesh -r 320 240 -s 2048 -m 8 --lights=mesh $CAM $SRC/scenes/cornell_materials.dae
r helmet_sky -r 320 240 -s 64 -m 6 -e sky.exr $G/DamagedHelmet.glb
r boombox_sky -r 320 240 -s 64 -m 6 -e sky.exr $G/BoomBox/BoomBox.gltf
r suzanne_sky -r 320 240 -s 64 -m 6 -e sky.exr $G/Suzanne/Suzanne.gltf
oiiotool gems_glass.png cornell_materials.png cornell_dof.png helmet_sky.png boombox_sky.png suzanne_sky.png \
  --mosaic 3x2 -o materials_sheet.png
# Last row: MIS | light only | BSDF only after the same 16 s on Veach's scene, the
# published image of benchmarks/mis_equal_time.sh (benchmarks/results/mis/).
MIS=$SRC/benchmarks/results/mis/mis_sheet.png
if [ -f "$MIS" ]; then
  oiiotool materials_sheet.png --ch R,G,B,A=1.0 "$MIS" --resize 960x240 --ch R,G,B,A=1.0 --origin +0+480 --over \
    --ch R,G,B --fullsize 960x720 --fullpixels -o materials_sheet.png
fi
# An instanced forest (scenegen --kind forest: 10^4 trees of 256 prototypes, 4*10^5
# triangles): leaf cards cut out by their texture's alpha (glTF alphaMode MASK), in
# front of the trunks and in the shadows.
"$(dirname "$PT")/scenegen" --kind forest -n 400000 -o forest.glb > /dev/null && r forest -r 640 400 -s 64 forest.glb
rm -f forest.glb
# The README's contact sheet, when the course renders are here too (RENDERS=all).
if [ -f CBbunny.png ] && [ -f CBspheres_lambertian.png ]; then
  oiiotool CBbunny.png --fit 320x240 CBspheres_lambertian.png --fit 320x240 cornell_materials.png gems_glass.png \
    cornell_dof.png helmet_sky.png boombox_sky.png suzanne_sky.png --mosaic:pad=4 4x2 -o contact_sheet.png
fi
for f in *.log; do echo "${f%.log}: $(grep -h 'Render time' "$f" | sed 's/\[PathTracer\] //')"; done > TIMES.txt
echo "renders in $OUT"
