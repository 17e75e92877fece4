#!/bin/bash
# MIS at equal time: on Veach's scene (scenes/mis_veach.dae: a glossy floor,
# three spherical lights of equal power and radius 0.03, 0.12, 0.45), render a converged
# reference, then each --strategy (mis, light, bsdf) for the same wall time with
# --time-limit, several times and repeats, and print the RMSE of the glossy floor against
# the reference with the samples per pixel each render got. Direct light only (-m 1), where
# the strategies differ; --lights=mesh, since the spheres are the lights.
#   benchmarks/mis_equal_time.sh [--quick] [OUTDIR]
# Output: a markdown table on stdout, the EXRs in OUTDIR (default /tmp/mis_equal_time:
# ~100 MB, not for the repository), and OUTDIR/mis_sheet.png (mis | light | bsdf at the
# longest time; benchmarks/results/mis/ keeps the published one and its table).
# The quick start's packages suffice (oiiotool from openimageio-tools).
set -euo pipefail
QUICK=0
if [ "${1:-}" = --quick ]; then QUICK=1; shift; fi
HERE=$(cd "$(dirname "$0")" && pwd)
PT=$(realpath "${PT:-$HERE/../build/tools/pathtracer}")
SCENE=$HERE/../scenes/mis_veach.dae
OUT=${1:-${TMPDIR:-/tmp}/mis_equal_time}
mkdir -p "$OUT"
W=240 H=180
# The floor: rows below the horizon. The lights themselves are seen by camera rays alike
# in every strategy; their edge pixels would only add the same noise to every row.
FLOOR="${W}x$((H / 2 - 4))+0+$((H / 2 + 4))"
VIEW=(--lights=mesh -m 1 -r $W $H --cam-pos 0 -4.5 1.6 --cam-target 0 0 0.35 --cam-up 0 0 1 --fov 45)
if [ $QUICK = 1 ]; then
  REF_SPP=16 TIMES="0.5" REPEATS=1 W=48 H=36
  FLOOR="${W}x$((H / 2 - 4))+0+$((H / 2 + 4))"
  VIEW=(--lights=mesh -m 1 -r $W $H --cam-pos 0 -4.5 1.6 --cam-target 0 0 0.35 --cam-up 0 0 1 --fov 45)
else
  REF_SPP=${REF_SPP:-4096} TIMES=${TIMES:-"2 4 8 16"} REPEATS=${REPEATS:-3}
fi
CPUS=$(nproc)
echo "pathtracer: $PT; cpus $CPUS; load $(cut -d' ' -f1-3 /proc/loadavg)" >&2

# Reference: MIS (any unbiased strategy converges to the same image; MIS is the fastest).
REF=$OUT/reference_${W}x${H}_${REF_SPP}.exr
if [ ! -f "$REF" ]; then
  echo "reference: $REF_SPP spp" >&2
  "$PT" -q "${VIEW[@]}" -s "$REF_SPP" --seed 999 -f "$REF" "$SCENE" > /dev/null 2>&1
fi

rmse() {  # RMSE over the floor region of $1 against the reference, RGB
  oiiotool "$1" --ch R,G,B --cut "$FLOOR" "$REF" --ch R,G,B --cut "$FLOOR" --diff 2>&1 | awk '/RMS error/ {print $NF; exit}' || true
}

echo "| seconds | strategy | spp (each repeat) | RMSE of the floor (mean of repeats) | RMSE / MIS |"
echo "|---|---|---|---|---|"
# Strategies interleaved within each repeat: the machine's load drifts, and each strategy
# should meet the same drift.
for T in $TIMES; do
  declare -A SUM SPPS
  for s in mis light bsdf; do SUM[$s]=0; SPPS[$s]=""; done
  for r in $(seq 1 $REPEATS); do
    for s in mis light bsdf; do
      img=$OUT/${s}_${T}s_$r.exr
      spp=$("$PT" -q "${VIEW[@]}" -s 1000000 --pass 1 --time-limit "$T" --strategy $s --seed $((r * 7 + ${#s})) \
            -f "$img" "$SCENE" 2>/dev/null | awk '/Time limit:/ {print $4}')
      e=$(rmse "$img")
      if [ -z "$spp" ] || [ -z "$e" ]; then echo "no time-limited render or no RMSE for $img" >&2; exit 1; fi
      SPPS[$s]="${SPPS[$s]}${SPPS[$s]:+, }${spp%.00}"
      SUM[$s]=$(awk -v a="${SUM[$s]}" -v b="$e" 'BEGIN {print a + b}')
    done
  done
  mis=$(awk -v a="${SUM[mis]}" -v n="$REPEATS" 'BEGIN {print a / n}')
  for s in mis light bsdf; do
    m=$(awk -v a="${SUM[$s]}" -v n="$REPEATS" 'BEGIN {print a / n}')
    echo "| $T | $s | ${SPPS[$s]} | $(awk -v a="$m" 'BEGIN {printf "%.4g", a}') | $(awk -v a="$m" -v b="$mis" 'BEGIN {printf "%.2f", a / b}') |"
  done
  unset SUM SPPS
done
# The three strategies side by side at the longest time (first repeat), tone-mapped PNGs.
LAST=${TIMES##* }
for s in mis light bsdf; do oiiotool "$OUT/${s}_${LAST}s_1.exr" --ch R,G,B --colorconvert linear sRGB -o "$OUT/${s}_${LAST}s.png"; done
oiiotool "$OUT/mis_${LAST}s.png" "$OUT/light_${LAST}s.png" "$OUT/bsdf_${LAST}s.png" --mosaic 3x1 -o "$OUT/mis_sheet.png"
echo "images in $OUT (mis_sheet.png: mis | light | bsdf at $LAST s)" >&2
