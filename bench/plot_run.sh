#!/usr/bin/env bash
# Plots of one run's CSV table (bin/dualsig writes <output>.csv): any run, any problem.
#
# Usage: bench/plot_run.sh RUN.csv [OUTDIR]     (make plots CSV=RUN.csv runs it)
#   OUTDIR defaults to out/.  Writes, for RUN.csv named NAME.csv:
#     OUTDIR/NAME_convergence.png     the computed error columns and sqrt(est) against h
#                                     (against ndof for an adaptive run), log-log
#     OUTDIR/NAME_work_precision.png  the same against the cumulative primal_s + dual_s
#     OUTDIR/NAME_bounds.png          energy_lo and energy_hi against ndof (dual runs only)
#     OUTDIR/NAME_timing.png          primal_s and dual_s against ndof
# Columns are found by name (the CSV schema of doc/user-guide.md, "Error tables"); a column
# that is absent or nan on every row is left out of the plots.  Needs gnuplot.
set -euo pipefail
if [ $# -lt 1 ] || [ $# -gt 2 ]; then
  echo "usage: bench/plot_run.sh RUN.csv [OUTDIR]   (plots written to OUTDIR, default out/)" >&2
  exit 1
fi
csv=$1
outdir=${2:-out}
if [ ! -f "$csv" ]; then
  echo "plot_run: $csv: no such file (expected the CSV table of a run, <output>.csv)" >&2
  exit 1
fi
if ! command -v gnuplot >/dev/null; then
  echo "plot_run: gnuplot not installed (Debian: apt-get install gnuplot-nox): no plots" >&2
  exit 1
fi
name=$(basename "$csv" .csv)
mkdir -p "$outdir"

# column index of a name that has at least one finite value, else 0
col() {
  awk -F, -v want="$1" 'NR == 1 { for (i = 1; i <= NF; i++) if ($i == want) c = i; next }
    c && $c != "nan" && $c != "" { found = 1 } END { print (c && found) ? c : 0 }' "$csv"
}
c_h=$(col h); c_ndof=$(col ndof); c_primal=$(col primal_s); c_dual=$(col dual_s)
c_adapt=$(col nmarked)
if [ "$(awk 'END { print NR }' "$csv")" -lt 2 ]; then
  echo "plot_run: $csv has no rows" >&2
  exit 1
fi

if [ "$c_adapt" != 0 ]; then
  xcol=$c_ndof; xlabel='unknowns (ndof)'
else
  xcol=$c_h; xlabel='h (longest side)'
fi
series=()
add() {  # column-name title: a series of the error plots when the column has values
  if [ "$(col "$1")" != 0 ]; then series+=("$1|$2"); fi
}
add err_u_H1 'err\_u\_H1 (energy norm of u - u_h)'
add sqrt_est 'sqrt(est) (guaranteed bound)'
add err_q_Q 'err\_q\_Q (dual error)'
add cert_rel_err 'cert\_rel\_err = sqrt(est/energy\_lo)'

plot_cmd() {  # x-expression: the gnuplot plot list of the series
  local x=$1 cmd='' s
  for s in "${series[@]}"; do
    cmd+="${cmd:+, }'$csv' using ($x):$(col "${s%%|*}") with linespoints lw 2 title '${s#*|}'"
  done
  echo "$cmd"
}

common="set datafile separator ','; set datafile columnheaders; set datafile missing 'nan'; cum = 0;
set terminal pngcairo size 900,650 enhanced font 'DejaVu Sans,11'; set logscale xy; set grid;
set format x '10^{%L}'; set format y '10^{%L}'; set key box opaque"
written=()
if [ ${#series[@]} -gt 0 ] && [ "$xcol" != 0 ]; then
  gnuplot -e "$common; set output '$outdir/${name}_convergence.png';
    set title '$name: errors and bounds' noenhanced; set xlabel '$xlabel';
    plot $(plot_cmd "column($xcol)")"
  written+=("$outdir/${name}_convergence.png")
  if [ "$c_primal" != 0 ]; then
    t="column($c_primal)"
    if [ "$c_dual" != 0 ]; then t="column($c_primal) + column($c_dual)"; fi
    gnuplot -e "$common; set output '$outdir/${name}_work_precision.png'; cum = 0;
      set title '$name: errors and bounds against solve time' noenhanced;
      set xlabel 'cumulative primal\_s + dual\_s [s]';
      plot $(plot_cmd "cum = (column(0) == 0 ? 0 : cum) + $t, cum")"
    written+=("$outdir/${name}_work_precision.png")
  fi
fi
c_lo=$(col energy_lo); c_hi=$(col energy_hi)
if [ "$c_lo" != 0 ] && [ "$c_hi" != 0 ] && [ "$c_ndof" != 0 ]; then
  gnuplot -e "$common; unset logscale y; set format y '%g'; set output '$outdir/${name}_bounds.png';
    set title '$name: energy bracket energy\_lo <= (f,u) <= energy\_hi' noenhanced; set xlabel 'unknowns (ndof)';
    plot '$csv' using $c_ndof:$c_lo with linespoints lw 2 title 'energy\_lo',
         '$csv' using $c_ndof:$c_hi with linespoints lw 2 title 'energy\_hi'"
  written+=("$outdir/${name}_bounds.png")
fi
if [ "$c_primal" != 0 ] && [ "$c_ndof" != 0 ]; then
  dual_series=''
  if [ "$c_dual" != 0 ]; then dual_series=", '$csv' using $c_ndof:$c_dual with linespoints lw 2 title 'dual\\_s'"; fi
  gnuplot -e "$common; set output '$outdir/${name}_timing.png';
    set title '$name: wall time of the solves per level' noenhanced; set xlabel 'unknowns (ndof)'; set ylabel 's';
    plot '$csv' using $c_ndof:$c_primal with linespoints lw 2 title 'primal\\_s'$dual_series"
  written+=("$outdir/${name}_timing.png")
fi
if [ ${#written[@]} -eq 0 ]; then
  echo "plot_run: nothing to plot in $csv" >&2
  exit 1
fi
echo "plot_run: ${written[*]}"
