#!/usr/bin/env bash
# Command-line behaviour of pathtracer as a user meets it: help, exit statuses, messages,
# whole-or-nothing output files. Args: TOOLS_DIR SOURCE_DIR SHARED_SCENES_DIR
set -u
PT="$1/pathtracer"; SRC="$2"
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
fails=0; passes=0
. "$(dirname "$0")/check.sh"

check help 0 "--embree-quality" -- "$PT" --help
grep -q "KHR_materials_unlit" "$TMP/out" || { echo "FAIL help does not list KHR_materials_unlit"; fails=$((fails+1)); }
for opt in -s -l -t -m -o -a -H -f -r -p --integrator --accel --bvh --leaf-size --triangle \
           --embree-quality --embree-robust --embree-count --camera --seed --rr --split --sampler --only --max-memory; do
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
printf '50 37.5 1.33 0.1 100\n0 -4 1\n0 0 zz\n' > "$TMP/cam.txt"
check bad-camera-file 2 "cam.txt: field 11 \\(target.z\\)" -- "$PT" -c "$TMP/cam.txt" -r 8 6 "$SRC/scenes/cornell.dae"
printf 'not an image' > "$TMP/sky.exr"
check bad-env-map 2 "sky.exr: cannot read the environment map" -- "$PT" -e "$TMP/sky.exr" -r 8 6 "$SRC/scenes/cornell.dae"
check bad-lens 2 "-b" -- "$PT" -b -1 "$SRC/scenes/cornell.dae"

# -H finds no delta light: a scene lit by a point light says so, and only with -H.
check hemisphere-point-light 0 "Note: -H: no hemisphere ray finds a point, spot or directional light; 1 of" -- \
  "$PT" -H -t 1 -s 1 -r 8 6 -f "$TMP/h.png" "$SRC/scenes/lights/point.gltf"
check point-light-sampled 0 "Lights sampled: .* 1 point" -- "$PT" -t 1 -s 1 -r 8 6 -f "$TMP/h.png" "$SRC/scenes/lights/point.gltf"
grep -q "hemisphere ray" "$TMP/err" && { echo "FAIL point-light-sampled: the -H note without -H"; fails=$((fails+1)); }
check hemisphere-area-light 0 "" -- "$PT" -H -t 1 -s 1 -r 8 6 -f "$TMP/h.png" "$SRC/scenes/cornell.dae"
grep -q "hemisphere ray" "$TMP/err" && { echo "FAIL hemisphere-area-light: the -H note for an area light"; fails=$((fails+1)); }

# Every bad-input class: exit status 2 and a message naming the file (and the element).
mkdir -p "$TMP/bad"
dae_head='<?xml version="1.0"?><COLLADA xmlns="http://www.collada.org/2005/11/COLLADASchema" version="1.4.1"><asset><up_axis>Z_UP</up_axis></asset>'
scene_tail='<library_visual_scenes><visual_scene id="s"><node id="n"><instance_geometry url="#g"/></node></visual_scene></library_visual_scenes><scene><instance_visual_scene url="#s"/></scene></COLLADA>'
geom() {  # geom POSITIONS COUNT P
  echo "<library_geometries><geometry id=\"g\"><mesh><source id=\"p\"><float_array id=\"pa\" count=\"$2\">$1</float_array><technique_common><accessor source=\"#pa\" count=\"$(( $2 / 3 ))\" stride=\"3\"/></technique_common></source><vertices id=\"v\"><input semantic=\"POSITION\" source=\"#p\"/></vertices><triangles count=\"1\"><input semantic=\"VERTEX\" source=\"#v\" offset=\"0\"/><p>$3</p></triangles></mesh></geometry></library_geometries>"
}
echo "$dae_head$(geom '0 0 0 1 0 0 0 1 0' 9 '0 1 7')$scene_tail" > "$TMP/bad/index.dae"
echo "$dae_head$(geom '0 0 0 1 nan 0 0 1 0' 9 '0 1 2')$scene_tail" > "$TMP/bad/nan.dae"
echo "$dae_head$(geom '0 0 0 1 0 0 0 1 0' 9 '0 1 2' | sed 's/#v/#nowhere/')$scene_tail" > "$TMP/bad/dangling.dae"
echo "$dae_head$(geom '0 0 0 1 0 0 0 1 0' 4000000000 '0 1 2')$scene_tail" > "$TMP/bad/huge.dae"
echo "$dae_head<library_visual_scenes><visual_scene id=\"s\"/></library_visual_scenes><scene><instance_visual_scene url=\"#s\"/></scene></COLLADA>" > "$TMP/bad/empty.dae"
check bad-dae-index 2 "index.dae.*(index|range)" -- "$PT" "$TMP/bad/index.dae"
check bad-dae-nan 2 "nan.dae" -- "$PT" "$TMP/bad/nan.dae"
check bad-dae-dangling 2 "dangling.dae.*nowhere" -- "$PT" "$TMP/bad/dangling.dae"
check bad-dae-huge-count 2 "huge.dae" -- "$PT" "$TMP/bad/huge.dae"
check bad-dae-empty 2 "empty.dae" -- "$PT" "$TMP/bad/empty.dae"
echo '{"asset": {"version": "2.0"}, "nodes": [' > "$TMP/bad/malformed.gltf"
check bad-gltf-json 2 "malformed.gltf" -- "$PT" "$TMP/bad/malformed.gltf"
echo '{"asset":{"version":"2.0"},"extensionsRequired":["EXT_meshopt_compression"],"extensionsUsed":["EXT_meshopt_compression"]}' > "$TMP/bad/meshopt.gltf"
check bad-gltf-meshopt 2 "meshopt.gltf.*EXT_meshopt_compression" -- "$PT" "$TMP/bad/meshopt.gltf"
echo '{"asset":{"version":"2.0"},"buffers":[{"uri":"missing.bin","byteLength":36}],"bufferViews":[{"buffer":0,"byteLength":36}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3"}],"meshes":[{"primitives":[{"attributes":{"POSITION":0}}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]}' > "$TMP/bad/nobin.gltf"
check bad-gltf-missing-buffer 2 "nobin.gltf.*missing.bin" -- "$PT" "$TMP/bad/nobin.gltf"
# A base-colour texture the renderer needs but cannot find: a warning naming the image, and
# the render uses the factor alone; --strict makes it an error.
echo '{"asset":{"version":"2.0"},"buffers":[{"uri":"data:application/octet-stream;base64,AAAAAAAAAAAAAAAAAACAPwAAAAAAAAAAAAAAAAAAgD8AAAAA","byteLength":36}],"bufferViews":[{"buffer":0,"byteLength":36}],"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}],"images":[{"uri":"gone.png"}],"textures":[{"source":0}],"materials":[{"pbrMetallicRoughness":{"baseColorTexture":{"index":0}}}],"meshes":[{"primitives":[{"attributes":{"POSITION":0},"material":0}]}],"nodes":[{"mesh":0}],"scenes":[{"nodes":[0]}]}' > "$TMP/bad/notex.gltf"
check gltf-missing-texture 0 "Warning: .*notex.gltf.*gone.png.*rendered without it" -- "$PT" -r 16 12 -s 1 -f "$TMP/notex.png" "$TMP/bad/notex.gltf"
[ -s "$TMP/notex.png" ] || { echo "FAIL gltf-missing-texture wrote no image"; fails=$((fails+1)); }
# A file that requires KHR_materials_unlit renders (tests/gltf/gltf_unlit_test.cpp checks the image).
check gltf-unlit-required 0 "" -- "$PT" -r 16 12 -s 1 -f "$TMP/unlit.png" "$SRC/tests/gltf/data/unlit_panel.gltf"
[ -s "$TMP/unlit.png" ] || { echo "FAIL gltf-unlit-required wrote no image"; fails=$((fails+1)); }
check gltf-missing-texture-strict 2 "notex.gltf.*gone.png.*--strict" -- "$PT" --strict -r 16 12 -s 1 -f "$TMP/notex2.png" "$TMP/bad/notex.gltf"
[ ! -e "$TMP/notex2.png" ] || { echo "FAIL --strict still wrote an image"; fails=$((fails+1)); }
printf 'glTF\x02\x00\x00\x00\xff\x00\x00\x00' > "$TMP/bad/truncated.glb"
check bad-glb-truncated 2 "truncated.glb" -- "$PT" "$TMP/bad/truncated.glb"
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
# --rr: the throughput roulette by default, the course's fixed probability on request.
grep -q "course" <("$PT" --help | grep -A4 -- "--rr") || { echo "FAIL --help does not say which roulette is the course's"; fails=$((fails+1)); }
check rr-fixed 0 "Render time" -- "$PT" -r 16 12 -s 2 --rr 0.65 -f "$TMP/rr.exr" "$SRC/scenes/cornell.dae"
check bad-rr 2 "--rr 1.5" -- "$PT" --rr 1.5 "$SRC/scenes/cornell.dae"
check bad-rr-word 2 "--rr fast" -- "$PT" --rr fast "$SRC/scenes/cornell.dae"
check bad-sampler 2 "--sampler" -- "$PT" --sampler=halton "$SRC/scenes/cornell.dae"
# --split: bounce rays per camera hit, 1 for the unsplit path tracer; 0 is refused.
check split-one 0 "Render time" -- "$PT" -r 16 12 -s 2 --split 1 -f "$TMP/split.exr" "$SRC/scenes/cornell.dae"
check bad-split 2 "--split" -- "$PT" --split 0 "$SRC/scenes/cornell.dae"
# Every sampler's image is the same for any thread count, tile and pass size, on a scene
# with glass, mirror and microfacet spheres (every kind of dimension is drawn).
if command -v idiff >/dev/null; then
  for smp in stratified sobol zsobol pmj02; do
    "$PT" -q -r 40 30 -s 12 -m 4 --seed 3 --sampler=$smp -t 1 --tile 32 -f "$TMP/s1.exr" "$SRC/scenes/cornell_materials.dae" >/dev/null 2>&1
    "$PT" -q -r 40 30 -s 12 -m 4 --seed 3 --sampler=$smp -t 2 --tile 7 --pass 5 -f "$TMP/s2.exr" "$SRC/scenes/cornell_materials.dae" >/dev/null 2>&1
    if idiff -fail 0 -warn 0 "$TMP/s1.exr" "$TMP/s2.exr" >/dev/null 2>&1; then
      echo "ok   sampler-$smp-any-split"; passes=$((passes+1))
    else
      echo "FAIL sampler-$smp-any-split: -t 1 and -t 2 --tile 7 --pass 5 differ"; fails=$((fails+1))
    fi
  done
fi
# Course 3-2 materials render as themselves: no "rendered as diffuse" note.
check materials-scene 0 "Render time" -- "$PT" -r 16 12 -s 2 -f "$TMP/mat.exr" "$SRC/scenes/cornell_materials.dae"
if grep -q "rendered as diffuse" "$TMP/err"; then
  echo "FAIL materials-scene: a CGL material was rendered as diffuse"; fails=$((fails+1))
else
  echo "ok   materials-no-diffuse-note"; passes=$((passes+1))
fi
leftovers=$(ls -A "$TMP" | grep -c '\.tmp' || true)
[ "$leftovers" -eq 0 ] || { echo "FAIL temporary files left behind: $(ls -A "$TMP")"; fails=$((fails+1)); }

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]
