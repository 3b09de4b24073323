!> Uzawa's algorithm for  min 1/2 y^T A y - b^T y  subject to  B_eq y = e_eq (free
!> multipliers) and B_in y >= e_in (multipliers >= 0), with A symmetric positive definite
!> and factorised once (Section 3; for Section 4 derived from the Lagrangian
!> 1/2 y^T A y - b^T y - z^T (B y - e), see the reading notes):
!>
!>     A y^m = b + B^T z^m,      z^{m+1} = z^m - rho (B y^m - e),
!>     then z_k <- max(0, z_k) on the inequality rows.
!>
!> Every iteration costs one solve with the stored factorisation of A (a sparse CHOLMOD
!> factor, or element-local LAPACK factors for a block-diagonal A: dualsig_spd_solver).
!> rho: given, or automatic = rho_auto_factor / lambda_max(B A^{-1} B^T), lambda_max from
!> the power iteration (one solve per step).  Convergence needs 0 < rho < 2 / lambda_max.
!> A diverging iteration (residual grows by divergence_factor) is detected: with an
!> automatic rho it is retried with rho halved, otherwise it is reported.
!>
!> Stopping test: the natural residual of the multiplier problem,
!>     r_k = min(z_k, rho (B y - e)_k) on inequality rows, rho (B y - e)_k on equality rows,
!> relative to ||b|| (zero exactly at the KKT point; in the units of b).
module dualsig_solver_uzawa
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: rect_t, rect_matvec, rect_matvec_t
  use dualsig_spd_solver, only: spd_solver_t
  use dualsig_qp_types, only: ROW_EQUALITY, ROW_INEQUALITY
  use dualsig_status, only: status_t, set_error, set_warning, DS_ERR_INPUT, DS_ERR_NUMERIC, &
                            DS_WARN_NOT_CONVERGED
  use dualsig_strings, only: itoa, rtoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  ! ROW_* live in dualsig_qp_types; re-exported for existing callers
  public :: ROW_EQUALITY, ROW_INEQUALITY, uzawa_settings_t, uzawa_result_t, uzawa_solve, &
            uzawa_lambda_max


  real(dp), parameter :: rho_auto_factor = 1.5_dp    !! rho = factor / lambda_max (< 2 for convergence)
  real(dp), parameter :: divergence_factor = 1.0e4_dp
  integer, parameter :: max_retries = 6
  integer, parameter :: power_max_iter = 100
  real(dp), parameter :: power_rel_tol = 1.0e-4_dp

  type :: uzawa_settings_t
    real(dp) :: rho = 0.0_dp          !! step; 0 = automatic
    real(dp) :: tol = 1.0e-10_dp      !! tolerance on the relative residual
    integer :: max_iter = 20000
  end type uzawa_settings_t

  type :: uzawa_result_t
    integer :: iterations = 0
    real(dp) :: residual = 0.0_dp
    logical :: converged = .false.
    real(dp) :: rho = 0.0_dp          !! the step used
    real(dp) :: lambda_max = 0.0_dp   !! estimate of lambda_max(B A^-1 B^T) (0 if rho given)
    integer :: power_iterations = 0
    integer :: retries = 0            !! automatic rho halvings after divergence
  end type uzawa_result_t

contains

  !> Run Uzawa from the multipliers z (intent inout: start and result); y returns the
  !> minimiser for the final multipliers.
  subroutine uzawa_solve(solver, b, bmat, row_kind, e, y, z, settings, res, st)
    class(spd_solver_t), intent(in) :: solver
    real(dp), intent(in) :: b(:)
    type(rect_t), intent(in) :: bmat
    integer, intent(in) :: row_kind(:)
    real(dp), intent(in) :: e(:)
    real(dp), intent(out) :: y(:)
    real(dp), intent(inout) :: z(:)
    type(uzawa_settings_t), intent(in) :: settings
    type(uzawa_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    real(dp), allocatable :: rhs(:), w(:), z0(:)
    real(dp) :: bnorm, r0, rho
    logical :: automatic, diverged
    integer :: it, ist

    if (settings%rho < 0.0_dp .or. settings%max_iter < 1 .or. .not. settings%tol > 0.0_dp) then
      call set_error(st, DS_ERR_INPUT, 'uzawa: need rho >= 0 (0 = automatic), max_iter >= 1, tol > 0')
      return
    end if
    allocate (rhs(size(b)), w(bmat%m), stat=ist)
    if (alloc_failed(ist, st, 'the Uzawa iteration vectors', size(b) + bmat%m, BYTES_REAL)) return
    z0 = z
    bnorm = norm2(b)
    if (bnorm == 0.0_dp) bnorm = 1.0_dp
    automatic = settings%rho == 0.0_dp
    if (automatic) then
      call uzawa_lambda_max(solver, bmat, res%lambda_max, res%power_iterations, st)
      if (st%code /= 0) return
      if (res%lambda_max <= 0.0_dp) then
        call set_error(st, DS_ERR_NUMERIC, 'uzawa: B A^-1 B^T has no positive eigenvalue (no constraints?)')
        return
      end if
      rho = rho_auto_factor / res%lambda_max
    else
      rho = settings%rho
    end if

    do
      z = z0
      where (row_kind == ROW_INEQUALITY) z = max(z, 0.0_dp)
      diverged = .false.
      call solve_for_y()
      if (st%code /= 0) return
      r0 = residual()
      res%residual = r0
      it = 0
      do while (.not. converged(settings%tol) .and. it < settings%max_iter)
        z = z - rho * w
        where (row_kind == ROW_INEQUALITY) z = max(z, 0.0_dp)
        call solve_for_y()
        if (st%code /= 0) return
        it = it + 1
        res%residual = residual()
        if (.not. res%residual <= divergence_factor * max(r0, settings%tol)) then
          diverged = .true.
          exit
        end if
      end do
      res%iterations = res%iterations + it
      if (.not. diverged) exit
      if (.not. automatic .or. res%retries >= max_retries) then
        call set_error(st, DS_ERR_NUMERIC, 'uzawa: the iteration diverges with rho = ' // rtoa(rho) // &
          ' (residual grew by more than ' // rtoa(divergence_factor) // '); choose a smaller rho' // &
          ' or rho = 0 (automatic)')
        res%rho = rho
        return
      end if
      res%retries = res%retries + 1
      rho = 0.5_dp * rho
    end do
    res%rho = rho
    res%converged = converged(settings%tol)
    if (.not. res%converged) call set_warning(st, DS_WARN_NOT_CONVERGED, 'uzawa: not converged after ' // &
      itoa(res%iterations) // ' iterations: residual ' // rtoa(res%residual) // ' (tol ' // rtoa(settings%tol) // &
      '), relative to the size of the constraints ' // rtoa(residual_of_constraints()) // ' (at most tol)')

  contains

    !> y = A^{-1} (b + B^T z) and w = B y - e.
    subroutine solve_for_y()
      call rect_matvec_t(bmat, z, rhs)
      rhs = rhs + b
      call solver%solve(rhs, y, st)
      if (st%code /= 0) return
      call rect_matvec(bmat, y, w)
      w = w - e
    end subroutine solve_for_y

    !> Relative natural residual of the multiplier problem.
    real(dp) function residual()
      residual = norm2(natural_residual()) / bnorm
    end function residual

    !> The natural residual min(z, rho w) (rho w on equality rows).
    function natural_residual() result(r)
      real(dp) :: r(size(z))
      r = rho * w
      where (row_kind == ROW_INEQUALITY) r = min(z, r)
    end function natural_residual

    !> The natural residual relative to the size of the constraint rows themselves,
    !> ||rho B y|| + ||z|| (relative to ||b|| when that size is 0).
    real(dp) function residual_of_constraints() result(rc)
      real(dp) :: d
      d = norm2(rho * (w + e)) + norm2(z)
      if (.not. d > 0.0_dp) d = bnorm
      rc = norm2(natural_residual()) / d
    end function residual_of_constraints

    !> Converged: the natural residual at most tol relative to ||b|| (the paper's test) and
    !> relative to the size of the constraint rows.  With the first alone a load
    !> that dominates b hid the constraints: P1 on a domain of side 0.01 (f ~ 1e5) stopped at
    !> the unconstrained start on every level, its bound 1e4 times the error and growing.
    logical function converged(tol)
      real(dp), intent(in) :: tol
      converged = res%residual <= tol
      if (converged) converged = residual_of_constraints() <= tol
    end function converged
  end subroutine uzawa_solve

  !> lambda_max of B A^{-1} B^T by the power iteration (Rayleigh quotients; stops when the
  !> estimate changes by less than power_rel_tol, at most power_max_iter solves).
  subroutine uzawa_lambda_max(solver, bmat, lambda, iterations, st)
    class(spd_solver_t), intent(in) :: solver
    type(rect_t), intent(in) :: bmat
    real(dp), intent(out) :: lambda
    integer, intent(out) :: iterations
    type(status_t), intent(out) :: st
    real(dp), allocatable :: v(:), w(:), x(:), rhs(:)
    real(dp) :: lambda_old
    integer :: k, ist
    allocate (v(bmat%m), w(bmat%m), x(bmat%n), rhs(bmat%n), stat=ist)
    if (alloc_failed(ist, st, 'the power iteration vectors', 2 * (bmat%m + bmat%n), BYTES_REAL)) return
    lambda = 0.0_dp
    iterations = 0
    if (bmat%m == 0) return
    do k = 1, bmat%m
      v(k) = 1.0_dp + 0.5_dp * sin(1.618033988749895_dp * k)
    end do
    v = v / norm2(v)
    lambda_old = 0.0_dp
    do k = 1, power_max_iter
      call rect_matvec_t(bmat, v, rhs)
      call solver%solve(rhs, x, st)
      if (st%code /= 0) return
      call rect_matvec(bmat, x, w)
      lambda = dot_product(v, w)
      iterations = k
      if (norm2(w) == 0.0_dp) return
      v = w / norm2(w)
      if (abs(lambda - lambda_old) <= power_rel_tol * abs(lambda)) exit
      lambda_old = lambda
    end do
  end subroutine uzawa_lambda_max
end module dualsig_solver_uzawa
