!> Dense bound-constrained QP
!>
!>     minimise 1/2 v^T S v - g^T v   subject to   v >= l   (every component bounded)
!>
!> with S symmetric positive definite (e.g. the Schur complement of a sparse matrix onto
!> its O(sqrt N) boundary unknowns, dualsig_solver_boundary_schur), solved exactly: the
!> LCP  lam = S v - g >= 0,  v >= l,  lam^T (v - l) = 0  by block principal pivoting
!> (the primal-dual active-set method) with Judice and Pires' safeguard.  Each iteration
!> holds the active set A at its bounds, solves S_II v_I = g_I - S_IA l_A by a dense
!> Cholesky factorisation (LAPACK dpotrf/dpotrs) and exchanges every infeasible index:
!> v_j < l_j in I, lam_j < 0 in A.  When the number of infeasible indices has not
!> decreased for `max_stall` iterations, only the infeasible index with the largest
!> number is exchanged (Murty's rule) until the count drops below its best value again:
!> Murty's rule terminates for every P-matrix, S SPD in particular, so the method cannot
!> cycle.
!>
!> Feasibility tolerances (rounding, not accuracy, tolerances): v_j counts as below its
!> bound when v_j < l_j - tol * max_k(|v_k|, |l_k|), lam_j as negative when
!> lam_j < -tol * (|g_j| + sum_k |S_jk v_k|) (the size of the terms that cancel in lam_j).
!> The returned v is clipped to the bounds (a change of at most the tolerance).
module dualsig_solver_dense_qp
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t, set_error, set_warning, DS_ERR_INPUT, DS_ERR_LAPACK, DS_WARN_NOT_CONVERGED
  use dualsig_strings, only: itoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: dense_qp_settings_t, dense_qp_result_t, dense_bound_qp

  type :: dense_qp_settings_t
    integer :: max_iter = 500            !! pivoting iterations
    integer :: max_stall = 3             !! block exchanges without progress before Murty's rule
    real(dp) :: tol = 1.0e-12_dp         !! relative feasibility tolerance (rounding level)
  end type dense_qp_settings_t

  type :: dense_qp_result_t
    integer :: iterations = 0            !! dense factorisations of S_II
    integer :: single_pivots = 0         !! iterations done by Murty's rule
    logical :: converged = .false.       !! no infeasible index left
    integer :: nactive = 0               !! components at their bound
  end type dense_qp_result_t

contains

  !> Solve the QP from the active-set guess `active` (updated to the final set).
  subroutine dense_bound_qp(s, g, l, active, v, settings, res, st)
    real(dp), intent(in) :: s(:,:)          !! (m, m) symmetric positive definite, both triangles stored
    real(dp), intent(in) :: g(:)            !! (m) linear term
    real(dp), intent(in) :: l(:)            !! (m) lower bounds
    logical, intent(inout) :: active(:)     !! (m) in: first guess of {v = l}; out: the final set
    real(dp), intent(out) :: v(:)           !! (m) the minimiser
    type(dense_qp_settings_t), intent(in) :: settings
    type(dense_qp_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    real(dp), allocatable :: lam(:), terms(:), sii(:,:), rhs(:)
    integer, allocatable :: inact(:)
    logical, allocatable :: flip(:)
    integer :: m, it, ni, ninf, best, stall, info, j, jmax, ist
    real(dp) :: vscale
    external :: dpotrf, dpotrs

    m = size(g)
    if (size(s, 1) /= m .or. size(s, 2) /= m .or. size(l) /= m .or. size(active) /= m .or. size(v) /= m) then
      call set_error(st, DS_ERR_INPUT, 'dense_bound_qp: inconsistent sizes (m = ' // itoa(m) // ')')
      return
    end if
    allocate (lam(m), terms(m), flip(m), rhs(m), inact(m), stat=ist)
    if (alloc_failed(ist, st, 'the dense bound-constrained QP', 5 * m, BYTES_REAL)) return
    best = m + 1
    stall = 0
    do it = 1, settings%max_iter
      res%iterations = it
      ! v_A = l_A, S_II v_I = g_I - S_IA l_A
      ni = 0
      do j = 1, m
        if (.not. active(j)) then
          ni = ni + 1
          inact(ni) = j
        end if
      end do
      v = merge(l, 0.0_dp, active)
      if (ni > 0) then
        sii = s(inact(1:ni), inact(1:ni))
        lam = matmul(s, v)                ! v vanishes on I: S_IA l_A in rows I
        rhs(1:ni) = g(inact(1:ni)) - lam(inact(1:ni))
        call dpotrf('L', ni, sii, ni, info)
        if (info /= 0) then
          call set_error(st, DS_ERR_LAPACK, 'dense_bound_qp: dpotrf failed (info = ' // itoa(info) // &
                         '): the matrix is not positive definite')
          return
        end if
        call dpotrs('L', ni, 1, sii, ni, rhs, m, info)
        if (info /= 0) then
          call set_error(st, DS_ERR_LAPACK, 'dense_bound_qp: dpotrs failed (info = ' // itoa(info) // ')')
          return
        end if
        v(inact(1:ni)) = rhs(1:ni)
      end if
      lam = matmul(s, v) - g
      terms = abs(g) + matmul(abs(s), abs(v))
      vscale = max(maxval(abs(v)), maxval(abs(l)))
      flip = (.not. active .and. v < l - settings%tol * vscale) .or. &
             (active .and. lam < -settings%tol * terms)
      ninf = count(flip)
      if (ninf == 0) then
        res%converged = .true.
        exit
      end if
      if (ninf < best) then
        best = ninf
        stall = 0
      else
        stall = stall + 1
      end if
      if (stall >= settings%max_stall) then
        ! Murty's rule: exchange only the infeasible index with the largest number
        jmax = findloc(flip, .true., dim=1, back=.true.)
        flip = .false.
        flip(jmax) = .true.
        res%single_pivots = res%single_pivots + 1
      end if
      active = active .neqv. flip
    end do
    v = max(v, l)
    res%nactive = count(active)
    if (.not. res%converged) call set_warning(st, DS_WARN_NOT_CONVERGED, 'dense_bound_qp: ' // itoa(ninf) // &
      ' infeasible indices after ' // itoa(settings%max_iter) // ' iterations')
  end subroutine dense_bound_qp
end module dualsig_solver_dense_qp
