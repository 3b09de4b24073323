!> Assembly for the dual problem of P1 (Section 3) in the H(div)-conforming space RT1
!> (dualsig_elements_rt1): minimise the functional (3.1')
!>
!>     I(q) = 1/2 (||q||_0^2 + ||div q||_0^2) + (f, div q)_0
!>
!> over q in RT1 with q.nu >= 0 on Gamma.  lambda_3 = f + div q is eliminated as in (3.1'),
!> so the problem is an SPD quadratic programme in the degrees of freedom of q alone.
!>
!> Global unknowns (the field vector x):
!> - x(2 (e-1) + j), j = 1, 2: the normal trace q.nu_e at the end node edge_nodes(j, e) of
!>   edge e, with nu_e the outward normal of the triangle edge_tri(1, e).  On a boundary
!>   edge nu_e is the outward normal of Omega, so q.nu >= 0 on that edge holds exactly when
!>   both of its unknowns are >= 0 (the trace is linear): simple bounds.
!> - x(2 nedge + 2 (t-1) + m), m = 1, 2: the interior unknowns of triangle t.
!> A triangle sees its side unknowns with the sign +1 when it is edge_tri(1, e) and -1
!> otherwise (outward normal flux of the triangle).
!>
!> The interior unknowns are free and local to a triangle, so they are eliminated element
!> by element: the assembled system is the Schur complement on the 2 nedge side unknowns,
!> one 6x6 block per triangle; hdiv_recover gives the interior unknowns back.
module dualsig_assembly_dual_hdiv
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_quadrature, only: tri_rule_t, tri_rule
  use dualsig_sparse, only: csr_t, csr_pattern_from_cliques, csr_add_block
  use dualsig_elements_rt1, only: rt1_geometry_t, rt1_geometry, rt1_values, rt1_element, rt1_condense, &
                                  rt1_matrix_degree, rt1_nbasis, rt1_nside
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, has_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: hdiv_system_t, hdiv_nside_dofs, hdiv_nfield, hdiv_side_dofs, hdiv_local_coefficients, &
            assemble_dual_hdiv, hdiv_recover, hdiv_dof_points, hdiv_point_value, &
            hdiv_bedge_dofs

  !> The condensed system of the side unknowns and what recovers the interior ones.
  type :: hdiv_system_t
    type(csr_t) :: a                        !! (2 nedge) Schur complement of the Gram matrix
    real(dp), allocatable :: b(:)           !! (2 nedge) its right-hand side
    real(dp), allocatable :: rec_k(:,:,:)   !! (2, 6, ntri) interior = rec_d - rec_k (local side values)
    real(dp), allocatable :: rec_d(:,:)     !! (2, ntri)
  end type hdiv_system_t

contains

  !> Number of side unknowns (2 per edge).
  pure integer function hdiv_nside_dofs(mesh)
    type(mesh_t), intent(in) :: mesh
    hdiv_nside_dofs = 2 * mesh%nedge
  end function hdiv_nside_dofs

  !> Length of the field vector (side and interior unknowns).
  pure integer function hdiv_nfield(mesh)
    type(mesh_t), intent(in) :: mesh
    hdiv_nfield = 2 * mesh%nedge + 2 * mesh%ntri
  end function hdiv_nfield

  !> The global side unknowns of the local basis functions 1..6 of triangle t and their
  !> signs (local coefficient = sgn * global unknown).
  pure subroutine hdiv_side_dofs(mesh, t, dofs, sgn)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: t
    integer, intent(out) :: dofs(rt1_nside)
    real(dp), intent(out) :: sgn(rt1_nside)
    integer :: k, k1, e, j
    do k = 1, 3
      k1 = mod(k, 3) + 1
      e = mesh%tri_edge(k, t)
      j = merge(1, 2, mesh%edge_nodes(1, e) == mesh%tri(k, t))
      dofs(2 * k - 1) = 2 * (e - 1) + j
      dofs(2 * k) = 2 * (e - 1) + 3 - j
      sgn(2 * k - 1:2 * k) = merge(1.0_dp, -1.0_dp, mesh%edge_tri(1, e) == t)
    end do
  end subroutine hdiv_side_dofs

  !> The two unknowns of boundary edge j (listed boundary edge): dofs(1) at its first node
  !> bedge_nodes(1, j), dofs(2) at its second; both are q.nu with the outward normal.
  pure subroutine hdiv_bedge_dofs(mesh, j, dofs)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: j
    integer, intent(out) :: dofs(2)
    integer :: e
    e = mesh%bedge_edge(j)
    if (mesh%edge_nodes(1, e) == mesh%bedge_nodes(1, j)) then
      dofs = [2 * e - 1, 2 * e]
    else
      dofs = [2 * e, 2 * e - 1]
    end if
  end subroutine hdiv_bedge_dofs

  !> The 8 local coefficients of triangle t (basis of dualsig_elements_rt1) from the field x.
  pure function hdiv_local_coefficients(mesh, x, t) result(c)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: x(:)
    integer, intent(in) :: t
    real(dp) :: c(rt1_nbasis)
    integer :: dofs(rt1_nside)
    real(dp) :: sgn(rt1_nside)
    call hdiv_side_dofs(mesh, t, dofs, sgn)
    c(1:6) = sgn * x(dofs)
    c(7:8) = x(2 * mesh%nedge + 2 * t - 1:2 * mesh%nedge + 2 * t)
  end function hdiv_local_coefficients

  !> Assemble the condensed system: element matrices (exact) and vectors (f with `rule`),
  !> interior unknowns eliminated per triangle.  Out of memory: DS_ERR_MEMORY in st
  !> (without st the program stops, see dualsig_alloc).
  subroutine assemble_dual_hdiv(mesh, f, rule, sys, st)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(hdiv_system_t), intent(out) :: sys
    type(status_t), intent(out), optional :: st
    integer, allocatable :: cliques(:,:)
    type(tri_rule_t) :: exact_rule
    type(rt1_geometry_t) :: g
    real(dp) :: ae(rt1_nbasis, rt1_nbasis), be(rt1_nbasis), se(rt1_nside, rt1_nside), ce(rt1_nside)
    real(dp) :: sgn(rt1_nside)
    integer :: t, i, dofs(rt1_nside), ist
    allocate (cliques(rt1_nside, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the RT1 element unknowns', rt1_nside * mesh%ntri, BYTES_INT)) return
    do t = 1, mesh%ntri
      call hdiv_side_dofs(mesh, t, cliques(:, t), sgn)
    end do
    call csr_pattern_from_cliques(2 * mesh%nedge, cliques, sys%a, st)
    if (has_failed(st)) return
    allocate (sys%b(2 * mesh%nedge), sys%rec_k(2, rt1_nside, mesh%ntri), sys%rec_d(2, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the condensed RT1 system', 2 * mesh%nedge + (2 * rt1_nside + 2) * mesh%ntri, &
                     BYTES_REAL)) return
    sys%b = 0.0_dp
    exact_rule = tri_rule(rt1_matrix_degree)
    do t = 1, mesh%ntri
      g = rt1_geometry(mesh%xy(:, mesh%tri(:, t)))
      call rt1_element(g, f, rule, exact_rule, ae, be)
      call rt1_condense(ae, be, se, ce, sys%rec_k(:, :, t), sys%rec_d(:, t))
      call hdiv_side_dofs(mesh, t, dofs, sgn)
      ! local = sgn * global: S_global = D S D, c_global = D c, rec_k D
      do i = 1, rt1_nside
        se(:, i) = sgn * se(:, i) * sgn(i)
        sys%rec_k(:, i, t) = sys%rec_k(:, i, t) * sgn(i)
      end do
      sys%b(dofs) = sys%b(dofs) + sgn * ce
      call csr_add_block(sys%a, dofs, se)
    end do
  end subroutine assemble_dual_hdiv

  !> The field vector (hdiv_nfield) from the side unknowns xs (2 nedge): the interior
  !> unknowns of every triangle from its condensation.
  pure subroutine hdiv_recover(mesh, sys, xs, x)
    type(mesh_t), intent(in) :: mesh
    type(hdiv_system_t), intent(in) :: sys
    real(dp), intent(in) :: xs(:)
    real(dp), intent(out) :: x(:)
    integer :: t, dofs(rt1_nside), n
    real(dp) :: sgn(rt1_nside)
    n = 2 * mesh%nedge
    x(1:n) = xs(1:n)
    do t = 1, mesh%ntri
      call hdiv_side_dofs(mesh, t, dofs, sgn)
      x(n + 2 * t - 1:n + 2 * t) = sys%rec_d(:, t) - matmul(sys%rec_k(:, :, t), xs(dofs))
    end do
  end subroutine hdiv_recover

  !> A point per side unknown (the midpoint of its edge), for the geometric ordering.
  pure subroutine hdiv_dof_points(mesh, xy)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(out) :: xy(:,:)
    integer :: e
    do e = 1, mesh%nedge
      xy(:, 2 * e - 1) = 0.5_dp * (mesh%xy(:, mesh%edge_nodes(1, e)) + mesh%xy(:, mesh%edge_nodes(2, e)))
      xy(:, 2 * e) = xy(:, 2 * e - 1)
    end do
  end subroutine hdiv_dof_points

  !> q at the point with barycentric coordinates bary in triangle t (from inside t).
  pure function hdiv_point_value(mesh, x, t, bary) result(q)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: x(:)
    integer, intent(in) :: t
    real(dp), intent(in) :: bary(3)
    real(dp) :: q(2)
    type(rt1_geometry_t) :: g
    real(dp) :: psi(2, rt1_nbasis), dpsi(rt1_nbasis)
    g = rt1_geometry(mesh%xy(:, mesh%tri(:, t)))
    call rt1_values(g, bary, psi, dpsi)
    q = matmul(psi, hdiv_local_coefficients(mesh, x, t))
  end function hdiv_point_value
end module dualsig_assembly_dual_hdiv
