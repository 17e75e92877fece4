#!/usr/bin/env python3
"""Markdown tables from the benchmark CSVs (run by benchmarks/run_study.sh).

  tables.py accel ACCEL_CSV > accel_table.md
  tables.py tradeoff TRADEOFF_CSV > tradeoff_table.md
  tables.py sampler_rr TRADEOFF_CSV   tradeoff's sampler_rr and split studies: every
                                  sampler under both roulettes, then sobol with the
                                  camera hit's bounce split, efficiency at 4, 16, 64 spp
  tables.py runs ACCEL_CSV...     the one-thread table over several runs of one command
  tables.py threads ACCEL_CSV...  thread scaling per run, beside the machine probe
  tables.py plugins ACCEL_CSV...  our BVH as a plugin against it compiled in, and the
                                  example plugin against Embree (RESULTS.md, "Plugins")

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


def _tradeoff_rows(path):
    rows = list(csv.DictReader(open(path)))
    for r in rows:
        for k in ("seconds", "rel_rmse_debiased", "rel_rmse_shadow_debiased", "param"):
            r[k] = float(r[k])
    return rows, list(OrderedDict.fromkeys(r["scene"] for r in rows))


def eff(r, col):
    e = r[col]
    return 1.0 / (e * e * r["seconds"]) if e > 0 and r["seconds"] > 0 else float("nan")


def _plain_spp_efficiency(rs):
    """Median efficiency of plain light sampling's 16..1024 spp points, per error column;
    None when the scene has no spp study."""
    base = [r for r in rs if r["study"] == "spp" and r["param"] >= 16]
    if not base:
        return None
    b = {}
    for col in ("rel_rmse_debiased", "rel_rmse_shadow_debiased"):
        v = sorted(eff(r, col) for r in base)
        b[col] = v[len(v) // 2]
    return b


def tradeoff(path):
    rows, scenes = _tradeoff_rows(path)
    for sc in scenes:
        rs = [r for r in rows if r["scene"] == sc]
        b = _plain_spp_efficiency(rs)
        if not b:
            continue
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


def sampler_rr(path):
    """Every sampler under both roulettes (tradeoff's sampler_rr study), then sobol with
    the throughput roulette and the camera hit's bounce split K ways (its split study):
    efficiency at 4, 16 and 64 spp relative to plain light sampling (independent samples,
    the course's rr 0.65), image and cast shadows, and the image's error and time at 64
    spp."""
    rows, scenes = _tradeoff_rows(path)
    for sc in scenes:
        rs = [r for r in rows if r["scene"] == sc]
        b = _plain_spp_efficiency(rs)
        pts = [r for r in rs if r["study"] in ("sampler_rr", "split")]
        if not b or not pts:
            continue
        print(f"\n#### {sc}\n")
        print("| sampler | roulette | split | efficiency, image: 4 / 16 / 64 spp | shadows: 4 / 16 / 64 spp "
              "| rel RMSE at 64 spp | seconds at 64 spp |")
        print("|---|---|---:|---|---|---:|---:|")
        for label in OrderedDict.fromkeys(r["label"] for r in pts):
            by = {int(r["spp"]): r for r in pts if r["label"] == label}
            name, rest = label.split(" rr=")
            rr, _, k = rest.partition(" split=")

            def effs(col):
                return " / ".join(f"{eff(by[n], col) / b[col]:.2f}" if n in by else "-" for n in (4, 16, 64))

            r64 = by.get(64)
            at64 = f"{r64['rel_rmse_debiased']:.4f} | {r64['seconds']:.3f}" if r64 else "- | -"
            print(f"| {name} | {'throughput' if rr == 'throughput' else 'fixed ' + rr} | {k or 1} | "
                  f"{effs('rel_rmse_debiased')} | {effs('rel_rmse_shadow_debiased')} | {at64} |")


def _index(path):
    """(scene, backend, ray_kind, threads) -> row of one accel_bench CSV."""
    return {(r["scene"], r["backend"], r["ray_kind"], int(r["threads"])): r for r in csv.DictReader(open(path))}


def runs(paths, fast="custom:sah:fast"):
    """The one-thread table: the fast backend's ratio to Embree HIGH in each run, the
    other custom backends' medians beside it, and per run how many cells reach 1.0 and 1.2."""
    idx = [_index(p) for p in paths]
    cells = list(OrderedDict.fromkeys((k[0], k[2]) for k in idx[0] if k[1] == fast and k[3] == 1))
    others = list(OrderedDict.fromkeys(k[1] for k in idx[0] if k[1].startswith("custom:") and k[1] != fast))
    mark = lambda x: f"**{x:.2f}**" if x < 1.0 else f"{x:.2f}"
    med = lambda v: sorted(v)[len(v) // 2]
    print("| scene | rays | " + fast + " " + " / ".join(f"run {i + 1}" for i in range(len(idx))) + " | "
          + " | ".join(others) + " | Embree HIGH Mrays/s |")
    print("|" + "---|" * (3 + len(others) + 1))
    for scene, kind in cells:
        f = [float(ix[(scene, fast, kind, 1)]["ratio_to_embree"]) for ix in idx]
        o = [med([float(ix[(scene, b, kind, 1)]["ratio_to_embree"]) for ix in idx]) for b in others]
        e = med([float(ix[(scene, "embree:high", kind, 1)]["mrays_per_s"]) for ix in idx])
        print(f"| {scene} | {kind} | " + " / ".join(mark(x) for x in f) + " | "
              + " | ".join(mark(x) for x in o) + f" | {e:.2f} |")
    print()
    for i, ix in enumerate(idx):
        f = [(float(ix[(sc, fast, k, 1)]["ratio_to_embree"]), f"{sc} {k}") for sc, k in cells]
        lo = min(f)
        print(f"run {i + 1} ({paths[i]}): >= 1.0 on {sum(x >= 1.0 for x, _ in f)} of {len(f)} cells, "
              f">= 1.2 on {sum(x >= 1.2 for x, _ in f)}; lowest {lo[0]:.2f} ({lo[1]})")


def plugins(paths, ours="plugin:libaccel_plugin_ours.so:sah", example="plugin:libaccel_plugin_example.so",
            fast="custom:sah:fast"):
    """Per one-thread cell: our BVH through the plugin ABI over our BVH compiled in (each
    run, and the median extra time per ray), and the example plugin over Embree HIGH."""
    idx = [_index(p) for p in paths]
    cells = list(OrderedDict.fromkeys((k[0], k[2]) for k in idx[0] if k[1] == fast and k[3] == 1))
    med = lambda v: sorted(v)[len(v) // 2]
    mr = lambda ix, sc, b, k: float(ix[(sc, b, k, 1)]["mrays_per_s"])
    print("| scene | rays | ours compiled in, Mrays/s | ours as a plugin / compiled in, "
          + " / ".join(f"run {i + 1}" for i in range(len(idx)))
          + " | extra ns per ray | example plugin / Embree HIGH | example: tests/ray, nodes/ray |")
    print("|" + "---|" * 7)
    ratios = []
    for sc, k in cells:
        r = [mr(ix, sc, ours, k) / mr(ix, sc, fast, k) for ix in idx]
        ratios.append((med(r), f"{sc} {k}"))
        ns = med([1e3 / mr(ix, sc, ours, k) - 1e3 / mr(ix, sc, fast, k) for ix in idx])
        ex = med([mr(ix, sc, example, k) / mr(ix, sc, "embree:high", k) for ix in idx])
        row = idx[0][(sc, example, k, 1)]
        print(f"| {sc.rsplit('.', 1)[0]} | {k} | {med([mr(ix, sc, fast, k) for ix in idx]):.2f} | "
              + " / ".join(f"{x:.2f}" for x in r) + f" | {ns:+.1f} | {ex:.2f} | "
              f"{float(row['tests_per_ray']):.1f}, {float(row['nodes_per_ray']):.1f} |")
    print()
    v = sorted(x for x, _ in ratios)
    lo = min(ratios)
    print(f"ours as a plugin / compiled in: median over the {len(v)} cells' medians {med(v):.3f}; "
          f"{sum(x >= 0.95 for x in v)} of {len(v)} cells within 5 %; lowest {lo[0]:.3f} ({lo[1]})")


def threads(paths, target=1.8):
    """Per run: each backend's N-thread / 1-thread scaling, the cells below `target`, and
    the machine probe accel_bench measured beside them (machine_probe.h): the scaling
    over the rounds in which the machine gave N cores, and in cells where it gave ~one; and
    the scaling per round against the sum of the N CPUs alone (N x `efficiency_per_round`)."""
    num = lambda r, k: float(r[k]) if r.get(k) else None
    for path in paths:
        ix = _index(path)
        per = OrderedDict()
        for (scene, backend, kind, t), r in ix.items():
            one = ix.get((scene, backend, kind, 1))
            if t == 1 or not one or float(one["mrays_per_s"]) <= 0:
                continue
            eff = num(r, "efficiency_per_round")
            per.setdefault(backend, []).append(dict(
                cell=f"{scene} {kind}", threads=t,
                scaling=float(r["mrays_per_s"]) / float(one["mrays_per_s"]),
                probe=num(r, "machine_scaling"),
                probe1=num(one, "machine_scaling"),  # in a study of several threads (newer CSVs)
                full=num(r, "scaling_full_rounds"), full_rounds=int(r.get("full_rounds") or 0),
                equal=None if eff is None else eff * t))  # newer CSVs: against the CPUs alone
        print(f"{path}:")
        for backend, v in per.items():
            below = [x for x in v if x["scaling"] < target]
            fulls = [x["full"] for x in v if x["full"] is not None]
            probe = (f"over the rounds the probe gave {0.9 * v[0]['threads']:.2f}: "
                     f"{sum(x >= target for x in fulls)} of {len(fulls)} cells >= {target}"
                     if any(x["probe"] is not None for x in v) else "no machine probe in this CSV (an older accel_bench)")
            equal = [x for x in v if x["equal"] is not None]
            eff = (f"; against the CPUs alone, per round: {min(x['equal'] for x in equal):.2f}-"
                   f"{max(x['equal'] for x in equal):.2f}x on equal CPUs, "
                   f"{sum(x['equal'] >= target for x in equal)} of {len(equal)} cells >= {target}" if equal else "")
            print(f"  {backend}: {min(x['scaling'] for x in v):.2f}-{max(x['scaling'] for x in v):.2f}x, "
                  f"{len(v) - len(below)} of {len(v)} cells >= {target}; {probe}{eff}")
            for x in equal:
                if x["equal"] < target:
                    print(f"    {x['cell']}: {x['equal']:.2f}x on equal CPUs")
            for x in below:
                why = "" if x["probe"] is None else f", probe {x['probe']:.2f}" + (
                    "" if x["probe1"] is None else f" (1-thread traces: {x['probe1']:.2f})") + ", " + (
                    f"{x['full']:.2f}x over {x['full_rounds']} such rounds" if x["full"] is not None else "no such round")
                print(f"    {x['cell']}: {x['scaling']:.2f}x{why}")


if __name__ == "__main__":
    if len(sys.argv) < 3 or sys.argv[1] not in ("accel", "tradeoff", "sampler_rr", "runs", "threads", "plugins"):
        sys.exit(__doc__)
    if sys.argv[1] in ("accel", "tradeoff", "sampler_rr"):
        if len(sys.argv) != 3:
            sys.exit(__doc__)
        {"accel": accel, "tradeoff": tradeoff, "sampler_rr": sampler_rr}[sys.argv[1]](sys.argv[2])
    else:
        {"runs": runs, "threads": threads, "plugins": plugins}[sys.argv[1]](sys.argv[2:])
