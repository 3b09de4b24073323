#!/usr/bin/env python3
"""Whole-program fuzzing of the dualsig batch program (issue 18's acceptance run).

Every case is generated from (seed, index) alone, so any case can be regenerated with
`--only INDEX`.  A case is a directory with a namelist `run.nml` and mesh files; the program
runs in that directory (so every output lands there) under a time limit.  Kinds of case:

  geometry   a valid coarse mesh (unit square grid, L-shape, Triangle rectangle, Gmsh plate
             with a hole, Gmsh graded L-shape) changed geometrically -- nodes moved a little,
             a lot, across a neighbour's side (folding the mesh), onto another node or side,
             to NaN/Inf/1e300; triangle vertices swapped; triangles doubled, removed, flipped;
             islands added; markers changed; the mesh renumbered, scaled, translated -- and
             written in a random supported format (dualsig text, Gmsh MSH 2.2 / 4.1, Triangle
             .node/.ele/.poly or .edge), run with a valid namelist;
  meshtext   a valid mesh file mutated as text (tokens replaced by -1, 0, 1e999, nan, huge
             integers; lines deleted, duplicated, swapped; counts changed; truncation; BOM,
             tabs, CRLF, NUL bytes);
  namelist   a valid namelist mutated (values replaced by hostile ones and wrong types, keys
             deleted, duplicated, misspelt; groups deleted, duplicated, unclosed; BOM, tabs,
             CRLF, long lines, garbage, batches).

Classification of each run:
  crash      killed by a signal, an exit status outside {0, 2, 3} (doc/user-guide.md, exit
             codes), a Fortran run-time error, backtrace or sanitizer report on stderr, or
             exit 2 without a 'dualsig: error:' message;
  hang       more than --timeout seconds of CPU time (RLIMIT_CPU), or 3 times that on the
             wall clock (blocked);
  bad_result exit 0 or 3 and a table row with energy_lo > energy_hi (beyond a relative
             1e-12 of the magnitudes), est < 0, non-finite est/energy_lo/energy_hi/h/ndof in
             a certified row, Inf anywhere, eff < 1 (exact solution known, domain unchanged),
             certified = 0 with exit status 0, or no table announced;
  bad_mesh   exit 0 or 3 on a mesh the harness finds folded (triangles of both orientations,
             each clearly non-degenerate), with a doubled triangle, or whose triangle areas do
             not sum to the area the boundary loops enclose;
  debris     '.part' or '.bak' files left behind by a process that exited (not killed);
  disagree   certified energy intervals of runs of the same problem on the same domain (mesh
             changed only in ways that keep the domain and its boundary parts) that do not
             intersect: max energy_lo > min energy_hi, so some bound is wrong.
and otherwise ok (exit 0), rejected (exit 2 with a message) or not_certified (exit 3).

Every failing case is saved under OUT/failures/<index>_<class>/ with its inputs, the
program's output and info.txt (class, reasons, mutations, the command).  The summary lists the
counts per class.  Exit status: 0 no failure, 1 some failure, 2 usage error.

Usage: tools/fuzz_driver.py --driver bin/dualsig [--n 10000] [--seed 18] [--jobs 2]
                            [--timeout 20] [--out DIR] [--max-level 3] [--only I,J,...]
"""

import argparse
import concurrent.futures
import math
import os
import random
import re
import resource
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.path.join(ROOT, 'data')

FAILURE_CLASSES = ('crash', 'hang', 'bad_result', 'bad_mesh', 'debris', 'disagree')
OUTCOME_CLASSES = ('ok', 'rejected', 'not_certified')
REL_TOL_BOUNDS = 1e-12        # lo > hi beyond this relative amount of the magnitudes
REL_TOL_DISAGREE = 1e-10      # intervals of different runs: rounding of different meshes
REL_TOL_EFF = 1e-6            # eff >= 1 - this (err_u_H1 is a degree-16 quadrature)
CRASH_PATTERNS = ('Fortran runtime error', 'Error termination', 'Backtrace for this error',
                  'Program received signal', 'ERROR STOP', 'AddressSanitizer', 'LeakSanitizer',
                  'UndefinedBehaviorSanitizer', 'runtime error:', 'Segmentation fault',
                  'Operating system error')


# ============================================================== mesh model
class Mesh:
    """A plane triangle mesh: nodes (x, y), triangles (0-based, counter-clockwise), boundary
    edges (a, b, marker), marker names (Gmsh physical names) and a description."""

    def __init__(self, nodes, tris, bedges, names=None):
        self.nodes = [list(p) for p in nodes]
        self.tris = [list(t) for t in tris]
        self.bedges = [list(e) for e in bedges]
        self.names = dict(names or {})

    def copy(self):
        return Mesh(self.nodes, self.tris, self.bedges, self.names)


def edge_owners(mesh):
    """Map sorted edge -> list of triangle indices."""
    owners = {}
    for k, t in enumerate(mesh.tris):
        for i in range(3):
            a, b = t[i], t[(i + 1) % 3]
            owners.setdefault((min(a, b), max(a, b)), []).append(k)
    return owners


def boundary_nodes(mesh):
    s = set()
    for a, b, _ in mesh.bedges:
        s.add(a)
        s.add(b)
    return s


def signed_area(p, q, r):
    return 0.5 * ((q[0] - p[0]) * (r[1] - p[1]) - (r[0] - p[0]) * (q[1] - p[1]))


def tri_area(mesh, t):
    n = mesh.nodes
    return signed_area(n[t[0]], n[t[1]], n[t[2]])


def refine_red(mesh):
    """Uniform red refinement (each triangle into four), markers kept on the halves."""
    nodes = [list(p) for p in mesh.nodes]
    mid = {}

    def midpoint(a, b):
        key = (min(a, b), max(a, b))
        if key not in mid:
            pa, pb = mesh.nodes[a], mesh.nodes[b]
            nodes.append([0.5 * (pa[0] + pb[0]), 0.5 * (pa[1] + pb[1])])
            mid[key] = len(nodes) - 1
        return mid[key]

    tris = []
    for a, b, c in mesh.tris:
        ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
        tris += [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]]
    bedges = []
    for a, b, m in mesh.bedges:
        c = midpoint(a, b)
        bedges += [[a, c, m], [c, b, m]]
    return Mesh(nodes, tris, bedges, mesh.names)


def square_grid(n, diag):
    """The unit square, n x n cells, diagonals 'right' or 'left'; markers 1 bottom, 2 right,
    3 top, 4 left."""
    def idx(i, j):
        return j * (n + 1) + i
    nodes = [[i / n, j / n] for j in range(n + 1) for i in range(n + 1)]
    tris = []
    for j in range(n):
        for i in range(n):
            a, b, c, d = idx(i, j), idx(i + 1, j), idx(i + 1, j + 1), idx(i, j + 1)
            if diag == 'right':
                tris += [[a, b, c], [a, c, d]]
            else:
                tris += [[a, b, d], [b, c, d]]
    bedges = []
    for i in range(n):
        bedges.append([idx(i, 0), idx(i + 1, 0), 1])
        bedges.append([idx(n, i), idx(n, i + 1), 2])
        bedges.append([idx(n - i, n), idx(n - i - 1, n), 3])
        bedges.append([idx(0, n - i), idx(0, n - i - 1), 4])
    return Mesh(nodes, tris, bedges)


def read_native(path):
    with open(path) as f:
        lines = [ln.split('#')[0].split() for ln in f]
    lines = [ln for ln in lines if ln]
    k = 1
    nn = int(lines[k][1])
    nodes = [[float(v) for v in ln[1:3]] for ln in lines[k + 1:k + 1 + nn]]
    k += 1 + nn
    nt = int(lines[k][1])
    tris = [[int(v) - 1 for v in ln[1:4]] for ln in lines[k + 1:k + 1 + nt]]
    k += 1 + nt
    nb = int(lines[k][1])
    bedges = [[int(ln[1]) - 1, int(ln[2]) - 1, int(ln[3])] for ln in lines[k + 1:k + 1 + nb]]
    return Mesh(nodes, tris, bedges)


def read_triangle(base):
    def rows(path):
        with open(path) as f:
            out = [ln.split('#')[0].split() for ln in f]
        return [r for r in out if r]
    nd = rows(base + '.node')
    first = int(nd[1][0])
    nodes = [[float(r[1]), float(r[2])] for r in nd[1:1 + int(nd[0][0])]]
    el = rows(base + '.ele')
    tris = [[int(v) - first for v in r[1:4]] for r in el[1:1 + int(el[0][0])]]
    po = rows(base + '.poly')
    nseg = int(po[1][0])
    bedges = [[int(r[1]) - first, int(r[2]) - first, int(r[3])] for r in po[2:2 + nseg]]
    return Mesh(nodes, tris, bedges)


def read_gmsh2(path):
    with open(path) as f:
        lines = [ln.strip() for ln in f]
    names = {}
    i = lines.index('$PhysicalNames')
    for ln in lines[i + 2:i + 2 + int(lines[i + 1])]:
        d, tag, name = ln.split(None, 2)
        if d == '1':
            names[int(tag)] = name.strip('"')
    i = lines.index('$Nodes')
    ids, xy = {}, []
    for ln in lines[i + 2:i + 2 + int(lines[i + 1])]:
        v = ln.split()
        ids[int(v[0])] = len(xy)
        xy.append([float(v[1]), float(v[2])])
    i = lines.index('$Elements')
    raw_tris, raw_lines = [], []
    for ln in lines[i + 2:i + 2 + int(lines[i + 1])]:
        v = [int(s) for s in ln.split()]
        ntag = v[2]
        conn = [ids[n] for n in v[3 + ntag:]]
        if v[1] == 2:
            raw_tris.append(conn)
        elif v[1] == 1:
            raw_lines.append(conn + [v[3]])
    used = sorted({n for t in raw_tris for n in t})
    new = {old: k for k, old in enumerate(used)}
    mesh = Mesh([xy[o] for o in used], [[new[n] for n in t] for t in raw_tris],
                [[new[a], new[b], m] for a, b, m in raw_lines], names)
    for t in mesh.tris:                       # counter-clockwise
        if tri_area(mesh, t) < 0:
            t[1], t[2] = t[2], t[1]
    return mesh


def base_meshes():
    """The valid meshes the geometric mutations start from."""
    lshape = refine_red(read_native(os.path.join(DATA, 'lshape_coarse.mesh')))
    return {
        'square3': square_grid(3, 'right'),
        'square4': square_grid(4, 'left'),
        'lshape': lshape,
        'rect_triangle': read_triangle(os.path.join(DATA, 'rect_triangle')),
        'plate_hole': read_gmsh2(os.path.join(DATA, 'plate_hole_v2.msh')),
        'graded_corner': read_gmsh2(os.path.join(DATA, 'graded_corner_v2.msh')),
    }


# ============================================================== mesh writers
def fmt(v):
    if isinstance(v, str):
        return v
    if math.isnan(v):
        return 'nan'
    if math.isinf(v):
        return 'inf' if v > 0 else '-inf'
    return repr(float(v))


def write_native(mesh, base, rng):
    path = base + '.mesh'
    out = ['# fuzz case', 'dualsig-mesh 1', 'nodes %d' % len(mesh.nodes)]
    out += ['%d %s %s' % (i + 1, fmt(p[0]), fmt(p[1])) for i, p in enumerate(mesh.nodes)]
    out.append('triangles %d' % len(mesh.tris))
    out += ['%d %d %d %d' % (i + 1, t[0] + 1, t[1] + 1, t[2] + 1) for i, t in enumerate(mesh.tris)]
    out.append('boundary %d' % len(mesh.bedges))
    out += ['%d %d %d %d' % (i + 1, e[0] + 1, e[1] + 1, e[2]) for i, e in enumerate(mesh.bedges)]
    with open(path, 'w') as f:
        f.write('\n'.join(out) + '\n')
    return [path], os.path.basename(path)


def gmsh_ids(mesh, rng):
    """Node ids for Gmsh: 1..N, or with gaps, or shuffled."""
    n = len(mesh.nodes)
    mode = rng.random()
    if mode < 0.6:
        return list(range(1, n + 1))
    if mode < 0.8:
        return [3 * i + 7 for i in range(n)]
    ids = list(range(1, n + 1))
    rng.shuffle(ids)
    return ids


def physical_names_block(mesh):
    markers = sorted({e[2] for e in mesh.bedges})
    out = ['$PhysicalNames', str(len(markers) + 1)]
    for m in markers:
        out.append('1 %d "%s"' % (m, mesh.names.get(m, 'curve%d' % m)))
    out += ['2 20 "domain"', '$EndPhysicalNames']
    return out


def write_gmsh2(mesh, base, rng):
    path = base + '.msh'
    ids = gmsh_ids(mesh, rng)
    out = ['$MeshFormat', '2.2 0 8', '$EndMeshFormat'] + physical_names_block(mesh)
    order = list(range(len(mesh.nodes)))
    if rng.random() < 0.3:
        rng.shuffle(order)
    out += ['$Nodes', str(len(order))]
    out += ['%d %s %s 0' % (ids[i], fmt(mesh.nodes[i][0]), fmt(mesh.nodes[i][1])) for i in order]
    out += ['$EndNodes', '$Elements', str(len(mesh.bedges) + len(mesh.tris))]
    k = 0
    for a, b, m in mesh.bedges:
        k += 1
        out.append('%d 1 2 %d %d %d %d' % (k, m, m, ids[a], ids[b]))
    for t in mesh.tris:
        k += 1
        out.append('%d 2 2 20 1 %d %d %d' % (k, ids[t[0]], ids[t[1]], ids[t[2]]))
    out.append('$EndElements')
    with open(path, 'w') as f:
        f.write('\n'.join(out) + '\n')
    return [path], os.path.basename(path)


def write_gmsh4(mesh, base, rng):
    path = base + '.msh'
    ids = gmsh_ids(mesh, rng)
    markers = sorted({e[2] for e in mesh.bedges})
    out = ['$MeshFormat', '4.1 0 8', '$EndMeshFormat'] + physical_names_block(mesh)
    out += ['$Entities', '0 %d 1 0' % len(markers)]
    for m in markers:
        out.append('%d 0 0 0 1 1 0 1 %d 0' % (m, m))
    out.append('1 0 0 0 1 1 0 1 20 %d %s' % (len(markers), ' '.join(str(m) for m in markers)))
    out.append('$EndEntities')
    n = len(mesh.nodes)
    out += ['$Nodes', '1 %d %d %d' % (n, min(ids), max(ids)), '2 1 0 %d' % n]
    out += [str(ids[i]) for i in range(n)]
    out += ['%s %s 0' % (fmt(p[0]), fmt(p[1])) for p in mesh.nodes]
    out.append('$EndNodes')
    nelem = len(mesh.bedges) + len(mesh.tris)
    out += ['$Elements', '%d %d 1 %d' % (len(markers) + 1, nelem, nelem)]
    k = 0
    for m in markers:
        es = [e for e in mesh.bedges if e[2] == m]
        out.append('1 %d 1 %d' % (m, len(es)))
        for a, b, _ in es:
            k += 1
            out.append('%d %d %d' % (k, ids[a], ids[b]))
    out.append('2 1 2 %d' % len(mesh.tris))
    for t in mesh.tris:
        k += 1
        out.append('%d %d %d %d' % (k, ids[t[0]], ids[t[1]], ids[t[2]]))
    out.append('$EndElements')
    with open(path, 'w') as f:
        f.write('\n'.join(out) + '\n')
    return [path], os.path.basename(path)


def write_triangle(mesh, base, rng):
    first = rng.choice((0, 1))
    paths = [base + '.node', base + '.ele']
    bn = boundary_nodes(mesh)
    with open(base + '.node', 'w') as f:
        f.write('%d 2 0 1\n' % len(mesh.nodes))
        for i, p in enumerate(mesh.nodes):
            f.write('%d %s %s %d\n' % (i + first, fmt(p[0]), fmt(p[1]), 1 if i in bn else 0))
    with open(base + '.ele', 'w') as f:
        f.write('%d 3 0\n' % len(mesh.tris))
        for i, t in enumerate(mesh.tris):
            f.write('%d %d %d %d\n' % (i + first, t[0] + first, t[1] + first, t[2] + first))
    if rng.random() < 0.7:
        paths.append(base + '.poly')
        with open(base + '.poly', 'w') as f:
            f.write('0 2 0 1\n%d 1\n' % len(mesh.bedges))
            for i, (a, b, m) in enumerate(mesh.bedges):
                f.write('%d %d %d %d\n' % (i + first, a + first, b + first, m))
            f.write('0\n')
    else:
        paths.append(base + '.edge')
        marks = {(min(a, b), max(a, b)): m for a, b, m in mesh.bedges}
        edges = list(edge_owners(mesh).keys())
        for a, b, m in mesh.bedges:
            if (min(a, b), max(a, b)) not in edge_owners(mesh):
                edges.append((a, b))
        with open(base + '.edge', 'w') as f:
            f.write('%d 1\n' % len(edges))
            for i, (a, b) in enumerate(edges):
                f.write('%d %d %d %d\n' % (i + first, a + first, b + first,
                                          marks.get((min(a, b), max(a, b)), 0)))
    name = os.path.basename(rng.choice([base, base + '.node', base + '.ele']))
    return paths, name


WRITERS = {'dualsig': write_native, 'gmsh2': write_gmsh2, 'gmsh4': write_gmsh4,
           'triangle': write_triangle}


# ============================================================== problems per base mesh
def problems_for(base):
    """Valid namelist groups (run, problem) for a base mesh; each has an id, and whether its
    scene has an exact solution on the base domain."""
    if base.startswith('square'):
        return [
            ('p2_contact', {'scene': "'p2_contact'", 'gamma_u_markers': '2, 3, 4',
                            'gamma_a_markers': '1'}, None, True),
            ('p1_contact', {'scene': "'p1_contact'", 'gamma_a_markers': '1, 2, 3, 4'}, None, True),
            ('p2_expr', {'gamma_u_markers': '2, 3, 4', 'gamma_a_markers': '1'},
             {'kind': "'P2'", 'f': "'20*x + 5*sin(pi*y) - 10'"}, False),
            ('p1_expr', {}, {'kind': "'P1'", 'f': "'1 - 4*x*y'"}, False),
        ]
    if base in ('lshape', 'graded_corner'):
        return [
            ('p2_lshape_load', {'scene': "'p2_lshape_load'", 'gamma_u_markers': '4, 5, 6',
                                'gamma_a_markers': '1, 2, 3'}, None, False),
            ('p2_lshape_corner', {'scene': "'p2_lshape_corner'", 'gamma_u_markers': '2, 3',
                                  'gamma_a_markers': '1, 4, 5, 6'}, None, False),
            ('p1_lshape_load', {'scene': "'p1_lshape_load'",
                                'gamma_a_markers': '1, 2, 3, 4, 5, 6'}, None, False),
        ]
    if base == 'rect_triangle':
        return [
            ('p2_rect', {'scene': "'p2_lshape_load'", 'gamma_u_markers': '2, 3, 4',
                         'gamma_a_markers': '1'}, None, False),
            ('p1_rect', {}, {'kind': "'P1'", 'f': "'1 - 4*x*y'"}, False),
        ]
    if base == 'plate_hole':
        return [
            ('p2_plate', {'gamma_u_names': "'left', 'hole'", 'gamma_a_names': "'bottom', 'right', 'top'"},
             {'kind': "'P2'", 'f': "'-1 + 3*y'"}, False),
            ('p2_plate_break', {'gamma_u_markers': '4, 5', 'gamma_a_markers': '1, 2, 3'},
             {'kind': "'P2'", 'f': "'if(x < 0.5, -1, 2*y)'", 'breaks': '0.5'}, False),
            ('p1_plate', {}, {'kind': "'P1'", 'f': "'1 - 4*x*y'"}, False),
        ]
    raise ValueError(base)


def solver_groups(rng, base, kind):
    small = base in ('square3', 'square4', 'lshape', 'rect_triangle')
    methods = ['active_set', 'auto', 'schur'] + (['psor'] if small else [])
    solver = {'method': "'%s'" % rng.choice(methods)}
    if solver['method'] == "'psor'":
        solver['omega_auto'] = '.true.'
    dual = {'enabled': '.true.'}
    r = rng.random()
    if kind == 'P1' and r < 0.25:
        dual['space'] = "'paper'"
    elif r < 0.35 and small:
        dual['method'] = "'uzawa'"
    elif r < 0.45:
        dual['ordering'] = "'%s'" % rng.choice(('amd', 'metis', 'best', 'natural'))
    return solver, dual


def render_namelist(groups):
    """groups: list of (name, [(key, value), ...]) -> namelist text."""
    out = []
    for name, items in groups:
        out.append('&' + name)
        for k, v in items:
            out.append('  %s = %s' % (k, v))
        out.append('/')
    return '\n'.join(out) + '\n'


def mesh_case_groups(rng, base, mesh_file, levels, fmt_name=None, problem=None):
    probs = problems_for(base)
    pid, run, prob, exact = problem or rng.choice(probs)
    kind = 'P1' if 'p1' in pid else 'P2'
    run_items = [('title', "'fuzz %s'" % pid), ('output', "'out/t'")] + list(run.items())
    if rng.random() < 0.1:
        run_items.append(('vtk', '.true.'))
    if rng.random() < 0.1:
        run_items.append(('latex', '.true.'))
    if fmt_name is None or not fmt_name.startswith('gmsh'):
        # boundary parts by name need a Gmsh file: the same parts by marker
        by_name = {"'left', 'hole'": '4, 5', "'bottom', 'right', 'top'": '1, 2, 3'}
        run_items = [(k.replace('_names', '_markers'), by_name[v]) if k.endswith('_names') else (k, v)
                     for k, v in run_items]
    mesh_items = [('source', "'file'"), ('file', "'%s'" % mesh_file), ('levels', str(levels))]
    if fmt_name and rng.random() < 0.3:
        mesh_items.append(('format', "'%s'" % ('gmsh' if fmt_name.startswith('gmsh') else fmt_name)))
    solver, dual = solver_groups(rng, base, kind)
    groups = [('run', run_items), ('mesh', mesh_items)]
    if prob:
        groups.append(('problem', list(prob.items())))
    groups += [('solver', list(solver.items())), ('dual', list(dual.items()))]
    if rng.random() < 0.08 and dual.get('method') != "'uzawa'":
        # adaptive steps instead of uniform levels (not with the paper's Uzawa: it takes its
        # 20000 iterations at every step, tens of steps; see doc/testing.md, Fuzzing)
        groups.append(('adapt', [('enabled', '.true.'), ('theta', rng.choice(('0.3', '0.5', '1.0'))),
                                 ('max_ndof', str(rng.choice((60, 150, 300))))]))
    return groups, pid, exact


# ============================================================== geometric mutations
def interior_nodes(mesh):
    bn = boundary_nodes(mesh)
    used = {n for t in mesh.tris for n in t}
    return [i for i in range(len(mesh.nodes)) if i not in bn and i in used]


def local_h(mesh, node):
    h = []
    p = mesh.nodes[node]
    for t in mesh.tris:
        if node in t:
            for q in t:
                if q != node:
                    h.append(math.hypot(mesh.nodes[q][0] - p[0], mesh.nodes[q][1] - p[1]))
    return min(h) if h else 0.1


def straight_boundary_node(mesh, node):
    """(prev, next, marker) when the node lies inside a straight boundary side with the same
    marker on both of its boundary edges, else None."""
    ins = [e for e in mesh.bedges if e[1] == node]
    outs = [e for e in mesh.bedges if e[0] == node]
    if len(ins) != 1 or len(outs) != 1 or ins[0][2] != outs[0][2]:
        return None
    a, b = ins[0][0], outs[0][1]
    pa, p, pb = mesh.nodes[a], mesh.nodes[node], mesh.nodes[b]
    cross = (p[0] - pa[0]) * (pb[1] - pa[1]) - (p[1] - pa[1]) * (pb[0] - pa[0])
    scale = math.hypot(pb[0] - pa[0], pb[1] - pa[1]) ** 2
    if abs(cross) > 1e-12 * scale:
        return None
    return a, b, ins[0][2]


def mut_move_interior(mesh, rng):
    nodes = interior_nodes(mesh)
    if not nodes:
        return mut_move_boundary(mesh, rng)
    i = rng.choice(nodes)
    h = local_h(mesh, i)
    size = rng.choice(('small', 'medium', 'large', 'huge'))
    f = {'small': rng.uniform(0.01, 0.3), 'medium': rng.uniform(0.3, 0.9),
         'large': rng.uniform(0.9, 2.5), 'huge': rng.uniform(2.5, 20)}[size]
    ang = rng.uniform(0, 2 * math.pi)
    mesh.nodes[i] = [mesh.nodes[i][0] + f * h * math.cos(ang), mesh.nodes[i][1] + f * h * math.sin(ang)]
    return 'interior node %d moved %s (%.3g h)' % (i + 1, size, f), True


def mut_fold_across(mesh, rng):
    """Move an interior node just across the opposite side of one of its triangles."""
    nodes = interior_nodes(mesh)
    if not nodes:
        return mut_move_boundary(mesh, rng)
    i = rng.choice(nodes)
    t = rng.choice([t for t in mesh.tris if i in t])
    a, b = [q for q in t if q != i]
    pa, pb, p = mesh.nodes[a], mesh.nodes[b], mesh.nodes[i]
    s = rng.uniform(0.2, 0.8)
    foot = [pa[0] + s * (pb[0] - pa[0]), pa[1] + s * (pb[1] - pa[1])]
    eps = rng.choice((1e-14, 1e-12, 1e-10, 1e-8, 1e-6, 1e-3, 0.05, 0.3))
    mesh.nodes[i] = [foot[0] + eps * (foot[0] - p[0]), foot[1] + eps * (foot[1] - p[1])]
    return 'interior node %d moved across the side (%d,%d) by %g of its distance' % (i + 1, a + 1, b + 1, eps), True


def mut_onto(mesh, rng):
    """A node onto another node (duplicate), onto a side (zero area), or almost."""
    i = rng.randrange(len(mesh.nodes))
    t = rng.choice([t for t in mesh.tris if i in t] or mesh.tris)
    others = [q for q in t if q != i] or [0]
    j = rng.choice(others)
    eps = rng.choice((0.0, 0.0, 1e-15, 1e-13, 1e-11))
    if rng.random() < 0.5:
        pj = mesh.nodes[j]
        mesh.nodes[i] = [pj[0] + eps, pj[1] - eps]
        return 'node %d moved onto node %d (+%g)' % (i + 1, j + 1, eps), False
    if len(others) == 2:
        pa, pb = mesh.nodes[others[0]], mesh.nodes[others[1]]
        mesh.nodes[i] = [0.5 * (pa[0] + pb[0]) + eps, 0.5 * (pa[1] + pb[1]) + eps]
    return 'node %d moved onto the midpoint of the opposite side (+%g)' % (i + 1, eps), False


def mut_move_boundary(mesh, rng):
    bn = sorted(boundary_nodes(mesh))
    i = rng.choice(bn)
    h = local_h(mesh, i)
    sb = straight_boundary_node(mesh, i)
    mode = rng.random()
    if sb and mode < 0.35:
        a, b, _ = sb
        pa, pb = mesh.nodes[a], mesh.nodes[b]
        f = rng.choice((rng.uniform(-0.3, 0.3), rng.uniform(-1.5, 1.5)))
        d = [pb[0] - pa[0], pb[1] - pa[1]]
        L = math.hypot(*d)
        p = mesh.nodes[i]
        mesh.nodes[i] = [p[0] + f * h * d[0] / L, p[1] + f * h * d[1] / L]
        # the domain stays the same while the node stays strictly between its neighbours
        t = ((mesh.nodes[i][0] - pa[0]) * d[0] + (mesh.nodes[i][1] - pa[1]) * d[1]) / L ** 2
        keep = 0.01 < t < 0.99 and abs(f) < 0.5
        return 'boundary node %d slid along its side by %.3g h' % (i + 1, f), keep
    f = rng.choice((rng.uniform(-0.4, 0.4), rng.uniform(-3, 3)))
    ang = rng.uniform(0, 2 * math.pi)
    p = mesh.nodes[i]
    mesh.nodes[i] = [p[0] + f * h * math.cos(ang), p[1] + f * h * math.sin(ang)]
    return 'boundary node %d moved by %.3g h' % (i + 1, f), False


def mut_far(mesh, rng):
    i = rng.randrange(len(mesh.nodes))
    xs = [p[0] for p in mesh.nodes]
    ys = [p[1] for p in mesh.nodes]
    mesh.nodes[i] = [rng.uniform(min(xs), max(xs)), rng.uniform(min(ys), max(ys))]
    return 'node %d moved to a random point of the bounding box' % (i + 1), i in interior_nodes(mesh)


def mut_special_coord(mesh, rng):
    i = rng.randrange(len(mesh.nodes))
    v = rng.choice((float('nan'), float('inf'), -float('inf'), 1e300, -1e300, 1e-300, 1e154,
                    '1e999', '-0.0', '1.0d0', '0x1p3', '1,5'))
    c = rng.randrange(2)
    mesh.nodes[i][c] = v
    return 'node %d coordinate %d set to %s' % (i + 1, c + 1, fmt(v)), False


def mut_swap_vertices(mesh, rng):
    r = rng.random()
    if r < 0.15:
        for t in mesh.tris:
            t[1], t[2] = t[2], t[1]
        return 'every triangle clockwise', True
    k = rng.randrange(len(mesh.tris))
    t = mesh.tris[k]
    t[1], t[2] = t[2], t[1]
    return 'vertices 2 and 3 of triangle %d swapped (clockwise)' % (k + 1), False


def mut_rotate_vertices(mesh, rng):
    for t in mesh.tris:
        s = rng.randrange(3)
        t[:] = t[s:] + t[:s]
    return 'triangle vertices rotated cyclically', True


def mut_duplicate_triangle(mesh, rng):
    k = rng.randrange(len(mesh.tris))
    t = list(mesh.tris[k])
    s = rng.randrange(3)
    t = t[s:] + t[:s]
    if rng.random() < 0.3:
        t[1], t[2] = t[2], t[1]
    mesh.tris.insert(rng.randrange(len(mesh.tris) + 1), t)
    return 'triangle %d listed twice' % (k + 1), False


def mut_island(mesh, rng):
    xs = [p[0] for p in mesh.nodes]
    ys = [p[1] for p in mesh.nodes]
    w = max(xs) - min(xs)
    markers = sorted({e[2] for e in mesh.bedges})
    m = rng.choice(markers)
    r = rng.random()
    n0 = len(mesh.nodes)
    if r < 0.4:                                   # a separate triangle to the right
        x0 = max(xs) + rng.choice((0.5, 0.01, 1e-9)) * w
        mesh.nodes += [[x0, min(ys)], [x0 + 0.3 * w, min(ys)], [x0, min(ys) + 0.3 * w]]
        what = 'a separate triangle'
    elif r < 0.7:                                 # a triangle touching at a corner
        c = min(range(n0), key=lambda i: (mesh.nodes[i][0], mesh.nodes[i][1]))
        pc = mesh.nodes[c]
        mesh.nodes += [[pc[0] - 0.3 * w, pc[1] - 0.3 * w], [pc[0], pc[1] - 0.3 * w]]
        mesh.tris.append([c, n0, n0 + 1])
        mesh.bedges += [[c, n0, m], [n0, n0 + 1, m], [n0 + 1, c, m]]
        return 'a triangle touching the mesh at node %d' % (c + 1), False
    else:                                         # an island inside the domain (overlap)
        t = mesh.tris[rng.randrange(len(mesh.tris))]
        cx = sum(mesh.nodes[q][0] for q in t) / 3
        cy = sum(mesh.nodes[q][1] for q in t) / 3
        d = 0.05 * local_h(mesh, t[0])
        mesh.nodes += [[cx - d, cy - d], [cx + d, cy - d], [cx, cy + d]]
        what = 'a triangle inside triangle %d' % (mesh.tris.index(t) + 1)
    mesh.tris.append([n0, n0 + 1, n0 + 2])
    mesh.bedges += [[n0, n0 + 1, m], [n0 + 1, n0 + 2, m], [n0 + 2, n0, m]]
    return what, False


def mut_remove_triangle(mesh, rng):
    """Remove a triangle; its new boundary sides get a marker (a valid notch or hole) or not."""
    owners = edge_owners(mesh)
    k = rng.randrange(len(mesh.tris))
    t = mesh.tris.pop(k)
    bset = {(min(a, b), max(a, b)): e for e in mesh.bedges for a, b in [e[:2]]}
    mark = rng.random() < 0.6
    markers = sorted({e[2] for e in mesh.bedges})
    m = rng.choice(markers)
    for i in range(3):
        a, b = t[i], t[(i + 1) % 3]
        key = (min(a, b), max(a, b))
        if key in bset:                          # it was a boundary side: gone
            mesh.bedges.remove(bset[key])
        elif mark and len(owners[key]) == 2:
            mesh.bedges.append([b, a, m])        # the neighbour keeps the domain on its left
    used = {q for tt in mesh.tris for q in tt}
    unused = [q for q in range(len(mesh.nodes)) if q not in used]
    if unused and mark:                          # a corner node left alone: drop it
        return mut_renumber_drop(mesh, unused, 'triangle %d removed' % (k + 1))
    return 'triangle %d removed (new sides %s)' % (k + 1, 'marked %d' % m if mark else 'unmarked'), False


def mut_renumber_drop(mesh, unused, what):
    keep = [q for q in range(len(mesh.nodes)) if q not in unused]
    new = {q: i for i, q in enumerate(keep)}
    mesh.nodes = [mesh.nodes[q] for q in keep]
    mesh.tris = [[new[q] for q in t] for t in mesh.tris]
    mesh.bedges = [[new[a], new[b], m] for a, b, m in mesh.bedges if a in new and b in new]
    return what + ' (its free node dropped)', False


def mut_edge_flip(mesh, rng):
    owners = edge_owners(mesh)
    inner = [e for e, o in owners.items() if len(o) == 2]
    if not inner:
        return mut_move_interior(mesh, rng)
    a, b = rng.choice(inner)
    k1, k2 = owners[(a, b)]
    c = [q for q in mesh.tris[k1] if q not in (a, b)][0]
    d = [q for q in mesh.tris[k2] if q not in (a, b)][0]
    t1, t2 = [c, d, a], [d, c, b]
    if tri_area(mesh, t1) < 0:
        t1 = [d, c, a]
        t2 = [c, d, b]
    mesh.tris[k1], mesh.tris[k2] = t1, t2
    ok = tri_area(mesh, t1) > 0 and tri_area(mesh, t2) > 0
    return 'diagonal (%d,%d) flipped to (%d,%d)%s' % (a + 1, b + 1, c + 1, d + 1,
                                                       '' if ok else ' (non-convex quadrilateral)'), True


def mut_permute(mesh, rng):
    perm = list(range(len(mesh.nodes)))
    rng.shuffle(perm)
    new = {old: i for i, old in enumerate(perm)}
    mesh.nodes = [mesh.nodes[o] for o in perm]
    mesh.tris = [[new[q] for q in t] for t in mesh.tris]
    mesh.bedges = [[new[a], new[b], m] if rng.random() < 0.7 else [new[b], new[a], m]
                   for a, b, m in mesh.bedges]
    rng.shuffle(mesh.tris)
    rng.shuffle(mesh.bedges)
    return 'nodes, triangles and boundary edges renumbered', True


def mut_scale(mesh, rng):
    s = rng.choice((1e-6, 1e-3, 1e3, 1e6))
    dx = rng.choice((0.0, 0.0, 1e3, -1e5))
    mesh.nodes = [[p[0] * s + dx, p[1] * s] for p in mesh.nodes]
    return 'coordinates scaled by %g and shifted by %g' % (s, dx), False


def mut_marker(mesh, rng):
    k = rng.randrange(len(mesh.bedges))
    markers = sorted({e[2] for e in mesh.bedges})
    v = rng.choice(markers + [0, -1, 99, 2147483647])
    old = mesh.bedges[k][2]
    mesh.bedges[k][2] = v
    if rng.random() < 0.2:
        del mesh.bedges[k]
        return 'boundary edge %d removed' % (k + 1), False
    return 'boundary edge %d marker %d -> %d' % (k + 1, old, v), v == old


def mut_overlap_copy(mesh, rng):
    """A second copy of a few triangles slightly shifted: overlapping triangles, all ccw."""
    k = rng.randrange(len(mesh.tris))
    t = mesh.tris[k]
    n0 = len(mesh.nodes)
    d = 0.1 * local_h(mesh, t[0])
    for q in t:
        mesh.nodes.append([mesh.nodes[q][0] + d, mesh.nodes[q][1] + 0.5 * d])
    mesh.tris.append([n0, n0 + 1, n0 + 2])
    m = mesh.bedges[0][2]
    mesh.bedges += [[n0, n0 + 1, m], [n0 + 1, n0 + 2, m], [n0 + 2, n0, m]]
    return 'a shifted copy of triangle %d added' % (k + 1), False


GEOMETRIC = [
    (mut_move_interior, 18), (mut_fold_across, 14), (mut_onto, 6), (mut_move_boundary, 10),
    (mut_far, 5), (mut_special_coord, 4), (mut_swap_vertices, 8), (mut_rotate_vertices, 2),
    (mut_duplicate_triangle, 6), (mut_island, 6), (mut_remove_triangle, 6), (mut_edge_flip, 6),
    (mut_permute, 3), (mut_scale, 3), (mut_marker, 4), (mut_overlap_copy, 3),
]


def weighted(rng, table):
    total = sum(w for _, w in table)
    r = rng.uniform(0, total)
    for item, w in table:
        r -= w
        if r <= 0:
            return item
    return table[-1][0]


def geometry_verdict(mesh):
    """'folded', 'duplicate', 'overlap' when the harness can tell for sure that the mesh is
    not a valid triangulation; None otherwise (valid, or not decidable here)."""
    try:
        areas = [tri_area(mesh, t) for t in mesh.tris]
    except (TypeError, IndexError):
        return None
    if not all(math.isfinite(a) for a in areas):
        return None
    total = sum(abs(a) for a in areas)
    if total <= 0:
        return None
    big = [a for a in areas if abs(a) > 1e-6 * total]
    if any(a > 0 for a in big) and any(a < 0 for a in big):
        return 'folded'
    keys = [tuple(sorted(t)) for t in mesh.tris]
    if len(set(keys)) != len(keys):
        return 'duplicate'
    # area enclosed by the boundary loops (shoelace over the boundary edges, domain on the
    # left when the triangles are counter-clockwise)
    sign = 1.0 if sum(areas) > 0 else -1.0
    owners = edge_owners(mesh)
    loop = 0.0
    for key, own in owners.items():
        if len(own) != 1:
            continue
        t = mesh.tris[own[0]]
        for i in range(3):
            a, b = t[i], t[(i + 1) % 3]
            if (min(a, b), max(a, b)) == key:       # about node 0 (no cancellation)
                pa, pb = mesh.nodes[a], mesh.nodes[b]
                loop += signed_area(mesh.nodes[0], pa, pb)
    loop *= sign
    if abs(abs(sum(areas)) - loop) > 1e-6 * total:
        return 'overlap'
    return None


# ============================================================== text mutations
HOSTILE = ['-1', '0', '1', '1e999', '-1e999', 'nan', 'NaN', 'inf', '-Infinity', '2147483647',
           '2147483648', '-2147483649', '99999999999999999999', '1.5', '0.5e-320', '1e308',
           "'abc'", '.true.', "''", 'x', '3*1', '1d300', '1e-9', '0x10', '+', '-']


def mutate_text(text, rng, namelist):
    """One textual mutation of a file's text."""
    lines = text.split('\n')
    r = rng.random()
    i = rng.randrange(max(1, len(lines)))
    if r < 0.30:                                           # a number/value token replaced
        toks = [(m.start(), m.end()) for m in re.finditer(r"[-+]?[0-9][0-9.eEdD+-]*|'[^']*'|\.true\.|\.false\.",
                                                           text)]
        if toks:
            s, e = rng.choice(toks)
            v = rng.choice(HOSTILE)
            return text[:s] + v + text[e:], 'token %r replaced by %r' % (text[s:e], v)
    if r < 0.40:
        del lines[i]
        return '\n'.join(lines), 'line %d deleted' % (i + 1)
    if r < 0.48:
        lines.insert(i, lines[i] if i < len(lines) else '')
        return '\n'.join(lines), 'line %d duplicated' % (i + 1)
    if r < 0.54:
        j = rng.randrange(max(1, len(lines)))
        if i < len(lines) and j < len(lines):
            lines[i], lines[j] = lines[j], lines[i]
        return '\n'.join(lines), 'lines %d and %d swapped' % (i + 1, j + 1)
    if r < 0.60:
        k = rng.randrange(max(1, len(text)))
        return text[:k], 'truncated after %d characters' % k
    if r < 0.64:
        return '\ufeff' + text, 'UTF-8 byte order mark'
    if r < 0.68:
        return text.replace(' ', '\t'), 'blanks replaced by tabs'
    if r < 0.72:
        return text.replace('\n', '\r\n'), 'CRLF line ends'
    if r < 0.75:
        k = rng.randrange(max(1, len(text)))
        return text[:k] + '\x00' + text[k:], 'NUL byte at %d' % k
    if r < 0.78:
        k = rng.randrange(max(1, len(text)))
        junk = ''.join(rng.choice('&/=,\'"!#$*()01.eE-\xe9 \t') for _ in range(rng.randint(1, 8)))
        return text[:k] + junk + text[k:], 'garbage %r inserted at %d' % (junk, k)
    if r < 0.80:
        n = rng.choice((1000, 70000))
        lines.insert(i, 'x' * n if rng.random() < 0.5 else ' ' * n + '1')
        return '\n'.join(lines), 'a line of %d characters' % n
    if r < 0.82:
        lines.insert(i, '\n' * rng.choice((100, 5000)))
        return '\n'.join(lines), 'blank lines inserted'
    if r < 0.88 and namelist:                              # namelist structure
        ends = [j for j, ln in enumerate(lines) if ln.strip() == '/']
        starts = [j for j, ln in enumerate(lines) if ln.lstrip().startswith('&')]
        q = rng.random()
        if q < 0.4 and ends:
            j = rng.choice(ends)
            del lines[j]
            return '\n'.join(lines), "the '/' of line %d deleted (group unclosed)" % (j + 1)
        if q < 0.6 and starts:
            j = rng.choice(starts)
            lines[j] = lines[j].replace('&', '', 1)
            return '\n'.join(lines), "the '&' of line %d deleted" % (j + 1)
        if q < 0.8:
            return ' '.join(lines), 'everything on one line'
        return text.upper(), 'upper case'
    if r < 0.88 and not namelist:                          # a count changed
        for j, ln in enumerate(lines):
            m = re.match(r'^(\s*(?:nodes|triangles|boundary)?\s*)(\d+)(.*)$', ln)
            if m and j >= i:
                v = rng.choice((int(m.group(2)) + 1, max(0, int(m.group(2)) - 1), 2000000000, 0))
                lines[j] = '%s%d%s' % (m.group(1), v, m.group(3))
                return '\n'.join(lines), 'count on line %d set to %d' % (j + 1, v)
    k = rng.randrange(max(1, len(text)))
    c = rng.choice('0123456789 -+.eE/&!\'"=,abcdxyz\t')
    return text[:k] + c + text[k + 1:], 'character %d replaced by %r' % (k, c)


# ============================================================== namelist mutations
NML_KEYS = {
    'run': ['title', 'scene', 'output', 'gamma_u_markers', 'gamma_a_markers', 'gamma_u_names',
            'gamma_a_names', 'vtk', 'latex', 'max_memory_gb'],
    'mesh': ['source', 'file', 'format', 'x0', 'x1', 'y0', 'y1', 'nx', 'ny', 'n', 'pattern', 'levels'],
    'solver': ['method', 'omega', 'omega_auto', 'tol', 'max_iter', 'check_every', 'nested'],
    'dual': ['enabled', 'method', 'rho', 'tol', 'tol_h2', 'max_iter', 'ordering', 'inner',
             'particular', 'space'],
    'problem': ['kind', 'f', 'f_regions', 'f_region_values', 'f_file', 'u_exact', 'breaks'],
    'adapt': ['enabled', 'theta', 'tol', 'max_ndof', 'max_seconds'],
}
VALUE_POOL = HOSTILE + ["'psor'", "'active_set'", "'file'", "'rectangle'", "'lshape'", "'P1'",
                        "'P3'", "'nd'", "'natural'", "'paper'", "'stream'", "'uzawa'", "'x*y'",
                        "'1/x'", "'sqrt(-1)'", "'exp(1000)'", "'if(x<0.5,'", '.false.', "'.'",
                        "'out/'", "'" + 'y' * 300 + "'", '1, 2, 3', "'%s'" % ('z' * 90)]


def generator_groups(rng, max_level):
    """A valid namelist of a generated mesh (no file), for the namelist mutations."""
    r = rng.random()
    levels = str(rng.randint(1, max_level))
    if r < 0.35:
        run = [('scene', rng.choice(("'p2_contact'", "'p1_contact'"))), ('output', "'out/a'")]
        mesh = [('source', "'rectangle'"), ('nx', str(rng.randint(1, 3))), ('ny', str(rng.randint(1, 3))),
                ('pattern', rng.choice(("'right'", "'left'", "'union_jack'"))), ('levels', levels)]
    elif r < 0.6:
        run = [('scene', rng.choice(("'p2_lshape_load'", "'p1_lshape_load'", "'p2_lshape_corner'"))),
               ('output', "'out/b'")]
        mesh = [('source', "'lshape'"), ('n', '1'), ('levels', levels)]
    elif r < 0.75:
        run = [('scene', "'p2_holed_load'"), ('output', "'out/c'")]
        mesh = [('source', "'holed_square'"), ('n', '1'), ('levels', str(min(2, int(levels))))]
    else:
        run = [('output', "'out/d'"), ('gamma_u_markers', '2, 3, 4'), ('gamma_a_markers', '1')]
        mesh = [('source', "'rectangle'"), ('x1', '2.0'), ('nx', '2'), ('ny', '1'), ('levels', levels)]
        groups = [('run', run), ('mesh', mesh),
                  ('problem', [('kind', "'P2'"), ('f', "'if(x < 0.7, -1, 3*y)'"), ('breaks', '0.7')])]
        groups += [('solver', [('method', "'active_set'")]), ('dual', [('enabled', '.true.')])]
        return groups
    groups = [('run', run), ('mesh', mesh), ('solver', [('method', "'%s'" % rng.choice(('active_set', 'auto', 'psor')))]),
              ('dual', [('enabled', '.true.' if rng.random() < 0.85 else '.false.')])]
    if rng.random() < 0.15 and run[0][1] in ("'p2_lshape_corner'", "'p2_lshape_load'"):
        groups.append(('adapt', [('enabled', '.true.'), ('theta', '0.5'), ('max_ndof', '300')]))
    return groups


def mutate_groups(groups, rng):
    """One structural mutation of the namelist groups (a list of (name, items))."""
    gi = rng.randrange(len(groups))
    name, items = groups[gi]
    items = list(items)
    r = rng.random()
    if r < 0.35 and items:                             # a value replaced
        k = rng.randrange(len(items))
        v = rng.choice(VALUE_POOL)
        what = '&%s %s = %s (was %s)' % (name, items[k][0], v[:40], items[k][1][:40])
        items[k] = (items[k][0], v)
    elif r < 0.45 and items:
        k = rng.randrange(len(items))
        what = '&%s %s deleted' % (name, items[k][0])
        del items[k]
    elif r < 0.55 and items:
        k = rng.randrange(len(items))
        v = items[k][1] if rng.random() < 0.5 else rng.choice(VALUE_POOL)
        items.insert(rng.randrange(len(items) + 1), (items[k][0], v))
        what = '&%s %s given twice' % (name, items[k][0])
    elif r < 0.68:                                      # a key added (known or not)
        keys = NML_KEYS.get(name, ['x'])
        key = rng.choice(keys + ['nxx', 'levles', 'méthode', 'a b', 'x(3)', 'tol%re'])
        v = rng.choice(VALUE_POOL)
        items.append((key, v))
        what = '&%s %s = %s added' % (name, key, v[:40])
    elif r < 0.74:
        what = '&%s deleted' % name
        groups = groups[:gi] + groups[gi + 1:]
        return groups or [('run', [])], what
    elif r < 0.80:
        what = '&%s duplicated' % name
        return groups[:gi + 1] + [(name, items)] + groups[gi + 1:], what
    elif r < 0.85:
        other = rng.choice(['slover', 'meshh', 'adapt', 'problem', 'run', 'RUN', 'Dual', 'end'])
        what = '&%s renamed &%s' % (name, other)
        name = other
    elif r < 0.92:
        groups = list(groups)
        rng.shuffle(groups)
        return groups, 'groups shuffled'
    else:                                               # a second run appended (a batch)
        extra = [(n, list(it)) for n, it in groups]
        for n, it in extra:
            if n == 'run':
                it[:] = [(k, v) for k, v in it if k != 'output'] + [('output', "'out/second'")]
        return groups + extra, 'a second run appended'
    groups = groups[:gi] + [(name, items)] + groups[gi + 1:]
    return groups, what


# ============================================================== cases
def case_rng(seed, index):
    return random.Random('dualsig-fuzz:%d:%d' % (seed, index))


def generate_case(seed, index, cdir, bases, max_level):
    """Write the case's inputs into cdir; return its description (a dict)."""
    rng = case_rng(seed, index)
    os.makedirs(cdir, exist_ok=True)
    r = rng.random()
    info = {'index': index, 'mutations': [], 'preserving': True, 'verdict': None,
            'group': None, 'exact': False}
    base = rng.choice(sorted(bases))
    big = base in ('plate_hole', 'graded_corner')
    levels = rng.randint(1, min(max_level, 2 if big else 3))
    fmt_name = rng.choice(sorted(WRITERS))
    if r < 0.55:
        info['kind'] = 'geometry'
        mesh = bases[base].copy()
        for _ in range(rng.choice((1, 1, 1, 2, 2, 3))):
            mutation = weighted(rng, GEOMETRIC)
            what, keep = mutation(mesh, rng)
            info['mutations'].append(what)
            info.setdefault('ops', []).append(mutation.__name__[4:])
            info['preserving'] = info['preserving'] and keep
            if mutation is mut_special_coord:       # no arithmetic on the coordinates after it
                break
        if fmt_name.startswith('gmsh'):
            # the Gmsh reader counts a triangle listed twice once (a surface in several
            # physical groups; doc/mesh-formats.md): judge the mesh it keeps
            seen, kept = set(), []
            for t in mesh.tris:
                if tuple(sorted(t)) not in seen:
                    seen.add(tuple(sorted(t)))
                    kept.append(t)
            judged = Mesh(mesh.nodes, kept, mesh.bedges)
        else:
            judged = mesh
        info['verdict'] = geometry_verdict(judged)
        paths, name = WRITERS[fmt_name](mesh, os.path.join(cdir, 'mesh'), rng)
        groups, pid, exact = mesh_case_groups(rng, base, name, levels, fmt_name)
        if info['preserving'] and info['verdict'] is None:
            # one exact energy per domain, boundary parts and load: the two L-shape meshes
            # and the two unit square grids share it
            domain = {'square3': 'square', 'square4': 'square', 'graded_corner': 'lshape'}.get(base, base)
            info['group'] = '%s/%s' % (domain, pid)
            info['exact'] = exact
        info['base'] = '%s (%s, %s, levels %d)' % (base, fmt_name, pid, levels)
        text = render_namelist(groups)
    elif r < 0.75:
        info['kind'] = 'meshtext'
        mesh = bases[base].copy()
        paths, name = WRITERS[fmt_name](mesh, os.path.join(cdir, 'mesh'), rng)
        target = rng.choice(paths)
        with open(target, encoding='utf-8') as f:
            t = f.read()
        for _ in range(rng.choice((1, 1, 2, 3))):
            t, what = mutate_text(t, rng, namelist=False)
            info['mutations'].append('%s: %s' % (os.path.basename(target), what))
        with open(target, 'w', encoding='utf-8', errors='surrogateescape') as f:
            f.write(t)
        groups, pid, _ = mesh_case_groups(rng, base, name, levels, fmt_name)
        info['preserving'] = False
        info['base'] = '%s (%s, %s, levels %d)' % (base, fmt_name, pid, levels)
        text = render_namelist(groups)
    else:
        info['kind'] = 'namelist'
        info['preserving'] = False
        if rng.random() < 0.5:
            groups = generator_groups(rng, max_level)
            info['base'] = 'generated mesh'
        else:
            small = rng.choice(('square3', 'lshape', 'rect_triangle'))
            paths, name = WRITERS[fmt_name](bases[small], os.path.join(cdir, 'mesh'), rng)
            groups, pid, _ = mesh_case_groups(rng, small, name, rng.randint(1, max_level), fmt_name)
            info['base'] = '%s (%s, %s)' % (small, fmt_name, pid)
        for _ in range(rng.choice((1, 1, 2, 3))):
            groups, what = mutate_groups(groups, rng)
            info['mutations'].append(what)
        text = render_namelist(groups)
        if rng.random() < 0.4:
            text, what = mutate_text(text, rng, namelist=True)
            info['mutations'].append('text: ' + what)
    with open(os.path.join(cdir, 'run.nml'), 'w', encoding='utf-8', errors='surrogateescape') as f:
        f.write(text)
    return info


# ============================================================== running and checking
LIVE = set()                 # the running programs (killed when the harness is stopped)
LIVE_LOCK = threading.Lock()


def stop_live(signum, frame):
    """SIGINT/SIGTERM: kill the running programs' process groups, then stop."""
    with LIVE_LOCK:
        for p in list(LIVE):
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    os._exit(128 + signum)


def run_case(driver, cdir, timeout):
    """Run the driver on cdir/run.nml in cdir; (status, stdout, stderr, seconds); status
    None means timed out, a negative status a signal.  The limit is on CPU time (RLIMIT_CPU:
    a loaded machine does not make a slow run a hang), and 3 times it on the wall clock (a
    run blocked without computing)."""
    def limit_cpu():
        resource.setrlimit(resource.RLIMIT_CPU, (int(math.ceil(timeout)), int(math.ceil(timeout)) + 2))

    t0 = time.monotonic()
    with open(os.path.join(cdir, 'stdout.txt'), 'wb') as out, \
            open(os.path.join(cdir, 'stderr.txt'), 'wb') as err:
        p = subprocess.Popen([driver, 'run.nml'], cwd=cdir, stdout=out, stderr=err,
                             stdin=subprocess.DEVNULL, start_new_session=True, preexec_fn=limit_cpu)
        with LIVE_LOCK:
            LIVE.add(p)
        try:
            status = p.wait(timeout=3 * timeout)
            if status == -signal.SIGXCPU:
                status = None                   # the CPU limit
        except subprocess.TimeoutExpired:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            p.wait()
            status = None
        with LIVE_LOCK:
            LIVE.discard(p)
    secs = time.monotonic() - t0

    def text(name):
        with open(os.path.join(cdir, name), 'rb') as f:
            return f.read().decode('utf-8', 'replace')
    return status, text('stdout.txt'), text('stderr.txt'), secs


def to_float(s):
    s = s.strip()
    try:
        return float(s)
    except ValueError:
        return float('nan')


def check_table(csv_path, status, exact_ok):
    """Problems of one CSV table of a run that exited 0 or 3; and its certified intervals."""
    problems, intervals = [], []
    try:
        with open(csv_path, encoding='utf-8', errors='replace') as f:
            rows = [ln.rstrip('\n').split(',') for ln in f if ln.strip() and not ln.startswith('#')]
    except OSError as e:
        return ['table %s announced but unreadable: %s' % (csv_path, e)], []
    if not rows:
        return ['table %s is empty' % csv_path], []
    head = rows[0]
    col = {name: i for i, name in enumerate(head)}
    if len(rows) == 1:
        problems.append('table %s has no rows' % csv_path)
    for row in rows[1:]:
        if len(row) != len(head):
            problems.append('row with %d fields, header has %d: %s' % (len(row), len(head), ','.join(row)[:200]))
            continue
        vals = {name: to_float(row[i]) for name, i in col.items()}
        lvl = row[col['level']] if 'level' in col else '?'
        for name, v in vals.items():
            if math.isinf(v):
                problems.append('level %s: %s = %s (Inf)' % (lvl, name, row[col[name]]))
        for name in ('level', 'h', 'ndof'):
            if name in vals and not math.isfinite(vals[name]):
                problems.append('level %s: %s is not finite' % (lvl, name))
        cert = vals.get('certified')
        if cert is None or not math.isfinite(cert) or cert != 1:
            if cert is not None and status == 0:
                problems.append('level %s: certified = %s but exit status 0' % (lvl, row[col['certified']]))
            continue
        est, lo, hi = vals.get('est'), vals.get('energy_lo'), vals.get('energy_hi')
        for name, v in (('est', est), ('energy_lo', lo), ('energy_hi', hi)):
            if v is None or not math.isfinite(v):
                problems.append('level %s: certified row with %s = %s' % (lvl, name, v))
        if est is not None and est < 0:
            problems.append('level %s: est = %r < 0' % (lvl, est))
        if lo is not None and hi is not None and math.isfinite(lo) and math.isfinite(hi):
            if lo - hi > REL_TOL_BOUNDS * max(abs(lo), abs(hi)):
                problems.append('level %s: energy_lo = %r > energy_hi = %r' % (lvl, lo, hi))
            intervals.append((lo, hi, lvl))
        eff = vals.get('eff')
        if exact_ok and eff is not None and math.isfinite(eff) and eff < 1 - REL_TOL_EFF:
            problems.append('level %s: eff = %r < 1: est is below the exact error squared' % (lvl, eff))
    return problems, intervals


def classify(info, status, out, err, cdir):
    """(class, reasons, intervals)"""
    reasons = []
    if status is None:
        return 'hang', ['no exit within the time limit'], []
    found = [p for p in CRASH_PATTERNS if p in err or p in out]
    if status < 0:
        reasons.append('killed by signal %d' % -status)
    if status not in (0, 2, 3) and status >= 0:
        reasons.append('exit status %d (documented: 0, 2, 3; 1 only for usage)' % status)
    if found:
        reasons.append('stderr/stdout contains ' + ', '.join(repr(p) for p in found))
    if status == 2 and 'dualsig: error:' not in err:
        reasons.append("exit status 2 without a 'dualsig: error:' message")
    if reasons:
        return 'crash', reasons, []
    debris = []
    for dp, _, files in os.walk(cdir):
        debris += [os.path.join(dp, f) for f in files if f.endswith('.part') or f.endswith('.bak')]
    if debris:
        return 'debris', ['left behind: ' + ', '.join(os.path.relpath(d, cdir) for d in debris)], []
    if status == 2:
        return 'rejected', [], []
    tables = re.findall(r'dualsig: table written to (.+?)\.txt and ', out)
    intervals = []
    if not tables:
        reasons.append("exit status %d but no 'table written' line" % status)
    for t in tables:
        path = os.path.join(cdir, t + '.csv')
        p, iv = check_table(path, status, info.get('exact'))
        reasons += p
        intervals += iv
    if reasons:
        return 'bad_result', reasons, intervals
    if info.get('verdict'):
        return 'bad_mesh', ['exit status %d on a mesh the harness finds %s' % (status, info['verdict'])], intervals
    return ('ok' if status == 0 else 'not_certified'), [], intervals


def save_failure(outdir, info, cls, reasons, cdir, driver, status, secs):
    dest = os.path.join(outdir, 'failures', '%05d_%s' % (info['index'], cls))
    if os.path.exists(dest):
        shutil.rmtree(dest)
    if os.path.isdir(cdir):
        shutil.copytree(cdir, dest, symlinks=True)
    else:
        os.makedirs(dest)
    with open(os.path.join(dest, 'info.txt'), 'w') as f:
        f.write('class: %s\n' % cls)
        f.write('index: %d  (regenerate: tools/fuzz_driver.py --only %d with the same --seed)\n'
                % (info['index'], info['index']))
        f.write('kind: %s, base: %s\n' % (info.get('kind'), info.get('base')))
        f.write('mutations:\n' + ''.join('  - %s\n' % m for m in info['mutations']))
        f.write('exit status: %s after %.2f s\n' % (status, secs))
        f.write('reasons:\n' + ''.join('  - %s\n' % r for r in reasons))
        f.write('reproduce: cd %s && %s run.nml\n' % (dest, driver))
    return dest


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--driver', default=os.environ.get('DUALSIG_DRIVER', os.path.join(ROOT, 'bin', 'dualsig')))
    ap.add_argument('--n', type=int, default=10000, help='number of cases')
    ap.add_argument('--seed', type=int, default=18)
    ap.add_argument('--jobs', type=int, default=2)
    ap.add_argument('--timeout', type=float, default=20.0, help='CPU seconds after which a run is a hang (3 times that on the wall clock)')
    ap.add_argument('--out', default=None, help='scratch directory (default: a new one under $TMPDIR)')
    ap.add_argument('--max-level', type=int, default=3)
    ap.add_argument('--only', default=None, help='comma-separated case indices to run')
    ap.add_argument('--start', type=int, default=0, help='first case index')
    ap.add_argument('--keep', action='store_true', help='keep the directories of passing cases')
    args = ap.parse_args(argv)
    driver = os.path.abspath(args.driver)
    if not os.access(driver, os.X_OK):
        print('fuzz_driver: the program %s is not executable' % driver, file=sys.stderr)
        return 2
    outdir = os.path.abspath(args.out) if args.out else tempfile.mkdtemp(prefix='dualsig_fuzz_')
    os.makedirs(os.path.join(outdir, 'runs'), exist_ok=True)
    indices = [int(s) for s in args.only.split(',')] if args.only else \
        list(range(args.start, args.start + args.n))
    signal.signal(signal.SIGINT, stop_live)
    signal.signal(signal.SIGTERM, stop_live)
    bases = base_meshes()
    counts = {c: 0 for c in OUTCOME_CLASSES + FAILURE_CLASSES}
    by_kind = {}
    by_op = {}
    failures = []
    harness_errors = []
    groups = {}
    lock = threading.Lock()
    t_start = time.monotonic()
    slowest = [0.0, None]
    slow = []
    done = [0]

    def one(index):
        try:
            one_case(index)
        except Exception:                            # a bug of the harness, not of the program
            import traceback
            with lock:
                harness_errors.append((index, traceback.format_exc()))

    def one_case(index):
        cdir = os.path.join(outdir, 'runs', '%05d' % index)
        if os.path.exists(cdir):
            shutil.rmtree(cdir)
        info = generate_case(args.seed, index, cdir, bases, args.max_level)
        status, out, err, secs = run_case(driver, cdir, args.timeout)
        cls, reasons, intervals = classify(info, status, out, err, cdir)
        with lock:
            counts[cls] += 1
            k = by_kind.setdefault(info['kind'], {})
            k[cls] = k.get(cls, 0) + 1
            for op in set(info.get('ops', [])):
                k = by_op.setdefault(op, {})
                k[cls] = k.get(cls, 0) + 1
            if secs > slowest[0]:
                slowest[:] = [secs, index]
            if secs > 5.0:
                slow.append((secs, index))
            if info['group'] and intervals:
                g = groups.setdefault(info['group'], [])
                g += [(lo, hi, index, lvl) for lo, hi, lvl in intervals]
            if cls in FAILURE_CLASSES:
                dest = save_failure(outdir, info, cls, reasons, cdir, driver, status, secs)
                failures.append((index, cls, reasons, dest, info))
            done[0] += 1
            if done[0] % 500 == 0:
                print('fuzz_driver: %d/%d cases, %.0f s, failures so far %d'
                      % (done[0], len(indices), time.monotonic() - t_start, len(failures)), flush=True)
        if not args.keep:
            shutil.rmtree(cdir, ignore_errors=True)

    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as ex:
        for f in [ex.submit(one, i) for i in indices]:
            f.result()

    # runs of one problem on one domain: their certified energy intervals must intersect
    for g, ivs in sorted(groups.items()):
        lo = max(ivs, key=lambda v: v[0])
        hi = min(ivs, key=lambda v: v[1])
        if lo[0] - hi[1] > REL_TOL_DISAGREE * max(abs(lo[0]), abs(hi[1])):
            reasons = ['%s: case %d level %s has energy_lo = %r > energy_hi = %r of case %d level %s'
                       % (g, lo[2], lo[3], lo[0], hi[1], hi[2], hi[3])]
            counts['disagree'] += 1
            for idx in sorted({lo[2], hi[2]}):
                cdir = os.path.join(outdir, 'runs', '%05d' % idx)
                info = generate_case(args.seed, idx, cdir, bases, args.max_level)
                dest = save_failure(outdir, info, 'disagree', reasons, cdir, driver, 'see the other case', 0)
                shutil.rmtree(cdir, ignore_errors=True)
                failures.append((idx, 'disagree', reasons, dest, info))
    elapsed = time.monotonic() - t_start
    nfail = sum(counts[c] for c in FAILURE_CLASSES)
    print('fuzz_driver: %d cases (seed %d, driver %s) in %.1f s, %d failure(s)'
          % (len(indices), args.seed, driver, elapsed, nfail))
    print('  outcomes: ' + ', '.join('%s %d' % (c, counts[c]) for c in OUTCOME_CLASSES))
    print('  failures: ' + ', '.join('%s %d' % (c, counts[c]) for c in FAILURE_CLASSES))
    for kind in sorted(by_kind):
        print('  %-9s ' % kind + ', '.join('%s %d' % (c, n) for c, n in sorted(by_kind[kind].items())))
    print('  geometric mutations (cases containing it):')
    for op in sorted(by_op):
        print('    %-18s %5d: ' % (op, sum(by_op[op].values())) +
              ', '.join('%s %d' % (c, n) for c, n in sorted(by_op[op].items())))
    print('  domain-preserving groups checked for intersecting energy intervals: %d (%d intervals)'
          % (len(groups), sum(len(v) for v in groups.values())))
    print('  slowest run: %.2f s (case %s); runs over 5 s: %d %s' % (
        slowest[0], slowest[1], len(slow), ' '.join('%d (%.1f s)' % (i, t) for t, i in sorted(slow)[-10:])))
    for index, cls, reasons, dest, info in sorted(failures, key=lambda f: f[0]):
        print('FAIL %s case %d (%s; %s): %s' % (cls, index, info.get('kind'), '; '.join(info['mutations'])[:300],
                                               '; '.join(reasons)[:500]))
        print('     reproducer: %s' % dest)
    for index, tb in harness_errors:
        print('HARNESS ERROR in case %d:\n%s' % (index, tb))
    print('  scratch directory: %s' % outdir)
    shutil.rmtree(os.path.join(outdir, 'runs'), ignore_errors=True) if not args.keep else None
    return 1 if nfail or harness_errors else 0


if __name__ == '__main__':
    sys.exit(main())
