#!/bin/bash
# Error at equal samples per sampler (--sampler) and roulette (--rr), on the course's
# framing at 480x360, --lights=mesh, -l 1 -m 6 (5 bounces), 2 threads: 16 and 64 spp,
# seeds 1 and 2, against our own 1024-spp reference (sobol, seed 99), as the Cycles
# harness (../shared/peers/cycles/cycles_efficiency.sh) measures.
#   PT=build/tools/pathtracer O=out/samplers benchmarks/sampler_study.sh SCENE.dae...
# then:  /usr/bin/python3 benchmarks/sampler_study.py $O   (needs python3-openimageio)
PT=${PT:?set PT to the built pathtracer}; O=${O:?set O to an output folder}; mkdir -p "$O"
ARGS="-q -r 480 360 -l 1 -m 6 -t 2 --lights=mesh"
CONFIGS=${CONFIGS:-"independent:throughput independent:0.65 stratified:throughput sobol:throughput zsobol:throughput pmj02:throughput"}
for S in "$@"; do
  n=$(basename "$S" .dae)
  for spp in 16 64; do
    for c in $CONFIGS; do
      smp=${c%%:*}; rr=${c##*:}
      for seed in 1 2; do
        f="$O/${n}_${smp}_rr${rr}_${spp}_$seed"
        [ -s "$f.exr" ] || nice -n 10 "$PT" $ARGS -s $spp --seed $seed --sampler=$smp --rr $rr -f "$f.exr" "$S" > "$f.out" 2>&1
      done
    done
  done
  [ -s "$O/${n}_ref.exr" ] || nice -n 10 "$PT" $ARGS -s 1024 --seed 99 --sampler=sobol -f "$O/${n}_ref.exr" "$S" > "$O/${n}_ref.out" 2>&1
done
echo ALLDONE > "$O/done"
