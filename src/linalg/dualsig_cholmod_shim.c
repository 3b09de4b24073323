/*
 * dualsig_cholmod_shim.c -- thin C layer between dualsig (Fortran) and CHOLMOD.
 *
 * The Fortran module dualsig_sparse_direct calls these functions through
 * iso_c_binding.  A handle (opaque to Fortran, a type(c_ptr)) owns
 *   - a cholmod_common (int interface, itype CHOLMOD_INT, never mirrored in Fortran),
 *   - a cholmod_sparse copy of the matrix with its own 0-based arrays,
 *   - the supernodal cholmod_factor (symbolic analysis + numeric LL'),
 *   - the dense workspaces of cholmod_solve2, kept between solves.
 *
 * The matrix is symmetric positive definite, given in 0-based CSC form; full storage is
 * allowed because the copy has stype = 1: CHOLMOD reads only the entries with
 * row <= column and ignores the others.
 *
 * Nothing here prints or exits: Common->print = 0 and Common->error_handler = NULL.
 * CHOLMOD, METIS and the BLAS are not written for a trapping floating-point environment
 * (dualsig's debug build runs with -ffpe-trap=invalid,zero,overflow), so every call into
 * CHOLMOD runs with all exceptions masked (feholdexcept) and the caller's environment --
 * traps and flags -- is restored afterwards (fesetenv); the library's own exception flags
 * are discarded.  Results are checked through CHOLMOD's status and L->minor instead.
 *
 * Every function returns an int status:
 */
#include <fenv.h>
#include <limits.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "cholmod.h"

enum {
    DSCHOL_OK = 0,               /* success */
    DSCHOL_ERR_INPUT = 1,        /* invalid argument: NULL pointer, n < 0, nrhs < 0, unknown
                                    ordering code, or colptr/rowind not a valid n x n CSC
                                    pattern (colptr[0] /= 0, decreasing, row out of range) */
    DSCHOL_ERR_NOMEM = 2,        /* out of memory (malloc or CHOLMOD_OUT_OF_MEMORY) */
    DSCHOL_ERR_NOT_POSDEF = 3,   /* matrix not positive definite: L->minor < n */
    DSCHOL_ERR_TOO_LARGE = 4,    /* CHOLMOD_TOO_LARGE: sizes overflow the int interface */
    DSCHOL_ERR_CHOLMOD = 5,      /* any other CHOLMOD failure (status < 0) */
    DSCHOL_ERR_NOT_FACTORED = 6  /* solve while the handle holds no valid numeric factor
                                    (the last refactorisation failed) */
};

/* Ordering codes: on input to dualsig_chol_factor 0..3; on output (*ordering_used) 1..7. */
enum {
    DSCHOL_ORD_BEST = 0,         /* input: try AMD and METIS, keep the one with less fill */
    DSCHOL_ORD_AMD = 1,          /* approximate minimum degree */
    DSCHOL_ORD_METIS = 2,        /* METIS_NodeND nested dissection */
    DSCHOL_ORD_NATURAL = 3,      /* identity, no postordering */
    DSCHOL_ORD_NESDIS = 4,       /* output only: CHOLMOD's own nested dissection */
    DSCHOL_ORD_COLAMD = 5,       /* output only */
    DSCHOL_ORD_POSTORDERED = 6,  /* output only: natural ordering followed by a postorder */
    DSCHOL_ORD_GIVEN = 7,        /* user permutation, post-ordered by CHOLMOD */
    DSCHOL_ORD_GIVEN_EXACT = 9,  /* input only: user permutation kept exactly (no post-ordering) */
    DSCHOL_ORD_UNKNOWN = -1      /* output only: a code this shim does not know */
};

typedef struct {
    cholmod_common c;            /* owned; cholmod_start'ed when started = 1 */
    int started;
    int n;
    cholmod_sparse *A;           /* 0-based copy of the matrix, stype = 1 */
    cholmod_factor *L;           /* supernodal factor (symbolic analysis kept) */
    cholmod_dense *X, *Y, *E;    /* cholmod_solve2 result and workspaces, reused */
    int factored;                /* 1 when L holds a valid numeric factor */
} dschol_handle;

int dualsig_chol_factor(int n, const int *colptr, const int *rowind, const double *val,
                        int ordering, const int *perm, void **handle, long *nnz_factor,
                        double *flops, int *ordering_used, int *minor);
int dualsig_chol_refactor(void *handle, const double *val);
int dualsig_chol_solve(void *handle, int nrhs, const double *b, double *x);
int dualsig_chol_minor(const void *handle);
void dualsig_chol_free(void **handle);
int dualsig_chol_order(int n, const int *colptr, const int *rowind, int ordering, int *perm);
int dualsig_chol_perm(const void *handle, int *perm);
int dualsig_chol_trailing(const void *handle, int na, double *ltt);
int dualsig_chol_solve_tri(void *handle, int upper, const double *b, double *x);

/* Map a negative CHOLMOD status to a shim status. */
static int map_failure(int cholmod_status)
{
    switch (cholmod_status) {
    case CHOLMOD_OUT_OF_MEMORY: return DSCHOL_ERR_NOMEM;
    case CHOLMOD_TOO_LARGE:     return DSCHOL_ERR_TOO_LARGE;
    default:                    return DSCHOL_ERR_CHOLMOD;
    }
}

static int map_ordering(int cholmod_ordering)
{
    switch (cholmod_ordering) {
    case CHOLMOD_AMD:         return DSCHOL_ORD_AMD;
    case CHOLMOD_METIS:       return DSCHOL_ORD_METIS;
    case CHOLMOD_NATURAL:     return DSCHOL_ORD_NATURAL;
    case CHOLMOD_NESDIS:      return DSCHOL_ORD_NESDIS;
    case CHOLMOD_COLAMD:      return DSCHOL_ORD_COLAMD;
    case CHOLMOD_POSTORDERED: return DSCHOL_ORD_POSTORDERED;
    case CHOLMOD_GIVEN:       return DSCHOL_ORD_GIVEN;
    default:                  return DSCHOL_ORD_UNKNOWN;
    }
}

/* Free a half-built handle and return st. */
static int fail(dschol_handle *h, int st)
{
    void *p = h;
    dualsig_chol_free(&p);
    return st;
}

/* Numeric factorisation of h->A into h->L (symbolic part already there), with the checks:
 * status < 0 is a failure, CHOLMOD_NOT_POSDEF is only a warning and L->minor < n is the
 * real sign that the matrix is not positive definite. */
static int factorize(dschol_handle *h)
{
    fenv_t env;
    int ok;
    h->factored = 0;
    feholdexcept(&env);
    ok = cholmod_factorize(h->A, h->L, &h->c);
    fesetenv(&env);
    if (!ok || h->c.status < CHOLMOD_OK) return map_failure(h->c.status);
    if (h->L->minor < (size_t) h->n) return DSCHOL_ERR_NOT_POSDEF;
    h->factored = 1;
    return DSCHOL_OK;
}

/*
 * Analyse and factorise the n x n symmetric matrix given in 0-based CSC form
 * (colptr[0..n], rowind[0..nnz-1], val[0..nnz-1], nnz = colptr[n]); only the entries with
 * rowind <= column are used.  ordering: 0 best of AMD and METIS (least nnz(L)), 1 AMD,
 * 2 METIS (CHOLMOD falls back to AMD if METIS fails), 3 natural, 7 given: perm[0..n-1]
 * (0-based, a permutation; NULL for the other orderings) is the elimination order, which
 * CHOLMOD post-orders, 9 given exactly: perm without post-ordering.
 *
 * Outputs (all set, also on failure where known):
 *   *handle         the new handle, NULL on any failure (everything is freed then)
 *   *nnz_factor     Common->lnz of the selected ordering: the nonzeros of L, diagonal
 *                   included, of the "pure" factor for this permutation (the exact count
 *                   of a simplicial L).  The supernodal storage holds more entries
 *                   (explicit zeros of relaxed amalgamation, dense diagonal blocks).
 *   *flops          Common->fl: flop count of that pure LL' factorisation
 *   *ordering_used  ordering actually used, from L->ordering (DSCHOL_ORD_* output codes)
 *   *minor          L->minor, 0-based: n on success, the failed column of the permuted
 *                   matrix when not positive definite, -1 when no factorisation ran
 */
int dualsig_chol_factor(int n, const int *colptr, const int *rowind, const double *val,
                        int ordering, const int *perm, void **handle, long *nnz_factor,
                        double *flops, int *ordering_used, int *minor)
{
    dschol_handle *h;
    fenv_t env;
    int *Ap, *Ai, sorted = 1, j, st;
    double *Ax;
    size_t nnz;

    if (handle == NULL || nnz_factor == NULL || flops == NULL || ordering_used == NULL ||
        minor == NULL)
        return DSCHOL_ERR_INPUT;
    *handle = NULL;
    *nnz_factor = 0;
    *flops = 0.0;
    *ordering_used = DSCHOL_ORD_UNKNOWN;
    *minor = -1;

    /* validate the pattern: colptr[0] = 0, nondecreasing, rows in [0, n) */
    if (n < 0 || colptr == NULL) return DSCHOL_ERR_INPUT;
    if (ordering == DSCHOL_ORD_GIVEN || ordering == DSCHOL_ORD_GIVEN_EXACT) {
        /* a permutation of 0..n-1 */
        char *seen;
        if (perm == NULL) return DSCHOL_ERR_INPUT;
        seen = calloc((size_t) n + 1, 1);
        if (seen == NULL) return DSCHOL_ERR_NOMEM;
        for (j = 0; j < n; j++) {
            if (perm[j] < 0 || perm[j] >= n || seen[perm[j]]) { free(seen); return DSCHOL_ERR_INPUT; }
            seen[perm[j]] = 1;
        }
        free(seen);
    } else if (ordering < DSCHOL_ORD_BEST || ordering > DSCHOL_ORD_NATURAL) {
        return DSCHOL_ERR_INPUT;
    }
    if (colptr[0] != 0) return DSCHOL_ERR_INPUT;
    for (j = 0; j < n; j++)
        if (colptr[j + 1] < colptr[j]) return DSCHOL_ERR_INPUT;
    nnz = (size_t) colptr[n];
    if (nnz > 0 && (rowind == NULL || val == NULL)) return DSCHOL_ERR_INPUT;
    for (j = 0; j < n; j++) {
        int p;
        for (p = colptr[j]; p < colptr[j + 1]; p++) {
            if (rowind[p] < 0 || rowind[p] >= n) return DSCHOL_ERR_INPUT;
            if (p > colptr[j] && rowind[p] <= rowind[p - 1]) sorted = 0;
        }
    }

    h = calloc(1, sizeof *h);
    if (h == NULL) return DSCHOL_ERR_NOMEM;
    h->n = n;

    feholdexcept(&env);
    cholmod_start(&h->c);
    h->started = 1;
    h->c.print = 0;                         /* CHOLMOD prints nothing ... */
    h->c.error_handler = NULL;              /* ... and calls no handler */
    h->c.supernodal = CHOLMOD_SUPERNODAL;
    switch (ordering) {
    case DSCHOL_ORD_BEST:
        h->c.nmethods = 2;
        h->c.method[0].ordering = CHOLMOD_AMD;
        h->c.method[1].ordering = CHOLMOD_METIS;
        break;
    case DSCHOL_ORD_AMD:
        h->c.nmethods = 1;
        h->c.method[0].ordering = CHOLMOD_AMD;
        break;
    case DSCHOL_ORD_METIS:
        h->c.nmethods = 1;
        h->c.method[0].ordering = CHOLMOD_METIS;
        break;
    case DSCHOL_ORD_GIVEN:
        h->c.nmethods = 1;
        h->c.method[0].ordering = CHOLMOD_GIVEN;  /* post-ordered (postorder = 1) */
        break;
    case DSCHOL_ORD_GIVEN_EXACT:
        h->c.nmethods = 1;
        h->c.method[0].ordering = CHOLMOD_GIVEN;
        h->c.postorder = 0;                 /* the elimination order is exactly perm */
        break;
    default:
        h->c.nmethods = 1;
        h->c.method[0].ordering = CHOLMOD_NATURAL;
        h->c.postorder = 0;                 /* genuinely the given order */
        break;
    }

    h->A = cholmod_allocate_sparse((size_t) n, (size_t) n, nnz, sorted, 1, 1, CHOLMOD_REAL,
                                   &h->c);
    fesetenv(&env);
    if (h->A == NULL) return fail(h, map_failure(h->c.status));
    Ap = h->A->p;
    Ai = h->A->i;
    Ax = h->A->x;
    memcpy(Ap, colptr, ((size_t) n + 1) * sizeof *Ap);
    if (nnz > 0) {
        memcpy(Ai, rowind, nnz * sizeof *Ai);
        memcpy(Ax, val, nnz * sizeof *Ax);
    }

    feholdexcept(&env);
    if (ordering == DSCHOL_ORD_GIVEN || ordering == DSCHOL_ORD_GIVEN_EXACT)
        h->L = cholmod_analyze_p(h->A, (int *) perm, NULL, 0, &h->c);
    else
        h->L = cholmod_analyze(h->A, &h->c);
    fesetenv(&env);
    if (h->L == NULL || h->c.status < CHOLMOD_OK) return fail(h, map_failure(h->c.status));
    *nnz_factor = (long) h->c.lnz;
    *flops = h->c.fl;
    *ordering_used = map_ordering(h->L->ordering);

    st = factorize(h);
    *minor = (int) h->L->minor;
    if (st != DSCHOL_OK) return fail(h, st);
    *handle = h;
    return DSCHOL_OK;
}

/*
 * Numeric refactorisation with new values val[0..nnz-1], same pattern (same CSC arrays as
 * given to dualsig_chol_factor): the symbolic analysis is reused.  On failure the handle
 * stays valid (it can be refactored again) but cannot solve until a refactorisation
 * succeeds; dualsig_chol_minor tells the failed pivot.
 */
int dualsig_chol_refactor(void *handle, const double *val)
{
    dschol_handle *h = handle;
    size_t nnz;
    if (h == NULL) return DSCHOL_ERR_INPUT;
    nnz = (size_t) ((int *) h->A->p)[h->n];
    if (nnz > 0 && val == NULL) return DSCHOL_ERR_INPUT;
    if (nnz > 0) memcpy(h->A->x, val, nnz * sizeof(double));
    return factorize(h);
}

/*
 * Solve A x = b for nrhs right-hand sides stored column-major, b and x both n x nrhs
 * (they may be the same array).  cholmod_solve2 reuses its result and workspaces between
 * calls (reallocated only when nrhs changes).
 */
int dualsig_chol_solve(void *handle, int nrhs, const double *b, double *x)
{
    dschol_handle *h = handle;
    cholmod_dense B;
    fenv_t env;
    size_t n, j;
    int ok;

    if (h == NULL || nrhs < 0) return DSCHOL_ERR_INPUT;
    if (!h->factored) return DSCHOL_ERR_NOT_FACTORED;
    if (nrhs == 0 || h->n == 0) return DSCHOL_OK;
    if (b == NULL || x == NULL) return DSCHOL_ERR_INPUT;
    n = (size_t) h->n;

    /* a header around the caller's b: cholmod_solve2 only reads B */
    memset(&B, 0, sizeof B);
    B.nrow = n;
    B.ncol = (size_t) nrhs;
    B.nzmax = n * (size_t) nrhs;
    B.d = n;
    B.x = (void *) b;
    B.z = NULL;
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;

    feholdexcept(&env);
    ok = cholmod_solve2(CHOLMOD_A, h->L, &B, NULL, &h->X, NULL, &h->Y, &h->E, &h->c);
    fesetenv(&env);
    if (!ok || h->X == NULL || h->c.status < CHOLMOD_OK) return map_failure(h->c.status);

    for (j = 0; j < (size_t) nrhs; j++)
        memcpy(x + j * n, (const double *) h->X->x + j * h->X->d, n * sizeof(double));
    return DSCHOL_OK;
}

/* L->minor of the last factorisation (0-based, n when it succeeded); -1 for NULL. */
int dualsig_chol_minor(const void *handle)
{
    const dschol_handle *h = handle;
    if (h == NULL || h->L == NULL) return -1;
    return (int) h->L->minor;
}

/* Free everything the handle owns and set *handle = NULL.  Safe on NULL and on *handle NULL. */
void dualsig_chol_free(void **handle)
{
    dschol_handle *h;
    fenv_t env;
    if (handle == NULL || *handle == NULL) return;
    h = *handle;
    if (h->started) {
        feholdexcept(&env);
        cholmod_free_dense(&h->X, &h->c);
        cholmod_free_dense(&h->Y, &h->c);
        cholmod_free_dense(&h->E, &h->c);
        cholmod_free_factor(&h->L, &h->c);
        cholmod_free_sparse(&h->A, &h->c);
        cholmod_finish(&h->c);
        fesetenv(&env);
    }
    free(h);
    *handle = NULL;
}

/*
 * The fill-reducing ordering alone: cholmod_analyze of the n x n pattern (colptr, rowind,
 * 0-based CSC, entries with row <= column read) with ordering 0 best, 1 AMD or 2 METIS,
 * and the final (post-ordered) elimination order copied to perm[0..n-1]: perm[k] is the
 * unknown eliminated k-th.  No numeric factorisation; everything is freed on return.
 */
int dualsig_chol_order(int n, const int *colptr, const int *rowind, int ordering, int *perm)
{
    cholmod_common c;
    cholmod_sparse *A;
    cholmod_factor *L;
    fenv_t env;
    size_t nnz;
    int j, st = DSCHOL_OK;

    if (n < 0 || colptr == NULL || perm == NULL || ordering < DSCHOL_ORD_BEST ||
        ordering > DSCHOL_ORD_METIS || colptr[0] != 0)
        return DSCHOL_ERR_INPUT;
    for (j = 0; j < n; j++)
        if (colptr[j + 1] < colptr[j]) return DSCHOL_ERR_INPUT;
    nnz = (size_t) colptr[n];
    if (nnz > 0 && rowind == NULL) return DSCHOL_ERR_INPUT;
    for (j = 0; j < (int) nnz; j++)
        if (rowind[j] < 0 || rowind[j] >= n) return DSCHOL_ERR_INPUT;

    feholdexcept(&env);
    cholmod_start(&c);
    c.print = 0;
    c.error_handler = NULL;
    c.supernodal = CHOLMOD_SUPERNODAL;
    c.nmethods = ordering == DSCHOL_ORD_BEST ? 2 : 1;
    c.method[0].ordering = ordering == DSCHOL_ORD_METIS ? CHOLMOD_METIS : CHOLMOD_AMD;
    c.method[1].ordering = CHOLMOD_METIS;
    /* a pattern-only matrix: CHOLMOD_PATTERN needs no values */
    A = cholmod_allocate_sparse((size_t) n, (size_t) n, nnz, 0, 1, 1, CHOLMOD_PATTERN, &c);
    if (A == NULL) {
        st = map_failure(c.status);
    } else {
        memcpy(A->p, colptr, ((size_t) n + 1) * sizeof(int));
        if (nnz > 0) memcpy(A->i, rowind, nnz * sizeof(int));
        L = cholmod_analyze(A, &c);
        if (L == NULL || c.status < CHOLMOD_OK) {
            st = map_failure(c.status);
        } else {
            memcpy(perm, L->Perm, (size_t) n * sizeof(int));
        }
        cholmod_free_factor(&L, &c);
        cholmod_free_sparse(&A, &c);
    }
    cholmod_finish(&c);
    fesetenv(&env);
    return st;
}

/* The final elimination order of the factor: perm[k] (0-based) is eliminated k-th. */
int dualsig_chol_perm(const void *handle, int *perm)
{
    const dschol_handle *h = handle;
    if (h == NULL || h->L == NULL || perm == NULL) return DSCHOL_ERR_INPUT;
    memcpy(perm, h->L->Perm, (size_t) h->n * sizeof(int));
    return DSCHOL_OK;
}

/*
 * The trailing na x na block of the supernodal factor L (rows and columns n-na .. n-1 of
 * the permuted matrix), copied into the dense column-major array ltt[na * na], lower
 * triangle, zeros above the diagonal.  With the unknowns T eliminated last,
 * P A P' = L L' gives the Schur complement of A onto T as ltt ltt'.
 */
int dualsig_chol_trailing(const void *handle, int na, double *ltt)
{
    const dschol_handle *h = handle;
    const int *super, *pi, *px, *ls;
    const double *lx;
    size_t first, s;
    int j, r;

    if (h == NULL || ltt == NULL || na < 0 || na > h->n) return DSCHOL_ERR_INPUT;
    if (!h->factored) return DSCHOL_ERR_NOT_FACTORED;
    if (!h->L->is_super || !h->L->is_ll) return DSCHOL_ERR_CHOLMOD;
    memset(ltt, 0, (size_t) na * (size_t) na * sizeof(double));
    first = (size_t) (h->n - na);
    super = h->L->super;
    pi = h->L->pi;
    px = h->L->px;
    ls = h->L->s;
    lx = h->L->x;
    for (s = 0; s < h->L->nsuper; s++) {
        int k1 = super[s], k2 = super[s + 1], nsrow = pi[s + 1] - pi[s];
        if ((size_t) k2 <= first) continue;
        for (j = k1 > (int) first ? k1 : (int) first; j < k2; j++) {
            const double *col = lx + px[s] + (size_t) (j - k1) * (size_t) nsrow;
            /* rows of the supernode: ls[pi[s] .. pi[s+1]-1], the first k2-k1 are k1..k2-1 */
            for (r = j - k1; r < nsrow; r++) {
                int row = ls[pi[s] + r];
                ltt[(size_t) (row - (int) first) + (size_t) (j - (int) first) * (size_t) na] = col[r];
            }
        }
    }
    return DSCHOL_OK;
}

/*
 * One triangular solve with the factor, in the permuted numbering: upper = 0 solves
 * L x = b, upper = 1 solves L' x = b (b and x of length n; the caller applies P).
 */
int dualsig_chol_solve_tri(void *handle, int upper, const double *b, double *x)
{
    dschol_handle *h = handle;
    cholmod_dense B;
    fenv_t env;
    int ok;

    if (h == NULL) return DSCHOL_ERR_INPUT;
    if (!h->factored) return DSCHOL_ERR_NOT_FACTORED;
    if (h->n == 0) return DSCHOL_OK;
    if (b == NULL || x == NULL || !h->L->is_ll) return DSCHOL_ERR_INPUT;
    memset(&B, 0, sizeof B);
    B.nrow = (size_t) h->n;
    B.ncol = 1;
    B.nzmax = (size_t) h->n;
    B.d = (size_t) h->n;
    B.x = (void *) b;
    B.xtype = CHOLMOD_REAL;
    B.dtype = CHOLMOD_DOUBLE;
    feholdexcept(&env);
    ok = cholmod_solve2(upper ? CHOLMOD_Lt : CHOLMOD_L, h->L, &B, NULL, &h->X, NULL, &h->Y, &h->E, &h->c);
    fesetenv(&env);
    if (!ok || h->X == NULL || h->c.status < CHOLMOD_OK) return map_failure(h->c.status);
    memcpy(x, h->X->x, (size_t) h->n * sizeof(double));
    return DSCHOL_OK;
}
