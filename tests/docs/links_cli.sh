#!/usr/bin/env bash
# Every relative link in every tracked Markdown file resolves: the path exists, and a
# #fragment into a .md file names one of its headings (GitHub's slugs: lower case, spaces
# to '-', punctuation other than '-' and '_' dropped, repeats numbered -1, -2, ...).
# A fragment alone (#section) is checked against the file's own headings. Links to
# http(s), mailto and other schemes are not checked (no network in the suite).
#
#   bash tests/docs/links_cli.sh BIN_DIR SOURCE_DIR SHARED_SCENES_DIR
#
# Only SOURCE_DIR is used. Exits 0 when every link resolves, 1 otherwise (one line per
# broken link: FILE:LINE: TARGET: why), 77 (skipped) without git or python3, or when
# SOURCE_DIR is not a git checkout.
set -u
src=${2:?usage: links_cli.sh BIN_DIR SOURCE_DIR SHARED_SCENES_DIR}
command -v git >/dev/null && command -v python3 >/dev/null || { echo "links_cli: needs git and python3; skipped"; exit 77; }
git -C "$src" rev-parse --is-inside-work-tree >/dev/null 2>&1 || { echo "links_cli: $src is not a git checkout; skipped"; exit 77; }

read -r -d '' check <<'EOF'
import os, re, sys

root = sys.argv[1]
files = [f for f in sys.stdin.read().split("\0") if f]

FENCE = re.compile(r"^\s*(```|~~~)")
HEADING = re.compile(r"^\s{0,3}(#{1,6})\s+(.*?)\s*#*\s*$")
# [text](target "title") and ![alt](target); the target ends at whitespace or ')'.
INLINE = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
REFDEF = re.compile(r"^\s{0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s+.*)?$")
CODE = re.compile(r"`+[^`]*`+")


def slug(text):
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", text)  # a link in a heading: its text
    text = text.replace("`", "").strip().lower()
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


def lines_outside_code(path):
    inside = False
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            if FENCE.match(line):
                inside = not inside
                continue
            if not inside:
                yield n, line


anchors_cache = {}


def anchors(path):
    if path not in anchors_cache:
        seen, out = {}, set()
        for _, line in lines_outside_code(path):
            m = HEADING.match(line)
            if not m:
                continue
            s = slug(m.group(2))
            k = seen.get(s, 0)
            out.add(s if k == 0 else f"{s}-{k}")
            seen[s] = k + 1
        anchors_cache[path] = out
    return anchors_cache[path]


bad = 0
for rel in files:
    path = os.path.join(root, rel)
    if not os.path.isfile(path):
        continue
    for n, line in lines_outside_code(path):
        targets = [m.group(1) for m in INLINE.finditer(CODE.sub("", line))]
        m = REFDEF.match(line)
        if m:
            targets.append(m.group(1))
        for t in targets:
            if re.match(r"^[a-zA-Z][a-zA-Z0-9+.-]*:", t):
                continue  # http:, https:, mailto:, ...
            target, _, frag = t.partition("#")
            dest = path if not target else os.path.normpath(os.path.join(os.path.dirname(path), target))
            why = None
            if not os.path.exists(dest):
                why = "no such file or folder"
            elif frag and dest.endswith(".md") and os.path.isfile(dest) and frag.lower() not in anchors(dest):
                why = f"no heading with anchor #{frag} in {os.path.relpath(dest, root)}"
            if why:
                print(f"{rel}:{n}: {t}: {why}")
                bad += 1

print(f"links_cli: {len(files)} Markdown files, {bad} broken link{'s' if bad != 1 else ''}")
sys.exit(1 if bad else 0)
EOF

git -C "$src" ls-files -z -- '*.md' | python3 -c "$check" "$src"
