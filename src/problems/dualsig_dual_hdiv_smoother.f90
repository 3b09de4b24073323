!> A matrix-free solver for the condensed RT1 dual problem of P1 (dualsig_problem_dual_hdiv)
!> from a close start: projected multiplicative Schwarz sweeps over the vertex patches (all
!> side unknowns of the edges at a vertex, the patches of the V-cycle's smoother in
!> dualsig_patch_schwarz), each patch's residual (and block) gathered from the condensed
!> systems of the triangles at the vertex (those of hdiv_condensed_element, kept per shape
!> class, below), never from an assembled matrix.  Every row of a patch unknown gets its
!> entries from the triangles at its edge, and both lie at the vertex, so the patch's block
!> and residual are exact.  Interior patches alike (patch_types) share one factored block;
!> the others have theirs formed and eliminated in the sweep.
!>
!> The problem is that of dualsig_problem_dual_hdiv: minimise J(x) = 1/2 x^T S x - c^T x
!> (S = sum_T S_T, c = sum_T c_T, the interior unknowns eliminated) subject to x_i >= 0 on
!> the bounded unknowns (q.nu at both ends of a boundary edge).  A patch step minimises J
!> over the patch's unknowns with the bounds handled in the patch (the unknowns whose
!> unconstrained step would go below 0 set to 0 and the rest solved again, until none
!> does), and against the feasible step along the first, unconstrained, direction cut at
!> the bound; the better of the two is taken when it decreases J, none otherwise.  So J
!> never increases, the field stays feasible after every step, and any field it returns
!> gives guaranteed bounds.
!>
!> Shape classes (dualsig_mesh_shapes): the condensed matrix of a triangle, its condensation
!> and the maps from the load to its right-hand side depend on the triangle only through the
!> Gram matrix J^T J of its edges (rt1_gram, rt1_load_map), so the triangles of one class
!> share those of the class's first triangle.  This changes only which field the sweeps
!> converge to, by a relative 2^-shape_bits at most: the field is feasible whatever the
!> matrices, and the bounds are computed from it on the mesh itself
!> (dualsig_estimate_dual_hdiv).
!>
!> Memory: per triangle its side unknowns, shape class and signs, its right-hand side and
!> the load part of its condensation (92 bytes); per shape class its condensed matrix and
!> condensation (384 bytes); the triangles at every node; no matrix, no factors.  The
!> sweeps are bound by memory latency, so everything is stored in the order of the sweep:
!> the nodes in the caller's order (e.g. along a Z-order curve), the triangles and the side
!> unknowns numbered as the patches first reach them.  The vectors of hdiv_local_energy and
!> hdiv_local_sweep are in that numbering of the side unknowns (hdiv_local_permute;
!> hdiv_local_recover returns the field in the mesh's).
module dualsig_dual_hdiv_smoother
  use dualsig_kinds, only: dp, i8
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_quadrature, only: tri_rule_t, tri_rule
  use dualsig_elements_rt1, only: rt1_nside, rt1_nbasis, rt1_reference_t, rt1_reference, rt1_matrix_degree, &
                                  rt1_geometry_t, rt1_geometry, rt1_gram, rt1_load_map, rt1_load_moments, rt1_condense
  use dualsig_assembly_dual_hdiv, only: hdiv_side_dofs, hdiv_load_values
  use dualsig_load_data, only: load_data_t
  use dualsig_status, only: status_t
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  use dualsig_key_index, only: key_index_t, key_index_init, key_index_add, key_index_find
  use dualsig_mesh_shapes, only: shape_classes
  implicit none
  private

  public :: hdiv_local_t, hdiv_local_build, hdiv_local_permute, hdiv_local_energy, hdiv_local_sweep, &
            hdiv_local_recover

  !> The P1 mass matrix of a triangle over its area: int lambda_i lambda_j / |T| =
  !> (1 + delta_ij) / 12.
  real(dp), parameter :: p1_mass_ref(3, 3) = reshape([2.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 2.0_dp, 1.0_dp, &
                                                      1.0_dp, 1.0_dp, 2.0_dp], [3, 3]) / 12.0_dp
  !> The signs of the 6 side unknowns of a triangle (local = sign * global) for each mask
  !> of code (hdiv_local_t): bit k-1 set when those of side k are -1.
  real(dp), parameter :: mask_sign(rt1_nside, 0:7) = reshape([ &
    1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, -1.0_dp, -1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, &
    1.0_dp, 1.0_dp, -1.0_dp, -1.0_dp, 1.0_dp, 1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, 1.0_dp, 1.0_dp, &
    1.0_dp, 1.0_dp, 1.0_dp, 1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, 1.0_dp, 1.0_dp, -1.0_dp, -1.0_dp, &
    1.0_dp, 1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp, -1.0_dp], &
    [rt1_nside, 8])

  !> The condensed systems of the triangles of a mesh (hdiv_condensed_element) by shape
  !> class (module header) and the triangles at every node, in the sweep's numbering
  !> (module header): node position p (the p-th of the caller's order), triangle tn, side
  !> unknown i.  Triangle tn's condensed matrix is mask_sign * se(:, :, c) * mask_sign, its
  !> interior unknowns rec_d(:, tn) - rec_k(:, :, c) (mask_sign * its side values), with
  !> its class c and mask from code(tn).
  type :: hdiv_local_t
    integer :: ntri = 0
    integer :: nside = 0                   !! side unknowns (2 nedge)
    integer :: max_patch = 0               !! most unknowns of a vertex patch
    integer :: nshape = 0                  !! shape classes
    integer, allocatable :: dofs(:,:)      !! (6, ntri) the side unknowns of each triangle
    !> (ntri) shape class c and signs of each triangle: code = 8 (c - 1) + mask (mask_sign)
    integer, allocatable :: code(:)
    real(dp), allocatable :: ce(:,:)       !! (6, ntri) condensed right-hand side, global signs
    real(dp), allocatable :: rec_d(:,:)    !! (2, ntri) the load part of the condensation
    real(dp), allocatable :: se(:,:,:)     !! (6, 6, nshape) condensed matrix, local signs
    real(dp), allocatable :: rec_k(:,:,:)  !! (2, 6, nshape) condensation, local signs
    integer, allocatable :: tri_of(:)      !! (ntri) the mesh's triangle of triangle tn
    integer, allocatable :: tperm(:)       !! (ntri) the mesh's triangle t is triangle tperm(t) here
    integer, allocatable :: perm(:)        !! (nside) side unknown i of the mesh is perm(i) here
    !> (npos+1) the triangles at node position p: node_tri(node_ptr(p):node_ptr(p+1)-1), with
    !> the node's local vertex number in each, node_corner
    integer, allocatable :: node_ptr(:), node_tri(:), node_corner(:)
    logical, allocatable :: node_boundary(:)   !! (npos) the node lies on the boundary
    !> the types of the vertex patches (patch_types): node position p's, 0 for none; the
    !> LDL^T factor (ldl_factor) of the sign-normalised block of each type
    integer :: ntype = 0
    integer, allocatable :: node_type(:)   !! (npos)
    real(dp), allocatable :: type_fac(:,:,:)   !! (max_patch, max_patch, ntype)
    real(dp) :: shift = 0.0_dp             !! as hdiv_system_t%shift
    real(dp) :: data_sq = 0.0_dp           !! as hdiv_system_t%data_sq
    real(dp) :: data_osc_sq = 0.0_dp       !! as hdiv_system_t%data_osc_sq
  end type hdiv_local_t

  !> What the right-hand side and data terms of a shape class's triangles need: with the
  !> vertex moments fb of the load (rt1_load_moments), ce = mask_sign * (cmap fb),
  !> rec_d = rmap fb, shift = -1/2 (bimap fb) . rec_d; ||grad u||^2 = ue^T kp1 ue.
  type :: shape_maps_t
    real(dp), allocatable :: cmap(:,:,:)   !! (6, 3, nshape)
    real(dp), allocatable :: rmap(:,:,:)   !! (2, 3, nshape)
    real(dp), allocatable :: bimap(:,:,:)  !! (2, 3, nshape)
    real(dp), allocatable :: kp1(:,:,:)    !! (3, 3, nshape) P1 stiffness matrix
    real(dp), allocatable :: area(:)       !! (nshape)
  end type shape_maps_t

  !> Work arrays of one patch step (max_patch long), allocated once per sweep.
  type :: patch_work_t
    real(dp), allocatable :: a(:,:)        !! the patch's block of S
    real(dp), allocatable :: f(:,:)        !! Cholesky factor of its free part
    real(dp), allocatable :: r(:), x(:), d(:), d0(:), y(:), sigma(:)
    integer, allocatable :: list(:), idx(:)
    logical, allocatable :: at_zero(:), bnd(:)
    real(dp) :: dj = 0.0_dp                !! the change of J by the step d
  end type patch_work_t

contains

  !> The condensed system of every triangle of mesh (what assemble_dual_hdiv would add into
  !> its matrix; f, rule, u and load as there), by shape class (module header), and the
  !> triangles at every node, in the sweep's numbering for the nodes in `order` (each node
  !> once).  Out of memory: DS_ERR_MEMORY in st.
  subroutine hdiv_local_build(mesh, f, rule, order, loc, st, u, load, x0, j0, xp0)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    integer, intent(in) :: order(:)
    type(hdiv_local_t), intent(out) :: loc
    type(status_t), intent(inout) :: st
    real(dp), intent(in), optional :: u(:)
    type(load_data_t), intent(in), optional :: load
    !> side unknowns in the mesh's numbering (optional): j0 = J(x0) (hdiv_local_energy)
    real(dp), intent(in), optional :: x0(:)
    real(dp), intent(out), optional :: j0
    !> with x0 (optional): x0 in the sweep's numbering (hdiv_local_permute)
    real(dp), intent(out), optional :: xp0(:)
    type(shape_maps_t) :: maps
    integer, allocatable :: rep(:), cls(:)
    real(dp), allocatable :: xp(:)
    integer :: ist
    loc%ntri = mesh%ntri
    loc%nside = 2 * mesh%nedge
    call node_triangles(mesh, order, loc, st)
    if (st%code /= 0) return
    call shape_classes(mesh, cls, rep, loc%nshape, st)
    if (st%code /= 0) return
    call canonical_node_order(loc, cls)
    call sweep_numbering(mesh, loc, cls, st)
    if (st%code /= 0) return
    call shape_tables(mesh, rep, loc, maps, st)
    if (st%code /= 0) return
    call patch_types(loc, st)
    if (st%code /= 0) return
    if (present(x0) .and. present(j0)) then
      if (present(xp0)) then
        call hdiv_local_permute(loc, x0, xp0)
        call triangle_loads(mesh, f, rule, maps, loc, st, u, load, xp0, j0)
      else
        allocate (xp(loc%nside), stat=ist)
        if (alloc_failed(ist, st, 'the RT1 side unknowns', loc%nside, BYTES_REAL)) return
        call hdiv_local_permute(loc, x0, xp)
        call triangle_loads(mesh, f, rule, maps, loc, st, u, load, xp, j0)
      end if
    else if (present(x0) .and. present(xp0)) then
      call hdiv_local_permute(loc, x0, xp0)
      call triangle_loads(mesh, f, rule, maps, loc, st, u, load)
    else
      call triangle_loads(mesh, f, rule, maps, loc, st, u, load)
    end if
  end subroutine hdiv_local_build

  !> The values at the vertices of triangle t of Pi_1 f from its load data: f_T + g_T .
  !> (a_j - x_T).
  pure function load_vertex_values(mesh, load, t) result(fv)
    type(mesh_t), intent(in) :: mesh
    type(load_data_t), intent(in) :: load
    integer, intent(in) :: t
    real(dp) :: fv(3)
    real(dp) :: xy(2, 3), centroid(2)
    integer :: j
    xy = mesh%xy(:, mesh%tri(:, t))
    centroid = sum(xy, dim=2) / 3.0_dp
    do j = 1, 3
      fv(j) = load%mean(t) + dot_product(load%slope(:, t), xy(:, j) - centroid)
    end do
  end function load_vertex_values

  !> The triangles at every node in a canonical order: by shape class, then by the node's
  !> corner in them (stable), so that vertex patches alike in shape list their unknowns
  !> alike (patch_types).  Any order of the triangles at a node is a valid patch.
  pure subroutine canonical_node_order(loc, cls)
    type(hdiv_local_t), intent(inout) :: loc
    integer, intent(in) :: cls(:)
    integer :: p, i, j, t, kv, key
    do p = 1, size(loc%node_boundary)
      do i = loc%node_ptr(p) + 1, loc%node_ptr(p + 1) - 1
        t = loc%node_tri(i)
        kv = loc%node_corner(i)
        key = 3 * cls(t) + kv
        j = i - 1
        do while (j >= loc%node_ptr(p))
          if (3 * cls(loc%node_tri(j)) + loc%node_corner(j) <= key) exit
          loc%node_tri(j + 1) = loc%node_tri(j)
          loc%node_corner(j + 1) = loc%node_corner(j)
          j = j - 1
        end do
        loc%node_tri(j + 1) = t
        loc%node_corner(j + 1) = kv
      end do
    end do
  end subroutine canonical_node_order

  !> The types of the vertex patches of the interior nodes (loc%node_type,
  !> type_fac): two patches are of one type when their triangles, in the canonical order,
  !> have the same shape classes and corners and place their unknowns at the same patch
  !> positions.  Then their blocks are sigma_i sigma_j A^_ij with the same A^ (sigma_i: the
  !> sign of unknown i in the first triangle that lists it; in the other triangle at its
  !> edge it has the opposite sign), so A^ is factored once per type (LDL^T) and a sweep
  !> only forms the residual.  Types are made for at most max(min_types, npos /
  !> nodes_per_type) patches' worth of factors; the other nodes, and those whose A^ is
  !> not positive definite, keep type 0 (block formed and factored in the sweep).
  subroutine patch_types(loc, st)
    type(hdiv_local_t), intent(inout) :: loc
    type(status_t), intent(inout) :: st
    integer, parameter :: min_types = 64, nodes_per_type = 16
    type(key_index_t) :: idx
    integer(i8), allocatable :: key(:)
    integer, allocatable :: pos(:), list(:)
    real(dp), allocatable :: a(:,:), sigma(:), fac(:,:,:), grown(:,:,:)
    logical, allocatable :: ok(:)
    integer :: p, npos, mp, maxdeg, c, m, ist, max_types, ierr
    npos = size(loc%node_boundary)
    mp = loc%max_patch
    maxdeg = maxval(loc%node_ptr(2:npos + 1) - loc%node_ptr(1:npos))
    max_types = max(min_types, npos / nodes_per_type)
    allocate (loc%node_type(npos), source=0, stat=ist)
    if (alloc_failed(ist, st, 'the types of the vertex patches', npos, BYTES_INT)) return
    allocate (key(1 + 6 * maxdeg), pos(loc%nside), list(mp), a(mp, mp), sigma(mp), &
              ok(max_types), fac(mp, mp, min_types), stat=ist)
    if (alloc_failed(ist, st, 'the types of the vertex patches', loc%nside + 2 * max_types + mp * mp * min_types, &
                     BYTES_REAL)) return
    pos = 0
    call key_index_init(idx, size(key), st)
    if (st%code /= 0) return
    do p = 1, npos
      if (loc%node_boundary(p)) cycle
      call patch_list(loc, p, pos, list, sigma, m)
      call patch_key(loc, p, pos, key)
      c = key_index_find(idx, key)
      if (c == 0 .and. idx%n < max_types) then
        ! a new type: its block, sign-normalised, factored
        call key_index_add(idx, key, p, c, st)
        if (st%code /= 0) return
        if (c > size(fac, 3)) then
          allocate (grown(mp, mp, 2 * size(fac, 3)), stat=ist)
          if (alloc_failed(ist, st, 'the factors of the patch types', 2 * mp * mp * size(fac, 3), BYTES_REAL)) return
          grown(:, :, 1:size(fac, 3)) = fac
          call move_alloc(grown, fac)
        end if
        call patch_block(loc, p, pos, a)
        a(1:m, 1:m) = a(1:m, 1:m) * spread(sigma(1:m), 1, m) * spread(sigma(1:m), 2, m)
        fac(1:m, 1:m, c) = a(1:m, 1:m)
        call ldl_factor(m, fac(:, :, c), ierr)
        ok(c) = ierr == 0
      end if
      if (c > 0) then
        if (ok(c)) loc%node_type(p) = c
      end if
      pos(list(1:m)) = 0
    end do
    loc%ntype = idx%n
    loc%type_fac = fac(:, :, 1:idx%n)
  end subroutine patch_types

  !> The key of the type of the vertex patch of node position p (patch_types): the number
  !> of its triangles, then for each its shape class, the node's corner and the patch
  !> positions of its four unknowns at the node (pos, set by patch_list); zeros after.
  pure subroutine patch_key(loc, p, pos, key)
    type(hdiv_local_t), intent(in) :: loc
    integer, intent(in) :: p
    integer, intent(in) :: pos(:)
    integer(i8), intent(out) :: key(:)
    integer :: it, t, kv, k
    key = 0_i8
    key(1) = loc%node_ptr(p + 1) - loc%node_ptr(p)
    k = 1
    do it = loc%node_ptr(p), loc%node_ptr(p + 1) - 1
      t = loc%node_tri(it)
      kv = loc%node_corner(it)
      key(k + 1) = ishft(loc%code(t), -3)
      key(k + 2) = kv
      key(k + 3:k + 6) = pos(loc%dofs(corner_dofs(kv), t))
      k = k + 6
    end do
  end subroutine patch_key

  !> The local unknowns of a triangle at its corner kv: those of its sides kv
  !> (a_kv a_kv+1) and kv - 1.
  pure function corner_dofs(kv) result(lp)
    integer, intent(in) :: kv
    integer :: lp(4), km
    km = mod(kv + 1, 3) + 1
    lp = [2 * kv - 1, 2 * kv, 2 * km - 1, 2 * km]
  end function corner_dofs

  !> The condensed matrix and condensation of every shape class (loc%se, loc%rec_k) and
  !> the maps of its loads (maps), from its first triangle rep(c): the element matrices of
  !> (3.1') (rt1_gram, rt1_load_map) condensed (rt1_condense), one column of the load map
  !> at a time.
  subroutine shape_tables(mesh, rep, loc, maps, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: rep(:)
    type(hdiv_local_t), intent(inout) :: loc
    type(shape_maps_t), intent(out) :: maps
    type(status_t), intent(inout) :: st
    type(rt1_reference_t) :: ref
    type(rt1_geometry_t) :: g
    real(dp) :: ae(rt1_nbasis, rt1_nbasis), bmap(rt1_nbasis, 3)
    integer :: c, v, ns, ist
    ns = loc%nshape
    allocate (loc%se(rt1_nside, rt1_nside, ns), loc%rec_k(2, rt1_nside, ns), maps%cmap(rt1_nside, 3, ns), &
              maps%rmap(2, 3, ns), maps%bimap(2, 3, ns), maps%kp1(3, 3, ns), maps%area(ns), stat=ist)
    if (alloc_failed(ist, st, 'the condensed RT1 systems of the shape classes', 80 * ns, BYTES_REAL)) return
    ref = rt1_reference(tri_rule(rt1_matrix_degree))
    do c = 1, ns
      g = rt1_geometry(mesh%xy(:, mesh%tri(:, rep(c))))
      ae = rt1_gram(g, ref)
      bmap = rt1_load_map(g, ref)
      do v = 1, 3
        call rt1_condense(ae, bmap(:, v), loc%se(:, :, c), maps%cmap(:, v, c), loc%rec_k(:, :, c), &
                          maps%rmap(:, v, c))
      end do
      maps%bimap(:, :, c) = bmap(7:8, :)
      maps%kp1(:, :, c) = g%area * matmul(transpose(g%grad), g%grad)
      maps%area(c) = g%area
    end do
  end subroutine shape_tables

  !> Every triangle's right-hand side and load part of the condensation (loc%ce,
  !> loc%rec_d) and its parts of loc%shift, data_sq and data_osc_sq through the maps of its
  !> shape class: what hdiv_condensed_element gives (the same formulas, the matrices
  !> shared).  With load, f enters as Pi_1 f from its vertex values (load_vertex_values),
  !> so that its vertex moments and ||Pi_1 f - u||^2 are the P1 mass matrix's, exact;
  !> without, f's values at the points of rule (hdiv_load_values).  With xp (side unknowns
  !> in the sweep's numbering), j0 = J(xp) (hdiv_local_energy) on the way.
  subroutine triangle_loads(mesh, f, rule, maps, loc, st, u, load, xp, j0)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: f
    type(tri_rule_t), intent(in) :: rule
    type(shape_maps_t), intent(in) :: maps
    type(hdiv_local_t), intent(inout) :: loc
    type(status_t), intent(inout) :: st
    real(dp), intent(in), optional :: u(:)
    type(load_data_t), intent(in), optional :: load
    real(dp), intent(in), optional :: xp(:)
    real(dp), intent(out), optional :: j0
    real(dp) :: fq(rule%n), fb(3), fv(3), ue(3), rd(2), sg(rt1_nside), xt(rt1_nside), dsq
    integer :: tn, t, c, ist
    allocate (loc%ce(rt1_nside, loc%ntri), loc%rec_d(2, loc%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the condensed RT1 right-hand sides', 8 * loc%ntri, BYTES_REAL)) return
    ue = 0.0_dp
    if (present(j0)) j0 = 0.0_dp
    do tn = 1, loc%ntri
      t = loc%tri_of(tn)
      c = ishft(loc%code(tn), -3) + 1
      sg = mask_sign(:, iand(loc%code(tn), 7))
      if (present(u)) ue = u(mesh%tri(:, t))
      if (present(load)) then
        fv = load_vertex_values(mesh, load, t)
        fb = matmul(p1_mass_ref, fv)
        dsq = load%osc(t)**2 + maps%area(c) * dot_product(fv - ue, matmul(p1_mass_ref, fv - ue))
        loc%data_osc_sq = loc%data_osc_sq + load%osc(t)**2
      else
        call hdiv_load_values(mesh, t, f, rule, fq, load)
        fb = rt1_load_moments(rule, fq)
        dsq = maps%area(c) * sum(rule%w(1:rule%n) * (fq - matmul(ue, rule%bary(:, 1:rule%n)))**2)
      end if
      loc%ce(:, tn) = sg * small_matvec(rt1_nside, 3, maps%cmap(:, :, c), fb)
      rd = small_matvec(2, 3, maps%rmap(:, :, c), fb)
      loc%rec_d(:, tn) = rd
      loc%shift = loc%shift - 0.5_dp * dot_product(small_matvec(2, 3, maps%bimap(:, :, c), fb), rd)
      loc%data_sq = loc%data_sq + dsq + dot_product(ue, small_matvec(3, 3, maps%kp1(:, :, c), ue))
      if (present(j0)) then
        xt = sg * xp(loc%dofs(:, tn))
        j0 = j0 + 0.5_dp * dot_product(xt, small_matvec(rt1_nside, rt1_nside, loc%se(:, :, c), xt)) &
                - dot_product(loc%ce(:, tn), sg * xt)
      end if
    end do
  end subroutine triangle_loads

  !> The triangles at every node position p (node order(p)) with the node's local vertex
  !> number in each, the nodes on the boundary, and the largest vertex patch: two unknowns
  !> per edge at the node, at most one edge more than triangles.  Triangles in the mesh's
  !> numbering (sweep_numbering renumbers them).
  subroutine node_triangles(mesh, order, loc, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: order(:)
    type(hdiv_local_t), intent(inout) :: loc
    type(status_t), intent(inout) :: st
    integer, allocatable :: fill(:), rank(:)
    integer :: t, k, p, ist
    allocate (rank(mesh%nnode), loc%node_ptr(mesh%nnode + 1), loc%node_tri(3 * mesh%ntri), &
              loc%node_corner(3 * mesh%ntri), loc%node_boundary(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the triangles at the nodes', 3 * mesh%nnode + 1 + 6 * mesh%ntri, BYTES_INT)) return
    do p = 1, mesh%nnode
      rank(order(p)) = p
    end do
    loc%node_boundary = mesh%node_on_boundary(order)
    loc%node_ptr = 0
    do t = 1, mesh%ntri
      do k = 1, 3
        p = rank(mesh%tri(k, t))
        loc%node_ptr(p + 1) = loc%node_ptr(p + 1) + 1
      end do
    end do
    loc%max_patch = 2 * (maxval(loc%node_ptr) + 1)
    loc%node_ptr(1) = 1
    do p = 1, mesh%nnode
      loc%node_ptr(p + 1) = loc%node_ptr(p + 1) + loc%node_ptr(p)
    end do
    fill = loc%node_ptr(1:mesh%nnode)
    do t = 1, mesh%ntri
      do k = 1, 3
        p = rank(mesh%tri(k, t))
        loc%node_tri(fill(p)) = t
        loc%node_corner(fill(p)) = k
        fill(p) = fill(p) + 1
      end do
    end do
  end subroutine node_triangles

  !> The sweep's numbering: the triangles (loc%tri_of, and node_tri renumbered) and the side
  !> unknowns (loc%perm) in the order the vertex patches first reach them; the shape class and
  !> the signs of each triangle's side unknowns (loc%code).  Every side
  !> unknown is in a patch (an edge has two ends).
  subroutine sweep_numbering(mesh, loc, cls, st)
    type(mesh_t), intent(in) :: mesh
    type(hdiv_local_t), intent(inout) :: loc
    integer, intent(in) :: cls(:)      !! (ntri) the shape class of each triangle of the mesh
    type(status_t), intent(inout) :: st
    integer :: it, t, tn, kv, l, g, next_t, next_i, ist, lp(4)
    real(dp) :: sgn(rt1_nside)
    allocate (loc%tperm(mesh%ntri), loc%tri_of(mesh%ntri), loc%perm(loc%nside), loc%dofs(rt1_nside, mesh%ntri), &
              loc%code(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the numbering of the patch sweeps', 9 * mesh%ntri + loc%nside, BYTES_INT)) return
    loc%tperm = 0
    loc%perm = 0
    next_t = 0
    next_i = 0
    do it = 1, size(loc%node_tri)
      t = loc%node_tri(it)
      kv = loc%node_corner(it)
      if (loc%tperm(t) == 0) then
        next_t = next_t + 1
        loc%tperm(t) = next_t
        loc%tri_of(next_t) = t
        call hdiv_side_dofs(mesh, t, loc%dofs(:, next_t), sgn)     ! the mesh's numbering for now
        loc%code(next_t) = 8 * (cls(t) - 1) + merge(1, 0, sgn(2) < 0.0_dp) + merge(2, 0, sgn(4) < 0.0_dp) &
                           + merge(4, 0, sgn(6) < 0.0_dp)
      end if
      tn = loc%tperm(t)
      lp = corner_dofs(kv)
      do l = 1, 4
        g = loc%dofs(lp(l), tn)
        if (loc%perm(g) /= 0) cycle
        next_i = next_i + 1
        loc%perm(g) = next_i
      end do
      loc%node_tri(it) = tn
    end do
    do tn = 1, mesh%ntri
      loc%dofs(:, tn) = loc%perm(loc%dofs(:, tn))
    end do
  end subroutine sweep_numbering

  !> xp = xs in the sweep's numbering of the side unknowns (xp(perm(i)) = xs(i)).
  pure subroutine hdiv_local_permute(loc, xs, xp)
    type(hdiv_local_t), intent(in) :: loc
    real(dp), intent(in) :: xs(:)
    real(dp), intent(out) :: xp(:)
    xp(loc%perm) = xs(1:loc%nside)
  end subroutine hdiv_local_permute

  !> J(xs) = 1/2 xs^T S xs - c^T xs, summed by triangles.
  pure real(dp) function hdiv_local_energy(loc, xs) result(j)
    type(hdiv_local_t), intent(in) :: loc
    real(dp), intent(in) :: xs(:)
    real(dp) :: xt(rt1_nside)
    integer :: t, c
    j = 0.0_dp
    do t = 1, loc%ntri
      c = ishft(loc%code(t), -3) + 1
      xt = mask_sign(:, iand(loc%code(t), 7)) * xs(loc%dofs(:, t))
      j = j + 0.5_dp * dot_product(xt, small_matvec(rt1_nside, rt1_nside, loc%se(:, :, c), xt)) &
            - dot_product(loc%ce(:, t), xs(loc%dofs(:, t)))
    end do
  end function hdiv_local_energy

  !> The field vector x in the mesh's numbering (side unknowns, then 2 interior unknowns per
  !> triangle) from the side unknowns xp in the sweep's: the interior ones from each
  !> triangle's condensation.
  pure subroutine hdiv_local_recover(loc, xp, x)
    type(hdiv_local_t), intent(in) :: loc
    real(dp), intent(in) :: xp(:)
    real(dp), intent(out) :: x(:)
    integer :: tn, t, n, c
    n = loc%nside
    x(1:n) = xp(loc%perm)
    do t = 1, loc%ntri
      tn = loc%tperm(t)
      c = ishft(loc%code(tn), -3) + 1
      x(n + 2 * t - 1:n + 2 * t) = loc%rec_d(:, tn) &
        - small_matvec(2, rt1_nside, loc%rec_k(:, :, c), mask_sign(:, iand(loc%code(tn), 7)) * xp(loc%dofs(:, tn)))
    end do
  end subroutine hdiv_local_recover

  !> One projected multiplicative sweep over the vertex patches, in the order of loc (module
  !> header), on the side unknowns xs in the sweep's numbering: xs stays feasible
  !> (bounded(i): xs(i) >= 0, same numbering) and J decreases by dj >= 0.  A patch of a type
  !> (patch_types) is solved with its type's factor; the others have their block formed
  !> and factored here.  Out of memory: DS_ERR_MEMORY in st.
  subroutine hdiv_local_sweep(loc, bounded, xs, dj, st)
    type(hdiv_local_t), intent(in) :: loc
    logical, intent(in) :: bounded(:)
    real(dp), intent(inout) :: xs(:)
    real(dp), intent(out) :: dj
    type(status_t), intent(inout) :: st
    type(patch_work_t) :: w
    integer, allocatable :: pos(:)
    integer :: iv, m, ist, mp, k
    dj = 0.0_dp
    mp = loc%max_patch
    allocate (pos(loc%nside), source=0, stat=ist)
    if (alloc_failed(ist, st, 'the patch positions of the RT1 unknowns', loc%nside, BYTES_INT)) return
    allocate (w%a(mp, mp), w%f(mp, mp), w%r(mp), w%d(mp), w%d0(mp), w%y(mp), w%list(mp), w%idx(mp), &
              w%at_zero(mp), w%bnd(mp), w%x(mp), w%sigma(mp), stat=ist)
    if (alloc_failed(ist, st, 'the block of a vertex patch', mp * (2 * mp + 9), BYTES_REAL)) return
    do iv = 1, size(loc%node_boundary)
      call patch_list(loc, iv, pos, w%list, w%sigma, m)
      if (m > 0) then
        call patch_residual(loc, iv, xs, pos, w%r)
        k = loc%node_type(iv)
        if (k > 0) then
          ! d = sigma A^-1 sigma r with the type's factor of A^ (patch_types)
          w%d(1:m) = w%sigma(1:m) * w%r(1:m)
          call ldl_solve(m, loc%type_fac(:, :, k), w%d)
          w%d(1:m) = w%sigma(1:m) * w%d(1:m)
          w%dj = min(-0.5_dp * dot_product(w%r(1:m), w%d(1:m)), 0.0_dp)
          w%bnd(1:m) = .false.
        else
          call patch_block(loc, iv, pos, w%a)
          w%x(1:m) = xs(w%list(1:m))
          ! only the patches of boundary nodes hold bounded unknowns (those of boundary edges)
          if (loc%node_boundary(iv)) then
            w%bnd(1:m) = bounded(w%list(1:m))
            call patch_step(w, m)
          else
            w%bnd(1:m) = .false.
            call free_patch_step(w, m)
          end if
        end if
        if (w%dj < 0.0_dp) then
          xs(w%list(1:m)) = xs(w%list(1:m)) + w%d(1:m)
          where (w%bnd(1:m)) xs(w%list(1:m)) = max(xs(w%list(1:m)), 0.0_dp)
          dj = dj - w%dj
        end if
      end if
      pos(w%list(1:m)) = 0
    end do
  end subroutine hdiv_local_sweep

  !> The unknowns list(1:m) of the vertex patch of node position p, in the order its
  !> triangles reach them (pos(list(k)) = k on return; the caller resets pos), and the sign
  !> sigma(k) of each in the first triangle that lists it.  The sides of triangle t
  !> through the node a_kv are its local sides kv and kv - 1 (corner_dofs).
  pure subroutine patch_list(loc, p, pos, list, sigma, m)
    type(hdiv_local_t), intent(in) :: loc
    integer, intent(in) :: p
    integer, intent(inout) :: pos(:)
    integer, intent(inout) :: list(:)
    real(dp), intent(inout) :: sigma(:)
    integer, intent(out) :: m
    integer :: it, t, ia, g, lp(4)
    m = 0
    do it = loc%node_ptr(p), loc%node_ptr(p + 1) - 1
      t = loc%node_tri(it)
      lp = corner_dofs(loc%node_corner(it))
      do ia = 1, 4
        g = loc%dofs(lp(ia), t)
        if (pos(g) /= 0) cycle
        m = m + 1
        list(m) = g
        pos(g) = m
        sigma(m) = mask_sign(lp(ia), iand(loc%code(t), 7))
      end do
    end do
  end subroutine patch_list

  !> The residual r = c - S xs on the unknowns of the vertex patch of node position p (pos
  !> from patch_list), from the triangles at the node.  Every row of a patch unknown gets
  !> its entries from the triangles at its edge, which all lie at the node.
  pure subroutine patch_residual(loc, p, xs, pos, r)
    type(hdiv_local_t), intent(in) :: loc
    integer, intent(in) :: p
    real(dp), intent(in) :: xs(:)
    integer, intent(in) :: pos(:)
    real(dp), intent(inout) :: r(:)
    real(dp) :: xt(rt1_nside), s, sg(rt1_nside)
    integer :: it, t, ia, l, l2, i, c, lp(4)
    do it = loc%node_ptr(p), loc%node_ptr(p + 1) - 1
      t = loc%node_tri(it)
      lp = corner_dofs(loc%node_corner(it))
      do ia = 1, 4
        r(pos(loc%dofs(lp(ia), t))) = 0.0_dp
      end do
    end do
    do it = loc%node_ptr(p), loc%node_ptr(p + 1) - 1
      t = loc%node_tri(it)
      lp = corner_dofs(loc%node_corner(it))
      c = ishft(loc%code(t), -3) + 1
      sg = mask_sign(:, iand(loc%code(t), 7))
      xt = sg * xs(loc%dofs(:, t))
      do ia = 1, 4
        l = lp(ia)
        i = pos(loc%dofs(l, t))
        s = 0.0_dp
        do l2 = 1, rt1_nside
          s = s + loc%se(l2, l, c) * xt(l2)
        end do
        r(i) = r(i) + loc%ce(l, t) - sg(l) * s
      end do
    end do
  end subroutine patch_residual

  !> The block a(1:m, 1:m) of S of the vertex patch of node position p (pos from
  !> patch_list), from the triangles at the node.
  pure subroutine patch_block(loc, p, pos, a)
    type(hdiv_local_t), intent(in) :: loc
    integer, intent(in) :: p
    integer, intent(in) :: pos(:)
    real(dp), intent(inout) :: a(:,:)
    real(dp) :: sg(rt1_nside)
    integer :: it, t, ia, ib, c, m, lp(4), ip(4)
    m = 0
    do it = loc%node_ptr(p), loc%node_ptr(p + 1) - 1
      t = loc%node_tri(it)
      m = max(m, maxval(pos(loc%dofs(corner_dofs(loc%node_corner(it)), t))))
    end do
    a(1:m, 1:m) = 0.0_dp
    do it = loc%node_ptr(p), loc%node_ptr(p + 1) - 1
      t = loc%node_tri(it)
      lp = corner_dofs(loc%node_corner(it))
      ip = pos(loc%dofs(lp, t))
      c = ishft(loc%code(t), -3) + 1
      sg = mask_sign(:, iand(loc%code(t), 7))
      do ia = 1, 4
        do ib = 1, 4
          a(ip(ia), ip(ib)) = a(ip(ia), ip(ib)) + sg(lp(ia)) * sg(lp(ib)) * loc%se(lp(ib), lp(ia), c)
        end do
      end do
    end do
  end subroutine patch_block

  !> patch_step for a patch without bounded unknowns: w%d = a^{-1} r, w%dj = -r^T d / 2 (or
  !> d = 0, dj = 0 when the block is not positive definite).
  pure subroutine free_patch_step(w, m)
    type(patch_work_t), intent(inout) :: w
    integer, intent(in) :: m
    integer :: i, j, ierr
    do j = 1, m
      do i = j, m
        w%f(i, j) = w%a(i, j)
      end do
    end do
    w%d(1:m) = w%r(1:m)
    call spd_solve_in_place(m, w%f, w%d, ierr)
    w%dj = -0.5_dp * dot_product(w%r(1:m), w%d(1:m))
    if (ierr /= 0 .or. .not. w%dj < 0.0_dp) then
      w%d(1:m) = 0.0_dp
      w%dj = 0.0_dp
    end if
  end subroutine free_patch_step

  !> The step w%d of one patch of m unknowns (module header) for its block w%a (SPD),
  !> residual w%r, values w%x and bounds (w%bnd: x + d >= 0), and the change of J it makes,
  !> w%dj = 1/2 d^T a d - r^T d (< 0; 0 with d = 0 when no feasible step decreases J or a
  !> block is not positive definite).
  pure subroutine patch_step(w, m)
    type(patch_work_t), intent(inout) :: w
    integer, intent(in) :: m
    real(dp) :: alpha, dj_cut
    integer :: round, ierr, i
    if (.not. any(w%bnd(1:m))) then
      call free_patch_step(w, m)
      return
    end if
    w%dj = 0.0_dp
    w%at_zero(1:m) = .false.
    call solve_with_zeros(w, m, ierr)
    if (ierr /= 0) then
      w%d(1:m) = 0.0_dp
      return
    end if
    w%d0(1:m) = w%d(1:m)
    do round = 1, m
      if (.not. any(w%bnd(1:m) .and. .not. w%at_zero(1:m) .and. w%x(1:m) + w%d(1:m) < 0.0_dp)) exit
      where (w%bnd(1:m) .and. w%x(1:m) + w%d(1:m) < 0.0_dp) w%at_zero(1:m) = .true.
      call solve_with_zeros(w, m, ierr)
      if (ierr /= 0) exit
    end do
    if (ierr /= 0 .or. any(w%bnd(1:m) .and. w%x(1:m) + w%d(1:m) < 0.0_dp)) w%d(1:m) = 0.0_dp
    w%dj = 0.5_dp * dot_product(w%d(1:m), matmul(w%a(1:m, 1:m), w%d(1:m))) - dot_product(w%r(1:m), w%d(1:m))
    ! the unconstrained direction cut at the first bound: J changes by (alpha^2/2 - alpha) r^T d0
    alpha = 1.0_dp
    do i = 1, m
      if (w%bnd(i) .and. w%d0(i) < 0.0_dp) alpha = min(alpha, w%x(i) / (-w%d0(i)))
    end do
    dj_cut = (0.5_dp * alpha**2 - alpha) * dot_product(w%r(1:m), w%d0(1:m))
    if (dj_cut < w%dj) then
      w%d(1:m) = alpha * w%d0(1:m)
      w%dj = dj_cut
    end if
    if (.not. w%dj < 0.0_dp) then
      w%d(1:m) = 0.0_dp
      w%dj = 0.0_dp
    end if
  end subroutine patch_step

  !> w%d minimising 1/2 d^T a d - r^T d over the patch's m unknowns with d_i = -x_i where
  !> w%at_zero(i) (those unknowns go to 0): the block of the others copied to w%f and solved
  !> there (spd_solve_in_place).  ierr /= 0 when that block is not positive definite.
  pure subroutine solve_with_zeros(w, m, ierr)
    type(patch_work_t), intent(inout) :: w
    integer, intent(in) :: m
    integer, intent(out) :: ierr
    integer :: nf, i, j
    nf = 0
    do i = 1, m
      if (w%at_zero(i)) then
        w%d(i) = -w%x(i)
      else
        w%d(i) = 0.0_dp
        nf = nf + 1
        w%idx(nf) = i
      end if
    end do
    ierr = 0
    if (nf == 0) return
    do j = 1, nf
      w%y(j) = w%r(w%idx(j)) - dot_product(w%a(w%idx(j), 1:m), w%d(1:m))
      do i = j, nf
        w%f(i, j) = w%a(w%idx(i), w%idx(j))
      end do
    end do
    call spd_solve_in_place(nf, w%f, w%y, ierr)
    if (ierr /= 0) return
    w%d(w%idx(1:nf)) = w%y(1:nf)
  end subroutine solve_with_zeros

  !> y = F^{-1} y for the SPD matrix F whose lower triangle is f(1:n, 1:n) (ldl_factor,
  !> then ldl_solve; f holds the factor on return).  ierr = j > 0 when pivot j is not
  !> positive (F not positive definite).
  pure subroutine spd_solve_in_place(n, f, y, ierr)
    integer, intent(in) :: n
    real(dp), intent(inout) :: f(:,:), y(:)
    integer, intent(out) :: ierr
    call ldl_factor(n, f, ierr)
    if (ierr /= 0) return
    call ldl_solve(n, f, y)
  end subroutine spd_solve_in_place

  !> F = L D L^T for the SPD matrix F whose lower triangle is f(1:n, 1:n): symmetric
  !> Gaussian elimination on the lower triangle, L (unit, strictly lower) and D (diagonal)
  !> left in f.  ierr = j > 0 when pivot j is not positive (F not positive definite).
  pure subroutine ldl_factor(n, f, ierr)
    integer, intent(in) :: n
    real(dp), intent(inout) :: f(:,:)
    integer, intent(out) :: ierr
    integer :: i, j, k
    real(dp) :: rpiv, fkj
    ierr = 0
    do j = 1, n
      if (.not. f(j, j) > 0.0_dp) then
        ierr = j
        return
      end if
      rpiv = 1.0_dp / f(j, j)
      do k = j + 1, n                  ! the trailing lower triangle updated by column j
        fkj = f(k, j)
        do i = k, n
          f(i, k) = f(i, k) - f(i, j) * fkj * rpiv
        end do
      end do
      do i = j + 1, n                  ! column j of L
        f(i, j) = f(i, j) * rpiv
      end do
    end do
  end subroutine ldl_factor

  !> y = F^{-1} y with the factor F = L D L^T of ldl_factor in f(1:n, 1:n).
  pure subroutine ldl_solve(n, f, y)
    integer, intent(in) :: n
    real(dp), intent(in) :: f(:,:)
    real(dp), intent(inout) :: y(:)
    integer :: i, j
    real(dp) :: s
    do j = 1, n                        ! L z = y
      s = y(j)
      do i = j + 1, n
        y(i) = y(i) - f(i, j) * s
      end do
    end do
    do j = 1, n                        ! D^{-1}
      y(j) = y(j) / f(j, j)
    end do
    do j = n, 1, -1                    ! L^T y = z
      s = y(j)
      do i = j + 1, n
        s = s - f(i, j) * y(i)
      end do
      y(j) = s
    end do
  end subroutine ldl_solve

  !> y = a x for a small matrix a (m x n) of a table: explicit loops (the sizes of the
  !> tables' slices are not known to the compiler, and the runtime's matmul costs more
  !> than the product at these sizes).
  pure function small_matvec(m, n, a, x) result(y)
    integer, intent(in) :: m, n
    real(dp), intent(in) :: a(m, n), x(n)
    real(dp) :: y(m)
    integer :: j
    y = a(:, 1) * x(1)
    do j = 2, n
      y = y + a(:, j) * x(j)
    end do
  end function small_matvec
end module dualsig_dual_hdiv_smoother
