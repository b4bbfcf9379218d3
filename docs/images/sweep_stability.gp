if (!exists("term")) term = 'png'
if (term eq 'svg') set terminal svg size 1200,990 dynamic noenhanced font "sans,11"; else set terminal pngcairo size 1200,990 noenhanced font ",11"
set output 'sweep_stability.'.term
set datafile separator ","
set multiplot layout 3,3 title 'Stability: sweep_bunny.yaml'
set grid
set key top right
set ylabel 'relight PSNR [dB]'
set yrange [15:29]
set title 'photos'
set xrange [-0.5:4.5]
set xtics ("1" 0, "3" 1, "6" 2, "12" 3, "24" 4)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'photos|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'photos|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
set title 'noise (read sigma)'
set xrange [-0.5:1.5]
set xtics ("0.002" 0, "0.02" 1)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'noise (read sigma)|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'noise (read sigma)|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
set title 'JPEG quality'
set xrange [-0.5:1.5]
set xtics ("80-95" 0, "20" 1)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'JPEG quality|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'JPEG quality|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
set title 'white balance error (EV)'
set xrange [-0.5:1.5]
set xtics ("0.15" 0, "0.75" 1)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'white balance error (EV)|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'white balance error (EV)|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
set title 'exposure key'
set xrange [-0.5:1.5]
set xtics ("0.18" 0, "0.6" 1)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'exposure key|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'exposure key|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
set title 'geometry (vertices)'
set xrange [-0.5:2.5]
set xtics ("5000" 0, "1500" 1, "400" 2)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'geometry (vertices)|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'geometry (vertices)|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
set title 'materials'
set xrange [-0.5:1.5]
set xtics ("matte (1)" 0, "glossy (4)" 1)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'materials|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'materials|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
set title 'illumination'
set xrange [-0.5:1.5]
set xtics ("mixed" 0, "sunny skies" 1)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'illumination|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'illumination|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
set title 'interreflection'
set xrange [-0.5:1.5]
set xtics ("off" 0, "on" 1)
plot 'sweep_stability.csv' skip 1 using (strcol(1) eq 'interreflection|Haar 16²' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 7 ps 1.2 lw 2 lc 1 title 'Haar 16²', \
     'sweep_stability.csv' skip 1 using (strcol(1) eq 'interreflection|SH order 4' && strcol(4) eq 'ok' ? $3 : 1/0):5 with linespoints pt 9 ps 1.2 lw 2 lc 2 title 'SH order 4'
unset multiplot
