!> Geometric checks of a triangulation, run before anything is assembled on it: the
!> readers, DSSIGN and the analysis pipeline (every level) call them.  A folded, doubled or
!> broken mesh would otherwise be solved, and the "guaranteed" bounds of the paper would
!> silently fail on it (they assume the triangles tile the domain once).
!>
!> - `mesh_orient_triangles` (before the topology): the triangles must be all
!>   counter-clockwise, or all clockwise (then all are made counter-clockwise by swapping
!>   their 2nd and 3rd vertex).  A mix is a folded mesh, e.g. a node moved across a side
!>   of a neighbour, and is rejected naming the first inverted triangle (one of the
!>   orientation held by fewer triangles) and how many there are.
!> - `mesh_check_duplicates` (before or after the topology): no two triangles with the
!>   same three vertices, in any order.
!> - `mesh_check_geometry` (after mesh_build_topology): duplicates; every triangle
!>   counter-clockwise; one piece (the triangles connected through shared sides: a piece
!>   that touches the rest only at a vertex counts as separate); exactly one boundary loop
!>   enclosing a positive area (the outer one, counter-clockwise), the others negative
!>   (holes, clockwise); and the triangle areas summing to the area the boundary loops
!>   enclose (shoelace formula) within area_sum_rel_tol.  The last check catches
!>   overlapping triangles whose orientations agree, e.g. after inverted triangles were
!>   reoriented one by one.  Linear in the number of triangles.
!>
!> Zero-area triangles (|area| <= mesh_zero_area: relative to the triangle's own longest
!> side, so the children of a valid triangle are valid) have no orientation here;
!> mesh_build_topology and the readers reject them.  Messages start with 'mesh: ' and name
!> the triangle and its nodes, by the optional tri_id / node_id maps when given (the ids of
!> a file), and what was expected; `bad_tri` (optional) returns the triangle's number in
!> the mesh (0: none), so that a reader can name the line of the file.
module dualsig_mesh_check
  use dualsig_kinds, only: dp, geom_rel_tol, area_sum_rel_tol
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_MESH
  use dualsig_strings, only: itoa
  use dualsig_mesh, only: mesh_t, mesh_triangle_area, mesh_diameter, mesh_zero_area, mesh_coordinate_scale
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL
  implicit none
  private

  public :: mesh_orient_triangles, mesh_check_duplicates, mesh_check_geometry
  public :: mesh_enclosed_area, mesh_count_pieces

  !> What a message calls the triangles and nodes: the mesh's numbers or a file's ids.
  type :: naming_t
    integer, allocatable :: tri_id(:), node_id(:)
  end type naming_t

contains

  !> Orientation of the triangles (vertex indices valid): all counter-clockwise, nothing
  !> to do; all clockwise, all are made counter-clockwise (2nd and 3rd vertex swapped) and
  !> counted in nflipped; a mix, an error naming the first triangle of the minority
  !> orientation (clockwise on a tie) and how many there are.  Zero-area triangles count
  !> for neither orientation.
  subroutine mesh_orient_triangles(mesh, nflipped, st, bad_tri, tri_id, node_id)
    type(mesh_t), intent(inout) :: mesh
    integer, intent(out) :: nflipped
    type(status_t), intent(inout) :: st
    integer, intent(out), optional :: bad_tri
    integer, intent(in), optional :: tri_id(:), node_id(:)
    real(dp), allocatable :: area(:), zero(:)
    integer :: t, nccw, ncw

    nflipped = 0
    if (present(bad_tri)) bad_tri = 0
    call signed_areas(mesh, area, zero, st)
    if (.not. is_ok(st)) return
    ncw = count(area < -zero)
    nccw = count(area > zero)
    if (ncw == 0) return
    if (nccw == 0) then
      do t = 1, mesh%ntri
        if (area(t) < 0.0_dp) mesh%tri(2:3, t) = mesh%tri([3, 2], t)
      end do
      nflipped = ncw
      return
    end if
    call report_mixed(mesh, area < -zero, area > zero, naming_of(tri_id, node_id), st, bad_tri)
  end subroutine mesh_orient_triangles

  !> Error for the first triangle whose three vertices another triangle listed before it
  !> already has (in any order).  Buckets the triangles by their smallest vertex (counting
  !> sort): linear in the number of triangles for meshes of bounded vertex degree.
  subroutine mesh_check_duplicates(mesh, st, bad_tri, tri_id, node_id)
    type(mesh_t), intent(in) :: mesh
    type(status_t), intent(inout) :: st
    integer, intent(out), optional :: bad_tri
    integer, intent(in), optional :: tri_id(:), node_id(:)
    integer, allocatable :: head(:), slot(:), key(:,:)
    integer :: t, s, p, q, lo, ist
    type(naming_t) :: nm

    if (present(bad_tri)) bad_tri = 0
    allocate (key(3, mesh%ntri), head(mesh%nnode + 1), slot(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the duplicate-triangle check', 4 * mesh%ntri + mesh%nnode + 1, BYTES_INT)) return
    head = 0
    do t = 1, mesh%ntri
      key(:, t) = sorted3(mesh%tri(:, t))
      head(key(1, t) + 1) = head(key(1, t) + 1) + 1
    end do
    head(1) = 1
    do lo = 1, mesh%nnode
      head(lo + 1) = head(lo + 1) + head(lo)
    end do
    ! fill the buckets in triangle order (head(lo) advances to the next free slot)
    do t = 1, mesh%ntri
      slot(head(key(1, t))) = t
      head(key(1, t)) = head(key(1, t)) + 1
    end do
    ! bucket lo is now slot(head(lo-1) : head(lo)-1) (head(0) = 1)
    p = 1
    do lo = 1, mesh%nnode
      do q = p + 1, head(lo) - 1
        t = slot(q)
        do s = p, q - 1
          if (all(key(:, slot(s)) == key(:, t))) then
            nm = naming_of(tri_id, node_id)
            call set_error(st, DS_ERR_MESH, 'mesh: ' // tri_text(mesh, nm, t) // ' duplicates ' // &
              tri_text(mesh, nm, slot(s)) // ': the same three vertices (expected every triangle once; ' // &
              'a doubled triangle makes its region count twice)')
            if (present(bad_tri)) bad_tri = t
            return
          end if
        end do
      end do
      p = head(lo)
    end do
  end subroutine mesh_check_duplicates

  !> The checks of the module header on a mesh with its topology (mesh_build_topology):
  !> duplicates, orientation, one piece, loop orientations, area sum.
  subroutine mesh_check_geometry(mesh, st, bad_tri, tri_id, node_id)
    type(mesh_t), intent(in) :: mesh
    type(status_t), intent(inout) :: st
    integer, intent(out), optional :: bad_tri
    integer, intent(in), optional :: tri_id(:), node_id(:)
    type(naming_t) :: nm
    real(dp), allocatable :: area(:), zero(:)
    integer :: bad

    bad = 0
    nm = naming_of(tri_id, node_id)
    if (.not. (allocated(mesh%edge_tri) .and. allocated(mesh%tri_edge) .and. allocated(mesh%loop_start) &
               .and. allocated(mesh%loop_bedge) .and. allocated(mesh%bedge_nodes))) then
      call set_error(st, DS_ERR_MESH, 'mesh: no topology (expected a mesh finished by mesh_build_topology)')
    else
      call mesh_check_duplicates(mesh, st, bad, tri_id, node_id)
    end if
    if (st%code == 0) call signed_areas(mesh, area, zero, st)
    if (st%code == 0) then
      ! (the topology admits only counter-clockwise triangles: the coordinates changed since?)
      if (any(.not. (area > zero))) &
        call report_mixed(mesh, .not. (area > zero), area > zero, nm, st, bad)
    end if
    if (st%code == 0) call check_one_piece(mesh, nm, st, bad)
    if (st%code == 0) call check_loops(mesh, st)
    if (st%code == 0) call check_area_sum(mesh, area, nm, st, bad)
    if (present(bad_tri)) bad_tri = bad
  end subroutine mesh_check_geometry

  !> The signed area the boundary loops enclose: the shoelace formula over the boundary
  !> edges (domain on their left, so holes count negative), about the first node to limit
  !> cancellation.  loop_area(l) (optional) returns it per loop.  Out of memory: 0 and
  !> DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  function mesh_enclosed_area(mesh, loop_area, st) result(total)
    type(mesh_t), intent(in) :: mesh
    real(dp), allocatable, intent(out), optional :: loop_area(:)
    type(status_t), intent(inout) :: st
    real(dp) :: total
    real(dp) :: c(2), a(2), b(2), part
    real(dp), allocatable :: la(:)
    integer :: l, p, j, ist
    total = 0.0_dp
    c = mesh%xy(:, 1)
    allocate (la(mesh%nloop), stat=ist)
    if (alloc_failed(ist, st, 'the areas of the boundary loops', mesh%nloop, BYTES_REAL)) return
    la = 0.0_dp
    do l = 1, mesh%nloop
      part = 0.0_dp
      do p = mesh%loop_start(l), mesh%loop_start(l + 1) - 1
        j = mesh%loop_bedge(p)
        a = mesh%xy(:, mesh%bedge_nodes(1, j)) - c
        b = mesh%xy(:, mesh%bedge_nodes(2, j)) - c
        part = part + (a(1) * b(2) - b(1) * a(2))
      end do
      la(l) = 0.5_dp * part
    end do
    total = sum(la)
    if (present(loop_area)) call move_alloc(la, loop_area)
  end function mesh_enclosed_area

  !> Number of pieces of a mesh with topology: the classes of triangles connected through
  !> shared sides (sharing a vertex only does not connect).  piece(t) (optional) returns
  !> the piece of each triangle, numbered by their smallest triangle.  Out of memory: 0
  !> and DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  function mesh_count_pieces(mesh, piece, st) result(npiece)
    type(mesh_t), intent(in) :: mesh
    integer, allocatable, intent(out), optional :: piece(:)
    type(status_t), intent(inout) :: st
    integer :: npiece
    integer, allocatable :: pc(:), stack(:)
    integer :: t0, t, k, e, nb, top, ist
    npiece = 0
    allocate (pc(mesh%ntri), stack(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the connected pieces of the mesh', 2 * mesh%ntri, BYTES_INT)) return
    pc = 0
    do t0 = 1, mesh%ntri
      if (pc(t0) /= 0) cycle
      npiece = npiece + 1
      pc(t0) = npiece
      top = 1
      stack(1) = t0
      do while (top > 0)
        t = stack(top)
        top = top - 1
        do k = 1, 3
          e = mesh%tri_edge(k, t)
          nb = mesh%edge_tri(1, e)
          if (nb == t) nb = mesh%edge_tri(2, e)
          if (nb == 0) cycle
          if (pc(nb) /= 0) cycle
          pc(nb) = npiece
          top = top + 1
          stack(top) = nb
        end do
      end do
    end do
    if (present(piece)) call move_alloc(pc, piece)
  end function mesh_count_pieces

  ! ------------------------------------------------------------------ the checks

  !> Error unless all triangles lie in one piece: the count, and one triangle of the second.
  subroutine check_one_piece(mesh, nm, st, bad)
    type(mesh_t), intent(in) :: mesh
    type(naming_t), intent(in) :: nm
    type(status_t), intent(inout) :: st
    integer, intent(inout) :: bad
    integer, allocatable :: piece(:)
    integer :: npiece, t2
    npiece = mesh_count_pieces(mesh, piece, st)
    if (npiece <= 1) return
    t2 = findloc(piece, 2, dim=1)
    call set_error(st, DS_ERR_MESH, 'mesh: the triangles form ' // itoa(npiece) // ' separate pieces ' // &
      '(triangles connected through shared sides; a piece touching another only at a vertex counts as ' // &
      'separate): ' // tri_text(mesh, nm, t2) // ' lies in the second piece, ' // tri_text(mesh, nm, 1) // &
      ' in the first (expected one connected domain, an island removed or joined to the rest by a side)')
    bad = t2
  end subroutine check_one_piece

  !> Error unless exactly one boundary loop encloses a positive area (the outer loop,
  !> counter-clockwise) and every other a negative one (a hole, clockwise).
  subroutine check_loops(mesh, st)
    type(mesh_t), intent(in) :: mesh
    type(status_t), intent(inout) :: st
    real(dp), allocatable :: la(:)
    real(dp) :: total
    integer :: nouter, l
    total = mesh_enclosed_area(mesh, la, st)
    if (.not. is_ok(st)) return
    nouter = count(la > 0.0_dp)
    if (nouter == 1) return
    if (mesh%nloop == 0) then
      call set_error(st, DS_ERR_MESH, 'mesh: the triangles have no boundary (every side is shared by two ' // &
        'triangles: they overlap, a folded mesh; expected a plane domain with a boundary loop)')
    else if (nouter == 0) then
      call set_error(st, DS_ERR_MESH, 'mesh: no boundary loop runs counter-clockwise around the domain ' // &
        '(all ' // itoa(mesh%nloop) // ' enclose a negative area; expected one outer loop with the domain ' // &
        'on its left, counter-clockwise: the triangles overlap, a folded mesh?)')
    else
      l = findloc(la > 0.0_dp, .true., dim=1, back=.true.)
      call set_error(st, DS_ERR_MESH, 'mesh: ' // itoa(nouter) // ' boundary loops run counter-clockwise: ' // &
        'loop ' // itoa(l) // ' (' // itoa(mesh%loop_start(l + 1) - mesh%loop_start(l)) // ' edges, through ' // &
        'node ' // itoa(mesh%bedge_nodes(1, mesh%loop_bedge(mesh%loop_start(l)))) // ') is a second outer ' // &
        'loop (expected one outer loop, counter-clockwise, and holes, clockwise: a folded mesh?)')
    end if
  end subroutine check_loops

  !> Error when the triangle areas do not sum to the area the boundary loops enclose
  !> within area_sum_rel_tol (relative to the sum); names an interior side whose two
  !> triangles lie on the same side of it, when there is one.
  subroutine check_area_sum(mesh, area, nm, st, bad)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: area(:)
    type(naming_t), intent(in) :: nm
    type(status_t), intent(inout) :: st
    integer, intent(inout) :: bad
    real(dp) :: sum_tri, enclosed, rel
    integer :: e
    character(len=:), allocatable :: where
    sum_tri = sum(area)
    enclosed = mesh_enclosed_area(mesh, st=st)
    if (.not. is_ok(st)) return
    rel = abs(sum_tri - enclosed) / sum_tri
    if (rel <= area_sum_rel_tol) return
    where = ''
    e = same_side_edge(mesh)
    if (e > 0) then
      where = '; the side (' // node_text(nm, mesh%edge_nodes(1, e)) // ',' // node_text(nm, mesh%edge_nodes(2, e)) // &
        ') has ' // tri_text(mesh, nm, mesh%edge_tri(1, e)) // ' and ' // tri_text(mesh, nm, mesh%edge_tri(2, e)) // &
        ' on the same side'
      bad = mesh%edge_tri(2, e)
    end if
    call set_error(st, DS_ERR_MESH, 'mesh: the triangle areas sum to ' // short(sum_tri) // ' but the boundary ' // &
      'loops enclose ' // short(enclosed) // ' (relative difference ' // short(rel) // ' > ' // &
      short(area_sum_rel_tol) // '): the triangles overlap, a folded mesh' // where // &
      ' (expected triangles that cover the domain once)')
  end subroutine check_area_sum

  !> The first interior edge that its two triangles run through in the same direction (both
  !> lie on the same side of it), or 0.
  integer function same_side_edge(mesh) result(edge)
    type(mesh_t), intent(in) :: mesh
    integer :: e, k1, k2, t1, t2
    edge = 0
    do e = 1, mesh%nedge
      t1 = mesh%edge_tri(1, e)
      t2 = mesh%edge_tri(2, e)
      if (t2 == 0) cycle
      k1 = findloc(mesh%tri_edge(:, t1), e, dim=1)
      k2 = findloc(mesh%tri_edge(:, t2), e, dim=1)
      if (mesh%tri(k1, t1) == mesh%tri(k2, t2)) then
        edge = e
        return
      end if
    end do
  end function same_side_edge

  !> Error for a mix of orientations: cw(t) / ccw(t) mark the clockwise / counter-clockwise
  !> triangles; names the first triangle of the minority (clockwise on a tie) and how many
  !> there are.
  subroutine report_mixed(mesh, cw, ccw, nm, st, bad)
    type(mesh_t), intent(in) :: mesh
    logical, intent(in) :: cw(:), ccw(:)
    type(naming_t), intent(in) :: nm
    type(status_t), intent(inout) :: st
    integer, intent(out), optional :: bad
    integer :: t, ninv
    character(len=:), allocatable :: odd, usual
    if (count(cw) <= count(ccw)) then
      t = findloc(cw, .true., dim=1)
      ninv = count(cw)
      odd = 'clockwise'
      usual = 'counter-clockwise'
    else
      t = findloc(ccw, .true., dim=1)
      ninv = count(ccw)
      odd = 'counter-clockwise'
      usual = 'clockwise'
    end if
    call set_error(st, DS_ERR_MESH, 'mesh: ' // tri_text(mesh, nm, t) // ' is inverted: ' // odd // ' among ' // &
      usual // ' triangles (' // itoa(ninv) // ' of the ' // itoa(mesh%ntri) // ' triangles are ' // odd // &
      '): a folded mesh, e.g. a node moved across a side of a neighbour (expected all triangles ' // &
      'counter-clockwise, or all clockwise)')
    if (present(bad)) bad = t
  end subroutine report_mixed

  ! ------------------------------------------------------------------ helpers

  !> Signed area of every triangle.
  subroutine signed_areas(mesh, area, zero, st)
    type(mesh_t), intent(in) :: mesh
    real(dp), allocatable, intent(out) :: area(:), zero(:)
    type(status_t), intent(inout) :: st
    integer :: t, ist
    real(dp) :: scale
    allocate (area(mesh%ntri), zero(mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the triangle areas', 2 * mesh%ntri, BYTES_REAL)) return
    scale = mesh_coordinate_scale(mesh)
    do t = 1, mesh%ntri
      area(t) = mesh_triangle_area(mesh, t)
      zero(t) = mesh_zero_area(mesh, t, scale)
    end do
  end subroutine signed_areas

  !> The naming of the optional id maps.
  function naming_of(tri_id, node_id) result(nm)
    integer, intent(in), optional :: tri_id(:), node_id(:)
    type(naming_t) :: nm
    if (present(tri_id)) nm%tri_id = tri_id
    if (present(node_id)) nm%node_id = node_id
  end function naming_of

  !> 'triangle <id> (nodes <a> <b> <c>)' for triangle t.
  function tri_text(mesh, nm, t) result(s)
    type(mesh_t), intent(in) :: mesh
    type(naming_t), intent(in) :: nm
    integer, intent(in) :: t
    character(len=:), allocatable :: s
    integer :: id
    id = t
    if (allocated(nm%tri_id)) then
      if (t <= size(nm%tri_id)) id = nm%tri_id(t)
    end if
    s = 'triangle ' // itoa(id) // ' (nodes ' // node_text(nm, mesh%tri(1, t)) // ' ' // &
      node_text(nm, mesh%tri(2, t)) // ' ' // node_text(nm, mesh%tri(3, t)) // ')'
  end function tri_text

  !> The id of node j.
  function node_text(nm, j) result(s)
    type(naming_t), intent(in) :: nm
    integer, intent(in) :: j
    character(len=:), allocatable :: s
    s = itoa(j)
    if (allocated(nm%node_id)) then
      if (j <= size(nm%node_id)) s = itoa(nm%node_id(j))
    end if
  end function node_text

  !> Three integers ascending.
  pure function sorted3(v) result(w)
    integer, intent(in) :: v(3)
    integer :: w(3)
    w = v
    if (w(1) > w(2)) w([1, 2]) = w([2, 1])
    if (w(2) > w(3)) w([2, 3]) = w([3, 2])
    if (w(1) > w(2)) w([1, 2]) = w([2, 1])
  end function sorted3

  !> x with 5 significant digits.
  function short(x) result(s)
    real(dp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write (buf, '(es12.4e2)') x
    s = trim(adjustl(buf))
  end function short
end module dualsig_mesh_check
