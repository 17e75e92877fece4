# Throughput relative to Embree (high quality) per scene, ray kind and thread count.
# gnuplot -c accel.gp ACCEL_CSV OUTPUT.png
csv = ARG1; out = ARG2
set terminal pngcairo size 1400,700 font ",10"
set output out
set termoption noenhanced  # scene names contain underscores
set datafile separator ","
set style data histograms
set style histogram clustered gap 1
set style fill solid 0.85 border -1
set boxwidth 0.9
set grid ytics
set yrange [0:*]
set ylabel "Mrays/s relative to Embree high (1.0 = same)"
set xtics rotate by -35 font ",8"
set bmargin 7
set rmargin 8
set key outside top center horizontal
# One row per (scene, ray kind, threads): columns midpoint, SAH ratios, via awk pivot.
pivot = sprintf("< awk -F, 'NR>1 { k=$1\" \"$4\" \"$5\"t\"; if (!(k in seen)) { seen[k]=1; order[++n]=k } r[k,$3]=$7 } END { for (i=1;i<=n;i++) { k=order[i]; printf \"\\\"%%s\\\",%%s,%%s\\n\", k, (r[k,\"custom:midpoint:fast\"]==\"\"?0:r[k,\"custom:midpoint:fast\"]), (r[k,\"custom:sah:fast\"]==\"\"?0:r[k,\"custom:sah:fast\"]) } }' %s", csv)
set title "Our BVH vs Embree: throughput ratio per scene, ray kind and thread count"
plot pivot using 2:xtic(1) title "custom midpoint", '' using 3 title "custom SAH", 1 with lines lc rgb "#444444" notitle
