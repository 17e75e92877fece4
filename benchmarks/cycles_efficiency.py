#!/usr/bin/python3
"""Efficiency at equal error against Blender Cycles, and against another build of ours.

For each Cornell box, renders the course's 480x360 framing at 16 and 64 spp with two
seeds, with Cycles (the harness in ../shared/peers/cycles) and with our pathtracer (and,
with --baseline, a second pathtracer binary, e.g. the previous release), each against
its own 1024-spp reference, 5 bounces (ours -m 6), 2 threads, the emissive panel as the
light in both (harness --lights mesh, ours --lights=mesh). Then prints, per scene and
spp, the path-tracing time, the relative RMSE and the efficiency 1 / (relRMSE^2 t), and
the ratios ours / Cycles and ours / baseline; last, how far the two references' region
means lie apart, since each renderer's error is measured against its own reference and
the ratios say nothing of a scene the two drew differently (a light one of them drops).

    benchmarks/cycles_efficiency.py [--pathtracer PT] [--baseline PT0] [--scenes ...]
                                    [--cycles-dir DIR] [--out-dir DIR] [--quick]

The error is the harness's (cycles_efficiency.py): per pixel and channel (x - ref) /
(ref + 0.01), RMS over the image without the light panel (reference above 5). Times are
each renderer's own path-tracing clock: Cycles' from its log ('Sample 0' to 'Finished',
no start-up, import or BVH build), ours the 'Render time' line.

Cycles renders are cached in --cycles-dir/SCENE/ (the harness's file names). References
are kept whatever the machine was doing (only their pixels are used); a 16- or 64-spp
Cycles render whose log shows more than --busy of the CPU taken by other processes
(the harness's foreign_fraction) is rendered again, so the times compared come from a
quiet machine. Our renders are made every run. For each scene and spp the renderers take
turns seed by seed (Cycles, ours, the baseline, then the next seed), so that a drift of
the host falls on both sides of a ratio. Keep the machine otherwise idle.

Needs the study's packages (not in the quick start):
    apt-get install -y blender python3-numpy python3-openimageio
--quick: one scene at 4 and 8 spp against 64-spp references, to check the plumbing.
"""
import argparse
import hashlib
import json
import os
import re
import sys

import numpy as np
import OpenImageIO as oiio

from cycles_compare import run  # one way of running a render and keeping its log

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHARED = os.environ.get('PT_SHARED', os.path.join(ROOT, '..', 'shared'))
HARNESS = os.path.join(SHARED, 'peers', 'cycles')
SCENES = [os.path.join(SHARED, 'scenes/cs184', n + '.dae') for n in ('CBspheres_lambertian', 'CBbunny', 'CBgems')] + [
    os.path.join(ROOT, 'scenes/cornell_materials.dae')]


def read_rgb(path):
    img = oiio.ImageBuf(path)
    if img.has_error:
        sys.exit(f'{path}: {img.geterror()}')
    spec = img.spec()
    px = np.asarray(img.get_pixels(oiio.FLOAT)).reshape(spec.height, spec.width, spec.nchannels)
    names = list(spec.channelnames)
    idx = [names.index(c) for c in 'RGB'] if all(c in names for c in 'RGB') else [0, 1, 2]
    return px[:, :, idx].astype(np.float64)


def errors(img, ref):
    """(relative RMSE, plain RMSE) over the image without the light panel (ref above 5)."""
    keep = (ref.max(-1) < 5)[..., None].repeat(3, -1)
    e = ((img - ref) / (ref + 0.01))[keep]
    return float(np.sqrt(np.mean(e * e))), float(np.sqrt(np.mean((img - ref)[keep] ** 2)))


def rel_rmse(img, ref):
    return errors(img, ref)[0]


def agreement(ours_ref, cycles_ref, grid=4):
    """How far our reference's luminance lies from Cycles': (whole image, the region of a
    grid x grid split that differs most), each as ours / Cycles - 1. Two renderers of one
    scene agree to the references' noise (about 0.1 % at 1024 spp); a light that one of
    them drops shows up here, where each renderer's error against its own reference does
    not."""
    w = np.array([0.2126, 0.7152, 0.0722])
    lo, lc = ours_ref @ w, cycles_ref @ w
    h, wd = lc.shape
    worst = 0.0
    for j in range(grid):
        for i in range(grid):
            sl = (slice(j * h // grid, (j + 1) * h // grid), slice(i * wd // grid, (i + 1) * wd // grid))
            d = lo[sl].mean() / lc[sl].mean() - 1
            worst = d if abs(d) > abs(worst) else worst
    return lo.mean() / lc.mean() - 1, worst


def cycles(scene, spp, seed, a, reference=False):
    """(exr, path-tracing seconds) of a Cycles render, from the cache when usable."""
    name = os.path.basename(scene)[:-4]
    d = os.path.join(a.cycles_dir, name)
    os.makedirs(d, exist_ok=True)
    tag = f'cyc_{spp}' if reference else f'cyc_{spp}_{seed}'
    exr, js = os.path.join(d, tag + '.exr'), os.path.join(d, tag + '.json')
    if os.path.exists(exr) and os.path.exists(js):
        t = json.load(open(js))['timing']
        if reference or t['foreign_fraction'] <= a.busy:
            return exr, t['pt_wall_s']
    run(['/usr/bin/python3', os.path.join(HARNESS, 'cycles_run.py'), tag, '-t', str(a.threads), '--outdir', d, '--',
         '--scene', scene, '--bounces', '5', '--lights', 'mesh', '--camera', 'cs184', '--cs184-window', '800x600',
         '--spp', str(spp), '--seed', str(seed)], os.path.join(d, tag + '.stdout'))
    return exr, json.load(open(js))['timing']['pt_wall_s']


def binary_id(path):
    h = hashlib.sha1()
    with open(path, 'rb') as f:
        h.update(f.read())
    return h.hexdigest()[:10]


def ours(pt, label, scene, spp, seed, a, reference=False):
    """(exr, Render time seconds) of one of our renders; references are cached per binary."""
    name = os.path.basename(scene)[:-4]
    d = os.path.join(a.out_dir, name)
    os.makedirs(d, exist_ok=True)
    tag = f'{label}_ref_{spp}_{binary_id(pt)}' if reference else f'{label}_{spp}_{seed}'
    exr, out = os.path.join(d, tag + '.exr'), os.path.join(d, tag + '.out')
    if not (reference and os.path.exists(exr) and os.path.exists(out)):
        run([pt, '-q', '-r', '480', '360', '-l', '1', '-m', '6', '-t', str(a.threads), '--lights=mesh', '-s',
             str(spp), '--seed', str(seed), '-f', exr] + a.ours_args.split() + [scene], out)
    t = float(re.search(r'Render time ([0-9.]+)', open(out).read()).group(1))
    return exr, t


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--pathtracer', default=os.path.join(ROOT, 'build/tools/pathtracer'))
    ap.add_argument('--baseline', help='a second pathtracer binary measured the same way')
    ap.add_argument('--ours-args', default='', help='extra arguments for our renders (both binaries)')
    ap.add_argument('--scenes', nargs='+', default=SCENES)
    ap.add_argument('--spp', type=int, nargs='+', default=[16, 64])
    ap.add_argument('--seeds', type=int, nargs='+', default=[1, 2])
    ap.add_argument('--ref-spp', type=int, default=1024)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('--busy', type=float, default=0.1, help='largest foreign CPU fraction of a timed Cycles render')
    ap.add_argument('--cycles-dir', default='/tmp/cycles_efficiency/cycles')
    ap.add_argument('--out-dir', default='/tmp/cycles_efficiency/ours')
    ap.add_argument('--no-cycles', action='store_true',
                    help='ours (and --baseline) only, for scenes the harness cannot import')
    ap.add_argument('--quick', action='store_true')
    a = ap.parse_args()
    if a.quick:
        a.scenes, a.spp, a.seeds, a.ref_spp = a.scenes[:1], [4, 8], [1], 64
        a.cycles_dir += '_quick'
    if not a.no_cycles and not os.path.isdir(HARNESS):
        print(f'cycles_efficiency: {HARNESS} not found; skipped')
        return 77
    bins = [('ours', a.pathtracer)] + ([('baseline', a.baseline)] if a.baseline else [])
    print(f'480x360, course framing, 5 bounces (ours -m 6), {a.threads} threads, --lights=mesh; '
          f'relRMSE against each renderer\'s own {a.ref_spp}-spp reference; eff = 1 / (relRMSE^2 t); '
          f'means over seeds {a.seeds}' + (f'; ours with {a.ours_args}' if a.ours_args else ''))
    cyc = not a.no_cycles
    head = '| scene | spp |' + (' Cycles t s | relRMSE | eff |' if cyc else '') + ''.join(
        f' {l} t s | relRMSE | eff |' + (f' {l} / Cycles |' if cyc else '') for l, _ in bins) + (
            ' ours / baseline |' if a.baseline else '')
    print(head)
    print('|' + '---|' * (head.count('|') - 1))
    agree = []
    for scene in a.scenes:
        name = os.path.basename(scene)[:-4]
        refs = {'cycles': read_rgb(cycles(scene, a.ref_spp, 99, a, reference=True)[0])} if cyc else {}
        for label, pt in bins:
            refs[label] = read_rgb(ours(pt, label, scene, a.ref_spp, 99, a, reference=True)[0])
        if cyc:
            agree.append((name, *agreement(refs['ours'], refs['cycles'])))
        for spp in a.spp:
            whos = (['cycles'] if cyc else []) + [l for l, _ in bins]
            ts, es = {w: [] for w in whos}, {w: [] for w in whos}
            # Seed by seed, each renderer in turn, so that the host's drift falls on both
            # sides of a ratio alike rather than on one renderer's block of renders.
            for seed in a.seeds:
                for who in whos:
                    exr, t = cycles(scene, spp, seed, a) if who == 'cycles' else ours(dict(bins)[who], who, scene, spp,
                                                                                      seed, a)
                    ts[who].append(t)
                    es[who].append(rel_rmse(read_rgb(exr), refs[who]))
            # As the harness averages: the mean of each render's efficiency.
            stats = {w: (float(np.mean(ts[w])), float(np.mean(es[w])),
                         float(np.mean([1.0 / (e * e * t) for e, t in zip(es[w], ts[w])]))) for w in whos}
            c = stats.get('cycles')
            row = f'| {name} | {spp} |' + (f' {c[0]:.2f} | {c[1]:.4f} | {c[2]:.1f} |' if c else '')
            for label, _ in bins:
                s = stats[label]
                row += f' {s[0]:.2f} | {s[1]:.4f} | {s[2]:.1f} |' + (f' **{s[2] / c[2]:.2f}** |' if c else '')
            if a.baseline:
                row += f' {stats["ours"][2] / stats["baseline"][2]:.2f} |'
            print(row, flush=True)
    if agree:
        # The ratios compare one scene only if both renderers drew the same one.
        print(f'\nReferences ({a.ref_spp} spp), luminance ours / Cycles - 1:\n'
              '| scene | whole image | the region (4x4) that differs most |\n|---|---:|---:|')
        for name, whole, worst in agree:
            flag = ' **not the same scene?**' if abs(worst) > 0.02 else ''
            print(f'| {name} | {100 * whole:+.2f} % | {100 * worst:+.2f} %{flag} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
