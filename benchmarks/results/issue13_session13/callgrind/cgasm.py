"""cgasm.py CALLGRIND_OUT FUNC_SUBSTR BINARY: per-instruction Ir of one function (self cost),
joined with objdump's disassembly, hottest basic blocks first."""
import sys, re, subprocess, collections
out, pat, binary = sys.argv[1:4]
ir = collections.Counter(); infn = False; addr = 0; skip = False
def rel(tok, cur):
    if tok == '*': return cur
    if tok[0] in '+-': return cur + int(tok)
    return int(tok, 16) if tok.startswith('0x') else int(tok)
line = 0
names = {}
for l in open(out):
    if l.startswith(('fn=', 'cfn=')):
        m = re.match(r'c?fn=\((\d+)\)\s*(.*)', l)
        if m and m.group(2).strip(): names[m.group(1)] = m.group(2)
    if l.startswith('fn='):
        infn = m is not None and pat in names.get(m.group(1), ''); continue
    if l.startswith('calls='): skip = True; continue
    if not infn or not l[0] in '0123456789+-*': continue
    w = l.split()
    a = rel(w[0], addr); addr = a
    if skip: skip = False; continue
    if len(w) >= 3: ir[a] += int(w[2])
lo, hi = min(ir), max(ir)
dis = subprocess.run(['objdump', '-d', '--no-show-raw-insn', '-M', 'intel', f'--start-address={lo}', f'--stop-address={hi+16}', binary], capture_output=True, text=True).stdout
n = int(sys.argv[4]) if len(sys.argv) > 4 else 1
tot = sum(ir.values())
print(f"total {tot} Ir, per call {tot/n:.1f}")
for d in dis.splitlines():
    m = re.match(r'\s*([0-9a-f]+):\s*(.*)', d)
    if m:
        a = int(m.group(1), 16); c = ir.get(a, 0)
        print(f"{c/n:8.2f}  {m.group(2)}")
# store summary: instructions whose destination is memory (first operand a PTR), prefetches excluded
st = 0.0; ld = 0.0
for d in dis.splitlines():
    m = re.match(r'\s*([0-9a-f]+):\s*(\S+)\s+(.*)', d)
    if not m: continue
    c = ir.get(int(m.group(1), 16), 0) / n
    op, args = m.group(2), m.group(3)
    if op.startswith('prefetch') or op.startswith('nop') or op == 'lea': continue
    if re.match(r'\w*\s*PTR \[', args) and ',' in args: st += c
    elif 'PTR [' in args: ld += c
print(f"stores per call {st:.1f}, other memory-operand instructions per call {ld:.1f}")
