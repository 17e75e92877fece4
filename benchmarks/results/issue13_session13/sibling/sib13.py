"""sib13.py LOG: exp13.sh's sets that began and ended while the host ran both vCPUs on one core
(both probes < 1.4), each rate relative to the same variant+mode's median over sets on two cores
(both probes >= 1.8). With a pause loop on vCPU 1 then, ours and Embree share a core with an
active sibling thread; 'none' leaves it idle."""
import statistics as st,collections
import os,sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
from corun_log import read_sets, two_core_medians
it=read_sets(sys.argv[1])
two=[c for a,b,c in it if a>=1.8 and b>=1.8]; one=[c for a,b,c in it if a<1.4 and b<1.4]
N=two_core_medians(it)
print(f"{len(two)} sets on two cores, {len(one)} on one core (of {len(it)})")
for k,v in sorted(N.items()): print(f"  two-core median {k[0]:16s} {k[1]:28s} {v:6.2f}")
R=collections.defaultdict(list)
for c in one:
    for m,v in c:
        for k,x in v.items(): R[(m,k)].append(x/N[(m,k)])
print("one core: median (min-max) of rate / two-core median")
for kind in ['camera','diffuse']:
    for m in sorted({m for m,_ in R}):
        o=R[(m,f'custom:sah:fast:{kind}')]; e=R[(m,f'embree:high:{kind}')]
        if o: print(f"  {kind:8s} {m:16s} ours {st.median(o):.2f} ({min(o):.2f}-{max(o):.2f})  Embree {st.median(e):.2f} ({min(e):.2f}-{max(e):.2f})  n={len(o)}")
