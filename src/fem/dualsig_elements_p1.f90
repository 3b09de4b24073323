!> Element routines for continuous piecewise-linear (P1) functions on a triangle.
!>
!> Local basis: the barycentric coordinates lambda_1, lambda_2, lambda_3 of the three
!> vertices, listed counter-clockwise (positive area).
module dualsig_elements_p1
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_quadrature, only: tri_rule_t
  implicit none
  private

  public :: p1_gradients, p1_element_stiffness, p1_element_mass, p1_element_load

contains

  !> Gradients grad(k, i) = d lambda_i / d x_k of the barycentric basis and the signed
  !> area of the triangle with vertices xy(:, 1:3).
  pure subroutine p1_gradients(xy, grad, area)
    real(dp), intent(in) :: xy(2, 3)
    real(dp), intent(out) :: grad(2, 3)
    real(dp), intent(out) :: area
    real(dp) :: two_area
    two_area = (xy(1, 2) - xy(1, 1)) * (xy(2, 3) - xy(2, 1)) &
             - (xy(1, 3) - xy(1, 1)) * (xy(2, 2) - xy(2, 1))
    area = 0.5_dp * two_area
    ! grad lambda_i = (y_j - y_k, x_k - x_j) / (2 area) for (i, j, k) cyclic
    grad(:, 1) = [xy(2, 2) - xy(2, 3), xy(1, 3) - xy(1, 2)] / two_area
    grad(:, 2) = [xy(2, 3) - xy(2, 1), xy(1, 1) - xy(1, 3)] / two_area
    grad(:, 3) = [xy(2, 1) - xy(2, 2), xy(1, 2) - xy(1, 1)] / two_area
  end subroutine p1_gradients

  !> Element stiffness matrix ke(i,j) = integral of grad(lambda_i) . grad(lambda_j).
  pure subroutine p1_element_stiffness(xy, ke)
    real(dp), intent(in) :: xy(2, 3)
    real(dp), intent(out) :: ke(3, 3)
    real(dp) :: grad(2, 3), area
    call p1_gradients(xy, grad, area)
    ke = area * matmul(transpose(grad), grad)
  end subroutine p1_element_stiffness

  !> Element mass matrix me(i,j) = integral of lambda_i lambda_j = area (1 + delta_ij) / 12.
  pure subroutine p1_element_mass(xy, me)
    real(dp), intent(in) :: xy(2, 3)
    real(dp), intent(out) :: me(3, 3)
    real(dp) :: grad(2, 3), area
    integer :: i
    call p1_gradients(xy, grad, area)
    me = area / 12.0_dp
    do i = 1, 3
      me(i, i) = area / 6.0_dp
    end do
  end subroutine p1_element_mass

  !> Element load vector fe(i) = integral of f lambda_i, by the quadrature `rule`
  !> (exact when f lambda_i is a polynomial of degree <= rule%degree).
  subroutine p1_element_load(xy, f, rule, fe)
    real(dp), intent(in) :: xy(2, 3)
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(out) :: fe(3)
    real(dp) :: grad(2, 3), area, p(2), fval
    integer :: q
    call p1_gradients(xy, grad, area)
    fe = 0.0_dp
    do q = 1, rule%n
      p = matmul(xy, rule%bary(:, q))
      fval = f%value(p(1), p(2))
      fe = fe + rule%w(q) * fval * rule%bary(:, q)
    end do
    fe = area * fe
  end subroutine p1_element_load
end module dualsig_elements_p1
