!> Triangle (J. R. Shewchuk) mesh files: reader `mesh_read_triangle` for `base.node`,
!> `base.ele` and the boundary markers of `base.poly` or, without a .poly file, `base.edge`.
!>
!> File layouts (fields separated by blanks; '#' starts a comment that runs to the end of
!> the line; blank lines are ignored):
!>   .node   <npoints> <dim = 2> <nattr> <nbmark 0|1>
!>           <id> <x> <y> [attr ...] [bmark]                 (npoints lines)
!>   .ele    <ntri> <nodes per triangle = 3> <nattr>
!>           <id> <n1> <n2> <n3> [attr ...]                  (ntri lines)
!>   .poly   <npoints> <dim = 2> <nattr> <nbmark>            (npoints = 0: the nodes are in .node)
!>           [npoints node lines as in .node]
!>           <nseg> <nbmark 0|1>
!>           <id> <a> <b> [marker]                           (nseg lines; holes etc. may follow)
!>   .edge   <nedge> <nbmark 0|1>
!>           <id> <a> <b> [marker]                           (nedge lines)
!> Numbering starts at 0 or at 1, as the first node id says; ids are consecutive.  Node
!> attributes and node markers are checked and ignored.  The first triangle attribute, when
!> there is one, is the triangle's region (`mesh%tri_region`; triangle -A writes the regional
!> attribute of the .poly file there) when every triangle's is an integer (otherwise the
!> mesh has no regions).  Further attributes are ignored.
!>
!> Boundary markers: a boundary side takes the marker (> 0) of the segment (or edge) on it;
!> marker 0 means none, and a boundary side without a marker is an error.  Segments on
!> interior sides are ignored with a note (edges of a .edge file on interior sides silently:
!> the file lists every edge); a segment or edge that is no side of a triangle is an error.
!> Nodes no triangle uses are dropped with a note.  Triangles all clockwise are reoriented
!> and counted; a mix of orientations (a folded mesh), zero-area and duplicate triangles,
!> duplicate nodes, several pieces and overlapping triangles are rejected as by the dualsig
!> text reader.  Every error names the
!> file, the line and what was expected.
module dualsig_mesh_triangle
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t, set_error, DS_ERR_MESH
  use dualsig_mesh, only: mesh_t
  use dualsig_mesh_io, only: mesh_text_reader_t, mesh_reader_open, mesh_reader_close, mesh_reader_next, &
                             mesh_reader_count_ok, mesh_reader_field, &
                             mesh_reader_expect, mesh_reader_int, mesh_reader_real, mesh_reader_fail, &
                             mesh_quote, mesh_check_file_geometry, mesh_finish_topology, mesh_drop_unused_nodes, &
                             mesh_mark_boundary, mesh_note_len
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: mesh_read_triangle, triangle_base_name

  !> Extensions of the Triangle files.
  character(len=5), parameter :: extensions(4) = ['.node', '.ele ', '.poly', '.edge']

  !> Nodes as read, with the numbering base of the file set.
  type :: node_list_t
    integer :: n = 0
    integer :: base = -1                      !! number of the first node (0 or 1)
    real(dp), allocatable :: xy(:,:)
    integer, allocatable :: line(:)
    character(len=:), allocatable :: path     !! the file the nodes came from
  end type node_list_t

contains

  !> Whether `path` names a Triangle file set, and its base name: `path` ends in .node, .ele,
  !> .poly or .edge (base = path without it), or no file `path` exists but `path`.node and
  !> `path`.ele do (base = path).
  subroutine triangle_base_name(path, base, is_triangle)
    character(len=*), intent(in) :: path
    character(len=:), allocatable, intent(out) :: base
    logical, intent(out) :: is_triangle
    integer :: k, n
    logical :: there, node_there, ele_there
    base = trim(path)
    n = len(base)
    do k = 1, size(extensions)
      if (n > len_trim(extensions(k))) then
        if (base(n - len_trim(extensions(k)) + 1:) == trim(extensions(k))) then
          base = base(1:n - len_trim(extensions(k)))
          is_triangle = .true.
          return
        end if
      end if
    end do
    inquire (file=base, exist=there)
    inquire (file=base // '.node', exist=node_there)
    inquire (file=base // '.ele', exist=ele_there)
    is_triangle = .not. there .and. node_there .and. ele_there
  end subroutine triangle_base_name

  !> Read the Triangle mesh named by `path` (any of its files, or the base name) into
  !> `mesh` and build its topology.  nflipped (optional): clockwise triangles reoriented;
  !> notes (optional): one line per ignored item (unused nodes, interior segments).
  subroutine mesh_read_triangle(path, mesh, st, nflipped, notes)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(out) :: mesh
    type(status_t), intent(out) :: st
    integer, intent(out), optional :: nflipped
    character(len=mesh_note_len), allocatable, intent(out), optional :: notes(:)
    character(len=mesh_note_len), allocatable :: nt(:)
    character(len=:), allocatable :: base
    type(mesh_text_reader_t) :: rpoly, rd
    type(node_list_t) :: nodes
    integer, allocatable :: tri_line(:), tri_id(:), cand(:,:), cand_marker(:), cand_line(:), new_index(:), node_id(:)
    integer :: npoly, nbmark, k, nflip, ndropped, ninterior, nstray
    logical :: is_triangle, has_poly, has_edge, has_ele, has_node
    character(len=:), allocatable :: what

    if (present(nflipped)) nflipped = 0
    allocate (nt(0))                                ! small: empty
    call triangle_base_name(path, base, is_triangle)
    inquire (file=base // '.poly', exist=has_poly)
    inquire (file=base // '.edge', exist=has_edge)
    inquire (file=base // '.ele', exist=has_ele)
    inquire (file=base // '.node', exist=has_node)
    if (.not. has_ele .or. .not. (has_node .or. has_poly)) then
      ! the triangles (.ele) and the nodes (.node, or a .poly listing them) first
      call set_error(st, DS_ERR_MESH, "mesh file '" // trim(path) // "' read as a Triangle mesh, but '" // &
        base // trim(merge('.ele ', '.node', .not. has_ele)) // "' does not exist (expected the files " // &
        "<base>.node and <base>.ele of Triangle; a mesh in another format needs &mesh format = 'auto' or " // &
        'its own format)')
      if (present(notes)) notes = nt
      return
    end if
    if (.not. (has_poly .or. has_edge)) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // base // ".node': no boundary markers: neither '" // &
        base // ".poly' nor '" // base // ".edge' exists (expected one of them, e.g. written by triangle -pe)")
      if (present(notes)) notes = nt
      return
    end if

    ! --- nodes: from the .poly file when it lists them, otherwise from the .node file ---
    npoly = 0
    if (has_poly) then
      call mesh_reader_open(rpoly, base // '.poly', .true., st)
      if (st%code == 0) call read_node_header(rpoly, npoly, st, allow_empty=.true.)
      if (st%code == 0 .and. npoly > 0) call read_nodes(rpoly, npoly, nodes, st)
    end if
    if (st%code == 0 .and. npoly == 0) then
      call mesh_reader_open(rd, base // '.node', .true., st)
      if (st%code == 0) call read_node_header(rd, nodes%n, st, allow_empty=.false.)
      if (st%code == 0) call read_nodes(rd, nodes%n, nodes, st)
      if (st%code == 0) call expect_end(rd, 'the ' // itoa(nodes%n) // ' announced nodes', st)
      call mesh_reader_close(rd)
    end if

    ! --- triangles ---
    if (st%code == 0) then
      call mesh_reader_open(rd, base // '.ele', .true., st)
      if (st%code == 0) call read_triangles(rd, nodes, mesh, tri_line, tri_id, st, what)
      if (st%code == 0 .and. len(what) > 0) nt = [character(len=mesh_note_len) :: nt, what]
      if (st%code == 0) call expect_end(rd, 'the ' // itoa(mesh%ntri) // ' announced triangles', st)
      call mesh_reader_close(rd)
    end if

    ! --- boundary markers: .poly segments, or the .edge file ---
    if (st%code == 0) then
      if (has_poly) then
        call read_edges(rpoly, nodes, 'segment', cand, cand_marker, cand_line, nbmark, st)
        what = 'segment of ' // base // '.poly'
      else
        call mesh_reader_open(rd, base // '.edge', .true., st)
        if (st%code == 0) call read_edges(rd, nodes, 'edge', cand, cand_marker, cand_line, nbmark, st)
        if (st%code == 0) call expect_end(rd, 'the announced edges', st)
        call mesh_reader_close(rd)
        what = 'edge of ' // base // '.edge'
      end if
      if (st%code == 0 .and. nbmark == 0) what = what // ' (the file has no markers: <nbmark> = 0)'
    end if
    call mesh_reader_close(rpoly)
    if (st%code /= 0) then
      if (present(notes)) notes = nt
      return
    end if

    ! --- mesh ---
    mesh%nnode = nodes%n
    call move_alloc(nodes%xy, mesh%xy)
    call mesh_drop_unused_nodes(mesh, new_index, ndropped, st)
    if (st%code /= 0) return
    if (ndropped > 0) then
      nt = [character(len=mesh_note_len) :: nt, itoa(ndropped) // ' node(s) used by no triangle dropped']
      nodes%line = pack(nodes%line, new_index > 0)
    end if
    do k = 1, size(cand, 2)
      cand(:, k) = new_index(cand(:, k))
    end do
    node_id = pack([(k + nodes%base - 1, k=1, size(new_index))], new_index > 0)
    call mesh_check_file_geometry(nodes%path, mesh, nodes%line, tri_line, nflip, st, node_id, tri_id, &
                                  base // '.ele')
    if (present(nflipped)) nflipped = nflip
    if (st%code == 0) call mesh_mark_boundary(base // merge('.poly', '.edge', has_poly), mesh, cand, cand_marker, &
                                              cand_line, what, .false., ninterior, nstray, st)
    if (st%code == 0 .and. has_poly .and. ninterior > 0) nt = [character(len=mesh_note_len) :: nt, &
      itoa(ninterior) // ' segment(s) on interior sides ignored']
    if (st%code == 0) call mesh_finish_topology(base // '.ele', mesh, st, tri_line=tri_line, node_id=node_id, &
                                                tri_id=tri_id)
    if (present(notes)) notes = nt
  end subroutine mesh_read_triangle

  !> The header '<npoints> <dim> <nattr> <nbmark>' of a .node or .poly file; returns npoints
  !> (> 0 unless allow_empty, >= 0 then) and checks dim = 2.
  subroutine read_node_header(rd, n, st, allow_empty)
    type(mesh_text_reader_t), intent(inout) :: rd
    integer, intent(out) :: n
    type(status_t), intent(inout) :: st
    logical, intent(in) :: allow_empty
    integer :: dim
    character(len=*), parameter :: layout = "'<npoints> <dim> <nattr> <nbmark>'"
    n = 0
    if (.not. mesh_reader_expect(rd, 'the header line ' // layout, st)) return
    if (rd%nf /= 4) then
      call mesh_reader_fail(rd, 'expected the header line ' // layout // ', found ' // mesh_quote(rd%line), st)
      return
    end if
    if (.not. mesh_reader_int(rd, 1, 'the number of points', n, st)) return
    if (.not. mesh_reader_int(rd, 2, 'the dimension', dim, st)) return
    if (n < 0 .or. (n == 0 .and. .not. allow_empty)) then
      call mesh_reader_fail(rd, 'number of points ' // itoa(n) // ' (expected an integer ' // &
        trim(merge('>= 0', '> 0 ', allow_empty)) // ')', st)
      return
    end if
    if (dim /= 2) then
      call mesh_reader_fail(rd, 'dimension ' // itoa(dim) // ' (expected 2, a plane mesh)', st)
      return
    end if
    if (.not. mesh_reader_count_ok(rd, n, 'the number of points', st)) return
  end subroutine read_node_header

  !> The n node lines after the header of the current .node or .poly file (the header is
  !> re-read from the reader's current record for nattr and nbmark).
  subroutine read_nodes(rd, n, nodes, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    integer, intent(in) :: n
    type(node_list_t), intent(inout) :: nodes
    type(status_t), intent(inout) :: st
    integer :: nattr, nbmark, k, j, id, mark, istat
    real(dp) :: attr
    character(len=:), allocatable :: layout

    if (.not. mesh_reader_int(rd, 3, 'the number of attributes', nattr, st)) return
    if (.not. mesh_reader_int(rd, 4, 'the number of boundary markers', nbmark, st)) return
    if (nattr < 0 .or. nbmark < 0 .or. nbmark > 1) then
      call mesh_reader_fail(rd, 'attribute count ' // itoa(nattr) // ', marker count ' // itoa(nbmark) // &
        ' (expected <nattr> >= 0 and <nbmark> 0 or 1)', st)
      return
    end if
    layout = '<id> <x> <y>'
    if (nattr > 0) layout = layout // ' <attr> x ' // itoa(nattr)
    if (nbmark > 0) layout = layout // ' <bmark>'
    allocate (nodes%xy(2, n), nodes%line(n), stat=istat)
    if (istat /= 0) then
      call mesh_reader_fail(rd, 'cannot allocate ' // itoa(n) // ' nodes (expected a smaller count)', st)
      return
    end if
    nodes%n = n
    nodes%path = rd%path
    do k = 1, n
      if (.not. entry_line(rd, k, n, layout, 3 + nattr + nbmark, st)) return
      if (.not. mesh_reader_int(rd, 1, 'the node id', id, st)) return
      if (.not. consecutive_id(rd, k, id, nodes%base, 'node', st)) return
      nodes%line(k) = rd%lineno
      do j = 1, 2
        if (.not. mesh_reader_real(rd, 1 + j, 'a node coordinate', nodes%xy(j, k), st)) return
      end do
      do j = 1, nattr
        if (.not. mesh_reader_real(rd, 3 + j, 'a node attribute', attr, st)) return
      end do
      if (nbmark > 0) then
        if (.not. mesh_reader_int(rd, 4 + nattr, 'the node boundary marker', mark, st)) return
      end if
    end do
  end subroutine read_nodes

  !> The .ele file: header '<ntri> <nodes per triangle> <nattr>' and the triangle lines.
  subroutine read_triangles(rd, nodes, mesh, tri_line, tri_id, st, note)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(node_list_t), intent(in) :: nodes
    type(mesh_t), intent(inout) :: mesh
    integer, allocatable, intent(out) :: tri_line(:), tri_id(:)
    type(status_t), intent(inout) :: st
    !> '' or why the triangles have no regions (a first attribute that is not an integer)
    character(len=:), allocatable, intent(out) :: note
    integer :: nt, npt, nattr, k, j, id, base, istat
    real(dp) :: attr
    character(len=:), allocatable :: layout
    character(len=*), parameter :: header = "'<ntriangles> <nodes per triangle> <nattr>'"

    note = ''
    if (.not. mesh_reader_expect(rd, 'the header line ' // header, st)) return
    if (rd%nf /= 3) then
      call mesh_reader_fail(rd, 'expected the header line ' // header // ', found ' // mesh_quote(rd%line), st)
      return
    end if
    if (.not. mesh_reader_int(rd, 1, 'the number of triangles', nt, st)) return
    if (.not. mesh_reader_int(rd, 2, 'the nodes per triangle', npt, st)) return
    if (.not. mesh_reader_int(rd, 3, 'the number of attributes', nattr, st)) return
    if (nt < 1 .or. npt /= 3 .or. nattr < 0) then
      call mesh_reader_fail(rd, itoa(nt) // ' triangles of ' // itoa(npt) // ' nodes, ' // itoa(nattr) // &
        ' attributes (expected > 0 triangles of 3 nodes, no second-order triangles (triangle -o2), ' // &
        'and >= 0 attributes)', st)
      return
    end if
    if (.not. mesh_reader_count_ok(rd, nt, 'the number of triangles', st)) return
    layout = '<id> <n1> <n2> <n3>'
    if (nattr > 0) layout = layout // ' <attr> x ' // itoa(nattr)
    allocate (mesh%tri(3, nt), tri_line(nt), tri_id(nt), stat=istat)
    if (istat /= 0) then
      call mesh_reader_fail(rd, 'cannot allocate ' // itoa(nt) // ' triangles (expected a smaller count)', st)
      return
    end if
    mesh%ntri = nt
    if (nattr > 0) then
      allocate (mesh%tri_region(nt), stat=istat)
      if (istat /= 0) then
        call mesh_reader_fail(rd, 'cannot allocate the regions of ' // itoa(nt) // ' triangles (expected a smaller count)', st)
        return
      end if
    end if
    base = -1
    do k = 1, nt
      if (.not. entry_line(rd, k, nt, layout, 4 + nattr, st)) return
      if (.not. mesh_reader_int(rd, 1, 'the triangle id', id, st)) return
      if (.not. consecutive_id(rd, k, id, base, 'triangle', st)) return
      tri_line(k) = rd%lineno
      tri_id(k) = id
      do j = 1, 3
        if (.not. node_ref(rd, 1 + j, nodes, mesh%tri(j, k), st)) return
      end do
      do j = 1, nattr
        if (.not. mesh_reader_real(rd, 4 + j, 'a triangle attribute', attr, st)) return
        if (j > 1) cycle
        ! the first attribute is the region attribute (triangle -A): the triangle's region
        if (.not. allocated(mesh%tri_region)) cycle
        if (abs(attr) < real(huge(1), dp) .and. attr == anint(attr)) then
          mesh%tri_region(k) = nint(attr)
        else
          deallocate (mesh%tri_region)              ! not integers: no regions
          note = 'no regions: the first attribute of triangle ' // itoa(id) // ' (line ' // itoa(rd%lineno) // &
                 ') is ' // mesh_reader_field(rd, 4 + j) // ', not an integer (a region attribute, triangle -A, is one)'
        end if
      end do
    end do
  end subroutine read_triangles

  !> Segments of a .poly file (after its nodes) or the edges of a .edge file: header
  !> '<n> <nbmark>' and lines '<id> <a> <b> [marker]'; node references become indices 1..N.
  subroutine read_edges(rd, nodes, kind, cand, cand_marker, cand_line, nbmark, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(node_list_t), intent(in) :: nodes
    character(len=*), intent(in) :: kind
    integer, allocatable, intent(out) :: cand(:,:), cand_marker(:), cand_line(:)
    integer, intent(out) :: nbmark
    type(status_t), intent(inout) :: st
    integer :: n, k, j, id, base, istat
    character(len=:), allocatable :: header, layout

    nbmark = 0
    allocate (cand(2, 0), cand_marker(0), cand_line(0))   ! small: empty
    header = "'<n" // kind // "s> <nbmark>'"
    if (.not. mesh_reader_expect(rd, 'the ' // kind // ' header ' // header, st)) return
    if (rd%nf /= 2) then
      call mesh_reader_fail(rd, 'expected the ' // kind // ' header ' // header // ', found ' // &
        mesh_quote(rd%line), st)
      return
    end if
    if (.not. mesh_reader_int(rd, 1, 'the number of ' // kind // 's', n, st)) return
    if (.not. mesh_reader_int(rd, 2, 'the number of boundary markers', nbmark, st)) return
    if (n < 0 .or. nbmark < 0 .or. nbmark > 1) then
      call mesh_reader_fail(rd, itoa(n) // ' ' // kind // 's, marker count ' // itoa(nbmark) // &
        ' (expected a count >= 0 and <nbmark> 0 or 1)', st)
      return
    end if
    if (.not. mesh_reader_count_ok(rd, n, 'the number of ' // kind // 's', st)) return
    layout = '<id> <a> <b>'
    if (nbmark > 0) layout = layout // ' <marker>'
    deallocate (cand, cand_marker, cand_line)
    allocate (cand(2, n), cand_marker(n), cand_line(n), stat=istat)
    if (istat /= 0) then
      call mesh_reader_fail(rd, 'cannot allocate ' // itoa(n) // ' ' // kind // 's (expected a smaller count)', st)
      return
    end if
    cand_marker = 0
    base = -1
    do k = 1, n
      if (.not. entry_line(rd, k, n, layout, 3 + nbmark, st)) return
      if (.not. mesh_reader_int(rd, 1, 'the ' // kind // ' id', id, st)) return
      if (.not. consecutive_id(rd, k, id, base, kind, st)) return
      cand_line(k) = rd%lineno
      do j = 1, 2
        if (.not. node_ref(rd, 1 + j, nodes, cand(j, k), st)) return
      end do
      if (nbmark > 0) then
        if (.not. mesh_reader_int(rd, 4, 'the boundary marker', cand_marker(k), st)) return
        if (cand_marker(k) < 0) then
          call mesh_reader_fail(rd, 'negative boundary marker ' // itoa(cand_marker(k)) // &
            ' (expected an integer >= 0; 0 = no marker)', st)
          return
        end if
      end if
    end do
  end subroutine read_edges

  ! ------------------------------------------------------------------ line helpers

  !> Data line k of n: it must exist and have nfield fields.
  logical function entry_line(rd, k, n, layout, nfield, st) result(ok)
    type(mesh_text_reader_t), intent(inout) :: rd
    integer, intent(in) :: k, n, nfield
    character(len=*), intent(in) :: layout
    type(status_t), intent(inout) :: st
    ok = mesh_reader_expect(rd, 'entry ' // itoa(k) // ' of ' // itoa(n) // " '" // layout // "'", st)
    if (.not. ok) return
    ok = rd%nf == nfield
    if (.not. ok) call mesh_reader_fail(rd, 'expected ' // itoa(nfield) // " fields '" // layout // &
      "' (entry " // itoa(k) // ' of ' // itoa(n) // '), found ' // itoa(rd%nf) // ': ' // mesh_quote(rd%line), st)
  end function entry_line

  !> Ids run consecutively from 0 or 1: the first id sets `base`.
  logical function consecutive_id(rd, k, id, base, kind, st) result(ok)
    type(mesh_text_reader_t), intent(in) :: rd
    integer, intent(in) :: k, id
    integer, intent(inout) :: base
    character(len=*), intent(in) :: kind
    type(status_t), intent(inout) :: st
    if (k == 1) then
      ok = id == 0 .or. id == 1
      if (ok) then
        base = id
      else
        call mesh_reader_fail(rd, 'the first ' // kind // ' id is ' // itoa(id) // ' (expected 0 or 1)', st)
      end if
      return
    end if
    ok = id == base + k - 1
    if (.not. ok) call mesh_reader_fail(rd, kind // ' id ' // itoa(id) // ' out of order (expected ' // &
      itoa(base + k - 1) // ')', st)
  end function consecutive_id

  !> Field k as a node reference in the numbering of the nodes (from base), returned as 1..N.
  logical function node_ref(rd, k, nodes, v, st) result(ok)
    type(mesh_text_reader_t), intent(in) :: rd
    integer, intent(in) :: k
    type(node_list_t), intent(in) :: nodes
    integer, intent(out) :: v
    type(status_t), intent(inout) :: st
    ok = mesh_reader_int(rd, k, 'a node index', v, st)
    if (.not. ok) return
    ok = v >= nodes%base .and. v <= nodes%base + nodes%n - 1
    if (.not. ok) then
      call mesh_reader_fail(rd, 'field ' // itoa(k) // ': node index ' // itoa(v) // ' out of range (expected ' // &
        itoa(nodes%base) // '..' // itoa(nodes%base + nodes%n - 1) // ', the nodes of ' // nodes%path // ')', st)
      return
    end if
    v = v - nodes%base + 1
  end function node_ref

  !> Nothing but comments may follow the announced entries.
  subroutine expect_end(rd, what, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: what
    type(status_t), intent(inout) :: st
    logical :: found
    call mesh_reader_next(rd, found, st)
    if (st%code /= 0) return
    if (found) call mesh_reader_fail(rd, 'unexpected content after ' // what // ': ' // mesh_quote(rd%line) // &
      ' (expected the end of the file; wrong count in the header?)', st)
  end subroutine expect_end
end module dualsig_mesh_triangle
