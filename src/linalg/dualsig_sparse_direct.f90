!> Sparse direct solver: supernodal Cholesky factorisation A = L L^T of a symmetric
!> positive definite `csr_t` matrix by CHOLMOD (SuiteSparse).
!>
!> The work is done by the C shim `src/dualsig_cholmod_shim.c`, which owns the CHOLMOD
!> common block, a 0-based copy of the matrix and the factor; Fortran only holds an opaque
!> handle.  The matrix is converted to 0-based indices once, in `cholesky_factor`; solves
!> and refactorisations never convert the pattern again.
!>
!> Only the lower triangle a(i, j), j <= i, of the CSR matrix is read (for a symmetric
!> matrix stored with both triangles, as `csr_t` does, the CSR arrays are the CSC arrays of
!> the same matrix, and CHOLMOD reads their upper triangle); symmetry is not checked.
!>
!> A `cholesky_t` owns C memory that Fortran cannot see: there is no finaliser, the user
!> must call `cholesky_free` when the factor is no longer needed (also after a failed
!> `cholesky_refactor`).  `cholesky_factor` on a `cholesky_t` that already holds a factor
!> frees the old one first.  Do not copy a `cholesky_t` by intrinsic assignment and free
!> both copies: the handle would be freed twice.
!>
!> Typical use:
!>
!>     call cholesky_factor(a, chol, st)              ! analyse + factorise
!>     call cholesky_solve(chol, b, x, st)            ! as many solves as needed
!>     call cholesky_refactor(a, chol, st)            ! new values, same pattern
!>     call cholesky_free(chol)
module dualsig_sparse_direct
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use, intrinsic :: iso_c_binding, only: c_ptr, c_null_ptr, c_associated, c_int, c_long, c_double, c_loc
  use dualsig_kinds, only: dp, i8
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT, DS_ERR_NUMERIC, DS_ERR_MEMORY
  use dualsig_sparse, only: csr_t
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_INT
  implicit none
  private

  public :: cholesky_t, cholesky_factor, cholesky_refactor, cholesky_solve, cholesky_free
  public :: cholesky_order, cholesky_permutation, cholesky_trailing_block, cholesky_solve_triangular
  public :: ORDERING_BEST, ORDERING_AMD, ORDERING_METIS, ORDERING_NATURAL, ORDERING_GIVEN, ORDERING_GEOMETRIC, &
            ORDERING_GIVEN_EXACT

  !> Fill-reducing orderings for `cholesky_factor`.
  integer, parameter :: ORDERING_BEST = 0     !! AMD and METIS both tried, the one with less fill kept
  integer, parameter :: ORDERING_AMD = 1      !! approximate minimum degree
  integer, parameter :: ORDERING_METIS = 2    !! METIS nested dissection (AMD if METIS fails)
  integer, parameter :: ORDERING_NATURAL = 3  !! no reordering
  integer, parameter :: ORDERING_GIVEN = 7    !! the caller's permutation (e.g. geometric nested dissection), post-ordered
  !> Not a CHOLMOD ordering: asks the problem layer (which knows the points of the unknowns)
  !> for a geometric nested dissection (dualsig_ordering_geometric), passed on as ORDERING_GIVEN.
  integer, parameter :: ORDERING_GEOMETRIC = 8
  !> The caller's permutation kept exactly (no post-ordering), e.g. to eliminate a set last.
  integer, parameter :: ORDERING_GIVEN_EXACT = 9

  ! Status codes of the C shim (see src/dualsig_cholmod_shim.c).
  integer(c_int), parameter :: SHIM_OK = 0, SHIM_ERR_INPUT = 1, SHIM_ERR_NOMEM = 2, &
                               SHIM_ERR_NOT_POSDEF = 3, SHIM_ERR_TOO_LARGE = 4, &
                               SHIM_ERR_CHOLMOD = 5, SHIM_ERR_NOT_FACTORED = 6

  !> A Cholesky factorisation held by CHOLMOD.  Release it with `cholesky_free`.
  type :: cholesky_t
    type(c_ptr) :: handle = c_null_ptr    !! the C shim's handle (opaque)
    integer :: n = 0                      !! order of the factored matrix
    integer(i8) :: nnz_factor = 0         !! nonzeros of L, diagonal included, for the ordering used
                                          !! (CHOLMOD's Common->lnz: the exact count of a
                                          !! non-amalgamated L; supernodal storage holds more)
    real(dp) :: flops = 0.0_dp            !! floating-point operations of the factorisation
    character(len=8) :: ordering = ''     !! 'amd', 'metis', 'natural', ... actually used
    integer :: nnz_a = 0                  !! stored entries of the factored matrix (pattern check)
    integer(i8) :: pattern_sig = 0        !! signature of its pattern (pattern check)
  end type cholesky_t

  interface
    !> See src/dualsig_cholmod_shim.c.
    function shim_factor(n, colptr, rowind, val, ordering, perm, handle, nnz_factor, flops, &
                         ordering_used, minor) result(code) bind(c, name='dualsig_chol_factor')
      import :: c_int, c_long, c_double, c_ptr
      integer(c_int), value, intent(in) :: n
      integer(c_int), intent(in) :: colptr(*), rowind(*)
      real(c_double), intent(in) :: val(*)
      integer(c_int), value, intent(in) :: ordering
      type(c_ptr), value, intent(in) :: perm          !! 0-based permutation or C NULL
      type(c_ptr), intent(inout) :: handle
      integer(c_long), intent(out) :: nnz_factor
      real(c_double), intent(out) :: flops
      integer(c_int), intent(out) :: ordering_used, minor
      integer(c_int) :: code
    end function shim_factor

    function shim_refactor(handle, val) result(code) bind(c, name='dualsig_chol_refactor')
      import :: c_int, c_double, c_ptr
      type(c_ptr), value, intent(in) :: handle
      real(c_double), intent(in) :: val(*)
      integer(c_int) :: code
    end function shim_refactor

    function shim_solve(handle, nrhs, b, x) result(code) bind(c, name='dualsig_chol_solve')
      import :: c_int, c_double, c_ptr
      type(c_ptr), value, intent(in) :: handle
      integer(c_int), value, intent(in) :: nrhs
      real(c_double), intent(in) :: b(*)
      real(c_double), intent(inout) :: x(*)
      integer(c_int) :: code
    end function shim_solve

    function shim_minor(handle) result(minor) bind(c, name='dualsig_chol_minor')
      import :: c_int, c_ptr
      type(c_ptr), value, intent(in) :: handle
      integer(c_int) :: minor
    end function shim_minor

    subroutine shim_free(handle) bind(c, name='dualsig_chol_free')
      import :: c_ptr
      type(c_ptr), intent(inout) :: handle
    end subroutine shim_free

    function shim_order(n, colptr, rowind, ordering, perm) result(code) bind(c, name='dualsig_chol_order')
      import :: c_int
      integer(c_int), value, intent(in) :: n
      integer(c_int), intent(in) :: colptr(*), rowind(*)
      integer(c_int), value, intent(in) :: ordering
      integer(c_int), intent(out) :: perm(*)
      integer(c_int) :: code
    end function shim_order

    function shim_perm(handle, perm) result(code) bind(c, name='dualsig_chol_perm')
      import :: c_int, c_ptr
      type(c_ptr), value, intent(in) :: handle
      integer(c_int), intent(out) :: perm(*)
      integer(c_int) :: code
    end function shim_perm

    function shim_trailing(handle, na, ltt) result(code) bind(c, name='dualsig_chol_trailing')
      import :: c_int, c_double, c_ptr
      type(c_ptr), value, intent(in) :: handle
      integer(c_int), value, intent(in) :: na
      real(c_double), intent(out) :: ltt(*)
      integer(c_int) :: code
    end function shim_trailing

    function shim_solve_tri(handle, upper, b, x) result(code) bind(c, name='dualsig_chol_solve_tri')
      import :: c_int, c_double, c_ptr
      type(c_ptr), value, intent(in) :: handle
      integer(c_int), value, intent(in) :: upper
      real(c_double), intent(in) :: b(*)
      real(c_double), intent(inout) :: x(*)
      integer(c_int) :: code
    end function shim_solve_tri
  end interface

  !> Solve A x = b with a factor from `cholesky_factor`: b(:), x(:) for one right-hand
  !> side, or b(:, :), x(:, :) with one right-hand side per column.
  interface cholesky_solve
    module procedure cholesky_solve_1, cholesky_solve_n
  end interface cholesky_solve

contains

  !> Analyse (fill-reducing ordering, symbolic factorisation) and factorise `a`.
  !> A factor already held by `chol` is freed first.  On failure `chol` holds no factor.
  !> Errors: DS_ERR_INPUT (bad matrix or ordering), DS_ERR_NUMERIC (not positive definite,
  !> out of memory, other CHOLMOD failure).
  subroutine cholesky_factor(a, chol, st, ordering, perm)
    type(csr_t), intent(in) :: a            !! symmetric positive definite (lower triangle read)
    type(cholesky_t), intent(inout) :: chol !! the factor
    type(status_t), intent(out) :: st       !! DS_OK or an error
    integer, intent(in), optional :: ordering !! ORDERING_BEST (default), _AMD, _METIS, _NATURAL, _GIVEN
    integer, intent(in), optional :: perm(:)  !! ORDERING_GIVEN(_EXACT): perm(k) = unknown eliminated k-th (1-based)
    integer(c_int), allocatable, target :: perm0(:)
    type(c_ptr) :: perm_ptr
    integer(c_int), allocatable :: colptr(:), rowind(:)
    integer(c_long) :: nnz_factor
    real(c_double) :: flops
    integer(c_int) :: ord, ord_used, minor, code

    call cholesky_free(chol)
    ord = ORDERING_BEST
    if (present(ordering)) ord = int(ordering, c_int)
    perm_ptr = c_null_ptr
    if (ord == ORDERING_GIVEN .or. ord == ORDERING_GIVEN_EXACT) then
      if (.not. present(perm)) then
        call set_error(st, DS_ERR_INPUT, 'cholesky: ORDERING_GIVEN needs the permutation perm')
        return
      end if
      if (size(perm) /= a%n) then
        call set_error(st, DS_ERR_INPUT, 'cholesky: perm has ' // itoa(size(perm)) // ' entries, the matrix ' // &
                       'has order ' // itoa(a%n))
        return
      end if
      perm0 = int(perm - 1, c_int)
      perm_ptr = c_loc(perm0)
    else if (ord < ORDERING_BEST .or. ord > ORDERING_NATURAL) then
      call set_error(st, DS_ERR_INPUT, 'cholesky: unknown ordering code ' // itoa(int(ord)) // &
                     ' (expected 0 best, 1 amd, 2 metis, 3 natural, 7 given, 9 given exactly)')
      return
    end if
    if (.not. pattern_ok(a, st)) return
    if (.not. all(ieee_is_finite(a%val))) then
      ! checked here: optimised BLAS (OpenBLAS) do not flag a NaN pivot as reference LAPACK does
      call set_error(st, DS_ERR_NUMERIC, 'cholesky: the matrix has a non-finite entry (NaN or Inf): ' // &
                     'not positive definite')
      return
    end if

    ! 0-based copies, handed over once: the C handle keeps its own
    colptr = int(a%rowptr - 1, c_int)
    rowind = int(a%col - 1, c_int)
    code = shim_factor(int(a%n, c_int), colptr, rowind, a%val, ord, perm_ptr, chol%handle, &
                       nnz_factor, flops, ord_used, minor)
    deallocate (colptr, rowind)
    if (code /= SHIM_OK) then
      call shim_error(st, code, int(minor), a%n)
      chol%handle = c_null_ptr
      return
    end if
    chol%n = a%n
    chol%nnz_factor = int(nnz_factor, i8)
    chol%flops = real(flops, dp)
    chol%ordering = ordering_name(int(ord_used))
    chol%nnz_a = a%rowptr(a%n + 1) - 1
    chol%pattern_sig = pattern_signature(a)
  end subroutine cholesky_factor

  !> Factorise new values of the matrix factored by `cholesky_factor` (same pattern),
  !> reusing its ordering and symbolic analysis.  After a failure `chol` can be refactored
  !> again but not used to solve; it must still be freed.
  subroutine cholesky_refactor(a, chol, st)
    type(csr_t), intent(in) :: a            !! same pattern as at `cholesky_factor`, new values
    type(cholesky_t), intent(inout) :: chol !! the factor, updated
    type(status_t), intent(out) :: st       !! DS_OK or an error
    integer(c_int) :: code

    if (.not. c_associated(chol%handle)) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_refactor: no factor (call cholesky_factor first)')
      return
    end if
    if (.not. pattern_ok(a, st)) return
    if (a%n /= chol%n .or. a%rowptr(a%n + 1) - 1 /= chol%nnz_a) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_refactor: matrix of order ' // itoa(a%n) // &
                     ' with ' // itoa(a%rowptr(a%n + 1) - 1) // ' entries, the factor has order ' // &
                     itoa(chol%n) // ' with ' // itoa(chol%nnz_a) // ' entries')
      return
    end if
    if (pattern_signature(a) /= chol%pattern_sig) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_refactor: the sparsity pattern differs from the factored one')
      return
    end if
    if (.not. all(ieee_is_finite(a%val))) then
      ! refactorise a zero matrix instead: the factor becomes invalid (a failed refactor),
      ! whatever the BLAS does with NaN pivots
      code = shim_refactor(chol%handle, spread(0.0_dp, 1, size(a%val)))
      call set_error(st, DS_ERR_NUMERIC, 'cholesky_refactor: the matrix has a non-finite entry (NaN or Inf): ' // &
                     'not positive definite')
      return
    end if
    code = shim_refactor(chol%handle, a%val)
    if (code /= SHIM_OK) call shim_error(st, code, int(shim_minor(chol%handle)), chol%n)
  end subroutine cholesky_refactor

  !> Solve A x = b for one right-hand side.
  subroutine cholesky_solve_1(chol, b, x, st)
    type(cholesky_t), intent(in) :: chol    !! a successful factorisation
    real(dp), intent(in) :: b(:)            !! (n) right-hand side
    real(dp), intent(out) :: x(:)           !! (n) solution
    type(status_t), intent(out) :: st       !! DS_OK or an error
    integer(c_int) :: code
    if (.not. solve_args_ok(chol, size(b), size(x), 1, 1, st)) return
    code = shim_solve(chol%handle, 1_c_int, b, x)
    if (code /= SHIM_OK) call shim_error(st, code, -1, chol%n)
  end subroutine cholesky_solve_1

  !> Solve A X = B for several right-hand sides, one per column.
  subroutine cholesky_solve_n(chol, b, x, st)
    type(cholesky_t), intent(in) :: chol    !! a successful factorisation
    real(dp), intent(in) :: b(:, :)         !! (n, nrhs) right-hand sides
    real(dp), intent(out) :: x(:, :)        !! (n, nrhs) solutions
    type(status_t), intent(out) :: st       !! DS_OK or an error
    integer(c_int) :: code
    if (.not. solve_args_ok(chol, size(b, 1), size(x, 1), size(b, 2), size(x, 2), st)) return
    code = shim_solve(chol%handle, int(size(b, 2), c_int), b, x)
    if (code /= SHIM_OK) call shim_error(st, code, -1, chol%n)
  end subroutine cholesky_solve_n

  !> Release the factor and reset `chol`.  Safe on a `cholesky_t` that holds nothing.
  subroutine cholesky_free(chol)
    type(cholesky_t), intent(inout) :: chol !! the factor, empty on return
    call shim_free(chol%handle)
    chol%handle = c_null_ptr
    chol%n = 0
    chol%nnz_factor = 0
    chol%flops = 0.0_dp
    chol%ordering = ''
    chol%nnz_a = 0
    chol%pattern_sig = 0
  end subroutine cholesky_free

  !> The fill-reducing ordering CHOLMOD would use for `a` (ORDERING_BEST, _AMD or _METIS),
  !> post-ordered, without a numeric factorisation: perm(k) = unknown eliminated k-th.
  subroutine cholesky_order(a, ordering, perm, st)
    type(csr_t), intent(in) :: a            !! the pattern (lower triangle read)
    integer, intent(in) :: ordering         !! ORDERING_BEST, ORDERING_AMD or ORDERING_METIS
    integer, allocatable, intent(out) :: perm(:) !! (n) 1-based elimination order
    type(status_t), intent(out) :: st       !! DS_OK or an error
    integer(c_int), allocatable :: colptr(:), rowind(:), perm0(:)
    integer(c_int) :: code
    integer :: ist
    if (ordering < ORDERING_BEST .or. ordering > ORDERING_METIS) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_order: ordering code ' // itoa(ordering) // &
                     ' (expected 0 best, 1 amd, 2 metis)')
      return
    end if
    if (.not. pattern_ok(a, st)) return
    colptr = int(a%rowptr - 1, c_int)
    rowind = int(a%col - 1, c_int)
    allocate (perm0(max(a%n, 1)), stat=ist)
    if (alloc_failed(ist, st, 'the fill-reducing ordering', max(a%n, 1), BYTES_INT)) return
    code = shim_order(int(a%n, c_int), colptr, rowind, int(ordering, c_int), perm0)
    if (code /= SHIM_OK) then
      call shim_error(st, code, -1, a%n)
      return
    end if
    perm = int(perm0(1:a%n)) + 1
  end subroutine cholesky_order

  !> The final elimination order of a factor (the given or computed ordering combined with
  !> CHOLMOD's post-ordering): perm(k) = unknown eliminated k-th, 1-based.
  subroutine cholesky_permutation(chol, perm, st)
    type(cholesky_t), intent(in) :: chol    !! a factor
    integer, allocatable, intent(out) :: perm(:) !! (n) elimination order
    type(status_t), intent(out) :: st       !! DS_OK or an error
    integer(c_int), allocatable :: perm0(:)
    integer(c_int) :: code
    integer :: ist
    if (.not. c_associated(chol%handle)) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_permutation: no factor')
      return
    end if
    allocate (perm0(max(chol%n, 1)), stat=ist)
    if (alloc_failed(ist, st, 'the elimination order', max(chol%n, 1), BYTES_INT)) return
    code = shim_perm(chol%handle, perm0)
    if (code /= SHIM_OK) then
      call shim_error(st, code, -1, chol%n)
      return
    end if
    perm = int(perm0(1:chol%n)) + 1
  end subroutine cholesky_permutation

  !> The trailing na x na block L_TT of the factor P A P^T = L L^T (the last na unknowns of
  !> the elimination order), dense lower triangular with zeros above the diagonal.  Then
  !> L_TT L_TT^T is the Schur complement of A onto those unknowns.
  subroutine cholesky_trailing_block(chol, na, ltt, st)
    type(cholesky_t), intent(in) :: chol    !! a successful factorisation
    integer, intent(in) :: na               !! 0 <= na <= n
    real(dp), intent(out) :: ltt(:,:)       !! (na, na)
    type(status_t), intent(out) :: st       !! DS_OK or an error
    integer(c_int) :: code
    if (.not. c_associated(chol%handle)) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_trailing_block: no factor')
      return
    end if
    if (na < 0 .or. na > chol%n .or. size(ltt, 1) /= na .or. size(ltt, 2) /= na) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_trailing_block: block of order ' // itoa(na) // &
                     ' with a ' // itoa(size(ltt, 1)) // ' x ' // itoa(size(ltt, 2)) // ' array, factor of order ' // &
                     itoa(chol%n))
      return
    end if
    if (na == 0) return
    code = shim_trailing(chol%handle, int(na, c_int), ltt)
    if (code /= SHIM_OK) call shim_error(st, code, -1, chol%n)
  end subroutine cholesky_trailing_block

  !> One triangular solve in the permuted numbering of the factor P A P^T = L L^T:
  !> x = L^{-1} b (transposed = .false.) or x = L^{-T} b (transposed = .true.).  The caller
  !> applies the permutation (`cholesky_permutation`).
  subroutine cholesky_solve_triangular(chol, transposed, b, x, st)
    type(cholesky_t), intent(in) :: chol    !! a successful factorisation
    logical, intent(in) :: transposed       !! solve with L^T instead of L
    real(dp), intent(in) :: b(:)            !! (n) right-hand side, permuted numbering
    real(dp), intent(out) :: x(:)           !! (n) solution, permuted numbering
    type(status_t), intent(out) :: st       !! DS_OK or an error
    integer(c_int) :: code
    if (.not. solve_args_ok(chol, size(b), size(x), 1, 1, st)) return
    code = shim_solve_tri(chol%handle, merge(1_c_int, 0_c_int, transposed), b, x)
    if (code /= SHIM_OK) call shim_error(st, code, -1, chol%n)
  end subroutine cholesky_solve_triangular

  ! ---------------------------------------------------------------- private helpers

  !> Check the arrays of `a` before handing them to C (the shim validates the indices).
  logical function pattern_ok(a, st) result(ok)
    type(csr_t), intent(in) :: a            !! the matrix
    type(status_t), intent(inout) :: st     !! error set when not ok
    ok = .false.
    if (a%n < 0 .or. .not. allocated(a%rowptr) .or. .not. allocated(a%col) .or. &
        .not. allocated(a%val)) then
      call set_error(st, DS_ERR_INPUT, 'cholesky: matrix not allocated')
      return
    end if
    if (size(a%rowptr) /= a%n + 1) then
      call set_error(st, DS_ERR_INPUT, 'cholesky: rowptr has ' // itoa(size(a%rowptr)) // &
                     ' entries, expected n + 1 = ' // itoa(a%n + 1))
      return
    end if
    if (a%rowptr(1) /= 1 .or. a%rowptr(a%n + 1) - 1 > min(size(a%col), size(a%val))) then
      call set_error(st, DS_ERR_INPUT, 'cholesky: rowptr inconsistent with col/val')
      return
    end if
    ok = .true.
  end function pattern_ok

  !> Check the shapes of a solve.
  logical function solve_args_ok(chol, nb, nx, nrhs_b, nrhs_x, st) result(ok)
    type(cholesky_t), intent(in) :: chol    !! the factor
    integer, intent(in) :: nb, nx           !! rows of b and x
    integer, intent(in) :: nrhs_b, nrhs_x   !! columns of b and x
    type(status_t), intent(inout) :: st     !! error set when not ok
    ok = .false.
    if (.not. c_associated(chol%handle)) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_solve: no factor (call cholesky_factor first)')
    else if (nb /= chol%n .or. nx /= chol%n .or. nrhs_b /= nrhs_x) then
      call set_error(st, DS_ERR_INPUT, 'cholesky_solve: b has ' // itoa(nb) // ' x ' // itoa(nrhs_b) // &
                     ', x has ' // itoa(nx) // ' x ' // itoa(nrhs_x) // ' entries, the factor has order ' // &
                     itoa(chol%n))
    else
      ok = .true.
    end if
  end function solve_args_ok

  !> Turn a shim status into a dualsig error.
  subroutine shim_error(st, code, minor, n)
    type(status_t), intent(inout) :: st     !! the error
    integer(c_int), intent(in) :: code      !! shim status /= 0
    integer, intent(in) :: minor            !! L->minor (0-based) or -1
    integer, intent(in) :: n                !! order of the matrix
    select case (code)
    case (SHIM_ERR_NOT_POSDEF)
      call set_error(st, DS_ERR_NUMERIC, 'cholesky: matrix not positive definite (pivot ' // &
                     itoa(minor + 1) // ' of ' // itoa(n) // ' in elimination order)')
    case (SHIM_ERR_INPUT)
      call set_error(st, DS_ERR_INPUT, 'cholesky: invalid matrix pattern or argument')
    case (SHIM_ERR_NOMEM)
      call set_error(st, DS_ERR_MEMORY, 'cholesky: out of memory in CHOLMOD (the ordering, factor or solve of ' // &
                     'a matrix of order ' // itoa(n) // '; expected fewer levels or more memory)')
    case (SHIM_ERR_TOO_LARGE)
      call set_error(st, DS_ERR_NUMERIC, 'cholesky: problem too large for 32-bit indices')
    case (SHIM_ERR_NOT_FACTORED)
      call set_error(st, DS_ERR_NUMERIC, 'cholesky_solve: the last factorisation failed')
    case default
      call set_error(st, DS_ERR_NUMERIC, 'cholesky: CHOLMOD failed (shim status ' // itoa(int(code)) // ')')
    end select
  end subroutine shim_error

  !> Name of a shim ordering code.
  pure function ordering_name(code) result(name)
    integer, intent(in) :: code             !! ordering code returned by the shim
    character(len=8) :: name
    select case (code)
    case (1)
      name = 'amd'
    case (2)
      name = 'metis'
    case (3)
      name = 'natural'
    case (4)
      name = 'nesdis'
    case (5)
      name = 'colamd'
    case (6)
      name = 'postord'
    case (7)
      name = 'given'
    case default
      name = 'unknown'
    end select
  end function ordering_name

  !> Cheap signature of the pattern (rowptr and col), to catch a refactorisation with a
  !> different pattern.  Arithmetic modulo two primes below 2^31: no overflow.
  pure integer(i8) function pattern_signature(a) result(sig)
    type(csr_t), intent(in) :: a            !! the matrix
    integer(i8), parameter :: p1 = 2147483647_i8, p2 = 2147483629_i8
    integer(i8) :: h1, h2
    integer :: k
    h1 = 1
    h2 = 7
    do k = 1, a%n + 1
      h1 = mod(h1 * 1000003_i8 + a%rowptr(k), p1)
    end do
    do k = 1, a%rowptr(a%n + 1) - 1
      h1 = mod(h1 * 1000003_i8 + a%col(k), p1)
      h2 = mod(h2 * 999983_i8 + a%col(k) * int(k, i8), p2)
    end do
    sig = h1 * 2147483648_i8 + h2
  end function pattern_signature
end module dualsig_sparse_direct
