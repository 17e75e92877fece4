#!/usr/bin/env bash
# Every --flag that a command in a tracked Markdown file gives one of our programs is a
# flag that program's --help lists, so that no page tells a newcomer to type an option
# that was renamed or removed. The commands are those in fenced code blocks (a line
# ending in '\' continues on the next) and in inline code spans; a command's flags are
# the tokens from the program's name up to a pipe, a ';', '&&', '||', a redirection or
# a '#' comment. The programs are the executables the build put in BIN_DIR (the tools)
# and BIN_DIR/../benchmarks, matched by file name, with or without a path before it.
#
#   bash tests/docs/flags_cli.sh BIN_DIR SOURCE_DIR SHARED_SCENES_DIR
#
# Exits 0 when every flag is known, 1 otherwise (one line per unknown flag: FILE:LINE:
# PROGRAM --FLAG), 77 (skipped) without git or python3, or when SOURCE_DIR is not a git
# checkout.
set -u
bin=${1:?usage: flags_cli.sh BIN_DIR SOURCE_DIR SHARED_SCENES_DIR}
src=${2:?usage: flags_cli.sh BIN_DIR SOURCE_DIR SHARED_SCENES_DIR}
command -v git >/dev/null && command -v python3 >/dev/null || { echo "flags_cli: needs git and python3; skipped"; exit 77; }
git -C "$src" rev-parse --is-inside-work-tree >/dev/null 2>&1 || { echo "flags_cli: $src is not a git checkout; skipped"; exit 77; }

read -r -d '' check <<'EOF'
import os, re, subprocess, sys

root, bins = sys.argv[1], sys.argv[2:]
files = [f for f in sys.stdin.read().split("\0") if f]

FLAG = re.compile(r"--[A-Za-z0-9][A-Za-z0-9_-]*")
FENCE = re.compile(r"^\s*(```|~~~)")
SPAN = re.compile(r"`([^`]+)`")
ENDS = {"|", ";", "&&", "||", ">", ">>", "2>", "2>&1", "<"}

programs = {}
for d in bins:
    if not os.path.isdir(d):
        continue
    for name in sorted(os.listdir(d)):
        path = os.path.join(d, name)
        if name in programs or not os.path.isfile(path) or not os.access(path, os.X_OK) or "." in name:
            continue
        out = subprocess.run([path, "--help"], capture_output=True, text=True, timeout=60)
        programs[name] = set(FLAG.findall(out.stdout + out.stderr))
if not programs:
    print(f"flags_cli: no programs in {', '.join(bins)}")
    sys.exit(1)


def commands(path):
    """(line number, text) of each command: fenced lines, joined across '\\', and code spans."""
    inside, start, pending = False, 0, ""
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if FENCE.match(line):
                inside, pending = not inside, ""
                continue
            if inside:
                text = line.rstrip("\n")
                if not pending:
                    start = n
                if text.rstrip().endswith("\\"):
                    pending += text.rstrip()[:-1] + " "
                    continue
                yield start, pending + text
                pending = ""
            else:
                for m in SPAN.finditer(line):
                    yield n, m.group(1)


bad = checked = 0
for rel in files:
    path = os.path.join(root, rel)
    if not os.path.isfile(path):
        continue
    for n, text in commands(path):
        program = None
        for tok in text.split():
            if tok.startswith("#") or tok in ENDS:
                program = None
                continue
            name = os.path.basename(tok)
            if name in programs:
                program = name
                continue
            if program and tok.startswith("--"):
                flag = FLAG.match(tok)
                if not flag:
                    continue
                checked += 1
                if flag.group(0) not in programs[program]:
                    print(f"{rel}:{n}: {program} {flag.group(0)}: not in '{program} --help'")
                    bad += 1

print(f"flags_cli: {checked} flags of {len(programs)} programs in {len(files)} Markdown files, {bad} unknown")
sys.exit(1 if bad else 0)
EOF

git -C "$src" ls-files -z -- '*.md' | python3 -c "$check" "$src" "$bin" "$bin/../benchmarks"
