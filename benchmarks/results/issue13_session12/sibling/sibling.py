"""sibling.py LOG: exp.sh's iterations that began while the host ran both vCPUs on one
core (probe before < 1.4). Each row's rates relative to the same co-runner's median over
the iterations on two cores (both probes >= 1.8). 'none' leaves vCPU 1 idle; the others
run a co-runner there, which in those moments is the sibling hardware thread of ours."""
import statistics as st,collections
import os,sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
from corun_log import read_sets, two_core_medians
it=read_sets(sys.argv[1])
N=two_core_medians(it)
keys=['custom:sah:fast:camera','embree:high:camera','custom:sah:fast:diffuse','embree:high:diffuse']
print(f"{sum(a>=1.8 and b>=1.8 for a,b,_ in it)} iterations on two cores; columns: ours camera, Embree camera, ours diffuse, Embree diffuse")
low=collections.defaultdict(list)
for a,b,c in it:
    if a<1.4:
        print(f"probe {a:.2f}->{b:.2f}: " + ' | '.join(f"{m}: " + ' '.join(f"{c2[k]/N[(m,k)]:.2f}" for k in keys) for m,c2 in c))
        for m,c2 in c:
            for k in keys: low[(m,k)].append(c2[k]/N[(m,k)])
# rows hit by the sibling: ours below 0.8 in that cell
print("\nrows where ours fell below 0.80 of its two-core median, and Embree in the same row:")
for m in sorted({m for m,_ in low}):
    for kind in ['camera','diffuse']:
        pairs=[(o,e) for o,e in zip(low[(m,f'custom:sah:fast:{kind}')],low[(m,f'embree:high:{kind}')]) if o<0.8]
        if pairs: print(f"  {m:6s} {kind:8s} {len(pairs)} rows: ours {min(p[0] for p in pairs):.2f}-{max(p[0] for p in pairs):.2f}, Embree {min(p[1] for p in pairs):.2f}-{max(p[1] for p in pairs):.2f}")
