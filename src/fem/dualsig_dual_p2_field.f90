!> The admissible dual field of problem P2 (Sections 4-6): lambda^h = lambda^f + q^h, with
!> lambda^f = lambda_bar + curl(omega) the particular field (div lambda^f = -f) and q^h the
!> equilibrium-element field given by the element matrices C_e and flux parameters beta_e
!> (Section 4).  Produced by dualsig_problem_dual_p2, read by the estimates and the output.
module dualsig_dual_p2_field
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_elements_equilibrium, only: equilibrium_field
  use dualsig_particular_field, only: particular_field_t, lambda_f_at
  implicit none
  private

  public :: dual_p2_field_t, dual_p2_lambda

  type :: dual_p2_field_t
    type(particular_field_t) :: pf          !! lambda^f
    real(dp), allocatable :: c(:,:,:)       !! (6, 6, ntri) C_e
    real(dp), allocatable :: beta(:,:)      !! (6, ntri) flux parameters of q^h
  end type dual_p2_field_t

contains

  !> lambda^h = lambda^f + q^h at the point with barycentric coordinates bary of triangle t.
  function dual_p2_lambda(field, mesh, f, t, bary) result(v)
    type(dual_p2_field_t), intent(in) :: field
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    integer, intent(in) :: t
    real(dp), intent(in) :: bary(3)
    real(dp) :: v(2)
    real(dp) :: p(2)
    p = matmul(mesh%xy(:, mesh%tri(:, t)), bary)
    v = lambda_f_at(field%pf, mesh, f, t, p(1), p(2)) + equilibrium_field(field%c(:, :, t), field%beta(:, t), bary)
  end function dual_p2_lambda
end module dualsig_dual_p2_field
