#!/usr/bin/env bash
# The installed library end to end, for test/test_install.pf:
#   test/install_check.sh WORKDIR
# 1. make install PREFIX=WORKDIR/prefix (the prefix already holds two files of "someone
#    else", lib/other.txt and include/other.mod, which uninstall must keep);
# 2. compile drivers/example_dssign.f against the INSTALLED library with only -L/-l flags:
#    -LPREFIX/lib -ldualsig and the output of `pkg-config --libs --static dualsig`
#    (PKG_CONFIG_PATH=PREFIX/lib/pkgconfig); no -I, no path into the source tree;
# 3. run it (output in example.out);
# 4. make uninstall PREFIX=WORKDIR/prefix;
# 5. make install DESTDIR=WORKDIR/stage PREFIX=/opt/dualsig (a staged install).
# Lists written to WORKDIR: installed.txt (files under PREFIX after step 1), libs.txt
# (pkg-config output), left_files.txt and left_dirs.txt (after step 4), staged.txt (files
# under WORKDIR/stage).  Logs: install.log, compile.log, uninstall.log, stage.log.
# Exit status: 0 all steps ran; 1 usage; 10 + step number when that step failed (the test
# checks the content).  Make variables of a calling make (MAKEFLAGS) are not passed on, so
# the install builds the default release library whatever the test run's settings are.
set -u
if [ $# -ne 1 ]; then echo "usage: $0 WORKDIR" >&2; exit 1; fi
root=$(cd "$(dirname "$0")/.." && pwd)
work=$1
prefix=$work/prefix
unset MAKEFLAGS MFLAGS MAKELEVEL MAKEOVERRIDES
rm -rf "$work"
mkdir -p "$prefix/lib" "$prefix/include" || exit 1
echo "not dualsig's" > "$prefix/lib/other.txt"
echo "not dualsig's" > "$prefix/include/other.mod"

list_files() { (cd "$1" && find . -type f | LC_ALL=C sort); }

make -C "$root" install PREFIX="$prefix" > "$work/install.log" 2>&1 || exit 11
list_files "$prefix" > "$work/installed.txt"

export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
libs=$(pkg-config --libs --static dualsig 2> "$work/compile.log") || exit 12
echo "$libs" > "$work/libs.txt"
# $libs is split into words on purpose (one flag per word)
# shellcheck disable=SC2086
gfortran "$root/drivers/example_dssign.f" -o "$work/example_dssign" -L"$prefix/lib" -ldualsig $libs \
  >> "$work/compile.log" 2>&1 || exit 12

(cd "$work" && ./example_dssign > example.out 2>&1) || exit 13

make -C "$root" uninstall PREFIX="$prefix" > "$work/uninstall.log" 2>&1 || exit 14
list_files "$prefix" > "$work/left_files.txt"
(cd "$prefix" && find . -mindepth 1 -type d | LC_ALL=C sort) > "$work/left_dirs.txt"

make -C "$root" install PREFIX=/opt/dualsig DESTDIR="$work/stage" > "$work/stage.log" 2>&1 || exit 15
list_files "$work/stage" > "$work/staged.txt"
exit 0
