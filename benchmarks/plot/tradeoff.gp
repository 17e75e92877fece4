# Error-time curves of the speed-accuracy study, log-log, one panel per knob.
# gnuplot -c tradeoff.gp CSV SCENE COLUMN OUTPUT.png TITLE
# COLUMN: 16 = rel_rmse over the image (reference noise subtracted), 17 = in cast shadows.
csv = ARG1; scene = ARG2; col = int(ARG3); out = ARG4; what = ARG5
set terminal pngcairo size 1500,950 font ",10"
set output out
set termoption noenhanced  # scene names contain underscores
set datafile separator ","
set logscale xy
set grid
set key top right font ",9"
set xlabel "wall time per image (s, 2 threads)"
set ylabel what
# Rows of one study (and optionally one label) of this scene, via awk (no header).
sel(study) = sprintf("< awk -F, '$1==\"%s\" && $2==\"%s\"' %s", scene, study, csv)
sell(study, label) = sprintf("< awk -F, '$1==\"%s\" && $2==\"%s\" && $3==\"%s\"' %s", scene, study, label, csv)
y(c) = (column(c) > 0 ? column(c) : 1/0)  # debiased error can reach 0 at the reference's floor
set multiplot layout 2,3 title sprintf("%s: %s vs wall time (160x120, reference 4096 spp)", scene, what)
set title "sampling the direct light (spp 1..1024)"
plot sel("spp") using 12:(y(col)) with linespoints pt 7 title "light sampling", \
     sel("sampling") using 12:(y(col)) with linespoints pt 5 title "hemisphere", \
     sel("spp") using 12:(y(col)):(sprintf("%d", $5)) with labels offset 0,0.8 font ",7" notitle
set title "samples per light at 4 spp (l = 1..64) vs more spp"
plot sel("spp") using 12:(y(col)) with linespoints pt 7 lc rgb "#aaaaaa" title "l = 1, spp 1..1024", \
     sel("light_samples") using 12:(y(col)) with linespoints pt 5 title "spp 4 l=N", \
     sel("light_samples") using 12:(y(col)):(sprintf("l=%d", $6)) with labels offset 0,0.8 font ",7" notitle
set title "Russian roulette continuation probability (16 spp)"
plot sel("spp") using 12:(y(col)) with linespoints pt 7 lc rgb "#aaaaaa" title "rr 0.65, spp 1..1024", \
     sel("rr") using 12:(y(col)) with linespoints pt 5 title "rr = p", \
     sel("rr") using 12:(y(col)):(sprintf("%.2f", $8)) with labels offset 0,0.8 font ",7" notitle
set title "maximum depth (64 spp; the reference has depth 100)"
plot sel("spp") using 12:(y(col)) with linespoints pt 7 lc rgb "#aaaaaa" title "depth 100, spp 1..1024", \
     sel("max_depth") using 12:(y(col)) with linespoints pt 5 title "depth m", \
     sel("max_depth") using 12:(y(col)):(sprintf("m=%d", $7)) with labels offset 0,0.8 font ",7" notitle
set title "accelerator at equal time (4, 16, 64 spp)"
plot sell("backend", "custom:midpoint") using 12:(y(col)) with linespoints pt 7 title "custom midpoint", \
     sell("backend", "custom:sah") using 12:(y(col)) with linespoints pt 5 title "custom SAH", \
     sell("backend", "embree:high") using 12:(y(col)) with linespoints pt 9 title "Embree high"
set title "triangle test at equal time (custom SAH; 4, 16, 64 spp)"
plot sell("triangle_test", "custom:sah:fast") using 12:(y(col)) with linespoints pt 7 title "fast (Moller-Trumbore)", \
     sell("triangle_test", "custom:sah:watertight") using 12:(y(col)) with linespoints pt 5 title "watertight"
unset multiplot
