!> Spectral estimates of sparse symmetric matrices by the Lanczos process.
!>
!> Used to choose relaxation parameters: the extreme eigenvalues of the Jacobi-scaled
!> matrix D^{-1/2} A D^{-1/2} restricted to the unknowns that are not fixed give the
!> Jacobi spectral radius and, by Young's formula, an SOR parameter.
module dualsig_spectral
  use dualsig_kinds, only: dp
  use dualsig_sparse, only: csr_t
  use dualsig_status, only: status_t, set_error, DS_ERR_LAPACK, DS_ERR_NUMERIC
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: jacobi_scaled_extremes, sor_omega_from_jacobi

  !> Ritz values are recomputed every this many Lanczos steps.
  integer, parameter :: ritz_check_every = 5

contains

  !> Extreme eigenvalues lmin <= lmax of D^{-1/2} A D^{-1/2} on the rows with active(i).
  !> Lanczos without reorthogonalisation (extreme Ritz values are reliable); stops when
  !> lmin changes by less than rel_tol (relative) between checks, or after max_steps.
  subroutine jacobi_scaled_extremes(a, active, max_steps, rel_tol, lmin, lmax, steps, st)
    type(csr_t), intent(in) :: a
    logical, intent(in) :: active(:)
    integer, intent(in) :: max_steps
    real(dp), intent(in) :: rel_tol
    real(dp), intent(out) :: lmin, lmax
    integer, intent(out) :: steps
    type(status_t), intent(out) :: st
    real(dp), allocatable :: v(:), v_old(:), w(:), dinv_sqrt(:), alpha(:), beta(:), d(:), e(:)
    real(dp) :: b, lmin_old, s
    integer :: i, p, k, info, n, nact, ist
    n = a%n
    nact = count(active)
    lmin = 1.0_dp
    lmax = 1.0_dp
    steps = 0
    if (nact == 0) return
    allocate (v(n), v_old(n), w(n), dinv_sqrt(n), alpha(max_steps), beta(max_steps), stat=ist)
    if (alloc_failed(ist, st, 'the Lanczos vectors', 4 * n + 2 * max_steps, BYTES_REAL)) return
    do i = 1, n
      if (a%val(a%diag(i)) <= 0.0_dp) then
        call set_error(st, DS_ERR_NUMERIC, 'spectral estimate: non-positive diagonal entry')
        return
      end if
      dinv_sqrt(i) = 1.0_dp / sqrt(a%val(a%diag(i)))
    end do
    ! deterministic start vector with components of varying sign and size
    do i = 1, n
      v(i) = merge(1.0_dp + 0.5_dp * sin(1.618033988749895_dp * i), 0.0_dp, active(i))
    end do
    v = v / norm2(v)
    v_old = 0.0_dp
    b = 0.0_dp
    lmin_old = huge(1.0_dp)
    do k = 1, min(max_steps, nact)
      ! w = S A S v on the active set, S = D^{-1/2}
      do i = 1, n
        if (.not. active(i)) then
          w(i) = 0.0_dp
          cycle
        end if
        s = 0.0_dp
        do p = a%rowptr(i), a%rowptr(i + 1) - 1
          if (active(a%col(p))) s = s + a%val(p) * dinv_sqrt(a%col(p)) * v(a%col(p))
        end do
        w(i) = dinv_sqrt(i) * s
      end do
      w = w - b * v_old
      alpha(k) = dot_product(w, v)
      w = w - alpha(k) * v
      b = norm2(w)
      beta(k) = b
      steps = k
      if (mod(k, ritz_check_every) == 0 .or. k == min(max_steps, nact) .or. b <= epsilon(1.0_dp)) then
        d = alpha(1:k)
        e = beta(1:max(k - 1, 1))
        call dsterf(k, d, e, info)
        if (info /= 0) then
          call set_error(st, DS_ERR_LAPACK, 'spectral estimate: LAPACK dsterf failed')
          return
        end if
        lmin = d(1)
        lmax = d(k)
        if (abs(lmin - lmin_old) <= rel_tol * abs(lmin)) exit
        lmin_old = lmin
      end if
      if (b <= epsilon(1.0_dp)) exit      ! invariant subspace found: Ritz values exact
      v_old = v
      v = w / b
    end do
  end subroutine jacobi_scaled_extremes

  !> Young's optimal SOR parameter 2 / (1 + sqrt(1 - rho^2)) for the Jacobi spectral
  !> radius rho = max(1 - lmin, lmax - 1); 1 when the estimate gives rho >= 1.
  pure real(dp) function sor_omega_from_jacobi(lmin, lmax) result(omega)
    real(dp), intent(in) :: lmin, lmax
    real(dp) :: rho
    rho = max(1.0_dp - lmin, lmax - 1.0_dp)
    if (rho >= 1.0_dp .or. rho <= 0.0_dp) then
      omega = 1.0_dp
    else
      omega = 2.0_dp / (1.0_dp + sqrt(1.0_dp - rho * rho))
    end if
  end function sor_omega_from_jacobi
end module dualsig_spectral
