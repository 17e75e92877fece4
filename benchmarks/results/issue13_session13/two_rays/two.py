"""two.py: one thread, Mrays/s, branch exp/two-rays (its one commit). e_*: no lfence, f_*: an lfence
before every call to the backend; 'one' = one ray per call (intersect), 'two' = PT_TWO_RAYS=1, two rays per
call (intersect2: ours interleaves them, Embree's default makes two calls). 2 alternating runs each, medians."""
import csv,glob,statistics as st,collections
r=collections.defaultdict(list)
for tag in ['e','f']:
    for v in ['one','two']:
        for f in glob.glob(f'{tag}_{v}_*.csv'):
            for row in csv.DictReader(open(f)):
                r[(row['backend'],row['ray_kind'],row['scene'],tag+v)].append(float(row['mrays_per_s']))
print("cell: no lfence one, two | lfence per call one, two | lfence cost one, two")
for c in sorted({k[:3] for k in r}):
    m={v:st.median(r[c+(v,)]) for v in ['eone','etwo','fone','ftwo']}
    print(f"{' '.join(c):40s} {m['eone']:6.2f} {m['etwo']:6.2f} | {m['fone']:6.2f} {m['ftwo']:6.2f} | x{m['fone']/m['eone']:.3f} x{m['ftwo']/m['etwo']:.3f}")
