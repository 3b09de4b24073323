!> Projected SOR ("Gauss-Seidel with constraints", Section 2 of the paper) for the
!> bound-constrained quadratic programme
!>
!>     minimise 1/2 x^T A x - F^T x   subject to   x_i free        (kind(i) = BOUND_FREE)
!>                                                 x_i >= bnd(i)   (kind(i) = BOUND_LOWER)
!>                                                 x_i  = bnd(i)   (kind(i) = BOUND_FIXED)
!>
!> with A symmetric positive definite in CSR form.  One sweep updates, for i = 1..n,
!>     x_i <- P_i( x_i + omega (F_i - (A x)_i) / A_ii ),
!> where P_i is the projection on the admissible interval; omega = 1 is the paper's
!> algorithm (the printed projection for P2 applies to Gamma_a: see the reading notes).
!>
!> Stopping test: the relative KKT residual (`kkt_residual`) <= tol.
module dualsig_solver_psor
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: csr_t, csr_matvec
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER, BOUND_FIXED, kkt_residual, kkt_scale
  use dualsig_status, only: status_t, set_error, set_warning, DS_ERR_INPUT, DS_ERR_NUMERIC, &
                            DS_WARN_NOT_CONVERGED
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  ! BOUND_* and kkt_residual live in dualsig_qp_types; re-exported for existing callers
  public :: BOUND_FREE, BOUND_LOWER, BOUND_FIXED
  public :: psor_settings_t, psor_result_t
  public :: psor_solve, kkt_residual, psor_plan_t, psor_plan, psor_sweep

  !> Sweeps over which the residual must fall by at least stall_rel_decrease (relative);
  !> otherwise the iteration makes no progress (a singular system) and stops with an error.
  !> Gauss-Seidel on a mesh of h = 1/1024 still gains several per cent over this window.
  integer, parameter :: stall_window = 5000
  real(dp), parameter :: stall_rel_decrease = 1.0e-3_dp

  type :: psor_settings_t
    real(dp) :: omega = 1.0_dp        !! relaxation parameter in (0, 2)
    real(dp) :: tol = 1.0e-10_dp      !! tolerance on the relative KKT residual
    integer :: max_iter = 100000      !! maximum number of sweeps
    integer :: check_every = 10       !! sweeps between two residual evaluations
  end type psor_settings_t

  type :: psor_result_t
    integer :: iterations = 0         !! sweeps performed
    real(dp) :: kkt_residual = 0.0_dp !! relative KKT residual of the returned x
    logical :: converged = .false.    !! kkt_residual <= tol
  end type psor_result_t

  !> A sweep prepared once per solve: the unknowns it updates (not fixed, ascending), the
  !> factors omega / A_ii, and the lower bounds (-huge for free unknowns), so that the
  !> sweep is branch-free and without divisions.
  type :: psor_plan_t
    integer, allocatable :: rows(:)
    real(dp), allocatable :: winv(:)
    real(dp), allocatable :: lower(:)
  end type psor_plan_t

contains

  !> Prepare the sweep for the bounds (kind, bnd) and the relaxation omega.
  pure subroutine psor_plan(a, kind, bnd, omega, plan)
    type(csr_t), intent(in) :: a
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(in) :: omega
    type(psor_plan_t), intent(out) :: plan
    integer :: i
    plan%rows = pack([(i, i=1, a%n)], kind /= BOUND_FIXED)
    plan%winv = omega / a%val(a%diag)
    plan%lower = merge(bnd, -huge(1.0_dp), kind == BOUND_LOWER)
  end subroutine psor_plan

  !> One projected SOR sweep with a prepared plan: x_i <- max(x_i + omega (F_i - (A x)_i) / A_ii, lower_i)
  !> for the unknowns that are not fixed, in increasing order (the update of the module header).
  pure subroutine psor_sweep(a, f, plan, x)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    type(psor_plan_t), intent(in) :: plan
    real(dp), intent(inout) :: x(:)
    integer :: j, i, p
    real(dp) :: r
    do j = 1, size(plan%rows)
      i = plan%rows(j)
      r = f(i)
      do p = a%rowptr(i), a%rowptr(i + 1) - 1
        r = r - a%val(p) * x(a%col(p))
      end do
      x(i) = max(x(i) + plan%winv(i) * r, plan%lower(i))
    end do
  end subroutine psor_sweep

  !> Projected SOR from the start x (projected on the constraints first).  On return
  !> x is the last iterate; `res` reports sweeps, the final residual and convergence.
  !> st: DS_WARN_NOT_CONVERGED when max_iter is reached, DS_ERR_INPUT for bad settings,
  !> DS_ERR_NUMERIC when the iterate becomes non-finite.
  subroutine psor_solve(a, f, kind, bnd, x, settings, res, st)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: f(:)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    type(psor_settings_t), intent(in) :: settings
    type(psor_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    real(dp), allocatable :: work(:)
    type(psor_plan_t) :: plan
    character(len=200) :: buf
    integer :: it, window_it, ist
    real(dp) :: window_res, den

    if (.not. (settings%omega > 0.0_dp .and. settings%omega < 2.0_dp)) then
      write (buf, '(a,es10.3)') 'psor: omega must lie in (0, 2), got ', settings%omega
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    if (settings%max_iter < 0 .or. settings%check_every < 1 .or. .not. settings%tol >= 0.0_dp) then
      call set_error(st, DS_ERR_INPUT, 'psor: need max_iter >= 0, check_every >= 1, tol >= 0')
      return
    end if
    if (any(a%val(a%diag) <= 0.0_dp)) then
      call set_error(st, DS_ERR_INPUT, 'psor: the matrix has a non-positive diagonal entry')
      return
    end if
    allocate (work(a%n), stat=ist)
    if (alloc_failed(ist, st, 'the projected SOR work vector', a%n, BYTES_REAL)) return
    where (kind == BOUND_FIXED) x = bnd
    where (kind == BOUND_LOWER) x = max(x, bnd)
    den = kkt_scale(a, f, kind, bnd)                   ! once: the data do not change
    res%kkt_residual = kkt_residual(a, f, kind, bnd, x, work, den)
    res%converged = res%kkt_residual <= settings%tol
    it = 0
    call psor_plan(a, kind, bnd, settings%omega, plan)
    window_it = 0
    window_res = res%kkt_residual
    do while (.not. res%converged .and. it < settings%max_iter)
      call psor_sweep(a, f, plan, x)
      it = it + 1
      if (mod(it, settings%check_every) == 0 .or. it == settings%max_iter) then
        res%kkt_residual = kkt_residual(a, f, kind, bnd, x, work, den)
        if (.not. (res%kkt_residual <= huge(1.0_dp))) then
          call set_error(st, DS_ERR_NUMERIC, 'psor: the iterate is no longer finite')
          res%iterations = it
          return
        end if
        res%converged = res%kkt_residual <= settings%tol
        if (.not. res%converged .and. it - window_it >= stall_window) then
          if (res%kkt_residual > (1.0_dp - stall_rel_decrease) * window_res) then
            write (buf, '(a,es9.2,a,es9.2,a,i0,a)') 'psor: no progress: the KKT residual stayed at ', &
              res%kkt_residual, ' (', window_res, ' ', it - window_it, ' sweeps earlier)'
            call set_error(st, DS_ERR_NUMERIC, trim(buf) // ': a singular or nearly singular system, e.g. a ' // &
              'part of the domain without Gamma_u (u = 0) in problem P2, or a P1 domain so small that the ' // &
              'u term of -Lap u + u is below the rounding of the Laplacian (expected every part of a P2 ' // &
              'domain held by Gamma_u, and a P1 problem scaled to a domain of moderate size)')
            res%iterations = it
            return
          end if
          window_it = it
          window_res = res%kkt_residual
        end if
      end if
    end do
    res%iterations = it
    if (.not. res%converged) then
      write (buf, '(a,i0,a,es9.2,a,es9.2)') 'psor: not converged after ', it, &
        ' sweeps: KKT residual ', res%kkt_residual, ' > tol ', settings%tol
      call set_warning(st, DS_WARN_NOT_CONVERGED, trim(buf))
    end if
  end subroutine psor_solve
end module dualsig_solver_psor
