import csv,sys,glob,re
def key(f): return int(re.findall(r'run(\d+)',f)[0])
tot=[0,0,0]
for f in sorted(glob.glob(sys.argv[1]),key=key):
    m={}
    for x in csv.DictReader(open(f)): m[(x['scene'],x['backend'],x['ray_kind'],x['threads'])]=x
    raw={'o':[],'e':[]}; full={'o':[],'e':[]}; miss=[]; probe=[]
    for (sc,bk,k,t),x in m.items():
        if t!='2': continue
        w='e' if bk.startswith('embree') else 'o'
        s=float(x['mrays_per_s'])/float(m[(sc,bk,k,'1')]['mrays_per_s'])
        raw[w].append(s); probe.append(float(x['machine_scaling']))
        if x['scaling_full_rounds']: full[w].append((float(x['scaling_full_rounds']),int(x['full_rounds'])))
        if w=='o' and s<1.8: miss.append(f"{sc[:6]} {k[:3]} {s:.2f} (probe {float(x['machine_scaling']):.2f}, full {x['full_rounds']}: {x['scaling_full_rounds']})")
    fo=[a for a,n in full['o']]
    print(f"{f.split('/')[-1]}: ours {min(raw['o']):.2f}-{max(raw['o']):.2f}, {sum(s>=1.8 for s in raw['o'])}/{len(raw['o'])} >=1.8; embree {min(raw['e']):.2f}-{max(raw['e']):.2f} ({sum(s>=1.8 for s in raw['e'])}/{len(raw['e'])}); full rounds ours {sum(a>=1.8 for a in fo)}/{len(fo)} >=1.8 (lowest {min(fo) if fo else float('nan'):.2f}); probe {min(probe):.2f}-{max(probe):.2f}")
    for x in miss: print("    miss:",x)
