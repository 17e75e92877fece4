# Reads the folder benchmarks/sampler_study.sh wrote: per scene and configuration (sampler,
# roulette), relative RMSE against the 1024-spp reference (the light panel, ref > 5, left
# out; (img - ref) / (ref + 0.01), as ../shared/peers/cycles/cycles_efficiency.py), plain
# RMSE, 'Render time', and efficiency 1 / (relRMSE^2 t), means over seeds 1 and 2.
#   /usr/bin/python3 benchmarks/sampler_study.py FOLDER
import numpy as np, re, sys, glob, os

from cycles_efficiency import errors, read_rgb as rgb  # the same error as the Cycles comparison
O = sys.argv[1] if len(sys.argv) > 1 else '.'


def t_and_rays(f):
    s = open(f).read()
    t = float(re.search(r'Render time ([0-9.]+)', s).group(1))
    return t


for refp in sorted(glob.glob(os.path.join(O, '*_ref.exr'))):
    scene = os.path.basename(refp)[:-len('_ref.exr')]
    ref = rgb(refp)
    configs = sorted({re.match(rf'{scene}_(.+)_(16|64)_\d+\.exr', os.path.basename(p)).group(1)
                      for p in glob.glob(os.path.join(O, f'{scene}_*_*_*.exr')) if not p.endswith('_ref.exr')})
    print(f'== {scene}: 480x360, --lights=mesh -l 1 -m 6 -t 2; vs own 1024-spp reference (sobol)')
    print(f'{"config":32s} {"spp":>4s} {"t (s)":>7s} {"relRMSE":>8s} {"RMSE":>8s} {"eff":>8s} {"eff/indep":>9s}')
    for spp in (16, 64):
        base = None
        rows = []
        for c in configs:
            r = []
            for seed in (1, 2):
                p = os.path.join(O, f'{scene}_{c}_{spp}_{seed}')
                e, a = errors(rgb(p + '.exr'), ref)
                r.append((t_and_rays(p + '.out'), e, a))
            t, e, a = (float(np.mean([x[i] for x in r])) for i in range(3))
            eff = 1 / (e * e * t)
            if c == 'independent_rrthroughput':
                base = eff
            rows.append((c, t, e, a, eff))
        for c, t, e, a, eff in rows:
            print(f'{c:32s} {spp:4d} {t:7.2f} {e:8.4f} {a:8.5f} {eff:8.2f} {eff / base if base else float("nan"):9.2f}')
