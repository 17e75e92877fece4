# The check helper of the command-line tests (sourced; not a test itself): runs a command,
# compares its exit status and searches its output, and counts passes and fails. The
# sourcing script sets TMP, and fails=0 and passes=0.
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
