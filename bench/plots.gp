# Convergence and work-precision plots of the two manufactured runs (the CSV tables of
# bin/dualsig data/p2_square.nml and data/p1_square.nml; columns are found by name).
# Usage: gnuplot bench/plots.gp   ->  out/convergence.png, out/work_precision_runs.png
# (`make plots` runs the two namelists first when their tables are missing).
set datafile separator ','
set datafile columnheaders
set terminal pngcairo size 1000,700 enhanced font 'DejaVu Sans,11'
set logscale xy
set format x '10^{%L}'
set format y '10^{%L}'
set grid
set key left top box opaque

P1 = 'out/p1_square.csv'
P2 = 'out/p2_square.csv'

# reference slopes h and h^2, drawn below the data: through 0.4 times the P2 errors
# |u-u_h|_1 and ||grad u - lambda_h|| of the finest level
stats P2 using 'h' nooutput
hmin = STATS_min
hmax = STATS_max
stats P2 using 'err_u_H1' nooutput
e1 = STATS_min
stats P2 using 'err_q_Q' nooutput
e2 = STATS_min
slope1(x) = 0.4 * e1 * (x / hmin)
slope2(x) = 0.4 * e2 * (x / hmin)**2

set output 'out/convergence.png'
set title 'dualsig convergence: manufactured contact problems on the unit square'
set xlabel 'h (longest side)'
set ylabel 'error, guaranteed bound'
set xrange [1.3 * hmax:hmin / 1.3]
set key left bottom box opaque
plot P1 using 'h':'err_u_H1' with linespoints lw 2 pt 7 lc rgb '#1f77b4' title 'P1: ||u-u_h||_1', \
     P1 using 'h':(sqrt(column('est'))) with linespoints lw 2 pt 6 dt 2 lc rgb '#1f77b4' \
        title 'P1: sqrt(est) (6.13)', \
     P1 using 'h':'err_q_Q' with linespoints lw 1 pt 9 lc rgb '#2ca02c' title 'P1: ||q-q_h||_Q', \
     P2 using 'h':'err_u_H1' with linespoints lw 2 pt 5 lc rgb '#d62728' title 'P2: |u-u_h|_1', \
     P2 using 'h':(sqrt(column('est'))) with linespoints lw 2 pt 4 dt 2 lc rgb '#d62728' \
        title 'P2: sqrt(est) (6.26)', \
     P2 using 'h':'err_q_Q' with linespoints lw 1 pt 11 lc rgb '#ff7f0e' \
        title 'P2: ||{/Symbol \321}u-{/Symbol l}_h||_0', \
     slope1(x) with lines lw 1 dt 3 lc rgb 'gray40' title 'slope h', \
     slope2(x) with lines lw 1 dt 4 lc rgb 'gray60' title 'slope h^2'

set output 'out/work_precision_runs.png'
set title 'dualsig work-precision of the runs: error and bound against primal + dual wall time'
set xlabel 'primal\_s + dual\_s [s]'
set ylabel 'error, guaranteed bound'
set autoscale x
set key right top box opaque
plot P1 using (column('primal_s') + column('dual_s')):'err_u_H1' with linespoints lw 2 pt 7 lc rgb '#1f77b4' \
        title 'P1: ||u-u_h||_1', \
     P1 using (column('primal_s') + column('dual_s')):(sqrt(column('est'))) with linespoints lw 2 pt 6 dt 2 \
        lc rgb '#1f77b4' title 'P1: sqrt(est)', \
     P2 using (column('primal_s') + column('dual_s')):'err_u_H1' with linespoints lw 2 pt 5 lc rgb '#d62728' \
        title 'P2: |u-u_h|_1', \
     P2 using (column('primal_s') + column('dual_s')):(sqrt(column('est'))) with linespoints lw 2 pt 4 dt 2 \
        lc rgb '#d62728' title 'P2: sqrt(est)'
