"""corr13.py LOG: in exp13c.sh's sets on two cores, how often our kernel and the wide loop were slow
(< 0.85 of their own medians) in the same row, against apart."""
import statistics as st,collections,sys
rows=[];cur=[];it=[]
for line in open(sys.argv[1]):
    w=line.split()
    if w[0]=='probe':
        a=[float(x) for x in w[1:4]]; b=[float(x) for x in w[5:8]]
        if st.median(a)>=1.8 and st.median(b)>=1.8: rows+=cur
        cur=[]
    else:
        cur.append((w[1],{t.rsplit(':',1)[0]:float(t.rsplit(':',1)[1]) for t in w[2:]}))
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
