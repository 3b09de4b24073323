!> Plain-text mesh files: reader `mesh_read_text` and writer `mesh_write_text`.
!>
!> File format (version 1):
!>
!>     # comment lines start with '#' and may appear anywhere; blank lines are ignored
!>     dualsig-mesh 1
!>     nodes N
!>     <id> <x> <y>          (N lines, ids 1..N in order)
!>     triangles T
!>     <id> <n1> <n2> <n3>   (T lines; all counter-clockwise, or all clockwise: then all are reoriented)
!>     boundary B
!>     <id> <n1> <n2> <marker>   (B lines; marker integer > 0)
!>
!> Details:
!> - Fields are separated by blanks or tabs; a line holds exactly the fields shown.  A comment
!>   line is a line whose first non-blank character is '#'.  A trailing carriage return
!>   (DOS line end) is ignored.  Nothing but comments and blank lines may follow the
!>   boundary section.
!> - Integers are written in decimal without a decimal point.  Reals are decimal numbers
!>   with an optional exponent (1, -0.5, 2.5e-3, 1.0D+00); no NaN or infinity, magnitude at
!>   most 1e100.  Node, triangle and boundary ids must be 1, 2, 3, ... in order.
!> - Node indices n1, n2, n3 refer to node ids (1..N).  Two nodes whose coordinates agree
!>   within geom_rel_tol times the bounding-box diameter (in both x and y) are rejected as
!>   duplicates; triangles with |area| <= mesh_zero_area (geom_rel_tol times the square of
!>   the triangle's longest side, or the rounding of its area) are rejected.
!> - The triangles are all counter-clockwise, or all clockwise: then every one is reoriented
!>   by swapping n2 and n3, and the reader reports how many (optional argument `nflipped`;
!>   the caller decides whether to print a note).  A mix of orientations is a folded mesh
!>   (e.g. a node moved across a side of a neighbour) and an error naming the first
!>   inverted triangle and how many there are.  Also rejected (dualsig_mesh_check): a
!>   triangle listed twice (same three vertices in any order), triangles in several pieces
!>   (joined by no side), and triangle areas that do not sum to the area the boundary
!>   loops enclose (overlapping triangles).
!> - The boundary section lists every boundary side of the triangulation once, in any order
!>   and either orientation, with an integer marker > 0 (it selects the boundary
!>   condition).  The writer lists them with the domain on their left.
!>
!> The writer uses ES24.16E3 for coordinates (17 significant digits), so that a written and
!> re-read mesh has bit-identical coordinates.  It writes the file in place (no temporary
!> file); if a write fails, the partly written file is deleted.
!>
!> The module also holds what the Gmsh and Triangle readers share with this one: a line
!> reader for records with any number of fields (`mesh_text_reader_t`), the number parsers,
!> the geometric checks and orientation (`mesh_check_file_geometry`), the topology and the
!> geometry checks after it (`mesh_finish_topology`), the attachment of
!> boundary markers from edges listed in a file (`mesh_mark_boundary`) and the removal of
!> nodes no triangle uses (`mesh_drop_unused_nodes`).
module dualsig_mesh_io
  use, intrinsic :: iso_fortran_env, only: iostat_end, iostat_eor
  use dualsig_kinds, only: dp, i8, geom_rel_tol
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_MESH, DS_ERR_IO
  use dualsig_mesh, only: mesh_t, mesh_build_topology, mesh_diameter, mesh_triangle_area, mesh_zero_area, &
                          mesh_coordinate_scale
  use dualsig_mesh_check, only: mesh_orient_triangles, mesh_check_duplicates, mesh_check_geometry
  use dualsig_strings, only: itoa, i8toa
  use dualsig_io_files, only: input_file_ok
  use dualsig_alloc, only: alloc_failed, alloc_check, BYTES_INT
  implicit none
  private

  public :: mesh_read_text, mesh_write_text
  ! shared with the Gmsh and Triangle readers (dualsig_mesh_gmsh, dualsig_mesh_triangle)
  public :: mesh_text_reader_t, mesh_reader_open, mesh_reader_close, mesh_reader_next, mesh_reader_expect, &
            mesh_reader_field, mesh_reader_int, mesh_reader_real, mesh_reader_fail, mesh_quote, &
            mesh_reader_count_ok, mesh_max_line_len
  public :: mesh_check_file_geometry, mesh_finish_topology, mesh_drop_unused_nodes, mesh_mark_boundary
  public :: merge_sort_pairs, lower_bound, mesh_note_len

  character(len=*), parameter :: magic = 'dualsig-mesh'   !! first word of the header line
  integer, parameter :: format_version = 1                 !! second word of the header line
  !> Fields stored per line: one more than the longest record, to detect extra fields.
  integer, parameter :: max_fields = 5
  !> Characters of an offending line quoted in error messages.
  integer, parameter :: echo_len = 60
  !> Characters read per chunk of a line (lines may be longer).
  integer, parameter :: chunk_len = 4096
  !> Longest line accepted (1 MiB): a longer one is an error (a binary file, a file without
  !> line ends such as /dev/zero copied to disk), read in linear time up to the cap.
  integer, parameter :: max_line_len = 1048576
  !> Longest line the mesh readers accept (public name).
  integer, parameter :: mesh_max_line_len = max_line_len
  !> iostat of read_line for a line longer than max_line_len (no gfortran code is this value).
  integer, parameter :: ios_too_long = 987654
  !> Fewest bytes one counted item of a header takes in the file: a character and a line end.
  integer, parameter :: min_item_bytes = 2
  !> Largest accepted coordinate magnitude: squares of lengths and areas cannot overflow.
  real(dp), parameter :: max_abs_coord = 1.0e100_dp
  !> Decimal exponent of max_abs_coord: numbers of a larger order are rejected before conversion.
  integer, parameter :: max_dec_exponent = 100
  !> Significant digits of an integer field that a 64-bit integer holds safely.
  integer, parameter :: max_int_digits = 18
  !> Cap on an exponent field while it is accumulated (anything larger is out of range anyway).
  integer, parameter :: exponent_cap = 100000
  character(len=*), parameter :: real_fmt = '(i0,2(1x,es24.16e3))'
  character(len=*), parameter :: int4_fmt = '(i0,3(1x,i0))'
  character(len=*), parameter :: whitespace = ' ' // achar(9)
  !> Length of the short reason a number field is rejected ('not a number', ...).
  integer, parameter :: why_len = 16

  !> State of the line reader: the file, the current line and its number.
  type :: reader_t
    integer :: unit = -1
    character(len=:), allocatable :: path
    character(len=:), allocatable :: line     !! current record (without line end)
    integer :: lineno = 0                     !! number of the current line in the file
    integer :: nf = 0                         !! number of fields of the current record
    integer :: fb(max_fields) = 0             !! first character of field k
    integer :: fe(max_fields) = 0             !! last character of field k
    integer(i8) :: nbytes = -1                !! size of the file (stat), -1 if unknown
    integer(i8) :: consumed = 0               !! bytes of the lines read so far
  end type reader_t

  !> Line reader of the Gmsh and Triangle readers: records with any number of fields.
  type :: mesh_text_reader_t
    integer :: unit = -1
    character(len=:), allocatable :: path
    character(len=:), allocatable :: line     !! current record (without line end and comment)
    integer :: lineno = 0                     !! number of the current line in the file
    integer :: nf = 0                         !! number of fields of the current record
    integer, allocatable :: fb(:), fe(:)      !! first and last character of field k
    logical :: hash_comments = .false.        !! '#' starts a comment that runs to the line end
    integer(i8) :: nbytes = -1                !! size of the file (stat), -1 if unknown
    integer(i8) :: consumed = 0               !! bytes of the lines read so far
  end type mesh_text_reader_t
  !> Length of the notes (skipped elements, dropped nodes, ...) the file readers return.
  integer, parameter :: mesh_note_len = 200
  !> Initial number of field slots of a mesh_text_reader_t (doubled when a line has more).
  integer, parameter :: initial_field_slots = 16

contains

  !> Read a mesh in the dualsig text format (see the module header) from file `path` and
  !> build its topology.  `nflipped` (optional) returns the number of clockwise triangles
  !> that were reoriented.  Errors name the file, the line and what was expected;
  !> DS_ERR_IO for files that cannot be read, DS_ERR_MESH for invalid content.
  subroutine mesh_read_text(path, mesh, st, nflipped)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(out) :: mesh
    type(status_t), intent(out) :: st
    integer, intent(out), optional :: nflipped
    type(reader_t) :: rd
    integer :: ios, nflip
    character(len=256) :: iom

    if (present(nflipped)) nflipped = 0
    rd%path = path
    if (.not. input_file_ok(path, "mesh file '" // path // "': ", 'a regular mesh file', rd%nbytes, st)) return
    iom = ''
    open (newunit=rd%unit, file=path, status='old', action='read', form='formatted', &
          access='sequential', iostat=ios, iomsg=iom)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, "mesh file '" // path // "': cannot open for reading (" // &
        trim(iom) // "); expected an existing readable file")
      return
    end if
    nflip = 0
    call read_body(rd, mesh, nflip, st)
    close (rd%unit, iostat=ios)
    if (present(nflipped)) nflipped = nflip
  end subroutine mesh_read_text

  !> Parse the sections of an open mesh file, check the data and build the topology.
  subroutine read_body(rd, mesh, nflip, st)
    type(reader_t), intent(inout) :: rd
    type(mesh_t), intent(inout) :: mesh
    integer, intent(out) :: nflip
    type(status_t), intent(inout) :: st
    integer, allocatable :: node_line(:), tri_line(:), bnd_line(:)
    integer :: i, k, v, nn, nt, nb, version, istat
    logical :: found

    nflip = 0
    ! --- header ---
    call next_record(rd, found, st)
    if (st%code /= 0) return
    if (.not. found) then
      if (rd%lineno == 0) then
        call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "': the file is empty or not a " // &
          "regular file (expected the header line '" // magic // " " // itoa(format_version) // "')")
      else
        call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "': no data line in its " // &
          itoa(rd%lineno) // " lines (expected the header line '" // magic // " " // &
          itoa(format_version) // "')")
      end if
      return
    end if
    if (rd%nf /= 2 .or. field(rd, 1) /= magic) then
      call fail(rd, "expected the header line '" // magic // " " // itoa(format_version) // &
        "', found " // quote(rd%line), st)
      return
    end if
    if (.not. int_field(rd, 2, 'the format version', version, st)) return
    if (version /= format_version) then
      call fail(rd, 'unsupported format version ' // itoa(version) // ' (expected ' // &
        itoa(format_version) // ')', st)
      return
    end if

    ! --- nodes ---
    if (.not. section_header(rd, 'nodes', nn, st)) return
    allocate (mesh%xy(2, nn), node_line(nn), stat=istat)
    if (istat /= 0) then
      call fail(rd, 'cannot allocate ' // itoa(nn) // ' nodes (expected a smaller count)', st)
      return
    end if
    mesh%nnode = nn
    do i = 1, nn
      if (.not. data_record(rd, 'nodes', i, nn, 3, '<id> <x> <y>', st)) return
      node_line(i) = rd%lineno
      do k = 2, 3
        if (.not. real_field(rd, k, 'node coordinate', mesh%xy(k - 1, i), st)) return
      end do
    end do

    ! --- triangles ---
    if (.not. section_header(rd, 'triangles', nt, st)) return
    allocate (mesh%tri(3, nt), tri_line(nt), stat=istat)
    if (istat /= 0) then
      call fail(rd, 'cannot allocate ' // itoa(nt) // ' triangles (expected a smaller count)', st)
      return
    end if
    mesh%ntri = nt
    do i = 1, nt
      if (.not. data_record(rd, 'triangles', i, nt, 4, '<id> <n1> <n2> <n3>', st)) return
      tri_line(i) = rd%lineno
      do k = 2, 4
        if (.not. node_field(rd, k, nn, mesh%tri(k - 1, i), st)) return
      end do
    end do

    ! --- boundary edges ---
    if (.not. section_header(rd, 'boundary', nb, st)) return
    allocate (mesh%bedge_nodes(2, nb), mesh%bedge_marker(nb), bnd_line(nb), stat=istat)
    if (istat /= 0) then
      call fail(rd, 'cannot allocate ' // itoa(nb) // ' boundary edges (expected a smaller count)', st)
      return
    end if
    mesh%nbedge = nb
    do i = 1, nb
      if (.not. data_record(rd, 'boundary', i, nb, 4, '<id> <n1> <n2> <marker>', st)) return
      bnd_line(i) = rd%lineno
      do k = 2, 3
        if (.not. node_field(rd, k, nn, mesh%bedge_nodes(k - 1, i), st)) return
      end do
      if (.not. int_field(rd, 4, 'the boundary marker', v, st)) return
      if (v <= 0) then
        call fail(rd, 'boundary edge ' // itoa(i) // ' has marker ' // itoa(v) // &
          ' (expected an integer > 0)', st)
        return
      end if
      mesh%bedge_marker(i) = v
    end do

    ! --- only comments may follow ---
    call next_record(rd, found, st)
    if (st%code /= 0) return
    if (found) then
      call fail(rd, 'unexpected content after the boundary section: ' // quote(rd%line) // &
        ' (expected the end of the file)', st)
      return
    end if

    ! --- geometric checks, orientation, topology ---
    call mesh_check_file_geometry(rd%path, mesh, node_line, tri_line, nflip, st)
    if (st%code /= 0) return
    call mesh_finish_topology(rd%path, mesh, st, node_line, tri_line, bnd_line)
  end subroutine read_body

  !> Write `mesh` to file `path` in the dualsig text format (see the module header),
  !> replacing an existing file.  On a write error the partial file is deleted.
  subroutine mesh_write_text(path, mesh, st)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(in) :: mesh
    type(status_t), intent(out) :: st
    integer :: u, ios, ios2, i
    character(len=256) :: iom

    if (.not. (allocated(mesh%xy) .and. allocated(mesh%tri) .and. allocated(mesh%bedge_nodes) &
        .and. allocated(mesh%bedge_marker))) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // path // &
        "': nothing to write (expected a mesh with nodes, triangles and boundary edges)")
      return
    end if
    if (size(mesh%xy, 2) < mesh%nnode .or. size(mesh%tri, 2) < mesh%ntri .or. &
        size(mesh%bedge_nodes, 2) < mesh%nbedge .or. size(mesh%bedge_marker) < mesh%nbedge) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // path // &
        "': the mesh arrays are shorter than its counts (expected a consistent mesh_t)")
      return
    end if
    iom = ''
    open (newunit=u, file=path, status='replace', action='write', form='formatted', &
          access='sequential', iostat=ios, iomsg=iom)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, "mesh file '" // path // "': cannot open for writing (" // &
        trim(iom) // ')')
      return
    end if

    write (u, '(a,i0,a,i0,a,i0,a)', iostat=ios, iomsg=iom) '# dualsig mesh: ', mesh%nnode, &
      ' nodes, ', mesh%ntri, ' triangles, ', mesh%nbedge, ' boundary edges'
    if (ios == 0) write (u, '(a,1x,i0)', iostat=ios, iomsg=iom) magic, format_version
    if (ios == 0) write (u, '(a)', iostat=ios, iomsg=iom) '# <id> <x> <y>'
    if (ios == 0) write (u, '(a,1x,i0)', iostat=ios, iomsg=iom) 'nodes', mesh%nnode
    do i = 1, mesh%nnode
      if (ios /= 0) exit
      write (u, real_fmt, iostat=ios, iomsg=iom) i, mesh%xy(:, i)
    end do
    if (ios == 0) write (u, '(a)', iostat=ios, iomsg=iom) '# <id> <n1> <n2> <n3>, counter-clockwise'
    if (ios == 0) write (u, '(a,1x,i0)', iostat=ios, iomsg=iom) 'triangles', mesh%ntri
    do i = 1, mesh%ntri
      if (ios /= 0) exit
      write (u, int4_fmt, iostat=ios, iomsg=iom) i, mesh%tri(:, i)
    end do
    if (ios == 0) write (u, '(a)', iostat=ios, iomsg=iom) '# <id> <n1> <n2> <marker>'
    if (ios == 0) write (u, '(a,1x,i0)', iostat=ios, iomsg=iom) 'boundary', mesh%nbedge
    do i = 1, mesh%nbedge
      if (ios /= 0) exit
      write (u, int4_fmt, iostat=ios, iomsg=iom) i, mesh%bedge_nodes(:, i), mesh%bedge_marker(i)
    end do
    if (ios /= 0) then
      close (u, status='delete', iostat=ios2)
      call set_error(st, DS_ERR_IO, "mesh file '" // path // "': write failed (" // trim(iom) // &
        '); the partial file was deleted')
      return
    end if
    close (u, iostat=ios, iomsg=iom)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, "mesh file '" // path // "': close failed (" // trim(iom) // ')')
    end if
  end subroutine mesh_write_text

  ! ------------------------------------------------------------------ reading lines

  !> Advance to the next record (a line that is neither blank nor a comment) and split it
  !> into fields.  found = .false. at the end of the file.
  subroutine next_record(rd, found, st)
    type(reader_t), intent(inout) :: rd
    logical, intent(out) :: found
    type(status_t), intent(inout) :: st
    integer :: ios, k
    character(len=256) :: iom

    found = .false.
    do
      call read_line(rd%unit, rd%line, ios, iom, rd%consumed)
      if (ios == iostat_end) return
      if (ios /= 0) then
        call read_failure(rd%path, rd%lineno + 1, ios, iom, st)
        return
      end if
      rd%lineno = rd%lineno + 1
      k = verify(rd%line, whitespace)
      if (k == 0) cycle                      ! blank line
      if (rd%line(k:k) == '#') cycle         ! comment line
      exit
    end do
    found = .true.
    call split_fields(rd)
  end subroutine next_record

  !> Read one line of up to max_line_len characters in linear time (a buffer that doubles);
  !> a carriage return at its end is dropped.  ios is 0, an error code, iostat_end when no
  !> line is left, or ios_too_long (the rest of the line is not read).  consumed grows by
  !> the bytes of the line and its line end.
  subroutine read_line(u, line, ios, iom, consumed)
    integer, intent(in) :: u
    character(len=:), allocatable, intent(out) :: line
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iom
    integer(i8), intent(inout) :: consumed
    character(len=chunk_len) :: chunk
    character(len=:), allocatable :: buf, grown
    integer :: sz, n, cap, istat

    n = 0
    cap = chunk_len
    allocate (character(len=cap) :: buf)          ! small: chunk_len characters
    do
      sz = 0
      read (u, '(a)', advance='no', iostat=ios, iomsg=iom, size=sz) chunk
      if (sz > 0) then
        if (n + sz > max_line_len) then
          ios = ios_too_long
          consumed = consumed + n + sz
          return
        end if
        if (n + sz > cap) then
          cap = min(max(2 * cap, n + sz), max_line_len)
          allocate (character(len=cap) :: grown, stat=istat)
          if (istat /= 0) then
            ios = ios_too_long
            return
          end if
          grown(1:n) = buf(1:n)
          call move_alloc(grown, buf)
        end if
        buf(n + 1:n + sz) = chunk(1:sz)
        n = n + sz
      end if
      if (ios == iostat_eor) then
        ios = 0
        exit
      end if
      if (ios == iostat_end .and. n > 0) then
        ios = 0                              ! last line without a line end
        exit
      end if
      if (ios /= 0) return
    end do
    consumed = consumed + n + 1
    if (n > 0) then
      if (buf(n:n) == achar(13)) n = n - 1
    end if
    line = buf(1:n)
  end subroutine read_line

  !> The error of a failed line read: a line over max_line_len, or the runtime's message.
  subroutine read_failure(path, lineno, ios, iom, st)
    character(len=*), intent(in) :: path, iom
    integer, intent(in) :: lineno, ios
    type(status_t), intent(inout) :: st
    if (ios == ios_too_long) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // path // "', line " // itoa(lineno) // &
        ': the line is longer than ' // itoa(max_line_len) // ' characters (expected a text mesh file ' // &
        'with shorter lines: a binary file, or a file without line ends?)')
    else
      call set_error(st, DS_ERR_IO, "mesh file '" // path // "', line " // itoa(lineno) // &
        ': read error (' // trim(iom) // '); expected a text file')
    end if
  end subroutine read_failure

  !> A count n of items announced in a header must fit in the rest of the file: every item
  !> takes at least min_item_bytes bytes, so a larger count is an error before anything of
  !> that size is allocated.  `what` names the count in the message.
  logical function count_fits(path, lineno, nbytes, consumed, n, what, st) result(ok)
    character(len=*), intent(in) :: path, what
    integer, intent(in) :: lineno
    integer(i8), intent(in) :: nbytes, consumed
    integer, intent(in) :: n
    type(status_t), intent(inout) :: st
    integer(i8) :: left
    ok = .true.
    if (nbytes < 0) return
    left = max(nbytes - consumed, 0_i8)
    if (int(n, i8) * min_item_bytes <= left) return
    ok = .false.
    call set_error(st, DS_ERR_MESH, "mesh file '" // path // "', line " // itoa(lineno) // ': ' // what // ' ' // &
      itoa(n) // ' cannot fit in the ' // i8toa(left) // ' bytes left in the file (every entry takes at least ' // &
      itoa(min_item_bytes) // ' bytes; expected the true count: a wrong header or a truncated file?)')
  end function count_fits


  !> The check of count_fits for the line reader of the Gmsh and Triangle readers, at its
  !> current line: .false. (and an error) when `n` items cannot fit in the rest of the file.
  logical function mesh_reader_count_ok(rd, n, what, st) result(ok)
    type(mesh_text_reader_t), intent(in) :: rd
    integer, intent(in) :: n
    character(len=*), intent(in) :: what
    type(status_t), intent(inout) :: st
    ok = count_fits(rd%path, rd%lineno, rd%nbytes, rd%consumed, n, what, st)
  end function mesh_reader_count_ok

  !> Split the current line into blank- or tab-separated fields (at most max_fields stored,
  !> all counted).
  subroutine split_fields(rd)
    type(reader_t), intent(inout) :: rd
    integer :: p, b, e
    rd%nf = 0
    p = 1
    do
      if (.not. next_field(rd%line, p, b, e)) exit
      rd%nf = rd%nf + 1
      if (rd%nf <= max_fields) then
        rd%fb(rd%nf) = b
        rd%fe(rd%nf) = e
      end if
    end do
  end subroutine split_fields

  !> The next blank- or tab-separated field of `line` at or after position p: its first and
  !> last characters b and e (p is moved past it); .false. when there is none.
  logical function next_field(line, p, b, e) result(found)
    character(len=*), intent(in) :: line
    integer, intent(inout) :: p
    integer, intent(out) :: b, e
    found = .false.
    b = 0
    e = 0
    if (p > len(line)) return
    b = verify(line(p:), whitespace)
    if (b == 0) return
    b = p + b - 1
    e = scan(line(b:), whitespace)
    if (e == 0) then
      e = len(line)
    else
      e = b + e - 2
    end if
    p = e + 1
    found = .true.
  end function next_field

  !> Text of field k of the current record.
  function field(rd, k) result(s)
    type(reader_t), intent(in) :: rd
    integer, intent(in) :: k
    character(len=:), allocatable :: s
    s = rd%line(rd%fb(k):rd%fe(k))
  end function field

  ! ------------------------------------------------------------------ records

  !> Read a section header '<name> <count>' with count >= 0.
  logical function section_header(rd, name, count, st) result(ok)
    type(reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: name
    integer, intent(out) :: count
    type(status_t), intent(inout) :: st
    logical :: found

    ok = .false.
    count = 0
    call next_record(rd, found, st)
    if (st%code /= 0) return
    if (.not. found) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "': unexpected end of file after line " // &
        itoa(rd%lineno) // " (expected the section header '" // name // " <count>'; truncated file?)")
      return
    end if
    if (rd%nf /= 2 .or. field(rd, 1) /= name) then
      call fail(rd, "expected the section header '" // name // " <count>', found " // quote(rd%line), st)
      return
    end if
    if (.not. int_field(rd, 2, "the '" // name // "' count", count, st)) return
    if (count < 0) then
      call fail(rd, "negative '" // name // "' count " // itoa(count) // ' (expected an integer >= 0)', st)
      return
    end if
    if (.not. count_fits(rd%path, rd%lineno, rd%nbytes, rd%consumed, count, "the '" // name // "' count", st)) return
    ok = .true.
  end function section_header

  !> Read data line i of n of a section: `nfield` fields, the first the id i.
  logical function data_record(rd, section, i, n, nfield, layout, st) result(ok)
    type(reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: section, layout
    integer, intent(in) :: i, n, nfield
    type(status_t), intent(inout) :: st
    logical :: found
    integer :: id
    character(len=len('triangles') + 1) :: first   ! long enough to tell the keywords from longer words

    ok = .false.
    call next_record(rd, found, st)
    if (st%code /= 0) return
    if (.not. found) then
      call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "': unexpected end of file after line " // &
        itoa(rd%lineno) // ": the '" // section // "' section announced " // itoa(n) // &
        ' lines but has ' // itoa(i - 1) // ' (expected entry ' // itoa(i) // " '" // layout // &
        "'; truncated file?)")
      return
    end if
    first = rd%line(rd%fb(1):rd%fe(1))
    if (first == 'nodes' .or. first == 'triangles' .or. first == 'boundary') then
      call fail(rd, "found " // quote(rd%line) // " but the '" // section // "' section announced " // &
        itoa(n) // ' lines and has only ' // itoa(i - 1) // " (expected '" // layout // "')", st)
      return
    end if
    if (rd%nf /= nfield) then
      call fail(rd, 'expected ' // itoa(nfield) // " fields '" // layout // "' in the '" // section // &
        "' section, found " // itoa(rd%nf) // ': ' // quote(rd%line), st)
      return
    end if
    if (.not. int_field(rd, 1, 'the id', id, st)) return
    if (id /= i) then
      call fail(rd, "id " // itoa(id) // " out of order in the '" // section // "' section (expected " // &
        itoa(i) // ')', st)
      return
    end if
    ok = .true.
  end function data_record

  !> Field k of the current record as an integer; `what` names it in the error message.
  logical function int_field(rd, k, what, v, st) result(ok)
    type(reader_t), intent(in) :: rd
    integer, intent(in) :: k
    character(len=*), intent(in) :: what
    integer, intent(out) :: v
    type(status_t), intent(inout) :: st
    character(len=why_len) :: why
    ok = parse_int(rd%line(rd%fb(k):rd%fe(k)), v, why)
    if (.not. ok) call fail(rd, 'field ' // itoa(k) // ' (' // what // ') ' // quote(field(rd, k)) // &
      ' is ' // trim(why) // ' (expected an integer)', st)
  end function int_field

  !> Field k of the current record as a node index in 1..nn.
  logical function node_field(rd, k, nn, v, st) result(ok)
    type(reader_t), intent(in) :: rd
    integer, intent(in) :: k, nn
    integer, intent(out) :: v
    type(status_t), intent(inout) :: st
    ok = int_field(rd, k, 'a node index', v, st)
    if (.not. ok) return
    if (v < 1 .or. v > nn) then
      ok = .false.
      call fail(rd, 'field ' // itoa(k) // ': node index ' // itoa(v) // ' out of range (expected 1..' // &
        itoa(nn) // ', the node count)', st)
    end if
  end function node_field

  !> Field k of the current record as a real number.
  logical function real_field(rd, k, what, v, st) result(ok)
    type(reader_t), intent(in) :: rd
    integer, intent(in) :: k
    character(len=*), intent(in) :: what
    real(dp), intent(out) :: v
    type(status_t), intent(inout) :: st
    character(len=why_len) :: why
    ok = parse_real(rd%line(rd%fb(k):rd%fe(k)), v, why)
    if (.not. ok) call fail(rd, 'field ' // itoa(k) // ' (' // what // ') ' // quote(field(rd, k)) // &
      ' is ' // trim(why) // ' (expected a real number of magnitude <= ' // rtoa(max_abs_coord) // ')', st)
  end function real_field

  !> Record a content error at the current line of the reader.
  subroutine fail(rd, what, st)
    type(reader_t), intent(in) :: rd
    character(len=*), intent(in) :: what
    type(status_t), intent(inout) :: st
    call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "', line " // itoa(rd%lineno) // ': ' // what)
  end subroutine fail

  ! ------------------------------------------------------------------ numbers

  !> Parse a decimal integer [+-]digits that fits a default integer.  On failure `why`
  !> says what is wrong.
  logical function parse_int(s, v, why) result(ok)
    character(len=*), intent(in) :: s
    integer, intent(out) :: v
    character(len=*), intent(out) :: why
    integer :: p, q, k
    integer(i8) :: w

    ok = .false.
    v = 0
    why = 'not a number'
    p = 1
    if (len(s) == 0) return
    if (s(1:1) == '+' .or. s(1:1) == '-') p = 2
    if (p > len(s)) return
    if (verify(s(p:), '0123456789') /= 0) then
      if (verify(s(p:), '0123456789.eEdD+-') == 0) why = 'not an integer'
      return
    end if
    q = verify(s(p:), '0')                   ! first significant digit
    if (q /= 0) then
      if (len(s) - (p + q - 1) + 1 > max_int_digits) then
        why = 'too large'
        return
      end if
    end if
    w = 0
    do k = p, len(s)
      w = 10 * w + (iachar(s(k:k)) - iachar('0'))
    end do
    if (s(1:1) == '-') w = -w
    if (abs(w) > int(huge(v), i8)) then
      why = 'too large'
      return
    end if
    v = int(w)
    ok = .true.
  end function parse_int

  !> Parse a decimal real [+-](digits[.digits]|.digits)[(e|E|d|D)[+-]digits] of magnitude
  !> <= max_abs_coord.  The order of magnitude is checked before the conversion, so that no
  !> floating-point overflow can occur.  On failure `why` says what is wrong.
  logical function parse_real(s, v, why) result(ok)
    character(len=*), intent(in) :: s
    real(dp), intent(out) :: v
    character(len=*), intent(out) :: why
    character(len=*), parameter :: digits = '0123456789'
    integer :: p, n, nint_digits, nfrac_digits, first_nz, pos, expo, esign, ios
    logical :: seen_point

    ok = .false.
    v = 0.0_dp
    why = 'not a number'
    n = len(s)
    p = 1
    if (n == 0) return
    if (s(1:1) == '+' .or. s(1:1) == '-') p = 2
    ! mantissa
    nint_digits = 0
    nfrac_digits = 0
    first_nz = 0          ! position (counted over the mantissa digits) of the first nonzero digit
    pos = 0
    seen_point = .false.
    do while (p <= n)
      if (is_digit(s(p:p))) then
        pos = pos + 1
        if (first_nz == 0 .and. s(p:p) /= '0') first_nz = pos
        if (seen_point) then
          nfrac_digits = nfrac_digits + 1
        else
          nint_digits = nint_digits + 1
        end if
      else if (s(p:p) == '.' .and. .not. seen_point) then
        seen_point = .true.
      else
        exit
      end if
      p = p + 1
    end do
    if (nint_digits + nfrac_digits == 0) return
    ! exponent
    expo = 0
    if (p <= n) then
      if (index('eEdD', s(p:p)) == 0) return
      p = p + 1
      esign = 1
      if (p <= n) then
        if (s(p:p) == '+' .or. s(p:p) == '-') then
          if (s(p:p) == '-') esign = -1
          p = p + 1
        end if
      end if
      if (p > n) return
      if (verify(s(p:), digits) /= 0) return
      do while (p <= n)
        expo = min(exponent_cap, 10 * expo + (iachar(s(p:p)) - iachar('0')))
        p = p + 1
      end do
      expo = esign * expo
    end if
    ! order of magnitude: the first nonzero digit stands for 10**(nint_digits - first_nz)
    if (first_nz > 0) then
      if (nint_digits - first_nz + expo > max_dec_exponent) then
        why = 'out of range'
        return
      end if
    end if
    read (s, *, iostat=ios) v
    if (ios /= 0) return
    if (abs(v) > max_abs_coord) then
      why = 'out of range'
      return
    end if
    ok = .true.
  end function parse_real

  !> True for the characters '0' .. '9'.
  elemental logical function is_digit(c)
    character(len=1), intent(in) :: c
    is_digit = c >= '0' .and. c <= '9'
  end function is_digit

  ! ------------------------------------------------------------------ duplicates

  !> Reject two nodes whose coordinates agree within tol = geom_rel_tol * diameter in both
  !> x and y.  The nodes are bucketed on a grid of cells of width 2 tol (so that two such
  !> nodes lie in the same or in adjacent cells), the cells are sorted, and each node is
  !> compared with the nodes of its own and the neighbouring cells only: O(N log N).
  subroutine check_duplicate_nodes(rd, mesh, node_line, st, node_id)
    type(reader_t), intent(inout) :: rd
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: node_line(:)
    type(status_t), intent(inout) :: st
    integer, intent(in), optional :: node_id(:)   !! the node ids of the file (default 1, 2, ...)
    integer(i8), allocatable :: kx(:), ky(:)
    integer, allocatable :: perm(:)
    integer :: nn, i, j, p, q, dx, ist
    real(dp) :: tol, cell, xmin, ymin

    nn = mesh%nnode
    if (nn < 2) return
    tol = geom_rel_tol * mesh_diameter(mesh)
    if (.not. (tol > 0.0_dp)) then
      call report(1, 2)                      ! all nodes coincide
      return
    end if
    cell = 2.0_dp * tol
    xmin = minval(mesh%xy(1, 1:nn))
    ymin = minval(mesh%xy(2, 1:nn))
    allocate (kx(nn), ky(nn), perm(nn), stat=ist)
    if (alloc_failed(ist, st, 'the node keys of ' // rd%path, 5 * nn, BYTES_INT)) return
    do i = 1, nn
      kx(i) = floor((mesh%xy(1, i) - xmin) / cell, i8)
      ky(i) = floor((mesh%xy(2, i) - ymin) / cell, i8)
      perm(i) = i
    end do
    call merge_sort_pairs(kx, ky, perm, st)
    if (.not. is_ok(st)) return
    do p = 1, nn
      i = perm(p)
      do dx = 0, 1
        q = lower_bound(kx, ky, perm, kx(i) + dx, ky(i) - 1)
        do while (q <= nn)
          j = perm(q)
          if (key_less(kx(i) + dx, ky(i) + 1, kx(j), ky(j))) exit
          if (j /= i) then
            if (abs(mesh%xy(1, i) - mesh%xy(1, j)) <= tol .and. &
                abs(mesh%xy(2, i) - mesh%xy(2, j)) <= tol) then
              call report(min(i, j), max(i, j))
              return
            end if
          end if
          q = q + 1
        end do
      end do
    end do

  contains

    !> Error: node b repeats node a.
    subroutine report(a, b)
      integer, intent(in) :: a, b
      integer :: ia, ib
      ia = a
      ib = b
      if (present(node_id)) then
        ia = node_id(a)
        ib = node_id(b)
      end if
      rd%lineno = node_line(b)
      call fail(rd, 'node ' // itoa(ib) // ' duplicates node ' // itoa(ia) // ' (line ' // &
        itoa(node_line(a)) // '): same coordinates within ' // rtoa(tol) // &
        ' (expected distinct node coordinates)', st)
    end subroutine report
  end subroutine check_duplicate_nodes

  !> Lexicographic order of integer pairs: (a1,a2) < (b1,b2).
  pure logical function key_less(a1, a2, b1, b2) result(less)
    integer(i8), intent(in) :: a1, a2, b1, b2
    less = a1 < b1 .or. (a1 == b1 .and. a2 < b2)
  end function key_less

  !> First position q of the sorted permutation with key(perm(q)) >= (c1,c2) (size+1 if none).
  pure integer function lower_bound(kx, ky, perm, c1, c2) result(lo)
    integer(i8), intent(in) :: kx(:), ky(:), c1, c2
    integer, intent(in) :: perm(:)
    integer :: hi, mid
    lo = 1
    hi = size(perm) + 1
    do while (lo < hi)
      mid = lo + (hi - lo) / 2
      if (key_less(kx(perm(mid)), ky(perm(mid)), c1, c2)) then
        lo = mid + 1
      else
        hi = mid
      end if
    end do
  end function lower_bound

  !> Sort the permutation `perm` by the pairs (kx, ky) lexicographically: bottom-up merge
  !> sort, O(N log N), stable.
  pure subroutine merge_sort_pairs(kx, ky, perm, st)
    integer(i8), intent(in) :: kx(:), ky(:)
    integer, intent(inout) :: perm(:)
    type(status_t), intent(inout) :: st          !! out of memory: DS_ERR_MEMORY, perm unsorted
    integer, allocatable :: tmp(:)
    integer :: n, width, lo, mid, hi, a, b, k, ist
    n = size(perm)
    allocate (tmp(n), stat=ist)
    call alloc_check(ist, st, 'the sort of a mesh file', n, BYTES_INT)
    if (ist /= 0) return
    width = 1
    do while (width < n)
      lo = 1
      do while (lo <= n)
        mid = min(lo + width, n + 1)
        hi = min(lo + 2 * width, n + 1)
        a = lo
        b = mid
        do k = lo, hi - 1
          if (a < mid .and. b < hi) then
            if (key_less(kx(perm(b)), ky(perm(b)), kx(perm(a)), ky(perm(a)))) then
              tmp(k) = perm(b)
              b = b + 1
            else
              tmp(k) = perm(a)
              a = a + 1
            end if
          else if (a < mid) then
            tmp(k) = perm(a)
            a = a + 1
          else
            tmp(k) = perm(b)
            b = b + 1
          end if
        end do
        lo = hi
      end do
      perm = tmp
      width = 2 * width
    end do
  end subroutine merge_sort_pairs

  ! ------------------------------------------------------------------ text helpers

  !> Short text of a real.
  pure function rtoa(x) result(s)
    real(dp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=32) :: buf
    write (buf, '(es10.3e3)') x
    s = trim(adjustl(buf))
  end function rtoa

  !> The text in quotes, cut to echo_len characters, control characters shown as '?'.
  pure function quote(text) result(s)
    character(len=*), intent(in) :: text
    character(len=:), allocatable :: s
    integer :: k, c, n
    n = min(len(text), echo_len)
    s = text(1:n)
    do k = 1, n
      c = iachar(s(k:k))
      if (c < iachar(' ') .or. c > iachar('~')) s(k:k) = '?'
    end do
    if (len(text) > echo_len) s = s // '...'
    s = "'" // s // "'"
  end function quote
  ! ------------------------------------------------------------------ shared with the Gmsh and Triangle readers

  !> Open mesh file `path` for the line reader; `hash_comments` makes '#' start a comment
  !> that runs to the end of its line.  DS_ERR_IO when the file cannot be opened.
  subroutine mesh_reader_open(rd, path, hash_comments, st)
    type(mesh_text_reader_t), intent(out) :: rd
    character(len=*), intent(in) :: path
    logical, intent(in) :: hash_comments
    type(status_t), intent(inout) :: st
    integer :: ios
    character(len=256) :: iom
    rd%path = path
    rd%hash_comments = hash_comments
    allocate (rd%fb(initial_field_slots), rd%fe(initial_field_slots))   ! small: fixed size
    if (.not. input_file_ok(path, "mesh file '" // path // "': ", 'a regular mesh file', rd%nbytes, st)) return
    iom = ''
    open (newunit=rd%unit, file=path, status='old', action='read', form='formatted', &
          access='sequential', iostat=ios, iomsg=iom)
    if (ios /= 0) then
      rd%unit = -1
      call set_error(st, DS_ERR_IO, "mesh file '" // path // "': cannot open for reading (" // &
        trim(iom) // "); expected an existing readable file")
    end if
  end subroutine mesh_reader_open

  !> Close the file of the line reader (if open).
  subroutine mesh_reader_close(rd)
    type(mesh_text_reader_t), intent(inout) :: rd
    integer :: ios
    if (rd%unit /= -1) close (rd%unit, iostat=ios)
    rd%unit = -1
  end subroutine mesh_reader_close

  !> Advance to the next record (a line with at least one field once a comment is removed)
  !> and split it into blank- or tab-separated fields.  found = .false. at the end of the file.
  subroutine mesh_reader_next(rd, found, st)
    type(mesh_text_reader_t), intent(inout) :: rd
    logical, intent(out) :: found
    type(status_t), intent(inout) :: st
    integer :: ios, k, p, b, e, ist
    integer, allocatable :: grown(:)
    character(len=256) :: iom

    found = .false.
    do
      iom = ''
      call read_line(rd%unit, rd%line, ios, iom, rd%consumed)
      if (ios == iostat_end) return
      if (ios /= 0) then
        call read_failure(rd%path, rd%lineno + 1, ios, iom, st)
        return
      end if
      rd%lineno = rd%lineno + 1
      if (rd%hash_comments) then
        k = index(rd%line, '#')
        if (k > 0) rd%line = rd%line(1:k - 1)
      end if
      rd%nf = 0
      p = 1
      do
        if (.not. next_field(rd%line, p, b, e)) exit
        rd%nf = rd%nf + 1
        if (rd%nf > size(rd%fb)) then
          allocate (grown(2 * size(rd%fb)), stat=ist)
          if (alloc_failed(ist, st, 'the fields of a line of ' // rd%path, 2 * size(rd%fb), BYTES_INT)) return
          grown(1:size(rd%fb)) = rd%fb
          call move_alloc(grown, rd%fb)
          allocate (grown(2 * size(rd%fe)), stat=ist)
          if (alloc_failed(ist, st, 'the fields of a line of ' // rd%path, 2 * size(rd%fe), BYTES_INT)) return
          grown(1:size(rd%fe)) = rd%fe
          call move_alloc(grown, rd%fe)
        end if
        rd%fb(rd%nf) = b
        rd%fe(rd%nf) = e
      end do
      if (rd%nf > 0) exit
    end do
    found = .true.
  end subroutine mesh_reader_next

  !> Advance to the next record; at the end of the file record an error saying that
  !> `expected` was expected (a truncated file).
  logical function mesh_reader_expect(rd, expected, st) result(ok)
    type(mesh_text_reader_t), intent(inout) :: rd
    character(len=*), intent(in) :: expected
    type(status_t), intent(inout) :: st
    call mesh_reader_next(rd, ok, st)
    if (st%code /= 0) then
      ok = .false.
      return
    end if
    if (.not. ok) call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // &
      "': unexpected end of file after line " // itoa(rd%lineno) // ' (expected ' // expected // &
      '; truncated file?)')
  end function mesh_reader_expect

  !> Text of field k of the current record ('' when the record has fewer fields).
  function mesh_reader_field(rd, k) result(s)
    type(mesh_text_reader_t), intent(in) :: rd
    integer, intent(in) :: k
    character(len=:), allocatable :: s
    if (k < 1 .or. k > rd%nf) then
      s = ''
    else
      s = rd%line(rd%fb(k):rd%fe(k))
    end if
  end function mesh_reader_field

  !> Field k of the current record as an integer; `what` names it in the error message.
  logical function mesh_reader_int(rd, k, what, v, st) result(ok)
    type(mesh_text_reader_t), intent(in) :: rd
    integer, intent(in) :: k
    character(len=*), intent(in) :: what
    integer, intent(out) :: v
    type(status_t), intent(inout) :: st
    character(len=why_len) :: why
    v = 0
    if (k > rd%nf) then
      ok = .false.
      call mesh_reader_fail(rd, 'field ' // itoa(k) // ' (' // what // ') is missing in ' // &
        quote(rd%line) // ' (expected an integer)', st)
      return
    end if
    ok = parse_int(rd%line(rd%fb(k):rd%fe(k)), v, why)
    if (.not. ok) call mesh_reader_fail(rd, 'field ' // itoa(k) // ' (' // what // ') ' // &
      quote(mesh_reader_field(rd, k)) // ' is ' // trim(why) // ' (expected an integer)', st)
  end function mesh_reader_int

  !> Field k of the current record as a real number of magnitude <= max_abs_coord.
  logical function mesh_reader_real(rd, k, what, v, st) result(ok)
    type(mesh_text_reader_t), intent(in) :: rd
    integer, intent(in) :: k
    character(len=*), intent(in) :: what
    real(dp), intent(out) :: v
    type(status_t), intent(inout) :: st
    character(len=why_len) :: why
    v = 0.0_dp
    if (k > rd%nf) then
      ok = .false.
      call mesh_reader_fail(rd, 'field ' // itoa(k) // ' (' // what // ') is missing in ' // &
        quote(rd%line) // ' (expected a real number)', st)
      return
    end if
    ok = parse_real(rd%line(rd%fb(k):rd%fe(k)), v, why)
    if (.not. ok) call mesh_reader_fail(rd, 'field ' // itoa(k) // ' (' // what // ') ' // &
      quote(mesh_reader_field(rd, k)) // ' is ' // trim(why) // ' (expected a real number of magnitude <= ' // &
      rtoa(max_abs_coord) // ')', st)
  end function mesh_reader_real

  !> Record a content error at the current line of the line reader.
  subroutine mesh_reader_fail(rd, what, st)
    type(mesh_text_reader_t), intent(in) :: rd
    character(len=*), intent(in) :: what
    type(status_t), intent(inout) :: st
    call set_error(st, DS_ERR_MESH, "mesh file '" // rd%path // "', line " // itoa(rd%lineno) // ': ' // what)
  end subroutine mesh_reader_fail

  !> The text in quotes for a message, cut to echo_len characters, control characters as '?'.
  pure function mesh_quote(text) result(s)
    character(len=*), intent(in) :: text
    character(len=:), allocatable :: s
    s = quote(text)
  end function mesh_quote

  !> Geometric checks of a mesh read from file `path` (nodes and triangles set) before its
  !> topology: no two nodes within geom_rel_tol * diameter in x and y, no triangle with
  !> |area| <= mesh_zero_area, no triangle twice (mesh_check_duplicates), and
  !> one orientation (mesh_orient_triangles): all
  !> triangles counter-clockwise, or all clockwise (then all are swapped, nflip counts
  !> them); a mix is a folded mesh and an error naming the first inverted triangle.
  !> node_line / tri_line: the file line of each node / triangle; node_id / tri_id
  !> (optional): the ids the file gives them (default 1, 2, ...), used in the messages;
  !> tri_path (optional): the file of the triangles when it is not `path` (Triangle's .ele
  !> next to its .node).
  subroutine mesh_check_file_geometry(path, mesh, node_line, tri_line, nflip, st, node_id, tri_id, tri_path)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(inout) :: mesh
    integer, intent(in) :: node_line(:), tri_line(:)
    integer, intent(out) :: nflip
    type(status_t), intent(inout) :: st
    integer, intent(in), optional :: node_id(:), tri_id(:)
    character(len=*), intent(in), optional :: tri_path
    type(reader_t) :: rd
    integer :: i, id, bad_tri
    real(dp) :: area, area_tol, scale

    nflip = 0
    rd%path = path
    call check_duplicate_nodes(rd, mesh, node_line, st, node_id)
    if (st%code /= 0) return
    if (present(tri_path)) rd%path = tri_path
    scale = mesh_coordinate_scale(mesh)
    do i = 1, mesh%ntri
      area = mesh_triangle_area(mesh, i)
      area_tol = mesh_zero_area(mesh, i, scale)
      if (abs(area) <= area_tol) then
        id = i
        if (present(tri_id)) id = tri_id(i)
        rd%lineno = tri_line(i)
        call fail(rd, 'triangle ' // itoa(id) // ' has zero area (|area| <= ' // rtoa(area_tol) // &
          '; expected three non-collinear vertices)', st)
        return
      end if
    end do
    call mesh_check_duplicates(mesh, st, bad_tri, tri_id, node_id)
    if (st%code == 0) call mesh_orient_triangles(mesh, nflip, st, bad_tri, tri_id, node_id)
    if (st%code /= 0) call name_file_line(rd%path, st, bad_tri, tri_line)
  end subroutine mesh_check_file_geometry

  !> Finish a mesh read from file `path`: no duplicate triangles (mesh_check_duplicates),
  !> the topology (mesh_build_topology), then the geometry (mesh_check_geometry: one
  !> orientation, one piece, the triangle areas summing to the area the boundary loops
  !> enclose).  An error message names the file and, when the optional line maps are
  !> given (file line of each node, triangle, listed boundary edge), the line of the
  !> offending item; node_id / tri_id (optional) are the file's ids of nodes and
  !> triangles, used in the geometry messages.
  subroutine mesh_finish_topology(path, mesh, st, node_line, tri_line, bnd_line, node_id, tri_id)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(inout) :: mesh
    type(status_t), intent(inout) :: st
    integer, intent(in), optional :: node_line(:), tri_line(:), bnd_line(:)
    integer, intent(in), optional :: node_id(:), tri_id(:)
    integer :: bad_tri, bad_bedge, bad_node
    character(len=:), allocatable :: where
    bad_bedge = 0
    bad_node = 0
    call mesh_check_duplicates(mesh, st, bad_tri, tri_id, node_id)
    if (st%code == 0) call mesh_build_topology(mesh, st, bad_tri, bad_bedge, bad_node)
    if (st%code == 0) call mesh_check_geometry(mesh, st, bad_tri, tri_id, node_id)
    if (st%code /= 0) then
      ! keep the code; name the file (and line) instead of the generic 'mesh: ' prefix
      if (index(st%msg, 'mesh: ') == 1) st%msg = st%msg(len('mesh: ') + 1:)
      where = "mesh file '" // path // "'"
      if (bad_bedge > 0 .and. present(bnd_line)) then
        if (bad_bedge <= size(bnd_line)) where = where // ', line ' // itoa(bnd_line(bad_bedge))
      else if (bad_tri > 0 .and. present(tri_line)) then
        if (bad_tri <= size(tri_line)) where = where // ', line ' // itoa(tri_line(bad_tri))
      else if (bad_node > 0 .and. present(node_line)) then
        if (bad_node <= size(node_line)) where = where // ', line ' // itoa(node_line(bad_node))
      end if
      st%msg = where // ': ' // st%msg
    end if
  end subroutine mesh_finish_topology

  !> Replace the 'mesh: ' prefix of an error message by the file and the line of triangle
  !> bad_tri (when known).
  subroutine name_file_line(path, st, bad_tri, tri_line)
    character(len=*), intent(in) :: path
    type(status_t), intent(inout) :: st
    integer, intent(in) :: bad_tri
    integer, intent(in) :: tri_line(:)
    character(len=:), allocatable :: where
    if (index(st%msg, 'mesh: ') == 1) st%msg = st%msg(len('mesh: ') + 1:)
    where = "mesh file '" // path // "'"
    if (bad_tri > 0 .and. bad_tri <= size(tri_line)) where = where // ', line ' // itoa(tri_line(bad_tri))
    st%msg = where // ': ' // st%msg
  end subroutine name_file_line

  !> Remove the nodes that no triangle uses (renumbering the rest in their order).
  !> new_index(i) is the new number of old node i, 0 when it was removed; ndropped counts
  !> the removed nodes.  Out of memory: DS_ERR_MEMORY in st (without st the program stops,
  !> see dualsig_alloc).
  subroutine mesh_drop_unused_nodes(mesh, new_index, ndropped, st)
    type(mesh_t), intent(inout) :: mesh
    integer, allocatable, intent(out) :: new_index(:)
    integer, intent(out) :: ndropped
    type(status_t), intent(inout) :: st
    logical, allocatable :: used(:)
    integer :: i, k, t, n, ist
    ndropped = 0
    allocate (used(mesh%nnode), new_index(mesh%nnode), stat=ist)
    if (alloc_failed(ist, st, 'the used nodes of the mesh', 2 * mesh%nnode, BYTES_INT)) return
    used = .false.
    new_index = 0
    do t = 1, mesh%ntri
      do k = 1, 3
        used(mesh%tri(k, t)) = .true.
      end do
    end do
    n = 0
    do i = 1, mesh%nnode
      if (.not. used(i)) cycle
      n = n + 1
      new_index(i) = n
      mesh%xy(:, n) = mesh%xy(:, i)
    end do
    ndropped = mesh%nnode - n
    if (ndropped == 0) return
    do t = 1, mesh%ntri
      do k = 1, 3
        mesh%tri(k, t) = new_index(mesh%tri(k, t))
      end do
    end do
    mesh%xy = mesh%xy(:, 1:n)
    mesh%nnode = n
  end subroutine mesh_drop_unused_nodes

  !> Set the boundary edges of `mesh` (nodes and triangles set, node indices valid) and their
  !> markers from the edges a file lists: cand(:, c) holds two node indices (0 = a node that
  !> was dropped), cand_marker(c) the marker (<= 0: none) and cand_line(c) the file line.
  !> The boundary sides are the triangle sides that belong to one triangle only.  A listed
  !> edge on a boundary side gives it its marker; one on an interior side is ignored and
  !> counted in ninterior; one that is no side of any triangle is an error, or, when
  !> stray_ok, ignored and counted in nstray.  Errors: two different markers for one
  !> boundary side, and boundary sides without a marker.  `what` names the listed edges in
  !> messages (e.g. 'line element', 'segment').  Sorting: O(T log T).
  subroutine mesh_mark_boundary(path, mesh, cand, cand_marker, cand_line, what, stray_ok, &
                                ninterior, nstray, st)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(inout) :: mesh
    integer, intent(in) :: cand(:,:), cand_marker(:), cand_line(:)
    character(len=*), intent(in) :: what
    logical, intent(in) :: stray_ok
    integer, intent(out) :: ninterior, nstray
    type(status_t), intent(inout) :: st
    integer(i8), allocatable :: kx(:), ky(:), ux(:), uy(:)
    integer, allocatable :: perm(:), mult(:), marker(:), mline(:), ident(:)
    integer :: nt, t, k, p, i, nu, c, q, nb, nunmarked, first, ist
    integer(i8) :: lo, hi

    ninterior = 0
    nstray = 0
    nt = mesh%ntri
    allocate (kx(3 * nt), ky(3 * nt), perm(3 * nt), ux(3 * nt), uy(3 * nt), mult(3 * nt), stat=ist)
    if (alloc_failed(ist, st, 'the sides of the triangles of ' // path, 30 * nt, BYTES_INT)) return
    do t = 1, nt
      do k = 1, 3
        i = 3 * (t - 1) + k
        kx(i) = min(mesh%tri(k, t), mesh%tri(mod(k, 3) + 1, t))
        ky(i) = max(mesh%tri(k, t), mesh%tri(mod(k, 3) + 1, t))
        perm(i) = i
      end do
    end do
    call merge_sort_pairs(kx, ky, perm, st)
    if (.not. is_ok(st)) return
    ! distinct sides (sorted) and the number of triangles sharing each
    nu = 0
    do p = 1, 3 * nt
      i = perm(p)
      if (nu > 0) then
        if (ux(nu) == kx(i) .and. uy(nu) == ky(i)) then
          mult(nu) = mult(nu) + 1
          cycle
        end if
      end if
      nu = nu + 1
      ux(nu) = kx(i)
      uy(nu) = ky(i)
      mult(nu) = 1
    end do
    allocate (ident(nu), marker(nu), mline(nu), stat=ist)
    if (alloc_failed(ist, st, 'the boundary sides of ' // path, 3 * nu, BYTES_INT)) return
    ident = [(p, p=1, nu)]
    marker = 0
    mline = 0

    do c = 1, size(cand, 2)
      lo = min(cand(1, c), cand(2, c))
      hi = max(cand(1, c), cand(2, c))
      q = nu + 1
      if (lo >= 1) q = lower_bound(ux(1:nu), uy(1:nu), ident, lo, hi)
      if (q <= nu) then
        if (ux(q) /= lo .or. uy(q) /= hi) q = nu + 1
      end if
      if (q > nu) then
        if (stray_ok) then
          nstray = nstray + 1
          cycle
        end if
        call set_error(st, DS_ERR_MESH, "mesh file '" // path // "', line " // itoa(cand_line(c)) // &
          ': the ' // what // ' is not a side of any triangle (expected an edge of the triangulation)')
        return
      end if
      if (mult(q) /= 1) then
        ninterior = ninterior + 1
        cycle
      end if
      if (cand_marker(c) <= 0) cycle
      if (marker(q) == 0) then
        marker(q) = cand_marker(c)
        mline(q) = cand_line(c)
      else if (marker(q) /= cand_marker(c)) then
        call set_error(st, DS_ERR_MESH, "mesh file '" // path // "', line " // itoa(cand_line(c)) // &
          ': the ' // what // ' gives marker ' // itoa(cand_marker(c)) // ' to the boundary side ' // &
          side_text(q) // ', which line ' // itoa(mline(q)) // ' marked ' // itoa(marker(q)) // &
          ' (expected one marker per boundary side)')
        return
      end if
    end do

    nb = count(mult(1:nu) == 1)
    nunmarked = count(mult(1:nu) == 1 .and. marker == 0)
    if (nunmarked > 0) then
      first = findloc(mult(1:nu) == 1 .and. marker == 0, .true., dim=1)
      call set_error(st, DS_ERR_MESH, "mesh file '" // path // "': " // itoa(nunmarked) // ' of the ' // &
        itoa(nb) // ' boundary sides have no marker, the first ' // side_text(first) // &
        ' (boundary edge without marker; expected every boundary side covered by a ' // what // &
        ' with a marker > 0)')
      return
    end if
    if (allocated(mesh%bedge_nodes)) deallocate (mesh%bedge_nodes)
    if (allocated(mesh%bedge_marker)) deallocate (mesh%bedge_marker)
    allocate (mesh%bedge_nodes(2, nb), mesh%bedge_marker(nb), stat=ist)
    if (alloc_failed(ist, st, 'the boundary edges of ' // path, 3 * nb, BYTES_INT)) return
    mesh%nbedge = nb
    k = 0
    do q = 1, nu
      if (mult(q) /= 1) cycle
      k = k + 1
      mesh%bedge_nodes(:, k) = [int(ux(q)), int(uy(q))]
      mesh%bedge_marker(k) = marker(q)
    end do

  contains

    !> 'from (x1, y1) to (x2, y2)' for distinct side q.
    function side_text(q) result(s)
      integer, intent(in) :: q
      character(len=:), allocatable :: s
      s = 'from (' // rtoa(mesh%xy(1, ux(q))) // ', ' // rtoa(mesh%xy(2, ux(q))) // ') to (' // &
        rtoa(mesh%xy(1, uy(q))) // ', ' // rtoa(mesh%xy(2, uy(q))) // ')'
    end function side_text
  end subroutine mesh_mark_boundary
end module dualsig_mesh_io
