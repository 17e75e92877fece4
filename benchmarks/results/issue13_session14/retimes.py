"""retimes.py ERR...: per accel_bench --wait-for-cores log, the rounds timed again and the rounds kept on their
last attempt although the check after it failed. Logs of fa0d556 print "timed again" for every failed check, the
kept last attempt's too (a round with three such lines kept its third); later logs print it only for the attempts
set aside and mark the kept one "the last attempt, kept"."""
import sys, re, collections
for f in sys.argv[1:]:
    n = collections.Counter(); kept_marked = 0; embree = 0
    for l in open(f):
        m = re.match(r'(\[accel_bench\] .*, round \d+): .*timed again', l)
        if m: n[m.group(1)] += 1
        if 'the last attempt, kept' in l: kept_marked += 1
    again = sum(min(v, 2) for v in n.values())
    kept_failed = sum(1 for v in n.values() if v >= 3) + kept_marked
    embree = sum(min(v, 2) for k, v in n.items() if 'embree' in k)
    print(f"{f}: {again} attempts timed again ({embree} of them Embree's) over {len(n)} rounds; "
          f"{kept_failed} rounds kept on a last attempt that ended below full issue")
