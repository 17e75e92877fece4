"""cmpv.py TAG VARIANTS...: per backend, median ratio_to_embree of each cell per variant"""
import csv,sys,glob,statistics as st,collections
tag=sys.argv[1]; vs=sys.argv[2:]
r=collections.defaultdict(list)
for v in vs:
    for f in glob.glob(f'{tag}_{v}_*.csv'):
        for row in csv.DictReader(open(f)):
            if row['backend'].startswith('embree') or row['threads']!='1': continue
            r[(row['backend'],row['ray_kind'],row['scene'],v)].append(float(row['ratio_to_embree']))
cells=sorted({k[:3] for k in r})
print('cell'.ljust(40)+''.join(v.rjust(10) for v in vs))
g=collections.defaultdict(list)
for c in cells:
    base=st.median(r[c+(vs[0],)])
    print(' '.join(c).ljust(40)+''.join(f"{st.median(r[c+(v,)]):10.2f}" for v in vs))
    for v in vs: g[v].append(st.median(r[c+(v,)])/base)
print('median vs first'.ljust(40)+''.join(f"{st.median(g[v]):10.3f}" for v in vs))
