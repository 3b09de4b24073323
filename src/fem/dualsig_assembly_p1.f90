!> Global assembly of P1 matrices and load vectors into CSR storage.
!>
!> The pattern comes from the mesh edges (node i couples with its edge neighbours), so
!> assembly is linear in the number of triangles; element contributions are summed.
module dualsig_assembly_p1
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_quadrature, only: tri_rule_t
  use dualsig_elements_p1, only: p1_element_stiffness, p1_element_mass, p1_element_load
  use dualsig_sparse, only: csr_t, csr_pattern_from_edges, csr_add_block
  use dualsig_status, only: status_t
  use dualsig_alloc, only: has_failed
  implicit none
  private

  public :: assemble_stiffness, assemble_mass, assemble_p1_operator, assemble_load

contains

  !> Stiffness matrix K(i,j) = integral of grad(phi_i) . grad(phi_j)  (Section 2, A for P2).
  subroutine assemble_stiffness(mesh, k, st)
    type(mesh_t), intent(in) :: mesh
    type(csr_t), intent(out) :: k
    type(status_t), intent(out) :: st      !! out of memory (see dualsig_alloc)
    call assemble_p1_operator(mesh, 0.0_dp, k, st)
  end subroutine assemble_stiffness

  !> Mass matrix M(i,j) = integral of phi_i phi_j.
  subroutine assemble_mass(mesh, m, st)
    type(mesh_t), intent(in) :: mesh
    type(csr_t), intent(out) :: m
    type(status_t), intent(out) :: st      !! out of memory (see dualsig_alloc)
    real(dp) :: me(3, 3), xy(2, 3)
    integer :: t
    call csr_pattern_from_edges(mesh%nnode, mesh%edge_nodes, m, st)
    if (has_failed(st)) return
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_element_mass(xy, me)
      call csr_add_block(m, mesh%tri(:, t), me)
    end do
  end subroutine assemble_mass

  !> A = K + mass_coef * M: the matrix of the bilinear form (grad u, grad v) + c (u, v).
  !> P1 of the paper uses c = 1 (A_ij = (phi_i, phi_j)_1), P2 uses c = 0, in which case
  !> no mass matrix is computed.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine assemble_p1_operator(mesh, mass_coef, a, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: mass_coef
    type(csr_t), intent(out) :: a
    type(status_t), intent(out) :: st
    real(dp) :: ke(3, 3), me(3, 3), xy(2, 3)
    integer :: t
    call csr_pattern_from_edges(mesh%nnode, mesh%edge_nodes, a, st)
    if (has_failed(st)) return
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_element_stiffness(xy, ke)
      if (mass_coef /= 0.0_dp) then
        call p1_element_mass(xy, me)
        ke = ke + mass_coef * me
      end if
      call csr_add_block(a, mesh%tri(:, t), ke)
    end do
  end subroutine assemble_p1_operator

  !> Load vector F(j) = (f, phi_j)_0 with the quadrature `rule` on every triangle.
  subroutine assemble_load(mesh, f, rule, load)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(out) :: load(:)
    real(dp) :: fe(3), xy(2, 3)
    integer :: t
    load = 0.0_dp
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call p1_element_load(xy, f, rule, fe)
      load(mesh%tri(:, t)) = load(mesh%tri(:, t)) + fe
    end do
  end subroutine assemble_load
end module dualsig_assembly_p1
