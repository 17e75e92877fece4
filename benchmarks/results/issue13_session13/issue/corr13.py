"""corr13.py LOG: in exp13c.sh's sets on two cores, how often our kernel and the wide loop were slow
(< 0.85 of their own medians) in the same row, against apart."""
import statistics as st,collections
import os,sys
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
from corun_log import read_sets, two_core_medians
rows=[r for a,b,c in read_sets(sys.argv[1]) if a>=1.8 and b>=1.8 for r in c]
med={}
for m in ['none','pause']:
    for k in rows[0][1]:
        med[(m,k)]=st.median([v[k] for mm,v in rows if mm==m])
for kind in ['camera','diffuse']:
  for loop in ['ipc:wide','ipc:wide2','ipc:narrow']:
    c=collections.Counter()
    for m,v in rows:
        o=v[f'custom:sah:fast:{kind}']<0.85*med[(m,f'custom:sah:fast:{kind}')]
        l=v[loop]<0.85*med[(m,loop)]
        c[(o,l)]+=1
    print(f"{kind:8s} ours slow & {loop:10s} slow: {c[(True,True)]:3d}, ours only: {c[(True,False)]:3d}, {loop} only: {c[(False,True)]:3d}, neither: {c[(False,False)]:3d}")
