!> Augmented Lagrangian (method of multipliers) for
!>
!>     minimise 1/2 x^T A x - b^T x   subject to   D x = 0,  x_i >= bnd_i (kind BOUND_LOWER)
!>
!> with A symmetric positive semi-definite on ker D and positive definite on the whole
!> space.  Lagrangian L_r = 1/2 x^T A x - b^T x - mu^T D x + r/2 ||D x||^2; each outer step
!> minimises L_r over the bounds with the matrix A + r D^T D (same pattern as A when every
!> row of D couples unknowns that A couples), warm-started from the previous x, then
!> updates mu <- mu - r D x.  A large r makes the number of outer steps small and
!> independent of h.
!>
!> Inner solvers (both factorise A + r D^T D and keep the factor over the outer steps):
!> - 'schur' (default while the bounded unknowns are at most max_schur): the bounded
!>   unknowns are eliminated last, their dense Schur complement is read off the factor and
!>   each outer step solves the QP exactly on it (dualsig_solver_boundary_schur): one
!>   factorisation in all, one forward and one backward substitution per outer step,
!>   whatever the active set does;
!> - 'active_set': the primal-dual active-set method on the whole matrix, changes of the
!>   active set bordered on the kept factor (refactorised when they grow).
!>
!> Stopping test: ||D x||_2 <= tol * || |D| |x| ||_2 (the divergence defect relative to
!> the size of the terms that cancel in it).
module dualsig_solver_augmented
  use dualsig_kinds, only: dp, i8
  use dualsig_sparse, only: csr_t, rect_t, rect_matvec, rect_matvec_t, csr_add_block
  use dualsig_solver_active_set, only: active_set_settings_t, active_set_result_t, active_set_solve, &
                                       active_set_workspace_t, active_set_workspace_free
  use dualsig_sparse_direct, only: ORDERING_AMD
  use dualsig_qp_types, only: BOUND_LOWER
  use dualsig_solver_boundary_schur, only: boundary_schur_t, boundary_schur_settings_t, boundary_schur_result_t, &
                                           boundary_schur_factor, boundary_schur_solve, boundary_schur_free
  use dualsig_status, only: status_t, set_warning, set_error, is_ok, DS_WARN_NOT_CONVERGED, DS_ERR_INPUT
  use dualsig_strings, only: itoa, rtoa
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: augmented_settings_t, augmented_result_t, augmented_solve

  type :: augmented_settings_t
    real(dp) :: r = 0.0_dp                !! penalty; 0 = automatic (r_auto_factor * scale)
    real(dp) :: tol = 1.0e-13_dp          !! relative defect of D x = 0
    integer :: max_outer = 50
    integer :: max_active = 100           !! active-set changes per outer step
    integer :: ordering = ORDERING_AMD
    integer, allocatable :: perm(:)       !! the elimination order when ordering = ORDERING_GIVEN
    character(len=16) :: inner = 'schur'  !! 'schur' or 'active_set' (see the module header)
    integer :: max_schur = 4096           !! 'schur' only up to this many bounded unknowns (dense |T|^2)
  end type augmented_settings_t

  type :: augmented_result_t
    integer :: outer = 0                  !! multiplier updates + 1
    integer :: factorisations = 0         !! CHOLMOD (re)factorisations in all outer steps
    real(dp) :: defect = 0.0_dp           !! final relative ||D x||
    logical :: converged = .false.
    real(dp) :: r = 0.0_dp                !! penalty used
    integer(i8) :: nnz_factor = 0
    character(len=8) :: ordering = ''
    integer :: nactive = 0
    real(dp) :: kkt_residual = 0.0_dp     !! of the last inner solve
    character(len=16) :: inner = ''       !! inner solver used
    integer :: inner_iterations = 0       !! active-set iterations, or dense pivoting iterations ('schur')
  end type augmented_result_t

  !> Automatic penalty: r = r_auto_factor * mean(diag A) / mean(diag D^T D).
  real(dp), parameter :: r_auto_factor = 1.0e8_dp

contains

  subroutine augmented_solve(a, b, dmat, kind, bnd, x, settings, res, st)
    type(csr_t), intent(in) :: a
    real(dp), intent(in) :: b(:)
    type(rect_t), intent(in) :: dmat
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:)
    real(dp), intent(inout) :: x(:)
    type(augmented_settings_t), intent(in) :: settings
    type(augmented_result_t), intent(out) :: res
    type(status_t), intent(out) :: st
    type(csr_t) :: ar
    type(active_set_settings_t) :: aset
    type(active_set_result_t) :: ares
    type(active_set_workspace_t) :: ws
    type(boundary_schur_t) :: bs
    type(boundary_schur_settings_t) :: bset
    type(boundary_schur_result_t) :: bres
    logical :: use_schur
    real(dp), allocatable :: mu(:), w(:), rhs(:), dtd_diag(:), absx(:), scale_w(:)
    integer :: i, p, q, outer, ist
    logical :: inner_ok
    integer, allocatable :: cols(:)
    real(dp), allocatable :: blk(:,:), vals(:)

    if (settings%r < 0.0_dp .or. .not. settings%tol > 0.0_dp .or. settings%max_outer < 1) then
      call set_error(st, DS_ERR_INPUT, 'augmented Lagrangian: need r >= 0, tol > 0, max_outer >= 1')
      return
    end if
    if (trim(settings%inner) /= 'schur' .and. trim(settings%inner) /= 'active_set') then
      call set_error(st, DS_ERR_INPUT, 'augmented Lagrangian: inner solver "' // trim(settings%inner) // &
                     '"; expected schur or active_set')
      return
    end if
    use_schur = trim(settings%inner) == 'schur' .and. count(kind == BOUND_LOWER) <= settings%max_schur
    ! penalty scale from the diagonals of A and D^T D
    allocate (dtd_diag(a%n), stat=ist)
    if (alloc_failed(ist, st, 'the augmented Lagrangian scaling', a%n, BYTES_REAL)) return
    dtd_diag = 0.0_dp
    do i = 1, dmat%m
      do p = dmat%rowptr(i), dmat%rowptr(i + 1) - 1
        dtd_diag(dmat%col(p)) = dtd_diag(dmat%col(p)) + dmat%val(p)**2
      end do
    end do
    res%r = settings%r
    if (res%r == 0.0_dp) res%r = r_auto_factor * sum(a%val(a%diag)) / max(sum(dtd_diag), tiny(1.0_dp))
    ! A + r D^T D, row by row of D (each row's unknowns are coupled in A)
    ar = a
    do i = 1, dmat%m
      cols = dmat%col(dmat%rowptr(i):dmat%rowptr(i + 1) - 1)
      vals = dmat%val(dmat%rowptr(i):dmat%rowptr(i + 1) - 1)
      if (allocated(blk)) deallocate (blk)
      allocate (blk(size(cols), size(cols)))   ! small: one row of D (the unknowns of one element)
      do q = 1, size(cols)
        blk(:, q) = res%r * vals * vals(q)
      end do
      call csr_add_block(ar, cols, blk)
    end do

    allocate (mu(dmat%m), w(dmat%m), rhs(a%n), absx(a%n), scale_w(dmat%m), stat=ist)
    if (alloc_failed(ist, st, 'the augmented Lagrangian vectors', 3 * dmat%m + 2 * a%n, BYTES_REAL)) return
    mu = 0.0_dp
    aset%max_iter = settings%max_active
    ! projected SOR on A + r D^T D (condition ~ r) would not converge in any useful time
    aset%fallback = .false.
    inner_ok = .true.
    aset%ordering = settings%ordering
    if (allocated(settings%perm)) aset%perm = settings%perm
    if (use_schur) then
      res%inner = 'schur'
      bset%ordering = settings%ordering
      if (allocated(settings%perm)) bset%perm = settings%perm
      call boundary_schur_factor(ar, kind, bset, bs, st)
      if (.not. is_ok(st)) return
      res%factorisations = 1
      res%nnz_factor = bs%chol%nnz_factor
      res%ordering = bs%chol%ordering
    else
      res%inner = 'active_set'
    end if
    do outer = 1, settings%max_outer
      call rect_matvec_t(dmat, mu, rhs)
      rhs = rhs + b
      if (use_schur) then
        call boundary_schur_solve(bs, ar, rhs, bnd, x, bset, bres, st)
        if (.not. is_ok(st)) then
          call boundary_schur_free(bs)
          return
        end if
        res%inner_iterations = res%inner_iterations + bres%qp_iterations
        res%nactive = bres%nactive
        res%kkt_residual = bres%kkt_residual
        inner_ok = inner_ok .and. bres%converged
      else
        call active_set_solve(ar, rhs, kind, bnd, x, aset, ares, st, ws)
        if (.not. is_ok(st)) then
          call active_set_workspace_free(ws)
          return
        end if
        res%factorisations = res%factorisations + ares%factorisations
        res%inner_iterations = res%inner_iterations + ares%iterations
        res%nnz_factor = ares%nnz_factor
        res%ordering = ares%ordering
        res%nactive = ares%nactive
        res%kkt_residual = ares%kkt_residual
        inner_ok = inner_ok .and. ares%converged
      end if
      res%outer = outer
      call rect_matvec(dmat, x, w)
      absx = abs(x)
      call abs_matvec(dmat, absx, scale_w)
      res%defect = norm2(w) / max(norm2(scale_w), tiny(1.0_dp))
      if (res%defect <= settings%tol) then
        res%converged = inner_ok          ! a non-converged inner solve is not hidden by a small defect
        exit
      end if
      mu = mu - res%r * w
    end do
    call active_set_workspace_free(ws)
    call boundary_schur_free(bs)
    if (.not. inner_ok) then
      call set_warning(st, DS_WARN_NOT_CONVERGED, 'augmented Lagrangian: an inner active-set solve did not ' // &
        'converge (cycle or limit); relative defect ' // rtoa(res%defect) // ' after ' // itoa(res%outer) // ' outer steps')
    else if (.not. res%converged) then
      call set_warning(st, DS_WARN_NOT_CONVERGED, 'augmented Lagrangian: defect ' // &
        rtoa(res%defect) // ' > tol after ' // itoa(res%outer) // ' outer steps')
    end if
  end subroutine augmented_solve

  !> y = |D| x (entrywise absolute values of D).
  pure subroutine abs_matvec(dmat, x, y)
    type(rect_t), intent(in) :: dmat
    real(dp), intent(in) :: x(:)
    real(dp), intent(out) :: y(:)
    integer :: i, p
    do i = 1, dmat%m
      y(i) = 0.0_dp
      do p = dmat%rowptr(i), dmat%rowptr(i + 1) - 1
        y(i) = y(i) + abs(dmat%val(p)) * x(dmat%col(p))
      end do
    end do
  end subroutine abs_matvec
end module dualsig_solver_augmented
