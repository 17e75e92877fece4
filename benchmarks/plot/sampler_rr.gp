# Error against time of every sampler under both roulettes (tradeoff's sampler_rr study),
# and of sobol with the camera hit's bounce split K ways (its split study: by noise, and
# K = 4 also uniform), log-log, one panel per scene, a line per setting through 4, 16
# and 64 spp.
# gnuplot -c sampler_rr.gp CSV OUTPUT.png
# The image's relative RMSE with the reference's noise subtracted (column 16) against the
# render's wall time (column 12); a line lower and to the left is more efficient.
csv = ARG1; out = ARG2
set terminal pngcairo size 1400,1000 font ",10"
set output out
set termoption noenhanced  # scene names contain underscores
set datafile separator ","
set logscale xy
set grid
set key top right font ",8"
set xlabel "wall time per image (s, 2 threads)"
set ylabel "relative RMSE (image)"
scenes = system(sprintf("awk -F, 'NR > 1 && $2 == \"sampler_rr\" && !s[$1]++ { print $1 }' %s", csv))
samplers = "independent stratified sobol zsobol pmj02"
sel(scene, label) = sprintf("< awk -F, '$1==\"%s\" && ($2==\"sampler_rr\" || $2==\"split\") && $3==\"%s\"' %s", scene, label, csv)
splits = "2 4 8"
y(c) = (column(c) > 0 ? column(c) : 1/0)
set multiplot layout 2,2 title "samplers x roulette: error against time (160x120, reference 4096 spp; dashed: the course's rr 0.65; grey to black: sobol split 2, 4, 8 ways by noise, dashed grey 4 uniform)"
do for [sc in scenes] {
  set title sc
  plot for [i=1:words(samplers)] sel(sc, word(samplers, i)." rr=throughput") using 12:(y(16)) \
         with linespoints lc i pt 7 dt 1 title word(samplers, i)." throughput", \
       for [i=1:words(samplers)] sel(sc, word(samplers, i)." rr=0.65") using 12:(y(16)) \
         with linespoints lc i pt 6 dt 2 title word(samplers, i)." 0.65", \
       for [k in splits] sel(sc, "sobol rr=throughput split=".k) using 12:(y(16)) \
         with linespoints lc rgb (k eq "2" ? "#a0a0a0" : k eq "4" ? "#505050" : "black") pt 5 dt 1 title "sobol throughput, split ".k, \
       sel(sc, "sobol rr=throughput split=4 uniform") using 12:(y(16)) \
         with linespoints lc rgb "#505050" pt 4 dt 2 title "sobol throughput, split 4 uniform"
}
unset multiplot
