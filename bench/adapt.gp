# Adaptive refinement plots (issue 14).
# Usage: gnuplot bench/adapt.gp   ->  out/adapt_mesh.png (the final mesh of
#   bin/dualsig data/adapt_lshape.nml) and, when bench/adapt_work_precision.sh has run,
#   out/adapt_work_precision.png (certified relative error against unknowns and seconds,
#   adaptive and uniform, every case).
set terminal pngcairo size 700,620 enhanced font 'DejaVu Sans,11'
set output 'out/adapt_mesh.png'
set title 'final adaptive mesh: bin/dualsig data/adapt\_lshape.nml'
set size ratio -1
unset key
plot 'out/adapt_lshape_mesh.dat' using 1:2 with lines lw 0.3 lc rgb '#1f3f7f'

cases = 'lshape_dirichlet_corner lshape_transition square_smooth notch_transition'
ncases = words(cases)
if (int(system('ls out/wp/square_smooth_adapt.csv 2>/dev/null | wc -l')) == 0) exit
set terminal pngcairo size 1400,600 enhanced font 'DejaVu Sans,11'
set output 'out/adapt_work_precision.png'
set datafile separator ','
set datafile columnheaders
set size noratio
unset title
set logscale xy
set format x '10^{%L}'
set format y '10^{%L}'
set grid
set key left bottom box opaque font ',9'
# a coarse mesh whose energy_lo is about 0 has a relative error bound of 1e20 and more
# (true, and of no use): such points are left out
rel(c) = (column(c) <= 10.0 ? column(c) : 1/0)
set multiplot layout 1,2 title 'certified relative error sqrt(est/energy\_lo): adaptive (solid) and uniform (dashed)'
set xlabel 'unknowns (ndof)'
set ylabel 'sqrt(est / energy\_lo)'
plot for [i=1:ncases] sprintf('out/wp/%s_adapt.csv', word(cases, i)) using 'ndof':(rel('rel_cert')) with linespoints lw 2 pt 7 ps 0.5 lc i title word(cases, i).' adaptive' noenhanced, \
     for [i=1:ncases] sprintf('out/wp/%s_uniform.csv', word(cases, i)) using 'ndof':(rel('rel_cert')) with linespoints lw 2 dt 2 pt 6 lc i title word(cases, i).' uniform' noenhanced, \
     [1e3:1e6] 3.0 * x**(-0.5) with lines lc rgb 'gray' dt 3 title 'ndof^{-1/2}'
set xlabel 'wall time (s, cumulative)'
plot for [i=1:ncases] sprintf('out/wp/%s_adapt.csv', word(cases, i)) using 'elapsed_s':(rel('rel_cert')) with linespoints lw 2 pt 7 ps 0.5 lc i title word(cases, i).' adaptive' noenhanced, \
     for [i=1:ncases] sprintf('out/wp/%s_uniform.csv', word(cases, i)) using 'seconds':(rel('rel_cert')) with linespoints lw 2 dt 2 pt 6 lc i title word(cases, i).' uniform' noenhanced
unset multiplot
