!> A posteriori error bounds and two-sided energy bounds for problem P1 (Section 6) with the
!> H(div) dual field q in RT1 (dualsig_problem_dual_hdiv): for u~ in K_1h and q with
!> q.nu >= 0 on Gamma,
!>
!>   (6.13)  ||u~ - u||_1^2 <= E(q, u~) = ||q - grad u~||^2 + ||f + div q - u~||^2
!>                                        + 2 int_Gamma (q.nu) u~ ds,
!>   (6.18)  ||q - grad u||^2 + ||f + div q - u||^2 <= E(q, u~)   (Remark 6.4),
!>   (6.14)  2 (f, u~) - ||u~||_1^2 <= ||u||_1^2 = (f, u) <= F(q) = ||q||^2 + ||f + div q||^2.
!>
!> The proofs use only q in Q = H(div) with q.nu|_Gamma >= 0, which RT1 fields satisfy.
!>
!> A sharper bound from the same q (its proof in doc/theory.md, "A bound robust in the size
!> of the domain").  With e = u - u~, the variational inequality at v = u~ and Green's
!> formula for q give ||e||_1^2 <= (q - grad u~, grad e) + (f + div q - u~, e) + c,
!> c = int_Gamma (q.nu) u~ ds.  Split f + div q - u~ = (f - Pi_1 f) + r_T on each triangle,
!> r_T = Pi_1 f + div q - u~ linear; f - Pi_1 f has mean zero on T, so by Payne-Weinberger
!> (f - Pi_1 f, e)_T <= (h_T/pi) osc_T ||grad e||_T.  Cauchy-Schwarz then gives
!> ||e||_1^2 <= S ||e||_1 + c with S^2 = sum_T (||q - grad u~||_T + (h_T/pi) osc_T)^2
!> + sum_T ||r_T||^2, so
!>   ||e||_1^2 <= est_pw = ((S + sqrt(S^2 + 4 c)) / 2)^2,
!> and est = min(E, est_pw).  On a domain of small diameter the data term ||f - Pi_1 f||^2
!> of E, unweighted, dominates it by orders of magnitude; est_pw weights it by h_T/pi, as
!> the bound of P2 does.  Then also ||u||_1^2 <= (||u~||_1 + sqrt(est))^2, and energy_hi is
!> the smaller of that and F(q).
!> E is summed from its non-negative element and edge terms (Remark 6.1).  Exactness:
!> - ||q - grad u~||^2 and ||q||^2 are integrals of polynomials of degree 4, integrated
!>   exactly (Radon's degree-5 rule);
!> - ||f + div q - u~||^2, ||f + div q||^2 and (f, u~): f enters only through its load data
!>   (dualsig_load_data: mean, moments, Pi_1 f and ||f - Pi_1 f|| per triangle), by exact
!>   identities, div q - u~ being linear (see dual_hdiv_bounds_load);
!> - the edge term: q.nu and u~ are both linear on a boundary edge, integrated exactly; q.nu
!>   is taken >= 0 at the edge ends (it is, for a feasible q), which can only increase E.
!> Element contributions (edge terms added to the triangle of the edge) are returned.
module dualsig_estimate_dual_hdiv
  use dualsig_kinds, only: dp, i8, pi
  use dualsig_fields, only: field_t, vector_field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_quadrature, only: tri_rule_t, tri_rule, tri_points_t, tri_points_set
  use dualsig_elements_p1, only: p1_gradients
  use dualsig_elements_rt1, only: rt1_geometry_t, rt1_geometry, rt1_values, rt1_nbasis, rt1_matrix_degree
  use dualsig_assembly_dual_hdiv, only: hdiv_local_coefficients, hdiv_bedge_dofs
  use dualsig_estimate_dual_p1, only: dual_p1_bounds_t
  use dualsig_load_data, only: load_data_t
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: dual_hdiv_bounds_load, dual_hdiv_errors

  !> Degree of the rule for the linear-times-linear integrands of dual_hdiv_bounds_load.
  integer, parameter :: linear_product_degree = 2

contains

  !> The bounds (6.13) and (6.14) for the nodal u~ (nnode) and the RT1 field x (hdiv_nfield),
  !> with f entering only through its load
  !> data (dualsig_load_data): f - Pi_1 f is orthogonal to linear functions on each triangle
  !> and div q, u~ are linear there, so
  !>   ||f + div q - u~||_T^2 = osc_T^2 + ||Pi_1 f + div q - u~||_T^2,
  !>   ||f + div q||_T^2 = osc_T^2 + ||Pi_1 f + div q||_T^2,   (f, u~)_T = f_T int u~ + grad u~ . m_T,
  !> identities; every other integrand is a polynomial, integrated exactly.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine dual_hdiv_bounds_load(mesh, u, x, load, bnd, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:), x(:)
    type(load_data_t), intent(in) :: load
    type(dual_p1_bounds_t), intent(out) :: bnd
    type(status_t), intent(out) :: st
    integer :: ist
    type(tri_rule_t) :: prule, lrule
    type(tri_points_t) :: tp
    type(rt1_geometry_t) :: g
    real(dp) :: c(rt1_nbasis), psi(2, rt1_nbasis), dpsi(rt1_nbasis), dv(3), ue(3), gu(2), qq(2)
    real(dp) :: e1, e2, r2, uq, dq, pf, fu, uu, hi, hi_t, grad(2, 3), area, bary(3), centroid(2)
    real(dp), allocatable :: pw_elem(:), b_elem(:)   ! S^2's terms, the boundary terms 2 (q.nu, u~), per triangle
    integer :: t, k
    allocate (bnd%est_elem(mesh%ntri), pw_elem(mesh%ntri), b_elem(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the element indicators', 3_i8 * mesh%ntri, BYTES_REAL)) return
    prule = tri_rule(rt1_matrix_degree)
    lrule = tri_rule(linear_product_degree)
    fu = 0.0_dp
    uu = 0.0_dp
    hi = 0.0_dp
    do t = 1, mesh%ntri
      g = rt1_geometry(mesh%xy(:, mesh%tri(:, t)))
      call p1_gradients(g%xy, grad, area)
      centroid = sum(g%xy, dim=2) / 3.0_dp
      c = hdiv_local_coefficients(mesh, x, t)
      ue = u(mesh%tri(:, t))
      gu = matmul(grad, ue)
      e1 = 0.0_dp
      hi_t = 0.0_dp
      do k = 1, prule%n
        call rt1_values(g, prule%bary(:, k), psi, dpsi)
        qq = matmul(psi, c)
        e1 = e1 + area * prule%w(k) * sum((qq - gu)**2)
        hi_t = hi_t + area * prule%w(k) * sum(qq**2)
      end do
      do k = 1, 3
        bary = 0.0_dp
        bary(k) = 1.0_dp
        call rt1_values(g, bary, psi, dpsi)
        dv(k) = dot_product(dpsi, c)
      end do
      ! Pi_1 f + div q - u~ and Pi_1 f + div q: linear, their squares exact with a degree-2 rule
      r2 = 0.0_dp
      hi_t = hi_t + load%osc(t)**2
      call tri_points_set(g%xy, lrule, tp, [real(dp) ::])
      do k = 1, tp%n
        pf = load%mean(t) + dot_product(load%slope(:, t), tp%p(:, k) - centroid)
        uq = dot_product(tp%bary(:, k), ue)
        dq = dot_product(tp%bary(:, k), dv)
        r2 = r2 + tp%w(k) * (pf + dq - uq)**2
        hi_t = hi_t + tp%w(k) * (pf + dq)**2
      end do
      e2 = load%osc(t)**2 + r2
      hi = hi + hi_t
      fu = fu + load%mean(t) * area * sum(ue) / 3.0_dp + dot_product(gu, load%moment(:, t))
      bnd%fu_abs = bnd%fu_abs + abs(load%mean(t) * area * sum(ue) / 3.0_dp) + sum(abs(gu * load%moment(:, t)))
      bnd%nsum = max(bnd%nsum, mesh%ntri + prule%n + tp%n + 1)
      uu = uu + area * (sum(gu**2) + (sum(ue**2) + sum(ue)**2) / 12.0_dp)
      bnd%est_elem(t) = e1 + e2
      pw_elem(t) = (sqrt(e1) + load%diameter(t) / pi * load%osc(t))**2 + r2
    end do
    call boundary_term(mesh, u, x, b_elem, bnd%boundary_term)
    bnd%est_elem = bnd%est_elem + b_elem
    bnd%est_hypercircle = sum(bnd%est_elem)
    bnd%energy_lo = 2.0_dp * fu - uu
    bnd%uu = uu
    call take_sharper(bnd, pw_elem, b_elem, uu, hi)
  end subroutine dual_hdiv_bounds_load

  !> est = min(E, est_pw) with est_pw = ((S + sqrt(S^2 + 4 c)) / 2)^2 (the module's header):
  !> S^2 = sum(pw_elem), c = sum(b_elem) / 2; the indicators those of the bound taken, scaled
  !> to sum to est; energy_hi = min(F(q), (||u~||_1 + sqrt(est))^2), uu = ||u~||_1^2, hi = F(q).
  pure subroutine take_sharper(bnd, pw_elem, b_elem, uu, hi)
    type(dual_p1_bounds_t), intent(inout) :: bnd
    real(dp), intent(in) :: pw_elem(:), b_elem(:), uu, hi
    real(dp) :: s2, c, est_pw, total
    s2 = sum(pw_elem)
    c = 0.5_dp * sum(b_elem)
    est_pw = 0.25_dp * (sqrt(s2) + sqrt(s2 + 4.0_dp * c))**2
    bnd%est = bnd%est_hypercircle
    if (est_pw < bnd%est_hypercircle) then
      bnd%est = est_pw
      total = s2 + 2.0_dp * c
      if (total > 0.0_dp) bnd%est_elem = (pw_elem + b_elem) * (est_pw / total)
    end if
    bnd%energy_hi = min(hi, (sqrt(max(uu, 0.0_dp)) + sqrt(bnd%est))**2)
  end subroutine take_sharper

  !> 2 int_Gamma (q.nu) u~ ds, exactly (both factors linear on an edge):
  !> 2 L/6 (2 a1 b1 + a1 b2 + a2 b1 + 2 a2 b2), per triangle of the edges (b_elem) and in all.
  subroutine boundary_term(mesh, u, x, b_elem, total)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:), x(:)
    real(dp), intent(out) :: b_elem(:), total
    real(dp) :: qn(2), ub(2), e1
    integer :: j, t, dofs(2)
    b_elem = 0.0_dp
    total = 0.0_dp
    do j = 1, mesh%nbedge
      call hdiv_bedge_dofs(mesh, j, dofs)
      qn = max(0.0_dp, x(dofs))
      ub = u(mesh%bedge_nodes(:, j))
      e1 = 2.0_dp * mesh%bedge_length(j) / 6.0_dp * (2.0_dp * qn(1) * ub(1) + qn(1) * ub(2) + qn(2) * ub(1) &
                                                     + 2.0_dp * qn(2) * ub(2))
      total = total + e1
      t = mesh%bedge_tri(j)
      b_elem(t) = b_elem(t) + e1
    end do
  end subroutine boundary_term

  !> Errors of the dual field against the exact solution u of P1 (grad u = q^0,
  !> u = f + div q^0): err_q = ||q - grad u||, err_div = ||f + div q - u||, and the
  !> Q-norm error sqrt(err_q^2 + err_div^2).
  subroutine dual_hdiv_errors(mesh, x, f, u, grad_u, rule, err_q, err_div, err_qnorm, breaks)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: x(:)
    class(field_t), intent(in) :: f, u
    class(vector_field_t), intent(in) :: grad_u
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(out) :: err_q, err_div, err_qnorm
    real(dp), intent(in), optional :: breaks(:)   !! lines x = const where f has a kink
    type(tri_points_t) :: tp
    type(rt1_geometry_t) :: g
    real(dp) :: c(rt1_nbasis), psi(2, rt1_nbasis), dpsi(rt1_nbasis), p(2), qq(2)
    integer :: t, k
    err_q = 0.0_dp
    err_div = 0.0_dp
    do t = 1, mesh%ntri
      g = rt1_geometry(mesh%xy(:, mesh%tri(:, t)))
      c = hdiv_local_coefficients(mesh, x, t)
      call tri_points_set(g%xy, rule, tp, breaks)
      do k = 1, tp%n
        p = tp%p(:, k)
        call rt1_values(g, tp%bary(:, k), psi, dpsi)
        qq = matmul(psi, c)
        err_q = err_q + tp%w(k) * sum((qq - grad_u%value(p(1), p(2)))**2)
        err_div = err_div + tp%w(k) * (f%value(p(1), p(2)) + dot_product(dpsi, c) - u%value(p(1), p(2)))**2
      end do
    end do
    err_qnorm = sqrt(err_q + err_div)
    err_q = sqrt(err_q)
    err_div = sqrt(err_div)
  end subroutine dual_hdiv_errors
end module dualsig_estimate_dual_hdiv
