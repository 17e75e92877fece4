"""slow.py ERR...: accel_bench's per-round stderr lines (session 12). For each cell (scene,
rays, CPU) of each run, the 1-thread rounds in which ours (custom:sah:fast, auto ISA) ran
more than 15 % below its fastest round of that cell, and the median loss of every backend
in those same rounds (traced tens of ms apart); then how often each backend was that slow."""
import re,glob,collections,statistics as st,sys
pat=re.compile(r"\[accel_bench\] (\S+) (\w+) (\S+), (\d) threads?( alone on CPU 1)?, round (\d+): ([0-9.]+) Mrays/s")
files=sys.argv[1:]
bes=None
per=collections.defaultdict(list); cnt=collections.Counter()
for f in files:
    d=collections.defaultdict(lambda: collections.defaultdict(dict))
    for line in open(f):
        m=pat.match(line)
        if m:
            sc,kind,be,t,alone,r,rate=m.groups()
            if t=='1': d[(sc,kind,1 if alone else 0)][be][int(r)]=float(rate)
    for key,bb in d.items():
        bes=sorted(bb)
        rel={be:{r:v/max(bb[be].values()) for r,v in bb[be].items()} for be in bes}
        for be in bes:
            for r,x in rel[be].items():
                cnt[key[0]+' '+key[1],be,'n']+=1; cnt[key[0]+' '+key[1],be,'slow']+=x<0.85
        lead=[b for b in bes if b.startswith('custom:sah:fast')][0]
        for r in rel[lead]:
            if rel[lead][r]<0.85:
                per[key[0]+' '+key[1]].append({be:1-rel[be].get(r,1) for be in bes})
for k,v in sorted(per.items()):
    print(f"{k:24s} {len(v):3d} slow rounds of ours; median loss:", ' '.join(f"{be} {100*st.median([x[be] for x in v]):.0f}%" for be in v[0]))
cells=sorted(set((c,b) for c,b,_ in cnt))
for c,b in cells: print(f"  {c:22s} {b:22s} slow {cnt[c,b,'slow']}/{cnt[c,b,'n']}")
