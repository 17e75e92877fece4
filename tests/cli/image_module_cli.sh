#!/usr/bin/env bash
# The image libraries (OpenImageIO and the ~270 it brings) load only when the pathtracer
# reads or writes its first image file (renderer/image_module.h): not for --help, not for
# an output check, and a render still saves PNG and EXR through them. A missing module
# is refused with the outputs, before the scene loads: one line, exit 2, no file. Args: TOOLS_DIR SOURCE_DIR SHARED_SCENES_DIR
set -u
ulimit -c 0
PT="$1/pathtracer"; SCENE="$2/scenes/cornell.dae"
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
fails=0
fail() { echo "FAIL $*"; fails=$((fails+1)); }
ok() { echo "ok   $*"; }

# The dynamic loader names every library it maps.
LD_DEBUG=libs "$PT" --help >/dev/null 2>"$TMP/libs"
if grep -q "libOpenImageIO" "$TMP/libs"; then fail "--help loads OpenImageIO"; else ok "--help loads no image library"; fi
LD_DEBUG=libs "$PT" -q -r 8 8 -s 1 -f "$TMP/nodir/x.png" "$SCENE" >/dev/null 2>"$TMP/libs"
if grep -q "libOpenImageIO" "$TMP/libs"; then fail "the output check loads OpenImageIO"; else ok "the output check loads no image library"; fi

for ext in png exr; do
  if "$PT" -q -r 16 12 -s 1 -f "$TMP/x.$ext" "$SCENE" >/dev/null 2>"$TMP/err" && [ -s "$TMP/x.$ext" ]; then
    ok "a render saves .$ext"
  else
    fail "a render does not save .$ext"; tail -3 "$TMP/err"
  fi
done

PT_IMAGE_MODULE="$TMP/missing/libpt_image.so" "$PT" -q -r 8 8 -s 1 -f "$TMP/y.png" "$SCENE" >/dev/null 2>"$TMP/err"
st=$?
if [ "$st" -eq 2 ] && grep -q "error: the image module" "$TMP/err" && ! grep -q "Input scene file" "$TMP/err" && [ ! -e "$TMP/y.png" ]; then
  ok "a missing module: exit 2 before the scene loads, no file"
else
  fail "a missing module: exit $st"; cat "$TMP/err"
fi

[ "$fails" -eq 0 ] || { echo "$fails failed"; exit 1; }
echo "all passed"
