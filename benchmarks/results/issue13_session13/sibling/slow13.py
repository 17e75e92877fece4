"""slow13.py LOG: over sets on two cores (both probes >= 1.8), how often each kernel traced
below 0.85 of its own median (the host's slow state), per variant and mode, and its median
rate then."""
import statistics as st,collections,sys
it=[];cur=[]
for line in open(sys.argv[1]):
    w=line.split()
    if not w: continue
    if w[0]=='probe':
        a=[float(x) for x in w[1:4]]; b=[float(x) for x in w[5:8]]
        it.append((st.median(a),st.median(b),cur)); cur=[]
    else:
        vals={}
        for t in w[2:]:
            p=t.rsplit(':',1); vals[p[0]]=float(p[1])
        cur.append((w[1],vals))
two=[c for a,b,c in it if a>=1.8 and b>=1.8]
V=collections.defaultdict(list)
for c in two:
    for m,v in c:
        for k,x in v.items(): V[(m,k)].append(x)
for (m,k),xs in sorted(V.items()):
    med=st.median(xs); lo=[x/med for x in xs if x<0.85*med]
    print(f"{m:16s} {k:28s} n={len(xs)} slow {len(lo):3d} ({100*len(lo)/len(xs):4.1f}%) median when slow {st.median(lo) if lo else float('nan'):.2f}")
