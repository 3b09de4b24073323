!> Adaptive refinement: newest-vertex bisection with conforming closure, the matching P1
!> prolongation, and Doerfler marking.
!>
!> Labelling.  Every triangle carries a refinement edge: on a mesh made here it is local
!> edge 1 (vertices 1 -> 2; the newest vertex is vertex 3) and `mesh%tri_gen` (bisections
!> from the coarse ancestor) is allocated.  A mesh without `tri_gen` (a generator's, a
!> reader's, a uniformly refined one) is labelled first: each triangle's vertices are
!> rotated cyclically (orientation kept) so that its longest side is local edge 1 (the
!> first of equally long sides), its generation 0.
!>
!> Bisection of (a, b, c) at the midpoint p of its refinement edge ab gives the children
!> (c, a, p) and (b, c, p), both counter-clockwise, each with its refinement edge opposite
!> the new vertex p (a side of the parent).  In two dimensions this produces at most
!> four similarity classes per coarse triangle, so the smallest angle stays bounded below
!> by a constant of the coarse mesh (Sewell; Mitchell).
!>
!> Closure.  The marked triangles mark their refinement edges; a triangle with a marked
!> edge marks its own refinement edge too, until nothing changes (a queue over edges,
!> linear in the number of marked edges).  Every triangle with a marked edge is then
!> bisected at its refinement edge, and each child again when its refinement edge (a side
!> of the parent) is marked: 2, 3 or 4 children.  Both sides of every marked edge split it
!> at its midpoint, so the result is conforming.
!>
!> Numbering of the refined mesh (relied upon by mesh_prolongate_bisection): nodes
!> 1..nnode are the coarse nodes, node nnode + k the midpoint of the k-th marked edge (in
!> edge order), whose end nodes are parents(:, k).  A boundary edge that is split becomes
!> two boundary edges with its marker; no node is ever removed, so the end points of
!> Gamma_u / Gamma_a stay vertices.  Holes and several boundary loops need nothing special.
module dualsig_mesh_adapt
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t, set_error, DS_ERR_MESH, DS_ERR_INPUT
  use dualsig_strings, only: itoa
  use dualsig_mesh, only: mesh_t, mesh_build_topology
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: mesh_refine_marked, mesh_prolongate_bisection, mesh_mark_doerfler, mesh_label_longest_edge
  public :: mesh_bisection_origin, mesh_bisection_ancestor

contains

  !> The labelled copy of a triangle list: vertices and edges of every triangle rotated so
  !> that its longest side is local edge 1 (needs mesh%tri_edge).
  subroutine mesh_label_longest_edge(mesh, tri, tedge)
    type(mesh_t), intent(in) :: mesh
    integer, intent(out) :: tri(:,:), tedge(:,:)
    integer :: t, k, kmax
    real(dp) :: d(2), len2, best
    do t = 1, mesh%ntri
      best = -1.0_dp
      kmax = 1
      do k = 1, 3
        d = mesh%xy(:, mesh%tri(mod(k, 3) + 1, t)) - mesh%xy(:, mesh%tri(k, t))
        len2 = d(1)**2 + d(2)**2
        ! a relative margin: equally long sides (up to rounding) keep the first one
        if (len2 > best * (1.0_dp + 1.0e-12_dp)) then
          best = len2
          kmax = k
        end if
      end do
      tri(:, t) = mesh%tri([kmax, mod(kmax, 3) + 1, mod(kmax + 1, 3) + 1], t)
      tedge(:, t) = mesh%tri_edge([kmax, mod(kmax, 3) + 1, mod(kmax + 1, 3) + 1], t)
    end do
  end subroutine mesh_label_longest_edge

  !> Refine the triangles `marked` (size coarse%ntri) of `coarse` (topology built) by
  !> newest-vertex bisection with conforming closure; `fine` gets its topology and tri_gen,
  !> parents(:, k) the end nodes of the edge whose midpoint is node coarse%nnode + k.  No
  !> marked triangle: fine is a copy of coarse (labelled).
  subroutine mesh_refine_marked(coarse, marked, fine, parents, st)
    type(mesh_t), intent(in) :: coarse
    logical, intent(in) :: marked(:)
    type(mesh_t), intent(out) :: fine
    integer, allocatable, intent(out) :: parents(:,:)
    type(status_t), intent(out) :: st
    integer, allocatable :: tri(:,:), tedge(:,:), gen(:), mid(:)
    integer :: nn, nnew, e, ist
    if (coarse%ntri < 1 .or. .not. (allocated(coarse%tri_edge) .and. allocated(coarse%edge_tri) &
        .and. allocated(coarse%bedge_edge))) then
      call set_error(st, DS_ERR_MESH, 'mesh_refine_marked: the mesh has no topology ' // &
        '(expected a mesh with triangles, finished by mesh_build_topology)')
      return
    end if
    if (size(marked) /= coarse%ntri) then
      call set_error(st, DS_ERR_INPUT, 'mesh_refine_marked: ' // itoa(size(marked)) // ' marks for ' // &
        itoa(coarse%ntri) // ' triangles')
      return
    end if
    allocate (tri(3, coarse%ntri), tedge(3, coarse%ntri), gen(coarse%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the labelled triangles', 7 * coarse%ntri, BYTES_INT)) return
    if (allocated(coarse%tri_gen)) then
      tri = coarse%tri
      tedge = coarse%tri_edge
      gen = coarse%tri_gen
    else
      call mesh_label_longest_edge(coarse, tri, tedge)
      gen = 0
    end if
    call close_marks(coarse, marked, tedge, mid, st)
    if (st%code /= 0) return
    ! mid(e) > 0: edge e is split; number its midpoint
    nn = coarse%nnode
    nnew = count(mid > 0)
    fine%nnode = nn + nnew
    allocate (parents(2, nnew), fine%xy(2, fine%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the nodes of the refined mesh', 2 * fine%nnode + 2 * nnew, BYTES_REAL)) return
    fine%xy(:, 1:nn) = coarse%xy
    nnew = 0
    do e = 1, coarse%nedge
      if (mid(e) == 0) cycle
      nnew = nnew + 1
      mid(e) = nn + nnew
      parents(:, nnew) = coarse%edge_nodes(:, e)
      fine%xy(:, nn + nnew) = 0.5_dp * (coarse%xy(:, parents(1, nnew)) + coarse%xy(:, parents(2, nnew)))
    end do
    call bisect_triangles(tri, tedge, gen, mid, fine, st)
    if (st%code == 0) call split_boundary(coarse, mid, fine, st)
    if (st%code /= 0) return
    call mesh_build_topology(fine, st)
    if (st%code /= 0) st%msg = 'mesh_refine_marked: ' // st%msg
  end subroutine mesh_refine_marked

  !> The conforming closure of the marks: mid(e) = 1 for every edge to split (the
  !> refinement edges of the marked triangles and of every triangle with a split edge).
  subroutine close_marks(mesh, marked, tedge, mid, st)
    type(mesh_t), intent(in) :: mesh
    logical, intent(in) :: marked(:)
    integer, intent(in) :: tedge(:,:)
    integer, allocatable, intent(out) :: mid(:)
    type(status_t), intent(inout) :: st
    integer, allocatable :: queue(:)
    integer :: t, e, head, tail, s, r, ist
    allocate (mid(mesh%nedge), queue(mesh%nedge), stat=ist)
    if (alloc_failed(ist, st, 'the edges to bisect', 2 * mesh%nedge, BYTES_INT)) return
    mid = 0
    tail = 0
    do t = 1, mesh%ntri
      if (.not. marked(t)) cycle
      e = tedge(1, t)
      if (mid(e) /= 0) cycle
      mid(e) = 1
      tail = tail + 1
      queue(tail) = e
    end do
    head = 0
    do while (head < tail)
      head = head + 1
      e = queue(head)
      do s = 1, 2
        t = mesh%edge_tri(s, e)
        if (t == 0) cycle
        r = tedge(1, t)
        if (mid(r) /= 0) cycle
        mid(r) = 1
        tail = tail + 1
        queue(tail) = r
      end do
    end do
  end subroutine close_marks

  !> The triangles of the refined mesh: each coarse triangle copied (refinement edge not
  !> split) or bisected, its children bisected again when their refinement edges are split.
  subroutine bisect_triangles(tri, tedge, gen, mid, fine, st)
    integer, intent(in) :: tri(:,:), tedge(:,:), gen(:), mid(:)
    type(mesh_t), intent(inout) :: fine
    type(status_t), intent(inout) :: st
    integer :: t, nt, nfine, p, v(3), ist
    nt = size(tri, 2)
    nfine = 0
    do t = 1, nt
      if (mid(tedge(1, t)) == 0) then
        nfine = nfine + 1
      else
        nfine = nfine + 2 + merge(1, 0, mid(tedge(2, t)) > 0) + merge(1, 0, mid(tedge(3, t)) > 0)
      end if
    end do
    fine%ntri = nfine
    allocate (fine%tri(3, nfine), fine%tri_gen(nfine), stat=ist)
    if (alloc_failed(ist, st, 'the triangles of the refined mesh', 4 * nfine, BYTES_INT)) return
    nfine = 0
    do t = 1, nt
      v = tri(:, t)
      if (mid(tedge(1, t)) == 0) then
        call put(v, gen(t))
        cycle
      end if
      p = mid(tedge(1, t))
      ! child (v3, v1, p): its refinement edge v3 v1 is the parent's local edge 3
      if (mid(tedge(3, t)) > 0) then
        call put([p, v(3), mid(tedge(3, t))], gen(t) + 2)
        call put([v(1), p, mid(tedge(3, t))], gen(t) + 2)
      else
        call put([v(3), v(1), p], gen(t) + 1)
      end if
      ! child (v2, v3, p): its refinement edge v2 v3 is the parent's local edge 2
      if (mid(tedge(2, t)) > 0) then
        call put([p, v(2), mid(tedge(2, t))], gen(t) + 2)
        call put([v(3), p, mid(tedge(2, t))], gen(t) + 2)
      else
        call put([v(2), v(3), p], gen(t) + 1)
      end if
    end do
  contains
    subroutine put(w, g)
      integer, intent(in) :: w(3), g
      nfine = nfine + 1
      fine%tri(:, nfine) = w
      fine%tri_gen(nfine) = g
    end subroutine put
  end subroutine bisect_triangles

  !> The boundary edges of the refined mesh: a split edge becomes its two halves, each
  !> with the marker of the edge.
  subroutine split_boundary(coarse, mid, fine, st)
    type(mesh_t), intent(in) :: coarse
    integer, intent(in) :: mid(:)
    type(mesh_t), intent(inout) :: fine
    type(status_t), intent(inout) :: st
    integer :: j, nb, m, ist
    fine%nbedge = coarse%nbedge + count(mid(coarse%bedge_edge) > 0)
    allocate (fine%bedge_nodes(2, fine%nbedge), fine%bedge_marker(fine%nbedge), stat=ist)
    if (alloc_failed(ist, st, 'the boundary edges of the refined mesh', 3 * fine%nbedge, BYTES_INT)) return
    nb = 0
    do j = 1, coarse%nbedge
      m = mid(coarse%bedge_edge(j))
      if (m == 0) then
        nb = nb + 1
        fine%bedge_nodes(:, nb) = coarse%bedge_nodes(:, j)
        fine%bedge_marker(nb) = coarse%bedge_marker(j)
      else
        fine%bedge_nodes(:, nb + 1) = [coarse%bedge_nodes(1, j), m]
        fine%bedge_nodes(:, nb + 2) = [m, coarse%bedge_nodes(2, j)]
        fine%bedge_marker(nb + 1:nb + 2) = coarse%bedge_marker(j)
        nb = nb + 2
      end if
    end do
  end subroutine split_boundary

  !> The triangles of the refined mesh fine (mesh_refine_marked of coarse) that are coarse
  !> triangles left whole: origin(t) = that coarse triangle, 0 for a child.  A child has a
  !> new node among its vertices; the whole ones keep the coarse order (bisect_triangles),
  !> so one pass over both lists matches them, each match checked on its vertex set (a
  !> triangle that does not match is given 0: nothing is ever matched wrongly).
  pure subroutine mesh_bisection_origin(coarse, fine, origin)
    type(mesh_t), intent(in) :: coarse, fine
    integer, intent(out) :: origin(:)            !! (fine%ntri)
    integer :: t, c, c_next
    origin = 0
    c_next = 1
    do t = 1, fine%ntri
      if (any(fine%tri(:, t) > coarse%nnode)) cycle
      do c = c_next, coarse%ntri
        if (same_vertices(coarse%tri(:, c), fine%tri(:, t))) then
          origin(t) = c
          c_next = c + 1
          exit
        end if
      end do
      if (origin(t) == 0) exit                   ! the order is not the coarse one: no more matches
    end do
  contains
    pure logical function same_vertices(a, b)
      integer, intent(in) :: a(3), b(3)
      same_vertices = all([any(b == a(1)), any(b == a(2)), any(b == a(3))])
    end function same_vertices
  end subroutine mesh_bisection_origin

  !> The coarse triangle every triangle of the refined mesh fine (mesh_refine_marked of
  !> coarse, parents its new nodes' edge ends) lies in: ancestor(t).  The children of a coarse
  !> triangle are consecutive and in the coarse order (bisect_triangles); a fine triangle
  !> belongs to coarse triangle c exactly when each of its vertices is a vertex of c or the
  !> midpoint of two of them (then it lies in c, and a non-degenerate triangle in c lies in
  !> no other).  ok = .false. (ancestor all 0) when the lists do not match so.  The same holds
  !> for mesh_refine_uniform (four children per coarse triangle, parents = coarse%edge_nodes).
  pure subroutine mesh_bisection_ancestor(coarse, fine, parents, ancestor, ok)
    type(mesh_t), intent(in) :: coarse, fine
    integer, intent(in) :: parents(:,:)
    integer, intent(out) :: ancestor(:)          !! (fine%ntri)
    logical, intent(out) :: ok
    integer :: c, t, k, n
    logical :: inside
    ancestor = 0
    ok = .false.
    if (size(ancestor) /= fine%ntri .or. fine%nnode - coarse%nnode /= size(parents, 2)) return
    t = 1
    do c = 1, coarse%ntri
      do while (t <= fine%ntri)
        inside = .true.
        do k = 1, 3
          n = fine%tri(k, t)
          if (n <= coarse%nnode) then
            inside = inside .and. any(coarse%tri(:, c) == n)
          else
            inside = inside .and. any(coarse%tri(:, c) == parents(1, n - coarse%nnode)) .and. &
                     any(coarse%tri(:, c) == parents(2, n - coarse%nnode))
          end if
        end do
        if (.not. inside) exit
        ancestor(t) = c
        t = t + 1
      end do
      if (t == 1 .or. ancestor(max(t - 1, 1)) /= c) then    ! coarse triangle c has no child here
        ancestor = 0
        return
      end if
    end do
    ok = t == fine%ntri + 1
    if (.not. ok) ancestor = 0
  end subroutine mesh_bisection_ancestor

  !> P1 transfer to the mesh of mesh_refine_marked: coarse values copied, a midpoint gets
  !> the mean of its edge's end values (exact: the coarse function is linear on the edge).
  pure subroutine mesh_prolongate_bisection(parents, uc, uf)
    integer, intent(in) :: parents(:,:)
    real(dp), intent(in) :: uc(:)
    real(dp), intent(out) :: uf(:)
    integer :: nn, k
    nn = size(uc)
    uf(1:nn) = uc
    do k = 1, size(parents, 2)
      uf(nn + k) = 0.5_dp * (uc(parents(1, k)) + uc(parents(2, k)))
    end do
  end subroutine mesh_prolongate_bisection

  !> Doerfler marking: the smallest set M of triangles with sum_M eta2 >= theta sum eta2
  !> (eta2: the squared indicators, negative values counted as 0), the largest
  !> indicators first (a heap sort: n log n).  theta <= 0 marks nothing, theta >= 1 every
  !> triangle with a positive indicator.  max_marked (optional): at most this many, the
  !> largest indicators (a prefix of the same order, i.e. Doerfler's set of a smaller
  !> theta).  min_marked (optional, within max_marked): at least this many, the set
  !> extended by the next largest positive indicators (Doerfler's set of a larger theta).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine mesh_mark_doerfler(eta2, theta, marked, nmarked, st, max_marked, min_marked)
    real(dp), intent(in) :: eta2(:)
    real(dp), intent(in) :: theta
    logical, allocatable, intent(out) :: marked(:)
    integer, intent(out), optional :: nmarked
    type(status_t), intent(out) :: st
    integer, intent(in), optional :: max_marked
    integer, intent(in), optional :: min_marked
    integer, allocatable :: idx(:)
    real(dp), allocatable :: w(:)
    real(dp) :: total, target, acc
    integer :: n, k, ist, kmax, kmin
    n = size(eta2)
    kmax = n
    if (present(max_marked)) kmax = min(n, max(max_marked, 0))
    kmin = 0
    if (present(min_marked)) kmin = min(kmax, max(min_marked, 0))
    if (present(nmarked)) nmarked = 0
    allocate (marked(n), w(n), idx(n), stat=ist)
    if (alloc_failed(ist, st, 'the marks of the refinement', 3 * n, BYTES_REAL)) return
    marked = .false.
    if (n == 0 .or. theta <= 0.0_dp) return
    w = max(eta2, 0.0_dp)
    total = sum(w)
    if (.not. total > 0.0_dp) return
    target = min(theta, 1.0_dp) * total
    call sort_descending(w, idx)
    acc = 0.0_dp
    do k = 1, kmax
      if (w(idx(k)) <= 0.0_dp) exit
      marked(idx(k)) = .true.
      acc = acc + w(idx(k))
      if (k >= kmin .and. acc >= target * (1.0_dp - 1.0e-14_dp)) exit
    end do
    if (present(nmarked)) nmarked = count(marked)
  end subroutine mesh_mark_doerfler

  !> idx: a permutation with w(idx(1)) >= w(idx(2)) >= ... (heap sort).
  subroutine sort_descending(w, idx)
    real(dp), intent(in) :: w(:)
    integer, intent(out) :: idx(:)           !! (size(w))
    integer :: n, i, tmp
    n = size(w)
    do i = 1, n
      idx(i) = i
    end do
    ! a min-heap on w: popping the smallest to the end leaves idx in descending order
    do i = n / 2, 1, -1
      call sift(i, n)
    end do
    do i = n, 2, -1
      tmp = idx(1)
      idx(1) = idx(i)
      idx(i) = tmp
      call sift(1, i - 1)
    end do
  contains
    subroutine sift(start, last)
      integer, intent(in) :: start, last
      integer :: root, child, t
      root = start
      do
        child = 2 * root
        if (child > last) exit
        if (child < last) then
          if (w(idx(child + 1)) < w(idx(child))) child = child + 1
        end if
        if (w(idx(root)) <= w(idx(child))) exit
        t = idx(root)
        idx(root) = idx(child)
        idx(child) = t
        root = child
      end do
    end subroutine sift
  end subroutine sort_descending
end module dualsig_mesh_adapt
