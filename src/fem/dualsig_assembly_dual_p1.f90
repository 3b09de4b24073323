!> Assembly for the dual problem of P1 (Section 3): continuous piecewise-linear vector
!> fields q = (q1, q2) in [V_h]^2 and the functional (3.1')
!>
!>     I(q) = 1/2 (||q||_0^2 + ||div q||_0^2) + (f, div q)_0  =  1/2 y^T A y - b^T y,
!>
!> so A is the Gram matrix of ||q||^2 + ||div q||^2 and b_j = -(f, div w_j)  (3.3).
!>
!> Numbering of unknowns: node-interleaved, dof(i, c) = 2 (i - 1) + c for component
!> c = 1, 2 of q at node i.  Local element order: (node 1: c=1, c=2, node 2: ..., node 3: ...).
!>
!> Optionally a per-node 2x2 change of variables q(i) = T_i s(i) is applied while
!> assembling (A_hat = T^T A T, b_hat = T^T b), element by element; see
!> dualsig_problem_dual_p1 for the transforms that turn q.nu >= 0 into simple bounds.
module dualsig_assembly_dual_p1
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_quadrature, only: tri_rule_t
  use dualsig_elements_p1, only: p1_gradients, p1_element_mass
  use dualsig_sparse, only: csr_t, csr_pattern_from_edges, csr_add_block
  use dualsig_alloc, only: alloc_failed, has_failed, BYTES_INT
  use dualsig_status, only: status_t
  implicit none
  private

  public :: dual_p1_dof, dual_p1_element, assemble_dual_p1

contains

  !> Index of component c of q at node i.
  elemental integer function dual_p1_dof(i, c)
    integer, intent(in) :: i, c
    dual_p1_dof = 2 * (i - 1) + c
  end function dual_p1_dof

  !> Element Gram matrix ae (6x6) of ||q||^2 + ||div q||^2 and element vector be (6) of
  !> -(f, div w_j) on the triangle xy; f is integrated with `rule`.
  !> div q is constant on the triangle: div q = sum_a (g(1,a) q1(a) + g(2,a) q2(a)).
  subroutine dual_p1_element(xy, f, rule, ae, be)
    real(dp), intent(in) :: xy(2, 3)
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(out) :: ae(6, 6), be(6)
    real(dp) :: grad(2, 3), area, me(3, 3), d(6), p(2), fint
    integer :: a, b, c, q
    call p1_gradients(xy, grad, area)
    call p1_element_mass(xy, me)
    ae = 0.0_dp
    do a = 1, 3
      do b = 1, 3
        do c = 1, 2
          ae(2 * (a - 1) + c, 2 * (b - 1) + c) = me(a, b)
        end do
      end do
    end do
    do a = 1, 3
      d(2 * a - 1) = grad(1, a)
      d(2 * a) = grad(2, a)
    end do
    do a = 1, 6
      ae(:, a) = ae(:, a) + area * d(a) * d
    end do
    fint = 0.0_dp
    do q = 1, rule%n
      p = matmul(xy, rule%bary(:, q))
      fint = fint + rule%w(q) * f%value(p(1), p(2))
    end do
    be = -area * fint * d
  end subroutine dual_p1_element

  !> Assemble A (2N x 2N, CSR) and b (2N) of the dual problem of P1.  With `transform`
  !> (2, 2, nnode) the result is T^T A T and T^T b for q(i) = transform(:,:,i) s(i).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine assemble_dual_p1(mesh, f, rule, a, b, transform, st)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(csr_t), intent(out) :: a
    real(dp), intent(out) :: b(:)
    real(dp), intent(in), optional :: transform(:,:,:)
    type(status_t), intent(out) :: st
    integer, allocatable :: pairs(:,:)
    real(dp) :: ae(6, 6), be(6), te(6, 6), xy(2, 3)
    integer :: e, i, j, k, t, dofs(6), n, r, s, ist
    n = mesh%nnode
    ! pattern: the two components at a node, and all four pairs along every edge
    allocate (pairs(2, n + 4 * mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the pattern of the dual P1 matrix', 2 * (n + 4 * mesh%nedge), BYTES_INT)) return
    k = 0
    do i = 1, n
      k = k + 1
      pairs(:, k) = [dual_p1_dof(i, 1), dual_p1_dof(i, 2)]
    end do
    do e = 1, mesh%nedge
      i = mesh%edge_nodes(1, e)
      j = mesh%edge_nodes(2, e)
      do r = 1, 2
        do s = 1, 2
          k = k + 1
          pairs(:, k) = [dual_p1_dof(i, r), dual_p1_dof(j, s)]
        end do
      end do
    end do
    call csr_pattern_from_edges(2 * n, pairs, a, st)
    if (has_failed(st)) return
    b = 0.0_dp
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call dual_p1_element(xy, f, rule, ae, be)
      if (present(transform)) then
        te = 0.0_dp
        do k = 1, 3
          te(2 * k - 1:2 * k, 2 * k - 1:2 * k) = transform(:, :, mesh%tri(k, t))
        end do
        ae = matmul(transpose(te), matmul(ae, te))
        be = matmul(transpose(te), be)
      end if
      do k = 1, 3
        dofs(2 * k - 1:2 * k) = dual_p1_dof(mesh%tri(k, t), [1, 2])
      end do
      b(dofs) = b(dofs) + be
      call csr_add_block(a, dofs, ae)
    end do
  end subroutine assemble_dual_p1
end module dualsig_assembly_dual_p1
