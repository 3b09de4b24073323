#!/usr/bin/env bash
# Work-precision of adaptive against uniform refinement (issue 14), measured in one run on
# the same machine: for each case the uniform runs (levels = 1..LMAX, each a separate run
# timed as a whole: grid sequencing runs every coarser level too) and one adaptive run
# (&adapt, the elapsed_s column of its table).  Both with the default solvers (primal
# 'auto', dual 'default'), as a user gets them.  Writes out/wp/<case>_uniform.csv
# (level, ndof, est, energy_lo, rel_cert, seconds) and out/wp/<case>_adapt.csv (the table).
# A second adaptive run with tol = 1e-2 writes out/wp/<case>_adapt_tol1e-2.csv: the 1e-2
# row of the summary is the step where that run stops, as a user asking for 1e-2 gets it
# (its last step aims at tol), not the step where the 1e-3 run passes 1e-2.
# Usage: bench/adapt_work_precision.sh [LMAX]   (default 9; bin/dualsig must be built)
#        MIN_GROWTH=g bench/adapt_work_precision.sh   (&adapt min_growth of both adaptive
#        runs; unset: the default)
#        ALGEBRAIC_SHARE=s bench/adapt_work_precision.sh   (&adapt algebraic_share of both
#        adaptive runs, e.g. 0 for exact solves on every step; unset: the default)
#        CASES='name ...' bench/adapt_work_precision.sh   (only these cases of
#        bench/adapt_cases.sh; the summary covers every case with tables in out/wp)
set -euo pipefail
LMAX=${1:-9}
mkdir -p out/wp
source "$(dirname "$0")/adapt_cases.sh"
for c in "${cases[@]}"; do
  IFS='|' read -r name scene gu ga mesh tol ndof <<<"$c"
  if [ -n "${CASES:-}" ] && [[ " $CASES " != *" $name "* ]]; then continue; fi
  out=out/wp/${name}_uniform.csv
  echo "level,ndof,est,energy_lo,rel_cert,seconds" > "$out"
  for L in $(seq 1 "$LMAX"); do
    namelist "$name" "$scene" "$gu" "$ga" "$mesh" "$L" > out/wp/${name}.nml
    t0=$(date +%s.%N)
    ./bin/dualsig out/wp/${name}.nml > /dev/null || [ $? -eq 3 ]
    t1=$(date +%s.%N)
    python3 - "$out" "$L" "$t0" "$t1" out/wp/${name}_run.csv <<'PY'
import csv, sys, math
out, L, t0, t1, table = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4]), sys.argv[5]
rows = list(csv.DictReader(open(table)))
r = rows[-1]
est, lo = float(r['est']), float(r['energy_lo'])
rel = math.sqrt(est / lo) if lo > 0 else float('nan')
open(out, 'a').write(f"{L},{int(float(r['ndof']))},{est:.6e},{lo:.10e},{rel:.6e},{t1 - t0:.4f}\n")
PY
  done
  namelist "$name" "$scene" "$gu" "$ga" "$mesh" 1 "$tol" "$ndof" > out/wp/${name}_adapt.nml
  sed -i "s#output = 'out/wp/${name}_run'#output = 'out/wp/${name}_adapt'#" out/wp/${name}_adapt.nml
  ./bin/dualsig out/wp/${name}_adapt.nml > out/wp/${name}_adapt.log || [ $? -eq 3 ]
  grep "adaptive loop stopped" out/wp/${name}_adapt.log || true
  namelist "$name" "$scene" "$gu" "$ga" "$mesh" 1 1.0e-2 "$ndof" > out/wp/${name}_adapt_tol1e-2.nml
  sed -i "s#output = 'out/wp/${name}_run'#output = 'out/wp/${name}_adapt_tol1e-2'#" out/wp/${name}_adapt_tol1e-2.nml
  ./bin/dualsig out/wp/${name}_adapt_tol1e-2.nml > out/wp/${name}_adapt_tol1e-2.log || [ $? -eq 3 ]
  grep "adaptive loop stopped" out/wp/${name}_adapt_tol1e-2.log || true
done
python3 bench/adapt_summary.py
