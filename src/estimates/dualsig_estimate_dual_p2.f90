!> A posteriori error bound and two-sided energy bounds for problem P2 (Section 6).
!>
!> For u~ in K_2h and an admissible lambda^h = lambda^f + q^h (div lambda^h = -f,
!> lambda^h . nu >= 0 on Gamma_a):
!>
!>   (6.26)     |u - u~|_1^2 <= E(lambda^h, u~) = ||lambda^h - grad u~||^2
!>                                             + 2 int_{Gamma_a} (lambda^h . nu) u~ ds,
!>   Remark 6.7 ||lambda^h - grad u||^2 <= E(lambda^h, u~),
!>   Thm 6.4    2 (f, u~) - |u~|_1^2 <= |u|_1^2 = (f, u) <= ||lambda^h||^2.
!>
!> E is summed from non-negative element and edge terms (Remark 6.1).  On a Gamma_a edge
!> lambda^h . nu = q^h . nu - g_h is linear, and so is u~: the edge term is integrated
!> exactly, with the flux taken >= 0 at the edge ends (it is, up to rounding).
module dualsig_estimate_dual_p2
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t, vector_field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_kinds, only: pi
  use dualsig_quadrature, only: tri_rule_t, tri_rule, tri_points_t, tri_points_set
  use dualsig_load_data, only: load_data_t
  use dualsig_elements_p1, only: p1_gradients
  use dualsig_elements_equilibrium, only: equilibrium_field, equilibrium_c_of
  use dualsig_dual_p2_field, only: dual_p2_field_t, dual_p2_lambda_points, bubble_value
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, BYTES_REAL
  implicit none
  private

  public :: dual_p2_bounds_t, dual_p2_bounds, dual_p2_bounds_load, dual_p2_error

  !> Largest total degree of the polynomial integrands of dual_p2_bounds_load (lambda^h is
  !> piecewise quadratic: |lambda^h - grad u~|^2 has degree 4).
  integer, parameter :: polynomial_degree = 4

  type :: dual_p2_bounds_t
    real(dp) :: est = 0.0_dp             !! E(lambda^h, u~) of (6.26)
    real(dp) :: energy_lo = 0.0_dp       !! 2 (f, u~) - |u~|_1^2
    real(dp) :: energy_hi = 0.0_dp       !! ||lambda^h||^2
    real(dp) :: boundary_term = 0.0_dp   !! 2 int_{Gamma_a} (lambda^h . nu) u~ ds
    real(dp), allocatable :: est_elem(:) !! (ntri) element contributions, sum = est
    real(dp) :: oscillation = 0.0_dp     !! (sum_T ((h_T/pi) ||f - Pi_1 f||_T)^2)^(1/2) (load version)
    !> for the rounding allowance of the energy bounds (dualsig_analysis): the sum of the
    !> absolute values of the terms of (f, u~), ||u~||_1^2, and nsum = the triangles plus the
    !> most terms of one triangle (every sum is summed per triangle first)
    real(dp) :: fu_abs = 0.0_dp
    real(dp) :: uu = 0.0_dp
    integer :: nsum = 0
  end type dual_p2_bounds_t

contains

  !> The bounds for the nodal u~ and the dual field; f is integrated with `rule`.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine dual_p2_bounds(mesh, u, field, f, is_gamma_a, rule, bnd, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:)
    type(dual_p2_field_t), intent(in) :: field
    class(field_t), intent(in) :: f
    logical, intent(in) :: is_gamma_a(:)
    type(tri_rule_t), intent(in) :: rule
    type(dual_p2_bounds_t), intent(out) :: bnd
    type(status_t), intent(out) :: st
    integer :: ist
    real(dp) :: xy(2, 3), grad(2, 3), area, gu(2), ue(3), e1, fu, uu, flux(2), ub(2), len
    real(dp) :: bary(3), fterm, s(3)
    real(dp), allocatable :: lam(:,:)
    type(tri_points_t) :: tp
    integer :: t, k, j, i, lv
    allocate (bnd%est_elem(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the element indicators', mesh%ntri, BYTES_REAL)) return
    fu = 0.0_dp
    uu = 0.0_dp
    allocate (lam(2, 0))                        ! small: grown to the points of one triangle
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_gradients(xy, grad, area)
      ue = u(mesh%tri(:, t))
      gu = matmul(grad, ue)
      e1 = 0.0_dp
      s = 0.0_dp                     ! this triangle's parts of energy_hi, fu, fu_abs
      call tri_points_set(xy, rule, tp, field%pf%breaks(1:field%pf%nbreaks))
      if (size(lam, 2) < tp%n) then
        deallocate (lam)
        allocate (lam(2, 2 * tp%n))               ! small: the points of one triangle
      end if
      call dual_p2_lambda_points(field, mesh, f, t, tp, lam(:, 1:tp%n))
      do k = 1, tp%n
        e1 = e1 + tp%w(k) * sum((lam(:, k) - gu)**2)
        fterm = tp%w(k) * f%value(tp%p(1, k), tp%p(2, k)) * dot_product(tp%bary(:, k), ue)
        s(1) = s(1) + tp%w(k) * sum(lam(:, k)**2)
        s(2) = s(2) + fterm
        s(3) = s(3) + abs(fterm)
      end do
      bnd%energy_hi = bnd%energy_hi + s(1)
      fu = fu + s(2)
      bnd%fu_abs = bnd%fu_abs + s(3)
      bnd%nsum = max(bnd%nsum, mesh%ntri + tp%n)
      uu = uu + area * sum(gu**2)
      bnd%est_elem(t) = e1
    end do
    do j = 1, mesh%nbedge
      if (.not. is_gamma_a(j)) cycle
      t = mesh%bedge_tri(j)
      len = mesh%bedge_length(j)
      do i = 1, 2
        ! lambda^h . nu = q^h . nu - g_h at the edge end i
        lv = findloc(mesh%tri(:, t), mesh%bedge_nodes(i, j), dim=1)
        bary = 0.0_dp
        bary(lv) = 1.0_dp
        flux(i) = max(0.0_dp, dot_product(equilibrium_field(equilibrium_c_of(mesh%xy(:, mesh%tri(:, t))), field%beta(:, t), bary), &
                                          mesh%bedge_normal(:, j)) - field%pf%gh(i, j))
        ub(i) = u(mesh%bedge_nodes(i, j))
      end do
      e1 = 2.0_dp * len / 6.0_dp * (2.0_dp * flux(1) * ub(1) + flux(1) * ub(2) + flux(2) * ub(1) &
                                    + 2.0_dp * flux(2) * ub(2))
      bnd%boundary_term = bnd%boundary_term + e1
      bnd%est_elem(t) = bnd%est_elem(t) + e1
    end do
    bnd%est = sum(bnd%est_elem)
    bnd%energy_lo = 2.0_dp * fu - uu
    bnd%uu = uu
  end subroutine dual_p2_bounds

  !> The bounds for a polynomial lambda^h (div lambda^h = -Pi_1 f on every triangle,
  !> lambda^h . nu >= 0 on Gamma_a; dualsig_dual_p2_field) and any f in L2, from the load
  !> data of f (mean f_T, moments m_T, osc_T = ||f - Pi_1 f||_T per triangle).  With
  !> w = u - u~ and the Payne-Weinberger inequality (f - Pi_1 f, w)_T <= (h_T/pi) osc_T
  !> |w|_{1,T} (f - Pi_1 f has mean zero on T; T convex, h_T its diameter):
  !>   |w|_1^2 <= (f, w) - (grad u~, grad w)      (the variational inequality, u~ in K_2h)
  !>           = (f - Pi_1 f, w) + (lambda - grad u~, grad w) - int_{Gamma_a} lambda.nu w
  !>           <= eta |w|_1 + B,   eta^2 = sum_T (||lambda - grad u~||_T + (h_T/pi) osc_T)^2,
  !>                               B = int_{Gamma_a} (lambda.nu) u~ ds >= 0
  !> (lambda.nu >= 0 and u >= 0 on Gamma_a), hence the guaranteed bound of (6.26)'s form
  !>   |w|_1^2 <= est = eta^2 + 2 B;
  !> likewise |u|_1^2 = (f, u) <= (||lambda|| + osc) |u|_1 with osc^2 = sum_T ((h_T/pi) osc_T)^2:
  !>   energy_hi = (||lambda|| + osc)^2,  and  energy_lo = 2 (f, u~) - |u~|_1^2 with
  !>   (f, u~)_T = f_T int_T u~ + grad u~ . m_T exactly (Theorem 6.4).
  !> Without oscillation (f linear on every triangle) these are (6.26) and Theorem 6.4 as
  !> printed.  Every other integrand is a polynomial of degree <= 4, integrated exactly.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine dual_p2_bounds_load(mesh, u, field, load, is_gamma_a, bnd, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:)
    type(dual_p2_field_t), intent(in) :: field
    type(load_data_t), intent(in) :: load
    logical, intent(in) :: is_gamma_a(:)
    type(dual_p2_bounds_t), intent(out) :: bnd
    type(status_t), intent(out) :: st
    integer :: ist
    real(dp) :: xy(2, 3), grad(2, 3), area, gu(2), ue(3), lam(2), e1, fu, uu, lsq, lsq_t, osc_t, c(6, 6), beta(6)
    type(tri_rule_t) :: rule
    type(tri_points_t) :: tp
    integer :: t, k
    rule = tri_rule(polynomial_degree)
    allocate (bnd%est_elem(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the element indicators', mesh%ntri, BYTES_REAL)) return
    fu = 0.0_dp
    uu = 0.0_dp
    lsq = 0.0_dp
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_gradients(xy, grad, area)
      ue = u(mesh%tri(:, t))
      gu = matmul(grad, ue)
      e1 = 0.0_dp
      lsq_t = 0.0_dp
      call tri_points_set(xy, rule, tp, [real(dp) ::])
      c = equilibrium_c_of(xy)
      beta = field%beta(:, t) + field%beta_f(:, t)
      do k = 1, tp%n
        lam = equilibrium_field(c, beta, tp%bary(:, k)) + &
              bubble_value(xy, field%bubble(:, t), tp%bary(:, k))
        e1 = e1 + tp%w(k) * sum((lam - gu)**2)
        lsq_t = lsq_t + tp%w(k) * sum(lam**2)
      end do
      lsq = lsq + lsq_t
      osc_t = load%diameter(t) / pi * load%osc(t)
      bnd%oscillation = bnd%oscillation + osc_t**2
      bnd%est_elem(t) = (sqrt(e1) + osc_t)**2
      uu = uu + area * sum(gu**2)
      fu = fu + load%mean(t) * area * sum(ue) / 3.0_dp + dot_product(gu, load%moment(:, t))
      bnd%fu_abs = bnd%fu_abs + abs(load%mean(t) * area * sum(ue) / 3.0_dp) + sum(abs(gu * load%moment(:, t)))
      bnd%nsum = max(bnd%nsum, mesh%ntri + tp%n)
    end do
    bnd%oscillation = sqrt(bnd%oscillation)
    call add_gamma_a_terms(mesh, u, field, is_gamma_a, bnd)
    bnd%est = sum(bnd%est_elem)
    bnd%energy_lo = 2.0_dp * fu - uu
    bnd%uu = uu
    bnd%energy_hi = (sqrt(lsq) + bnd%oscillation)**2
  end subroutine dual_p2_bounds_load

  !> 2 int_{Gamma_a} (lambda.nu) u~ ds, both factors linear on an edge (exact), the flux
  !> taken >= 0 at the edge ends; added to est_elem of the edge's triangle.
  subroutine add_gamma_a_terms(mesh, u, field, is_gamma_a, bnd)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: u(:)
    type(dual_p2_field_t), intent(in) :: field
    logical, intent(in) :: is_gamma_a(:)
    type(dual_p2_bounds_t), intent(inout) :: bnd
    real(dp) :: flux(2), ub(2), len, e1, bary(3)
    integer :: j, i, t, lv
    do j = 1, mesh%nbedge
      if (.not. is_gamma_a(j)) cycle
      t = mesh%bedge_tri(j)
      len = mesh%bedge_length(j)
      do i = 1, 2
        lv = findloc(mesh%tri(:, t), mesh%bedge_nodes(i, j), dim=1)
        bary = 0.0_dp
        bary(lv) = 1.0_dp
        flux(i) = max(0.0_dp, dot_product(equilibrium_field(equilibrium_c_of(mesh%xy(:, mesh%tri(:, t))), &
                                                            field%beta(:, t) + field%beta_f(:, t), bary), &
                                          mesh%bedge_normal(:, j)))
        ub(i) = u(mesh%bedge_nodes(i, j))
      end do
      e1 = 2.0_dp * len / 6.0_dp * (2.0_dp * flux(1) * ub(1) + flux(1) * ub(2) + flux(2) * ub(1) &
                                    + 2.0_dp * flux(2) * ub(2))
      bnd%boundary_term = bnd%boundary_term + e1
      bnd%est_elem(t) = bnd%est_elem(t) + e1
    end do
  end subroutine add_gamma_a_terms

  !> ||grad u - lambda^h||_0 for the exact solution u.
  real(dp) function dual_p2_error(mesh, field, f, grad_u, rule) result(err)
    type(mesh_t), intent(in) :: mesh
    type(dual_p2_field_t), intent(in) :: field
    class(field_t), intent(in) :: f
    class(vector_field_t), intent(in) :: grad_u
    type(tri_rule_t), intent(in) :: rule
    real(dp) :: xy(2, 3)
    real(dp), allocatable :: lam(:,:)
    type(tri_points_t) :: tp
    integer :: t, k
    err = 0.0_dp
    allocate (lam(2, 0))                        ! small: grown to the points of one triangle
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call tri_points_set(xy, rule, tp, field%pf%breaks(1:field%pf%nbreaks))
      if (size(lam, 2) < tp%n) then
        deallocate (lam)
        allocate (lam(2, 2 * tp%n))               ! small: the points of one triangle
      end if
      call dual_p2_lambda_points(field, mesh, f, t, tp, lam(:, 1:tp%n))
      do k = 1, tp%n
        err = err + tp%w(k) * sum((grad_u%value(tp%p(1, k), tp%p(2, k)) - lam(:, k))**2)
      end do
    end do
    err = sqrt(err)
  end function dual_p2_error
end module dualsig_estimate_dual_p2
