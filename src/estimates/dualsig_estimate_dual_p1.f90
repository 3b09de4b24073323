!> A posteriori error bounds and two-sided energy bounds for problem P1 (Section 6).
!>
!> For a primal approximation u~ in K_1h (u~ >= 0 at the boundary nodes) and a feasible
!> dual field q in U_0h (q.nu >= 0 on Gamma):
!>
!>   (6.13)  ||u~ - u||_1^2 <= E(q, u~) = ||q - grad u~||^2 + ||f + div q - u~||^2
!>                                         + 2 int_Gamma (q.nu) u~ ds,
!>   (6.18)  ||q - grad u||^2 + ||f + div q - u||^2 <= E(q, u~)   (Remark 6.4),
!>   (6.14)  -2 L_1(u~) = 2 (f, u~) - ||u~||_1^2  <=  ||u||_1^2 = (f, u)  <=
!>           F(q) = ||q||^2 + ||f + div q||^2.
!>
!> E is accumulated from its non-negative element and edge terms (Remark 6.1: never as a
!> difference of energies).  On a boundary edge both q.nu and u~ are linear, so the edge
!> term is integrated exactly; q.nu is taken >= 0 at the edge ends (it is, up to rounding,
!> for a feasible q), which can only increase E.  The element contributions (edge terms
!> added to the triangle that owns the edge) are returned for adaptivity and plots.
module dualsig_estimate_dual_p1
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t, vector_field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_quadrature, only: tri_rule_t, tri_rule, tri_points_t, tri_points_set
  use dualsig_elements_p1, only: p1_gradients
  use dualsig_load_data, only: load_data_t
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: dual_p1_bounds_t, dual_p1_bounds, dual_p1_bounds_load, dual_p1_errors

  !> Largest total degree of the polynomial integrands of dual_p1_bounds_load.
  integer, parameter :: polynomial_degree = 2

  type :: dual_p1_bounds_t
    real(dp) :: est = 0.0_dp             !! a bound of ||u - u~||_1^2: E(q, u~) of (6.13), or a sharper one (hdiv)
    real(dp) :: est_hypercircle = 0.0_dp !! E(q, u~) of (6.13) = F(q) - (2 (f, u~) - ||u~||_1^2), bounds (6.18) too
    real(dp) :: energy_lo = 0.0_dp       !! 2 (f, u~) - ||u~||_1^2
    real(dp) :: energy_hi = 0.0_dp       !! F(q), or a sharper bound (hdiv)
    real(dp) :: boundary_term = 0.0_dp   !! 2 int_Gamma (q.nu) u~ ds (part of est)
    real(dp), allocatable :: est_elem(:) !! (ntri) element contributions, sum = est
    !> for the rounding allowance of the energy bounds (dualsig_analysis): the sum of the
    !> absolute values of the terms of (f, u~), ||u~||_1^2, and nsum = the triangles plus the
    !> most terms of one triangle (every sum is summed per triangle first)
    real(dp) :: fu_abs = 0.0_dp
    real(dp) :: uu = 0.0_dp
    integer :: nsum = 0
  end type dual_p1_bounds_t

contains

  !> The bounds of (6.13) and (6.14) for the nodal u~ (nnode) and the interleaved nodal
  !> field q (2 nnode); f is integrated with `rule` (choose a high degree).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine dual_p1_bounds(mesh, u, q, f, rule, bnd, breaks, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:), q(:)
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(dual_p1_bounds_t), intent(out) :: bnd
    type(status_t), intent(out) :: st
    integer :: ist
    real(dp), intent(in), optional :: breaks(:)   !! lines x = const where f has a kink
    real(dp) :: xy(2, 3), grad(2, 3), area, gu(2), divq, qe(2, 3), ue(3), fq, uq, qq(2)
    real(dp) :: e1, e2, fu, uu, s(4)
    type(tri_points_t) :: tp
    integer :: t, k
    allocate (bnd%est_elem(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the element indicators', mesh%ntri, BYTES_REAL)) return
    fu = 0.0_dp
    uu = 0.0_dp
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_gradients(xy, grad, area)
      ue = u(mesh%tri(:, t))
      do k = 1, 3
        qe(:, k) = q(2 * mesh%tri(k, t) - 1:2 * mesh%tri(k, t))
      end do
      gu = matmul(grad, ue)
      divq = sum(grad * qe)
      e1 = 0.0_dp
      e2 = 0.0_dp
      s = 0.0_dp                       ! this triangle's parts of energy_hi, fu, fu_abs, uu
      call tri_points_set(xy, rule, tp, breaks)
      do k = 1, tp%n
        fq = f%value(tp%p(1, k), tp%p(2, k))
        uq = dot_product(tp%bary(:, k), ue)
        qq = matmul(qe, tp%bary(:, k))
        e1 = e1 + tp%w(k) * sum((qq - gu)**2)
        e2 = e2 + tp%w(k) * (fq + divq - uq)**2
        s(1) = s(1) + tp%w(k) * (sum(qq**2) + (fq + divq)**2)
        s(2) = s(2) + tp%w(k) * fq * uq
        s(3) = s(3) + abs(tp%w(k) * fq * uq)
        s(4) = s(4) + tp%w(k) * (uq**2 + sum(gu**2))
      end do
      bnd%energy_hi = bnd%energy_hi + s(1)
      fu = fu + s(2)
      bnd%fu_abs = bnd%fu_abs + s(3)
      uu = uu + s(4)
      bnd%nsum = max(bnd%nsum, mesh%ntri + tp%n)
      bnd%est_elem(t) = e1 + e2
    end do
    call add_boundary_terms(mesh, u, q, bnd)
    bnd%est = sum(bnd%est_elem)
    bnd%est_hypercircle = bnd%est
    bnd%energy_lo = 2.0_dp * fu - uu
    bnd%uu = uu
  end subroutine dual_p1_bounds

  !> The bounds of (6.13) and (6.14) as dual_p1_bounds, with f entering only through its
  !> load data (dualsig_load_data: mean f_T, moments m_T, Pi_1 f = f_T + g_T . (x - x_T) and
  !> osc_T = ||f - Pi_1 f||_T per triangle), every other integrand a polynomial integrated
  !> exactly.  f - Pi_1 f is orthogonal to linear functions on T, so with div q constant
  !> and u~ linear on T
  !>   ||f + div q - u~||_T^2 = osc_T^2 + ||Pi_1 f + div q - u~||_T^2,
  !>   ||f + div q||_T^2 = osc_T^2 + ||Pi_1 f + div q||_T^2,
  !>   (f, u~)_T = f_T int_T u~ + grad u~ . m_T,
  !> identities, so the bounds hold for any f in L2 whose load data are right.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine dual_p1_bounds_load(mesh, u, q, load, bnd, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:), q(:)
    type(load_data_t), intent(in) :: load
    type(dual_p1_bounds_t), intent(out) :: bnd
    type(status_t), intent(out) :: st
    integer :: ist
    real(dp) :: xy(2, 3), grad(2, 3), area, gu(2), divq, qe(2, 3), ue(3), qq(2), pv
    real(dp) :: e1, e2, fu, uu, qsq, hsq, c, centroid(2)
    type(tri_points_t) :: tp
    type(tri_rule_t) :: exact_rule
    integer :: t, k
    exact_rule = tri_rule(polynomial_degree)
    allocate (bnd%est_elem(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the element indicators', mesh%ntri, BYTES_REAL)) return
    fu = 0.0_dp
    uu = 0.0_dp
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_gradients(xy, grad, area)
      ue = u(mesh%tri(:, t))
      do k = 1, 3
        qe(:, k) = q(2 * mesh%tri(k, t) - 1:2 * mesh%tri(k, t))
      end do
      gu = matmul(grad, ue)
      divq = sum(grad * qe)
      centroid = sum(xy, dim=2) / 3.0_dp
      ! polynomial parts, degree 2: exact with the degree-2 rule
      call tri_points_set(xy, exact_rule, tp, [real(dp) ::])
      e1 = 0.0_dp
      e2 = 0.0_dp
      qsq = 0.0_dp
      hsq = 0.0_dp
      do k = 1, tp%n
        qq = matmul(qe, tp%bary(:, k))
        c = load%mean(t) + dot_product(load%slope(:, t), tp%p(:, k) - centroid) + divq   ! Pi_1 f + div q
        pv = c - dot_product(tp%bary(:, k), ue)
        e1 = e1 + tp%w(k) * sum((qq - gu)**2)
        e2 = e2 + tp%w(k) * pv**2
        qsq = qsq + tp%w(k) * sum(qq**2)
        hsq = hsq + tp%w(k) * c**2
        uu = uu + tp%w(k) * dot_product(tp%bary(:, k), ue)**2
      end do
      uu = uu + area * sum(gu**2)
      e2 = e2 + load%osc(t)**2
      bnd%energy_hi = bnd%energy_hi + qsq + load%osc(t)**2 + hsq
      fu = fu + load%mean(t) * area * sum(ue) / 3.0_dp + dot_product(gu, load%moment(:, t))
      bnd%fu_abs = bnd%fu_abs + abs(load%mean(t) * area * sum(ue) / 3.0_dp) + sum(abs(gu * load%moment(:, t)))
      bnd%nsum = max(bnd%nsum, mesh%ntri + tp%n)
      bnd%est_elem(t) = e1 + e2
    end do
    call add_boundary_terms(mesh, u, q, bnd)
    bnd%est = sum(bnd%est_elem)
    bnd%est_hypercircle = bnd%est
    bnd%energy_lo = 2.0_dp * fu - uu
    bnd%uu = uu
  end subroutine dual_p1_bounds_load

  !> The boundary term of (6.13): 2 int_e (q.nu) u~ ds on every boundary edge, with both
  !> factors linear: L/6 (2 a1 b1 + a1 b2 + a2 b1 + 2 a2 b2), q.nu taken >= 0 at the edge
  !> ends; added to est_elem of the edge's triangle and to boundary_term.
  subroutine add_boundary_terms(mesh, u, q, bnd)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:), q(:)
    type(dual_p1_bounds_t), intent(inout) :: bnd
    real(dp) :: qn(2), ub(2), len, e1
    integer :: j, a, b, t
    do j = 1, mesh%nbedge
      a = mesh%bedge_nodes(1, j)
      b = mesh%bedge_nodes(2, j)
      len = mesh%bedge_length(j)
      qn(1) = max(0.0_dp, dot_product(q(2 * a - 1:2 * a), mesh%bedge_normal(:, j)))
      qn(2) = max(0.0_dp, dot_product(q(2 * b - 1:2 * b), mesh%bedge_normal(:, j)))
      ub = [u(a), u(b)]
      e1 = 2.0_dp * len / 6.0_dp * (2.0_dp * qn(1) * ub(1) + qn(1) * ub(2) + qn(2) * ub(1) &
                                    + 2.0_dp * qn(2) * ub(2))
      bnd%boundary_term = bnd%boundary_term + e1
      t = mesh%bedge_tri(j)
      bnd%est_elem(t) = bnd%est_elem(t) + e1
    end do
  end subroutine add_boundary_terms

  !> Errors of the dual field against the exact solution u of P1 (grad u = q^0,
  !> u = f + div q^0): err_q = ||q - grad u||, err_div = ||f + div q - u||, and the
  !> Q-norm error sqrt(err_q^2 + err_div^2) (div q^0 = Lap u = u - f).
  subroutine dual_p1_errors(mesh, q, f, u, grad_u, rule, err_q, err_div, err_qnorm, breaks)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: q(:)
    class(field_t), intent(in) :: f, u
    class(vector_field_t), intent(in) :: grad_u
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(out) :: err_q, err_div, err_qnorm
    real(dp), intent(in), optional :: breaks(:)   !! lines x = const where f has a kink
    real(dp) :: xy(2, 3), grad(2, 3), area, qe(2, 3), divq, p(2), qq(2), e1, e2
    type(tri_points_t) :: tp
    integer :: t, k
    err_q = 0.0_dp
    err_div = 0.0_dp
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_gradients(xy, grad, area)
      do k = 1, 3
        qe(:, k) = q(2 * mesh%tri(k, t) - 1:2 * mesh%tri(k, t))
      end do
      divq = sum(grad * qe)
      e1 = 0.0_dp
      e2 = 0.0_dp
      call tri_points_set(xy, rule, tp, breaks)
      do k = 1, tp%n
        p = tp%p(:, k)
        qq = matmul(qe, tp%bary(:, k))
        e1 = e1 + tp%w(k) * sum((qq - grad_u%value(p(1), p(2)))**2)
        e2 = e2 + tp%w(k) * (f%value(p(1), p(2)) + divq - u%value(p(1), p(2)))**2
      end do
      err_q = err_q + e1
      err_div = err_div + e2
    end do
    err_qnorm = sqrt(err_q + err_div)
    err_q = sqrt(err_q)
    err_div = sqrt(err_div)
  end subroutine dual_p1_errors
end module dualsig_estimate_dual_p1
