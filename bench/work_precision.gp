# Work-precision and scaling plots from the CSV tables of `make bench`
# (out/bench_primal.csv, out/bench_large_p1_contact.csv, out/bench_large_p2_contact.csv).
# Usage: gnuplot bench/work_precision.gp   ->  out/work_precision.png, out/scaling.png
set datafile separator ','
set terminal pngcairo size 1000,700 enhanced font 'DejaVu Sans,11'
set logscale xy
set format x '10^{%L}'
set format y '10^{%L}'
set grid
set key left bottom box opaque

L1 = "< grep ',active_set,' out/bench_large_p1_contact.csv"
L2 = "< grep ',active_set,' out/bench_large_p2_contact.csv"
D1 = "< grep ',dual_p1,' out/bench_large_p1_contact.csv"
D2 = "< grep ',dual_p2,' out/bench_large_p2_contact.csv"
S1 = "< grep '^p1_contact,' out/bench_primal.csv | grep ',zero,' | grep -v ', *1.00000,'"
S2 = "< grep '^p2_contact,' out/bench_primal.csv | grep ',zero,' | grep -v ', *1.00000,'"

set output 'out/work_precision.png'
set title 'dualsig work-precision (one run of make bench; manufactured scenes)'
set xlabel 'wall time [s]'
set ylabel 'error'
plot L1 using 5:11 with linespoints lw 2 pt 7 title 'P1 primal, active set: ||u-u_h||_1', \
     L2 using 5:11 with linespoints lw 2 pt 5 title 'P2 primal, active set: |u-u_h|_1', \
     S1 using 8:9 with linespoints lw 1 pt 6 dt 2 title 'P1 primal, projected SOR (auto {/Symbol w})', \
     S2 using 8:9 with linespoints lw 1 pt 4 dt 2 title 'P2 primal, projected SOR (auto {/Symbol w})', \
     D1 using 5:11 with linespoints lw 2 pt 9 title 'P1 dual (active set): sqrt(est)', \
     D2 using 5:11 with linespoints lw 2 pt 11 title 'P2 dual (augmented): ||{/Symbol \321}u-{/Symbol l}_h||_0'

set output 'out/scaling.png'
set title 'dualsig scaling: wall time against unknowns'
set xlabel 'unknowns'
set ylabel 'wall time [s]'
set key left top box opaque
plot L1 using 3:5 with linespoints lw 2 pt 7 title 'P1 primal, active set', \
     L1 using 3:9 with linespoints lw 1 pt 6 dt 2 title 'P1: one ordering+analyse+factorise+solve (same ordering)', \
     L2 using 3:5 with linespoints lw 2 pt 5 title 'P2 primal, active set', \
     L2 using 3:9 with linespoints lw 1 pt 4 dt 2 title 'P2: one ordering+analyse+factorise+solve (same ordering)', \
     D1 using 3:5 with linespoints lw 2 pt 9 title 'P1 dual (2N unknowns)', \
     D2 using 3:5 with linespoints lw 2 pt 11 title 'P2 dual (edge fluxes)', \
     [1e3:3e6] 1e-6*x lw 1 lc rgb 'gray' title 'slope 1'
