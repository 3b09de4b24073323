!> Quadrature rules on triangles, exact for polynomials of a stated total degree.
!>
!> A rule is given in barycentric coordinates `bary(3, n)` with weights `w(n)` that sum
!> to 1: the integral of g over a triangle T is area(T) * sum_k w(k) g(x_k).
!> - degree 5: Radon's 7-point rule (all weights positive, points inside);
!> - any degree p: the collapsed (Duffy) product of Gauss-Legendre rules, exact for total
!>   degree p with m = ceil((p+2)/2) points per direction (m^2 points), used for the
!>   high-order integrals of exact solutions.
module dualsig_quadrature
  use dualsig_kinds, only: dp, pi
  implicit none
  private

  public :: tri_rule_t, tri_rule, gauss_legendre

  !> Newton iteration for the Gauss-Legendre nodes stops when the update is below this.
  real(dp), parameter :: newton_tol = 4.0_dp * epsilon(1.0_dp)
  integer, parameter :: newton_max_iter = 100

  type :: tri_rule_t
    integer :: degree = 0                 !! total degree integrated exactly
    integer :: n = 0                      !! number of points
    real(dp), allocatable :: bary(:,:)    !! (3, n) barycentric coordinates of the points
    real(dp), allocatable :: w(:)         !! (n) weights, sum(w) = 1
  end type tri_rule_t

contains

  !> A rule exact for every polynomial of total degree <= `degree` (degree >= 0).
  function tri_rule(degree) result(rule)
    integer, intent(in) :: degree
    type(tri_rule_t) :: rule
    if (degree <= 5) then
      rule = radon7()
    else
      rule = collapsed_gauss((degree + 3) / 2)
    end if
  end function tri_rule

  !> Radon's 7-point rule, exact for degree 5.
  function radon7() result(rule)
    type(tri_rule_t) :: rule
    real(dp) :: s15, a1, a2, w1, w2
    s15 = sqrt(15.0_dp)
    a1 = (6.0_dp - s15) / 21.0_dp
    a2 = (6.0_dp + s15) / 21.0_dp
    w1 = (155.0_dp - s15) / 1200.0_dp
    w2 = (155.0_dp + s15) / 1200.0_dp
    rule%degree = 5
    rule%n = 7
    allocate (rule%bary(3, 7), rule%w(7))
    rule%bary(:, 1) = [1.0_dp, 1.0_dp, 1.0_dp] / 3.0_dp
    rule%w(1) = 9.0_dp / 40.0_dp
    rule%bary(:, 2) = [a1, a1, 1.0_dp - 2.0_dp * a1]
    rule%bary(:, 3) = [a1, 1.0_dp - 2.0_dp * a1, a1]
    rule%bary(:, 4) = [1.0_dp - 2.0_dp * a1, a1, a1]
    rule%w(2:4) = w1
    rule%bary(:, 5) = [a2, a2, 1.0_dp - 2.0_dp * a2]
    rule%bary(:, 6) = [a2, 1.0_dp - 2.0_dp * a2, a2]
    rule%bary(:, 7) = [1.0_dp - 2.0_dp * a2, a2, a2]
    rule%w(5:7) = w2
  end function radon7

  !> Collapsed Gauss rule with m points per direction, exact for total degree 2m - 2.
  !> The unit square (s, t) maps to the reference triangle by xi = s, eta = t (1 - s),
  !> Jacobian (1 - s); reference vertices (0,0), (1,0), (0,1) have barycentrics 1, 2, 3.
  function collapsed_gauss(m) result(rule)
    integer, intent(in) :: m
    type(tri_rule_t) :: rule
    real(dp) :: s(m), ws(m)
    integer :: i, j, k
    real(dp) :: xi, eta
    call gauss_legendre(m, s, ws)       ! on [-1, 1]
    s = 0.5_dp * (s + 1.0_dp)
    ws = 0.5_dp * ws
    rule%degree = 2 * m - 2
    rule%n = m * m
    allocate (rule%bary(3, m * m), rule%w(m * m))
    k = 0
    do i = 1, m
      do j = 1, m
        k = k + 1
        xi = s(i)
        eta = s(j) * (1.0_dp - s(i))
        rule%bary(:, k) = [1.0_dp - xi - eta, xi, eta]
        rule%w(k) = 2.0_dp * ws(i) * ws(j) * (1.0_dp - s(i))   ! reference area is 1/2
      end do
    end do
  end function collapsed_gauss

  !> Gauss-Legendre nodes x(m) and weights w(m) on [-1, 1] by Newton's method on P_m.
  pure subroutine gauss_legendre(m, x, w)
    integer, intent(in) :: m
    real(dp), intent(out) :: x(m), w(m)
    integer :: i, it
    real(dp) :: z, p1, dp_dz, dz
    do i = 1, (m + 1) / 2
      z = cos(pi * (real(i, dp) - 0.25_dp) / (real(m, dp) + 0.5_dp))
      do it = 1, newton_max_iter
        call legendre(m, z, p1, dp_dz)
        dz = p1 / dp_dz
        z = z - dz
        if (abs(dz) <= newton_tol) exit
      end do
      call legendre(m, z, p1, dp_dz)      ! derivative at the converged node, for the weight
      x(i) = -z
      x(m + 1 - i) = z
      w(i) = 2.0_dp / ((1.0_dp - z * z) * dp_dz * dp_dz)
      w(m + 1 - i) = w(i)
    end do
    if (mod(m, 2) == 1) x((m + 1) / 2) = 0.0_dp
  end subroutine gauss_legendre

  !> The Legendre polynomial P_m(z) and its derivative, by the three-term recurrence
  !> (|z| < 1).
  pure subroutine legendre(m, z, pm, dpm)
    integer, intent(in) :: m
    real(dp), intent(in) :: z
    real(dp), intent(out) :: pm, dpm
    real(dp) :: p0, p2
    integer :: k
    p0 = 1.0_dp
    pm = z
    do k = 2, m
      p2 = ((2 * k - 1) * z * pm - (k - 1) * p0) / k
      p0 = pm
      pm = p2
    end do
    dpm = m * (z * pm - p0) / (z * z - 1.0_dp)
  end subroutine legendre
end module dualsig_quadrature
