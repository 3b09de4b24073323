#!/usr/bin/env python3
"""petsc_peers.py -- solve dualsig's exported bound-constrained QP with PETSc solvers.

A peer comparison on the *same* discrete problem.  dualsig writes its primal QP with
``write_qp_matrix_market`` (src/dualsig_io_matrix_market.f90); for a base name B the files
are

    B_A.mtx     coordinate real general (symmetric, both triangles stored)
    B_F.mtx     array real (n x 1): right-hand side F
    B_kind.mtx  array integer (n x 1): 0 free, 1 lower bound x >= bnd, 2 fixed x = bnd
    B_bnd.mtx   array real (n x 1): bound value (lower bound or fixed value)
    B_x.mtx     array real (n x 1): dualsig's solution

and the QP is   min 1/2 x^T A x - F^T x   subject to the bounds.

Usage
-----
    python3 bench/petsc_peers.py BASE [BASE ...] [--tol 1e-10] [--time-limit 400]
                                 [--csv out/bench_peers.csv] [--solvers a,b,...]
                                 [--petsc-options "-tron_ksp_rtol 1e-6 ..."]

    BASE            base name of an export, e.g. /tmp/qp/p2_contact_n64
    --tol           KKT tolerance (the same relative natural residual dualsig uses), 1e-10
    --time-limit    wall-clock limit in seconds per solver run (solve phase), 400
    --csv           CSV file the rows are appended to (header written if the file is new),
                    default out/bench_peers.csv; --csv '' writes none
    --solvers       comma-separated subset of the solver names below (default: all)
    --petsc-options extra PETSc options, inserted after the defaults below so they override
                    them; use the solver's prefix, e.g. "-tron_pc_type gamg -vigamg_ksp_rtol 1e-4"
    --list          print the solvers and their PETSc options and exit

Fair mode (issue 16 item 4; what `make bench-peers` runs)
--------------------------------------------------------
    bin/dualsig_bench peers L SCENE
    python3 bench/petsc_peers.py --fair out/peers/SCENE --level L [--solvers a,b,...]
                                 [--seq-solvers a,b,...] [--mem-limit-gb G] [...]

`bin/dualsig_bench peers` (drivers/support/dualsig_bench_peers.f90) runs dualsig's multigrid
grid sequence to level L, exports every level's QP in binary (out/peers/SCENE_l<l>.bin: the
CSR matrix, F, kinds, bounds, dualsig's x and the prolongation from level l-1, format in
that file's header) and times cold solves of the finest QP from x = 0: 'multigrid' on the
same hierarchy and 'schur' on the finest mesh given as one level; the times go to
out/peers/SCENE_dualsig.csv.  The fair mode then, right after it on the same machine:
  (a), (c) cold against cold: each of --solvers on the level-L QP from x = 0 (projected onto
      the bounds), ratios to dualsig's cold multigrid and cold schur;
  (b), (c) the whole grid sequence: each of --seq-solvers (default snes-vi-hypre,
      snes-vi-gamg) solves levels 1..L in turn, level l from the P1 interpolation of its own
      level l-1 solution (dualsig's prolongation, read from the export; fixed values and
      lower bounds imposed), to the same KKT tolerance on every level; the sum of the solve
      phases against dualsig's whole sequence.
--mem-limit-gb limits each solver child's address space (RLIMIT_AS, the parent's shared
pages included): a problem PETSc cannot hold ends in an out-of-memory abort (reported)
instead of pressing a shared machine.  Rows are appended to --csv (make bench-peers:
out/bench_peers_fair.csv) with the load average at the end of each run.

If petsc4py cannot be imported the script prints one line
"petsc_peers: PETSc (python3-petsc4py) not installed; skipped" and exits with status 0.

PETSc set-up
------------
Debian's petsc4py (package python3-petsc4py, PETSc 3.18) lives under
$PETSC_DIR/lib/python3/dist-packages; without the petsc-dev package there is no /usr/lib/petsc
link, so the script sets PETSC_DIR=/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real itself
when PETSC_DIR is unset and that directory exists.  The package is built for Debian's own
interpreter: when the running python3 (e.g. a pyenv one) cannot import numpy/petsc4py, the
script re-executes itself once with /usr/bin/python3.  It also sets
OMPI_MCA_ess_singleton_isolated=1 (unless set) so that Open MPI's MPI_Init in each solver
child does not spawn an orted helper process.

The problem handed to PETSc
---------------------------
Fixed unknowns (kind 2) are eliminated: the reduced QP on the m = n - #fixed remaining
unknowns is   min 1/2 y^T A_rr y - (F_r - A_rf bnd_f)^T y,  y_i >= bnd_i for kind 1,
free (PETSC_NINFINITY / PETSC_INFINITY) for kind 0.  The full x is rebuilt with x_f = bnd_f.
This is the cleanest robust choice: dualsig's A is the full stiffness matrix (the fixed rows
and columns are coupled to the others), A_rr is SPD, and every solver sees exactly the same
well-posed problem, whereas equal bounds l = u are not handled uniformly by the solvers
(bqpip's source lists "remove fixed variables and treat them correctly" as a TODO; its
barrier slacks x - l and u - x cannot both stay positive).  The reduced matrix is marked
SYMMETRIC and SPD.  The initial guess is y = 0 projected onto the bounds.

Solvers (name: method, default PETSc options; each has its own options prefix)
------------------------------------------------------------------------------
"direct" below means preonly + cholesky with -pc_factor_mat_solver_type cholmod when PETSc
was built with SuiteSparse (Debian's is), else mumps, else PETSc's own factorisation.
``--list`` prints the exact option strings.

    tao-bqpip      TAO bqpip, Mehrotra predictor-corrector interior point for box QPs
                   (prefix bqpip_).  Each iteration solves (A_rr + D_k) d = r with a barrier
                   diagonal D_k that changes every iteration: direct (one CHOLMOD
                   factorisation per iteration).  cg + icc breaks down (zero pivot on
                   A_rr + D_k); cg + gamg works but bqpip's inner tolerance
                   min(mu/10, 1e-3) makes the interior point take twice as many iterations
                   and it is slower.
    tao-tron       TAO tron, trust-region Newton: gradient projection, then Steihaug CG on
                   the free-variable submatrix (prefix tron_).  KSP stcg (tron needs a
                   trust-region CG) + gamg, ksp_rtol 1e-8.  tron calls KSPReset and changes
                   the submatrix size whenever the active set changes, which PETSc 3.18's GAMG
                   cannot handle ("Cannot change local size of Amat after use"), so the GAMG
                   is wrapped in a PCPYTHON that builds a fresh GAMG for each new operator
                   (class FreshGAMG).  stcg + icc also works (fastest on small grids, about
                   2x slower than gamg at 66k unknowns): --petsc-options="-tron_pc_type icc".
    tao-blmvm      TAO blmvm, bound-constrained limited-memory variable metric, gradient
                   only, More-Thuente line search (prefix blmvm_).  Its line search works on
                   objective values, whose decrease drops below rounding near the solution:
                   it stops with DIVERGED_LS_FAILURE at a KKT residual around 1e-9 (and needs
                   tens of thousands of iterations, the condition number grows like h^-2).
                   Reported as it is.
    tao-gpcg       TAO gpcg, gradient projection + CG for bound-constrained QPs
                   (More-Toraldo) (prefix gpcg_); direct solves on the free-variable
                   submatrix.  Not in the original brief; the QP-specific active-set method
                   of TAO.  With cg + icc at the default ksp_rtol it stalls (>6000
                   iterations at n = 4k); with ksp_rtol 1e-10 it converges but is ~10x slower
                   than with the direct solve.
    snes-vi-chol   SNES vinewtonrsls, reduced-space active-set (semismooth) Newton on the
                   variational inequality  l <= x  _|_  A x - F  (residual A x - F,
                   Jacobian A, bounds by SNESVISetVariableBounds) (prefix vichol_); direct
                   solve of the inactive-set system each Newton step, line search basic (the
                   problem is linear on a fixed active set, the full step is exact).
    snes-vi-gamg   the same with cg + gamg, ksp_rtol 1e-8 (prefix vigamg_); GAMG wrapped in
                   FreshGAMG for the same reason as for tron.
    snes-vi-hypre  the same with cg + hypre BoomerAMG, ksp_rtol 1e-8 (prefix vihypre_);
                   BoomerAMG handles the changing operator without a wrapper.

The convergence test (identical for all solvers)
------------------------------------------------
The script installs its own convergence test in every TAO/SNES object (the solvers' own
tolerances are disabled) and stops as soon as the relative KKT (natural) residual of the
current iterate is <= --tol.  With g = A x - F (full vectors, x_f = bnd_f):

    r_i = g_i                               for free unknowns       (kind 0)
    r_i = min(g_i, A_ii (x_i - bnd_i))      for lower-bounded ones  (kind 1)
    kkt = ||r||_2 / ||F restricted to the unknowns that are not fixed||_2

(absolute ||r||_2 when that norm of F is zero), exactly dualsig's ``kkt_residual``
(src/dualsig_solver_psor.f90).  After the solve it is recomputed independently with numpy
from the original, unreduced A.  For interior-point iterates (x strictly feasible) the same
formula applies.

Time limit and hangs: each solver runs in a forked child process.  The convergence test
also checks the wall clock and stops the solver (status "time limit") after --time-limit
seconds of solve time; if the child does not answer within 1.25 * time-limit + 30 s (e.g. a
single factorisation or linear solve that never returns) it is killed and reported as
"killed (hard timeout)".  Iteration limits (TAO/SNES max_it) are set high so that normally
the time limit or the KKT test ends the run; reaching them is reported as "max_it".

Reported per solver
-------------------
    setup_s         creating the PETSc Mat/Vecs from the CSR arrays and the solver object,
                    options, setUp() (reading the files and eliminating fixed unknowns is
                    common to all and printed once per BASE as "read")
    solve_s         wall time of TAO/SNES solve() only (includes factorisations, PC set-ups
                    and the cost of the KKT test: one extra mat-vec per iteration)
    iterations      TAO / SNES (outer) iterations
    ksp_iterations  total KSP iterations (TAO: counted with a KSP monitor; SNES:
                    SNESGetLinearSolveIterations; a preonly direct solve counts 1 per solve)
    kkt             relative KKT residual defined above, of the returned x
    rel_diff        max |x - x_dualsig| / max |x_dualsig|
    status          converged (kkt <= tol) | time limit | max_it | not converged (<PETSc
                    reason>) | killed (hard timeout) | error: ...

CSV columns: base, n, solver, setup_s, solve_s, iterations, ksp_iterations, kkt, rel_diff,
status.
"""

import argparse
import csv
import glob
import importlib.util
import multiprocessing as mp
import os
import sys
import time
import traceback

DEBIAN_PYTHON = '/usr/bin/python3'
PETSC_DIR_DEFAULT = '/usr/lib/petscdir/petsc3.18/x86_64-linux-gnu-real'
SKIP_LINE = 'petsc_peers: PETSc (python3-petsc4py) not installed; skipped'
REEXEC_FLAG = 'DUALSIG_PETSC_PEERS_REEXEC'

# name: (kind, PETSc type, options prefix, default options (without prefix), max_it)
SOLVERS = {
    'tao-bqpip': ('tao', 'bqpip', 'bqpip_',
                  '-ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type {direct}', 500),
    'tao-tron': ('tao', 'tron', 'tron_', '-ksp_type stcg -pc_type gamg -ksp_rtol 1e-8', 5000),
    'tao-blmvm': ('tao', 'blmvm', 'blmvm_', '', 10 ** 7),
    'tao-gpcg': ('tao', 'gpcg', 'gpcg_',
                 '-ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type {direct}', 10000),
    'snes-vi-chol': ('snes', 'vinewtonrsls', 'vichol_',
                     '-ksp_type preonly -pc_type cholesky -pc_factor_mat_solver_type {direct}'
                     ' -snes_linesearch_type basic', 1000),
    'snes-vi-gamg': ('snes', 'vinewtonrsls', 'vigamg_',
                     '-ksp_type cg -pc_type gamg -ksp_rtol 1e-8 -snes_linesearch_type basic',
                     1000),
    'snes-vi-hypre': ('snes', 'vinewtonrsls', 'vihypre_',
                      '-ksp_type cg -pc_type hypre -pc_hypre_type boomeramg -ksp_rtol 1e-8'
                      ' -snes_linesearch_type basic', 1000),
}


# --------------------------------------------------------------------------- environment

def _petsc_dir_guess():
    if os.path.isdir(PETSC_DIR_DEFAULT):
        return PETSC_DIR_DEFAULT
    cands = sorted(glob.glob('/usr/lib/petscdir/petsc*/*-real'))
    return cands[-1] if cands else None


def ensure_petsc4py():
    """Make Debian's petsc4py importable; re-exec with /usr/bin/python3 if needed.

    Returns True when numpy and petsc4py can be found (PETSc itself is only initialised in
    the solver child processes)."""
    if not os.environ.get('PETSC_DIR') and not os.path.isdir('/usr/lib/petsc'):
        guess = _petsc_dir_guess()
        if guess:
            os.environ['PETSC_DIR'] = guess
    pdir = os.environ.get('PETSC_DIR') or '/usr/lib/petsc'
    site = os.path.join(pdir, 'lib', 'python3', 'dist-packages')
    if os.path.isdir(site) and site not in sys.path:
        sys.path.append(site)
    ok = (importlib.util.find_spec('numpy') is not None
          and importlib.util.find_spec('petsc4py') is not None)
    if (not ok and not os.environ.get(REEXEC_FLAG) and os.access(DEBIAN_PYTHON, os.X_OK)
            and os.path.realpath(sys.executable) != os.path.realpath(DEBIAN_PYTHON)):
        os.environ[REEXEC_FLAG] = '1'
        sys.stdout.flush()
        os.execv(DEBIAN_PYTHON, [DEBIAN_PYTHON, os.path.abspath(__file__)] + sys.argv[1:])
    return ok


# --------------------------------------------------------------------------- Matrix Market

def _mm_header(path):
    """Banner tokens, size line and number of lines before the data."""
    with open(path, 'rb') as f:
        first = f.readline()
        if not first.startswith(b'%%MatrixMarket'):
            raise ValueError('%s: not a Matrix Market file' % path)
        banner = first.decode('ascii', 'replace').lower().split()
        nlines = 1
        while True:
            line = f.readline()
            if not line:
                raise ValueError('%s: no size line' % path)
            nlines += 1
            s = line.strip()
            if s and not s.startswith(b'%'):
                return banner, [int(t) for t in s.split()], nlines


def read_mm_array(path, dtype=float):
    """Dense n x 1 Matrix Market array -> 1-D numpy array."""
    import numpy as np
    banner, size, skip = _mm_header(path)
    if 'array' not in banner or len(size) != 2 or size[1] != 1:
        raise ValueError('%s: expected an n x 1 "array" file' % path)
    v = np.loadtxt(path, dtype=float, comments='%', skiprows=skip, ndmin=1)
    if v.size != size[0]:
        raise ValueError('%s: %d values, header says %d' % (path, v.size, size[0]))
    return v.astype(dtype) if dtype is not float else v


def read_mm_coo(path):
    """Sparse coordinate Matrix Market file -> (n, rows, cols, vals), 0-based int64.
    `symmetric` storage is expanded to both triangles."""
    import numpy as np
    banner, size, skip = _mm_header(path)
    if 'coordinate' not in banner or len(size) != 3:
        raise ValueError('%s: expected a "coordinate" file' % path)
    nr, nc, nnz = size
    if nr != nc:
        raise ValueError('%s: matrix is not square' % path)
    d = np.loadtxt(path, dtype=float, comments='%', skiprows=skip, ndmin=2)
    if d.shape != (nnz, 3):
        raise ValueError('%s: %s entries, header says %d' % (path, d.shape, nnz))
    rows = d[:, 0].astype(np.int64) - 1
    cols = d[:, 1].astype(np.int64) - 1
    vals = np.ascontiguousarray(d[:, 2])
    if 'symmetric' in banner:
        off = rows != cols
        rows, cols, vals = (np.concatenate([rows, cols[off]]), np.concatenate([cols, rows[off]]),
                            np.concatenate([vals, vals[off]]))
    return nr, rows, cols, vals


# --------------------------------------------------------------------------- problem

class Problem:
    """The QP of one BASE, plus its reduction to the non-fixed unknowns (numpy only)."""

    def __init__(self, base):
        import numpy as np
        t0 = time.perf_counter()
        self.base = base
        self.ends = None
        if base.endswith('.bin'):
            n, rows, cols, vals = self._read_binary(base)
        else:
            n, rows, cols, vals = read_mm_coo(base + '_A.mtx')
            self.F = read_mm_array(base + '_F.mtx')
            self.kind = read_mm_array(base + '_kind.mtx').astype(np.int64)
            self.bnd = read_mm_array(base + '_bnd.mtx')
            self.xref = read_mm_array(base + '_x.mtx')
        self.n = n
        for name, v in (('F', self.F), ('kind', self.kind), ('bnd', self.bnd), ('x', self.xref)):
            if v.size != n:
                raise ValueError('%s_%s.mtx: size %d, A has %d' % (base, name, v.size, n))
        if np.any((self.kind < 0) | (self.kind > 2)):
            raise ValueError('%s_kind.mtx: kinds must be 0, 1 or 2' % base)
        self.rows, self.cols, self.vals = rows, cols, vals
        self.t_read = time.perf_counter() - t0

        t0 = time.perf_counter()
        fixed = self.kind == 2
        keep = ~fixed
        self.keep_idx = np.flatnonzero(keep)
        m = self.keep_idx.size
        self.m = m
        newidx = np.full(n, -1, dtype=np.int64)
        newidx[self.keep_idx] = np.arange(m, dtype=np.int64)
        # x with the fixed values in place, zeros elsewhere: F_r - A_rf bnd_f
        xfix = np.where(fixed, self.bnd, 0.0)
        sel = keep[rows]
        Ab = np.bincount(rows[sel], weights=vals[sel] * xfix[cols[sel]], minlength=n)
        self.b = (self.F - Ab)[self.keep_idx]
        sel &= keep[cols]
        ri, rj, rv = newidx[rows[sel]], newidx[cols[sel]], vals[sel]
        key = ri * m + rj
        if key.size > 1 and np.any(key[1:] < key[:-1]):
            order = np.argsort(key, kind='stable')
            ri, rj, rv = ri[order], rj[order], rv[order]
            key = key[order]
        if key.size > 1 and np.any(key[1:] == key[:-1]):       # duplicates: sum them
            uniq, start = np.unique(key, return_index=True)
            rv = np.add.reduceat(rv, start)
            ri, rj = uniq // m, uniq % m
        self.indptr = np.concatenate([[0], np.cumsum(np.bincount(ri, minlength=m))])
        self.indices = rj
        self.data = rv
        diag = np.zeros(m)
        dsel = ri == rj
        diag[ri[dsel]] = rv[dsel]
        self.diag = diag
        kr = self.kind[self.keep_idx]
        self.bidx = np.flatnonzero(kr == 1)         # bounded unknowns, reduced numbering
        self.lb = self.bnd[self.keep_idx][self.bidx]
        self.diag_b = diag[self.bidx]
        fk = self.F[keep]
        den = float(np.sqrt(fk @ fk))
        self.den = den if den > 0.0 else 1.0
        self.nnz_r = rv.size
        self.t_reduce = time.perf_counter() - t0
        self.ref_kkt = self.kkt_full(self.xref)
        self.ref_scale = float(np.max(np.abs(self.xref))) if n else 0.0

    def _read_binary(self, path):
        """The binary export of `bin/dualsig_bench peers` (drivers/support/dualsig_bench_peers.f90):
        'DSQP0001', n, nnz, ne (int32), rowptr(n+1), col(nnz) (int32, 1-based), val(nnz),
        F, bnd, x (float64), kind(n), ends(2, ne) (int32, 1-based)."""
        import numpy as np
        with open(path, 'rb') as fh:
            if fh.read(8) != b'DSQP0001':
                raise ValueError('%s: not a dualsig binary QP' % path)
            n, nnz, ne = (int(v) for v in np.fromfile(fh, dtype='<i4', count=3))
            rowptr = np.fromfile(fh, dtype='<i4', count=n + 1).astype(np.int64) - 1
            cols = np.fromfile(fh, dtype='<i4', count=nnz) - 1     # int32: half the memory
            vals = np.fromfile(fh, dtype='<f8', count=nnz)
            self.F = np.fromfile(fh, dtype='<f8', count=n)
            self.bnd = np.fromfile(fh, dtype='<f8', count=n)
            self.xref = np.fromfile(fh, dtype='<f8', count=n)
            self.kind = np.fromfile(fh, dtype='<i4', count=n).astype(np.int64)
            ends = np.fromfile(fh, dtype='<i4', count=2 * ne)
        if ends.size != 2 * ne or vals.size != nnz:
            raise ValueError('%s: truncated file' % path)
        self.ends = ends.reshape(ne, 2).astype(np.int64) - 1
        rows = np.repeat(np.arange(n, dtype=np.int32), np.diff(rowptr))
        return n, rows, cols, vals

    def prolong(self, xc):
        """P1 interpolation of the previous level's x onto this level (coarse nodes first,
        then the edge midpoints), with the fixed values and the lower bounds imposed."""
        import numpy as np
        nc = self.n - self.ends.shape[0]
        x = np.empty(self.n)
        x[:nc] = xc
        x[nc:] = 0.5 * (xc[self.ends[:, 0]] + xc[self.ends[:, 1]])
        fixed = self.kind == 2
        x[fixed] = self.bnd[fixed]
        low = self.kind == 1
        x[low] = np.maximum(x[low], self.bnd[low])
        return x

    def kkt_reduced(self, y, Ay):
        """Relative KKT residual from reduced y and A_rr y (numpy arrays)."""
        import numpy as np
        r = Ay - self.b
        if self.bidx.size:
            r[self.bidx] = np.minimum(r[self.bidx], self.diag_b * (y[self.bidx] - self.lb))
        return float(np.sqrt(r @ r)) / self.den

    def full_x(self, y):
        import numpy as np
        x = np.where(self.kind == 2, self.bnd, 0.0)
        x[self.keep_idx] = y
        return x

    def kkt_full(self, x):
        """dualsig's kkt_residual on the original (unreduced) data."""
        import numpy as np
        g = np.bincount(self.rows, weights=self.vals * x[self.cols], minlength=self.n) - self.F
        r = g.copy()
        low = self.kind == 1
        r[low] = np.minimum(g[low], self.diag_full()[low] * (x[low] - self.bnd[low]))
        r = r[self.kind != 2]
        return float(np.sqrt(r @ r)) / self.den

    def diag_full(self):
        import numpy as np
        d = np.zeros(self.n)
        s = self.rows == self.cols
        np.add.at(d, self.rows[s], self.vals[s])
        return d

    def rel_diff(self, x):
        import numpy as np
        dmax = float(np.max(np.abs(x - self.xref))) if self.n else 0.0
        return dmax / self.ref_scale if self.ref_scale > 0 else dmax


# --------------------------------------------------------------------------- options

def split_options(s):
    """'-a 1 -b -c x' -> [('a','1'), ('b', None), ('c','x')] (keys without the dash)."""
    toks = s.split()
    out = []
    i = 0
    while i < len(toks):
        t = toks[i]
        if not (t.startswith('-') and len(t) > 1 and not _is_number(t)):
            raise ValueError('bad PETSc option token %r in %r' % (t, s))
        val = None
        if i + 1 < len(toks) and not (toks[i + 1].startswith('-') and not _is_number(toks[i + 1])):
            val = toks[i + 1]
            i += 1
        out.append((t[1:], val))
        i += 1
    return out


def _is_number(t):
    try:
        float(t)
        return True
    except ValueError:
        return False


def direct_solver_type(PETSc):
    if PETSc.Sys.hasExternalPackage('suitesparse') or PETSc.Sys.hasExternalPackage('cholmod'):
        return 'cholmod'
    if PETSc.Sys.hasExternalPackage('mumps'):
        return 'mumps'
    return 'petsc'


def default_options(name, direct='cholmod'):
    kind, typ, prefix, opts, maxit = SOLVERS[name]
    return ' '.join('-' + prefix + k + ('' if v is None else ' ' + v)
                    for k, v in split_options(opts.format(direct=direct)))


# --------------------------------------------------------------------------- child

class FreshGAMG:
    """PCPYTHON context: a PCGAMG rebuilt from scratch whenever the PC is set up.

    PETSc 3.18's GAMG cannot be re-set-up after KSPReset when the operator's size changes
    ("Cannot change local size of Amat after use" from a coarse level): SNES vinewtonrsls and
    TAO tron call KSPReset and hand the KSP a submatrix of a different size whenever the
    active set changes.  This wrapper creates a new GAMG for each new operator, which is what
    those solvers intend; the GAMG options of the solver's prefix still apply."""

    def __init__(self, PETSc, prefix):
        self.PETSc = PETSc
        self.prefix = prefix
        self.inner = None

    def setUp(self, pc):
        self.reset(pc)
        A, P = pc.getOperators()
        inner = self.PETSc.PC().create(comm=pc.getComm())
        inner.setOptionsPrefix(self.prefix)
        inner.setOperators(A, P)
        inner.setType('gamg')
        inner.setFromOptions()
        inner.setUp()
        self.inner = inner

    def apply(self, pc, x, y):
        self.inner.apply(x, y)

    def reset(self, pc):
        if self.inner is not None:
            self.inner.destroy()
            self.inner = None


def wrap_gamg(PETSc, ksp, prefix, opts):
    """Replace a PCGAMG of a KSP that sees changing operator sizes by FreshGAMG."""
    pc = ksp.getPC()
    if pc.getType() != 'gamg':
        return False
    if opts.hasName(prefix + 'pc_type'):
        opts.delValue(prefix + 'pc_type')      # KSPResetFromOptions must not restore gamg
    pc.setType('python')
    pc.setPythonContext(FreshGAMG(PETSc, prefix))
    return True


def run_solver(name, prob, tol, time_limit, user_opts, conn, y0=None, want_x=False,
               mem_limit_gb=0.0):
    """Runs in a forked child: set up and solve with one PETSc solver, send a result dict.
    mem_limit_gb > 0: the child's address space is limited to that (RLIMIT_AS, including
    the parent's pages it shares), so that a problem PETSc cannot hold ends in an
    out-of-memory error instead of pressing the shared machine."""
    res = {'solver': name, 'setup_s': float('nan'), 'solve_s': float('nan'),
           'iterations': -1, 'ksp_iterations': -1, 'kkt': float('nan'),
           'rel_diff': float('nan'), 'status': 'error'}
    try:
        if mem_limit_gb > 0:
            import resource
            lim = int(mem_limit_gb * 2 ** 30)
            resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
        import numpy as np
        import petsc4py
        petsc4py.init([sys.argv[0]])
        from petsc4py import PETSc

        kind, typ, prefix, _, maxit = SOLVERS[name]
        direct = direct_solver_type(PETSc)
        res['options'] = default_options(name, direct)
        opts = PETSc.Options()
        for k, v in split_options(res['options']):
            opts.setValue(k, '' if v is None else v)
        if user_opts:
            opts.insertString(user_opts)

        t0 = time.perf_counter()
        m = prob.m
        it = PETSc.IntType
        A = PETSc.Mat().createAIJ(size=(m, m), csr=(prob.indptr.astype(it),
                                                    prob.indices.astype(it), prob.data),
                                  comm=PETSc.COMM_SELF)
        A.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        A.setOption(PETSc.Mat.Option.SPD, True)
        A.assemble()
        b = PETSc.Vec().createWithArray(prob.b.copy(), comm=PETSc.COMM_SELF)
        xl = A.createVecRight()
        xu = A.createVecRight()
        xl.set(PETSc.NINFINITY)
        xu.set(PETSc.INFINITY)
        xla = xl.getArray()
        xla[prob.bidx] = prob.lb
        xl.setArray(xla)
        x = A.createVecRight()
        if y0 is None:                       # cold: zero projected onto the bounds
            x0 = np.zeros(m)
            x0[prob.bidx] = np.maximum(0.0, prob.lb)
        else:                                # warm: the given start (reduced numbering)
            x0 = np.array(y0, dtype=float)
        x.setArray(x0)
        work = A.createVecRight()

        state = {'t_solve0': None, 'kkt': float('inf'), 'timeout': False, 'maxit': False,
                 'ksp_its': 0}

        def kkt_of(xv):
            A.mult(xv, work)
            return prob.kkt_reduced(xv.getArray(readonly=True), work.getArray(readonly=True))

        def out_of_time():
            t = state['t_solve0']
            return t is not None and time.perf_counter() - t > time_limit

        def ksp_monitor(ksp, its, rnorm):
            if its > 0:
                state['ksp_its'] += 1

        if kind == 'tao':
            solver = PETSc.TAO().create(comm=PETSc.COMM_SELF)
            solver.setOptionsPrefix(prefix)
            solver.setType(typ)

            def objgrad(tao, xv, g):
                A.mult(xv, g)
                f = 0.5 * xv.dot(g) - xv.dot(b)
                g.axpy(-1.0, b)
                return f

            def hessian(tao, xv, H, P):
                pass            # constant Hessian, assembled once

            def converged(tao):
                its = tao.getIterationNumber()
                state['kkt'] = kkt_of(tao.getSolution())
                if state['kkt'] <= tol:
                    tao.setConvergedReason(PETSc.TAO.Reason.CONVERGED_USER)
                elif out_of_time():
                    state['timeout'] = True
                    tao.setConvergedReason(PETSc.TAO.Reason.DIVERGED_USER)
                elif its >= tao.getMaximumIterations():
                    state['maxit'] = True
                    tao.setConvergedReason(PETSc.TAO.Reason.DIVERGED_MAXITS)
                else:
                    tao.setConvergedReason(PETSc.TAO.Reason.CONTINUE_ITERATING)

            g = A.createVecRight()
            solver.setObjectiveGradient(objgrad, g)
            if typ in ('bqpip', 'tron', 'gpcg', 'bnls', 'bntr', 'bntl'):
                # bqpip shifts the Hessian's diagonal in place: give it its own copy
                H = A.duplicate(copy=True) if typ == 'bqpip' else A
                solver.setHessian(hessian, H, H)
            solver.setVariableBounds(xl, xu)
            solver.setSolution(x)
            solver.setTolerances(gatol=0.0, grtol=0.0, gttol=0.0)
            solver.setMaximumIterations(maxit)
            solver.setMaximumFunctionEvaluations(10 ** 9)
            solver.setFromOptions()
            solver.setConvergenceTest(converged)
            ksp = solver.getKSP()
            if ksp is not None and not ksp.handle:
                ksp = None      # gradient-only methods have no KSP (a NULL handle)
            if ksp is not None:
                ksp.setMonitor(ksp_monitor)
                if typ in ('tron', 'gpcg'):
                    res['gamg_wrapped'] = wrap_gamg(PETSc, ksp, prefix, opts)
            solver.setUp()
            res['setup_s'] = time.perf_counter() - t0
            state['t_solve0'] = time.perf_counter()
            solver.solve(x)
            res['solve_s'] = time.perf_counter() - state['t_solve0']
            res['iterations'] = solver.getIterationNumber()
            res['ksp_iterations'] = state['ksp_its'] if ksp is not None else 0
            reason = solver.getConvergedReason()
            reason_name = _reason_name(PETSc.TAO.Reason, reason)
            xsol = solver.getSolution()
        else:
            solver = PETSc.SNES().create(comm=PETSc.COMM_SELF)
            solver.setOptionsPrefix(prefix)
            solver.setType(typ)

            def residual(snes, xv, f):
                A.mult(xv, f)
                f.axpy(-1.0, b)

            def jacobian(snes, xv, J, P):
                pass            # constant Jacobian

            def converged(snes, its, norms):
                state['kkt'] = kkt_of(snes.getSolution())
                if state['kkt'] <= tol:
                    return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS
                if out_of_time():
                    state['timeout'] = True
                    return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
                if its >= snes.getTolerances()[3]:
                    state['maxit'] = True
                    return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
                return PETSc.SNES.ConvergedReason.ITERATING

            f = A.createVecRight()
            solver.setFunction(residual, f)
            solver.setJacobian(jacobian, A, A)
            solver.setVariableBounds(xl, xu)
            solver.setTolerances(rtol=0.0, atol=0.0, stol=0.0, max_it=maxit)
            solver.setMaxFunctionEvaluations(10 ** 9)
            solver.setFromOptions()
            solver.setConvergenceTest(converged)
            res['gamg_wrapped'] = wrap_gamg(PETSc, solver.getKSP(), prefix, opts)
            solver.setSolution(x)
            solver.setUp()
            res['setup_s'] = time.perf_counter() - t0
            state['t_solve0'] = time.perf_counter()
            solver.solve(None, x)
            res['solve_s'] = time.perf_counter() - state['t_solve0']
            res['iterations'] = solver.getIterationNumber()
            res['ksp_iterations'] = solver.getLinearSolveIterations()
            reason = solver.getConvergedReason()
            reason_name = _reason_name(PETSc.SNES.ConvergedReason, reason)
            xsol = solver.getSolution()

        y = xsol.getArray(readonly=True).copy()
        xfull = prob.full_x(y)
        if want_x:
            res['x'] = xfull
        res['kkt'] = prob.kkt_full(xfull)
        res['rel_diff'] = prob.rel_diff(xfull)
        if res['kkt'] <= tol:
            res['status'] = 'converged'
        elif state['timeout']:
            res['status'] = 'time limit'
        elif state['maxit']:
            res['status'] = 'max_it'
        else:
            res['status'] = 'not converged (%s)' % reason_name
    except Exception as e:                        # report, never hang the parent
        res['status'] = 'error: %s' % (str(e).strip().splitlines() or [type(e).__name__])[0]
        res['traceback'] = traceback.format_exc()
    try:
        import resource
        res['peak_mb'] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    except Exception:                             # not on this platform
        res['peak_mb'] = float('nan')
    try:
        conn.send(res)
    finally:
        conn.close()


def _reason_name(enum, value):
    for k in dir(enum):
        if not k.startswith('_') and getattr(enum, k) == value:
            return k
    return str(value)


# --------------------------------------------------------------------------- parent

def run_one(name, prob, args, y0=None, want_x=False):
    """Run one solver in a forked child with a hard timeout (start y0: reduced numbering,
    None = cold; want_x: the result carries the full solution as 'x')."""
    ctx = mp.get_context('fork')
    parent_mb = rss_mb()
    rd, wr = ctx.Pipe(duplex=False)
    p = ctx.Process(target=run_solver,
                    args=(name, prob, args.tol, args.time_limit, args.petsc_options, wr),
                    kwargs={'y0': y0, 'want_x': want_x,
                            'mem_limit_gb': getattr(args, 'mem_limit_gb', 0.0)})
    p.start()
    wr.close()
    hard = 1.25 * args.time_limit + 30.0
    res = None
    if rd.poll(hard):
        try:
            res = rd.recv()
        except EOFError:            # the child died without an answer (crash, MPI_Abort)
            p.join(10)
    if res is None:
        if p.is_alive():
            p.kill()            # only the child started just above
            status = 'killed (hard timeout)'
        else:
            status = 'error: child exited with code %s' % p.exitcode
            if getattr(args, 'mem_limit_gb', 0.0) > 0:
                status += ' (PETSc aborted; out of memory within --mem-limit-gb %g?)' % args.mem_limit_gb
        res = {'solver': name, 'setup_s': float('nan'), 'solve_s': float('nan'),
               'iterations': -1, 'ksp_iterations': -1, 'kkt': float('nan'),
               'rel_diff': float('nan'), 'status': status}
    p.join(10)
    rd.close()
    res['parent_mb'] = parent_mb
    return res


def rss_mb():
    """Resident memory of this process in MB (0 when /proc is not there)."""
    try:
        with open('/proc/self/statm') as fh:
            return int(fh.read().split()[1]) * os.sysconf('SC_PAGE_SIZE') / 2.0 ** 20
    except (OSError, ValueError, IndexError):
        return 0.0


def fmt_row(cols, widths):
    """First column left-aligned, last one free, the others right-aligned."""
    out = [str(cols[0]).ljust(widths[0])]
    out += [str(c).rjust(w) for c, w in zip(cols[1:-1], widths[1:-1])]
    out.append(str(cols[-1]))
    return '  '.join(out)


# --------------------------------------------------------------------------- fair mode

def read_dualsig_csv(path):
    """Rows of out/peers/<scene>_dualsig.csv by (pass, level)."""
    out = {}
    with open(path, newline='') as fh:
        for r in csv.DictReader(fh):
            out[(r['pass'], int(r['level']))] = r
    return out


def loadavg():
    try:
        return '%.2f %.2f %.2f' % os.getloadavg()
    except OSError:
        return '?'


def fair_main(args, names, seq_names):
    """Issue 16 item 4: (a) cold against cold on the finest exported QP, (b) the whole grid
    sequence against PETSc's own grid sequencing on the same exported QPs, (c) multigrid
    against VINEWTONRSLS + BoomerAMG / GAMG (part of (a) and (b)); ratios within this run."""
    prefix, lmax = args.fair, args.level
    scene = os.path.basename(prefix)
    dcsv = prefix + '_dualsig.csv'
    if not os.path.exists(dcsv):
        print('petsc_peers: %s missing: run bin/dualsig_bench peers %d %s first' % (dcsv, lmax, scene))
        return 1
    ds = read_dualsig_csv(dcsv)
    dcmd = 'bin/dualsig_bench peers %d %s' % (lmax, scene)
    pcmd = 'python3 bench/petsc_peers.py --fair %s --level %d' % (prefix, lmax)
    rows_out = []
    mg_seq = ds.get(('sequence', lmax))
    mg_cold = ds.get(('cold_multigrid', lmax))
    schur_cold = ds.get(('cold_schur', lmax))
    amg_cold = ds.get(('cold_amg', lmax))
    if mg_seq is None or mg_cold is None:
        print('petsc_peers: %s has no level %d rows' % (dcsv, lmax))
        return 1

    prob = Problem('%s_l%d.bin' % (prefix, lmax)) if names else None
    if names:
        print('\n(a), (c) cold against cold: %s level %d, n = %d (reduced m = %d), KKT tol %.0e, '
              'every solver from x = 0 (projected onto the bounds); load average %s'
              % (scene, lmax, prob.n, prob.m, args.tol, loadavg()), flush=True)
        print('  dualsig (%s): cold multigrid %.3f s (%s V-cycles; x = 0 on the geometric hierarchy, '
              'nested start on the restricted QPs)%s'
              % (dcmd, float(mg_cold['seconds']), mg_cold['iterations'],
                 '' if schur_cold is None else '; cold schur %.3f s (%s pivoting steps; the mesh as '
                 'one level, no hierarchy)' % (float(schur_cold['seconds']), schur_cold['iterations'])))
        if amg_cold is not None:
            print('  dualsig (%s): cold multigrid_amg %.3f s (%s V-cycles; the mesh as one level, no '
                  'hierarchy: multigrid on the algebraic hierarchy it builds from the matrix, the '
                  'set-up inside the time, as for PETSc)' % (dcmd, float(amg_cold['seconds']), amg_cold['iterations']))
        t_mg_cold = float(mg_cold['seconds'])
        t_schur = float(schur_cold['seconds']) if schur_cold is not None else float('nan')
        t_amg = float(amg_cold['seconds']) if amg_cold is not None else float('nan')
        print('  %-14s %9s %9s %5s %7s %10s %9s %9s %8s %12s %12s %12s  %s' %
              ('PETSc solver', 'setup_s', 'solve_s', 'its', 'ksp_its', 'kkt', 'rel_diff', 'peak_MB',
               'load', '/mg_cold', '/amg_cold', '/schur_cold', 'status'), flush=True)
        for name in names:
            r = run_one(name, prob, args)
            la = loadavg().split()[0]
            ok = r['status'] == 'converged'
            rm = r['solve_s'] / t_mg_cold
            rs = r['solve_s'] / t_schur
            ra = r['solve_s'] / t_amg
            fmt = (lambda v: ('%.1fx' % v) if ok else ('>%.1fx' % v if v == v else '-'))
            print('  %-14s %9.3f %9.3f %5d %7d %10.2e %9.1e %9.0f %8s %12s %12s %12s  %s' %
                  (name, r['setup_s'], r['solve_s'], r['iterations'], r['ksp_iterations'], r['kkt'],
                   r['rel_diff'], r.get('peak_mb', float('nan')), la, fmt(rm), fmt(ra), fmt(rs),
                   r['status']), flush=True)
            if r['status'] != 'converged':
                print('    (the parent process held %.0f MB at the fork)' % r['parent_mb'])
            if 'traceback' in r:
                sys.stderr.write(r['traceback'])
            rows_out.append(['cold', scene, lmax, prob.n, name, '%.4f' % r['setup_s'],
                             '%.4f' % r['solve_s'], r['iterations'], r['ksp_iterations'],
                             '%.3e' % r['kkt'], '%.0f' % r.get('peak_mb', float('nan')), la,
                             '%.4f' % t_mg_cold, '%.4f' % t_schur, r['status'], '%.4f' % t_amg])
    del prob

    t_seq = float(mg_seq['cumulative_s'])
    print('\n(b), (c) the whole grid sequence, levels 1..%d of %s, KKT tol %.0e on every level; '
          'PETSc solves level l from the P1 interpolation of its level l-1 solution (its own grid '
          'sequencing, level 1 from x = 0); load average %s'
          % (lmax, scene, args.tol, loadavg()), flush=True)
    print('  dualsig (%s): multigrid grid sequence %.3f s in all (level %d: %.3f s, %s V-cycles)'
          % (dcmd, t_seq, lmax, float(mg_seq['seconds']), mg_seq['iterations']))
    print('  %-14s %11s %11s %9s %9s %10s %9s %8s %12s  %s' %
          ('PETSc solver', 'sum solve_s', 'sum setup_s', 'its(L)', 'its(all)', 'kkt(L)',
           'peak_MB', 'load', '/dualsig', 'status'), flush=True)
    for name in seq_names:
        tot, tot_setup, its_all, peak, status, x, r = 0.0, 0.0, 0, 0.0, 'converged', None, None
        for level in range(1, lmax + 1):
            p = Problem('%s_l%d.bin' % (prefix, level))
            y0 = None if x is None else p.prolong(x)[p.keep_idx]
            r = run_one(name, p, args, y0=y0, want_x=True)
            tot += r['solve_s']
            tot_setup += r['setup_s']
            its_all += max(r['iterations'], 0)
            peak = max(peak, r.get('peak_mb', 0.0) or 0.0)
            if r['status'] != 'converged':
                status = 'level %d: %s' % (level, r['status'])
            if 'traceback' in r:
                sys.stderr.write(r['traceback'])
            if 'x' not in r:
                status = 'level %d: %s' % (level, r['status'])
                print('    level %2d  n = %9d  %s (the parent process held %.0f MB)'
                      % (level, p.n, r['status'], r['parent_mb']), flush=True)
                break
            x = r['x']
            print('    level %2d  n = %9d  solve %8.3f s  its %3d  ksp_its %4d  kkt %.2e  '
                  'peak %6.0f MB (the parent\'s %.0f MB included)'
                  % (level, p.n, r['solve_s'], r['iterations'], r['ksp_iterations'], r['kkt'],
                     r.get('peak_mb', float('nan')), r['parent_mb']), flush=True)
            del p
        la = loadavg().split()[0]
        ratio = tot / t_seq
        print('  %-14s %11.3f %11.3f %9d %9d %10.2e %9.0f %8s %12s  %s' %
              (name, tot, tot_setup, r['iterations'], its_all, r['kkt'], peak, la,
               ('%.1fx' % ratio) if status == 'converged' else '-', status), flush=True)
        rows_out.append(['sequence', scene, lmax, '', name, '%.4f' % tot_setup, '%.4f' % tot,
                         r['iterations'], its_all, '%.3e' % r['kkt'], '%.0f' % peak, la,
                         '%.4f' % t_seq, '', status, ''])
    print('\n  commands: make bench-peers PEER_LEVEL=%d PEER_SCENE=%s, i.e. %s && %s '
          '(solve_s: the solve phase; setup_s: PETSc Mat/Vec/solver creation from the CSR '
          'arrays, the analogue of dualsig\'s assembly, which is not timed either)'
          % (lmax, scene, dcmd, pcmd))
    if args.csv:
        d = os.path.dirname(args.csv)
        if d:
            os.makedirs(d, exist_ok=True)
        new = not os.path.exists(args.csv) or os.path.getsize(args.csv) == 0
        with open(args.csv, 'a', newline='') as fh:
            w = csv.writer(fh)
            if new:
                w.writerow(['comparison', 'scene', 'level', 'n', 'solver', 'setup_s', 'solve_s',
                            'iterations', 'ksp_or_all_iterations', 'kkt', 'peak_mb', 'load1',
                            'dualsig_s', 'dualsig_schur_cold_s', 'status', 'dualsig_amg_cold_s'])
            w.writerows(rows_out)
        print('petsc_peers: %d row(s) appended to %s' % (len(rows_out), args.csv))
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument('bases', nargs='*', metavar='BASE')
    ap.add_argument('--tol', type=float, default=1e-10)
    ap.add_argument('--time-limit', type=float, default=400.0)
    ap.add_argument('--csv', default='out/bench_peers.csv')
    ap.add_argument('--solvers', default=','.join(SOLVERS))
    ap.add_argument('--petsc-options', default='')
    ap.add_argument('--list', action='store_true')
    ap.add_argument('--fair', metavar='PREFIX', default='',
                    help='fair mode on the binary exports PREFIX_l<level>.bin and '
                         'PREFIX_dualsig.csv of `bin/dualsig_bench peers`')
    ap.add_argument('--level', type=int, default=10, help='fair mode: the finest level')
    ap.add_argument('--mem-limit-gb', type=float, default=0.0,
                    help='address-space limit of each solver child in GiB (0: none)')
    ap.add_argument('--seq-solvers', default='snes-vi-hypre,snes-vi-gamg',
                    help='fair mode: the solvers run through the whole grid sequence')
    args = ap.parse_args(argv)

    names = [s.strip() for s in args.solvers.split(',') if s.strip()]
    bad = [s for s in names if s not in SOLVERS]
    if bad:
        ap.error('unknown solver(s) %s; known: %s' % (', '.join(bad), ', '.join(SOLVERS)))
    if args.list:
        for s in SOLVERS:
            print('%-13s %-5s %-13s %s' % (s, SOLVERS[s][0], SOLVERS[s][1], default_options(s)))
        return 0
    seq_names = [s.strip() for s in args.seq_solvers.split(',') if s.strip()]
    bad = [s for s in seq_names if s not in SOLVERS]
    if bad:
        ap.error('unknown solver(s) %s; known: %s' % (', '.join(bad), ', '.join(SOLVERS)))
    if not args.bases and not args.fair:
        ap.error('at least one BASE (or --fair PREFIX) is required')

    if not ensure_petsc4py():
        print(SKIP_LINE)
        return 0
    # Open MPI: let each child's MPI_Init run as an isolated singleton instead of spawning
    # an orted helper process per solver run
    os.environ.setdefault('OMPI_MCA_ess_singleton_isolated', '1')
    if args.fair:
        return fair_main(args, names, seq_names)

    widths = [13, 8, 8, 8, 8, 10, 10, 0]
    head = ['solver', 'setup_s', 'solve_s', 'its', 'ksp_its', 'kkt', 'rel_diff', 'status']
    rows_out = []
    used = {}
    for base in args.bases:
        prob = Problem(base)
        print('%s: n = %d (free %d, bounded %d, fixed %d), reduced m = %d, nnz(A_rr) = %d;'
              ' read %.2f s, reduce %.2f s; dualsig x: kkt = %.3e; tol = %.1e'
              % (base, prob.n, int((prob.kind == 0).sum()), int((prob.kind == 1).sum()),
                 int((prob.kind == 2).sum()), prob.m, prob.nnz_r, prob.t_read, prob.t_reduce,
                 prob.ref_kkt, args.tol), flush=True)
        print(fmt_row(head, widths), flush=True)
        for name in names:
            r = run_one(name, prob, args)
            print(fmt_row([name, '%.3f' % r['setup_s'], '%.3f' % r['solve_s'], r['iterations'],
                           r['ksp_iterations'], '%.3e' % r['kkt'], '%.3e' % r['rel_diff'],
                           r['status']], widths), flush=True)
            if 'traceback' in r:
                sys.stderr.write(r['traceback'])
            if r.get('options') is not None:
                used[name] = r['options'] + (' (GAMG wrapped in FreshGAMG)'
                                             if r.get('gamg_wrapped') else '')
            rows_out.append([base, prob.n, name, '%.4f' % r['setup_s'], '%.4f' % r['solve_s'],
                             r['iterations'], r['ksp_iterations'], '%.6e' % r['kkt'],
                             '%.6e' % r['rel_diff'], r['status']])
        print(flush=True)

    print('PETSc options (defaults%s):' % (', then ' + args.petsc_options
                                          if args.petsc_options else ''))
    for name in names:
        if name in used:
            print('  %-13s %s' % (name, used[name] or '(none)'))
    if args.csv:
        d = os.path.dirname(args.csv)
        if d:
            os.makedirs(d, exist_ok=True)
        new = not os.path.exists(args.csv) or os.path.getsize(args.csv) == 0
        with open(args.csv, 'a', newline='') as fh:
            w = csv.writer(fh)
            if new:
                w.writerow(['base', 'n', 'solver', 'setup_s', 'solve_s', 'iterations',
                            'ksp_iterations', 'kkt', 'rel_diff', 'status'])
            w.writerows(rows_out)
        print('petsc_peers: %d row(s) appended to %s' % (len(rows_out), args.csv))
    return 0


if __name__ == '__main__':
    sys.exit(main())
