#!/usr/bin/env python3
"""Markdown tables from the benchmark CSVs (run by benchmarks/run_study.sh).

  tables.py accel ACCEL_CSV > accel_table.md
  tables.py tradeoff TRADEOFF_CSV > tradeoff_table.md

The tradeoff table ranks settings by efficiency, 1 / (rel_rmse^2 * seconds): for an
unbiased estimator error falls as 1/sqrt(time), so err^2 * time is constant along a
curve and the time to reach a target error e is 1 / (efficiency * e^2). Efficiencies are
given relative to plain light sampling with more spp (median over its 16..1024 spp
points), so 2.0 means "reaches any error in half the time". Biased settings (small
maximum depth) have an error floor instead: the table marks a depth whose error is more
than 1.25x that of depth 100 at the same spp as biased (more spp will not remove it).
"""
import csv
import math
import sys
from collections import OrderedDict


def accel(path):
    rows = list(csv.DictReader(open(path)))
    by_scene = OrderedDict()
    for r in rows:
        by_scene.setdefault((r["scene"], r["triangles"]), []).append(r)
    for (scene, tris), rs in by_scene.items():
        print(f"\n#### {scene} ({int(tris):,} triangles)\n")
        threads = sorted({int(r["threads"]) for r in rs})
        hdr = "| backend | rays | " + " | ".join(f"{t} thr Mrays/s (vs Embree)" for t in threads)
        hdr += " | scaling | tests/ray | nodes/ray | build ms | memory |"
        print(hdr)
        print("|" + "---|" * (hdr.count("|") - 1))
        keys = OrderedDict()
        for r in rs:
            keys.setdefault((r["backend"], r["ray_kind"]), {})[int(r["threads"])] = r
        for (backend, kind), per in keys.items():
            any_r = next(iter(per.values()))
            cells = []
            for t in threads:
                r = per.get(t)
                cells.append(f"{float(r['mrays_per_s']):.2f} ({float(r['ratio_to_embree']):.2f})" if r else "-")
            lo, hi = per.get(threads[0]), per.get(threads[-1])
            scale = (f"{float(hi['mrays_per_s']) / float(lo['mrays_per_s']):.2f}x"
                     if lo and hi and lo is not hi and float(lo["mrays_per_s"]) > 0 else "-")
            t_ray = any_r["tests_per_ray"] or "-"
            n_ray = any_r["nodes_per_ray"] or "-"
            nbytes = int(any_r["bytes"])
            mem = f"{nbytes / 2**20:.1f} MiB" if nbytes >= 2**20 else f"{nbytes / 1024:.1f} KiB"
            print(f"| {backend} | {kind} | " + " | ".join(cells) +
                  f" | {scale} | {t_ray} | {n_ray} | {float(any_r['build_ms']):.1f} | {mem} |")


def tradeoff(path):
    rows = list(csv.DictReader(open(path)))
    for r in rows:
        for k in ("seconds", "rel_rmse_debiased", "rel_rmse_shadow_debiased", "param"):
            r[k] = float(r[k])
    scenes = list(OrderedDict.fromkeys(r["scene"] for r in rows))

    def eff(r, col):
        e = r[col]
        return 1.0 / (e * e * r["seconds"]) if e > 0 and r["seconds"] > 0 else float("nan")

    for sc in scenes:
        rs = [r for r in rows if r["scene"] == sc]
        base = [r for r in rs if r["study"] == "spp" and r["param"] >= 16]
        if not base:
            continue
        b = {}
        for col in ("rel_rmse_debiased", "rel_rmse_shadow_debiased"):
            v = sorted(eff(r, col) for r in base)
            b[col] = v[len(v) // 2]
        print(f"\n#### {sc}\n")
        print("Plain light sampling, 1 light sample, depth 100, rr 0.65 reaches relative RMSE "
              + ", ".join(f"{e} in ~{1 / (b['rel_rmse_debiased'] * e * e):.2f} s" for e in (0.1, 0.05, 0.02))
              + " (image); "
              + ", ".join(f"{e} in ~{1 / (b['rel_rmse_shadow_debiased'] * e * e):.2f} s" for e in (0.1, 0.05))
              + " (shadows).\n")
        print("| study | setting | spp | seconds | rel RMSE image | shadows | efficiency vs plain spp (image / shadows) |")
        print("|---|---|---|---|---|---|---|")
        for r in rs:
            ei = eff(r, "rel_rmse_debiased") / b["rel_rmse_debiased"]
            es = eff(r, "rel_rmse_shadow_debiased") / b["rel_rmse_shadow_debiased"]
            deep = [q for q in rs if q["study"] == "max_depth" and q["param"] >= 100]
            floor = (r["study"] == "max_depth" and deep and
                     r["rel_rmse_debiased"] > 1.25 * deep[0]["rel_rmse_debiased"])
            setting = {
                "spp": "light sampling",
                "sampling": "hemisphere",
                "light_samples": f"l = {int(r['param'])}",
                "adaptive": ("fixed (no adaptive)" if r["label"] == "fixed" else f"tol {r['param']:g}"),
                "rr": f"rr {r['param']:g}",
                "max_depth": f"m = {int(r['param'])}",
            }.get(r["study"], r["label"])
            print(f"| {r['study']} | {setting}{' (biased)' if floor else ''} | {r['spp']} | {r['seconds']:.3f} | "
                  f"{r['rel_rmse_debiased']:.4f} | {r['rel_rmse_shadow_debiased']:.4f} | {ei:.2f} / {es:.2f} |")


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("accel", "tradeoff"):
        sys.exit(__doc__)
    (accel if sys.argv[1] == "accel" else tradeoff)(sys.argv[2])
