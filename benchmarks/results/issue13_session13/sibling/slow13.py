"""slow13.py LOG: over sets on two cores (both probes >= 1.8), how often each kernel traced
below 0.85 of its own median (the host's slow state), per variant and mode, and its median
rate then."""
import statistics as st,collections
import os,sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
from corun_log import read_sets, two_core_medians
two=[c for a,b,c in read_sets(sys.argv[1]) if a>=1.8 and b>=1.8]
V=collections.defaultdict(list)
for c in two:
    for m,v in c:
        for k,x in v.items(): V[(m,k)].append(x)
for (m,k),xs in sorted(V.items()):
    med=st.median(xs); lo=[x/med for x in xs if x<0.85*med]
    print(f"{m:16s} {k:28s} n={len(xs)} slow {len(lo):3d} ({100*len(lo)/len(xs):4.1f}%) median when slow {st.median(lo) if lo else float('nan'):.2f}")
