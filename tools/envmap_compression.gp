# Chart of tools/envmap_compression's CSV: relative L2 error of octahedral
# environment maps vs the number of kept coefficients, Haar (lines) against
# spherical harmonics of orders 2..8 (points).
#   build-wavelet/bin/envmap_compression --csv docs/images/envmap_compression.csv
#   gnuplot -e "csv='docs/images/envmap_compression.csv'; out='docs/images/envmap_compression.png'" tools/envmap_compression.gp
if (!exists("csv")) csv = 'docs/images/envmap_compression.csv'
if (!exists("out")) out = 'docs/images/envmap_compression.png'
if (!exists("res")) res = 64
set datafile separator ","
set terminal pngcairo size 1100,700 font ",11"
set output out
set logscale xy
set xrange [1:res*res]
set yrange [1e-4:1.2]
set format y "10^{%L}"
set grid
set key outside right
set xlabel "kept coefficients"
set ylabel "relative L2 error over the sphere"
set title sprintf("Environment map compression, octahedral %dx%d: Haar (lines) vs spherical harmonics orders 2-8 (points)", res, res)
maps = system("tail -n +2 ".csv." | cut -d, -f1 | awk '!seen[$0]++' | tr '\\n' ' '")
plot for [i=1:words(maps)] csv using ((strcol(1) eq word(maps,i) && strcol(2) eq "haar" && $3 == res) ? $4 : 1/0):5 \
       with lines lw 2 lc i title word(maps,i), \
     for [i=1:words(maps)] csv using ((strcol(1) eq word(maps,i) && strcol(2) eq "sh" && $3 == res) ? $4 : 1/0):5 \
       with linespoints pt 7 ps 0.8 dt 2 lc i notitle
