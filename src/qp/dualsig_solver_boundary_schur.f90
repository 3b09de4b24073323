!> Bound-constrained QP whose bounds touch only a small set T of the unknowns (the
!> O(sqrt N) boundary unknowns of a Signorini problem):
!>
!>     minimise 1/2 x^T M x - b^T x   subject to   x_i >= bnd_i  for i in T  (kind BOUND_LOWER),
!>                                                 the other unknowns free   (kind BOUND_FREE)
!>
!> solved exactly with ONE sparse Cholesky factorisation, whatever the active set:
!> - factorise P M P^T = L L^T with a fill-reducing ordering in which the unknowns of T are
!>   eliminated last (CHOLMOD, dualsig_sparse_direct).  With the blocks of the permuted
!>   matrix (I = the free unknowns, T last), L = [L_II 0; L_TI L_TT], and the Schur
!>   complement of M onto T is  S = M_TT - M_TI M_II^{-1} M_IT = L_TT L_TT^T  (dense,
!>   |T| x |T|), read off the factor;
!> - forward solve z = L^{-1} P b.  Eliminating x_I = M_II^{-1} (b_I - M_IT x_T), the QP in
!>   x_T alone is  minimise 1/2 x_T^T S x_T - g^T x_T, x_T >= bnd_T, with
!>   g = b_T - M_TI M_II^{-1} b_I = L_TT z_T;
!> - the dense QP is solved exactly (dualsig_solver_dense_qp, block principal pivoting);
!> - back substitution with z_T replaced by L_TT^T x_T:  x = P^T L^{-T} [z_I; L_TT^T x_T]
!>   gives x_I = M_II^{-1} (b_I - M_IT x_T).
!> A solve costs one forward and one backward substitution (one plain solve) plus the
!> dense QP; the active set of the dense QP is kept as the next solve's first guess, so
!> a sequence of right-hand sides (augmented Lagrangian) reuses factor, S and active set.
!>
!> Fixed unknowns (kind BOUND_FIXED, x_i = bnd_i: the Dirichlet nodes of a primal problem)
!> are held by identity rows and columns (the reduced matrix M(F) of
!> dualsig_solver_active_set, formed once by boundary_schur_factor); each solve moves their
!> values to the right-hand side.  So the primal Signorini QP, whatever its start, is solved
!> with one factorisation (`boundary_schur_qp_solve`: factor, solve, free).
!>
!> First active set of the dense QP: the previous solve's; else, with
!> `guess_unconstrained`, the bounds violated by the unconstrained minimiser
!> S^{-1} g (two triangular solves with L_TT, the Cholesky factor of S), which makes the
!> number of pivoting steps independent of the start; else the bounded unknowns of the
!> start x at their bound.
module dualsig_solver_boundary_schur
  use dualsig_kinds, only: dp, i8
  use dualsig_sparse, only: csr_t
  use dualsig_sparse_direct, only: cholesky_t, cholesky_factor, cholesky_free, cholesky_order, &
                                   cholesky_permutation, cholesky_trailing_block, cholesky_solve_triangular, &
                                   ORDERING_AMD, ORDERING_GIVEN, ORDERING_GIVEN_EXACT, ORDERING_NATURAL
  use dualsig_sparse, only: csr_matvec
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER, BOUND_FIXED, kkt_residual
  use dualsig_solver_dense_qp, only: dense_qp_settings_t, dense_qp_result_t, dense_bound_qp
  use dualsig_status, only: status_t, set_error, set_alloc_error, is_ok, DS_ERR_INPUT, DS_ERR_NUMERIC
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: boundary_schur_t, boundary_schur_settings_t, boundary_schur_result_t, boundary_schur_factor, &
            boundary_schur_solve, boundary_schur_free, boundary_schur_qp_solve, boundary_schur_max_default

  !> Default largest number of bounded unknowns for the boundary Schur route (|T|^2 doubles
  !> twice: 268 MB at 4096; the dense QP's factorisations cost O(|T|^3) each).
  integer, parameter :: boundary_schur_max_default = 4096

  type :: boundary_schur_settings_t
    integer :: ordering = ORDERING_AMD       !! fill-reducing ordering (dualsig_sparse_direct); T is moved last
    integer, allocatable :: perm(:)          !! the elimination order when ordering = ORDERING_GIVEN
    type(dense_qp_settings_t) :: qp          !! the dense QP on T
    !> first active set without a previous one: the bounds violated by the unconstrained
    !> minimiser (.false.: the bounded unknowns of the start x at their bound)
    logical :: guess_unconstrained = .false.
  end type boundary_schur_settings_t

  type :: boundary_schur_result_t
    integer :: qp_iterations = 0             !! dense factorisations of the QP on T
    integer :: single_pivots = 0             !! of which by Murty's rule
    logical :: converged = .false.
    integer :: nactive = 0                   !! bounded unknowns at their bound
    real(dp) :: kkt_residual = 0.0_dp        !! relative KKT residual of the returned x
    integer :: factorisations = 0            !! boundary_schur_qp_solve: CHOLMOD factorisations (1)
    integer(i8) :: nnz_factor = 0            !! boundary_schur_qp_solve: nonzeros of the factor
    integer :: nbounded = 0                  !! |T|
  end type boundary_schur_result_t

  !> The factor of M with T last, the Schur complement onto T and the last active set.
  !> Free with boundary_schur_free.
  type :: boundary_schur_t
    type(cholesky_t) :: chol
    integer :: n = 0                         !! order of M
    integer :: nt = 0                        !! |T|
    integer, allocatable :: perm(:)          !! (n) final elimination order, T = perm(n-nt+1:n)
    real(dp), allocatable :: ltt(:,:)        !! (nt, nt) trailing block L_TT of the factor
    real(dp), allocatable :: s(:,:)          !! (nt, nt) S = L_TT L_TT^T, both triangles
    logical, allocatable :: active(:)        !! (nt) active set of the last solve
    logical :: have_active = .false.
    integer, allocatable :: kind(:)          !! (n) the kinds factorised
    logical :: has_fixed = .false.           !! some unknowns are BOUND_FIXED (identity rows)
  end type boundary_schur_t

contains

  !> Factorise m (with identity rows and columns for the fixed unknowns) with the bounded
  !> unknowns (kind = BOUND_LOWER) eliminated last and form their Schur complement.
  subroutine boundary_schur_factor(m, kind, settings, bs, st)
    type(csr_t), intent(in) :: m                    !! symmetric positive definite (on the unknowns not fixed)
    integer, intent(in) :: kind(:)                  !! (n) BOUND_FREE, BOUND_LOWER or BOUND_FIXED
    type(boundary_schur_settings_t), intent(in) :: settings
    type(boundary_schur_t), intent(inout) :: bs     !! the factorisation (freed first)
    type(status_t), intent(out) :: st
    integer, allocatable :: base(:), cperm(:)
    integer :: nt, i
    type(csr_t) :: mr

    call boundary_schur_free(bs)
    if (size(kind) /= m%n .or. any(kind /= BOUND_FREE .and. kind /= BOUND_LOWER .and. kind /= BOUND_FIXED)) then
      call set_error(st, DS_ERR_INPUT, 'boundary_schur_factor: kind must have ' // itoa(m%n) // &
                     ' entries, each BOUND_FREE, BOUND_LOWER or BOUND_FIXED')
      return
    end if
    if (settings%ordering == ORDERING_GIVEN) then
      if (.not. allocated(settings%perm)) then
        call set_error(st, DS_ERR_INPUT, 'boundary_schur_factor: ORDERING_GIVEN needs perm')
        return
      end if
      base = settings%perm
      if (size(base) /= m%n) then
        call set_error(st, DS_ERR_INPUT, 'boundary_schur_factor: perm has ' // itoa(size(base)) // &
                       ' entries, the matrix has order ' // itoa(m%n))
        return
      end if
    else if (settings%ordering == ORDERING_NATURAL) then
      ! no fill-reducing order: the unknowns as numbered (CHOLMOD computes none for natural)
      allocate (base(m%n), stat=i)
      if (i /= 0) then
        call set_alloc_error(st, 4_i8 * m%n, 'the natural ordering (boundary_schur_factor)')
        return
      end if
      base = [(i, i = 1, m%n)]
    else
      call cholesky_order(m, settings%ordering, base, st)
      if (.not. is_ok(st)) return
    end if
    ! the fill-reducing order of the free unknowns, then the bounded ones (in that order too)
    nt = count(kind == BOUND_LOWER)
    cperm = [pack(base, kind(base) /= BOUND_LOWER), pack(base, kind(base) == BOUND_LOWER)]
    bs%has_fixed = any(kind == BOUND_FIXED)
    ! exactly this order: a post-ordering would move T when S is not structurally dense
    if (bs%has_fixed) then
      call held_matrix(m, kind == BOUND_FIXED, mr)
      call cholesky_factor(mr, bs%chol, st, ORDERING_GIVEN_EXACT, cperm)
    else
      call cholesky_factor(m, bs%chol, st, ORDERING_GIVEN_EXACT, cperm)
    end if
    if (.not. is_ok(st)) return
    bs%kind = kind
    call cholesky_permutation(bs%chol, bs%perm, st)
    if (.not. is_ok(st)) return
    if (any(kind(bs%perm(m%n - nt + 1:m%n)) /= BOUND_LOWER)) then
      call set_error(st, DS_ERR_NUMERIC, 'boundary_schur_factor: CHOLMOD did not keep the bounded unknowns ' // &
                     'at the end of the elimination order')
      call boundary_schur_free(bs)
      return
    end if
    bs%n = m%n
    bs%nt = nt
    allocate (bs%ltt(nt, nt), bs%s(nt, nt), bs%active(nt), stat=i)
    if (alloc_failed(i, st, 'the boundary Schur complement', 2_i8 * nt * nt, BYTES_REAL)) return
    call cholesky_trailing_block(bs%chol, nt, bs%ltt, st)
    if (.not. is_ok(st)) return
    if (nt > 0) call lower_times_transpose(bs%ltt, bs%s, st)
    if (.not. is_ok(st)) return
    bs%have_active = .false.
  end subroutine boundary_schur_factor

  !> Solve the QP for the right-hand side b with the factorisation of `bs`.  x: in, the
  !> start (its bounded unknowns at their bound give the first active set unless a
  !> previous solve left one); out, the solution, exactly feasible.
  subroutine boundary_schur_solve(bs, m, b, bnd, x, settings, res, st)
    type(boundary_schur_t), intent(inout) :: bs     !! from boundary_schur_factor (same m)
    type(csr_t), intent(in) :: m                    !! the matrix (the fixed values' coupling, the KKT residual)
    real(dp), intent(in) :: b(:)                    !! (n) right-hand side
    real(dp), intent(in) :: bnd(:)                  !! (n) lower bounds of the bounded unknowns, values of the fixed
    real(dp), intent(inout) :: x(:)                 !! (n) start / solution
    type(boundary_schur_settings_t), intent(in) :: settings
    type(boundary_schur_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(dense_qp_result_t) :: qres
    real(dp), allocatable :: z(:), w(:), g(:), xt(:), lt(:)
    integer :: n, nt, t0, ist
    external :: dtrmv, dtrsv

    n = bs%n
    nt = bs%nt
    if (n == 0 .or. size(b) /= n .or. size(bnd) /= n .or. size(x) /= n .or. m%n /= n) then
      call set_error(st, DS_ERR_INPUT, 'boundary_schur_solve: no factorisation, or sizes differ from its ' // itoa(n))
      return
    end if
    t0 = n - nt
    allocate (z(n), w(n), stat=ist)
    if (alloc_failed(ist, st, 'the boundary Schur solve', 2 * n, BYTES_REAL)) return
    ! z = L^{-1} P b, the fixed values moved to the right-hand side: M(F) x = b - M x_F on
    ! the others, x_F = bnd_F
    if (bs%has_fixed) then
      z = merge(bnd, 0.0_dp, bs%kind == BOUND_FIXED)
      call csr_matvec(m, z, w)
      w = merge(bnd, b - w, bs%kind == BOUND_FIXED)
      w = w(bs%perm)
    else
      w = b(bs%perm)
    end if
    call cholesky_solve_triangular(bs%chol, .false., w, z, st)
    if (.not. is_ok(st)) return
    lt = bnd(bs%perm(t0 + 1:n))
    if (nt > 0) then
      ! g = L_TT z_T
      g = z(t0 + 1:n)
      call dtrmv('L', 'N', 'N', nt, bs%ltt, nt, g, 1)
      if (.not. bs%have_active) then
        if (settings%guess_unconstrained) then
          ! the unconstrained minimiser S^{-1} g = L_TT^{-T} z_T
          xt = z(t0 + 1:n)
          call dtrsv('L', 'T', 'N', nt, bs%ltt, nt, xt, 1)
          bs%active = xt < lt
          deallocate (xt)
        else
          bs%active = x(bs%perm(t0 + 1:n)) <= lt
        end if
      end if
      allocate (xt(nt), stat=ist)
      if (alloc_failed(ist, st, 'the boundary Schur solve', nt, BYTES_REAL)) return
      call dense_bound_qp(bs%s, g, lt, bs%active, xt, settings%qp, qres, st)
      if (.not. is_ok(st)) return
      bs%have_active = .true.
      res%qp_iterations = qres%iterations
      res%single_pivots = qres%single_pivots
      res%converged = qres%converged
      res%nactive = qres%nactive
      ! z_T = L_TT^T x_T, then x = P^T L^{-T} z
      z(t0 + 1:n) = xt
      call dtrmv('L', 'T', 'N', nt, bs%ltt, nt, z(t0 + 1:n), 1)
    else
      res%converged = .true.
    end if
    call cholesky_solve_triangular(bs%chol, .true., z, w, st)
    if (.not. is_ok(st)) return
    x(bs%perm) = w
    if (nt > 0) x(bs%perm(t0 + 1:n)) = xt          ! exactly the QP's feasible values
    if (bs%has_fixed) where (bs%kind == BOUND_FIXED) x = bnd
    res%nbounded = nt
    res%kkt_residual = kkt_residual(m, b, bs%kind, bnd, x, w)
  end subroutine boundary_schur_solve

  !> The bound-constrained QP of dualsig_qp_types (kinds BOUND_FREE, BOUND_LOWER,
  !> BOUND_FIXED) solved with one factorisation: boundary_schur_factor, one
  !> boundary_schur_solve, the factor freed.  x: in, the start (only its bounded unknowns
  !> at their bound matter, as the first active set, unless settings%guess_unconstrained);
  !> out, the minimiser, exactly feasible.
  subroutine boundary_schur_qp_solve(a, f, kind, bnd, x, settings, res, st)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    type(boundary_schur_settings_t), intent(in) :: settings
    type(boundary_schur_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(boundary_schur_t) :: bs
    call boundary_schur_factor(a, kind, settings, bs, st)
    if (.not. is_ok(st)) return
    call boundary_schur_solve(bs, a, f, bnd, x, settings, res, st)
    res%factorisations = 1
    res%nnz_factor = bs%chol%nnz_factor
    call boundary_schur_free(bs)
  end subroutine boundary_schur_qp_solve

  !> s = l l^T (both triangles) for a lower triangular l, in nt^3/3 flops (dsyrk would
  !> take nt^3): with J the reversal, u = J l J is upper triangular and l l^T = J (u u^T) J,
  !> formed in place by LAPACK's dlauum.
  subroutine lower_times_transpose(l, s, st)
    real(dp), intent(in) :: l(:,:)
    real(dp), intent(out) :: s(:,:)
    type(status_t), intent(inout) :: st
    integer :: nt, i, info
    external :: dlauum
    nt = size(l, 1)
    s = l(nt:1:-1, nt:1:-1)
    call dlauum('U', nt, s, nt, info)
    if (info /= 0) then
      call set_error(st, DS_ERR_NUMERIC, 'boundary_schur_factor: dlauum failed (info = ' // itoa(info) // ')')
      return
    end if
    do i = 1, nt
      s(i + 1:nt, i) = s(i, i + 1:nt)
    end do
    s = s(nt:1:-1, nt:1:-1)
  end subroutine lower_times_transpose

  !> mr = M(held): the matrix m with identity rows and columns for the held unknowns.
  subroutine held_matrix(m, held, mr)
    type(csr_t), intent(in) :: m
    logical, intent(in) :: held(:)
    type(csr_t), intent(out) :: mr
    integer :: i, p
    mr = m
    do i = 1, m%n
      do p = m%rowptr(i), m%rowptr(i + 1) - 1
        if (held(i) .or. held(m%col(p))) mr%val(p) = 0.0_dp
      end do
      if (held(i)) mr%val(m%diag(i)) = 1.0_dp
    end do
  end subroutine held_matrix

  !> Release the factor and the dense blocks.
  subroutine boundary_schur_free(bs)
    type(boundary_schur_t), intent(inout) :: bs
    call cholesky_free(bs%chol)
    if (allocated(bs%perm)) deallocate (bs%perm)
    if (allocated(bs%ltt)) deallocate (bs%ltt, bs%s, bs%active)
    if (allocated(bs%kind)) deallocate (bs%kind)
    bs%has_fixed = .false.
    bs%n = 0
    bs%nt = 0
    bs%have_active = .false.
  end subroutine boundary_schur_free
end module dualsig_solver_boundary_schur
