# Adaptive sampling: samples saved vs error added, per tolerance, against the fixed-spp
# render at the same cap. gnuplot -c adaptive.gp CSV SCENE OUTPUT.png
csv = ARG1; scene = ARG2; out = ARG3
set terminal pngcairo size 1500,600 font ",10"
set output out
set termoption noenhanced  # scene names contain underscores
set datafile separator ","
set grid
set logscale x
set key top left
rows = sprintf("< awk -F, '$1==\"%s\" && $2==\"adaptive\" && $3!=\"fixed\"' %s", scene, csv)
fixed = sprintf("< awk -F, '$1==\"%s\" && $2==\"adaptive\" && $3==\"fixed\"' %s", scene, csv)
# The fixed render's samples and errors, read into variables.
stats fixed using 13 nooutput; fs = STATS_max
stats fixed using 16 nooutput; fe = STATS_max
stats fixed using 17 nooutput; fsh = STATS_max
stats fixed using 12 nooutput; ft = STATS_max
set multiplot layout 1,2
set title sprintf("%s: adaptive sampling (cap 256 spp, batch 16) vs 256 spp everywhere", scene)
set xlabel "tolerance (stop when 1.96 sigma/sqrt(n) <= tol * mean)"
set ylabel "fraction of the fixed render"
set yrange [0:*]
plot rows using 11:($13/fs) with linespoints pt 7 title "samples taken", \
     rows using 11:($12/ft) with linespoints pt 6 title "wall time", \
     rows using 11:($16/fe) with linespoints pt 5 title "rel RMSE (image)", \
     rows using 11:($17/fsh) with linespoints pt 9 title "rel RMSE (shadows)", \
     1 with lines lc rgb "#888888" notitle
# The question a user asks: at equal time, is adaptive better than uniform spp?
spp = sprintf("< awk -F, '$1==\"%s\" && $2==\"spp\"' %s", scene, csv)
set title sprintf("%s: adaptive (cap 256) vs uniform spp at equal time", scene)
set logscale xy
set yrange [*:*]
set key top right
set xlabel "wall time per image (s, 2 threads)"
set ylabel "relative RMSE (image, reference noise subtracted)"
plot spp using 12:16 with linespoints pt 7 lc rgb "#aaaaaa" title "uniform, spp 1..1024", \
     rows using 12:16 with linespoints pt 5 title "adaptive, tol = t", \
     rows using 12:16:(sprintf("t=%g", $11)) with labels offset 0,0.8 font ",8" notitle
unset multiplot
