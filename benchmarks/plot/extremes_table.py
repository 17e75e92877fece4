#!/usr/bin/env python3
"""Condenses the CSVs of `extremes` into the Markdown tables of benchmarks/RESULTS.md.

usage: extremes_table.py EXTREMES.csv   (EXTREMES_wall.csv is read from beside it)
"""
import csv
import sys
from collections import OrderedDict

BACKENDS = ["custom-fast", "custom-watertight", "embree", "embree-robust"]


def rate(bad, n):
    if n == 0:
        return "n/a"
    if bad == 0:
        return f"0/{n:.1e}".replace("e+0", "e")
    return f"{bad / n:.1e}"


def main(path):
    rows = list(csv.DictReader(open(path)))
    agg = OrderedDict()
    for r in rows:
        key = (float(r["scale"]), float(r["offset"]))
        a = agg.setdefault(key, {}).setdefault(r["backend"], {})
        for k, v in r.items():
            if k in ("scale", "offset", "mesh", "backend"):
                continue
            v = float(v)
            a[k] = max(a.get(k, 0.0), v) if k.startswith("max_") else a.get(k, 0.0) + v
    def num(x):
        if x == 0:
            return "0"
        t = f"{x:.0e}".replace("e+0", "e").replace("e-0", "e-")
        return "1" if t == "1e0" else t

    label = lambda k: f"{num(k[0])} / {num(k[1])}"

    print("Leaks at shared edges and vertices (rays through a closed mesh), per backend:\n")
    print("| scale / offset | rays | custom-fast | custom-watertight | embree | embree-robust (all at vertices) |")
    print("|---|---|---|---|---|---|")
    for k, b in agg.items():
        n = int(b["custom-watertight"]["leak_rays"])
        cells = [rate(int(b[x]["leaks"]), int(b[x]["leak_rays"])) for x in BACKENDS if x in b]
        print(f"| {label(k)} | {n:,} | " + " | ".join(cells) + " |")

    print("\nFalse self-hits per acne ray (hemisphere rays + shadow segments) with the error-bound offset, "
          "every backend; hits within rounding (ambiguous) and the epsilon offset beside them:\n")
    print("| scale / offset | acne rays | false, error-bound (4 backends) | ambiguous, error-bound | "
          "false, epsilon | ambiguous, epsilon |")
    print("|---|---|---|---|---|---|")
    for k, b in agg.items():
        w = b["custom-watertight"]
        n = int(w["hemi_rays_eb"] + w["shadow_rays_eb"])
        false_eb = " / ".join(str(int(b[x]["hemi_false_eb"] + b[x]["shadow_false_eb"])) for x in BACKENDS if x in b)
        amb = rate(int(w["hemi_ambiguous_eb"] + w["shadow_ambiguous_eb"]), n)
        n_eps = int(w["hemi_rays_eps"] + w["shadow_rays_eps"])
        f_eps = rate(int(w["hemi_false_eps"] + w["shadow_false_eps"]), n_eps)
        a_eps = rate(int(w["hemi_ambiguous_eps"] + w["shadow_ambiguous_eps"]), n_eps)
        print(f"| {label(k)} | {n:,} | {false_eb} | {amb} | {f_eps} | {a_eps} |")

    print("\nt against the double-precision reference on rays float can decide: max |dt|/t on random and "
          "axis rays, on grazing rays, and max |dt| over pbrt-v4's bound; wrong misses (decidable rays "
          "missed):\n")
    print("| scale / offset | decidable rays | " + " | ".join(BACKENDS) + " | wrong misses (embree) |")
    print("|---|---|" + "---|" * len(BACKENDS) + "---|")
    for k, b in agg.items():
        n = int(b["custom-watertight"]["ref_rays"])
        cells = []
        for x in BACKENDS:
            if x not in b:
                continue
            c = b[x]
            cells.append(f"{c['max_rel_t']:.1e} / {c['max_rel_t_grazing']:.1e} / {c['max_t_over_bound']:.1e}")
        wm = ", ".join(f"{x}: {int(b[x]['wrong_miss'])}" for x in BACKENDS if x in b and b[x]["wrong_miss"])
        print(f"| {label(k)} | {n:,} | " + " | ".join(cells) + f" | {wm or 'none'} |")

    wall = path.rsplit(".", 1)[0] + "_wall.csv"
    try:
        wrows = list(csv.DictReader(open(wall)))
    except OSError:
        return
    print("\nLight through a thin wall (1e-3 of the scene, at least 64 ulps thick): leaking shadow segments, "
          "error-bound / epsilon (custom-watertight; the other backends in the CSV):\n")
    print("| scale / offset | thickness | segments | error-bound | epsilon |")
    print("|---|---|---|---|---|")
    for r in wrows:
        if r["backend"] != "custom-watertight":
            continue
        n = int(r["rays"])
        print(f"| {label((float(r['scale']), float(r['offset'])))} | {float(r['thickness']):.2g} | {n:,} | {rate(int(r['leaks_eb']), n)} | "
              f"{rate(int(r['leaks_eps']), n)} |")


if __name__ == "__main__":
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    main(sys.argv[1])
