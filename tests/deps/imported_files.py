#!/usr/bin/env python3
"""Every file that CMake's imported targets reference exists, and the Debian package that
owns it is in the quick start's install list or is a dependency of a package there.

    imported_files.py BUILD/imported_files.txt QUICKSTART.sh

A package installed by hand on the machine that runs CI satisfies CMake there while a
fresh machine fails at configure; this test fails on the machine that has the package,
naming the file and its package. Reads only dpkg's database: no network, ~1 s."""
import os
import re
import subprocess
import sys


def aliases(path):
    """path and the merged-/usr names dpkg may have recorded it under."""
    out = [path, os.path.realpath(path)]
    for p in list(out):
        if p.startswith(("/usr/lib/", "/usr/bin/", "/usr/sbin/")):
            out.append(p[4:])
        elif p.startswith(("/lib/", "/bin/", "/sbin/")):
            out.append("/usr" + p)
    return out


def owners(paths):
    """path -> the packages that own it (or one of its aliases), in one dpkg-query call."""
    names = sorted({a for p in paths for a in aliases(p)})
    r = subprocess.run(["dpkg-query", "-S", *names], capture_output=True, text=True)
    by_name = {}
    for line in r.stdout.splitlines():
        if line.startswith("diversion"):
            continue
        pkgs, _, name = line.partition(": ")
        by_name.setdefault(name, set()).update(
            n.strip().split(":")[0] for n in pkgs.split(","))
    return {p: set().union(*(by_name.get(a, set()) for a in aliases(p))) for p in paths}


def installed_graph():
    """name -> (dependencies as lists of alternatives, virtual names it provides)."""
    fmt = "${Package}\\t${Status}\\t${Pre-Depends}, ${Depends}\\t${Provides}\\n"
    out = subprocess.run(["dpkg-query", "-W", "-f", fmt], capture_output=True, text=True,
                         check=True).stdout
    deps, provides = {}, {}
    for line in out.splitlines():
        name, status, dep, prov = (line.split("\t") + ["", "", ""])[:4]
        if "installed" not in status.split()[-1:]:
            continue
        alts = []
        for group in dep.split(","):
            names = [re.split(r"[\s(:]", a.strip())[0] for a in group.split("|")]
            names = [n for n in names if n]
            if names:
                alts.append(names)
        deps[name] = alts
        for p in prov.split(","):
            p = re.split(r"[\s(:]", p.strip())[0]
            if p:
                provides.setdefault(p, set()).add(name)
    return deps, provides


def closure(roots, deps, provides):
    seen, todo = set(), list(roots)
    while todo:
        n = todo.pop()
        for real in ({n} if n in deps else set()) | provides.get(n, set()):
            if real in seen:
                continue
            seen.add(real)
            for alts in deps.get(real, []):
                todo.extend(alts)  # every installed alternative may be the one in use
    return seen


def main():
    listing, quickstart = sys.argv[1], sys.argv[2]
    roots = subprocess.run(["bash", quickstart, "packages"], capture_output=True, text=True,
                           check=True).stdout.split()
    deps, provides = installed_graph()
    missing_roots = [r for r in roots if r not in deps]
    allowed = closure(roots, deps, provides)
    entries = [l.rstrip("\n").split("\t", 1) for l in open(listing) if "\t" in l]
    owned = owners([p for _, p in entries if os.path.exists(p)])
    failures, checked = [], len(entries)
    for target, path in entries:
        if not os.path.exists(path):
            failures.append(f"{target}: {path} does not exist")
            continue
        pkgs = owned[path]
        if not pkgs:
            # Directories such as /usr/include belong to many packages or none; a file
            # nobody owns was put there by hand.
            if os.path.isdir(path):
                continue
            failures.append(f"{target}: {path} is owned by no Debian package")
        elif not pkgs & allowed:
            failures.append(f"{target}: {path} comes from {', '.join(sorted(pkgs))}, which "
                            "quickstart.sh neither installs nor gets as a dependency")
    print(f"{checked} files referenced by imported targets, "
          f"{len(allowed)} packages in the quick start's closure")
    if missing_roots:
        print("not installed here (cannot check their closure): " + " ".join(missing_roots))
    for f in failures:
        print("FAIL " + f)
    if checked == 0:
        print("FAIL no imported files listed: the CMake collection broke")
        return 1
    return 1 if failures or missing_roots else 0


if __name__ == "__main__":
    sys.exit(main())
