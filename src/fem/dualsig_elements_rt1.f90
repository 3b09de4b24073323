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
!> and be_i = -(f, div psi_i) (from the caller's values of f at the points of a rule).  The
!> two interior unknowns are eliminated element by element (static condensation, exact:
!> they are free).
!>
!> ae in closed form (rt1_element): every basis function is a multiple s_i of the
!> contravariant Piola image of the same function on the reference triangle
!> a^_1 = (0,0), a^_2 = (1,0), a^_3 = (0,1): with J = [a_2 - a_1, a_3 - a_1] (det J = 2|T| > 0,
!> counter-clockwise), psi_i(x) = s_i J psi^_i(x^) / det J and div psi_i = s_i div^ psi^_i /
!> det J, where s = |S_k| / |S^_k| for the two functions of side k and
!> s = h^ det J / h for the interior ones (h^ = sqrt 2).  Hence
!>     ae_ij = s_i s_j / det J (C_11 R11 + C_12 R12 + C_22 R22 + D)_ij,   C = J^T J,
!> with the reference matrices R11_ij = int psi^_i,1 psi^_j,1, R12_ij = int (psi^_i,1 psi^_j,2 +
!> psi^_i,2 psi^_j,1), R22_ij = int psi^_i,2 psi^_j,2 and D_ij = int div^ psi^_i div^ psi^_j
!> (rt1_reference: degree-4 integrands, integrated exactly once), and the linear
!> divergences give be_i = -(s_i / 2) sum_q w_q f_q div^ psi^_i(x^_q) (exact for f linear
!> and a rule of degree >= 2).
module dualsig_elements_rt1
  use dualsig_kinds, only: dp
  use dualsig_quadrature, only: tri_rule_t
  use dualsig_elements_p1, only: p1_gradients
  implicit none
  private

  public :: rt1_geometry_t, rt1_geometry, rt1_values, rt1_element, rt1_condense, rt1_matrix_degree
  public :: rt1_nbasis, rt1_nside, rt1_reference_t, rt1_reference
  public :: rt1_gram, rt1_load_map, rt1_load_moments

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

  !> The reference triangle's matrices of the closed-form element matrix (module header).
  type :: rt1_reference_t
    real(dp) :: r11(rt1_nbasis, rt1_nbasis) = 0.0_dp
    real(dp) :: r12(rt1_nbasis, rt1_nbasis) = 0.0_dp
    real(dp) :: r22(rt1_nbasis, rt1_nbasis) = 0.0_dp
    real(dp) :: d(rt1_nbasis, rt1_nbasis) = 0.0_dp
    real(dp) :: div_vertex(3, rt1_nbasis) = 0.0_dp   !! div^ psi^_i at the reference vertices
    real(dp) :: side(3) = 0.0_dp                     !! |S^_k|
    real(dp) :: h = 0.0_dp                           !! h^ = sqrt 2
  end type rt1_reference_t

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

  !> The reference matrices R11, R12, R22, D and the vertex divergences of the basis on
  !> the reference triangle (0,0), (1,0), (0,1), integrated exactly by `rule` (degree >=
  !> rt1_matrix_degree, e.g. tri_rule(rt1_matrix_degree)).
  pure function rt1_reference(rule) result(ref)
    type(tri_rule_t), intent(in) :: rule
    type(rt1_reference_t) :: ref
    type(rt1_geometry_t) :: g
    real(dp) :: psi(2, rt1_nbasis), dpsi(rt1_nbasis), w
    integer :: q, i, v
    g = rt1_geometry(reshape([0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], [2, 3]))
    do q = 1, rule%n
      call rt1_values(g, rule%bary(:, q), psi, dpsi)
      w = g%area * rule%w(q)
      do i = 1, rt1_nbasis
        ref%r11(:, i) = ref%r11(:, i) + w * psi(1, :) * psi(1, i)
        ref%r12(:, i) = ref%r12(:, i) + w * (psi(1, :) * psi(2, i) + psi(2, :) * psi(1, i))
        ref%r22(:, i) = ref%r22(:, i) + w * psi(2, :) * psi(2, i)
        ref%d(:, i) = ref%d(:, i) + w * dpsi * dpsi(i)
      end do
    end do
    do v = 1, 3
      call rt1_values(g, real([merge(1, 0, v == 1), merge(1, 0, v == 2), merge(1, 0, v == 3)], dp), psi, dpsi)
      ref%div_vertex(v, :) = dpsi
    end do
    ! exactly symmetric (the products above are summed in two orders)
    ref%r11 = 0.5_dp * (ref%r11 + transpose(ref%r11))
    ref%r12 = 0.5_dp * (ref%r12 + transpose(ref%r12))
    ref%r22 = 0.5_dp * (ref%r22 + transpose(ref%r22))
    ref%d = 0.5_dp * (ref%d + transpose(ref%d))
    ref%side = g%side
    ref%h = g%h
  end function rt1_reference

  !> Element matrix ae (Gram matrix of ||q||^2 + ||div q||^2, exact) and vector
  !> be_i = -(f, div psi_i) with the values fq of f at the points of `rule` (exact when f is
  !> linear on the triangle, e.g. Pi_1 f, and rule%degree >= 2) of the functional (3.1'),
  !> both in closed form from the reference matrices ref = rt1_reference(...) (module header).
  pure subroutine rt1_element(g, fq, rule, ref, ae, be)
    type(rt1_geometry_t), intent(in) :: g
    real(dp), intent(in) :: fq(:)
    type(tri_rule_t), intent(in) :: rule
    type(rt1_reference_t), intent(in) :: ref
    real(dp), intent(out) :: ae(rt1_nbasis, rt1_nbasis), be(rt1_nbasis)
    real(dp) :: bmap(rt1_nbasis, 3), fb(3)
    ae = rt1_gram(g, ref)
    bmap = rt1_load_map(g, ref)
    fb = rt1_load_moments(rule, fq)
    be = matmul(bmap, fb)
  end subroutine rt1_element

  !> The Gram matrix ae of ||q||^2 + ||div q||^2 of triangle g in closed form (module
  !> header): it depends on the triangle only through C = J^T J (the side lengths and det J
  !> follow from C), so congruent triangles have the same ae.
  pure function rt1_gram(g, ref) result(ae)
    type(rt1_geometry_t), intent(in) :: g
    type(rt1_reference_t), intent(in) :: ref
    real(dp) :: ae(rt1_nbasis, rt1_nbasis)
    real(dp) :: e1(2), e2(2), c11, c12, c22, det, s(rt1_nbasis)
    integer :: i
    e1 = g%xy(:, 2) - g%xy(:, 1)
    e2 = g%xy(:, 3) - g%xy(:, 1)
    det = 2.0_dp * g%area
    c11 = dot_product(e1, e1)
    c12 = dot_product(e1, e2)
    c22 = dot_product(e2, e2)
    s = rt1_scales(g, ref)
    do i = 1, rt1_nbasis
      ae(:, i) = (s * s(i) / det) * (c11 * ref%r11(:, i) + c12 * ref%r12(:, i) + c22 * ref%r22(:, i) + ref%d(:, i))
    end do
  end function rt1_gram

  !> The scales s_i of the basis functions of triangle g against the reference ones
  !> (module header): |S_k| / |S^_k| for the two functions of side k, h^ det J / h_T for
  !> the interior ones.
  pure function rt1_scales(g, ref) result(s)
    type(rt1_geometry_t), intent(in) :: g
    type(rt1_reference_t), intent(in) :: ref
    real(dp) :: s(rt1_nbasis)
    integer :: k
    do k = 1, 3
      s(2 * k - 1:2 * k) = g%side(k) / ref%side(k)
    end do
    s(7:8) = ref%h * 2.0_dp * g%area / g%h
  end function rt1_scales

  !> The element vector as a linear map of the vertex moments of f (rt1_load_moments):
  !> be = bmap fb with bmap(i, v) = -(s_i / 2) div^ psi^_i(a^_v), since div psi_i is linear
  !> (module header).  Like ae, bmap depends on the triangle only through J^T J.
  pure function rt1_load_map(g, ref) result(bmap)
    type(rt1_geometry_t), intent(in) :: g
    type(rt1_reference_t), intent(in) :: ref
    real(dp) :: bmap(rt1_nbasis, 3)
    real(dp) :: s(rt1_nbasis)
    integer :: v
    s = rt1_scales(g, ref)
    do v = 1, 3
      bmap(:, v) = -0.5_dp * s * ref%div_vertex(v, :)
    end do
  end function rt1_load_map

  !> The vertex moments fb_v = sum_q w_q f_q lambda_v(x_q) of the values fq of f at the
  !> points of `rule` (|T| fb_v = (f, lambda_v)_T when the rule is exact for f lambda_v).
  pure function rt1_load_moments(rule, fq) result(fb)
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(in) :: fq(:)
    real(dp) :: fb(3)
    integer :: q
    fb = 0.0_dp
    do q = 1, rule%n
      fb = fb + (rule%w(q) * fq(q)) * rule%bary(:, q)
    end do
  end function rt1_load_moments

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
