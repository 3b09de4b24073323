#!/usr/bin/env python3
"""Check the layering and the size rule of the library sources.

Usage: check_layers.py [--max-lines N] [--graph] SRC_DIR LAYER [LAYER ...]

The layers are given lowest first (the Makefile's LAYERS).  Checks, each failure printed as
`file:line: message`:
  1. every Fortran or C file under SRC_DIR lies in exactly one layer folder SRC_DIR/LAYER/;
  2. a Fortran file holds one module, named like the file (dualsig_x.f90: module dualsig_x),
     or, in the api layer, external procedures only (the F77 entry points);
  3. a module uses only modules of its own layer or of an earlier one (intrinsic modules and
     modules outside SRC_DIR, e.g. iso_c_binding, are not checked);
  4. no subroutine or function is longer than N lines (default 200), counted from its
     first line to its `end` line, comments included.
With --graph, also print the layer graph: for each layer the earlier layers its modules use.
Exit status 0 when everything holds, 1 otherwise; the last line says which.
"""
import os
import re
import sys

START = re.compile(r"^\s*(?:(?:pure|elemental|impure|recursive|module|non_recursive|integer(?:\([^)]*\))?|"
                   r"real(?:\([^)]*\))?|logical(?:\([^)]*\))?|complex(?:\([^)]*\))?|"
                   r"character(?:\([^)]*\))?|type\([^)]*\)|class\([^)]*\))\s+)*"
                   r"(subroutine|function)\s+(\w+)", re.I)
END = re.compile(r"^\s*end\s*(subroutine|function)\b", re.I)
INTERFACE = re.compile(r"^\s*(abstract\s+)?interface\b", re.I)
END_INTERFACE = re.compile(r"^\s*end\s*interface\b", re.I)
MODULE = re.compile(r"^\s*module\s+(\w+)\s*$", re.I)
USE = re.compile(r"^\s*use\s*(?:,\s*(intrinsic|non_intrinsic)\s*::|::)?\s*(\w+)", re.I)


def code(line):
    """The line without its comment (quotes are rare enough in use lines to ignore)."""
    return line.split("!", 1)[0]


def main(argv):
    max_lines, graph = 200, False
    while len(argv) > 1 and argv[1].startswith("--"):
        if argv[1] == "--max-lines" and len(argv) > 2:
            max_lines = int(argv[2])
            argv = argv[:1] + argv[3:]
        elif argv[1] == "--graph":
            graph = True
            argv = argv[:1] + argv[2:]
        else:
            print(__doc__)
            return 2
    if len(argv) < 3:
        print(__doc__)
        return 2
    src, layers = argv[1], argv[2:]
    rank = {name: k for k, name in enumerate(layers)}
    errors = []
    module_layer, files = {}, []
    edges = {name: set() for name in layers}
    for root, _, names in os.walk(src):
        for name in sorted(names):
            if not name.endswith((".f90", ".c")):
                continue
            path = os.path.join(root, name)
            rel = os.path.relpath(path, src).split(os.sep)
            if len(rel) != 2 or rel[0] not in rank:
                errors.append(f"{path}:1: not in a layer folder ({', '.join(layers)})")
                continue
            if name.endswith(".f90"):
                files.append((path, rel[0]))
    for path, layer in files:
        stem = os.path.basename(path)[:-4]
        mods = [MODULE.match(code(l)).group(1).lower() for l in open(path) if MODULE.match(code(l))
                and MODULE.match(code(l)).group(1).lower() != "procedure"]
        if mods:
            if mods != [stem.lower()]:
                errors.append(f"{path}:1: expected exactly one module named {stem}, found {', '.join(mods) or 'none'}")
            module_layer[mods[0]] = layer
        elif layer != "api":
            errors.append(f"{path}:1: no module (external procedures belong to the api layer)")
    for path, layer in files:
        stack, in_interface = [], 0
        for number, line in enumerate(open(path), 1):
            text = code(line)
            m = USE.match(text)
            if m and m.group(1) is None or (m and m.group(1).lower() == "non_intrinsic"):
                used = m.group(2).lower()
                if used in module_layer and module_layer[used] != layer:
                    edges[layer].add(module_layer[used])
                if used in module_layer and rank[module_layer[used]] > rank[layer]:
                    errors.append(f"{path}:{number}: layer '{layer}' uses {used} of the later layer "
                                  f"'{module_layer[used]}'")
            if INTERFACE.match(text):
                in_interface += 1
                continue
            if END_INTERFACE.match(text):
                in_interface -= 1
                continue
            if in_interface:
                continue
            if END.match(text):
                if stack:
                    name, first = stack.pop()
                    length = number - first + 1
                    if length > max_lines:
                        errors.append(f"{path}:{first}: {name} has {length} lines (at most {max_lines})")
            else:
                m = START.match(text)
                if m and not re.match(r"^\s*end\b", text, re.I):
                    stack.append((m.group(2), number))
    if graph:
        for name in layers:
            used = sorted(edges[name], key=rank.get)
            print(f"{name:10s} uses {', '.join(used) if used else '(nothing)'}")
    for e in errors:
        print(e)
    if errors:
        print(f"check-layers: {len(errors)} violation(s)")
        return 1
    print(f"check-layers: {len(files)} Fortran files in {len(layers)} layers, layering and "
          f"procedure size (<= {max_lines} lines) hold")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
