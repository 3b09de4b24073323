!> ParaView output: one VTK XML unstructured grid (`.vtu`, ASCII) per mesh level and a
!> `.pvd` collection over the levels.
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
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t, set_error, DS_ERR_IO, DS_ERR_INPUT
  use dualsig_mesh, only: mesh_t
  use dualsig_qp_types, only: BOUND_FREE, BOUND_LOWER, BOUND_FIXED
  use dualsig_io_files, only: temp_name, file_delete, file_commit_all, text_file_t, text_open, text_put, text_close
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: vtk_fields_t, vtk_write_level, vtk_write_collection, vtk_commit_run, vtk_discard_run, vtk_run_files
  public :: vtk_level_path, vtk_collection_path, vtk_contact_status, mesh_edges_write, mesh_edges_path
  public :: CONTACT_INTERIOR, CONTACT_SEPARATED, CONTACT_ACTIVE, CONTACT_DIRICHLET

  integer, parameter :: CONTACT_INTERIOR = -1   !! node not on the boundary
  integer, parameter :: CONTACT_SEPARATED = 0   !! Signorini node with u_h above the obstacle
  integer, parameter :: CONTACT_ACTIVE = 1      !! Signorini node with u_h on the obstacle
  integer, parameter :: CONTACT_DIRICHLET = 2   !! node on the closure of Gamma_u (u = 0)

  integer, parameter :: vtk_triangle = 5        !! VTK cell type VTK_TRIANGLE

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
  !> temp_name(path).  Array sizes are checked against the mesh.  The caller commits.
  subroutine vtk_write_level(path, mesh, level, h, u, fld, st)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: level
    real(dp), intent(in) :: h
    real(dp), intent(in) :: u(:)
    type(vtk_fields_t), intent(in) :: fld
    type(status_t), intent(out) :: st
    type(text_file_t) :: tf
    integer :: i, t
    logical :: bad
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
    call text_open(tf, path, st)
    if (st%code /= 0) return
    call text_put(tf, '<?xml version="1.0"?>')
    call text_put(tf, '<!-- dualsig level ' // itoa(level) // '. contact_status: -1 interior node, ' // &
      '0 separated (Signorini node, u_h > obstacle), 1 contact (Signorini node, u_h = obstacle), ' // &
      '2 Dirichlet (Gamma_u). error = u_h - u_exact at the nodes. est_element sums to est. -->')
    call text_put(tf, '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">')
    call text_put(tf, '  <UnstructuredGrid>')
    call text_put(tf, '    <FieldData>')
    call int_array(tf, 'level', 1, [level], 'NumberOfTuples="1" ')
    call real_array(tf, 'TimeValue', 1, [real(level, dp)], 'NumberOfTuples="1" ')
    call real_array(tf, 'h', 1, [h], 'NumberOfTuples="1" ')
    if (fld%has_est) call real_array(tf, 'est', 1, [fld%est], 'NumberOfTuples="1" ')
    call text_put(tf, '    </FieldData>')
    call text_put(tf, '    <Piece NumberOfPoints="' // itoa(mesh%nnode) // '" NumberOfCells="' // &
      itoa(mesh%ntri) // '">')
    call text_put(tf, '      <PointData Scalars="u_h">')
    call real_array(tf, 'u_h', 1, u)
    if (allocated(fld%u_exact)) then
      call real_array(tf, 'u_exact', 1, fld%u_exact)
      call real_array(tf, 'error', 1, u - fld%u_exact)
    end if
    if (allocated(fld%contact)) call int_array(tf, 'contact_status', 1, fld%contact)
    if (allocated(fld%q_h)) call real_array(tf, 'q_h', 3, pad_z(fld%q_h))
    call text_put(tf, '      </PointData>')
    if (allocated(fld%est_element)) then
      call text_put(tf, '      <CellData Scalars="est_element">')
    else
      call text_put(tf, '      <CellData>')
    end if
    if (allocated(fld%est_element)) call real_array(tf, 'est_element', 1, fld%est_element)
    if (allocated(fld%depth)) call int_array(tf, 'depth', 1, fld%depth)
    if (allocated(fld%lambda_centroid)) call real_array(tf, 'lambda_h', 3, pad_z(fld%lambda_centroid))
    if (allocated(fld%lambda_vertices)) call real_array(tf, 'lambda_h_vertices', 6, &
                                                        reshape(fld%lambda_vertices, [6 * mesh%ntri]))
    call text_put(tf, '      </CellData>')
    call text_put(tf, '      <Points>')
    call real_array(tf, 'Points', 3, pad_z(mesh%xy))
    call text_put(tf, '      </Points>')
    call text_put(tf, '      <Cells>')
    call text_put(tf, '        <DataArray type="Int64" Name="connectivity" format="ascii">')
    do t = 1, mesh%ntri
      call put_ints(tf, mesh%tri(:, t) - 1, 3)
    end do
    call text_put(tf, '        </DataArray>')
    call text_put(tf, '        <DataArray type="Int64" Name="offsets" format="ascii">')
    call put_ints(tf, [(3 * t, t=1, mesh%ntri)], 8)
    call text_put(tf, '        </DataArray>')
    call text_put(tf, '        <DataArray type="UInt8" Name="types" format="ascii">')
    call put_ints(tf, [(vtk_triangle, i=1, mesh%ntri)], 20)
    call text_put(tf, '        </DataArray>')
    call text_put(tf, '      </Cells>')
    call text_put(tf, '    </Piece>')
    call text_put(tf, '  </UnstructuredGrid>')
    call text_put(tf, '</VTKFile>')
    call text_close(tf, st)
  end subroutine vtk_write_level

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
    allocate (paths(nlevel + 1))
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

  !> The gnuplot file of a run's final mesh: `<output>_mesh.dat`.
  pure function mesh_edges_path(output) result(path)
    character(len=*), intent(in) :: output
    character(len=:), allocatable :: path
    path = trim(output) // '_mesh.dat'
  end function mesh_edges_path

  !> The edges of `mesh` as gnuplot segments (x y / x y / blank line) to temp_name(path);
  !> the caller commits.  `plot 'file' with lines` draws the mesh.
  subroutine mesh_edges_write(path, mesh, st)
    character(len=*), intent(in) :: path
    type(mesh_t), intent(in) :: mesh
    type(status_t), intent(out) :: st
    type(text_file_t) :: tf
    character(len=80) :: buf
    integer :: e, k
    call text_open(tf, path, st)
    if (st%code /= 0) return
    call text_put(tf, '# dualsig mesh: ' // itoa(mesh%nnode) // ' nodes, ' // itoa(mesh%ntri) // &
      ' triangles, ' // itoa(mesh%nedge) // ' edges as segments')
    do e = 1, mesh%nedge
      do k = 1, 2
        write (buf, '(2es24.15e3)') mesh%xy(:, mesh%edge_nodes(k, e))
        call text_put(tf, trim(buf))
      end do
      call text_put(tf, '')
    end do
    call text_close(tf, st)
  end subroutine mesh_edges_write

  ! ------------------------------------------------------------------ private
  !> One real DataArray of `ncomp` components (values in tuple order), four per line.
  subroutine real_array(tf, name, ncomp, v, extra)
    type(text_file_t), intent(inout) :: tf
    integer, intent(in) :: ncomp
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: v(:)
    character(len=*), intent(in), optional :: extra   !! further attributes, e.g. NumberOfTuples
    integer :: k, k1
    character(len=:), allocatable :: attrs
    character(len=4 * 25) :: buf
    attrs = ''
    if (present(extra)) attrs = extra
    if (ncomp > 1) attrs = attrs // 'NumberOfComponents="' // itoa(ncomp) // '" '
    call text_put(tf, '        <DataArray type="Float64" Name="' // name // '" ' // attrs // 'format="ascii">')
    do k = 1, size(v), 4
      k1 = min(size(v), k + 3)
      write (buf, '(4es25.16e3)') v(k:k1)
      call text_put(tf, trim(buf))
    end do
    call text_put(tf, '        </DataArray>')
  end subroutine real_array

  !> One Int32 DataArray.
  subroutine int_array(tf, name, ncomp, v, extra)
    type(text_file_t), intent(inout) :: tf
    integer, intent(in) :: ncomp
    character(len=*), intent(in) :: name
    integer, intent(in) :: v(:)
    character(len=*), intent(in), optional :: extra
    character(len=:), allocatable :: attrs
    attrs = ''
    if (present(extra)) attrs = extra
    if (ncomp > 1) attrs = attrs // 'NumberOfComponents="' // itoa(ncomp) // '" '
    call text_put(tf, '        <DataArray type="Int32" Name="' // name // '" ' // attrs // 'format="ascii">')
    call put_ints(tf, v, 20)
    call text_put(tf, '        </DataArray>')
  end subroutine int_array

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
