#!/bin/bash
# Size and time of the ParaView output, ascii against binary (make bench-vtu; the figures are
# in doc/user-guide.md#size-and-speed-of-the-vtu-encodings).
#
#   bench/vtu_sizes.sh [WORKDIR]      (default: out/vtu_bench; needs bin/dualsig and
#                                      bin/dualsig_vtu_bench)
# 1. Whole runs of bin/dualsig with vtk off, vtu_format = 'ascii' and 'binary' (best of 3
#    wall times): data/p2_plate_hole_gmsh.nml at 4 levels, and p2_contact on the unit square
#    at 8 levels, both with the dual analysis; the bytes of the finest level's .vtu and of
#    all levels.  Write time ~ (time with vtk) - (time without).
# 2. bin/dualsig_vtu_bench 256: the write time of one file of level-8 size, directly.
set -euo pipefail
work=${1:-out/vtu_bench}
mkdir -p "$work"
best_time() {   # best wall time of 3 runs of bin/dualsig on $1 (exit status 0 or 3, not certified)
  local best=999999 t rc
  for _ in 1 2 3; do
    rc=0
    /usr/bin/time -f '%e' -o "$work/time.txt" ./bin/dualsig "$1" > "$work/run.log" 2>&1 || rc=$?
    if [ $rc -ne 0 ] && [ $rc -ne 3 ]; then echo "bin/dualsig $1 failed ($rc): see $work/run.log" >&2; exit 1; fi
    t=$(tail -1 "$work/time.txt")
    best=$(python3 -c "print(min($best, $t))")
  done
  echo "$best"
}
for case in plate square; do
  for fmt in none ascii binary; do
    nml=$work/${case}_$fmt.nml
    vtk=.true.; f=$fmt
    if [ $fmt = none ]; then vtk=.false.; f=binary; fi
    if [ $case = plate ]; then
      sed -e "s#output = 'out/p2_plate_hole_gmsh'#output = '$work/${case}_$fmt', vtk = $vtk, vtu_format = '$f'#" \
          -e "s/levels = 3/levels = 4/" -e "s#file = '\(data/\)\?#file = '$PWD/data/#" data/p2_plate_hole_gmsh.nml > "$nml"
      last=04
    else
      printf "&run scene = 'p2_contact', output = '%s', vtk = %s, vtu_format = '%s' /\n&mesh levels = 8 /\n" \
        "$work/${case}_$fmt" $vtk $f > "$nml"
      printf "&solver method = 'active_set' /\n&dual enabled = .true. /\n" >> "$nml"
      last=08
    fi
    t=$(best_time "$nml")
    if [ $fmt = none ]; then
      echo "$case: vtk off: ${t} s"
    else
      total=$(cat "$work/${case}_${fmt}"_level*.vtu | wc -c)
      echo "$case: $fmt: finest level $(wc -c < "$work/${case}_${fmt}_level$last.vtu") bytes, all levels $total bytes, ${t} s"
    fi
  done
done
./bin/dualsig_vtu_bench 256 "$work"
