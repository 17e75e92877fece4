#!/bin/bash
# Whether the custom BVH's opaque traversal kernels compile to the same instructions in two
# builds: every traverse/occlude instantiation and Kernel method of BASE_BUILD's kernel
# objects, against its opaque (Masked = false) counterpart in NEW_BUILD's, disassembled
# with addresses and symbol names stripped. Prints per ISA how many are identical, how
# many differ only in memory displacements (a member's offset), and each that differs.
#
#   benchmarks/same_kernel_code.sh BASE_BUILD NEW_BUILD
#   e.g. git archive b367b7e | tar -x -C /tmp/base && cmake -S /tmp/base -B /tmp/base/build
#        -G Ninja -DCMAKE_BUILD_TYPE=Release && ninja -C /tmp/base/build accel_bvh, then
#        benchmarks/same_kernel_code.sh /tmp/base/build build
BASE=$1; NEW=$2; W=$(mktemp -d); trap 'rm -rf $W' EXIT
for isa in sse2 avx2 avx512; do
B=$BASE/accel/CMakeFiles/accel_bvh.dir/bvh/kernel_$isa.cpp.o; N=$NEW/accel/CMakeFiles/accel_bvh.dir/bvh/kernel_$isa.cpp.o
nm $B | grep -E "traverse|occlude|6Kernel" | awk '{print $3}' > $W/bsyms; nm $N | grep -E "traverse|occlude|6Kernel" | grep -v Masked | awk '{print $3}' > $W/nsyms
W=$W python3 - <<'PY'
import subprocess,re
import os
W=os.environ['W']
b=open(W+'/bsyms').read().split(); n=open(W+'/nsyms').read().split()
def dem(s): return subprocess.run(['c++filt',s],capture_output=True,text=True).stdout.strip()
def key(s):
    # The opaque traversals' empty filter argument (kernel.h, NoFilter) is no instruction.
    d=re.sub(r', accel::bvh::\w+::NoFilter','',dem(s))
    d=re.sub(r'\(accel::bvh::WideBvh const&, accel::Ray const&, accel::TraceStats&(, accel::GeometryView const\*)?\)','(ARGS)',d)
    d=re.sub(r'(true|false), (true|false), false>\(ARGS\)',r'\1, \2>(ARGS)',d); return d.replace(" [clone .constprop.0]","")
bk={key(s):s for s in b}; nk={key(s):s for s in n}
open(W+'/pairs','w').write('\n'.join(f"{bk[k]} {nk[k]}" for k in bk if k in nk)+'\n')
PY
norm() { objdump -d --no-show-raw-insn --disassemble=$1 $2 | sed -n '/^[0-9a-f]* </,$p' | tail -n +2 | sed -E 's/^ *[0-9a-f]+:\s*//; s/[0-9a-f]+ <[^>+]*(\+0x[0-9a-f]+)?>/ADDR\1/g'; }
same=0; disp=0; differ=0
while read bs ns; do norm $bs $B > $W/b.s; norm $ns $N > $W/n.s
  name=$(c++filt $bs | sed 's/accel::bvh::[a-z0-9]*:://g; s/(anonymous namespace):://g' | cut -c1-100)
  if cmp -s $W/b.s $W/n.s; then same=$((same+1))
  elif cmp -s <(sed -E 's/0x[0-9a-f]+\(/D(/g' $W/b.s) <(sed -E 's/0x[0-9a-f]+\(/D(/g' $W/n.s); then disp=$((disp+1)); echo "  displacement only: $name"
  else differ=$((differ+1)); echo "  differs ($(diff $W/b.s $W/n.s | grep -c '^<') of $(wc -l < $W/b.s) lines): $name"; fi
done < $W/pairs
echo "$isa: $((same+disp+differ)) functions: identical=$same identical-but-displacement=$disp differ=$differ"
done
