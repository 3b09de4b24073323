!> Element routines for continuous piecewise-quadratic (P2) functions on a triangle of a mesh.
!>
!> Local order of the six values: the vertices a_1, a_2, a_3 (counter-clockwise), then the
!> midpoints of the edges a_1 a_2, a_2 a_3, a_3 a_1 (the mesh's local edges 1, 2, 3); the
!> global numbering of the P2 values of a mesh is its vertices 1..nnode, then the edge
!> midpoints nnode + e.  Basis: vertex i lambda_i (2 lambda_i - 1), edge i (vertices i, i+1)
!> 4 lambda_i lambda_(i+1), lambda the barycentric coordinates.
module dualsig_elements_p2
  use dualsig_kinds, only: dp
  use dualsig_mesh, only: mesh_t
  implicit none
  private

  public :: p2_dofs, p2_element_stiffness

contains

  !> The P2 values of triangle t: its vertices, then the midpoints of its edges (edge i from
  !> vertex i to vertex i + 1).
  pure function p2_dofs(mesh, t) result(cl)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: t
    integer :: cl(6)
    cl(1:3) = mesh%tri(:, t)
    cl(4:6) = mesh%nnode + mesh%tri_edge(:, t)
  end function p2_dofs

  !> The P2 element stiffness matrix int grad phi_i . grad phi_j of the triangle xy (local
  !> order of p2_dofs; the edge-midpoint rule is exact for the quadratic integrands).
  pure subroutine p2_element_stiffness(xy, ke)
    real(dp), intent(in) :: xy(2, 3)
    real(dp), intent(out) :: ke(6, 6)
    real(dp), parameter :: lam(3, 3) = reshape([0.5_dp, 0.5_dp, 0.0_dp, 0.0_dp, 0.5_dp, 0.5_dp, 0.5_dp, 0.0_dp, &
                                                0.5_dp], [3, 3])   ! barycentrics of the edge midpoints
    real(dp) :: gl(2, 3), area, gr(2, 6, 3)
    integer :: q, i, j
    area = 0.5_dp * ((xy(1, 2) - xy(1, 1)) * (xy(2, 3) - xy(2, 1)) - (xy(1, 3) - xy(1, 1)) * (xy(2, 2) - xy(2, 1)))
    do i = 1, 3
      j = mod(i, 3) + 1
      q = mod(j, 3) + 1
      gl(:, i) = [xy(2, j) - xy(2, q), xy(1, q) - xy(1, j)] / (2 * area)
    end do
    ! P2 basis: vertex i lambda_i (2 lambda_i - 1), edge i (vertices i, i+1) 4 lambda_i lambda_(i+1)
    do q = 1, 3
      do i = 1, 3
        j = mod(i, 3) + 1
        gr(:, i, q) = (4 * lam(i, q) - 1) * gl(:, i)
        gr(:, 3 + i, q) = 4 * (lam(j, q) * gl(:, i) + lam(i, q) * gl(:, j))
      end do
    end do
    ke = 0.0_dp
    do q = 1, 3
      do j = 1, 6
        do i = 1, 6
          ke(i, j) = ke(i, j) + area / 3 * dot_product(gr(:, i, q), gr(:, j, q))
        end do
      end do
    end do
  end subroutine p2_element_stiffness
end module dualsig_elements_p2
