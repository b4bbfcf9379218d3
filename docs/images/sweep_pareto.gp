if (!exists("term")) term = 'png'
if (term eq 'svg') set terminal svg size 1200,520 dynamic noenhanced font "sans,11"; else set terminal pngcairo size 1200,520 noenhanced font ",11"
set output 'sweep_pareto.'.term
set datafile separator ","
set multiplot layout 1,2 title 'Accuracy against speed: sweep_bunny.yaml'
set logscale x
set grid
set key below
set xlabel 'visibility + inverse wall time [s] (2 shared cores)'
set ylabel 'relighting HDR-PSNR [dB] (held-out views and maps)'
plot 'sweep_pareto_front.csv' skip 1 using 1:2 with steps lw 2 lc rgb '#999999' title 'Pareto front', \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'SH' && strcol(4) eq 'ok' ? column(12) : 1/0):5 with points pt 5 ps 1.6 lc 1 title 'SH', \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 16x16' && strcol(4) eq 'ok' ? column(12) : 1/0):5 with points pt 7 ps 1.6 lc 2 title 'Haar 16x16', \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32' && strcol(4) eq 'ok' ? column(12) : 1/0):5 with points pt 9 ps 1.6 lc 3 title 'Haar 32x32', \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 visibility' && strcol(4) eq 'ok' ? column(12) : 1/0):5 with points pt 11 ps 1.6 lc 4 title 'Haar 32x32 visibility', \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 basis BRDFs' && strcol(4) eq 'ok' ? column(12) : 1/0):5 with points pt 5 ps 1.6 lc 5 title 'Haar 32x32 basis BRDFs', \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 wavelet route' && strcol(4) eq 'ok' ? column(12) : 1/0):5 with points pt 7 ps 1.6 lc 6 title 'Haar 32x32 wavelet route', \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 iterations' && strcol(4) eq 'ok' ? column(12) : 1/0):5 with points pt 9 ps 1.6 lc 7 title 'Haar 32x32 iterations', \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 materials' && strcol(4) eq 'ok' ? column(12) : 1/0):5 with points pt 11 ps 1.6 lc 8 title 'Haar 32x32 materials'
set ylabel 'environment-map relative error (upper hemisphere)'
plot 'sweep_pareto.csv' skip 1 using (strcol(1) eq 'SH' && strcol(4) eq 'ok' ? column(12) : 1/0):7 with points pt 5 ps 1.6 lc 1 notitle, \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 16x16' && strcol(4) eq 'ok' ? column(12) : 1/0):7 with points pt 7 ps 1.6 lc 2 notitle, \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32' && strcol(4) eq 'ok' ? column(12) : 1/0):7 with points pt 9 ps 1.6 lc 3 notitle, \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 visibility' && strcol(4) eq 'ok' ? column(12) : 1/0):7 with points pt 11 ps 1.6 lc 4 notitle, \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 basis BRDFs' && strcol(4) eq 'ok' ? column(12) : 1/0):7 with points pt 5 ps 1.6 lc 5 notitle, \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 wavelet route' && strcol(4) eq 'ok' ? column(12) : 1/0):7 with points pt 7 ps 1.6 lc 6 notitle, \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 iterations' && strcol(4) eq 'ok' ? column(12) : 1/0):7 with points pt 9 ps 1.6 lc 7 notitle, \
     'sweep_pareto.csv' skip 1 using (strcol(1) eq 'Haar 32x32 materials' && strcol(4) eq 'ok' ? column(12) : 1/0):7 with points pt 11 ps 1.6 lc 8 notitle
unset multiplot
