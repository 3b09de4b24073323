!> Primal-dual active-set method (semismooth Newton) with a sparse Cholesky factorisation
!> for the bound-constrained QP
!>
!>     minimise 1/2 x^T A x - F^T x  subject to  x_i free / x_i >= bnd_i / x_i = bnd_i
!>
!> (the same kinds as dualsig_solver_psor).  With g = A x - F, a bounded unknown is
!> predicted active when g_i - A_ii (x_i - bnd_i) > 0; the active and the fixed unknowns
!> are set to their bound and the others solve the reduced system.  The reduced system
!> keeps the full pattern (rows and columns of active unknowns become identity rows), so
!> the symbolic analysis is done once and every later iteration only refactorises.
!> The iteration stops when the active set repeats (then the KKT conditions hold up to the
!> accuracy of the solve).  A cycle or the iteration limit is reported as not converged;
!> in every case the returned x is projected on the bounds, so it is always feasible.
module dualsig_solver_active_set
  use dualsig_kinds, only: dp, i8
  use dualsig_sparse, only: csr_t, csr_matvec
  use dualsig_sparse_direct, only: cholesky_t, cholesky_factor, cholesky_refactor, cholesky_solve, &
                                   cholesky_free, ORDERING_BEST
  use dualsig_solver_psor, only: BOUND_LOWER, BOUND_FIXED, kkt_residual
  use dualsig_status, only: status_t, set_warning, DS_WARN_NOT_CONVERGED
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: active_set_settings_t, active_set_result_t, active_set_solve, active_set_workspace_t, &
            active_set_workspace_free

  type :: active_set_settings_t
    integer :: max_iter = 100            !! maximum number of active-set changes
    integer :: ordering = ORDERING_BEST  !! fill-reducing ordering (dualsig_sparse_direct)
  end type active_set_settings_t

  type :: active_set_result_t
    integer :: iterations = 0            !! active sets tried (solves)
    integer :: factorisations = 0        !! (re)factorisations (0 when a kept factor fitted)
    real(dp) :: kkt_residual = 0.0_dp    !! relative KKT residual of the returned x
    logical :: converged = .false.       !! the active set was reproduced
    integer :: nactive = 0               !! bounded unknowns at their bound
    integer(i8) :: nnz_factor = 0    !! nonzeros of the Cholesky factor
    character(len=8) :: ordering = ''    !! ordering used by CHOLMOD
  end type active_set_result_t

  !> State kept between calls for the SAME matrix (e.g. the outer steps of an augmented
  !> Lagrangian, where only the right-hand side changes): the factor of the reduced matrix
  !> and the active set it belongs to.  When the first predicted active set equals the kept
  !> one, the call starts with a solve instead of a factorisation.  Free with
  !> active_set_workspace_free.
  type :: active_set_workspace_t
    logical :: have_factor = .false.
    type(cholesky_t) :: chol
    type(csr_t) :: ar                          !! the reduced matrix of `fixed`
    logical, allocatable :: fixed(:)
  end type active_set_workspace_t

contains

  !> Release the factor kept in a workspace.
  subroutine active_set_workspace_free(ws)
    type(active_set_workspace_t), intent(inout) :: ws
    call cholesky_free(ws%chol)
    ws%have_factor = .false.
  end subroutine active_set_workspace_free

  !> Solve from the start x (which predicts the first active set); x returns the solution.
  !> With `ws` the factorisation is kept for the next call with the same matrix a.
  subroutine active_set_solve(a, f, kind, bnd, x, settings, res, st, ws)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    type(active_set_settings_t), intent(in) :: settings
    type(active_set_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(active_set_workspace_t), intent(inout), optional, target :: ws
    type(active_set_workspace_t), target :: local
    type(active_set_workspace_t), pointer :: w
    logical, allocatable :: fixed(:), fixed_new(:)
    real(dp), allocatable :: g(:), rhs(:), xb(:)
    integer :: i, p, it
    logical :: reuse

    if (present(ws)) then
      w => ws
    else
      w => local
    end if
    allocate (fixed(a%n), fixed_new(a%n), g(a%n), rhs(a%n), xb(a%n))
    call predict_fixed(fixed)
    if (.not. w%have_factor) w%ar = a
    do it = 1, settings%max_iter
      ! reduced system: identity rows/columns for fixed unknowns, bound values moved right
      xb = 0.0_dp
      where (fixed) xb = bnd
      call csr_matvec(a, xb, rhs)
      rhs = f - rhs
      where (fixed) rhs = bnd
      reuse = w%have_factor
      if (reuse) reuse = all(w%fixed .eqv. fixed)
      if (.not. reuse) then
        do i = 1, a%n
          do p = a%rowptr(i), a%rowptr(i + 1) - 1
            if (fixed(i) .or. fixed(a%col(p))) then
              w%ar%val(p) = 0.0_dp
            else
              w%ar%val(p) = a%val(p)
            end if
          end do
          if (fixed(i)) w%ar%val(a%diag(i)) = 1.0_dp
        end do
        if (.not. w%have_factor) then
          call cholesky_factor(w%ar, w%chol, st, settings%ordering)
        else
          call cholesky_refactor(w%ar, w%chol, st)
        end if
        if (st%code /= 0) exit
        w%have_factor = .true.
        w%fixed = fixed
        res%factorisations = res%factorisations + 1
      end if
      res%nnz_factor = w%chol%nnz_factor
      res%ordering = w%chol%ordering
      call cholesky_solve(w%chol, rhs, x, st)
      if (st%code /= 0) exit
      res%iterations = it
      call predict_fixed(fixed_new)
      if (all(fixed_new .eqv. fixed)) then
        res%converged = .true.
        exit
      end if
      fixed = fixed_new
    end do
    if (.not. present(ws)) call active_set_workspace_free(local)
    if (st%code /= 0) return
    where (kind == BOUND_LOWER) x = max(x, bnd)
    where (kind == BOUND_FIXED) x = bnd
    res%nactive = count(fixed .and. kind == BOUND_LOWER)
    res%kkt_residual = kkt_residual(a, f, kind, bnd, x, g)
    if (.not. res%converged) call set_warning(st, DS_WARN_NOT_CONVERGED, &
      'active set: no stable active set after ' // itoa(res%iterations) // ' iterations')

  contains

    !> The unknowns held at their bound by the next step: fixed ones, and bounded ones with
    !> g_i - A_ii (x_i - bnd_i) > 0 for the current x (g = A x - F is left in g).
    subroutine predict_fixed(at_bound)
      logical, intent(out) :: at_bound(:)
      integer :: j
      call csr_matvec(a, x, g)
      g = g - f
      at_bound = kind == BOUND_FIXED
      do j = 1, a%n
        if (kind(j) == BOUND_LOWER) at_bound(j) = g(j) - a%val(a%diag(j)) * (x(j) - bnd(j)) > 0.0_dp
      end do
    end subroutine predict_fixed
  end subroutine active_set_solve
end module dualsig_solver_active_set
