!> ParaView output: one VTK XML unstructured grid (`.vtu`) per mesh level and a `.pvd`
!> collection over the levels.
!>
!> Two encodings of the arrays (vtk_write_level argument `format`):
!>   'binary' (the default)  format="binary" DataArrays, zlib-compressed: on <VTKFile>
!>            header_type="UInt64" compressor="vtkZLibDataCompressor" and the machine's
!>            byte_order; each array is the raw values (Float64, Int32, Int64, UInt8) cut
!>            into blocks of vtu_block_bytes, each block compressed by zlib's compress2
!>            (level vtu_zlib_level), written as base64(header) // base64(blocks) on one
!>            line, header = [nblocks, block size, size of the last block, compressed size
!>            of each block] as UInt64 (the layout of VTK's vtkXMLWriter, read by ParaView,
!>            VTK and meshio).  2.9 to 3.5 times smaller than ascii and about 5 times
!>            faster to write (measured: doc/user-guide.md, make bench-vtu).
!>   'ascii'  the values as text, reals with 17 significant digits (exact round trip).
!> Both hold the same values bit for bit.  Every zlib return code is checked: a failure is
!> an error naming the file and the array, and the temporary file is removed.
!>
!> File names: level L of the run with output path `out/name` is `out/name_levelLL.vtu`
!> (two digits, zero-padded), the collection is `out/name.pvd`; it lists the level files by
!> their base names (relative to its own directory) with timestep = level.
!>
!> A level file holds (arrays absent when the run did not compute them):
!>   FieldData  level (Int32), h (longest side), est (the bound E of the level), TimeValue (= level)
!>   PointData  u_h; u_exact and error = u_h - u (nodal values) when the scene has an exact
!>              solution; contact_status (Int32, codes below); q_h (P1 dual field of the
!>              space 'paper', continuous, 3 components with z = 0)
!>   CellData   est_element (element contributions of est, boundary-edge terms added to the
!>              triangle that owns the edge: their sum is est); lambda_h (P2 equilibrium field,
!>              or the P1 RT1 field of the space 'hdiv', at the centroid, 3 components with
!>              z = 0); depth (Int32, adaptive runs: bisections of the triangle from its
!>              coarse ancestor); lambda_h_vertices (6 components:
!>              the x and y components of lambda_h at the triangle's vertices 1, 2, 3, taken
!>              from inside the triangle: the field is discontinuous between triangles)
!>   Points     x, y, 0;  Cells  VTK_TRIANGLE (type 5), 0-based vertex numbers, counter-clockwise
!>
!> contact_status codes (also stated in a comment at the top of every file):
!>   -1 interior node, 0 separated (Signorini node, u_h above its obstacle),
!>    1 contact (Signorini node, u_h on its obstacle), 2 Dirichlet (node of the closure of Gamma_u).
!>
!> Every file is written to temp_name(path) and committed by vtk_commit_run when the whole
!> run succeeded; vtk_discard_run removes the temporary files of a failed run.
module dualsig_io_vtk
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_ptr, c_loc, c_f_pointer, c_associated, c_char, &
                                         c_int8_t, c_null_char
  use dualsig_kinds, only: dp, i8
  use dualsig_status, only: status_t, set_error, set_alloc_error, DS_ERR_IO, DS_ERR_INPUT
  use dualsig_mesh, only: mesh_t
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER, BOUND_FIXED
  use dualsig_io_files, only: temp_name, file_delete, file_exists, file_commit_all, text_file_t, text_open, text_put, text_close, &
                              text_abandon
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: vtk_fields_t, vtk_write_level, vtk_write_collection, vtk_commit_run, vtk_discard_run, vtk_run_files
  public :: vtk_remove_stale
  public :: vtk_level_path, vtk_collection_path, vtk_contact_status, mesh_edges_write, mesh_edges_path
  public :: CONTACT_INTERIOR, CONTACT_SEPARATED, CONTACT_ACTIVE, CONTACT_DIRICHLET
  public :: VTU_BINARY, VTU_ASCII, vtu_format_valid, vtu_binary_text, vtu_block_bytes, vtu_zlib_level

  integer, parameter :: CONTACT_INTERIOR = -1   !! node not on the boundary
  integer, parameter :: CONTACT_SEPARATED = 0   !! Signorini node with u_h above the obstacle
  integer, parameter :: CONTACT_ACTIVE = 1      !! Signorini node with u_h on the obstacle
  integer, parameter :: CONTACT_DIRICHLET = 2   !! node on the closure of Gamma_u (u = 0)

  integer, parameter :: vtk_triangle = 5        !! VTK cell type VTK_TRIANGLE
  !> The most level files of a run: the two digits of <output>_levelLL.vtu.
  integer, parameter :: vtk_max_levels = 99
  !> Characters of a node's line in the gnuplot mesh file: x and y as es24.15e3.
  integer, parameter :: node_line_len = 48

  character(len=*), parameter :: VTU_BINARY = 'binary'   !! zlib-compressed base64 arrays (default)
  character(len=*), parameter :: VTU_ASCII = 'ascii'     !! arrays as text
  !> uncompressed bytes per zlib block (VTK's default block size: a reader inflates one
  !> block at a time)
  integer, parameter :: vtu_block_bytes = 32768
  !> zlib compression level (1 fastest .. 9 smallest): the computed fields are nearly
  !> incompressible doubles, so higher levels gain about 1 % for twice the time (measured:
  !> doc/user-guide.md)
  integer, parameter :: vtu_zlib_level = 1
  integer(c_int), parameter :: z_ok = 0         !! zlib: success
  character(len=*), parameter :: b64_alphabet = &
    'ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/'

  !> The file being written and how its arrays are encoded.
  type :: vtu_out_t
    type(text_file_t) :: tf
    logical :: binary = .true.                   !! format="binary" (zlib) or "ascii"
    integer :: zlib_level = vtu_zlib_level       !! zlib's compression level
    type(status_t) :: st                         !! the first encoding failure (nothing written after it)
  end type vtu_out_t

  interface
    !> zlib: compress source(1:sourcelen) into dest, *destlen = capacity on entry, size on exit.
    integer(c_int) function z_compress2(dest, destlen, source, sourcelen, level) bind(c, name='compress2')
      import :: c_int, c_long, c_ptr
      type(c_ptr), value :: dest
      integer(c_long), intent(inout) :: destlen
      type(c_ptr), value :: source
      integer(c_long), value :: sourcelen
      integer(c_int), value :: level
    end function z_compress2
    !> zlib: the largest compressed size of n bytes.
    integer(c_long) function z_compress_bound(n) bind(c, name='compressBound')
      import :: c_long
      integer(c_long), value :: n
    end function z_compress_bound
    !> zlib: the text of a return code (a static string).
    type(c_ptr) function z_error(code) bind(c, name='zError')
      import :: c_ptr, c_int
      integer(c_int), value :: code
    end function z_error
  end interface

  !> The fields of one level besides the mesh and u_h; unallocated arrays are not written.
  type :: vtk_fields_t
    real(dp), allocatable :: u_exact(:)            !! (nnode) exact solution at the nodes
    integer, allocatable :: contact(:)             !! (nnode) contact_status codes
    real(dp), allocatable :: q_h(:,:)              !! (2, nnode) P1 dual field
    real(dp), allocatable :: lambda_centroid(:,:)  !! (2, ntri) P2 dual field at the centroids
    real(dp), allocatable :: lambda_vertices(:,:)  !! (6, ntri) P2 dual field at the vertices
    real(dp), allocatable :: est_element(:)        !! (ntri) contributions of est
    logical :: has_est = .false.                   !! est below is set
    real(dp) :: est = 0.0_dp                       !! the bound E of the level
    integer, allocatable :: depth(:)               !! (ntri) adaptive: refinement depth (bisections)
  end type vtk_fields_t

contains

  !> The file of level `level` of the run with output path `output` (no extension).
  pure function vtk_level_path(output, level) result(path)
    character(len=*), intent(in) :: output
    integer, intent(in) :: level
    character(len=:), allocatable :: path
    character(len=16) :: buf
    write (buf, '(i2.2)') level
    path = trim(output) // '_level' // trim(buf) // '.vtu'
  end function vtk_level_path

  !> The .pvd collection of the run with output path `output`.
  pure function vtk_collection_path(output) result(path)
    character(len=*), intent(in) :: output
    character(len=:), allocatable :: path
    path = trim(output) // '.pvd'
  end function vtk_collection_path

  !> contact_status code of every node from the bounds of the primal problem (kind, bnd as
  !> for psor_solve): a BOUND_LOWER node is in contact when u_h - bnd <= rel_tol * max|u_h|
  !> (the solvers put contact nodes exactly on the obstacle; rel_tol only absorbs rounding).
  pure function vtk_contact_status(kind, bnd, u, rel_tol) result(code)
    integer, intent(in) :: kind(:)
    real(dp), intent(in) :: bnd(:), u(:)
    real(dp), intent(in) :: rel_tol
    integer :: code(size(kind))
    real(dp) :: gap_tol
    integer :: i
    gap_tol = 0.0_dp
    if (size(u) > 0) gap_tol = rel_tol * maxval(abs(u))
    do i = 1, size(kind)
      select case (kind(i))
      case (BOUND_FIXED)
        code(i) = CONTACT_DIRICHLET
      case (BOUND_LOWER)
        code(i) = merge(CONTACT_ACTIVE, CONTACT_SEPARATED, u(i) - bnd(i) <= gap_tol)
      case default
        code(i) = CONTACT_INTERIOR
      end select
    end do
  end function vtk_contact_status

  !> Write level `level` (mesh size h, nodal primal solution u) with the fields `fld` to
  !> temp_name(path), its arrays encoded as `format` (VTU_BINARY, the default, or
  !> VTU_ASCII; binary with zlib level `zlib_level`, default vtu_zlib_level).  Array sizes
  !> are checked against the mesh.  On failure (a write, zlib, or memory) nothing is left:
  !> the temporary file is removed.  The caller commits.
  subroutine vtk_write_level(path, mesh, level, h, u, fld, st, format, zlib_level)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: level
    real(dp), intent(in) :: h
    real(dp), intent(in), contiguous :: u(:)
    type(vtk_fields_t), intent(in) :: fld
    type(status_t), intent(out) :: st
    character(len=*), intent(in), optional :: format   !! VTU_BINARY (default) or VTU_ASCII
    integer, intent(in), optional :: zlib_level        !! 1 (fastest) .. 9 (smallest)
    type(vtu_out_t) :: out
    logical :: bad
    out%binary = .true.
    if (present(zlib_level)) out%zlib_level = zlib_level
    if (present(format)) then
      if (.not. vtu_format_valid(format)) then
        call set_error(st, DS_ERR_INPUT, trim(path) // ': unknown .vtu format "' // trim(format) // &
          '"; expected ' // VTU_BINARY // ' or ' // VTU_ASCII)
        return
      end if
      out%binary = trim(format) == VTU_BINARY
    end if
    bad = size(u) /= mesh%nnode
    if (allocated(fld%u_exact)) bad = bad .or. size(fld%u_exact) /= mesh%nnode
    if (allocated(fld%contact)) bad = bad .or. size(fld%contact) /= mesh%nnode
    if (allocated(fld%q_h)) bad = bad .or. size(fld%q_h, 1) /= 2 .or. size(fld%q_h, 2) /= mesh%nnode
    if (allocated(fld%lambda_centroid)) bad = bad .or. size(fld%lambda_centroid, 1) /= 2 .or. &
                                              size(fld%lambda_centroid, 2) /= mesh%ntri
    if (allocated(fld%lambda_vertices)) bad = bad .or. size(fld%lambda_vertices, 1) /= 6 .or. &
                                              size(fld%lambda_vertices, 2) /= mesh%ntri
    if (allocated(fld%est_element)) bad = bad .or. size(fld%est_element) /= mesh%ntri
    if (allocated(fld%depth)) bad = bad .or. size(fld%depth) /= mesh%ntri
    if (bad) then
      call set_error(st, DS_ERR_INPUT, trim(path) // ': a field does not match the mesh (' // &
        itoa(mesh%nnode) // ' nodes, ' // itoa(mesh%ntri) // ' triangles)')
      return
    end if
    call text_open(out%tf, path, st)
    if (st%code /= 0) return
    call text_put(out%tf, '<?xml version="1.0"?>')
    call text_put(out%tf, '<!-- dualsig level ' // itoa(level) // '. contact_status: -1 interior node, ' // &
      '0 separated (Signorini node, u_h > obstacle), 1 contact (Signorini node, u_h = obstacle), ' // &
      '2 Dirichlet (Gamma_u). error = u_h - u_exact at the nodes. est_element sums to est. -->')
    if (out%binary) then
      call text_put(out%tf, '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="' // native_byte_order() // &
        '" header_type="UInt64" compressor="vtkZLibDataCompressor">')
    else
      call text_put(out%tf, '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">')
    end if
    call text_put(out%tf, '  <UnstructuredGrid>')
    call text_put(out%tf, '    <FieldData>')
    call int_array(out, 'level', 1, [level], 'NumberOfTuples="1" ')
    call real_array(out, 'TimeValue', 1, [real(level, dp)], 'NumberOfTuples="1" ')
    call real_array(out, 'h', 1, [h], 'NumberOfTuples="1" ')
    if (fld%has_est) call real_array(out, 'est', 1, [fld%est], 'NumberOfTuples="1" ')
    call text_put(out%tf, '    </FieldData>')
    call text_put(out%tf, '    <Piece NumberOfPoints="' // itoa(mesh%nnode) // '" NumberOfCells="' // &
      itoa(mesh%ntri) // '">')
    call text_put(out%tf, '      <PointData Scalars="u_h">')
    call real_array(out, 'u_h', 1, u)
    if (allocated(fld%u_exact)) then
      call real_array(out, 'u_exact', 1, fld%u_exact)
      call real_array(out, 'error', 1, u - fld%u_exact)
    end if
    if (allocated(fld%contact)) call int_array(out, 'contact_status', 1, fld%contact)
    if (allocated(fld%q_h)) call real_array(out, 'q_h', 3, pad_z(fld%q_h))
    call text_put(out%tf, '      </PointData>')
    if (allocated(fld%est_element)) then
      call text_put(out%tf, '      <CellData Scalars="est_element">')
    else
      call text_put(out%tf, '      <CellData>')
    end if
    if (allocated(fld%est_element)) call real_array(out, 'est_element', 1, fld%est_element)
    if (allocated(fld%depth)) call int_array(out, 'depth', 1, fld%depth)
    if (allocated(fld%lambda_centroid)) call real_array(out, 'lambda_h', 3, pad_z(fld%lambda_centroid))
    if (allocated(fld%lambda_vertices)) call real_array(out, 'lambda_h_vertices', 6, &
                                                        reshape(fld%lambda_vertices, [6 * mesh%ntri]))
    call text_put(out%tf, '      </CellData>')
    call text_put(out%tf, '      <Points>')
    call real_array(out, 'Points', 3, pad_z(mesh%xy))
    call text_put(out%tf, '      </Points>')
    call text_put(out%tf, '      <Cells>')
    call cell_arrays(out, mesh)
    call text_put(out%tf, '      </Cells>')
    call text_put(out%tf, '    </Piece>')
    call text_put(out%tf, '  </UnstructuredGrid>')
    call text_put(out%tf, '</VTKFile>')
    if (out%st%code /= 0) then
      call text_abandon(out%tf)
      st = out%st
      st%msg = 'cannot write ' // trim(path) // ': ' // st%msg // ' (nothing written: the temporary file ' // &
        temp_name(path) // ' was removed)'
      return
    end if
    call text_close(out%tf, st)
  end subroutine vtk_write_level

  !> True when `format` names a .vtu encoding: VTU_BINARY or VTU_ASCII.
  pure logical function vtu_format_valid(format)
    character(len=*), intent(in) :: format
    vtu_format_valid = trim(format) == VTU_BINARY .or. trim(format) == VTU_ASCII
  end function vtu_format_valid

  !> Write the collection of levels 1..nlevel of the run `output` to
  !> temp_name(vtk_collection_path(output)); the caller commits.
  subroutine vtk_write_collection(output, nlevel, st)
    character(len=*), intent(in) :: output
    integer, intent(in) :: nlevel
    type(status_t), intent(out) :: st
    type(text_file_t) :: tf
    integer :: level
    call text_open(tf, vtk_collection_path(output), st)
    if (st%code /= 0) return
    call text_put(tf, '<?xml version="1.0"?>')
    call text_put(tf, '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">')
    call text_put(tf, '  <Collection>')
    do level = 1, nlevel
      call text_put(tf, '    <DataSet timestep="' // itoa(level) // '" group="" part="0" file="' // &
        xml_escape(base_name(vtk_level_path(output, level))) // '"/>')
    end do
    call text_put(tf, '  </Collection>')
    call text_put(tf, '</VTKFile>')
    call text_close(tf, st)
  end subroutine vtk_write_collection

  !> text with the XML special characters & < > " ' written as entities (a file name in an
  !> attribute of the .pvd file may hold them).
  pure function xml_escape(text) result(s)
    character(len=*), intent(in) :: text
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, len(text)
      select case (text(k:k))
      case ('&')
        s = s // '&amp;'
      case ('<')
        s = s // '&lt;'
      case ('>')
        s = s // '&gt;'
      case ('"')
        s = s // '&quot;'
      case ('''')
        s = s // '&apos;'
      case default
        s = s // text(k:k)
      end select
    end do
  end function xml_escape

  !> The files of a run with levels 1..nlevel: the level files, then the collection.
  function vtk_run_files(output, nlevel) result(paths)
    character(len=*), intent(in) :: output
    integer, intent(in) :: nlevel
    character(len=len_trim(output) + 16), allocatable :: paths(:)
    integer :: level
    allocate (paths(nlevel + 1))  ! small: one path per level
    do level = 1, nlevel
      paths(level) = vtk_level_path(output, level)
    end do
    paths(nlevel + 1) = vtk_collection_path(output)
  end function vtk_run_files

  !> Commit the level files 1..nlevel and the collection of the run `output` (all written
  !> under their temporary names) as one set (file_commit_all).  On failure no file is
  !> replaced and the temporary files are removed.
  subroutine vtk_commit_run(output, nlevel, st)
    character(len=*), intent(in) :: output
    integer, intent(in) :: nlevel
    type(status_t), intent(out) :: st
    call file_commit_all(vtk_run_files(output, nlevel), st)
  end subroutine vtk_commit_run

  !> Remove the temporary files of levels 1..nlevel and of the collection of the run
  !> `output` (committed files are not touched).
  subroutine vtk_discard_run(output, nlevel)
    character(len=*), intent(in) :: output
    integer, intent(in) :: nlevel
    integer :: level
    do level = 1, nlevel
      call file_delete(temp_name(vtk_level_path(output, level)))
    end do
    call file_delete(temp_name(vtk_collection_path(output)))
  end subroutine vtk_discard_run

  !> Remove the level files <output>_levelLL.vtu, LL = nlevel + 1 to 99 (the most levels or
  !> adaptive steps of a run), left by an earlier run into the same output with more levels:
  !> a ParaView user opening the group of level files would see them beside the new ones.
  !> nremoved: how many there were.
  subroutine vtk_remove_stale(output, nlevel, nremoved)
    character(len=*), intent(in) :: output
    integer, intent(in) :: nlevel
    integer, intent(out) :: nremoved
    integer :: level
    nremoved = 0
    do level = nlevel + 1, vtk_max_levels
      if (.not. file_exists(vtk_level_path(output, level))) cycle
      call file_delete(vtk_level_path(output, level))
      nremoved = nremoved + 1
    end do
  end subroutine vtk_remove_stale

  !> The gnuplot file of a run's final mesh: `<output>_mesh.dat`.
  pure function mesh_edges_path(output) result(path)
    character(len=*), intent(in) :: output
    character(len=:), allocatable :: path
    path = trim(output) // '_mesh.dat'
  end function mesh_edges_path

  !> The edges of `mesh` as gnuplot segments (x y / x y / blank line) to temp_name(path);
  !> the caller commits.  `plot 'file' with lines` draws the mesh.  Each node's line is
  !> formatted once (a node ends about 6 edges) when its text fits in memory.
  subroutine mesh_edges_write(path, mesh, st)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(in) :: mesh
    type(status_t), intent(out) :: st
    type(text_file_t) :: tf
    character(len=node_line_len), allocatable :: line(:)
    integer, allocatable :: nlen(:)
    integer :: e, k, i, ist
    call text_open(tf, path, st)
    if (st%code /= 0) return
    call text_put(tf, '# dualsig mesh: ' // itoa(mesh%nnode) // ' nodes, ' // itoa(mesh%ntri) // &
      ' triangles, ' // itoa(mesh%nedge) // ' edges as segments')
    allocate (line(mesh%nnode), nlen(mesh%nnode), stat=ist)
    if (ist == 0) then                            ! else no room for the lines: format as we go
      do i = 1, mesh%nnode
        line(i) = node_line(mesh%xy(:, i))
        nlen(i) = len_trim(line(i))
      end do
    end if
    do e = 1, mesh%nedge
      do k = 1, 2
        i = mesh%edge_nodes(k, e)
        if (ist == 0) then
          call text_put(tf, line(i)(1:nlen(i)))
        else
          call text_put(tf, trim(node_line(mesh%xy(:, i))))
        end if
      end do
      call text_put(tf, '')
    end do
    call text_close(tf, st)
  end subroutine mesh_edges_write

  !> One node's line of mesh_edges_write: x and y to 16 significant digits.
  function node_line(xy) result(buf)
    real(dp), intent(in) :: xy(2)
    character(len=node_line_len) :: buf
    write (buf, '(2es24.15e3)') xy
  end function node_line

  ! ------------------------------------------------------------------ private
  !> The opening tag of a DataArray of VTK type `vtype`; `extra` holds further attributes.
  subroutine open_array(out, vtype, name, ncomp, extra)
    type(vtu_out_t), intent(inout) :: out
    character(len=*), intent(in) :: vtype, name
    integer, intent(in) :: ncomp
    character(len=*), intent(in), optional :: extra   !! further attributes, e.g. NumberOfTuples
    character(len=:), allocatable :: attrs
    attrs = ''
    if (present(extra)) attrs = extra
    if (ncomp > 1) attrs = attrs // 'NumberOfComponents="' // itoa(ncomp) // '" '
    call text_put(out%tf, '        <DataArray type="' // vtype // '" Name="' // name // '" ' // attrs // &
      'format="' // trim(merge(VTU_BINARY, VTU_ASCII // ' ', out%binary)) // '">')
  end subroutine open_array

  !> One Float64 DataArray of `ncomp` components (values in tuple order); ASCII: four per line.
  subroutine real_array(out, name, ncomp, v, extra)
    type(vtu_out_t), intent(inout) :: out
    integer, intent(in) :: ncomp
    character(len=*), intent(in) :: name
    real(dp), intent(in), target, contiguous :: v(:)
    character(len=*), intent(in), optional :: extra   !! further attributes, e.g. NumberOfTuples
    integer :: k, k1
    character(len=4 * 25) :: buf
    if (out%st%code /= 0) return
    call open_array(out, 'Float64', name, ncomp, extra)
    if (out%binary) then
      call put_binary(out, name, c_loc(v), int(storage_size(v) / 8, i8) * size(v, kind=i8))
    else
      do k = 1, size(v), 4
        k1 = min(size(v), k + 3)
        write (buf, '(4es25.16e3)') v(k:k1)
        call text_put(out%tf, trim(buf))
      end do
    end if
    call text_put(out%tf, '        </DataArray>')
  end subroutine real_array

  !> One Int32 DataArray.
  subroutine int_array(out, name, ncomp, v, extra)
    type(vtu_out_t), intent(inout) :: out
    integer, intent(in) :: ncomp
    character(len=*), intent(in) :: name
    integer, intent(in), target, contiguous :: v(:)
    character(len=*), intent(in), optional :: extra
    if (out%st%code /= 0) return
    call open_array(out, 'Int32', name, ncomp, extra)
    if (out%binary) then
      call put_binary(out, name, c_loc(v), int(storage_size(v) / 8, i8) * size(v, kind=i8))
    else
      call put_ints(out%tf, v, 20)
    end if
    call text_put(out%tf, '        </DataArray>')
  end subroutine int_array

  !> The Cells arrays of `mesh`: connectivity (Int64, 0-based), offsets (Int64) and types
  !> (UInt8, VTK_TRIANGLE).
  subroutine cell_arrays(out, mesh)
    type(vtu_out_t), intent(inout) :: out
    type(mesh_t), intent(in) :: mesh
    integer(i8), allocatable, target :: conn(:), offs(:)
    integer(c_int8_t), allocatable, target :: types(:)
    integer :: t, ierr
    if (out%st%code /= 0) return
    if (.not. out%binary) then
      call text_put(out%tf, '        <DataArray type="Int64" Name="connectivity" format="ascii">')
      do t = 1, mesh%ntri
        call put_ints(out%tf, mesh%tri(:, t) - 1, 3)
      end do
      call text_put(out%tf, '        </DataArray>')
      call text_put(out%tf, '        <DataArray type="Int64" Name="offsets" format="ascii">')
      call put_ints(out%tf, [(3 * t, t=1, mesh%ntri)], 8)
      call text_put(out%tf, '        </DataArray>')
      call text_put(out%tf, '        <DataArray type="UInt8" Name="types" format="ascii">')
      call put_ints(out%tf, [(vtk_triangle, t=1, mesh%ntri)], 20)
      call text_put(out%tf, '        </DataArray>')
      return
    end if
    allocate (conn(3 * mesh%ntri), offs(mesh%ntri), types(mesh%ntri), stat=ierr)
    if (ierr /= 0) then
      call set_alloc_error(out%st, 17_i8 * mesh%ntri + 8_i8 * mesh%ntri, 'the cell arrays')
      return
    end if
    conn = int(reshape(mesh%tri(1:3, 1:mesh%ntri), [3 * mesh%ntri]) - 1, i8)
    offs = [(3_i8 * t, t=1, mesh%ntri)]
    types = int(vtk_triangle, c_int8_t)
    call open_array(out, 'Int64', 'connectivity', 1)
    call put_binary(out, 'connectivity', c_loc(conn), 8_i8 * size(conn, kind=i8))
    call text_put(out%tf, '        </DataArray>')
    call open_array(out, 'Int64', 'offsets', 1)
    call put_binary(out, 'offsets', c_loc(offs), 8_i8 * size(offs, kind=i8))
    call text_put(out%tf, '        </DataArray>')
    call open_array(out, 'UInt8', 'types', 1)
    call put_binary(out, 'types', c_loc(types), size(types, kind=i8))
    call text_put(out%tf, '        </DataArray>')
  end subroutine cell_arrays

  !> The content line of a binary DataArray: nbytes raw bytes at src, encoded by
  !> vtu_binary_text.  A failure is kept in out%st (naming the array) and stops the output.
  subroutine put_binary(out, name, src, nbytes)
    type(vtu_out_t), intent(inout) :: out
    character(len=*), intent(in) :: name
    type(c_ptr), intent(in) :: src
    integer(i8), intent(in) :: nbytes
    character(len=:), allocatable :: text
    if (out%st%code /= 0) return
    call encode_binary(src, nbytes, out%zlib_level, text, out%st)
    if (out%st%code /= 0) then
      out%st%msg = 'array ' // name // ': ' // out%st%msg
      return
    end if
    call text_put(out%tf, text)
  end subroutine put_binary

  !> The bytes `bytes` as the content of a format="binary" DataArray of a file with
  !> header_type="UInt64" compressor="vtkZLibDataCompressor": base64 of the header
  !> [nblocks, vtu_block_bytes, size of the last block, compressed size of each block]
  !> (UInt64, native byte order) followed by base64 of the zlib-compressed blocks (each of
  !> vtu_block_bytes uncompressed bytes, the last one shorter), indented by 10 blanks.
  !> `level` (default vtu_zlib_level) is zlib's compression level; a zlib failure is an
  !> error DS_ERR_IO with zlib's code and text, an allocation failure DS_ERR_MEMORY.
  subroutine vtu_binary_text(bytes, text, st, level)
    integer(c_int8_t), intent(in), target, contiguous :: bytes(:)
    character(len=:), allocatable, intent(out) :: text
    type(status_t), intent(out) :: st
    integer, intent(in), optional :: level
    integer(c_int8_t), target :: none(1)
    integer :: zlevel
    zlevel = vtu_zlib_level
    if (present(level)) zlevel = level
    if (size(bytes) > 0) then
      call encode_binary(c_loc(bytes), size(bytes, kind=i8), zlevel, text, st)
    else
      call encode_binary(c_loc(none), 0_i8, zlevel, text, st)
    end if
  end subroutine vtu_binary_text

  !> vtu_binary_text of the nbytes bytes at src, zlib level `level`.
  subroutine encode_binary(src, nbytes, level, text, st)
    type(c_ptr), intent(in) :: src
    integer(i8), intent(in) :: nbytes
    integer, intent(in) :: level
    character(len=:), allocatable, intent(out) :: text
    type(status_t), intent(out) :: st
    integer, parameter :: indent = 10
    integer(i8) :: nblocks, k, off, pos, blen, bound, total
    integer(i8), allocatable, target :: header(:)
    integer(c_int8_t), allocatable, target :: cbuf(:)
    integer(c_int8_t), pointer :: hbytes(:), bytes(:)
    integer(c_long) :: dlen
    integer(c_int) :: rc
    integer :: ierr
    call c_f_pointer(src, bytes, [max(1_i8, nbytes)])
    nblocks = (nbytes + vtu_block_bytes - 1) / vtu_block_bytes
    bound = int(z_compress_bound(int(vtu_block_bytes, c_long)), i8)
    allocate (header(3 + nblocks), cbuf(max(1_i8, nblocks * bound)), stat=ierr)
    if (ierr /= 0) then
      call set_alloc_error(st, 8 * (3 + nblocks) + nblocks * bound, 'a compressed array')
      return
    end if
    header(1) = nblocks
    header(2) = vtu_block_bytes
    header(3) = 0
    if (nblocks > 0) header(3) = nbytes - (nblocks - 1) * vtu_block_bytes
    pos = 0
    do k = 1, nblocks
      off = (k - 1) * vtu_block_bytes
      blen = min(int(vtu_block_bytes, i8), nbytes - off)
      dlen = int(bound, c_long)
      rc = z_compress2(c_loc(cbuf(pos + 1)), dlen, c_loc(bytes(off + 1)), int(blen, c_long), int(level, c_int))
      if (rc /= z_ok) then
        call set_error(st, DS_ERR_IO, 'zlib compress2 failed on block ' // itoa(int(k)) // ' of ' // &
          itoa(int(nblocks)) // ': ' // zlib_message(rc) // ' (zlib code ' // itoa(int(rc)) // ')')
        return
      end if
      header(3 + k) = int(dlen, i8)
      pos = pos + int(dlen, i8)
    end do
    call c_f_pointer(c_loc(header), hbytes, [8 * size(header, kind=i8)])
    total = indent + b64_length(size(hbytes, kind=i8)) + b64_length(pos)
    allocate (character(len=total) :: text, stat=ierr)
    if (ierr /= 0) then
      call set_alloc_error(st, total, 'the base64 text of a compressed array')
      return
    end if
    text(1:indent) = ''
    call b64_encode(hbytes, text(indent + 1:indent + b64_length(size(hbytes, kind=i8))))
    call b64_encode(cbuf(1:pos), text(total - b64_length(pos) + 1:))
  end subroutine encode_binary

  !> Characters of the base64 encoding of n bytes (padded with '=').
  pure integer(i8) function b64_length(n)
    integer(i8), intent(in) :: n
    b64_length = 4 * ((n + 2) / 3)
  end function b64_length

  !> The base64 encoding (RFC 4648, padded) of `bytes` into `text` (b64_length characters).
  pure subroutine b64_encode(bytes, text)
    integer(c_int8_t), intent(in) :: bytes(:)
    character(len=*), intent(out) :: text
    integer(i8) :: n, k, j
    integer :: b1, b2, b3
    n = size(bytes, kind=i8)
    j = 0
    do k = 1, n, 3
      b1 = iand(int(bytes(k)), 255)
      b2 = 0
      b3 = 0
      if (k + 1 <= n) b2 = iand(int(bytes(k + 1)), 255)
      if (k + 2 <= n) b3 = iand(int(bytes(k + 2)), 255)
      text(j + 1:j + 1) = b64_alphabet(ishft(b1, -2) + 1:ishft(b1, -2) + 1)
      text(j + 2:j + 2) = b64_alphabet(ior(ishft(iand(b1, 3), 4), ishft(b2, -4)) + 1: &
                                       ior(ishft(iand(b1, 3), 4), ishft(b2, -4)) + 1)
      if (k + 1 <= n) then
        text(j + 3:j + 3) = b64_alphabet(ior(ishft(iand(b2, 15), 2), ishft(b3, -6)) + 1: &
                                         ior(ishft(iand(b2, 15), 2), ishft(b3, -6)) + 1)
      else
        text(j + 3:j + 3) = '='
      end if
      if (k + 2 <= n) then
        text(j + 4:j + 4) = b64_alphabet(iand(b3, 63) + 1:iand(b3, 63) + 1)
      else
        text(j + 4:j + 4) = '='
      end if
      j = j + 4
    end do
  end subroutine b64_encode

  !> zlib's text of the return code rc (zError).
  function zlib_message(rc) result(text)
    integer(c_int), intent(in) :: rc
    character(len=:), allocatable :: text
    character(kind=c_char), pointer :: chars(:)
    type(c_ptr) :: p
    integer :: n
    text = 'unknown error'
    p = z_error(rc)
    if (.not. c_associated(p)) return
    call c_f_pointer(p, chars, [200])
    n = 0
    do while (n < 200)
      if (chars(n + 1) == c_null_char) exit
      n = n + 1
    end do
    if (n == 0) return
    text = transfer(chars(1:n), repeat(' ', n))
  end function zlib_message

  !> 'LittleEndian' or 'BigEndian': the byte order of this machine's integers and reals.
  function native_byte_order() result(order)
    character(len=:), allocatable :: order
    integer(c_int8_t) :: b(4)
    b = transfer(1_c_int, b)
    order = merge('LittleEndian', 'BigEndian   ', b(1) == 1)
    order = trim(order)
  end function native_byte_order

  !> The integers v, `per_line` to a line, each preceded by a blank.
  subroutine put_ints(tf, v, per_line)
    type(text_file_t), intent(inout) :: tf
    integer, intent(in) :: v(:)
    integer, intent(in) :: per_line
    character(len=:), allocatable :: line
    integer :: k, j
    do k = 1, size(v), per_line
      line = ''
      do j = k, min(size(v), k + per_line - 1)
        line = line // ' ' // itoa(v(j))
      end do
      call text_put(tf, line)
    end do
  end subroutine put_ints

  !> (2, n) planar vectors as the flat (3 n) tuple sequence x, y, 0.
  pure function pad_z(v) result(w)
    real(dp), intent(in) :: v(:,:)
    real(dp) :: w(3 * size(v, 2))
    integer :: k
    do k = 1, size(v, 2)
      w(3 * k - 2:3 * k - 1) = v(1:2, k)
      w(3 * k) = 0.0_dp
    end do
  end function pad_z

  !> The part of `path` after its last '/'.
  pure function base_name(path) result(name)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: name
    name = path(index(path, '/', back=.true.) + 1:)
  end function base_name

end module dualsig_io_vtk
