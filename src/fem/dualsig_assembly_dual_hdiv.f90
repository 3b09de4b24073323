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
  use dualsig_sparse, only: csr_t, rect_t, sort_row_by_column, sort_small_ints
  use dualsig_elements_rt1, only: rt1_geometry_t, rt1_geometry, rt1_values, rt1_element, rt1_condense, &
                                  rt1_matrix_degree, rt1_nbasis, rt1_nside, rt1_reference_t, rt1_reference
  use dualsig_status, only: status_t
  use dualsig_load_data, only: load_data_t
  use dualsig_alloc, only: alloc_failed, has_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: hdiv_system_t, hdiv_element_t, hdiv_condensed_element, hdiv_load_values
  public :: hdiv_nside_dofs, hdiv_nfield, hdiv_side_dofs, hdiv_local_coefficients, &
            assemble_dual_hdiv, hdiv_recover, hdiv_dof_points, hdiv_point_value, &
            hdiv_bedge_dofs, hdiv_prolongate, hdiv_prolongate_interior, hdiv_prolongation_matrix

  !> Relative size below which an entry of the prolongation is a rounded zero: the exact
  !> values are O(1) multiples of the row's largest, the rounded zeros O(eps) of it.
  real(dp), parameter :: prolongation_zero = 64.0_dp * epsilon(1.0_dp)
  !> Red refinement (mesh_refine_uniform): the barycentric coordinates in the parent of its
  !> vertices a_1, a_2, a_3 and side midpoints m_1, m_2, m_3 (m_k on a_k a_{k+1}), points 1..6;
  !> the points that are the vertices of child c (its triangle 4 t - 4 + c); the centroids of
  !> the children.
  real(dp), parameter :: child_point(3, 6) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, &
    0.0_dp, 0.0_dp, 1.0_dp, 0.5_dp, 0.5_dp, 0.0_dp, 0.0_dp, 0.5_dp, 0.5_dp, 0.5_dp, 0.0_dp, 0.5_dp], [3, 6])
  integer, parameter :: child_vertex(3, 4) = reshape([1, 4, 6, 4, 2, 5, 6, 5, 3, 4, 5, 6], [3, 4])
  !> Ends of the fine edges inside a coarse triangle, at most (4 children, 3 sides, 2 ends).
  integer, parameter :: max_side_ends = 24
  real(dp), parameter :: child_centroid(3, 4) = reshape([4.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 4.0_dp, 1.0_dp, &
    1.0_dp, 1.0_dp, 4.0_dp, 2.0_dp, 2.0_dp, 2.0_dp], [3, 4]) / 6.0_dp

  !> The condensed system of one triangle (hdiv_condensed_element), in the global signs.
  type :: hdiv_element_t
    integer :: dofs(rt1_nside) = 0                 !! its side unknowns (hdiv_side_dofs)
    real(dp) :: se(rt1_nside, rt1_nside) = 0.0_dp  !! condensed matrix
    real(dp) :: ce(rt1_nside) = 0.0_dp             !! condensed right-hand side
    real(dp) :: rec_k(2, rt1_nside) = 0.0_dp       !! interior = rec_d - rec_k (side values)
    real(dp) :: rec_d(2) = 0.0_dp
    real(dp) :: shift = 0.0_dp                     !! its part of hdiv_system_t%shift
    real(dp) :: data_sq = 0.0_dp                   !! its part of hdiv_system_t%data_sq
    real(dp) :: osc_sq = 0.0_dp                    !! its part of hdiv_system_t%data_osc_sq
  end type hdiv_element_t

  !> The condensed system of the side unknowns and what recovers the interior ones.
  type :: hdiv_system_t
    type(csr_t) :: a                        !! (2 nedge) Schur complement of the Gram matrix
    real(dp), allocatable :: b(:)           !! (2 nedge) its right-hand side
    real(dp), allocatable :: rec_k(:,:,:)   !! (2, 6, ntri) interior = rec_d - rec_k (local side values)
    real(dp), allocatable :: rec_d(:,:)     !! (2, ntri)
    !> I(q) of (3.1') for the side unknowns xs (interior recovered) is
    !> 1/2 xs^T a xs - b^T xs + shift (shift = -1/2 sum_T b_I^T A_II^{-1} b_I of the condensation)
    real(dp) :: shift = 0.0_dp
    !> ||f - u||^2 + ||grad u||^2 with u the P1 field given to assemble_dual_hdiv (0
    !> without) and f as there: the data part of E of (1.10), for a stopping criterion
    real(dp) :: data_sq = 0.0_dp
    !> sum_T ||f - Pi_1 f||_T^2 (part of data_sq; 0 when f is sampled instead of given by its
    !> load data): a constant of E that the sharper bound weights by h_T/pi
    real(dp) :: data_osc_sq = 0.0_dp
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

  !> Assemble the condensed system: element matrices (exact) and vectors, interior unknowns
  !> eliminated per triangle; sys%data_sq with the P1 field u (optional, nnode; 0 without).
  !> f enters through its values at the points of `rule`: with `load` (optional, the load
  !> data of f on mesh) those of Pi_1 f, so that be = -(f, div psi_i) is exact (div psi_i
  !> is linear) and ||f - u||^2 = osc_T^2 + ||Pi_1 f - u||^2 too, without evaluating f;
  !> without it f itself.  With renumber (optional), the system's unknowns are the side
  !> unknowns in that numbering (sys%a, sys%b; rec_k and rec_d stay local to the triangles).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine assemble_dual_hdiv(mesh, f, rule, sys, st, u, load, renumber)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(hdiv_system_t), intent(out) :: sys
    type(status_t), intent(out) :: st
    real(dp), intent(in), optional :: u(:)
    type(load_data_t), intent(in), optional :: load
    !> (2 nedge) side unknown i of the field vector is unknown renumber(i) of the system
    integer, intent(in), optional :: renumber(:)
    type(rt1_reference_t) :: ref
    type(hdiv_element_t) :: el
    integer :: t, dofs(rt1_nside), ist
    call hdiv_pattern(mesh, sys%a, st, renumber)
    if (has_failed(st)) return
    allocate (sys%b(2 * mesh%nedge), sys%rec_k(2, rt1_nside, mesh%ntri), sys%rec_d(2, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the condensed RT1 system', 2 * mesh%nedge + (2 * rt1_nside + 2) * mesh%ntri, &
                     BYTES_REAL)) return
    sys%b = 0.0_dp
    ref = rt1_reference(tri_rule(rt1_matrix_degree))
    do t = 1, mesh%ntri
      call hdiv_condensed_element(mesh, t, f, rule, ref, el, u, load)
      sys%data_osc_sq = sys%data_osc_sq + el%osc_sq
      sys%data_sq = sys%data_sq + el%data_sq
      sys%shift = sys%shift + el%shift
      sys%rec_k(:, :, t) = el%rec_k
      sys%rec_d(:, t) = el%rec_d
      dofs = el%dofs
      if (present(renumber)) dofs = renumber(dofs)
      sys%b(dofs) = sys%b(dofs) + el%ce
      call add_element_rows(sys%a, dofs, el%se)
    end do
  end subroutine assemble_dual_hdiv

  !> The condensed system of triangle t, what assemble_dual_hdiv adds for it: the element
  !> matrix and vector of (3.1') (rt1_element, exact), the interior unknowns eliminated
  !> (rt1_condense), in the global signs of the side unknowns el%dofs (local = sgn *
  !> global: S = D S_loc D, c = D c_loc, rec_k D); its parts of shift, data_sq and
  !> data_osc_sq (hdiv_system_t).  f, rule, u and load as in assemble_dual_hdiv; ref =
  !> rt1_reference(tri_rule(rt1_matrix_degree)).
  subroutine hdiv_condensed_element(mesh, t, f, rule, ref, el, u, load)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: t
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(rt1_reference_t), intent(in) :: ref
    type(hdiv_element_t), intent(out) :: el
    real(dp), intent(in), optional :: u(:)
    type(load_data_t), intent(in), optional :: load
    type(rt1_geometry_t) :: g
    real(dp) :: ae(rt1_nbasis, rt1_nbasis), be(rt1_nbasis), sgn(rt1_nside), fq(rule%n), ue(3)
    integer :: i
    g = rt1_geometry(mesh%xy(:, mesh%tri(:, t)))
    call hdiv_load_values(mesh, t, f, rule, fq, load)
    el%osc_sq = 0.0_dp
    if (present(load)) el%osc_sq = load%osc(t)**2
    call rt1_element(g, fq, rule, ref, ae, be)
    ue = 0.0_dp
    if (present(u)) ue = u(mesh%tri(:, t))
    el%data_sq = el%osc_sq + g%area * (sum(matmul(g%grad, ue)**2) + sum(rule%w * (fq - matmul(ue, rule%bary))**2))
    call rt1_condense(ae, be, el%se, el%ce, el%rec_k, el%rec_d)
    el%shift = -0.5_dp * dot_product(be(7:8), el%rec_d)
    call hdiv_side_dofs(mesh, t, el%dofs, sgn)
    do i = 1, rt1_nside
      el%se(:, i) = sgn * el%se(:, i) * sgn(i)
      el%rec_k(:, i) = el%rec_k(:, i) * sgn(i)
    end do
    el%ce = sgn * el%ce
  end subroutine hdiv_condensed_element

  !> The values fq(1:rule%n) at the points of `rule` in triangle t of what the dual problem
  !> integrates as f (assemble_dual_hdiv): Pi_1 f from its load data `load` (optional), else
  !> f itself.
  subroutine hdiv_load_values(mesh, t, f, rule, fq, load)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: t
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    real(dp), intent(out) :: fq(:)
    type(load_data_t), intent(in), optional :: load
    real(dp) :: xy(2, 3), p(2), centroid(2)
    integer :: q
    xy = mesh%xy(:, mesh%tri(:, t))
    centroid = sum(xy, dim=2) / 3.0_dp
    do q = 1, rule%n
      p = matmul(xy, rule%bary(:, q))
      if (present(load)) then
        fq(q) = load%mean(t) + dot_product(load%slope(:, t), p - centroid)
      else
        fq(q) = f%value(p(1), p(2))
      end if
    end do
  end subroutine hdiv_load_values

  !> a(dofs, dofs) += se, every entry in the pattern (columns sorted in every row): the 6
  !> columns sorted once, then each row's entries found by one merge pass over the row
  !> (an entry outside the pattern, which hdiv_pattern does not leave, would be skipped).
  pure subroutine add_element_rows(a, dofs, se)
    type(csr_t), intent(inout) :: a
    integer, intent(in) :: dofs(rt1_nside)
    real(dp), intent(in) :: se(rt1_nside, rt1_nside)
    integer :: r, k, p, ds(rt1_nside), loc(rt1_nside), kl, last
    real(dp) :: pos(rt1_nside)
    ! the columns sorted, with their local positions (carried as exact small reals)
    ds = dofs
    pos = [(real(k, dp), k = 1, rt1_nside)]
    call sort_row_by_column(ds, pos)
    loc = nint(pos)
    do r = 1, rt1_nside
      p = a%rowptr(dofs(r))
      last = a%rowptr(dofs(r) + 1) - 1
      do k = 1, rt1_nside
        kl = ds(k)
        do while (p < last .and. a%col(p) /= kl)
          p = p + 1
        end do
        if (a%col(p) == kl) a%val(p) = a%val(p) + se(r, loc(k))
      end do
    end do
  end subroutine add_element_rows

  !> The pattern of the condensed system (values 0), built from the mesh: the row of a side
  !> unknown of edge e has the columns of the side unknowns of the triangles at e (e's own
  !> two and the two other edges' of each triangle: 10 in the interior, 6 on the
  !> boundary), the union of the element cliques at it.  renumber (optional) as in
  !> assemble_dual_hdiv.  Out of memory: DS_ERR_MEMORY in st.
  subroutine hdiv_pattern(mesh, a, st, renumber)
    type(mesh_t), intent(in) :: mesh
    type(csr_t), intent(out) :: a
    type(status_t), intent(inout) :: st
    integer, intent(in), optional :: renumber(:)
    integer, parameter :: max_row = 2 + 4 * 2
    integer :: row(max_row), e, j, k, side, t, ee, i, len, nnz, ist, r
    a%n = 2 * mesh%nedge
    allocate (a%rowptr(a%n + 1), a%diag(a%n), stat=ist)
    if (alloc_failed(ist, st, 'the rows of the condensed RT1 system', 2 * a%n + 1, BYTES_INT)) return
    a%rowptr(1) = 1
    a%rowptr(2:) = 0
    do e = 1, mesh%nedge
      len = merge(max_row, max_row - 4, mesh%edge_tri(2, e) /= 0)
      do j = 1, 2
        a%rowptr(row_of(2 * (e - 1) + j) + 1) = len
      end do
    end do
    do r = 1, a%n
      a%rowptr(r + 1) = a%rowptr(r + 1) + a%rowptr(r)
    end do
    nnz = a%rowptr(a%n + 1) - 1
    allocate (a%col(nnz), a%val(nnz), stat=ist)
    if (alloc_failed(ist, st, 'the entries of the condensed RT1 system', 3 * nnz, BYTES_INT)) return
    a%val = 0.0_dp
    do e = 1, mesh%nedge
      len = 2
      row(1:2) = [2 * e - 1, 2 * e]
      do side = 1, 2
        t = mesh%edge_tri(side, e)
        if (t == 0) cycle
        do k = 1, 3
          ee = mesh%tri_edge(k, t)
          if (ee == e) cycle
          row(len + 1:len + 2) = [2 * ee - 1, 2 * ee]
          len = len + 2
        end do
      end do
      if (present(renumber)) row(1:len) = renumber(row(1:len))
      call sort_small_ints(row(1:len))
      do j = 1, 2
        r = row_of(2 * (e - 1) + j)
        a%col(a%rowptr(r):a%rowptr(r) + len - 1) = row(1:len)
        do i = a%rowptr(r), a%rowptr(r) + len - 1
          if (a%col(i) == r) a%diag(r) = i
        end do
      end do
    end do
  contains
    pure integer function row_of(i)
      integer, intent(in) :: i
      row_of = i
      if (present(renumber)) row_of = renumber(i)
    end function row_of
  end subroutine hdiv_pattern

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

  !> The RT1 field xc (hdiv_nfield of coarse) as a field xf of the mesh fine obtained from
  !> coarse by mesh_refine_uniform (the children of coarse triangle t are 4t-3 .. 4t): RT1
  !> spaces are nested under red refinement, so this is exact.  Side unknowns: the coarse
  !> field of the parent, evaluated at the fine edge's ends, times the fine edge's normal
  !> (on a fine edge inside a coarse edge the normal trace is the same from both sides);
  !> interior unknowns: matched to the coarse field's value at the child's centroid.
  pure subroutine hdiv_prolongate(coarse, fine, xc, xf, sides_only)
    type(mesh_t), intent(in) :: coarse, fine
    real(dp), intent(in) :: xc(:)
    real(dp), intent(out) :: xf(:)
    !> only the side unknowns (xf's interior ones left 0), for a caller that recovers the
    !> interior ones itself (optional, default .false.)
    logical, intent(in), optional :: sides_only
    type(rt1_geometry_t) :: gc
    real(dp) :: c(rt1_nbasis), psi(2, rt1_nbasis), dpsi(rt1_nbasis), qp(2, 6), nus(2, max_side_ends)
    integer :: tc, k, ip, m, rows(max_side_ends), pts(max_side_ends)
    xf = 0.0_dp
    do tc = 1, coarse%ntri
      ! per coarse triangle: the field at its vertices and side midpoints (child_point), the
      ! ends of every fine edge inside it
      gc = rt1_geometry(coarse%xy(:, coarse%tri(:, tc)))
      c = hdiv_local_coefficients(coarse, xc, tc)
      do ip = 1, 6
        call rt1_values(gc, child_point(:, ip), psi, dpsi)
        qp(:, ip) = matmul(psi, c)
      end do
      call child_side_ends(fine, tc, rows, pts, nus, m)
      do k = 1, m
        xf(rows(k)) = dot_product(nus(:, k), qp(:, pts(k)))
      end do
    end do
    if (present(sides_only)) then
      if (sides_only) return
    end if
    call hdiv_prolongate_interior(coarse, fine, xc, xf)
  end subroutine hdiv_prolongate

  !> The interior unknowns of hdiv_prolongate: xf's side unknowns given, the interior ones
  !> matched to the coarse field xc at the centroid of every fine triangle.  Per coarse
  !> triangle: its geometry and coefficients once, the centroids of its children at their
  !> fixed barycentric coordinates (child_centroid).
  pure subroutine hdiv_prolongate_interior(coarse, fine, xc, xf)
    type(mesh_t), intent(in) :: coarse, fine
    real(dp), intent(in) :: xc(:)
    real(dp), intent(inout) :: xf(:)
    type(rt1_geometry_t) :: gc, gf
    real(dp) :: c(rt1_nbasis), cf(rt1_nbasis), psi(2, rt1_nbasis), dpsi(rt1_nbasis), q(2)
    real(dp) :: m(2, 2), det
    integer :: tf, tc, n, ch
    do tc = 1, coarse%ntri
      gc = rt1_geometry(coarse%xy(:, coarse%tri(:, tc)))
      c = hdiv_local_coefficients(coarse, xc, tc)
      do ch = 1, 4
        tf = 4 * tc - 4 + ch
        call rt1_values(gc, child_centroid(:, ch), psi, dpsi)
        q = matmul(psi, c)
        gf = rt1_geometry(fine%xy(:, fine%tri(:, tf)))
        n = 2 * fine%nedge + 2 * tf
        xf(n - 1:n) = 0.0_dp
        cf = hdiv_local_coefficients(fine, xf, tf)
        call rt1_values(gf, [1.0_dp, 1.0_dp, 1.0_dp] / 3.0_dp, psi, dpsi)
        ! q - (side part) = c7 psi_7 + c8 psi_8 at the centroid: a 2x2 system
        q = q - matmul(psi(:, 1:6), cf(1:6))
        m = psi(:, 7:8)
        det = m(1, 1) * m(2, 2) - m(1, 2) * m(2, 1)
        xf(n - 1) = (m(2, 2) * q(1) - m(1, 2) * q(2)) / det
        xf(n) = (m(1, 1) * q(2) - m(2, 1) * q(1)) / det
      end do
    end do
  end subroutine hdiv_prolongate_interior

  !> The outward unit normal of triangle t of mesh on its side k (a_k a_{k+1},
  !> counter-clockwise): the nu_e of the edge when t = edge_tri(1, e).
  pure function side_normal(mesh, t, k) result(nu)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: t, k
    real(dp) :: nu(2), d(2)
    d = mesh%xy(:, mesh%tri(mod(k, 3) + 1, t)) - mesh%xy(:, mesh%tri(k, t))
    nu = [d(2), -d(1)] / hypot(d(1), d(2))
  end function side_normal

  !> The prolongation of side unknowns from coarse to its uniform refinement fine, as a
  !> (2 fine%nedge) x (2 coarse%nedge) matrix p: the coarse field of side unknowns xs with
  !> its interior unknowns -rec_k xs (the homogeneous condensation of the coarse level,
  !> hdiv_system_t%rec_k), prolongated as in hdiv_prolongate, side unknowns kept.  A row
  !> depends on the 6 side unknowns of the parent triangle; built row by row (columns
  !> sorted), without the entries that vanish exactly (a fine edge inside a coarse
  !> side sees only that side's 2 unknowns: the others have zero normal trace there, and
  !> their computed values, rounding of 0, are below prolongation_zero).
  !> With xc (hdiv_nfield of coarse) and xf (of fine): also the side unknowns of
  !> hdiv_prolongate of xc in xf, from the same basis values (hdiv_prolongate_interior
  !> completes xf).  Out of memory: DS_ERR_MEMORY in st (without st the program stops, see
  !> dualsig_alloc).
  subroutine hdiv_prolongation_matrix(coarse, fine, rec_k, p, st, xc, xf, row_perm, col_perm)
    type(mesh_t), intent(in) :: coarse, fine
    real(dp), intent(in) :: rec_k(:,:,:)
    type(rect_t), intent(out) :: p
    type(status_t), intent(inout) :: st
    real(dp), intent(in), optional :: xc(:)
    real(dp), intent(inout), optional :: xf(:)
    !> (2 fine%nedge, 2 coarse%nedge) the numberings of the levels' matrices: fine side
    !> unknown i is row row_perm(i) of p, coarse side unknown j column col_perm(j)
    integer, intent(in), optional :: row_perm(:), col_perm(:)
    type(rt1_geometry_t) :: gc
    real(dp) :: psi(2, rt1_nbasis, 6), dpsi(rt1_nbasis), w(rt1_nbasis), sgn(rt1_nside), nus(2, max_side_ends)
    real(dp) :: v(rt1_nside), c(rt1_nbasis), pos(rt1_nside), big
    integer :: tc, k, cdofs(rt1_nside), order(rt1_nside), sorted(rt1_nside), i, row, ist, ip, m
    integer :: pass, q, rows(max_side_ends), pts(max_side_ends)
    logical :: fill
    p%m = 2 * fine%nedge
    p%n = 2 * coarse%nedge
    allocate (p%rowptr(p%m + 1), stat=ist)
    if (alloc_failed(ist, st, 'the RT1 prolongation', p%m + 1, BYTES_INT)) return
    p%rowptr = 0
    ! pass 1 counts the entries of every row (p%rowptr(row + 1)), pass 2 stores them: the
    ! arrays are allocated at their size, and the rows are computed twice (cheaper than
    ! touching memory of 6 entries per row on this kind of machine: doc/performance.md)
    do pass = 1, 2
      fill = pass == 2
      if (fill) then
        p%rowptr(1) = 1
        do row = 1, p%m
          p%rowptr(row + 1) = p%rowptr(row + 1) + p%rowptr(row)
        end do
        allocate (p%col(p%rowptr(p%m + 1) - 1), p%val(p%rowptr(p%m + 1) - 1), stat=ist)
        if (alloc_failed(ist, st, 'the RT1 prolongation', 3 * (p%rowptr(p%m + 1) - 1), BYTES_INT)) return
      end if
      do tc = 1, coarse%ntri
        ! per coarse triangle: the basis at its vertices and side midpoints (the ends of every
        ! fine edge inside it), its unknowns in increasing order (the columns of its rows)
        gc = rt1_geometry(coarse%xy(:, coarse%tri(:, tc)))
        call hdiv_side_dofs(coarse, tc, cdofs, sgn)
        if (present(col_perm)) cdofs = col_perm(cdofs)
        ! the permutation that sorts cdofs (the positions carried along as exact small reals)
        sorted = cdofs
        pos = [(real(i, dp), i = 1, rt1_nside)]
        call sort_row_by_column(sorted, pos)
        order = nint(pos)
        do ip = 1, 6
          call rt1_values(gc, child_point(:, ip), psi(:, :, ip), dpsi)
        end do
        if (fill .and. present(xc)) c = hdiv_local_coefficients(coarse, xc, tc)
        call child_side_ends(fine, tc, rows, pts, nus, m)
        do k = 1, m
          w = matmul(nus(:, k), psi(:, :, pts(k)))
          if (fill .and. present(xc) .and. present(xf)) xf(rows(k)) = dot_product(w, c)
          do i = 1, rt1_nside
            v(i) = w(i) * sgn(i) - dot_product(w(7:8), rec_k(:, i, tc))
          end do
          v = v(order)
          row = rows(k)
          if (present(row_perm)) row = row_perm(row)
          ! without the entries that are rounded zeros
          big = maxval(abs(v))
          if (.not. fill) then
            p%rowptr(row + 1) = count(abs(v) > prolongation_zero * big)
            cycle
          end if
          q = p%rowptr(row)
          do i = 1, rt1_nside
            if (.not. abs(v(i)) > prolongation_zero * big) cycle
            p%col(q) = cdofs(order(i))
            p%val(q) = v(i)
            q = q + 1
          end do
        end do
      end do
    end do
  end subroutine hdiv_prolongation_matrix

  !> The ends of the fine edges inside coarse triangle tc (its children 4tc-3 .. 4tc, each
  !> edge once: from the child that is its edge_tri(1, e)): m of them, end j of edge e as
  !> the fine side unknown rows(k) = 2e - 2 + j, its point pts(k) of the parent (child_point:
  !> vertex k or k+1 of the child) and the fine edge's normal nus(:, k).
  pure subroutine child_side_ends(fine, tc, rows, pts, nus, m)
    type(mesh_t), intent(in) :: fine
    integer, intent(in) :: tc
    integer, intent(out) :: rows(max_side_ends), pts(max_side_ends), m
    real(dp), intent(out) :: nus(2, max_side_ends)
    integer :: ch, tf, k, e, j
    m = 0
    do ch = 1, 4
      tf = 4 * tc - 4 + ch
      do k = 1, 3
        e = fine%tri_edge(k, tf)
        if (fine%edge_tri(1, e) /= tf) cycle
        do j = 1, 2
          m = m + 1
          rows(m) = 2 * e - 2 + j
          pts(m) = child_vertex(merge(k, mod(k, 3) + 1, fine%edge_nodes(j, e) == fine%tri(k, tf)), ch)
          nus(:, m) = side_normal(fine, tf, k)
        end do
      end do
    end do
  end subroutine child_side_ends
end module dualsig_assembly_dual_hdiv
