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

  public :: tri_rule_t, tri_rule, gauss_legendre, tri_points_t, tri_points, tri_points_set, crossed_by_breaks

  !> Newton iteration for the Gauss-Legendre nodes stops when the update is below this.
  real(dp), parameter :: newton_tol = 4.0_dp * epsilon(1.0_dp)
  integer, parameter :: newton_max_iter = 100

  type :: tri_rule_t
    integer :: degree = 0                 !! total degree integrated exactly
    integer :: n = 0                      !! number of points
    real(dp), allocatable :: bary(:,:)    !! (3, n) barycentric coordinates of the points
    real(dp), allocatable :: w(:)         !! (n) weights, sum(w) = 1
  end type tri_rule_t

  !> Quadrature points of one triangle: physical points, absolute weights (summing to the
  !> area) and barycentric coordinates in that triangle.
  type :: tri_points_t
    integer :: n = 0
    real(dp), allocatable :: p(:,:)      !! (2, n)
    real(dp), allocatable :: w(:)        !! (n)
    real(dp), allocatable :: bary(:,:)   !! (3, n) with respect to the parent triangle
  end type tri_points_t

  !> Sub-triangles thinner than this fraction of the parent's area are dropped.
  real(dp), parameter :: sliver_rel_area = 1.0e-14_dp

contains

  !> The points of `rule` on the triangle xy(2,3), after cutting it along the vertical lines
  !> x = breaks(k) that cross it: the rule is applied on every piece (a piece of a triangle
  !> cut by a line is a triangle or a quadrilateral = two triangles), so an integrand that is
  !> smooth on each side of the lines (a source with a kink, and fields built from it) is
  !> integrated to the rule's accuracy instead of the accuracy of a kink.  Without breaks
  !> (absent or empty) the rule is applied on the triangle itself.
  pure function tri_points(xy, rule, breaks) result(tp)
    real(dp), intent(in) :: xy(2, 3)
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(in), optional :: breaks(:)
    type(tri_points_t) :: tp
    call tri_points_set(xy, rule, tp, breaks)
  end function tri_points

  !> Whether one of the lines x = breaks(k) passes through the interior of the triangle xy
  !> (tri_points_set cuts the rule there).
  pure logical function crossed_by_breaks(xy, breaks)
    real(dp), intent(in) :: xy(2, 3), breaks(:)
    crossed_by_breaks = any(minval(xy(1, :)) < breaks .and. breaks < maxval(xy(1, :)))
  end function crossed_by_breaks

  !> tri_points into tp, whose arrays are kept when large enough (a loop over the triangles
  !> allocates them once, not three times per triangle); a triangle that no break line
  !> crosses takes the rule directly, without pieces.
  pure subroutine tri_points_set(xy, rule, tp, breaks)
    real(dp), intent(in) :: xy(2, 3)
    type(tri_rule_t), intent(in) :: rule
    type(tri_points_t), intent(inout) :: tp
    real(dp), intent(in), optional :: breaks(:)
    real(dp), allocatable :: pieces(:,:,:), next(:,:,:)
    real(dp) :: area, det, pa, q(2)
    integer :: k, j, m, npiece, nnext, i, nbreak
    logical :: crossed
    area = abs(tri_area(xy))
    nbreak = 0
    crossed = .false.
    if (present(breaks)) nbreak = size(breaks)
    if (present(breaks)) crossed = crossed_by_breaks(xy, breaks)
    if (.not. crossed) then
      call points_of_rule(xy, area, rule, tp)
      return
    end if
    allocate (pieces(2, 3, 1))                        ! small: one triangle
    pieces(:, :, 1) = xy
    npiece = 1
    do k = 1, nbreak
      allocate (next(2, 3, 3 * npiece))               ! small: pieces of one triangle (< 3 per break line)
      nnext = 0
      do j = 1, npiece
        call cut_at_x(pieces(:, :, j), breaks(k), next, nnext)
      end do
      call move_alloc(next, pieces)
      npiece = nnext
    end do
    call reserve(tp, npiece * rule%n)
    det = (xy(1, 2) - xy(1, 1)) * (xy(2, 3) - xy(2, 1)) - (xy(1, 3) - xy(1, 1)) * (xy(2, 2) - xy(2, 1))
    m = 0
    do j = 1, npiece
      pa = abs(tri_area(pieces(:, :, j)))
      if (pa <= sliver_rel_area * area) cycle
      do i = 1, rule%n
        m = m + 1
        q = pieces(:, 1, j) * rule%bary(1, i) + pieces(:, 2, j) * rule%bary(2, i) + pieces(:, 3, j) * rule%bary(3, i)
        tp%p(:, m) = q
        tp%w(m) = pa * rule%w(i)
        q = q - xy(:, 1)
        tp%bary(2, m) = (q(1) * (xy(2, 3) - xy(2, 1)) - q(2) * (xy(1, 3) - xy(1, 1))) / det
        tp%bary(3, m) = (q(2) * (xy(1, 2) - xy(1, 1)) - q(1) * (xy(2, 2) - xy(2, 1))) / det
        tp%bary(1, m) = 1.0_dp - tp%bary(2, m) - tp%bary(3, m)
      end do
    end do
    tp%n = m
  end subroutine tri_points_set

  !> The rule on the uncut triangle xy (area `area`): its barycentric coordinates are the
  !> rule's own.
  pure subroutine points_of_rule(xy, area, rule, tp)
    real(dp), intent(in) :: xy(2, 3), area
    type(tri_rule_t), intent(in) :: rule
    type(tri_points_t), intent(inout) :: tp
    integer :: i
    call reserve(tp, rule%n)
    do i = 1, rule%n
      tp%p(1, i) = xy(1, 1) * rule%bary(1, i) + xy(1, 2) * rule%bary(2, i) + xy(1, 3) * rule%bary(3, i)
      tp%p(2, i) = xy(2, 1) * rule%bary(1, i) + xy(2, 2) * rule%bary(2, i) + xy(2, 3) * rule%bary(3, i)
      tp%w(i) = area * rule%w(i)
      tp%bary(:, i) = rule%bary(:, i)
    end do
    tp%n = rule%n
  end subroutine points_of_rule

  !> tp's arrays hold at least n points (kept when large enough).
  pure subroutine reserve(tp, n)
    type(tri_points_t), intent(inout) :: tp
    integer, intent(in) :: n
    if (allocated(tp%w)) then
      if (size(tp%w) >= n) return
      deallocate (tp%p, tp%w, tp%bary)
    end if
    allocate (tp%p(2, n), tp%w(n), tp%bary(3, n))     ! small: the points of one triangle
  end subroutine reserve

  !> Append to out(:,:,1:nout) the pieces of triangle t on either side of the line x = c.
  pure subroutine cut_at_x(t, c, out, nout)
    real(dp), intent(in) :: t(2, 3), c
    real(dp), intent(inout) :: out(:,:,:)
    integer, intent(inout) :: nout
    real(dp) :: a(2), b(2), d(2), p(2), q(2)
    integer :: lone, k, nleft
    logical :: left(3)
    left = t(1, :) < c
    nleft = count(left)
    if (nleft == 0 .or. nleft == 3) then
      nout = nout + 1
      out(:, :, nout) = t
      return
    end if
    ! the vertex alone on its side, and the other two in counter-clockwise order
    do k = 1, 3
      if (count(left .eqv. left(k)) == 1) lone = k
    end do
    a = t(:, lone)
    b = t(:, mod(lone, 3) + 1)
    d = t(:, mod(lone + 1, 3) + 1)
    p = a + (c - a(1)) / (b(1) - a(1)) * (b - a)
    q = a + (c - a(1)) / (d(1) - a(1)) * (d - a)
    out(:, :, nout + 1) = reshape([a, p, q], [2, 3])
    out(:, :, nout + 2) = reshape([p, b, d], [2, 3])
    out(:, :, nout + 3) = reshape([p, d, q], [2, 3])
    nout = nout + 3
  end subroutine cut_at_x

  pure real(dp) function tri_area(t)
    real(dp), intent(in) :: t(2, 3)
    tri_area = 0.5_dp * ((t(1, 2) - t(1, 1)) * (t(2, 3) - t(2, 1)) - (t(1, 3) - t(1, 1)) * (t(2, 2) - t(2, 1)))
  end function tri_area

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
    allocate (rule%bary(3, 7), rule%w(7))              ! small: fixed size
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
    allocate (rule%bary(3, m * m), rule%w(m * m))      ! small: m from the rule's degree
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
