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

  public :: active_set_settings_t, active_set_result_t, active_set_solve

  type :: active_set_settings_t
    integer :: max_iter = 100            !! maximum number of active-set changes
    integer :: ordering = ORDERING_BEST  !! fill-reducing ordering (dualsig_sparse_direct)
  end type active_set_settings_t

  type :: active_set_result_t
    integer :: iterations = 0            !! factorisations = active sets tried
    real(dp) :: kkt_residual = 0.0_dp    !! relative KKT residual of the returned x
    logical :: converged = .false.       !! the active set was reproduced
    integer :: nactive = 0               !! bounded unknowns at their bound
    integer(i8) :: nnz_factor = 0    !! nonzeros of the Cholesky factor
    character(len=8) :: ordering = ''    !! ordering used by CHOLMOD
  end type active_set_result_t

contains

  !> Solve from the start x (which predicts the first active set); x returns the solution.
  subroutine active_set_solve(a, f, kind, bnd, x, settings, res, st)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    type(active_set_settings_t), intent(in) :: settings
    type(active_set_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(csr_t) :: ar
    type(cholesky_t) :: chol
    logical, allocatable :: fixed(:), fixed_new(:)
    real(dp), allocatable :: g(:), rhs(:), xb(:)
    integer :: i, p, it

    allocate (fixed(a%n), fixed_new(a%n), g(a%n), rhs(a%n), xb(a%n))
    call predict_fixed(fixed)
    ar = a
    do it = 1, settings%max_iter
      ! reduced system: identity rows/columns for fixed unknowns, bound values moved right
      xb = 0.0_dp
      where (fixed) xb = bnd
      call csr_matvec(a, xb, rhs)
      rhs = f - rhs
      do i = 1, a%n
        do p = a%rowptr(i), a%rowptr(i + 1) - 1
          if (fixed(i) .or. fixed(a%col(p))) then
            ar%val(p) = 0.0_dp
          else
            ar%val(p) = a%val(p)
          end if
        end do
        if (fixed(i)) then
          ar%val(a%diag(i)) = 1.0_dp
          rhs(i) = bnd(i)
        end if
      end do
      if (it == 1) then
        call cholesky_factor(ar, chol, st, settings%ordering)
        res%nnz_factor = chol%nnz_factor
        res%ordering = chol%ordering
      else
        call cholesky_refactor(ar, chol, st)
      end if
      if (st%code /= 0) exit
      call cholesky_solve(chol, rhs, x, st)
      if (st%code /= 0) exit
      res%iterations = it
      call predict_fixed(fixed_new)
      if (all(fixed_new .eqv. fixed)) then
        res%converged = .true.
        exit
      end if
      fixed = fixed_new
    end do
    call cholesky_free(chol)
    if (st%code /= 0) return
    where (kind == BOUND_LOWER) x = max(x, bnd)
    where (kind == BOUND_FIXED) x = bnd
    res%nactive = count(fixed .and. kind == BOUND_LOWER)
    res%kkt_residual = kkt_residual(a, f, kind, bnd, x, g)
    if (.not. res%converged) call set_warning(st, DS_WARN_NOT_CONVERGED, &
      'active set: no stable active set after ' // itoa(res%iterations) // ' factorisations')

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
