!> Raviart-Thomas elements of order 1 (RT1) on a triangle: an H(div)-conforming space for
!> the dual problem of P1 (the set U_0 of (3.1) with q in H(div) instead of [V_h]^2).
!>
!> RT1(T) = [P1(T)]^2 + x P~1(T) (P~1: homogeneous linear), dimension 8; div RT1(T) = P1(T)
!> and the normal trace on every side is linear.  Vertices a_1 a_2 a_3 counter-clockwise,
!> local side k = a_k a_{k+1} (the mesh's local edges), opposite vertex a_{k+2}.
!>
!> Local basis (8 functions), lambda_i the barycentric coordinates:
!> - sides: phi_k = |S_k| / (2 |T|) (x - a_{k+2}) is the RT0 function with outward normal flux
!>   1 on S_k and 0 on the other sides ((x - a_{k+2}) is tangent to both sides through
!>   a_{k+2}).  The two functions of side k are
!>       psi_{2k-1} = lambda_k phi_k,   psi_{2k} = lambda_{k+1} phi_k:
!>   their outward normal flux on S_k is the hat function of a_k resp. a_{k+1} and zero on
!>   the other sides.  So the coefficient of psi_{2k-1} (psi_{2k}) is the value of the
!>   linear outward normal trace q.nu at the end a_k (a_{k+1}) of S_k: the side degrees of
!>   freedom are end-point values of the normal trace (equivalent to the two normal moments
!>   against P1 of the usual definition; same space);
!> - interior: psi_{6+m} = lambda_m (x - a_m) / h_T, m = 1, 2 (zero normal trace on every
!>   side; lambda_3 (x - a_3) is their dependent combination: sum_m lambda_m (x - a_m) = 0).
!>
!> Divergences: div psi_{2k-1} = grad lambda_k . phi_k + lambda_k |S_k| / |T| (div phi_k =
!> |S_k| / |T|), and div psi_{6+m} = (3 lambda_m - 1) / h_T (grad lambda_m . (x - a_m) =
!> lambda_m - 1).  Both are linear, so div q is evaluated from its vertex values.
!>
!> Element matrices of the dual functional (3.1'): ae = Gram matrix of ||q||^2 + ||div q||^2
!> (integrands of degree 4, integrated exactly by Radon's degree-5 rule) and
!> be_i = -(f, div psi_i) (from the caller's values of f at the rule's points).  The two
!> interior unknowns are eliminated element by element (static condensation, exact: they
!> are free).
module dualsig_elements_rt1
  use dualsig_kinds, only: dp
  use dualsig_quadrature, only: tri_rule_t
  use dualsig_elements_p1, only: p1_gradients
  implicit none
  private

  public :: rt1_geometry_t, rt1_geometry, rt1_values, rt1_element, rt1_condense, rt1_matrix_degree
  public :: rt1_nbasis, rt1_nside

  integer, parameter :: rt1_nbasis = 8    !! basis functions per triangle
  integer, parameter :: rt1_nside = 6     !! of them side functions (2 per side)
  !> Total degree of the integrands of the element matrix (products of quadratics).
  integer, parameter :: rt1_matrix_degree = 4

  !> What the basis needs of one triangle.
  type :: rt1_geometry_t
    real(dp) :: xy(2, 3) = 0.0_dp       !! vertices, counter-clockwise
    real(dp) :: grad(2, 3) = 0.0_dp     !! gradients of the barycentric coordinates
    real(dp) :: area = 0.0_dp           !! |T| > 0
    real(dp) :: side(3) = 0.0_dp        !! |S_k|, S_k = a_k a_{k+1}
    real(dp) :: h = 0.0_dp              !! longest side (scale of the interior functions)
  end type rt1_geometry_t

contains

  !> The geometry of the triangle xy (counter-clockwise).
  pure function rt1_geometry(xy) result(g)
    real(dp), intent(in) :: xy(2, 3)
    type(rt1_geometry_t) :: g
    real(dp) :: d(2)
    integer :: k
    g%xy = xy
    call p1_gradients(xy, g%grad, g%area)
    do k = 1, 3
      d = xy(:, mod(k, 3) + 1) - xy(:, k)
      g%side(k) = sqrt(d(1)**2 + d(2)**2)
    end do
    g%h = maxval(g%side)
  end function rt1_geometry

  !> Values psi(:, i) and divergences dpsi(i) of the 8 basis functions at the point with
  !> barycentric coordinates bary.
  pure subroutine rt1_values(g, bary, psi, dpsi)
    type(rt1_geometry_t), intent(in) :: g
    real(dp), intent(in) :: bary(3)
    real(dp), intent(out) :: psi(2, rt1_nbasis), dpsi(rt1_nbasis)
    real(dp) :: x(2), phi(2), c
    integer :: k, k1, o, m
    x = matmul(g%xy, bary)
    do k = 1, 3
      k1 = mod(k, 3) + 1
      o = mod(k + 1, 3) + 1
      c = g%side(k) / (2.0_dp * g%area)
      phi = c * (x - g%xy(:, o))
      psi(:, 2 * k - 1) = bary(k) * phi
      psi(:, 2 * k) = bary(k1) * phi
      dpsi(2 * k - 1) = dot_product(g%grad(:, k), phi) + bary(k) * 2.0_dp * c
      dpsi(2 * k) = dot_product(g%grad(:, k1), phi) + bary(k1) * 2.0_dp * c
    end do
    do m = 1, 2
      psi(:, 6 + m) = bary(m) * (x - g%xy(:, m)) / g%h
      dpsi(6 + m) = (3.0_dp * bary(m) - 1.0_dp) / g%h
    end do
  end subroutine rt1_values

  !> Element matrix ae (Gram matrix of ||q||^2 + ||div q||^2) and vector
  !> be_i = -(f, div psi_i) with the values fq of f at the points of `rule` (exact when f is
  !> linear on the triangle, e.g. Pi_1 f, and rule%degree >= 2) of the functional (3.1').
  !> exact_rule must have degree >= rt1_matrix_degree (e.g. tri_rule(rt1_matrix_degree)):
  !> then ae is exact.  When `rule` itself has that degree, ae is integrated with it (one
  !> evaluation of the basis per point, the same exact values).
  pure subroutine rt1_element(g, fq, rule, exact_rule, ae, be)
    type(rt1_geometry_t), intent(in) :: g
    real(dp), intent(in) :: fq(:)
    type(tri_rule_t), intent(in) :: rule, exact_rule
    real(dp), intent(out) :: ae(rt1_nbasis, rt1_nbasis), be(rt1_nbasis)
    real(dp) :: psi(2, rt1_nbasis), dpsi(rt1_nbasis), w
    integer :: q
    logical :: shared
    shared = rule%degree >= rt1_matrix_degree
    ae = 0.0_dp
    be = 0.0_dp
    do q = 1, rule%n
      call rt1_values(g, rule%bary(:, q), psi, dpsi)
      w = g%area * rule%w(q)
      be = be - w * fq(q) * dpsi
      if (shared) call add_gram(w, psi, dpsi, ae)
    end do
    if (.not. shared) then
      do q = 1, exact_rule%n
        call rt1_values(g, exact_rule%bary(:, q), psi, dpsi)
        call add_gram(g%area * exact_rule%w(q), psi, dpsi, ae)
      end do
    end if
    ae = 0.5_dp * (ae + transpose(ae))
  end subroutine rt1_element

  !> ae = ae + w (psi_i . psi_j + dpsi_i dpsi_j): one quadrature point of the Gram matrix.
  pure subroutine add_gram(w, psi, dpsi, ae)
    real(dp), intent(in) :: w, psi(2, rt1_nbasis), dpsi(rt1_nbasis)
    real(dp), intent(inout) :: ae(rt1_nbasis, rt1_nbasis)
    integer :: i
    do i = 1, rt1_nbasis
      ae(:, i) = ae(:, i) + w * (psi(1, i) * psi(1, :) + psi(2, i) * psi(2, :) + dpsi(i) * dpsi)
    end do
  end subroutine add_gram

  !> Static condensation of the two interior unknowns x_I (free): with the blocks of ae
  !> and be on the side (S) and interior (I) unknowns,
  !>     se = A_SS - A_SI A_II^{-1} A_IS,   ce = b_S - A_SI A_II^{-1} b_I,
  !> and x_I = rec_d - rec_k x_S recovers the interior unknowns from the side ones
  !> (rec_k = A_II^{-1} A_IS, rec_d = A_II^{-1} b_I).
  pure subroutine rt1_condense(ae, be, se, ce, rec_k, rec_d)
    real(dp), intent(in) :: ae(rt1_nbasis, rt1_nbasis), be(rt1_nbasis)
    real(dp), intent(out) :: se(rt1_nside, rt1_nside), ce(rt1_nside)
    real(dp), intent(out) :: rec_k(2, rt1_nside), rec_d(2)
    real(dp) :: aii(2, 2), inv(2, 2), det
    aii = ae(7:8, 7:8)
    det = aii(1, 1) * aii(2, 2) - aii(1, 2) * aii(2, 1)
    inv = reshape([aii(2, 2), -aii(2, 1), -aii(1, 2), aii(1, 1)], [2, 2]) / det
    rec_k = matmul(inv, ae(7:8, 1:6))
    rec_d = matmul(inv, be(7:8))
    se = ae(1:6, 1:6) - matmul(ae(1:6, 7:8), rec_k)
    se = 0.5_dp * (se + transpose(se))
    ce = be(1:6) - matmul(ae(1:6, 7:8), rec_d)
  end subroutine rt1_condense
end module dualsig_elements_rt1
