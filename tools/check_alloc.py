#!/usr/bin/env python3
"""Check that every allocation of the library sources has its status checked.

Usage: check_alloc.py [--list] SRC_DIR

Every Fortran `allocate (...)` statement under SRC_DIR (continuation lines joined) must
  - have `stat=`, and the status variable must be used within the next three lines
    (`if (alloc_failed(ist, st, ...)) return`, see src/base/dualsig_alloc.f90), or
  - carry a comment starting `! small:` on one of its lines, saying why its size is small
    and fixed (a constant, or a few dozen elements at most).
Failures are printed as `file:line: message`.  Files listed in PENDING are reported but
not failed (a temporary, explicit exemption).  With --list, also print every exempt
(`! small:`) allocation.  Exit status 0 when everything holds, 1 otherwise.
"""
import os
import re
import sys

# Temporary exemptions: files another branch is rewriting (issue 18); the lead converts
# them after merging and then removes them from this list.
PENDING = {
}

ALLOC = re.compile(r"(?<![\w%])allocate\s*\(", re.I)
STAT = re.compile(r"\bstat\s*=\s*([\w%]+)", re.I)
SMALL = re.compile(r"!\s*small:", re.I)


def code(line):
    """The line without its comment (no '!' inside strings of allocate statements)."""
    return line.split("!", 1)[0]


def check_file(path, errors, small, pending):
    lines = open(path, encoding="utf-8").read().split("\n")
    name = os.path.basename(path)
    i = 0
    while i < len(lines):
        text = code(lines[i])
        if not ALLOC.search(text):
            i += 1
            continue
        first, stmt, raw = i, text, [lines[i]]
        while stmt.rstrip().endswith("&") and i + 1 < len(lines):
            i += 1
            stmt = stmt.rstrip()[:-1] + code(lines[i]).lstrip().lstrip("&")
            raw.append(lines[i])
        i += 1
        where = f"{path}:{first + 1}"
        m = STAT.search(stmt)
        if m:
            var = m.group(1).lower()
            after = " ".join(code(l) for l in lines[i:i + 3]).lower()
            if not re.search(r"(?<![\w%])" + re.escape(var) + r"(?![\w%])", after):
                errors.append(f"{where}: stat={m.group(1)} is not checked in the next lines")
            continue
        if any(SMALL.search(l) for l in raw):
            small.append(f"{where}: {raw[0].strip()}")
            continue
        if name in PENDING:
            pending.append(f"{where}: no stat= ({PENDING[name]})")
            continue
        errors.append(f"{where}: allocate without stat= (add stat= and alloc_failed, or a "
                      f"'! small: why' comment if its size is a small constant)")


def main(argv):
    listing = "--list" in argv
    argv = [a for a in argv if a != "--list"]
    if len(argv) != 2:
        print(__doc__)
        return 2
    errors, small, pending, nfile = [], [], [], 0
    for root, _, names in sorted(os.walk(argv[1])):
        for name in sorted(names):
            if name.endswith(".f90"):
                nfile += 1
                check_file(os.path.join(root, name), errors, small, pending)
    if listing:
        for s in small:
            print(f"small: {s}")
    for p in pending:
        print(f"pending: {p}")
    for e in errors:
        print(e)
    if errors:
        print(f"check-alloc: {len(errors)} unchecked allocation(s)")
        return 1
    print(f"check-alloc: every allocation of {nfile} Fortran files checks its status "
          f"({len(small)} marked small; {len(pending)} pending in {len(PENDING)} listed files)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
