!> Errors of a P1 approximation against a known exact solution, integrated with a
!> high-order quadrature rule on every triangle.
module dualsig_estimate_errors
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t, vector_field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_quadrature, only: tri_rule_t
  use dualsig_elements_p1, only: p1_gradients
  implicit none
  private

  public :: p1_error_norms, exact_energy

contains

  !> err_l2 = ||u - u_h||_0 and err_h1semi = |u - u_h|_1 for the nodal P1 vector uh.
  subroutine p1_error_norms(mesh, uh, u, grad_u, rule, err_l2, err_h1semi)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: uh(:)
    class(field_t), intent(in) :: u
    class(vector_field_t), intent(in) :: grad_u
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(out) :: err_l2, err_h1semi
    real(dp) :: xy(2, 3), grad(2, 3), area, p(2), gh(2), e0, e1, el0, el1, ue(3), d(2)
    integer :: t, q
    e0 = 0.0_dp
    e1 = 0.0_dp
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      ue = uh(mesh%tri(:, t))
      call p1_gradients(xy, grad, area)
      gh = matmul(grad, ue)
      el0 = 0.0_dp
      el1 = 0.0_dp
      do q = 1, rule%n
        p = matmul(xy, rule%bary(:, q))
        el0 = el0 + rule%w(q) * (u%value(p(1), p(2)) - dot_product(rule%bary(:, q), ue))**2
        d = grad_u%value(p(1), p(2)) - gh
        el1 = el1 + rule%w(q) * dot_product(d, d)
      end do
      e0 = e0 + area * el0
      e1 = e1 + area * el1
    end do
    err_l2 = sqrt(e0)
    err_h1semi = sqrt(e1)
  end subroutine p1_error_norms

  !> Energy of the exact solution over the mesh's domain: |u|_1^2, plus ||u||_0^2 when
  !> `full` (then ||u||_1^2, the energy of P1), by the quadrature `rule`.
  real(dp) function exact_energy(mesh, u, grad_u, rule, full) result(energy)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: u
    class(vector_field_t), intent(in) :: grad_u
    type(tri_rule_t), intent(in) :: rule
    logical, intent(in) :: full
    real(dp) :: xy(2, 3), grad(2, 3), area, p(2), el
    integer :: t, q
    energy = 0.0_dp
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_gradients(xy, grad, area)
      el = 0.0_dp
      do q = 1, rule%n
        p = matmul(xy, rule%bary(:, q))
        el = el + rule%w(q) * sum(grad_u%value(p(1), p(2))**2)
        if (full) el = el + rule%w(q) * u%value(p(1), p(2))**2
      end do
      energy = energy + area * el
    end do
  end function exact_energy
end module dualsig_estimate_errors
