"""lfence.py: one thread, Mrays/s with an lfence before every ray in renderer::trace_set_into
(c_lfence_*) against the same code without it (c_wideonly_*, fb58701); 3 alternating runs each,
medians. lfence lets no later instruction start until every earlier one has completed, so the
next ray's work cannot overlap the end of this one's: what each kernel loses is what it gains
from the out-of-order window overlapping consecutive rays."""
import csv,glob,statistics as st,collections
r=collections.defaultdict(list)
for v in ['wideonly','lfence']:
    for f in glob.glob(f'c_{v}_*.csv'):
        for row in csv.DictReader(open(f)):
            r[(row['backend'],row['ray_kind'],row['scene'],v)].append(float(row['mrays_per_s']))
for c in sorted({k[:3] for k in r}):
    a=st.median(r[c+('wideonly',)]); b=st.median(r[c+('lfence',)])
    print(f"{' '.join(c):45s} {a:6.2f} -> {b:6.2f} Mrays/s  x{b/a:.3f}")
