#!/usr/bin/python3
"""Region means of our renders against Blender Cycles, in both light semantics.

For each scene and light model, renders the course's 480x360 framing with our pathtracer
and with Cycles (the harness in ../shared/peers/cycles), then prints, per region and
channel, both means and their relative difference. Regions: a 4x3 grid of 120x120
blocks (row-major from the top left) and the whole image.

    benchmarks/cycles_compare.py [--spp-ours 256] [--spp-cycles 256] [--threads 1]
                                 [--cycles-dir DIR] [--quick]

Needs the study's packages (not in the quick start):
    apt-get install -y blender python3-numpy python3-openimageio
Cycles renders are cached in --cycles-dir (NAME.exr, NAME.json) and reused when their
settings match (at least --spp-cycles); ours are re-rendered each run. At 256 spp the
Monte Carlo error of a 120x120 region mean is about 0.2% on either side (the harness:
~0.1% at 1024 spp), well below the 2% being checked. Model mapping (the harness's README):
    ours --lights=mesh   <-> harness --lights mesh
    ours --lights=course <-> harness --lights cs184
    ours -m B+1          <-> harness --bounces B
Our side uses light sampling (-l 1); in mesh semantics -H converges to the same image.
--quick: 2 scenes x 2 models at a few spp, to check the plumbing (MC error > 2%).
Exit status 1 when a region differs by more than --tol (default 2%) in any channel.
"""
import argparse
import json
import os
import subprocess
import sys

import numpy as np
import OpenImageIO as oiio

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SHARED = os.environ.get('PT_SHARED', os.path.join(ROOT, '..', 'shared'))
SCENES = ('CBspheres_lambertian', 'CBbunny')
MODELS = (('mesh', 'mesh'), ('course', 'cs184'))  # ours, harness
W, H = 480, 360
GRID_X, GRID_Y = 4, 3


def read_rgb(path):
    img = oiio.ImageBuf(path)
    if img.has_error:
        sys.exit(f'{path}: {img.geterror()}')
    px = img.get_pixels(oiio.FLOAT)
    return np.asarray(px)[:, :, :3].astype(np.float64)


def regions(rgb):
    """[(name, mean RGB)] over the grid blocks and the whole image."""
    h, w, _ = rgb.shape
    out = []
    for gy in range(GRID_Y):
        for gx in range(GRID_X):
            block = rgb[gy * h // GRID_Y:(gy + 1) * h // GRID_Y, gx * w // GRID_X:(gx + 1) * w // GRID_X]
            out.append((f'r{gy}c{gx}', block.reshape(-1, 3).mean(axis=0)))
    out.append(('whole', rgb.reshape(-1, 3).mean(axis=0)))
    return out


def run(cmd, log):
    print('+ ' + ' '.join(cmd), file=sys.stderr, flush=True)
    with open(log, 'w') as f:
        p = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT)
    if p.returncode != 0:
        sys.exit(f'failed (status {p.returncode}); see {log}')


def cycles(scene, harness_lights, a):
    name = f'{scene}_{harness_lights}'
    exr, js = (os.path.join(a.cycles_dir, name + ext) for ext in ('.exr', '.json'))
    if os.path.exists(exr) and os.path.exists(js):
        args = json.load(open(js))['args']
        if args['spp'] >= a.spp_cycles and args['bounces'] == a.bounces and args['lights'] == harness_lights:
            return exr
    run(['python3', os.path.join(SHARED, 'peers/cycles/cycles_run.py'), name, '-t', str(a.threads),
         '--outdir', a.cycles_dir, '--', '--scene', os.path.join(SHARED, 'scenes/cs184', scene + '.dae'),
         '--spp', str(a.spp_cycles), '--bounces', str(a.bounces), '--lights', harness_lights,
         '--camera', 'cs184', '--cs184-window', '800x600'], os.path.join(a.cycles_dir, name + '.run.log'))
    return exr


def course_hfov(scene):
    """The course's 480x360 horizontal fov (scenes README, "Window size"): its 800x600 view
    keeps xfov when the file is wider than 800:600, else the vertical fov; 480x360 is
    the central crop."""
    import math
    import xml.etree.ElementTree as ET
    ns = '{http://www.collada.org/2005/11/COLLADASchema}'
    p = ET.parse(os.path.join(SHARED, 'scenes/cs184', scene + '.dae')).find(f'.//{ns}perspective')
    tx = math.tan(math.radians(float(p.find(f'{ns}xfov').text)) / 2)
    y, r = p.find(f'{ns}yfov'), p.find(f'{ns}aspect_ratio')
    ty = math.tan(math.radians(float(y.text)) / 2) if y is not None else tx / float(r.text)
    t800 = tx if tx / ty > 800 / 600 else ty * 800 / 600
    return math.degrees(2 * math.atan(t800 * W / 800))


def ours(scene, model, a):
    out = os.path.join(a.out_dir, f'{scene}_{model}.exr')
    fov = ['--fov', f'{course_hfov(scene):.4f}'] if a.fov_from_rule else []
    run([a.pathtracer, '-q', '-r', str(W), str(H), '-s', str(a.spp_ours), '-l', '1', '-m', str(a.bounces + 1),
         '-t', str(a.threads), '--lights', model, '--camera', 'course', '-f', out] + fov + [
         os.path.join(SHARED, 'scenes/cs184', scene + '.dae')], out[:-4] + '.log')
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('--pathtracer', default=os.path.join(ROOT, 'build/tools/pathtracer'))
    ap.add_argument('--spp-ours', type=int, default=256)
    ap.add_argument('--spp-cycles', type=int, default=256)
    ap.add_argument('--bounces', type=int, default=4, help='indirect bounces (ours: -m BOUNCES+1)')
    ap.add_argument('--threads', type=int, default=1)
    ap.add_argument('--cycles-dir', default='/tmp/cycles_compare/cycles')
    ap.add_argument('--out-dir', default='/tmp/cycles_compare/ours')
    ap.add_argument('--tol', type=float, default=0.02)
    ap.add_argument('--quick', action='store_true')
    ap.add_argument('--scenes', nargs='+', default=list(SCENES))
    ap.add_argument('--models', nargs='+', default=[m for m, _ in MODELS], choices=[m for m, _ in MODELS])
    ap.add_argument('--fov-from-rule', action='store_true',
                    help="pass our renderer the course's 480x360 hfov computed here (--fov), "
                         "instead of relying on its own course framing")
    a = ap.parse_args()
    if a.quick:
        a.spp_ours, a.spp_cycles = 4, 4
        a.cycles_dir += '_quick'
        a.tol = 1.0
    os.makedirs(a.cycles_dir, exist_ok=True)
    os.makedirs(a.out_dir, exist_ok=True)
    print(f'480x360, course framing; ours {a.spp_ours} spp -m {a.bounces + 1} -l 1, '
          f'Cycles {a.spp_cycles} spp --bounces {a.bounces}; rel = ours / Cycles - 1')
    print(f'| scene | lights | region | ours R G B | Cycles R G B | rel R | rel G | rel B |')
    print('|---|---|---|---|---|---:|---:|---:|')
    worst = 0.0
    for scene in a.scenes:
        for model, harness in MODELS:
            if model not in a.models:
                continue
            ro = regions(read_rgb(ours(scene, model, a)))
            rc = regions(read_rgb(cycles(scene, harness, a)))
            for (name, mo), (_, mc) in zip(ro, rc):
                rel = mo / np.maximum(mc, 1e-12) - 1.0
                worst = max(worst, float(np.max(np.abs(rel))))
                print(f'| {scene} | {model} | {name} | {mo[0]:.4f} {mo[1]:.4f} {mo[2]:.4f} | '
                      f'{mc[0]:.4f} {mc[1]:.4f} {mc[2]:.4f} | {100 * rel[0]:+.2f}% | {100 * rel[1]:+.2f}% | '
                      f'{100 * rel[2]:+.2f}% |', flush=True)
    print(f'largest |rel| {100 * worst:.2f}% (tolerance {100 * a.tol:g}%)')
    return 0 if worst <= a.tol else 1


if __name__ == '__main__':
    sys.exit(main())
