#!/usr/bin/env python3
"""Bar chart of our BVH's throughput relative to Embree HIGH, from accel_bench CSVs.

    python3 benchmarks/plot/accel_ratio.py CSV[@MACHINE]... -o OUT.png [--backends LIST] [--title T]

Each bar is one (backend, thread count) in one (scene, ray kind) cell: the median of
`ratio_to_embree` over every row of that cell in the CSVs given (several runs of one
command, or runs of several commands; a cell measured by more than one of them is the
median over all of their rows). Embree's own rows (always 1.0) and naive are left out;
the line at 1.0 is Embree. A CSV named as PATH@MACHINE is a series of its own per
machine ("custom:sah:fast, 16 threads, MACHINE"), so runs on different machines are never
mixed into one median. Needs matplotlib (Debian: python3-matplotlib).
"""
import argparse
import csv
import statistics
import sys
from collections import OrderedDict, defaultdict


def read(paths):
    cells = defaultdict(list)   # (scene, kind, backend, threads) -> ratios
    order = OrderedDict()       # (scene, kind) in the order first seen
    series = OrderedDict()      # (backend, threads, machine) in the order first seen
    for arg in paths:
        path, _, machine = arg.partition("@")
        with open(path, newline="") as f:
            for row in csv.DictReader(f):
                backend = row["backend"]
                if not backend.startswith("custom") or not row["ratio_to_embree"]:
                    continue
                key = (row["scene"], row["ray_kind"])
                s = (backend, int(row["threads"]), machine)
                order.setdefault(key, None)
                series.setdefault(s, None)
                cells[key + s].append(float(row["ratio_to_embree"]))
    return cells, list(order), list(series)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("csv", nargs="+", help="accel_bench --csv files")
    ap.add_argument("-o", "--output", required=True, help="PNG to write")
    ap.add_argument("--backends", help="comma-separated backends to plot (default: every custom one)")
    ap.add_argument("--title", default="Our BVH against Embree HIGH on the same rays (median over runs)")
    a = ap.parse_args()

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cells, groups, series = read(a.csv)
    if a.backends:
        keep = a.backends.split(",")
        series = [s for s in series if s[0] in keep]
    series.sort(key=lambda s: (s[2], s[1], s[0] != "custom:sah:fast", s[0]))
    if not groups or not series:
        sys.exit("accel_ratio: no custom backend rows with a ratio to Embree in the CSVs")

    width = 0.8 / len(series)
    fig, ax = plt.subplots(figsize=(max(13, 0.55 * len(groups) * max(1, len(series) / 3)), 6))
    colours = plt.get_cmap("tab10")
    for i, s in enumerate(series):
        xs, ys = [], []
        for g, key in enumerate(groups):
            v = cells.get(key + s)
            if v:
                xs.append(g - 0.4 + width * (i + 0.5))
                ys.append(statistics.median(v))
        label = f"{s[0]}, {s[1]} thread{'s' if s[1] > 1 else ''}" + (f", {s[2]}" if s[2] else "")
        ax.bar(xs, ys, width, label=label,
               color=colours(i % 10), edgecolor="black", linewidth=0.3)
    ax.axhline(1.0, color="#333333", linewidth=1)
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([f"{sc.rsplit('.', 1)[0]}\n{kind}" for sc, kind in groups], fontsize=8)
    ax.set_ylabel("Mrays/s relative to Embree HIGH (1.0 = same)")
    ax.set_ylim(0, None)
    ax.grid(axis="y", alpha=0.4)
    ax.set_title(a.title)
    ax.legend(fontsize=8, ncol=min(2 if any(s[2] for s in series) else 4, len(series)), loc="upper center",
              bbox_to_anchor=(0.5, -0.14))
    fig.tight_layout()
    fig.savefig(a.output, dpi=110)


if __name__ == "__main__":
    main()
