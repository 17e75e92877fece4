"""Reader for the co-runner experiment logs of issue 13 (sessions 12-13: exp.sh, exp13*.sh):
rows "TIME LABEL name:kind:rate ..." then, per set, "probe B1 B2 B3 | A1 A2 A3" (the machine
probe's readings before and after the set)."""
import statistics as st


def read_sets(path):
    """[(median probe before, median probe after, [(label, {name:kind: rate})])], one per set."""
    sets, cur = [], []
    for line in open(path):
        w = line.split()
        if not w:
            continue
        if w[0] == 'probe':
            a = [float(x) for x in w[1:4]]
            b = [float(x) for x in w[5:8]]
            sets.append((st.median(a), st.median(b), cur))
            cur = []
        else:
            cur.append((w[1], {t.rsplit(':', 1)[0]: float(t.rsplit(':', 1)[1]) for t in w[2:]}))
    return sets


def two_core_medians(sets):
    """Each label's and series' median rate over the sets whose probes read two cores before and after."""
    by = {}
    for a, b, rows in sets:
        if a >= 1.8 and b >= 1.8:
            for label, vals in rows:
                for k, x in vals.items():
                    by.setdefault((label, k), []).append(x)
    return {k: st.median(v) for k, v in by.items()}
