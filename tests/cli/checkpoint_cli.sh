#!/usr/bin/env bash
# Resumable renders as a user meets them: checkpoint, kill -9, resume gives the same EXR
# bit for bit (every channel: radiance, AOVs, sample counts, cost); a checkpoint written for
# other settings is refused with exit 2; --time-limit ends a long render with an image.
# Args: TOOLS_DIR SOURCE_DIR SHARED_SCENES_DIR
set -u
PT="$1/pathtracer"; SRC="$2"; SCENE="$SRC/scenes/cornell.dae"
TMP=$(mktemp -d); trap 'rm -rf "$TMP"' EXIT
fails=0
fail() { echo "FAIL $*"; fails=$((fails+1)); }
same() {  # same A B: every channel of every pixel equal
  idiff -fail 0 -warn 0 "$1" "$2" >"$TMP/idiff" 2>&1 || { fail "$3: $1 and $2 differ"; tail -4 "$TMP/idiff"; return; }
  echo "ok   $3"
}
ARGS=(-s 256 --pass 4 -r 64 48 -m 4 --seed 5 -q)

"$PT" "${ARGS[@]}" -t 2 -f "$TMP/full.exr" "$SCENE" >/dev/null 2>"$TMP/err" || fail "uninterrupted render"

# Checkpoint after every pass; kill -9 once one exists (the worst interruption: no handler).
"$PT" "${ARGS[@]}" -t 1 --checkpoint "$TMP/ck" --checkpoint-every 0 -f "$TMP/killed.exr" "$SCENE" \
  >/dev/null 2>&1 &
pid=$!
for _ in $(seq 600); do [ -s "$TMP/ck" ] && break; sleep 0.05; done
kill -9 $pid 2>/dev/null; wait $pid 2>/dev/null; st=$?
[ "$st" -eq 137 ] || fail "kill: the render ended by itself (status $st) before it was killed"
[ -e "$TMP/killed.exr" ] && fail "kill: a killed render left an image"
# A kill that lands during a write leaves that write's temporary file (no handler runs
# under SIGKILL); the previous checkpoint stays whole, and the next run's first checkpoint
# removes the dead process's temporary (checked after the resume below).
cp "$TMP/ck" "$TMP/ck.saved"
# A dead process's temporary, as such a kill leaves it (pid 4194303: Linux never hands out
# a pid that high, its limit being 4194304), must be gone after the resumed run; a live
# process's must not be touched.
: >"$TMP/ck.tmp4194303"
sleep 300 & live=$!
: >"$TMP/ck.tmp$live"

"$PT" "${ARGS[@]}" -t 2 --resume "$TMP/ck" --checkpoint "$TMP/ck" -f "$TMP/resumed.exr" "$SCENE" \
  >"$TMP/out" 2>"$TMP/err" || { fail "resume: exit $?"; tail -3 "$TMP/err"; }
same "$TMP/full.exr" "$TMP/resumed.exr" "checkpoint, kill -9, resume is bit-identical"
[ -e "$TMP/ck.tmp4194303" ] && fail "resume: a dead process's temporary checkpoint was left behind" \
  || echo "ok   the dead process's temporary checkpoint was removed by the resumed run"
[ -e "$TMP/ck.tmp$live" ] && echo "ok   a running process's temporary checkpoint was kept" \
  || fail "resume: removed the temporary checkpoint of a running process"
kill $live 2>/dev/null; wait $live 2>/dev/null
grep -q "BVH traced" "$TMP/out" && [ "$(grep 'BVH traced' "$TMP/out")" = \
  "$("$PT" "${ARGS[@]}" -f "$TMP/again.exr" "$SCENE" 2>/dev/null | grep 'BVH traced')" ] \
  && echo "ok   resumed statistics equal the uninterrupted run's" || fail "resumed statistics differ"

# Other settings (here the light samples) are refused, naming the file; exit 2, no image.
"$PT" "${ARGS[@]}" -l 2 --resume "$TMP/ck.saved" -f "$TMP/bad.exr" "$SCENE" >/dev/null 2>"$TMP/err"
st=$?
{ [ $st -eq 2 ] && grep -q "ck.saved: written for another scene or other settings" "$TMP/err" \
  && [ ! -e "$TMP/bad.exr" ]; } && echo "ok   mismatched resume refused" \
  || { fail "mismatched resume: exit $st"; tail -3 "$TMP/err"; }
head -c 100 "$TMP/ck.saved" >"$TMP/trunc"
"$PT" "${ARGS[@]}" --resume "$TMP/trunc" -f "$TMP/bad.exr" "$SCENE" >/dev/null 2>"$TMP/err"
st=$?
{ [ $st -eq 2 ] && grep -q "trunc: truncated" "$TMP/err"; } && echo "ok   truncated checkpoint refused" \
  || { fail "truncated checkpoint: exit $st"; tail -3 "$TMP/err"; }

# A render that would take hours ends after the time limit with a whole image.
"$PT" -s 1000000 -r 32 24 -q --time-limit 1 -f "$TMP/limited.exr" "$SCENE" >"$TMP/out" 2>"$TMP/err"
st=$?
{ [ $st -eq 0 ] && [ -s "$TMP/limited.exr" ] && grep -q "Time limit:" "$TMP/out"; } \
  && echo "ok   --time-limit" || { fail "--time-limit: exit $st"; tail -3 "$TMP/err"; }

[ $fails -eq 0 ] || { echo "$fails failure(s)"; exit 1; }
