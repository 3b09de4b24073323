!> Triangular mesh of a plane polygonal domain and its derived topology.
!>
!> Conventions (used by every other module):
!> - `tri(:,t)` lists the vertices of triangle t counter-clockwise (positive signed area).
!> - Local edge k of a triangle (k = 1, 2, 3) joins local vertices k and mod(k,3)+1,
!>   i.e. the sides (1,2), (2,3), (3,1).
!> - Boundary edges are stored oriented so that the domain lies on their left: the
!>   outer loop runs counter-clockwise, the loops around holes clockwise.  For a
!>   boundary edge from a to b with direction (dx, dy) and length L the outward unit
!>   normal is (dy, -dx) / L.
!> - Every boundary edge carries an integer marker (> 0) chosen by the mesh source;
!>   a run decides by marker which edges form Gamma_u and which Gamma_a.
!> - A boundary node is a polygon corner when the directions of its incoming and
!>   outgoing boundary edges differ (sine of the angle > corner_sin_tol).
module dualsig_mesh
  use dualsig_kinds, only: dp, i8, corner_sin_tol, geom_rel_tol
  use dualsig_status, only: status_t, set_error, DS_ERR_MESH
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL, BYTES_LOGICAL
  implicit none
  private

  public :: mesh_t, mesh_build_topology, mesh_triangle_area, mesh_diameter, mesh_h, mesh_zero_area, &
            mesh_coordinate_scale, mesh_longest_side
  public :: mesh_move, mesh_release_adjacency, mesh_ensure_adjacency, mesh_boundary_markers

  !> Rounding of a triangle's area (a cross product of coordinate differences) in units of
  !> eps * coordinate scale * side (mesh_zero_area).
  real(dp), parameter :: area_rounding = 64.0_dp

  !> (mesh_move moves every allocatable component: a new component must be added there too.)
  type :: mesh_t
    integer :: nnode = 0                        !! number of nodes
    integer :: ntri = 0                         !! number of triangles
    integer :: nedge = 0                        !! number of edges (interior + boundary)
    integer :: nbedge = 0                       !! number of boundary edges
    integer :: nloop = 0                        !! number of boundary loops (1 + holes)
    real(dp), allocatable :: xy(:,:)            !! (2, nnode) node coordinates
    integer, allocatable :: tri(:,:)            !! (3, ntri) vertices, counter-clockwise
    integer, allocatable :: bedge_nodes(:,:)    !! (2, nbedge) boundary edge, domain on the left
    integer, allocatable :: bedge_marker(:)     !! (nbedge) boundary marker (> 0)
    !> (ntri) region of each triangle (Gmsh physical surface tag, Triangle region attribute);
    !> unallocated when the mesh source has no regions.  Refinement: children inherit it.
    integer, allocatable :: tri_region(:)
    !> (ntri) newest-vertex bisection (dualsig_mesh_adapt): bisections from the coarse
    !> ancestor; allocated only on meshes made by it, whose local edge 1 of every triangle
    !> (vertices 1, 2) is then its refinement edge.  Unallocated: no labelling yet.
    integer, allocatable :: tri_gen(:)
    ! ---- derived by mesh_build_topology ----
    integer, allocatable :: edge_nodes(:,:)     !! (2, nedge) end nodes, edge_nodes(1,e) < edge_nodes(2,e)
    !> edge_tri, tri_edge, node_bedge_in and node_bedge_out, the adjacency, may be released
    !> (mesh_release_adjacency) on a mesh that needs no more than its nodes, triangles, edges
    !> and boundary edges, and rebuilt by mesh_ensure_adjacency
    integer, allocatable :: edge_tri(:,:)       !! (2, nedge) adjacent triangles; edge_tri(2,e) = 0 on the boundary
    integer, allocatable :: tri_edge(:,:)       !! (3, ntri) global edge of local edge k (vertices k, k+1)
    integer, allocatable :: bedge_edge(:)       !! (nbedge) global edge number of a boundary edge
    integer, allocatable :: bedge_tri(:)        !! (nbedge) triangle containing the boundary edge
    real(dp), allocatable :: bedge_normal(:,:)  !! (2, nbedge) outward unit normal
    real(dp), allocatable :: bedge_length(:)    !! (nbedge) side length
    integer, allocatable :: loop_start(:)       !! (nloop+1) loop l is loop_bedge(loop_start(l):loop_start(l+1)-1)
    integer, allocatable :: loop_bedge(:)       !! (nbedge) boundary edges in traversal order
    integer, allocatable :: node_bedge_in(:)    !! (nnode) boundary edge ending at the node (0 inside)
    integer, allocatable :: node_bedge_out(:)   !! (nnode) boundary edge starting at the node (0 inside)
    logical, allocatable :: node_on_boundary(:) !! (nnode)
    logical, allocatable :: node_is_corner(:)   !! (nnode) polygon corner of the boundary
  end type mesh_t

  !> Edge lookup built by build_edges: the edges of node lo (their smaller node) are
  !> bucket_edge(head(lo) : head(lo) + cnt(lo) - 1), with other end nodes bucket_other.
  type :: edge_table_t
    integer, allocatable :: head(:), cnt(:), bucket_other(:), bucket_edge(:)
  end type edge_table_t

  !> The triangle, listed boundary edge or node an error of mesh_build_topology is about (0: none).
  type :: culprit_t
    integer :: tri = 0, bedge = 0, node = 0
  end type culprit_t

contains

  !> Signed area of triangle t (positive for counter-clockwise vertices).
  pure real(dp) function mesh_triangle_area(mesh, t) result(area)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: t
    real(dp) :: a(2), b(2), c(2)
    a = mesh%xy(:, mesh%tri(1, t))
    b = mesh%xy(:, mesh%tri(2, t))
    c = mesh%xy(:, mesh%tri(3, t))
    area = 0.5_dp * ((b(1) - a(1)) * (c(2) - a(2)) - (c(1) - a(1)) * (b(2) - a(2)))
  end function mesh_triangle_area

  !> The area at or below which triangle t counts as degenerate (no orientation): the
  !> larger of geom_rel_tol times the square of its longest side (a shape criterion, the
  !> same for the children of a uniform refinement, which are similar to their parent)
  !> and the rounding of the area's cross product for coordinates of size `scale`
  !> (mesh_coordinate_scale) and sides of that length.
  pure real(dp) function mesh_zero_area(mesh, t, scale) result(z)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: t
    real(dp), intent(in) :: scale
    real(dp) :: h
    h = mesh_longest_side(mesh, t)
    z = max(geom_rel_tol * h**2, area_rounding * epsilon(1.0_dp) * scale * h)
  end function mesh_zero_area

  !> The distinct markers of the boundary edges, ascending (none without boundary edges).
  pure function mesh_boundary_markers(mesh) result(markers)
    type(mesh_t), intent(in) :: mesh
    integer, allocatable :: markers(:)
    allocate (markers(0))                     ! small: empty
    if (mesh%nbedge < 1) return
    markers = [minval(mesh%bedge_marker(1:mesh%nbedge))]
    do while (any(mesh%bedge_marker(1:mesh%nbedge) > markers(size(markers))))
      markers = [markers, minval(mesh%bedge_marker(1:mesh%nbedge), &
                                 mask=mesh%bedge_marker(1:mesh%nbedge) > markers(size(markers)))]
    end do
  end function mesh_boundary_markers

  !> The longest side of triangle t.
  pure real(dp) function mesh_longest_side(mesh, t) result(h)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: t
    integer :: k
    h = 0.0_dp
    do k = 1, 3
      h = max(h, norm2(mesh%xy(:, mesh%tri(mod(k, 3) + 1, t)) - mesh%xy(:, mesh%tri(k, t))))
    end do
  end function mesh_longest_side

  !> The largest coordinate magnitude of the nodes (the scale of their rounding).
  pure real(dp) function mesh_coordinate_scale(mesh) result(r)
    type(mesh_t), intent(in) :: mesh
    r = 0.0_dp
    if (mesh%nnode > 0) r = maxval(abs(mesh%xy(:, 1:mesh%nnode)))
  end function mesh_coordinate_scale

  !> Diameter of the bounding box of the nodes (the length scale for geometric tolerances).
  pure real(dp) function mesh_diameter(mesh) result(d)
    type(mesh_t), intent(in) :: mesh
    if (mesh%nnode == 0) then
      d = 0.0_dp
      return
    end if
    d = hypot(maxval(mesh%xy(1, :)) - minval(mesh%xy(1, :)), &
              maxval(mesh%xy(2, :)) - minval(mesh%xy(2, :)))
  end function mesh_diameter

  !> Mesh size h: the longest side of all triangles (the paper's definition, Section 2).
  pure real(dp) function mesh_h(mesh) result(h)
    type(mesh_t), intent(in) :: mesh
    integer :: t, k
    real(dp) :: d(2)
    h = 0.0_dp
    do t = 1, mesh%ntri
      do k = 1, 3
        d = mesh%xy(:, mesh%tri(mod(k, 3) + 1, t)) - mesh%xy(:, mesh%tri(k, t))
        h = max(h, sqrt(d(1)**2 + d(2)**2))
      end do
    end do
  end function mesh_h

  !> Build edges, edge-triangle adjacency, boundary orientation, normals, lengths,
  !> boundary loops and corners from `xy`, `tri`, `bedge_nodes` and `bedge_marker`.
  !>
  !> Checks: indices in range, positive triangle areas, no edge shared by more than two
  !> triangles, every node a vertex of some triangle, every topological boundary edge
  !> listed exactly once with a marker > 0, no listed boundary edge that is interior,
  !> boundary loops closed and manifold.  A side missing from the boundary list is
  !> reported as a hanging node when a node lies inside it (non-conforming mesh).
  !> The input orientation of boundary edges is free; they are re-oriented so that the
  !> domain lies on their left.  Runs in time linear in the number of triangles (the
  !> hanging-node search runs only on the error path).
  !> On an error, `bad_tri`, `bad_bedge` and `bad_node` (optional) return the triangle,
  !> listed boundary edge or node the message is about (0: none), so that a reader can
  !> name the line of the file.
  subroutine mesh_build_topology(mesh, st, bad_tri, bad_bedge, bad_node)
    type(mesh_t), intent(inout) :: mesh
    type(status_t), intent(out) :: st
    integer, intent(out), optional :: bad_tri, bad_bedge, bad_node
    type(culprit_t) :: bad
    integer, allocatable :: bedge_of_edge(:), bedge_e(:)
    logical, allocatable :: used(:)

    call check_triangles(mesh, st, bad)
    if (st%code == 0) call build_edges(mesh, bedge_e, st, bad)
    if (st%code == 0) then
      ! every node must be a vertex (an unused node has no basis function support)
      call mark_vertices(mesh, used, st)
      if (st%code == 0) call match_boundary_edges(mesh, bedge_e, used, bedge_of_edge, st, bad)
    end if
    if (st%code == 0) call check_all_listed(mesh, bedge_of_edge, st, bad)
    if (st%code == 0) call check_nodes_used(mesh, used, st, bad)
    if (st%code == 0) call link_boundary_nodes(mesh, st)
    if (st%code == 0) call trace_boundary_loops(mesh, bedge_of_edge, st)
    if (st%code == 0) call mark_corners(mesh)
    if (present(bad_tri)) bad_tri = bad%tri
    if (present(bad_bedge)) bad_bedge = bad%bedge
    if (present(bad_node)) bad_node = bad%node
  end subroutine mesh_build_topology

  !> Check the triangle list: enough nodes and triangles, vertex indices in range, and
  !> every area above its tolerance mesh_zero_area (counter-clockwise vertices).
  subroutine check_triangles(mesh, st, bad)
    type(mesh_t), intent(in) :: mesh
    type(status_t), intent(inout) :: st
    type(culprit_t), intent(inout) :: bad
    integer :: t
    real(dp) :: scale, area, zero
    character(len=320) :: buf

    if (mesh%nnode < 3 .or. mesh%ntri < 1) then
      call set_error(st, DS_ERR_MESH, 'mesh: need at least 3 nodes and 1 triangle')
      return
    end if
    if (any(mesh%tri(:, 1:mesh%ntri) < 1) .or. any(mesh%tri(:, 1:mesh%ntri) > mesh%nnode)) then
      t = findloc(any(mesh%tri < 1 .or. mesh%tri > mesh%nnode, dim=1), .true., dim=1)
      write (buf, '(a,i0,a,i0,a)') 'mesh: triangle ', t, ' has a vertex index outside 1..', &
        mesh%nnode, ' (node count)'
      call set_error(st, DS_ERR_MESH, trim(buf))
      bad%tri = t
      return
    end if
    scale = mesh_coordinate_scale(mesh)
    do t = 1, mesh%ntri
      area = mesh_triangle_area(mesh, t)
      zero = mesh_zero_area(mesh, t, scale)
      if (area <= zero) then
        if (area < -zero) then
          write (buf, '(a,i0,a)') 'mesh: triangle ', t, &
            ' has zero or negative area: its vertices are clockwise (expected counter-clockwise vertices)'
        else
          write (buf, '(a,i0,a,es10.3e3,a,es10.3e3,a)') 'mesh: triangle ', t, ' has zero or negative area: ', &
            area, ', at most the tolerance ', zero, ' (1e-12 times the square of its longest side, or the ' // &
            'rounding of its area; expected three non-collinear vertices, not a needle)'
        end if
        call set_error(st, DS_ERR_MESH, trim(buf))
        bad%tri = t
        return
      end if
    end do
  end subroutine check_triangles

  !> Number the edges: bucket the 3*ntri half-edges by their smaller node (counting sort),
  !> numbering each edge where a triangle first has it, giving tri_edge, nedge and
  !> edge_nodes (sized exactly), then edge_tri (link_edge_triangles); bedge_e(j) is the edge
  !> of listed boundary edge j (0: none, or bad node indices).  The lookup table is freed
  !> before edge_tri is allocated (the peak memory of a refinement).  Rejects repeated
  !> vertices and edges of more than two triangles, the first in triangle order.
  subroutine build_edges(mesh, bedge_e, st, bad)
    type(mesh_t), intent(inout) :: mesh
    integer, allocatable, intent(out) :: bedge_e(:)
    type(status_t), intent(inout) :: st
    type(culprit_t), intent(inout) :: bad
    type(edge_table_t) :: tab
    integer :: t, k, a, b, lo, hi, e, j, ne, p, q, ist, t_rep, k_rep
    character(len=320) :: buf

    call bucket_heads(mesh%nnode, tab, st)
    if (st%code /= 0) return
    do t = 1, mesh%ntri
      do k = 1, 3
        lo = min(mesh%tri(k, t), mesh%tri(mod(k, 3) + 1, t))
        tab%cnt(lo + 1) = tab%cnt(lo + 1) + 1
      end do
    end do
    call bucket_fill_heads(mesh%nnode, tab)
    allocate (tab%bucket_other(3 * mesh%ntri), tab%bucket_edge(3 * mesh%ntri), mesh%tri_edge(3, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the edges of the mesh', 9_i8 * mesh%ntri, BYTES_INT)) return
    ne = 0
    t_rep = 0
    k_rep = 0
    sides: do t = 1, mesh%ntri
      do k = 1, 3
        a = mesh%tri(k, t)
        b = mesh%tri(mod(k, 3) + 1, t)
        lo = min(a, b)
        hi = max(a, b)
        if (lo == hi) then
          t_rep = t
          k_rep = k
          exit sides
        end if
        e = find_edge(tab, lo, hi)
        if (e == 0) then
          ne = ne + 1
          e = ne
          p = tab%head(lo) + tab%cnt(lo)
          tab%cnt(lo) = tab%cnt(lo) + 1
          tab%bucket_other(p) = hi
          tab%bucket_edge(p) = e
        end if
        mesh%tri_edge(k, t) = e
      end do
    end do sides
    mesh%nedge = ne
    allocate (mesh%edge_nodes(2, ne), bedge_e(mesh%nbedge), stat=ist)
    if (alloc_failed(ist, st, 'the edges of the mesh', 2_i8 * ne + mesh%nbedge, BYTES_INT)) return
    do lo = 1, mesh%nnode
      do q = tab%head(lo), tab%head(lo) + tab%cnt(lo) - 1
        mesh%edge_nodes(:, tab%bucket_edge(q)) = [lo, tab%bucket_other(q)]
      end do
    end do
    bedge_e = 0
    do j = 1, mesh%nbedge
      a = mesh%bedge_nodes(1, j)
      b = mesh%bedge_nodes(2, j)
      if (min(a, b) >= 1 .and. max(a, b) <= mesh%nnode .and. a /= b) bedge_e(j) = find_edge(tab, min(a, b), max(a, b))
    end do
    deallocate (tab%head, tab%cnt, tab%bucket_other, tab%bucket_edge)
    ! an edge of more than two triangles before the repeated vertex is the first error
    call link_edge_triangles(mesh, t_rep, k_rep, st, bad)
    if (st%code /= 0 .or. t_rep == 0) return
    write (buf, '(a,i0,a)') 'mesh: triangle ', t_rep, ' repeats a vertex'
    call set_error(st, DS_ERR_MESH, trim(buf))
    bad%tri = t_rep
  end subroutine build_edges

  !> The node counters of an edge table for n nodes, zeroed (the caller counts the edges of
  !> node lo in cnt(lo + 1), then calls bucket_fill_heads).
  subroutine bucket_heads(n, tab, st)
    integer, intent(in) :: n
    type(edge_table_t), intent(inout) :: tab
    type(status_t), intent(inout) :: st
    integer :: ist
    allocate (tab%cnt(n + 1), tab%head(n + 1), stat=ist)
    if (alloc_failed(ist, st, 'the node table of the edges', 2 * n + 2, BYTES_INT)) return
    tab%cnt = 0
  end subroutine bucket_heads

  !> The heads of the buckets from the counts cnt(lo + 1); cnt zeroed again (it then counts
  !> the edges stored in each bucket).
  subroutine bucket_fill_heads(n, tab)
    integer, intent(in) :: n
    type(edge_table_t), intent(inout) :: tab
    integer :: j
    tab%head(1) = 1
    do j = 1, n
      tab%head(j + 1) = tab%head(j) + tab%cnt(j + 1)
    end do
    tab%cnt = 0
  end subroutine bucket_fill_heads

  !> edge_tri from tri_edge: the triangles of each edge in triangle order, over the sides
  !> (t, k) before (t_stop, k_stop) (all of them when t_stop = 0).  Rejects an edge of more
  !> than two triangles.
  subroutine link_edge_triangles(mesh, t_stop, k_stop, st, bad)
    type(mesh_t), intent(inout) :: mesh
    integer, intent(in) :: t_stop, k_stop
    type(status_t), intent(inout) :: st
    type(culprit_t), intent(inout) :: bad
    integer :: t, k, e, ist
    character(len=320) :: buf
    allocate (mesh%edge_tri(2, mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the edge-triangle adjacency of the mesh', 2_i8 * mesh%nedge, BYTES_INT)) return
    mesh%edge_tri = 0
    do t = 1, mesh%ntri
      do k = 1, 3
        if (t == t_stop .and. k == k_stop) return
        e = mesh%tri_edge(k, t)
        if (mesh%edge_tri(1, e) == 0) then
          mesh%edge_tri(1, e) = t
        else if (mesh%edge_tri(2, e) == 0) then
          mesh%edge_tri(2, e) = t
        else
          write (buf, '(a,i0,a,i0,a,i0,a,i0,a,i0,a)') 'mesh: edge (', mesh%edge_nodes(1, e), ',', mesh%edge_nodes(2, e), &
            ') is shared by more than two triangles (triangles ', mesh%edge_tri(1, e), ', ', &
            mesh%edge_tri(2, e), ' and ', t, '; expected at most two: overlapping triangles?)'
          call set_error(st, DS_ERR_MESH, trim(buf))
          bad%tri = t
          return
        end if
      end do
    end do
  end subroutine link_edge_triangles

  !> Release the adjacency edge_tri, tri_edge, node_bedge_in and node_bedge_out (56 of the
  !> topology's 128 bytes per node on a uniform mesh) of a mesh that needs only its nodes,
  !> triangles, edges and boundary edges from now on (the last level of a primal-only run);
  !> mesh_ensure_adjacency rebuilds it.
  subroutine mesh_release_adjacency(mesh)
    type(mesh_t), intent(inout) :: mesh
    if (allocated(mesh%edge_tri)) deallocate (mesh%edge_tri)
    if (allocated(mesh%tri_edge)) deallocate (mesh%tri_edge)
    if (allocated(mesh%node_bedge_in)) deallocate (mesh%node_bedge_in)
    if (allocated(mesh%node_bedge_out)) deallocate (mesh%node_bedge_out)
  end subroutine mesh_release_adjacency

  !> Rebuild the adjacency (edge_tri, tri_edge, node_bedge_in, node_bedge_out), when
  !> released, from edge_nodes, tri and bedge_nodes: the same arrays as mesh_build_topology's
  !> (edges keep their numbers).  A mesh that has them is left alone; one without edges (no
  !> mesh_build_topology) is an error.
  subroutine mesh_ensure_adjacency(mesh, st)
    type(mesh_t), intent(inout) :: mesh
    type(status_t), intent(inout) :: st
    type(edge_table_t) :: tab
    type(culprit_t) :: bad
    integer :: t, k, e, lo, hi, p, ist
    if (allocated(mesh%edge_tri) .and. allocated(mesh%tri_edge) .and. allocated(mesh%node_bedge_in) .and. &
        allocated(mesh%node_bedge_out)) return
    if (.not. allocated(mesh%edge_nodes)) then
      call set_error(st, DS_ERR_MESH, 'mesh: no topology (expected a mesh finished by mesh_build_topology)')
      return
    end if
    call mesh_release_adjacency(mesh)
    call bucket_heads(mesh%nnode, tab, st)
    if (st%code /= 0) return
    do e = 1, mesh%nedge
      lo = mesh%edge_nodes(1, e)
      tab%cnt(lo + 1) = tab%cnt(lo + 1) + 1
    end do
    call bucket_fill_heads(mesh%nnode, tab)
    allocate (tab%bucket_other(mesh%nedge), tab%bucket_edge(mesh%nedge), mesh%tri_edge(3, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the triangle-edge adjacency of the mesh', 2_i8 * mesh%nedge + 3_i8 * mesh%ntri, &
                     BYTES_INT)) return
    do e = 1, mesh%nedge
      lo = mesh%edge_nodes(1, e)
      p = tab%head(lo) + tab%cnt(lo)
      tab%cnt(lo) = tab%cnt(lo) + 1
      tab%bucket_other(p) = mesh%edge_nodes(2, e)
      tab%bucket_edge(p) = e
    end do
    do t = 1, mesh%ntri
      do k = 1, 3
        lo = min(mesh%tri(k, t), mesh%tri(mod(k, 3) + 1, t))
        hi = max(mesh%tri(k, t), mesh%tri(mod(k, 3) + 1, t))
        e = find_edge(tab, lo, hi)
        if (e == 0) then
          call set_error(st, DS_ERR_MESH, 'mesh: a side of a triangle is not among the edges (the triangles changed ' // &
            'since mesh_build_topology?)')
          call mesh_release_adjacency(mesh)
          return
        end if
        mesh%tri_edge(k, t) = e
      end do
    end do
    deallocate (tab%head, tab%cnt, tab%bucket_other, tab%bucket_edge)
    call link_edge_triangles(mesh, 0, 0, st, bad)
    if (st%code == 0) call link_boundary_nodes(mesh, st)
  end subroutine mesh_ensure_adjacency

  !> mesh_to = mesh_from without copying the arrays (moved); mesh_from is left empty.
  subroutine mesh_move(mesh_from, mesh_to)
    type(mesh_t), intent(inout) :: mesh_from
    type(mesh_t), intent(out) :: mesh_to
    mesh_to%nnode = mesh_from%nnode
    mesh_to%ntri = mesh_from%ntri
    mesh_to%nedge = mesh_from%nedge
    mesh_to%nbedge = mesh_from%nbedge
    mesh_to%nloop = mesh_from%nloop
    call move_alloc(mesh_from%xy, mesh_to%xy)
    call move_alloc(mesh_from%tri, mesh_to%tri)
    call move_alloc(mesh_from%bedge_nodes, mesh_to%bedge_nodes)
    call move_alloc(mesh_from%bedge_marker, mesh_to%bedge_marker)
    call move_alloc(mesh_from%tri_region, mesh_to%tri_region)
    call move_alloc(mesh_from%tri_gen, mesh_to%tri_gen)
    call move_alloc(mesh_from%edge_nodes, mesh_to%edge_nodes)
    call move_alloc(mesh_from%edge_tri, mesh_to%edge_tri)
    call move_alloc(mesh_from%tri_edge, mesh_to%tri_edge)
    call move_alloc(mesh_from%bedge_edge, mesh_to%bedge_edge)
    call move_alloc(mesh_from%bedge_tri, mesh_to%bedge_tri)
    call move_alloc(mesh_from%bedge_normal, mesh_to%bedge_normal)
    call move_alloc(mesh_from%bedge_length, mesh_to%bedge_length)
    call move_alloc(mesh_from%loop_start, mesh_to%loop_start)
    call move_alloc(mesh_from%loop_bedge, mesh_to%loop_bedge)
    call move_alloc(mesh_from%node_bedge_in, mesh_to%node_bedge_in)
    call move_alloc(mesh_from%node_bedge_out, mesh_to%node_bedge_out)
    call move_alloc(mesh_from%node_on_boundary, mesh_to%node_on_boundary)
    call move_alloc(mesh_from%node_is_corner, mesh_to%node_is_corner)
    mesh_from = mesh_t()
  end subroutine mesh_move

  !> used(j): node j is a vertex of some triangle.
  subroutine mark_vertices(mesh, used, st)
    type(mesh_t), intent(in) :: mesh
    logical, allocatable, intent(out) :: used(:)
    type(status_t), intent(inout) :: st
    integer :: t, ist
    allocate (used(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the node flags of the mesh', mesh%nnode, BYTES_LOGICAL)) return
    used = .false.
    do t = 1, mesh%ntri
      used(mesh%tri(:, t)) = .true.
    end do
  end subroutine mark_vertices

  !> Match the listed boundary edges to the topological ones (bedge_e(j): the edge of listed
  !> edge j found by build_edges, 0 for none; bedge_of_edge(e): the listed edge on edge e,
  !> 0 for none), orient them with the domain on their left and compute
  !> bedge_edge, bedge_tri, bedge_length and bedge_normal.  Rejects bad node indices and
  !> markers, listed edges that are no side, interior sides and repeated sides.
  subroutine match_boundary_edges(mesh, bedge_e, used, bedge_of_edge, st, bad)
    type(mesh_t), intent(inout) :: mesh
    integer, intent(in) :: bedge_e(:)
    logical, intent(in) :: used(:)
    integer, allocatable, intent(out) :: bedge_of_edge(:)
    type(status_t), intent(inout) :: st
    type(culprit_t), intent(inout) :: bad
    integer :: t, k, a, b, lo, hi, e, j, ist
    real(dp) :: d(2)
    character(len=320) :: buf

    allocate (bedge_of_edge(mesh%nedge), mesh%bedge_edge(mesh%nbedge), mesh%bedge_tri(mesh%nbedge), &
              mesh%bedge_normal(2, mesh%nbedge), mesh%bedge_length(mesh%nbedge), stat=ist)
    if (alloc_failed(ist, st, 'the boundary edges of the mesh', mesh%nedge + 5 * mesh%nbedge, BYTES_REAL)) return
    bedge_of_edge = 0
    do j = 1, mesh%nbedge
      a = mesh%bedge_nodes(1, j)
      b = mesh%bedge_nodes(2, j)
      if (min(a, b) < 1 .or. max(a, b) > mesh%nnode) then
        write (buf, '(a,i0,a,i0)') 'mesh: boundary edge ', j, &
          ' has a node index outside 1..', mesh%nnode
        call set_error(st, DS_ERR_MESH, trim(buf))
        bad%bedge = j
        return
      end if
      if (mesh%bedge_marker(j) <= 0) then
        write (buf, '(a,i0,a)') 'mesh: boundary edge ', j, ' has no marker (expected an integer > 0)'
        call set_error(st, DS_ERR_MESH, trim(buf))
        bad%bedge = j
        return
      end if
      lo = min(a, b)
      hi = max(a, b)
      e = bedge_e(j)
      if (e == 0) then
        if (.not. used(a) .or. .not. used(b)) then
          ! (A3): the end points of Gamma_u / Gamma_a pieces must be vertices of the triangulation
          write (buf, '(a,i0,a,i0,a,i0,a,i0,a)') 'mesh: boundary edge ', j, ' (', lo, ',', hi, &
            ') ends at node ', merge(b, a, used(a)), ', which is not a vertex of any triangle ' // &
            '(expected a side of a triangle: the end points of Gamma_u and Gamma_a must be mesh vertices, A3)'
        else
          write (buf, '(a,i0,a,i0,a,i0,a)') 'mesh: boundary edge ', j, ' (', lo, ',', hi, &
            ') is not a side of any triangle (expected two vertices of one triangle)'
        end if
        call set_error(st, DS_ERR_MESH, trim(buf))
        bad%bedge = j
        return
      end if
      if (mesh%edge_tri(2, e) /= 0) then
        write (buf, '(a,i0,a,i0,a,i0,a)') 'mesh: boundary edge ', j, ' (', lo, ',', hi, &
          ') is an interior edge (expected a side of only one triangle)'
        call set_error(st, DS_ERR_MESH, trim(buf))
        bad%bedge = j
        return
      end if
      if (bedge_of_edge(e) /= 0) then
        write (buf, '(a,i0,a,i0,a)') 'mesh: boundary edge ', j, ' repeats boundary edge ', &
          bedge_of_edge(e), ' (expected every boundary side once)'
        call set_error(st, DS_ERR_MESH, trim(buf))
        bad%bedge = j
        return
      end if
      bedge_of_edge(e) = j
      t = mesh%edge_tri(1, e)
      k = findloc(mesh%tri_edge(:, t), e, dim=1)
      ! orient as in the counter-clockwise triangle: the domain lies on the left
      mesh%bedge_nodes(:, j) = [mesh%tri(k, t), mesh%tri(mod(k, 3) + 1, t)]
      mesh%bedge_edge(j) = e
      mesh%bedge_tri(j) = t
      d = mesh%xy(:, mesh%bedge_nodes(2, j)) - mesh%xy(:, mesh%bedge_nodes(1, j))
      mesh%bedge_length(j) = hypot(d(1), d(2))
      mesh%bedge_normal(:, j) = [d(2), -d(1)] / mesh%bedge_length(j)
    end do
  end subroutine match_boundary_edges

  !> Every listed edge matched a distinct topological boundary edge: any left over are
  !> unlisted, an error (reported for the first one).
  subroutine check_all_listed(mesh, bedge_of_edge, st, bad)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: bedge_of_edge(:)
    type(status_t), intent(inout) :: st
    type(culprit_t), intent(inout) :: bad
    integer :: e
    if (count(mesh%edge_tri(2, :) == 0) /= mesh%nbedge) then
      e = findloc(mesh%edge_tri(2, :) == 0 .and. bedge_of_edge == 0, .true., dim=1)
      call report_unlisted_side(mesh, e, st, bad)
    end if
  end subroutine check_all_listed

  !> Error: the side edge_nodes(:, e) of triangle edge_tri(1, e) is a boundary side that
  !> the boundary list lacks.  When a node lies inside it, or one of its end nodes lies
  !> inside another boundary side, the mesh is non-conforming (hanging node): say so.
  subroutine report_unlisted_side(mesh, e, st, bad)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: e
    type(status_t), intent(inout) :: st
    type(culprit_t), intent(inout) :: bad
    integer :: c, f, hang, host, k
    real(dp) :: tol
    character(len=320) :: buf
    tol = geom_rel_tol * mesh_diameter(mesh)
    hang = 0
    host = e
    do c = 1, mesh%nnode
      if (c == mesh%edge_nodes(1, e) .or. c == mesh%edge_nodes(2, e)) cycle
      if (inside_segment(mesh%xy(:, c), mesh%xy(:, mesh%edge_nodes(1, e)), &
                         mesh%xy(:, mesh%edge_nodes(2, e)), tol)) then
        hang = c
        exit
      end if
    end do
    if (hang == 0) then
      search: do f = 1, mesh%nedge
        if (f == e .or. mesh%edge_tri(2, f) /= 0) cycle
        do k = 1, 2
          c = mesh%edge_nodes(k, e)
          if (c == mesh%edge_nodes(1, f) .or. c == mesh%edge_nodes(2, f)) cycle
          if (inside_segment(mesh%xy(:, c), mesh%xy(:, mesh%edge_nodes(1, f)), &
                             mesh%xy(:, mesh%edge_nodes(2, f)), tol)) then
            hang = c
            host = f
            exit search
          end if
        end do
      end do search
    end if
    if (hang /= 0) then
      write (buf, '(a,i0,a,i0,a,i0,a,i0,a)') 'mesh: node ', hang, ' lies inside the side (', &
        mesh%edge_nodes(1, host), ',', mesh%edge_nodes(2, host), ') of triangle ', mesh%edge_tri(1, host), &
        ' without being one of its vertices: a hanging node (expected a conforming triangulation, ' // &
        'neighbouring triangles sharing whole sides)'
      call set_error(st, DS_ERR_MESH, trim(buf))
      bad%tri = mesh%edge_tri(1, host)
    else
      write (buf, '(a,i0,a,i0,a,i0,a)') 'mesh: the side (', mesh%edge_nodes(1, e), ',', &
        mesh%edge_nodes(2, e), ') of triangle ', mesh%edge_tri(1, e), ' is on the boundary but not in ' // &
        'the boundary list (expected every boundary side listed once, with a marker > 0)'
      call set_error(st, DS_ERR_MESH, trim(buf))
      bad%tri = mesh%edge_tri(1, e)
    end if
  end subroutine report_unlisted_side

  !> Error for the first node that is not a vertex of any triangle.
  subroutine check_nodes_used(mesh, used, st, bad)
    type(mesh_t), intent(in) :: mesh
    logical, intent(in) :: used(:)
    type(status_t), intent(inout) :: st
    type(culprit_t), intent(inout) :: bad
    integer :: j
    character(len=320) :: buf
    do j = 1, mesh%nnode
      if (.not. used(j)) then
        write (buf, '(a,i0,a)') 'mesh: node ', j, ' is not a vertex of any triangle (expected every ' // &
          'node to be used by a triangle)'
        call set_error(st, DS_ERR_MESH, trim(buf))
        bad%node = j
        return
      end if
    end do
  end subroutine check_nodes_used

  !> node_bedge_out / node_bedge_in: the boundary edge leaving / entering each node;
  !> rejects a node that two boundary edges leave or enter.
  subroutine link_boundary_nodes(mesh, st)
    type(mesh_t), intent(inout) :: mesh
    type(status_t), intent(inout) :: st
    integer :: j, a, b, ist
    character(len=320) :: buf
    allocate (mesh%node_bedge_in(mesh%nnode), mesh%node_bedge_out(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the boundary links of the nodes', 2 * mesh%nnode, BYTES_INT)) return
    mesh%node_bedge_in = 0
    mesh%node_bedge_out = 0
    do j = 1, mesh%nbedge
      a = mesh%bedge_nodes(1, j)
      b = mesh%bedge_nodes(2, j)
      if (mesh%node_bedge_out(a) /= 0 .or. mesh%node_bedge_in(b) /= 0) then
        write (buf, '(a,i0,a)') 'mesh: boundary is not a set of simple closed loops at node ', &
          merge(a, b, mesh%node_bedge_out(a) /= 0), ' (two boundary edges leave or enter it)'
        call set_error(st, DS_ERR_MESH, trim(buf))
        return
      end if
      mesh%node_bedge_out(a) = j
      mesh%node_bedge_in(b) = j
    end do
  end subroutine link_boundary_nodes

  !> Boundary loops (nloop, loop_start, loop_bedge): follow the boundary edges head to
  !> tail; also allocates node_on_boundary (set here) and node_is_corner.  Rejects a loop
  !> that does not close.  `visited` (size >= nbedge) is workspace.
  subroutine trace_boundary_loops(mesh, visited, st)
    type(mesh_t), intent(inout) :: mesh
    integer, intent(inout) :: visited(:)
    type(status_t), intent(inout) :: st
    integer :: nb, p, l, start, cur, steps, nxt, ist
    nb = mesh%nbedge
    allocate (mesh%loop_bedge(nb), mesh%loop_start(nb + 1), mesh%node_on_boundary(mesh%nnode), &
              mesh%node_is_corner(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the boundary loops of the mesh', 2 * nb + 2 * mesh%nnode + 1, BYTES_INT)) return
    mesh%node_on_boundary = mesh%node_bedge_out /= 0
    visited = 0            ! a flag per boundary edge
    p = 0
    l = 0
    do start = 1, nb
      if (visited(start) /= 0) cycle
      l = l + 1
      mesh%loop_start(l) = p + 1
      cur = start
      steps = 0
      do
        p = p + 1
        steps = steps + 1
        mesh%loop_bedge(p) = cur
        visited(cur) = 1
        nxt = mesh%node_bedge_out(mesh%bedge_nodes(2, cur))
        if (nxt == start) exit
        if (nxt == 0 .or. steps > nb) then
          call set_error(st, DS_ERR_MESH, 'mesh: a boundary loop is not closed')
          return
        end if
        cur = nxt
      end do
    end do
    mesh%nloop = l
    mesh%loop_start(l + 1) = p + 1
    mesh%loop_start = mesh%loop_start(1:l + 1)
  end subroutine trace_boundary_loops

  !> node_is_corner: boundary nodes where the incoming and outgoing boundary edges turn
  !> (|sine of the angle| > corner_sin_tol) or reverse.
  subroutine mark_corners(mesh)
    type(mesh_t), intent(inout) :: mesh
    integer :: j, a, b
    real(dp) :: din(2), dout(2), len_in, len_out, sin_angle
    mesh%node_is_corner = .false.
    do j = 1, mesh%nnode
      if (.not. mesh%node_on_boundary(j)) cycle
      a = mesh%node_bedge_in(j)
      b = mesh%node_bedge_out(j)
      din = mesh%xy(:, mesh%bedge_nodes(2, a)) - mesh%xy(:, mesh%bedge_nodes(1, a))
      dout = mesh%xy(:, mesh%bedge_nodes(2, b)) - mesh%xy(:, mesh%bedge_nodes(1, b))
      len_in = hypot(din(1), din(2))
      len_out = hypot(dout(1), dout(2))
      sin_angle = (din(1) * dout(2) - din(2) * dout(1)) / (len_in * len_out)
      ! a reversal (dot < 0) with sine ~ 0 is also a corner (a slit tip)
      mesh%node_is_corner(j) = abs(sin_angle) > corner_sin_tol .or. dot_product(din, dout) < 0.0_dp
    end do
  end subroutine mark_corners

  !> The edge (lo, hi), lo < hi, already stored in lo's bucket of `tab`, or 0.
  pure integer function find_edge(tab, lo, hi) result(edge)
    type(edge_table_t), intent(in) :: tab
    integer, intent(in) :: lo, hi
    integer :: q
    edge = 0
    do q = tab%head(lo), tab%head(lo) + tab%cnt(lo) - 1
      if (tab%bucket_other(q) == hi) then
        edge = tab%bucket_edge(q)
        return
      end if
    end do
  end function find_edge

  !> True when point p lies on the segment from a to b, strictly between its end points:
  !> distance to the line <= tol and the projection more than tol from both ends.
  pure logical function inside_segment(p, a, b, tol) result(inside)
    real(dp), intent(in) :: p(2), a(2), b(2), tol
    real(dp) :: d(2), len_ab, along, across
    d = b - a
    len_ab = hypot(d(1), d(2))
    inside = .false.
    if (.not. (len_ab > tol)) return
    along = dot_product(p - a, d) / len_ab
    across = abs(d(1) * (p(2) - a(2)) - d(2) * (p(1) - a(1))) / len_ab
    inside = across <= tol .and. along > tol .and. along < len_ab - tol
  end function inside_segment
end module dualsig_mesh
