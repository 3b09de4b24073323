!> Gmsh mesh files: reader `mesh_read_gmsh` for MSH 2.2 and MSH 4.1 in ASCII, and the
!> translation of physical-group names into boundary markers (`gmsh_markers_from_names`).
!>
!> What is read:
!> - `$MeshFormat`: version 2.x (read as 2.2) or 4.1, file-type 0 (ASCII).  Binary files and
!>   other versions are rejected.
!> - `$PhysicalNames`: `dim tag "name"` lines, returned as a table (gmsh_physical_t).
!> - `$Entities` (4.1): the physical tags of every curve entity.  `$PartitionedEntities`
!>   (a partitioned mesh) is rejected.
!> - `$Nodes`: node ids may be any positive integers in any order (they are mapped to
!>   1..N); every z coordinate must be 0 (|z| <= geom_rel_tol times the diameter).
!>   Nodes that no triangle uses (e.g. the centre point of a circle arc) are dropped.
!> - `$Elements`: 3-node triangles (type 2) form the mesh; 2-node lines (type 1) carry the
!>   boundary markers; points (type 15) are skipped silently and every other type is
!>   skipped with a note giving the count per type.  In MSH 2.2 the physical tag of an
!>   element is its first tag (0 when it has none); in MSH 4.1 a line takes the physical
!>   tag of its curve entity (a curve in k physical groups gives k marked copies, as MSH 2.2
!>   writes an element once per physical group).  Triangles listed more than once (a
!>   surface in several physical groups, MSH 2.2) are kept once, with a note.
!> - Any other section `$Name ... $EndName` is skipped.
!>
!> Boundary markers: the marker of a boundary side is the physical tag (> 0) of the line
!> element on it.  A boundary side without such a line, or with two lines of different
!> physical tags, is an error.  Lines on interior sides and lines that are no side of a
!> triangle are ignored with a note.  Triangle orientation: triangles all clockwise are
!> reoriented and counted (`nflipped`); a mix of orientations (a folded mesh), zero-area
!> triangles, duplicate nodes, several pieces and overlapping triangles are rejected as by
!> the dualsig text reader.  Every error names the file, the line and what was expected.
module dualsig_mesh_gmsh
  use dualsig_kinds, only: dp, i8, geom_rel_tol
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_MESH, DS_ERR_INPUT
  use dualsig_mesh, only: mesh_t, mesh_diameter
  use dualsig_mesh_io, only: mesh_text_reader_t, mesh_reader_open, mesh_reader_close, mesh_reader_next, &
                             mesh_reader_count_ok, &
                             mesh_reader_expect, mesh_reader_field, mesh_reader_int, mesh_reader_real, &
                             mesh_reader_fail, mesh_quote, mesh_check_file_geometry, mesh_finish_topology, &
                             mesh_drop_unused_nodes, mesh_mark_boundary, merge_sort_pairs, &
                             mesh_note_len
  use dualsig_strings, only: itoa, rtoa
  use dualsig_alloc, only: alloc_failed, BYTES_INT
  implicit none
  private

  public :: gmsh_physical_t, mesh_read_gmsh, gmsh_markers_from_names, gmsh_name_len

  integer, parameter :: gmsh_name_len = 256          !! longest accepted physical name
  integer, parameter :: type_line = 1                !! Gmsh element type: 2-node line
  integer, parameter :: type_triangle = 2            !! Gmsh element type: 3-node triangle
  integer, parameter :: type_point = 15              !! Gmsh element type: 1-node point
  !> Element types up to this number are counted one by one in the skip notes; larger
  !> numbers (not used by Gmsh 4) are counted together.
  integer, parameter :: max_type = 140
  !> Initial capacity of the growing element lists.
  integer, parameter :: initial_capacity = 64

  !> Physical groups named in `$PhysicalNames`: dimension, tag and name of each.
  type :: gmsh_physical_t
    integer :: n = 0
    integer, allocatable :: dim(:)
    integer, allocatable :: tag(:)
    character(len=gmsh_name_len), allocatable :: name(:)
  end type gmsh_physical_t

  !> Everything read from the file before the mesh is assembled.
  type :: gmsh_data_t
    integer :: version = 0                         !! 2 or 4
    ! nodes
    logical :: have_nodes = .false.
    integer :: nn = 0
    integer, allocatable :: node_id(:), node_line(:)
    real(dp), allocatable :: xyz(:,:)              !! (3, nn)
    integer(i8), allocatable :: sorted_id(:), zero_key(:)
    integer, allocatable :: id_perm(:)             !! node_id(id_perm(k)) is the k-th smallest id
    ! elements
    logical :: have_elements = .false.
    integer :: nt = 0, nl = 0
    integer, allocatable :: tri(:,:), tri_id(:), tri_line(:)      !! node indices 1..nn
    integer, allocatable :: tri_phys(:)                            !! physical surface tag (0: none)
    integer, allocatable :: lin(:,:), lin_phys(:), lin_line(:)    !! node indices 1..nn
    integer :: skipped(max_type + 1) = 0                           !! skipped elements per type
    ! 4.1 entities: physical tags of the curves
    logical :: have_entities = .false.
    integer :: ncurve = 0
    integer, allocatable :: curve_tag(:), curve_nphys(:), curve_phys_start(:), curve_phys(:)
    ! 4.1 entities: the first physical tag of each surface (0: none)
    integer, allocatable :: surf_tag(:), surf_phys(:)
  end type gmsh_data_t

contains

  !> Read the Gmsh MSH 2.2 or 4.1 ASCII file `path` into `mesh` (topology built) and its
  !> physical names into `phys`.  nflipped (optional): clockwise triangles reoriented;
  !> notes (optional): one line per skipped item (element types, unused nodes, ignored lines).
  subroutine mesh_read_gmsh(path, mesh, phys, st, nflipped, notes)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(out) :: mesh
    type(gmsh_physical_t), intent(out) :: phys
    type(status_t), intent(out) :: st
    integer, intent(out), optional :: nflipped
    character(len=mesh_note_len), allocatable, intent(out), optional :: notes(:)
    type(mesh_text_reader_t) :: rd
    type(gmsh_data_t) :: g
    character(len=mesh_note_len), allocatable :: nt(:)

    if (present(nflipped)) nflipped = 0
    allocate (nt(0))                                    ! small: empty
    allocate (phys%dim(0), phys%tag(0), phys%name(0))   ! small: empty
    call mesh_reader_open(rd, path, .false., st)
    if (st%code /= 0) then
      if (present(notes)) notes = nt
      return
    end if
    call read_sections(rd, g, phys, st)
    call mesh_reader_close(rd)
    if (st%code == 0) call assemble(path, g, mesh, nflipped, nt, st)
    if (present(notes)) notes = nt
  end subroutine mesh_read_gmsh

  !> The markers of the physical curves named in `names` (blank entries skipped; a name given
  !> to several physical curves gives all their tags, in the order of $PhysicalNames), for the
  !> namelist item `item`, from the physical names `phys` of mesh file `path`.  A name that
  !> is not a physical curve of the file is an error naming the item, the file, the name and
  !> the curve names the file has.
  subroutine gmsh_markers_from_names(phys, names, item, path, markers, st)
    type(gmsh_physical_t), intent(in) :: phys
    character(len=*), intent(in) :: names(:)
    character(len=*), intent(in) :: item, path
    integer, allocatable, intent(out) :: markers(:)
    type(status_t), intent(inout) :: st
    integer :: k, j, jany, ncurve

    allocate (markers(0))                            ! small: grown by the tags of one namelist item
    do k = 1, size(names)
      if (len_trim(names(k)) == 0) cycle
      jany = 0
      ncurve = 0
      ! every physical curve of that name (a name given to several curve groups names them all)
      do j = 1, phys%n
        if (trim(phys%name(j)) /= trim(names(k))) cycle
        if (jany == 0) jany = j
        if (phys%dim(j) /= 1) cycle
        ncurve = ncurve + 1
        markers = [markers, phys%tag(j)]
      end do
      if (ncurve > 0) cycle
      if (jany > 0) then
        call set_error(st, DS_ERR_INPUT, item // ": '" // trim(names(k)) // "' is a physical group of " // &
          'dimension ' // itoa(phys%dim(jany)) // " in mesh file '" // path // &
          "' (expected the name of a physical curve, dimension 1; its curves: " // curve_names() // ')')
      else
        call set_error(st, DS_ERR_INPUT, item // ": no physical curve named '" // trim(names(k)) // &
          "' in mesh file '" // path // "' (expected one of its physical curve names: " // curve_names() // ')')
      end if
      return
    end do

  contains

    !> The quoted names of the physical curves, or a remark that there are none.
    function curve_names() result(s)
      character(len=:), allocatable :: s
      integer :: i
      s = ''
      do i = 1, phys%n
        if (phys%dim(i) /= 1) cycle
        if (len(s) > 0) s = s // ', '
        s = s // "'" // trim(phys%name(i)) // "'"
      end do
      if (len(s) == 0) s = 'none, the file names no physical curve in $PhysicalNames'
    end function curve_names
  end subroutine gmsh_markers_from_names

  ! ------------------------------------------------------------------ sections

  !> Read $MeshFormat, then every section of the file.
  subroutine read_sections(rd, g, phys, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    type(gmsh_physical_t), intent(inout) :: phys
    type(status_t), intent(inout) :: st
    logical :: found
    integer :: ftype
    character(len=:), allocatable :: name, ver

    call mesh_reader_next(rd, found, st)
    if (st%code /= 0) return
    if (.not. found) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "': the file is empty (expected a Gmsh " // &
        "file starting with '$MeshFormat')")
      return
    end if
    if (mesh_reader_field(rd, 1) /= '$MeshFormat' .or. rd%nf /= 1) then
      call mesh_reader_fail(rd, "expected '$MeshFormat' (the first line of a Gmsh .msh file), found " // &
        mesh_quote(rd%line), st)
      return
    end if
    if (.not. mesh_reader_expect(rd, "the line '<version> <file-type> <data-size>' of $MeshFormat", st)) return
    if (rd%nf < 3) then
      call mesh_reader_fail(rd, "expected '<version> <file-type> <data-size>', found " // mesh_quote(rd%line), st)
      return
    end if
    ver = mesh_reader_field(rd, 1)
    if (ver == '4.1') then
      g%version = 4
    else if (len(ver) >= 2 .and. ver(1:min(2, len(ver))) == '2.') then
      g%version = 2
    else
      call mesh_reader_fail(rd, 'unsupported MSH version ' // mesh_quote(ver) // &
        ' (expected 2.2 or 4.1: gmsh -format msh22 or -format msh41)', st)
      return
    end if
    if (.not. mesh_reader_int(rd, 2, 'the file-type', ftype, st)) return
    if (ftype /= 0) then
      call mesh_reader_fail(rd, 'binary MSH files are not supported (file-type ' // itoa(ftype) // &
        '; expected 0, ASCII: write the mesh without gmsh -bin)', st)
      return
    end if
    if (.not. end_of_section(rd, '$MeshFormat', st)) return

    do
      call mesh_reader_next(rd, found, st)
      if (st%code /= 0 .or. .not. found) exit
      name = mesh_reader_field(rd, 1)
      if (name(1:1) /= '$' .or. rd%nf /= 1) then
        call mesh_reader_fail(rd, "expected a section header such as '$Nodes', found " // mesh_quote(rd%line), st)
        return
      end if
      select case (name)
      case ('$PhysicalNames')
        call read_physical_names(rd, phys, st)
      case ('$Entities')
        if (g%version == 4) then
          call read_entities(rd, g, st)
        else
          call skip_section(rd, name, st)
        end if
      case ('$PartitionedEntities')
        call mesh_reader_fail(rd, 'partitioned meshes are not supported (expected a mesh written without ' // &
          'partitions, gmsh without -part)', st)
      case ('$Nodes')
        if (g%have_nodes) then
          call mesh_reader_fail(rd, "second '$Nodes' section (expected one)", st)
        else if (g%version == 2) then
          call read_nodes_v2(rd, g, st)
        else
          call read_nodes_v4(rd, g, st)
        end if
        if (st%code == 0) call index_nodes(rd, g, st)
      case ('$Elements')
        if (g%have_elements) then
          call mesh_reader_fail(rd, "second '$Elements' section (expected one)", st)
        else if (.not. g%have_nodes) then
          call mesh_reader_fail(rd, "'$Elements' before '$Nodes' (expected the nodes first)", st)
        else if (g%version == 2) then
          call read_elements_v2(rd, g, st)
        else
          call read_elements_v4(rd, g, st)
        end if
      case ('$MeshFormat')
        call mesh_reader_fail(rd, "second '$MeshFormat' (expected one, at the start of the file)", st)
      case default
        if (name(1:min(4, len(name))) == '$End') then
          call mesh_reader_fail(rd, mesh_quote(name) // ' closes no open section (expected a section ' // &
            "header such as '$Nodes')", st)
        else
          call skip_section(rd, name, st)
        end if
      end select
      if (st%code /= 0) return
    end do
    if (st%code /= 0) return
    if (.not. g%have_nodes .or. .not. g%have_elements) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "': no '" // &
        trim(merge('$Nodes   ', '$Elements', .not. g%have_nodes)) // "' section in its " // itoa(rd%lineno) // &
        ' lines (expected $Nodes and $Elements sections; truncated file?)')
    end if
  end subroutine read_sections

  !> $PhysicalNames: a count, then lines `dim tag "name"`.
  subroutine read_physical_names(rd, phys, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_physical_t), intent(inout) :: phys
    type(status_t), intent(inout) :: st
    integer :: n, k, q1, q2, d, t, ist
    if (.not. count_line(rd, '$PhysicalNames', 'the number of physical names', n, st)) return
    deallocate (phys%dim, phys%tag, phys%name)
    allocate (phys%dim(n), phys%tag(n), phys%name(n), stat=ist)
    if (alloc_failed(ist, st, 'the physical names of ' // rd%path, n, 8 + storage_size(phys%name) / 8)) return
    phys%n = n
    do k = 1, n
      if (.not. data_line(rd, '$PhysicalNames', k, n, '<dim> <tag> "<name>"', st)) return
      if (.not. mesh_reader_int(rd, 1, 'the dimension', d, st)) return
      if (.not. mesh_reader_int(rd, 2, 'the physical tag', t, st)) return
      q1 = index(rd%line, '"')
      q2 = index(rd%line, '"', back=.true.)
      if (d < 0 .or. d > 3 .or. q1 == 0 .or. q2 <= q1) then
        call mesh_reader_fail(rd, "expected '<dim> <tag> ""<name>""' with dim 0..3 and the name in " // &
          'double quotes, found ' // mesh_quote(rd%line), st)
        return
      end if
      if (q2 - q1 - 1 > gmsh_name_len) then
        call mesh_reader_fail(rd, 'physical name longer than ' // itoa(gmsh_name_len) // &
          ' characters (expected a shorter name)', st)
        return
      end if
      phys%dim(k) = d
      phys%tag(k) = t
      phys%name(k) = rd%line(q1 + 1:q2 - 1)
    end do
    if (.not. end_of_section(rd, '$PhysicalNames', st)) return
  end subroutine read_physical_names

  !> $Entities (MSH 4.1): keep the physical tags of the curves; points, surfaces and volumes
  !> are checked for their layout only.
  subroutine read_entities(rd, g, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    type(status_t), intent(inout) :: st
    integer :: counts(4), d, k, np, j, total, v, first_phys, ist
    real(dp) :: coord
    if (.not. mesh_reader_expect(rd, "'<numPoints> <numCurves> <numSurfaces> <numVolumes>' of $Entities", st)) return
    if (rd%nf /= 4) then
      call mesh_reader_fail(rd, "expected '<numPoints> <numCurves> <numSurfaces> <numVolumes>', found " // &
        mesh_quote(rd%line), st)
      return
    end if
    do d = 1, 4
      if (.not. mesh_reader_int(rd, d, 'an entity count', counts(d), st)) return
      if (counts(d) < 0) then
        call mesh_reader_fail(rd, 'negative entity count ' // itoa(counts(d)) // ' (expected an integer >= 0)', st)
        return
      end if
      if (.not. mesh_reader_count_ok(rd, counts(d), 'the entity count', st)) return
    end do
    g%ncurve = counts(2)
    allocate (g%curve_tag(counts(2)), g%curve_nphys(counts(2)), g%curve_phys_start(counts(2) + 1), &
              g%curve_phys(0), g%surf_tag(counts(3)), g%surf_phys(counts(3)), stat=ist)
    if (alloc_failed(ist, st, 'the entities of ' // rd%path, 3 * counts(2) + 2 * counts(3) + 1, BYTES_INT)) return
    g%curve_phys_start(1) = 1
    g%surf_phys = 0
    do d = 0, 3
      do k = 1, counts(d + 1)
        if (.not. data_line(rd, '$Entities', k, counts(d + 1), entity_layout(d), st)) return
        ! points: tag x y z nphys ...; curves, surfaces, volumes: tag 6 box coordinates nphys ...
        first_phys = merge(5, 8, d == 0)
        if (.not. mesh_reader_int(rd, 1, 'the entity tag', v, st)) return
        do j = 2, first_phys - 1
          if (.not. mesh_reader_real(rd, j, 'a coordinate', coord, st)) return
        end do
        if (.not. mesh_reader_int(rd, first_phys, 'the number of physical tags', np, st)) return
        total = first_phys + np
        if (d > 0) total = total + 1
        if (np < 0 .or. rd%nf < total) then
          call mesh_reader_fail(rd, 'expected ' // entity_layout(d) // ', found ' // mesh_quote(rd%line), st)
          return
        end if
        if (d == 1) then
          g%curve_tag(k) = v
          g%curve_nphys(k) = np
          g%curve_phys_start(k + 1) = g%curve_phys_start(k) + np
          do j = 1, np
            if (.not. mesh_reader_int(rd, first_phys + j, 'a physical tag', v, st)) return
            g%curve_phys = [g%curve_phys, abs(v)]
          end do
        else if (d == 2) then
          g%surf_tag(k) = v
          if (np > 0) then
            if (.not. mesh_reader_int(rd, first_phys + 1, 'a physical tag', v, st)) return
            g%surf_phys(k) = abs(v)
          end if
        end if
      end do
    end do
    g%have_entities = .true.
    if (.not. end_of_section(rd, '$Entities', st)) return
  end subroutine read_entities

  !> Layout of an entity line of dimension d (for messages).
  pure function entity_layout(d) result(s)
    integer, intent(in) :: d
    character(len=:), allocatable :: s
    if (d == 0) then
      s = "'<tag> <x> <y> <z> <numPhysicalTags> <physicalTag>...'"
    else
      s = "'<tag> <minX> <minY> <minZ> <maxX> <maxY> <maxZ> <numPhysicalTags> <physicalTag>... " // &
        "<numBounding> <tag>...'"
    end if
  end function entity_layout

  !> $Nodes of MSH 2.2: a count, then lines `id x y z`.
  subroutine read_nodes_v2(rd, g, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    type(status_t), intent(inout) :: st
    integer :: n, k
    if (.not. count_line(rd, '$Nodes', 'the number of nodes', n, st)) return
    if (.not. alloc_nodes(rd, g, n, st)) return
    do k = 1, n
      if (.not. data_line(rd, '$Nodes', k, n, '<id> <x> <y> <z>', st)) return
      if (.not. nfields(rd, 4, '<id> <x> <y> <z>', st)) return
      if (.not. node_record(rd, g, k, 1, st)) return
    end do
    g%nn = n
    if (.not. end_of_section(rd, '$Nodes', st)) return
    g%have_nodes = .true.
  end subroutine read_nodes_v2

  !> $Nodes of MSH 4.1: '<numEntityBlocks> <numNodes> <minNodeTag> <maxNodeTag>', then per
  !> block '<entityDim> <entityTag> <parametric> <numNodesInBlock>', the node tags (one per
  !> line) and the coordinates 'x y z' (plus the parametric coordinates when parametric = 1).
  subroutine read_nodes_v4(rd, g, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    type(status_t), intent(inout) :: st
    integer :: nblock, n, b, edim, etag, param, nin, k, m, nf
    if (.not. block_header(rd, '$Nodes', '<numEntityBlocks> <numNodes> <minNodeTag> <maxNodeTag>', &
                           nblock, n, st)) return
    if (.not. alloc_nodes(rd, g, n, st)) return
    m = 0
    do b = 1, nblock
      if (.not. data_line(rd, '$Nodes', b, nblock, &
                          'block header <entityDim> <entityTag> <parametric> <numNodesInBlock>', st)) return
      if (.not. nfields(rd, 4, '<entityDim> <entityTag> <parametric> <numNodesInBlock>', st)) return
      if (.not. mesh_reader_int(rd, 1, 'the entity dimension', edim, st)) return
      if (.not. mesh_reader_int(rd, 2, 'the entity tag', etag, st)) return
      if (.not. mesh_reader_int(rd, 3, 'the parametric flag', param, st)) return
      if (.not. mesh_reader_int(rd, 4, 'the number of nodes in the block', nin, st)) return
      if (edim < 0 .or. edim > 3 .or. param < 0 .or. param > 1 .or. nin < 0 .or. nin > n - m) then
        call mesh_reader_fail(rd, 'invalid node block header ' // mesh_quote(rd%line) // ' (expected ' // &
          'entityDim 0..3, parametric 0 or 1 and at most ' // itoa(n - m) // ' nodes, the rest of numNodes)', st)
        return
      end if
      nf = 3 + param * edim
      do k = 1, nin
        if (.not. data_line(rd, '$Nodes', m + k, n, '<nodeTag>', st)) return
        if (.not. nfields(rd, 1, '<nodeTag>', st)) return
        if (.not. mesh_reader_int(rd, 1, 'the node tag', g%node_id(m + k), st)) return
        g%node_line(m + k) = rd%lineno
      end do
      do k = 1, nin
        if (.not. data_line(rd, '$Nodes', m + k, n, '<x> <y> <z>', st)) return
        if (.not. nfields(rd, nf, coordinate_layout(param, edim), st)) return
        if (.not. node_record(rd, g, m + k, 0, st)) return
      end do
      m = m + nin
    end do
    if (m /= n) then
      call mesh_reader_fail(rd, 'the node blocks hold ' // itoa(m) // ' nodes but numNodes is ' // itoa(n) // &
        ' (expected equal counts)', st)
      return
    end if
    g%nn = n
    if (.not. end_of_section(rd, '$Nodes', st)) return
    g%have_nodes = .true.
  end subroutine read_nodes_v4

  !> Layout of a 4.1 coordinate line.
  pure function coordinate_layout(param, edim) result(s)
    integer, intent(in) :: param, edim
    character(len=:), allocatable :: s
    s = '<x> <y> <z>'
    if (param == 1 .and. edim >= 1) s = s // ' <u>'
    if (param == 1 .and. edim >= 2) s = s // ' <v>'
    if (param == 1 .and. edim >= 3) s = s // ' <w>'
  end function coordinate_layout

  !> Allocate room for n nodes.
  logical function alloc_nodes(rd, g, n, st) result(ok)
    type(mesh_text_reader_t), intent(in) :: rd
    type(gmsh_data_t), intent(inout) :: g
    integer, intent(in) :: n
    type(status_t), intent(inout) :: st
    integer :: istat
    allocate (g%node_id(n), g%node_line(n), g%xyz(3, n), stat=istat)
    ok = istat == 0
    if (.not. ok) call mesh_reader_fail(rd, 'cannot allocate ' // itoa(n) // ' nodes (expected a smaller count)', st)
  end function alloc_nodes

  !> Node k from the current line: the id from field 1 when id_field = 1, then x y z.
  logical function node_record(rd, g, k, id_field, st) result(ok)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    integer, intent(in) :: k, id_field
    type(status_t), intent(inout) :: st
    integer :: j
    ok = .false.
    if (id_field == 1) then
      if (.not. mesh_reader_int(rd, 1, 'the node id', g%node_id(k), st)) return
      g%node_line(k) = rd%lineno
    end if
    do j = 1, 3
      if (.not. mesh_reader_real(rd, id_field + j, 'a node coordinate', g%xyz(j, k), st)) return
    end do
    ok = .true.
  end function node_record

  !> Sort the node ids, reject repeated ones, prepare the id -> index lookup.
  subroutine index_nodes(rd, g, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    type(status_t), intent(inout) :: st
    integer :: k, a, b, ist
    allocate (g%sorted_id(g%nn), g%zero_key(g%nn), g%id_perm(g%nn), stat=ist)
    if (alloc_failed(ist, st, 'the node index of ' // rd%path, 5 * g%nn, BYTES_INT)) return
    g%zero_key = 0
    g%id_perm = [(k, k=1, g%nn)]
    g%sorted_id = g%node_id
    call merge_sort_pairs(g%sorted_id, g%zero_key, g%id_perm, st)
    if (.not. is_ok(st)) return
    g%sorted_id = g%sorted_id(g%id_perm)
    do k = 2, g%nn
      if (g%sorted_id(k) == g%sorted_id(k - 1)) then
        a = min(g%id_perm(k), g%id_perm(k - 1))
        b = max(g%id_perm(k), g%id_perm(k - 1))
        rd%lineno = g%node_line(b)
        call mesh_reader_fail(rd, 'node id ' // itoa(g%node_id(b)) // ' repeats the node of line ' // &
          itoa(g%node_line(a)) // ' (expected distinct node ids)', st)
        return
      end if
    end do
  end subroutine index_nodes

  !> Index 1..nn of the node with file id `id` (0 if there is none).
  integer function node_index(g, id) result(i)
    type(gmsh_data_t), intent(in) :: g
    integer, intent(in) :: id
    integer :: q
    i = 0
    if (g%nn == 0) return
    q = bsearch(g%sorted_id, int(id, i8))
    if (q > 0) i = g%id_perm(q)
  end function node_index

  !> Position of `key` in the ascending array `a`, 0 if absent.
  pure integer function bsearch(a, key) result(pos)
    integer(i8), intent(in) :: a(:), key
    integer :: lo, hi, mid
    pos = 0
    lo = 1
    hi = size(a)
    do while (lo <= hi)
      mid = lo + (hi - lo) / 2
      if (a(mid) == key) then
        pos = mid
        return
      else if (a(mid) < key) then
        lo = mid + 1
      else
        hi = mid - 1
      end if
    end do
  end function bsearch

  !> $Elements of MSH 2.2: a count, then lines `id type ntags tag... node...`.
  subroutine read_elements_v2(rd, g, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    type(status_t), intent(inout) :: st
    integer :: n, k, id, etype, ntags, phys
    if (.not. count_line(rd, '$Elements', 'the number of elements', n, st)) return
    call alloc_elements(g)
    do k = 1, n
      if (.not. data_line(rd, '$Elements', k, n, '<id> <type> <ntags> <tag>... <node>...', st)) return
      if (.not. mesh_reader_int(rd, 1, 'the element id', id, st)) return
      if (.not. mesh_reader_int(rd, 2, 'the element type', etype, st)) return
      if (.not. mesh_reader_int(rd, 3, 'the number of tags', ntags, st)) return
      if (ntags < 0 .or. rd%nf < 3 + ntags) then
        call mesh_reader_fail(rd, 'the element has ' // itoa(rd%nf - 3) // ' fields after <ntags> = ' // &
          itoa(ntags) // ' (expected <ntags> >= 0 tags, then the nodes)', st)
        return
      end if
      phys = 0
      if (ntags >= 1) then
        if (.not. mesh_reader_int(rd, 4, 'the physical tag', phys, st)) return
      end if
      call add_element(rd, g, id, etype, 3 + ntags, phys, st)
      if (st%code /= 0) return
    end do
    if (.not. end_of_section(rd, '$Elements', st)) return
    g%have_elements = .true.
  end subroutine read_elements_v2

  !> $Elements of MSH 4.1: '<numEntityBlocks> <numElements> <minTag> <maxTag>', then per block
  !> '<entityDim> <entityTag> <elementType> <numElementsInBlock>' and lines 'tag node...'.
  subroutine read_elements_v4(rd, g, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    type(status_t), intent(inout) :: st
    integer :: nblock, n, b, edim, etag, etype, nin, k, m, c, p, id, sphys
    if (.not. block_header(rd, '$Elements', '<numEntityBlocks> <numElements> <minElementTag> <maxElementTag>', &
                           nblock, n, st)) return
    call alloc_elements(g)
    m = 0
    do b = 1, nblock
      if (.not. data_line(rd, '$Elements', b, nblock, &
                          'block header <entityDim> <entityTag> <elementType> <numElementsInBlock>', st)) return
      if (.not. nfields(rd, 4, '<entityDim> <entityTag> <elementType> <numElementsInBlock>', st)) return
      if (.not. mesh_reader_int(rd, 1, 'the entity dimension', edim, st)) return
      if (.not. mesh_reader_int(rd, 2, 'the entity tag', etag, st)) return
      if (.not. mesh_reader_int(rd, 3, 'the element type', etype, st)) return
      if (.not. mesh_reader_int(rd, 4, 'the number of elements in the block', nin, st)) return
      if (edim < 0 .or. edim > 3 .or. nin < 0 .or. nin > n - m) then
        call mesh_reader_fail(rd, 'invalid element block header ' // mesh_quote(rd%line) // ' (expected ' // &
          'entityDim 0..3 and at most ' // itoa(n - m) // ' elements, the rest of numElements)', st)
        return
      end if
      c = 0
      if (etype == type_line) then
        if (edim /= 1) then
          call mesh_reader_fail(rd, 'line elements (type 1) in an entity of dimension ' // itoa(edim) // &
            ' (expected dimension 1, a curve)', st)
          return
        end if
        if (.not. g%have_entities) then
          call mesh_reader_fail(rd, "line elements but no '$Entities' section before '$Elements' (expected " // &
            'the physical tags of the curves there)', st)
          return
        end if
        c = findloc(g%curve_tag, etag, dim=1)
        if (c == 0) then
          call mesh_reader_fail(rd, 'curve entity ' // itoa(etag) // " is not in '$Entities' (expected a " // &
            'curve listed there)', st)
          return
        end if
      end if
      sphys = 0                                   ! a triangle's region: its surface's physical tag
      if (etype == type_triangle .and. edim == 2 .and. g%have_entities) then
        if (findloc(g%surf_tag, etag, dim=1) > 0) sphys = g%surf_phys(findloc(g%surf_tag, etag, dim=1))
      end if
      do k = 1, nin
        if (.not. data_line(rd, '$Elements', m + k, n, '<elementTag> <nodeTag>...', st)) return
        if (.not. mesh_reader_int(rd, 1, 'the element tag', id, st)) return
        if (c == 0) then
          call add_element(rd, g, id, etype, 1, sphys, st)
        else if (g%curve_nphys(c) == 0) then
          call add_element(rd, g, id, etype, 1, 0, st)
        else
          ! one marked copy per physical group of the curve (as MSH 2.2 writes them)
          do p = g%curve_phys_start(c), g%curve_phys_start(c + 1) - 1
            call add_element(rd, g, id, etype, 1, g%curve_phys(p), st)
            if (st%code /= 0) exit
          end do
        end if
        if (st%code /= 0) return
      end do
      m = m + nin
    end do
    if (m /= n) then
      call mesh_reader_fail(rd, 'the element blocks hold ' // itoa(m) // ' elements but numElements is ' // &
        itoa(n) // ' (expected equal counts)', st)
      return
    end if
    if (.not. end_of_section(rd, '$Elements', st)) return
    g%have_elements = .true.
  end subroutine read_elements_v4

  !> Start the element lists.
  subroutine alloc_elements(g)
    type(gmsh_data_t), intent(inout) :: g
    allocate (g%tri(3, initial_capacity), g%tri_id(initial_capacity), g%tri_line(initial_capacity))  ! small: fixed
    allocate (g%tri_phys(initial_capacity))                                                         ! small: fixed
    allocate (g%lin(2, initial_capacity), g%lin_phys(initial_capacity), g%lin_line(initial_capacity))  ! small: fixed
  end subroutine alloc_elements

  !> Keep the element of the current line (a triangle or a line; other types are counted):
  !> its nodes are the fields after field `nskip`, checked in number and mapped to indices.
  subroutine add_element(rd, g, id, etype, nskip, phys, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    type(gmsh_data_t), intent(inout) :: g
    integer, intent(in) :: id, etype, nskip, phys
    type(status_t), intent(inout) :: st
    integer :: nv, k, v(3)
    select case (etype)
    case (type_triangle)
      nv = 3
    case (type_line)
      nv = 2
    case (type_point)
      nv = 1
    case default
      g%skipped(min(max(etype, 1), max_type + 1)) = g%skipped(min(max(etype, 1), max_type + 1)) + 1
      return
    end select
    if (rd%nf /= nskip + nv) then
      call mesh_reader_fail(rd, 'element ' // itoa(id) // ' of type ' // itoa(etype) // ' has ' // &
        itoa(rd%nf - nskip) // ' nodes (expected ' // itoa(nv) // ')', st)
      return
    end if
    if (etype == type_point) then
      g%skipped(type_point) = g%skipped(type_point) + 1
      return
    end if
    do k = 1, nv
      if (.not. mesh_reader_int(rd, nskip + k, 'a node tag', v(k), st)) return
      v(k) = node_index(g, v(k))
      if (v(k) == 0) then
        call mesh_reader_fail(rd, 'element ' // itoa(id) // ': node ' // mesh_reader_field(rd, nskip + k) // &
          " is not in '$Nodes' (expected the tag of a node)", st)
        return
      end if
    end do
    if (etype == type_triangle) then
      if (g%nt == size(g%tri_id)) then
        call grow_triangles(g, st)
        if (.not. is_ok(st)) return
      end if
      g%nt = g%nt + 1
      g%tri(:, g%nt) = v
      g%tri_id(g%nt) = id
      g%tri_line(g%nt) = rd%lineno
      g%tri_phys(g%nt) = phys
    else
      if (g%nl == size(g%lin_phys)) then
        call grow_lines(g, st)
        if (.not. is_ok(st)) return
      end if
      g%nl = g%nl + 1
      g%lin(:, g%nl) = v(1:2)
      g%lin_phys(g%nl) = phys
      g%lin_line(g%nl) = rd%lineno
    end if
  end subroutine add_element

  !> Double the capacity of the triangle list.
  subroutine grow_triangles(g, st)
    type(gmsh_data_t), intent(inout) :: g
    type(status_t), intent(inout) :: st
    integer, allocatable :: t2(:,:), i1(:), i2(:), i3(:)
    integer :: n, ist
    n = size(g%tri_id)
    allocate (t2(3, 2 * n), i1(2 * n), i2(2 * n), i3(2 * n), stat=ist)
    if (alloc_failed(ist, st, 'the triangles of a Gmsh file', 12 * n, BYTES_INT)) return
    t2(:, 1:n) = g%tri
    i1(1:n) = g%tri_id
    i2(1:n) = g%tri_line
    call move_alloc(t2, g%tri)
    call move_alloc(i1, g%tri_id)
    call move_alloc(i2, g%tri_line)
    i3(1:n) = g%tri_phys
    call move_alloc(i3, g%tri_phys)
  end subroutine grow_triangles

  !> Double the capacity of the line list.
  subroutine grow_lines(g, st)
    type(gmsh_data_t), intent(inout) :: g
    type(status_t), intent(inout) :: st
    integer, allocatable :: t2(:,:), i1(:), i2(:)
    integer :: n, ist
    n = size(g%lin_phys)
    allocate (t2(2, 2 * n), i1(2 * n), i2(2 * n), stat=ist)
    if (alloc_failed(ist, st, 'the boundary lines of a Gmsh file', 8 * n, BYTES_INT)) return
    t2(:, 1:n) = g%lin
    i1(1:n) = g%lin_phys
    i2(1:n) = g%lin_line
    call move_alloc(t2, g%lin)
    call move_alloc(i1, g%lin_phys)
    call move_alloc(i2, g%lin_line)
  end subroutine grow_lines

  !> Skip a section the reader does not use, up to its '$End...' line.
  subroutine skip_section(rd, name, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: name
    type(status_t), intent(inout) :: st
    integer :: start
    logical :: found
    start = rd%lineno
    do
      call mesh_reader_next(rd, found, st)
      if (st%code /= 0) return
      if (.not. found) then
        call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "': section " // mesh_quote(name) // &
          ' of line ' // itoa(start) // " is not closed (expected '$End" // name(2:) // "'; truncated file?)")
        return
      end if
      if (mesh_reader_field(rd, 1) == '$End' // name(2:)) return
    end do
  end subroutine skip_section

  ! ------------------------------------------------------------------ line helpers

  !> The next line must be '$End<name>' (name given with its '$').
  logical function end_of_section(rd, name, st) result(ok)
    type(mesh_text_reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: name
    type(status_t), intent(inout) :: st
    ok = mesh_reader_expect(rd, "'$End" // name(2:) // "'", st)
    if (.not. ok) return
    ok = rd%nf == 1 .and. mesh_reader_field(rd, 1) == '$End' // name(2:)
    if (.not. ok) call mesh_reader_fail(rd, "expected '$End" // name(2:) // "' (the end of the section " // &
      "announced by its count), found " // mesh_quote(rd%line), st)
  end function end_of_section

  !> The count line of a section: one integer >= 0.
  logical function count_line(rd, section, what, n, st) result(ok)
    type(mesh_text_reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: section, what
    integer, intent(out) :: n
    type(status_t), intent(inout) :: st
    n = 0
    ok = mesh_reader_expect(rd, what // ' of ' // section, st)
    if (.not. ok) return
    ok = nfields(rd, 1, '<count>', st)
    if (.not. ok) return
    ok = mesh_reader_int(rd, 1, what, n, st)
    if (.not. ok) return
    if (n < 0) then
      ok = .false.
      call mesh_reader_fail(rd, 'negative count ' // itoa(n) // ' (expected ' // what // ', an integer >= 0)', st)
      return
    end if
    ok = mesh_reader_count_ok(rd, n, what, st)
  end function count_line

  !> The header line of a 4.1 $Nodes or $Elements section: four integers; returns the number
  !> of blocks and of items (both >= 0).
  logical function block_header(rd, section, layout, nblock, n, st) result(ok)
    type(mesh_text_reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: section, layout
    integer, intent(out) :: nblock, n
    type(status_t), intent(inout) :: st
    nblock = 0
    n = 0
    ok = mesh_reader_expect(rd, "'" // layout // "' of " // section, st)
    if (.not. ok) return
    ok = nfields(rd, 4, layout, st)
    if (.not. ok) return
    ok = mesh_reader_int(rd, 1, 'the number of entity blocks', nblock, st)
    if (ok) ok = mesh_reader_int(rd, 2, 'the number of items', n, st)
    if (.not. ok) return
    if (nblock < 0 .or. n < 0) then
      ok = .false.
      call mesh_reader_fail(rd, 'negative count in ' // mesh_quote(rd%line) // ' (expected ' // layout // &
        ', counts >= 0)', st)
      return
    end if
    ok = mesh_reader_count_ok(rd, nblock, 'the number of entity blocks', st)
    if (ok) ok = mesh_reader_count_ok(rd, n, 'the number of items', st)
  end function block_header

  !> Data line k of n of a section: it must exist and not be a '$' keyword.
  logical function data_line(rd, section, k, n, layout, st) result(ok)
    type(mesh_text_reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: section, layout
    integer, intent(in) :: k, n
    type(status_t), intent(inout) :: st
    character(len=:), allocatable :: f
    ok = mesh_reader_expect(rd, 'entry ' // itoa(k) // ' of ' // itoa(n) // " '" // layout // "' of " // section, st)
    if (.not. ok) return
    f = mesh_reader_field(rd, 1)
    if (f(1:1) == '$') then
      ok = .false.
      call mesh_reader_fail(rd, 'found ' // mesh_quote(rd%line) // ' but ' // section // ' announced ' // &
        itoa(n) // ' entries and has only ' // itoa(k - 1) // " (expected '" // layout // "')", st)
    end if
  end function data_line

  !> The current line must have exactly n fields.
  logical function nfields(rd, n, layout, st) result(ok)
    type(mesh_text_reader_t), intent(in) :: rd
    integer, intent(in) :: n
    character(len=*), intent(in) :: layout
    type(status_t), intent(inout) :: st
    ok = rd%nf == n
    if (.not. ok) call mesh_reader_fail(rd, 'expected ' // itoa(n) // " fields '" // layout // "', found " // &
      itoa(rd%nf) // ': ' // mesh_quote(rd%line), st)
  end function nfields

  ! ------------------------------------------------------------------ the mesh

  !> Build the mesh from the elements read: check z, keep each triangle once, drop unused
  !> nodes, check the geometry, attach the markers of the lines, build the topology.
  subroutine assemble(path, g, mesh, nflipped, notes, st)
    character(len=*), intent(in) :: path
    type(gmsh_data_t), intent(inout) :: g
    type(mesh_t), intent(inout) :: mesh
    integer, intent(inout), optional :: nflipped
    character(len=mesh_note_len), allocatable, intent(inout) :: notes(:)
    type(status_t), intent(inout) :: st
    integer, allocatable :: new_index(:), keep(:), cand(:,:)
    integer :: k, ndup, ndropped, nflip, ninterior, nstray, j, ist
    real(dp) :: ztol

    ! --- skipped element types ---
    do k = 1, max_type + 1
      if (k == type_point .or. g%skipped(k) == 0) cycle
      call note(itoa(g%skipped(k)) // ' element(s) of type ' // type_text(k) // ' skipped (only 3-node ' // &
        'triangles, type 2, and 2-node lines, type 1, are used)')
    end do
    if (g%nt == 0) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // path // "': no 3-node triangles (element type 2) in " // &
        '$Elements' // skipped_text() // ' (expected a first-order 2-D triangle mesh: gmsh -2 -order 1, ' // &
        'and a Physical Surface when physical groups are used)')
      return
    end if

    ! --- planar: z = 0 ---
    ztol = geom_rel_tol * max(hypot(maxval(g%xyz(1, 1:g%nn)) - minval(g%xyz(1, 1:g%nn)), &
                                    maxval(g%xyz(2, 1:g%nn)) - minval(g%xyz(2, 1:g%nn))), tiny(1.0_dp))
    j = maxloc(abs(g%xyz(3, 1:g%nn)), dim=1)
    if (abs(g%xyz(3, j)) > ztol) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // path // "', line " // itoa(g%node_line(j)) // ': node ' // &
        itoa(g%node_id(j)) // ' has z = ' // rtoa(g%xyz(3, j)) // ' (expected a plane mesh in z = 0)')
      return
    end if

    ! --- each triangle once ---
    call unique_triangles(g, keep, ndup, st)
    if (.not. is_ok(st)) return
    if (ndup > 0) call note(itoa(ndup) // ' triangle(s) listed more than once (a surface in several ' // &
      'physical groups) counted once')

    mesh%nnode = g%nn
    mesh%xy = g%xyz(1:2, 1:g%nn)
    mesh%ntri = size(keep)
    mesh%tri = g%tri(:, keep)
    g%tri_id = g%tri_id(keep)
    g%tri_line = g%tri_line(keep)
    if (any(g%tri_phys(keep) > 0)) mesh%tri_region = g%tri_phys(keep)   ! the physical surfaces

    ! --- nodes of the triangles only ---
    call mesh_drop_unused_nodes(mesh, new_index, ndropped, st)
    if (.not. is_ok(st)) return
    if (ndropped > 0) then
      call note(itoa(ndropped) // ' node(s) used by no triangle dropped (e.g. centres of circle arcs)')
      g%node_line = pack(g%node_line(1:g%nn), new_index > 0)
      g%node_id = pack(g%node_id(1:g%nn), new_index > 0)
    end if
    allocate (cand(2, g%nl), stat=ist)
    if (alloc_failed(ist, st, 'the boundary lines of ' // path, 2 * g%nl, BYTES_INT)) return
    do k = 1, g%nl
      cand(:, k) = new_index(g%lin(:, k))
    end do

    call mesh_check_file_geometry(path, mesh, g%node_line, g%tri_line, nflip, st, g%node_id, g%tri_id)
    if (present(nflipped)) nflipped = nflip
    if (st%code /= 0) return
    call mesh_mark_boundary(path, mesh, cand, g%lin_phys(1:g%nl), g%lin_line(1:g%nl), &
                            'line element (type 1) of a physical curve', .true., ninterior, nstray, st)
    if (st%code /= 0) return
    if (ninterior > 0) call note(itoa(ninterior) // ' line element(s) on interior sides ignored')
    if (nstray > 0) call note(itoa(nstray) // ' line element(s) that are no side of a triangle ignored')
    call mesh_finish_topology(path, mesh, st, g%node_line, g%tri_line, node_id=g%node_id, tri_id=g%tri_id)

  contains

    !> Append a note.
    subroutine note(text)
      character(len=*), intent(in) :: text
      notes = [character(len=mesh_note_len) :: notes, text]
    end subroutine note

    !> '; skipped: n of type t, ...' for the error without triangles ('' when nothing was skipped).
    function skipped_text() result(s)
      character(len=:), allocatable :: s
      integer :: t
      s = ''
      do t = 1, max_type + 1
        if (t == type_point .or. g%skipped(t) == 0) cycle
        if (len(s) > 0) s = s // ','
        s = s // ' ' // itoa(g%skipped(t)) // ' of type ' // type_text(t)
      end do
      if (len(s) > 0) s = '; skipped:' // s
    end function skipped_text
  end subroutine assemble

  !> Name of a Gmsh element type for the notes.
  function type_text(t) result(s)
    integer, intent(in) :: t
    character(len=:), allocatable :: s
    if (t > max_type) then
      s = '> ' // itoa(max_type)
      return
    end if
    s = itoa(t)
    select case (t)
    case (3)
      s = s // ' (4-node quadrangle)'
    case (4)
      s = s // ' (4-node tetrahedron)'
    case (5)
      s = s // ' (8-node hexahedron)'
    case (6)
      s = s // ' (6-node prism)'
    case (7)
      s = s // ' (5-node pyramid)'
    case (8)
      s = s // ' (3-node line)'
    case (9)
      s = s // ' (6-node triangle)'
    case (10)
      s = s // ' (9-node quadrangle)'
    case (11)
      s = s // ' (10-node tetrahedron)'
    case (16)
      s = s // ' (8-node quadrangle)'
    end select
  end function type_text

  !> Positions of the triangles to keep: the first of every set of triangles with the same
  !> three nodes; ndup counts the others.  Sorting: O(T log T).
  subroutine unique_triangles(g, keep, ndup, st)
    type(gmsh_data_t), intent(in) :: g
    integer, allocatable, intent(out) :: keep(:)
    integer, intent(out) :: ndup
    type(status_t), intent(inout) :: st
    integer(i8), allocatable :: kx(:), ky(:)
    integer, allocatable :: perm(:)
    logical, allocatable :: dup(:)
    integer :: t, p, v(3), ist
    ndup = 0
    allocate (kx(g%nt), ky(g%nt), perm(g%nt), dup(g%nt), stat=ist)
    if (alloc_failed(ist, st, 'the triangle keys of a Gmsh file', 6 * g%nt, BYTES_INT)) return
    do t = 1, g%nt
      v = g%tri(:, t)
      call sort3(v)
      kx(t) = v(1)
      ky(t) = int(v(2), i8) * (int(g%nn, i8) + 1) + v(3)
      perm(t) = t
    end do
    call merge_sort_pairs(kx, ky, perm, st)      ! stable: the first listed comes first
    if (.not. is_ok(st)) return
    dup = .false.
    do p = 2, g%nt
      if (kx(perm(p)) == kx(perm(p - 1)) .and. ky(perm(p)) == ky(perm(p - 1))) dup(perm(p)) = .true.
    end do
    ndup = count(dup)
    keep = pack([(t, t=1, g%nt)], .not. dup)
  end subroutine unique_triangles

  !> Sort three integers ascending.
  pure subroutine sort3(v)
    integer, intent(inout) :: v(3)
    if (v(1) > v(2)) v([1, 2]) = v([2, 1])
    if (v(2) > v(3)) v([2, 3]) = v([3, 2])
    if (v(1) > v(2)) v([1, 2]) = v([2, 1])
  end subroutine sort3
end module dualsig_mesh_gmsh
