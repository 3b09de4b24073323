#!/usr/bin/env python3
"""check_vtu: parse and check the ParaView output of one dualsig run (used by test/test_vtk.pf).

Usage:
  python3 test/check_vtu.py --pvd OUT.pvd --csv OUT.csv --problem p1|p2 [--exact] [--dual]
                            [--transition X] [--require-reader]

Parses OUT.pvd and every .vtu it lists with the standard library (xml.etree) and checks:
  - the collection: one DataSet per CSV row, timestep = level = 1, 2, ..., files present;
  - the grid: NumberOfPoints/NumberOfCells against the arrays, VTK_TRIANGLE cells with
    0-based vertex numbers, offsets 3, 6, ..., counter-clockwise triangles, z = 0, every
    node used, h (FieldData and CSV) = the longest triangle side computed from the points;
  - every array: size = tuples x components, all values finite;
  - u_h; with --exact: u_exact and error = u_h - u_exact;
  - contact_status: Int32 codes -1 interior, 0 separated, 1 contact, 2 Dirichlet; -1 exactly
    on the nodes off the boundary; u_h = 0 on contact and Dirichlet nodes, > 0 on separated
    ones; P1 has no Dirichlet node, P2 has some; with --transition X: on the finest level
    contact nodes lie on y = 0 left of X + h and separated nodes of y = 0 (corners left out)
    right of X - h;
  - with --dual: est_element >= 0 with sum = est of the FieldData = est of the CSV; for P1
    with space 'paper' the continuous q_h with q_h . nu >= 0 at the ends of every boundary
    edge (feasibility); for P2, and for P1 with space 'hdiv' (RT1), lambda_h (centroid) and
    lambda_h_vertices, whose normal component is continuous across every interior edge
    (H(div) field) and >= 0 on Signorini edges.
If the python modules meshio or vtk can be imported (here or by the Debian interpreter
/usr/bin/python3, where python3-meshio installs), every file is also read with them and
compared with the xml.etree values.  --require-reader makes the absence of both an error.

Exit status 0 when every check passes, 1 otherwise (messages on stdout).
"""

import argparse
import csv
import math
import os
import subprocess
import sys
import xml.etree.ElementTree as ET

CONTACT_CODES = {-1, 0, 1, 2}   # interior, separated, contact, Dirichlet
VTK_TRIANGLE = 5
REL_TOL = 1e-12                 # rounding of sums and of the ASCII round trip (17 digits)
FLUX_REL_TOL = 1e-8             # normal-flux continuity / sign, relative to max |field|
DEBIAN_PYTHON = '/usr/bin/python3'


class CheckError(Exception):
    pass


def need(cond, msg):
    if not cond:
        raise CheckError(msg)


def parse_array(da, where):
    """Values of an ASCII DataArray as a list of floats (ints for integer types)."""
    need(da.get('format', 'ascii') == 'ascii', f'{where}: format {da.get("format")} (expected ascii)')
    typ = da.get('type')
    text = (da.text or '').split()
    if typ.startswith('Int') or typ.startswith('UInt'):
        return [int(t) for t in text]
    need(typ in ('Float64', 'Float32'), f'{where}: unexpected type {typ}')
    vals = [float(t) for t in text]
    need(all(math.isfinite(v) for v in vals), f'{where}: non-finite value')
    return vals


def arrays_of(node, where):
    out = {}
    if node is None:
        return out
    for da in node.findall('DataArray'):
        name = da.get('Name')
        need(name is not None, f'{where}: DataArray without Name')
        need(name not in out, f'{where}: duplicate array {name}')
        out[name] = (da, parse_array(da, f'{where}/{name}'))
    return out


def ncomp(da):
    return int(da.get('NumberOfComponents', '1'))


def read_csv(path):
    with open(path, newline='') as f:
        rows = list(csv.DictReader(f))
    need(len(rows) > 0, f'{path}: no rows')
    return rows


def check_vtu(path, level, row, args):
    """All xml.etree checks of one level file; returns a summary for the reader comparison."""
    root = ET.parse(path).getroot()
    need(root.tag == 'VTKFile' and root.get('type') == 'UnstructuredGrid', f'{path}: not an UnstructuredGrid')
    grid = root.find('UnstructuredGrid')
    pieces = grid.findall('Piece')
    need(len(pieces) == 1, f'{path}: {len(pieces)} pieces')
    piece = pieces[0]
    n = int(piece.get('NumberOfPoints'))
    t = int(piece.get('NumberOfCells'))
    need(n > 0 and t > 0, f'{path}: empty grid')
    fd = arrays_of(grid.find('FieldData'), f'{path}:FieldData')
    pd = arrays_of(piece.find('PointData'), f'{path}:PointData')
    cd = arrays_of(piece.find('CellData'), f'{path}:CellData')
    pts = arrays_of(piece.find('Points'), f'{path}:Points')
    cells = arrays_of(piece.find('Cells'), f'{path}:Cells')

    # ---- geometry and topology
    need(len(pts) == 1, f'{path}: Points must hold one array')
    pda, p = next(iter(pts.values()))
    need(ncomp(pda) == 3 and len(p) == 3 * n, f'{path}: Points has {len(p)} values, expected {3 * n}')
    xy = [(p[3 * i], p[3 * i + 1]) for i in range(n)]
    need(all(p[3 * i + 2] == 0.0 for i in range(n)), f'{path}: z must be 0')
    conn, offs, types = cells['connectivity'][1], cells['offsets'][1], cells['types'][1]
    need(len(conn) == 3 * t, f'{path}: connectivity has {len(conn)} entries, expected {3 * t}')
    need(offs == [3 * (k + 1) for k in range(t)], f'{path}: offsets are not 3, 6, ...')
    need(types == [VTK_TRIANGLE] * t, f'{path}: cell types other than VTK_TRIANGLE (5)')
    need(all(0 <= v < n for v in conn), f'{path}: connectivity out of range (must be 0-based)')
    need(len(set(conn)) == n, f'{path}: not every point is a triangle vertex')
    tri = [conn[3 * k:3 * k + 3] for k in range(t)]
    hmax = 0.0
    edge_use = {}
    for k, (a, b, c) in enumerate(tri):
        (xa, ya), (xb, yb), (xc, yc) = xy[a], xy[b], xy[c]
        area2 = (xb - xa) * (yc - ya) - (xc - xa) * (yb - ya)
        need(area2 > 0.0, f'{path}: triangle {k} is not counter-clockwise')
        for i, j in ((a, b), (b, c), (c, a)):
            hmax = max(hmax, math.hypot(xy[j][0] - xy[i][0], xy[j][1] - xy[i][1]))
            edge_use.setdefault((min(i, j), max(i, j)), []).append((k, i, j))
    bedges = [v[0] for v in edge_use.values() if len(v) == 1]   # (triangle, from, to): domain on the left
    on_boundary = set()
    for _, i, j in bedges:
        on_boundary.update((i, j))

    # ---- field data
    need(fd['level'][1] == [level], f'{path}: FieldData level {fd["level"][1]}, expected {level}')
    h = fd['h'][1][0]
    need(abs(h - hmax) <= REL_TOL * hmax, f'{path}: FieldData h = {h}, longest side = {hmax}')
    need(abs(h - float(row['h'])) <= REL_TOL * h, f'{path}: FieldData h = {h}, CSV h = {row["h"]}')

    # ---- point data
    def point_array(name, comps):
        need(name in pd, f'{path}: PointData {name} missing')
        da, v = pd[name]
        need(ncomp(da) == comps and len(v) == comps * n, f'{path}: PointData {name} has the wrong size')
        return v

    def cell_array(name, comps):
        need(name in cd, f'{path}: CellData {name} missing')
        da, v = cd[name]
        need(ncomp(da) == comps and len(v) == comps * t, f'{path}: CellData {name} has the wrong size')
        return v

    u = point_array('u_h', 1)
    umax = max(abs(x) for x in u)
    if args.exact:
        ue, err = point_array('u_exact', 1), point_array('error', 1)
        need(all(abs(err[i] - (u[i] - ue[i])) <= REL_TOL * max(umax, 1.0) for i in range(n)),
             f'{path}: error != u_h - u_exact')
    else:
        need('u_exact' not in pd and 'error' not in pd, f'{path}: u_exact written for a scene without one')
    need(pd['contact_status'][0].get('type') == 'Int32', f'{path}: contact_status must be Int32')
    code = point_array('contact_status', 1)
    need(set(code) <= CONTACT_CODES, f'{path}: contact codes {sorted(set(code) - CONTACT_CODES)}')
    for i in range(n):
        need((code[i] == -1) == (i not in on_boundary),
             f'{path}: node {i} at {xy[i]}: code {code[i]} but on_boundary = {i in on_boundary}')
        if code[i] in (1, 2):
            need(abs(u[i]) <= REL_TOL * umax, f'{path}: node {i} has code {code[i]} but u_h = {u[i]}')
        if code[i] == 0:
            need(u[i] > 0.0, f'{path}: separated node {i} has u_h = {u[i]}')
    if args.problem == 'p1':
        need(2 not in code, f'{path}: P1 has no Dirichlet boundary')
    else:
        need(2 in code, f'{path}: P2 needs Dirichlet nodes')
    if args.transition is not None and level == args.levels:
        xmin, xmax = min(x for x, _ in xy), max(x for x, _ in xy)
        for i in range(n):
            x, y = xy[i]
            if code[i] == 1:
                need(y == 0.0 and x < args.transition + h, f'{path}: contact node at {xy[i]}')
            if code[i] == 0 and y == 0.0 and xmin < x < xmax:   # corners are left out
                need(x > args.transition - h, f'{path}: separated node at {xy[i]} left of the transition')
        need(1 in code and 0 in code, f'{path}: expected both contact and separated nodes')

    # ---- dual fields
    if args.dual:
        est_el = cell_array('est_element', 1)
        need(min(est_el) >= 0.0, f'{path}: negative est_element')
        est = fd['est'][1][0]
        s = math.fsum(est_el)
        need(abs(s - est) <= REL_TOL * est, f'{path}: sum of est_element {s} != est {est}')
        need(abs(est - float(row['est'])) <= REL_TOL * est, f'{path}: est {est} != CSV est {row["est"]}')
        if args.problem == 'p1' and 'lambda_h' not in cd:   # P1, space 'paper': continuous nodal q_h
            q = point_array('q_h', 3)
            need(all(q[3 * i + 2] == 0.0 for i in range(n)), f'{path}: q_h z component must be 0')
            qmax = max(abs(v) for v in q)
            for _, i, j in bedges:
                L = math.hypot(xy[j][0] - xy[i][0], xy[j][1] - xy[i][1])
                nu = ((xy[j][1] - xy[i][1]) / L, -(xy[j][0] - xy[i][0]) / L)   # outward
                for a in (i, j):
                    qn = q[3 * a] * nu[0] + q[3 * a + 1] * nu[1]
                    need(qn >= -FLUX_REL_TOL * qmax, f'{path}: q_h . nu = {qn} < 0 at node {a}')
            need('lambda_h' not in cd, f'{path}: lambda_h written for P1')
        else:
            lc = cell_array('lambda_h', 3)
            lv = cell_array('lambda_h_vertices', 6)
            need(all(lc[3 * k + 2] == 0.0 for k in range(t)), f'{path}: lambda_h z component must be 0')
            lmax = max(abs(v) for v in lv)
            need(lmax > 0.0, f'{path}: lambda_h_vertices all zero')

            def lam(k, node):   # lambda_h of triangle k at its vertex `node`
                loc = tri[k].index(node)
                return lv[6 * k + 2 * loc], lv[6 * k + 2 * loc + 1]

            nint = 0
            for (i, j), uses in edge_use.items():
                L = math.hypot(xy[j][0] - xy[i][0], xy[j][1] - xy[i][1])
                nu = ((xy[j][1] - xy[i][1]) / L, -(xy[j][0] - xy[i][0]) / L)
                if len(uses) == 2:
                    nint += 1
                    for a in (i, j):
                        f1 = sum(x * y for x, y in zip(lam(uses[0][0], a), nu))
                        f2 = sum(x * y for x, y in zip(lam(uses[1][0], a), nu))
                        need(abs(f1 - f2) <= FLUX_REL_TOL * lmax,
                             f'{path}: normal flux jumps by {f1 - f2} at node {a} of edge {(i, j)}')
                elif code[i] in (0, 1) and code[j] in (0, 1):   # a Signorini edge
                    k, a0, b0 = uses[0]
                    nu = ((xy[b0][1] - xy[a0][1]) / L, -(xy[b0][0] - xy[a0][0]) / L)
                    for a in (a0, b0):
                        fl = sum(x * y for x, y in zip(lam(k, a), nu))
                        need(fl >= -FLUX_REL_TOL * lmax, f'{path}: lambda_h . nu = {fl} < 0 on Gamma_a')
            need(nint > 0 or t == 1, f'{path}: no interior edge')
            need('q_h' not in pd, f'{path}: q_h written beside lambda_h')
    else:
        need('est_element' not in cd, f'{path}: est_element without a dual analysis')
    return {'n': n, 't': t, 'u_h': u, 'point': sorted(pd), 'cell': sorted(cd)}


def check_readers(files, summaries, require):
    """Read every file with meshio and/or vtk (in this interpreter or /usr/bin/python3)."""
    used = []
    try:
        import meshio  # noqa: F401
        have_meshio = True
    except ImportError:
        have_meshio = False
    try:
        import vtk  # noqa: F401
        have_vtk = True
    except ImportError:
        have_vtk = False
    if have_meshio:
        import meshio
        for path, s in zip(files, summaries):
            m = meshio.read(path)
            need(len(m.points) == s['n'], f'meshio {path}: {len(m.points)} points')
            need(len(m.cells) == 1 and m.cells[0].type == 'triangle' and len(m.cells[0].data) == s['t'],
                 f'meshio {path}: cells')
            need(sorted(m.point_data) == s['point'], f'meshio {path}: point data {sorted(m.point_data)}')
            need(sorted(m.cell_data) == s['cell'], f'meshio {path}: cell data {sorted(m.cell_data)}')
            need(all(abs(a - b) <= REL_TOL * max(1.0, abs(b)) for a, b in zip(m.point_data['u_h'], s['u_h'])),
                 f'meshio {path}: u_h differs')
        used.append('meshio')
    if have_vtk:
        import vtk
        for path, s in zip(files, summaries):
            r = vtk.vtkXMLUnstructuredGridReader()
            r.SetFileName(path)
            r.Update()
            g = r.GetOutput()
            need(g.GetNumberOfPoints() == s['n'] and g.GetNumberOfCells() == s['t'], f'vtk {path}: counts')
            pdn = sorted(g.GetPointData().GetArrayName(k) for k in range(g.GetPointData().GetNumberOfArrays()))
            cdn = sorted(g.GetCellData().GetArrayName(k) for k in range(g.GetCellData().GetNumberOfArrays()))
            need(pdn == s['point'] and cdn == s['cell'], f'vtk {path}: arrays {pdn} {cdn}')
        used.append('vtk')
    if used:
        return used
    # the pyenv/venv interpreter may not see the Debian packages: ask /usr/bin/python3
    if os.path.realpath(sys.executable) != os.path.realpath(DEBIAN_PYTHON) and os.path.exists(DEBIAN_PYTHON):
        probe = subprocess.run([DEBIAN_PYTHON, '-c', 'import meshio'], capture_output=True)
        probe_vtk = subprocess.run([DEBIAN_PYTHON, '-c', 'import vtk'], capture_output=True)
        if probe.returncode == 0 or probe_vtk.returncode == 0:
            return ['delegate']
    need(not require, 'neither meshio nor vtk can be imported (--require-reader)')
    return []


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--pvd', required=True)
    ap.add_argument('--csv', required=True)
    ap.add_argument('--problem', choices=('p1', 'p2'), required=True)
    ap.add_argument('--exact', action='store_true')
    ap.add_argument('--dual', action='store_true')
    ap.add_argument('--transition', type=float)
    ap.add_argument('--require-reader', action='store_true')
    args = ap.parse_args()
    try:
        rows = read_csv(args.csv)
        args.levels = len(rows)
        root = ET.parse(args.pvd).getroot()
        need(root.tag == 'VTKFile' and root.get('type') == 'Collection', f'{args.pvd}: not a Collection')
        ds = root.find('Collection').findall('DataSet')
        need(len(ds) == len(rows), f'{args.pvd}: {len(ds)} data sets for {len(rows)} CSV rows')
        files, summaries = [], []
        for level, (d, row) in enumerate(zip(ds, rows), start=1):
            need(int(d.get('timestep')) == level and int(row['level']) == level,
                 f'{args.pvd}: data set {level} has timestep {d.get("timestep")}')
            f = d.get('file')
            need('/' not in f, f'{args.pvd}: file {f} must be relative to the collection')
            path = os.path.join(os.path.dirname(os.path.abspath(args.pvd)), f)
            need(os.path.isfile(path), f'{args.pvd}: {f} does not exist')
            summaries.append(check_vtu(path, level, row, args))
            files.append(path)
        used = check_readers(files, summaries, args.require_reader)
        if used == ['delegate']:
            r = subprocess.run([DEBIAN_PYTHON] + sys.argv)
            return r.returncode
        print(f'check_vtu: {args.pvd}: {len(files)} level(s) OK; readers: ' +
              (', '.join(used) if used else 'xml.etree only (meshio and vtk not importable)'))
        return 0
    except (CheckError, KeyError, ValueError, ET.ParseError, OSError) as e:
        print(f'check_vtu: FAILED: {type(e).__name__}: {e}')
        return 1


if __name__ == '__main__':
    sys.exit(main())
