#!/usr/bin/env python3
"""check_vtu: parse and check the ParaView output of one dualsig run (used by test/test_vtk.pf).

Usage:
  python3 test/check_vtu.py --pvd OUT.pvd --csv OUT.csv --problem p1|p2 [--exact] [--dual]
                            [--transition X] [--require-reader] [--format binary|ascii]
                            [--same-as OTHER.pvd]
  python3 test/check_vtu.py --dump FILE.vtu
  python3 test/check_vtu.py --compare FILE.vtu OTHER.vtu

Parses OUT.pvd and every .vtu it lists with the standard library (xml.etree; binary
arrays decoded with base64, zlib and struct) and checks:
  - the encoding: format="ascii" arrays, or format="binary" arrays of a file with
    header_type UInt32/UInt64, byte_order and (optionally) compressor="vtkZLibDataCompressor":
    the compression header [nblocks, block size, last block size, compressed sizes] must
    match the data (every block inflates to its stated size); --format requires one of the
    two for every array;
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
compared with the xml.etree values: meshio's points, cells, point data and cell data must
equal them exactly.  --require-reader makes the absence of both an error.
--same-as OTHER.pvd: every level file must hold the same arrays (names, types, components)
with the same values, bit for bit, as the level file of the same level of OTHER.pvd (e.g.
the ascii and the binary output of one run).
--dump FILE.vtu: print every array of one file, decoded: a line
"ARRAY <section> <name> <type> <components> <count>", then one value per line (reals in
Python's repr, which reads back to the same double); no checks.
--compare FILE.vtu OTHER.vtu: the two files hold the same arrays with the same values, bit
for bit (as --same-as, for two single files).

Exit status 0 when every check passes, 1 otherwise (messages on stdout).
"""

import argparse
import base64
import csv
import math
import os
import struct
import subprocess
import sys
import zlib
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


STRUCT_CODES = {'Float64': 'd', 'Float32': 'f', 'Int8': 'b', 'UInt8': 'B', 'Int16': 'h', 'UInt16': 'H',
                'Int32': 'i', 'UInt32': 'I', 'Int64': 'q', 'UInt64': 'Q'}


def b64_chars(nbytes):
    """Characters of the padded base64 encoding of nbytes bytes."""
    return 4 * ((nbytes + 2) // 3)


def decode_binary(text, typ, enc, where):
    """The raw bytes of a format="binary" DataArray of a file with the encoding `enc`
    (byte_order, header_type, compressor of <VTKFile>)."""
    text = ''.join(text.split())
    hcode = {'UInt32': 'I', 'UInt64': 'Q'}.get(enc['header_type'])
    need(hcode is not None, f'{where}: header_type {enc["header_type"]} (expected UInt32 or UInt64)')
    bo = {'LittleEndian': '<', 'BigEndian': '>'}.get(enc['byte_order'])
    need(bo is not None, f'{where}: byte_order {enc["byte_order"]}')
    hsize = struct.calcsize(hcode)
    try:
        if enc['compressor'] is None:     # base64 of [byte count][data]
            raw = base64.b64decode(text, validate=True)
            need(len(raw) >= hsize, f'{where}: binary data shorter than its header')
            nbytes = struct.unpack(bo + hcode, raw[:hsize])[0]
            need(len(raw) - hsize >= nbytes, f'{where}: header says {nbytes} bytes, {len(raw) - hsize} present')
            return raw[hsize:hsize + nbytes]
        need(enc['compressor'] == 'vtkZLibDataCompressor', f'{where}: compressor {enc["compressor"]}')
        # the header and the blocks are base64-encoded separately
        first = base64.b64decode(text[:b64_chars(hsize)], validate=True)
        nblocks = struct.unpack(bo + hcode, first[:hsize])[0]
        hchars = b64_chars((3 + nblocks) * hsize)
        header = struct.unpack(bo + hcode * (3 + nblocks), base64.b64decode(text[:hchars], validate=True)
                               [:(3 + nblocks) * hsize])
        data = base64.b64decode(text[hchars:], validate=True)
    except (ValueError, struct.error) as e:   # binascii.Error is a ValueError
        raise CheckError(f'{where}: bad base64 or header: {e}')
    block, last, csizes = header[1], header[2], header[3:]
    need(sum(csizes) == len(data), f'{where}: compressed sizes sum to {sum(csizes)}, {len(data)} bytes present')
    out, pos = [], 0
    for k, c in enumerate(csizes):
        try:
            chunk = zlib.decompress(data[pos:pos + c])
        except zlib.error as e:
            raise CheckError(f'{where}: block {k + 1} of {nblocks} does not inflate: {e}')
        want = last if (k == nblocks - 1 and last != 0) else block
        need(len(chunk) == want, f'{where}: block {k + 1} inflates to {len(chunk)} bytes, header says {want}')
        out.append(chunk)
        pos += c
    return b''.join(out)


def parse_array(da, where, enc):
    """Values of a DataArray as a list of floats (ints for integer types), ascii or binary."""
    fmt = da.get('format', 'ascii')
    need(fmt in ('ascii', 'binary'), f'{where}: format {fmt} (expected ascii or binary)')
    need(enc['want'] is None or fmt == enc['want'], f'{where}: format {fmt} (expected {enc["want"]})')
    typ = da.get('type')
    need(typ in STRUCT_CODES, f'{where}: unexpected type {typ}')
    if fmt == 'binary':
        raw = decode_binary(da.text or '', typ, enc, where)
        size = struct.calcsize(STRUCT_CODES[typ])
        need(len(raw) % size == 0, f'{where}: {len(raw)} bytes are not a whole number of {typ}')
        bo = '<' if enc['byte_order'] == 'LittleEndian' else '>'
        vals = list(struct.unpack(f'{bo}{len(raw) // size}{STRUCT_CODES[typ]}', raw))
    elif typ.startswith('Int') or typ.startswith('UInt'):
        vals = [int(t) for t in (da.text or '').split()]
    else:
        vals = [float(t) for t in (da.text or '').split()]
    if typ.startswith('Float'):
        vals = [float(v) for v in vals]
        need(all(math.isfinite(v) for v in vals), f'{where}: non-finite value')
    return vals


def encoding_of(root, want=None):
    """The attributes of <VTKFile> that say how binary arrays are stored."""
    return {'byte_order': root.get('byte_order', 'LittleEndian'), 'header_type': root.get('header_type', 'UInt32'),
            'compressor': root.get('compressor'), 'want': want}


def arrays_of(node, where, enc):
    out = {}
    if node is None:
        return out
    for da in node.findall('DataArray'):
        name = da.get('Name')
        need(name is not None, f'{where}: DataArray without Name')
        need(name not in out, f'{where}: duplicate array {name}')
        out[name] = (da, parse_array(da, f'{where}/{name}', enc))
    return out


SECTIONS = ('FieldData', 'PointData', 'CellData', 'Points', 'Cells')


def all_arrays(path, want=None):
    """{(section, name): (type, components, values)} of every array of the file `path`."""
    root = ET.parse(path).getroot()
    enc = encoding_of(root, want)
    grid = root.find('UnstructuredGrid')
    need(grid is not None, f'{path}: not an UnstructuredGrid')
    piece = grid.find('Piece')
    out = {}
    for sec in SECTIONS:
        node = grid.find(sec) if sec == 'FieldData' else (piece.find(sec) if piece is not None else None)
        for name, (da, vals) in arrays_of(node, f'{path}:{sec}', enc).items():
            out[(sec, name)] = (da.get('type'), ncomp(da), vals)
    return out


def same_arrays(path, other):
    """Every array of `path` equals the one of `other` bit for bit (names, types, sizes)."""
    a, b = all_arrays(path), all_arrays(other)
    need(sorted(a) == sorted(b), f'{path}: arrays {sorted(a)} differ from those of {other}: {sorted(b)}')
    for key in sorted(a):
        (ta, ca, va), (tb, cb, vb) = a[key], b[key]
        need(ta == tb and ca == cb, f'{path}: {key[0]}/{key[1]} is {ta} x {ca} but {tb} x {cb} in {other}')
        need(len(va) == len(vb), f'{path}: {key[0]}/{key[1]} has {len(va)} values, {len(vb)} in {other}')
        if ta.startswith('Float'):
            diff = [k for k in range(len(va)) if struct.pack('<d', va[k]) != struct.pack('<d', vb[k])]
        else:
            diff = [k for k in range(len(va)) if va[k] != vb[k]]
        need(not diff, f'{path}: {key[0]}/{key[1]}: {len(diff)} values differ from {other}, first at index '
             f'{diff[0] if diff else 0}: {va[diff[0]] if diff else 0!r} != {vb[diff[0]] if diff else 0!r}')
    return len(a)


def dump(path):
    """Print every array of `path` (see --dump)."""
    for (sec, name), (typ, comps, vals) in all_arrays(path).items():
        print(f'ARRAY {sec} {name} {typ} {comps} {len(vals)}')
        for v in vals:
            print(repr(v))


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
    enc = encoding_of(root, args.format)
    grid = root.find('UnstructuredGrid')
    pieces = grid.findall('Piece')
    need(len(pieces) == 1, f'{path}: {len(pieces)} pieces')
    piece = pieces[0]
    n = int(piece.get('NumberOfPoints'))
    t = int(piece.get('NumberOfCells'))
    need(n > 0 and t > 0, f'{path}: empty grid')
    fd = arrays_of(grid.find('FieldData'), f'{path}:FieldData', enc)
    pd = arrays_of(piece.find('PointData'), f'{path}:PointData', enc)
    cd = arrays_of(piece.find('CellData'), f'{path}:CellData', enc)
    pts = arrays_of(piece.find('Points'), f'{path}:Points', enc)
    cells = arrays_of(piece.find('Cells'), f'{path}:Cells', enc)

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
    return {'n': n, 't': t, 'u_h': u, 'point': sorted(pd), 'cell': sorted(cd), 'xyz': p, 'conn': conn,
            'pd': {k: v[1] for k, v in pd.items()}, 'cd': {k: v[1] for k, v in cd.items()}}


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
            # meshio's values equal the xml.etree ones exactly (ascii: 17 digits read back)
            need(m.points.ravel().tolist() == s['xyz'], f'meshio {path}: points differ')
            need(m.cells[0].data.ravel().tolist() == s['conn'], f'meshio {path}: connectivity differs')
            for name, vals in s['pd'].items():
                need(m.point_data[name].ravel().tolist() == vals, f'meshio {path}: point data {name} differs')
            for name, vals in s['cd'].items():
                need(m.cell_data[name][0].ravel().tolist() == vals, f'meshio {path}: cell data {name} differs')
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
            # VTK's values (ParaView's reader) equal the decoded ones exactly
            pts = g.GetPoints().GetData()
            need([pts.GetComponent(i, c) for i in range(s['n']) for c in range(3)] == s['xyz'],
                 f'vtk {path}: points differ')
            need([g.GetCell(k).GetPointId(j) for k in range(s['t']) for j in range(3)] == s['conn'],
                 f'vtk {path}: connectivity differs')
            for data, arrays in ((g.GetPointData(), s['pd']), (g.GetCellData(), s['cd'])):
                for name, vals in arrays.items():
                    a = data.GetArray(name)
                    nc = a.GetNumberOfComponents()
                    got = [a.GetComponent(i, c) for i in range(a.GetNumberOfTuples()) for c in range(nc)]
                    need(got == [float(v) for v in vals], f'vtk {path}: {name} differs')
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
    if (len(sys.argv) == 3 and sys.argv[1] == '--dump') or (len(sys.argv) == 4 and sys.argv[1] == '--compare'):
        try:
            if sys.argv[1] == '--dump':
                dump(sys.argv[2])
            else:
                n = same_arrays(sys.argv[2], sys.argv[3])
                print(f'check_vtu: {sys.argv[2]}: {n} arrays equal bit for bit to those of {sys.argv[3]}')
            return 0
        except (CheckError, KeyError, ValueError, ET.ParseError, OSError) as e:
            print(f'check_vtu: FAILED: {type(e).__name__}: {e}')
            return 1
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--pvd', required=True)
    ap.add_argument('--csv', required=True)
    ap.add_argument('--problem', choices=('p1', 'p2'), required=True)
    ap.add_argument('--format', choices=('ascii', 'binary'))
    ap.add_argument('--same-as')
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
        same = ''
        if args.same_as:
            other = ET.parse(args.same_as).getroot().find('Collection').findall('DataSet')
            need(len(other) == len(ds), f'{args.same_as}: {len(other)} data sets, {len(ds)} in {args.pvd}')
            narr = 0
            for path, d in zip(files, other):
                narr += same_arrays(path, os.path.join(os.path.dirname(os.path.abspath(args.same_as)), d.get('file')))
            same = f'; {narr} arrays equal bit for bit to those of {args.same_as}'
        used = check_readers(files, summaries, args.require_reader)
        if used == ['delegate']:
            r = subprocess.run([DEBIAN_PYTHON] + sys.argv)
            return r.returncode
        print(f'check_vtu: {args.pvd}: {len(files)} level(s) OK; readers: ' +
              (', '.join(used) if used else 'xml.etree only (meshio and vtk not importable)') + same)
        return 0
    except (CheckError, KeyError, ValueError, ET.ParseError, OSError) as e:
        print(f'check_vtu: FAILED: {type(e).__name__}: {e}')
        return 1


if __name__ == '__main__':
    sys.exit(main())
