!> Assembly for the equilibrium elements of the P2 dual (Section 4, (4.5)-(4.10)).
!>
!> Two parametrisations of the same space:
!> - element parameters beta (6 per triangle, index 6 (t - 1) + k, convention of
!>   dualsig_elements_equilibrium), constrained by D beta = 0 -- one divergence row (4.9)
!>   per triangle and two continuity rows (4.10) per interior edge -- and E beta >= e on
!>   Gamma_a (two rows per Gamma_a edge); A is block diagonal (the A_e).  This is the
!>   paper's formulation, solved by plain Uzawa.
!> - global edge-end fluxes x: for edge e with end nodes n1 < n2 (edge_nodes) and the
!>   reference normal n_e = outward normal of the triangle edge_tri(1, e), unknown
!>   2 (e - 1) + j is q.n_e at node n_j.  A triangle's parameter is beta_k = sgn * x(dof)
!>   with sgn = +1 in edge_tri(1, e) and -1 in its neighbour, so the continuity rows
!>   (4.10) hold by construction (the space is BDM1).  What remains is D x = 0 (one
!>   divergence row per triangle) and simple bounds x >= g_h on the Gamma_a unknowns
!>   (on a boundary edge n_e is the outward normal).
module dualsig_assembly_equilibrium
  use, intrinsic :: iso_fortran_env, only: int8
  use dualsig_kinds, only: dp, i8
  use dualsig_mesh, only: mesh_t
  use dualsig_sparse, only: csr_t, rect_t, csr_pattern_from_cliques, csr_add_block, rect_from_triplets
  use dualsig_elements_equilibrium, only: param_side, param_vertex, equilibrium_c_matrix, &
                                          equilibrium_element_matrix, equilibrium_div_row, &
                                          equilibrium_field_xy, equilibrium_sides, equilibrium_c_of_normals
  use dualsig_qp_types, only: ROW_EQUALITY, ROW_INEQUALITY
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_alloc, only: alloc_failed, has_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: equilibrium_map_t, equilibrium_map, equilibrium_elements, assemble_equilibrium_global, &
            equilibrium_to_global, equilibrium_to_local, equilibrium_div_rows_global, &
            equilibrium_rows_local, equilibrium_gamma_a_dofs, equilibrium_div_coefficients, &
            equilibrium_prolongate_bisection

  type :: equilibrium_map_t
    integer :: ntri = 0
    integer :: nedge = 0
    integer, allocatable :: dof(:,:)     !! (6, ntri) global unknown of local parameter k
    !> (6, ntri) beta_k = sgn * x(dof), +1 or -1 (one byte each: the map is held beside
    !> the per-triangle fields of a 10^6-triangle mesh)
    integer(int8), allocatable :: sgn(:,:)
  end type equilibrium_map_t

contains

  !> The map from element parameters to global edge-end fluxes.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine equilibrium_map(mesh, map, st)
    type(mesh_t), intent(in) :: mesh
    type(equilibrium_map_t), intent(out) :: map
    type(status_t), intent(out) :: st
    integer :: t, k, e, node, jend, ist
    map%ntri = mesh%ntri
    map%nedge = mesh%nedge
    allocate (map%dof(6, mesh%ntri), map%sgn(6, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the equilibrium element map', 8_i8 * mesh%ntri, BYTES_INT)) return
    do t = 1, mesh%ntri
      do k = 1, 6
        e = mesh%tri_edge(param_side(k), t)
        node = mesh%tri(param_vertex(k), t)
        jend = merge(1, 2, node == mesh%edge_nodes(1, e))
        map%dof(k, t) = 2 * (e - 1) + jend
        map%sgn(k, t) = merge(1_int8, -1_int8, mesh%edge_tri(1, e) == t)
      end do
    end do
  end subroutine equilibrium_map

  !> Per element: C_e, A_e (4.6) and the divergence row d_e (4.9).
  subroutine equilibrium_elements(mesh, c, ae, d, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), allocatable, intent(out) :: c(:,:,:), ae(:,:,:), d(:,:)
    type(status_t), intent(out) :: st
    real(dp) :: xy(2, 3)
    integer :: t, ist
    allocate (c(6, 6, mesh%ntri), ae(6, 6, mesh%ntri), d(6, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the equilibrium element matrices', 78_i8 * mesh%ntri, BYTES_REAL)) return
    do t = 1, mesh%ntri
      xy = mesh%xy(:, mesh%tri(:, t))
      call equilibrium_c_matrix(xy, c(:, :, t), st)
      if (st%code /= 0) return
      call equilibrium_element_matrix(xy, c(:, :, t), ae(:, :, t))
      call equilibrium_div_row(xy, d(:, t))
    end do
  end subroutine equilibrium_elements

  !> The divergence rows d(6, ntri) of (4.9) alone, each triangle checked as
  !> equilibrium_elements checks it (C_e^{-1} not singular); for the solvers that need
  !> neither C_e nor A_e stored (the fields compute C_e where they are evaluated).
  subroutine equilibrium_div_coefficients(mesh, d, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), allocatable, intent(out) :: d(:,:)
    type(status_t), intent(out) :: st
    real(dp) :: c(6, 6), nu(2, 3), l(3)
    integer :: t, ist
    allocate (d(6, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the divergence rows', 6_i8 * mesh%ntri, BYTES_REAL)) return
    do t = 1, mesh%ntri
      call equilibrium_sides(mesh%xy(:, mesh%tri(:, t)), nu, l)   ! once for the check and the row
      call equilibrium_c_of_normals(nu, c, st)
      if (st%code /= 0) return
      d(:, t) = 0.5_dp * l(param_side)                            ! (equilibrium_div_row)
    end do
  end subroutine equilibrium_div_coefficients

  !> A = sum_e P_e^T A_e P_e in the global edge-end unknowns (2 nedge), CSR.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine assemble_equilibrium_global(map, ae, a, st)
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: ae(:,:,:)
    type(csr_t), intent(out) :: a
    type(status_t), intent(out) :: st
    real(dp) :: blk(6, 6)
    integer :: t, r, s
    call csr_pattern_from_cliques(2 * map%nedge, map%dof, a, st)
    if (has_failed(st)) return
    do t = 1, map%ntri
      do r = 1, 6
        do s = 1, 6
          blk(r, s) = map%sgn(r, t) * map%sgn(s, t) * ae(r, s, t)
        end do
      end do
      call csr_add_block(a, map%dof(:, t), blk)
    end do
  end subroutine assemble_equilibrium_global

  !> Global load b_x = sum_e P_e^T b_e from the element loads be(6, ntri).
  pure subroutine equilibrium_to_global(map, be, bx)
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: be(:,:)
    real(dp), intent(out) :: bx(:)
    integer :: t, k
    bx = 0.0_dp
    do t = 1, map%ntri
      do k = 1, 6
        bx(map%dof(k, t)) = bx(map%dof(k, t)) + map%sgn(k, t) * be(k, t)
      end do
    end do
  end subroutine equilibrium_to_global

  !> Element parameters beta(6, ntri) of the global fluxes x.
  pure subroutine equilibrium_to_local(map, x, beta)
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: x(:)
    real(dp), intent(out) :: beta(:,:)
    integer :: t
    do t = 1, map%ntri
      beta(:, t) = map%sgn(:, t) * x(map%dof(:, t))
    end do
  end subroutine equilibrium_to_local

  !> The divergence rows (4.9) in the global unknowns: row t is sum_k d_k sgn_k x(dof_k).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine equilibrium_div_rows_global(map, d, dmat, st)
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: d(:,:)
    type(rect_t), intent(out) :: dmat
    type(status_t), intent(out) :: st
    integer :: t, ist
    integer, allocatable :: r(:), c(:)
    real(dp), allocatable :: v(:)
    allocate (r(6 * map%ntri), c(6 * map%ntri), v(6 * map%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the divergence rows', 24_i8 * map%ntri, BYTES_INT)) return
    do t = 1, map%ntri
      r(6 * t - 5:6 * t) = t
      c(6 * t - 5:6 * t) = map%dof(:, t)
      v(6 * t - 5:6 * t) = d(:, t) * map%sgn(:, t)
    end do
    call rect_from_triplets(map%ntri, 2 * map%nedge, r, c, v, dmat, st)
  end subroutine equilibrium_div_rows_global

  !> The global unknowns on Gamma_a and their lower bounds g_h: bnd(dof) = gh(end, j) for
  !> boundary edge j with is_gamma_a(j); on_gamma_a(dof) marks them.
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine equilibrium_gamma_a_dofs(mesh, is_gamma_a, gh, on_gamma_a, bnd, st)
    type(mesh_t), intent(in) :: mesh
    logical, intent(in) :: is_gamma_a(:)
    real(dp), intent(in) :: gh(:,:)
    logical, allocatable, intent(out) :: on_gamma_a(:)
    real(dp), allocatable, intent(out) :: bnd(:)
    type(status_t), intent(out) :: st
    integer :: j, e, i, node, ist
    allocate (on_gamma_a(2 * mesh%nedge), bnd(2 * mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the bounds on Gamma_a', 4 * mesh%nedge, BYTES_REAL)) return
    on_gamma_a = .false.
    bnd = 0.0_dp
    do j = 1, mesh%nbedge
      if (.not. is_gamma_a(j)) cycle
      e = mesh%bedge_edge(j)
      do i = 1, 2
        node = mesh%bedge_nodes(i, j)
        associate (dof => 2 * (e - 1) + merge(1, 2, node == mesh%edge_nodes(1, e)))
          on_gamma_a(dof) = .true.
          bnd(dof) = gh(i, j)
        end associate
      end do
    end do
  end subroutine equilibrium_gamma_a_dofs

  !> The constraint rows of (4.8) in the element parameters (index 6 (t-1) + k): first the
  !> divergence rows (4.9), then two continuity rows (4.10) per interior edge, both with
  !> free multipliers; then the Gamma_a rows beta >= g_h (E, one unit per row).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine equilibrium_rows_local(mesh, map, d, on_gamma_a, bnd, bmat, row_kind, e, st)
    type(mesh_t), intent(in) :: mesh
    type(equilibrium_map_t), intent(in) :: map
    real(dp), intent(in) :: d(:,:)
    logical, intent(in) :: on_gamma_a(:)
    real(dp), intent(in) :: bnd(:)
    type(rect_t), intent(out) :: bmat
    integer, allocatable, intent(out) :: row_kind(:)
    real(dp), allocatable, intent(out) :: e(:)
    type(status_t), intent(out) :: st
    integer, allocatable :: first(:), r(:), c(:)
    real(dp), allocatable :: v(:)
    integer :: t, k, nrow, nnz, g, idx, ndof, ist
    ndof = 2 * mesh%nedge
    allocate (first(ndof), r(6 * mesh%ntri + 2 * ndof), c(6 * mesh%ntri + 2 * ndof), v(6 * mesh%ntri + 2 * ndof), &
              stat=ist)
    if (alloc_failed(ist, st, 'the equilibrium constraint rows', 24_i8 * mesh%ntri + 9_i8 * ndof, BYTES_INT)) return
    first = 0
    nnz = 0
    do t = 1, mesh%ntri
      do k = 1, 6
        nnz = nnz + 1
        r(nnz) = t
        c(nnz) = 6 * (t - 1) + k
        v(nnz) = d(k, t)
      end do
    end do
    nrow = mesh%ntri
    ! continuity: the two parameters that share a global unknown sum to zero
    do t = 1, mesh%ntri
      do k = 1, 6
        g = map%dof(k, t)
        idx = 6 * (t - 1) + k
        if (first(g) == 0) then
          first(g) = idx
        else
          nrow = nrow + 1
          r(nnz + 1:nnz + 2) = nrow
          c(nnz + 1:nnz + 2) = [first(g), idx]
          v(nnz + 1:nnz + 2) = 1.0_dp
          nnz = nnz + 2
        end if
      end do
    end do
    allocate (row_kind(nrow + count(on_gamma_a)), e(nrow + count(on_gamma_a)), stat=ist)
    if (alloc_failed(ist, st, 'the equilibrium constraint rows', 2 * (nrow + count(on_gamma_a)), BYTES_REAL)) return
    row_kind = ROW_EQUALITY
    e = 0.0_dp
    do g = 1, ndof
      if (.not. on_gamma_a(g)) cycle
      nrow = nrow + 1
      nnz = nnz + 1
      r(nnz) = nrow
      c(nnz) = first(g)            ! the only parameter of a boundary unknown (sgn = +1)
      v(nnz) = 1.0_dp
      row_kind(nrow) = ROW_INEQUALITY
      e(nrow) = bnd(g)
    end do
    call rect_from_triplets(nrow, 6 * mesh%ntri, r(1:nnz), c(1:nnz), v(1:nnz), bmat, st)
  end subroutine equilibrium_rows_local

  !> The piecewise linear field with global edge-end fluxes x_coarse on `coarse` as a field of
  !> its bisection `fine` (ancestor: mesh_bisection_ancestor; parents: the new nodes' edge
  !> ends): x_fine(2 (e - 1) + j) = q.n_e at end node j of fine edge e, q evaluated in the
  !> ancestor of e's reference triangle edge_tri(1, e).  Exact: q is linear in every coarse
  !> triangle and the fine edges lie in one (on a coarse edge both neighbours give the same
  !> normal flux, the continuity of the space), so q.n_e is linear on e and fixed by its two
  !> end values.  The divergence of every fine triangle is that of q there.
  subroutine equilibrium_prolongate_bisection(coarse, fine, ancestor, parents, x_coarse, x_fine, st)
    type(mesh_t), intent(in) :: coarse, fine
    integer, intent(in) :: ancestor(:)           !! (fine%ntri)
    integer, intent(in) :: parents(:,:)          !! (2, fine%nnode - coarse%nnode)
    real(dp), intent(in) :: x_coarse(:)          !! (2 coarse%nedge)
    real(dp), allocatable, intent(out) :: x_fine(:)
    type(status_t), intent(out) :: st
    type(equilibrium_map_t) :: map
    real(dp) :: xy(2, 3), beta(6), nus(2, 3), ls(3), nu(2), bary(3), q(2)
    integer :: e, t, c, j, n, ist
    if (size(x_coarse) /= 2 * coarse%nedge .or. size(ancestor) /= fine%ntri .or. &
        size(parents, 2) /= fine%nnode - coarse%nnode) then
      call set_error(st, DS_ERR_INPUT, 'equilibrium_prolongate_bisection: the fluxes, ancestors or parents ' // &
        'are not of these meshes')
      return
    end if
    if (any(ancestor < 1 .or. ancestor > coarse%ntri)) then
      call set_error(st, DS_ERR_INPUT, 'equilibrium_prolongate_bisection: an ancestor is not a triangle of ' // &
        'the coarse mesh (expected mesh_bisection_ancestor''s map)')
      return
    end if
    call equilibrium_map(coarse, map, st)
    if (st%code /= 0) return
    allocate (x_fine(2 * fine%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the prolongated fluxes', 2 * fine%nedge, BYTES_REAL)) return
    do e = 1, fine%nedge
      t = fine%edge_tri(1, e)
      c = ancestor(t)
      xy = coarse%xy(:, coarse%tri(:, c))
      beta = map%sgn(:, c) * x_coarse(map%dof(:, c))
      ! n_e: the outward normal of t on e, its local side k
      call equilibrium_sides(fine%xy(:, fine%tri(:, t)), nus, ls)
      nu = nus(:, findloc(fine%tri_edge(:, t), e, dim=1))
      do j = 1, 2
        n = fine%edge_nodes(j, e)
        bary = 0.0_dp
        if (n <= coarse%nnode) then
          where (coarse%tri(:, c) == n) bary = 1.0_dp
        else
          where (coarse%tri(:, c) == parents(1, n - coarse%nnode) .or. &
                 coarse%tri(:, c) == parents(2, n - coarse%nnode)) bary = 0.5_dp
        end if
        q = equilibrium_field_xy(xy, beta, bary)
        x_fine(2 * (e - 1) + j) = dot_product(q, nu)
      end do
    end do
  end subroutine equilibrium_prolongate_bisection
end module dualsig_assembly_equilibrium
