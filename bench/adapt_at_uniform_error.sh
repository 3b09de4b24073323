#!/usr/bin/env bash
# Adaptive against uniform refinement at the same certified error, both measured (issue 14):
# for each case of bench/adapt_cases.sh, one uniform run with `levels = L` (grid sequencing
# through every coarser level, timed as a whole, as a user runs it), then one adaptive run
# with `tol` set to the certified relative error sqrt(est/energy_lo) that uniform run
# reached, so that the adaptive run stops at an error at most the uniform one (its last step
# aims at tol).  Both under /usr/bin/time -v, one after the other, with the default solvers.
# Prints a markdown table (wall seconds of the whole program, unknowns, certified relative
# error, peak resident memory, and the ratios adaptive / uniform) and writes it to
# out/wp/at_uniform_error_L<L>.md.  The extrapolations of bench/adapt_work_precision.sh
# extend the time of levels 8-9 to levels the machine cannot hold; this script measures
# both arms at the finest uniform level it can hold instead.
# Usage: bench/adapt_at_uniform_error.sh [L] [CASE...]   (default L = 11: about 4.2e6
#        unknowns on the square, 3.1e6 on the L-shape, 8-11 GB, 10-15 minutes in all;
#        bin/dualsig must be built; CASE: names from bench/adapt_cases.sh, default all)
set -euo pipefail
L=${1:-11}
shift || true
MAX_SECONDS=${MAX_SECONDS:-3600}
source "$(dirname "$0")/adapt_cases.sh"
mkdir -p out/wp
report=out/wp/at_uniform_error_L${L}.md
rows=()
# wall seconds and peak resident kB of a /usr/bin/time -v log
time_of() { python3 - "$1" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
wall = re.search(r'Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)', text).group(1)
secs = 0.0
for part in wall.split(':'):
    secs = secs * 60 + float(part)
kb = int(re.search(r'Maximum resident set size \(kbytes\): (\d+)', text).group(1))
print(f"{secs:.2f} {kb}")
PY
}
# unknowns, certified relative error and step count of a run's table
last_row() { python3 - "$1" <<'PY'
import csv, math, sys
rows = list(csv.DictReader(open(sys.argv[1])))
r = rows[-1]
est, lo = float(r['est']), float(r['energy_lo'])
print(int(float(r['ndof'])), f"{math.sqrt(est / lo):.6e}", len(rows))
PY
}
for c in "${cases[@]}"; do
  IFS='|' read -r name scene gu ga mesh tol ndof <<<"$c"
  if [ $# -gt 0 ] && [[ " $* " != *" $name "* ]]; then continue; fi
  namelist "$name" "$scene" "$gu" "$ga" "$mesh" "$L" > out/wp/${name}_L${L}.nml
  sed -i "s#output = 'out/wp/${name}_run'#output = 'out/wp/${name}_L${L}'#" out/wp/${name}_L${L}.nml
  /usr/bin/time -v ./bin/dualsig out/wp/${name}_L${L}.nml > out/wp/${name}_L${L}.log 2> out/wp/${name}_L${L}.time \
    || [ $? -eq 3 ]
  read -r u_s u_kb <<<"$(time_of out/wp/${name}_L${L}.time)"
  read -r u_ndof u_rel _ <<<"$(last_row out/wp/${name}_L${L}.csv)"
  namelist "$name" "$scene" "$gu" "$ga" "$mesh" 1 "$u_rel" 100000000 > out/wp/${name}_at_L${L}.nml
  sed -i "s#output = 'out/wp/${name}_run'#output = 'out/wp/${name}_at_L${L}'#" out/wp/${name}_at_L${L}.nml
  /usr/bin/time -v ./bin/dualsig out/wp/${name}_at_L${L}.nml > out/wp/${name}_at_L${L}.log \
    2> out/wp/${name}_at_L${L}.time || [ $? -eq 3 ]
  grep "adaptive loop stopped" out/wp/${name}_at_L${L}.log || true
  read -r a_s a_kb <<<"$(time_of out/wp/${name}_at_L${L}.time)"
  read -r a_ndof a_rel a_steps <<<"$(last_row out/wp/${name}_at_L${L}.csv)"
  rows+=("$(python3 -c "
import sys
n, L, us, ukb, un, ur, as_, akb, an, ar, st = sys.argv[1:]
print(f'| {n} | {L} | {int(un):,} | {ur} | {float(us):.1f} | {int(ukb)/1e6:.1f} | {st} | {int(an):,} | {ar} | '
      f'{float(as_):.1f} | {int(akb)/1e6:.1f} | {float(as_)/float(us):.2f} | {int(un)/int(an):.2f} |')
" "$name" "$L" "$u_s" "$u_kb" "$u_ndof" "$u_rel" "$a_s" "$a_kb" "$a_ndof" "$a_rel" "$a_steps")")
done
{
  echo "Command: bench/adapt_at_uniform_error.sh $L $*  ($(date -u +%Y-%m-%d), $(git rev-parse --short HEAD 2>/dev/null || echo '?'))"
  echo
  echo "| case | uniform levels | uniform ndof | uniform rel | uniform s | uniform GB | adaptive steps | adaptive ndof | adaptive rel | adaptive s | adaptive GB | time adaptive / uniform | ndof uniform / adaptive |"
  echo "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |"
  printf '%s\n' "${rows[@]}"
} | tee "$report"
