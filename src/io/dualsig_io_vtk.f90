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
!>              z = 0); lambda_h_vertices (6 components:
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
  use dualsig_io_files, only: temp_name, file_delete, file_commit
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: vtk_fields_t, vtk_write_level, vtk_write_collection, vtk_commit_run, vtk_discard_run
  public :: vtk_level_path, vtk_collection_path, vtk_contact_status
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
    integer :: un, ios, i, t
    character(len=256) :: msg
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
    if (bad) then
      call set_error(st, DS_ERR_INPUT, trim(path) // ': a field does not match the mesh (' // &
        itoa(mesh%nnode) // ' nodes, ' // itoa(mesh%ntri) // ' triangles)')
      return
    end if
    open (newunit=un, file=temp_name(path), status='replace', action='write', iostat=ios, iomsg=msg)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, 'cannot write ' // trim(path) // ': ' // trim(msg))
      return
    end if
    write (un, '(a)', iostat=ios) '<?xml version="1.0"?>'
    write (un, '(a)', iostat=ios) '<!-- dualsig level ' // itoa(level) // '. contact_status: -1 interior node, ' // &
      '0 separated (Signorini node, u_h > obstacle), 1 contact (Signorini node, u_h = obstacle), ' // &
      '2 Dirichlet (Gamma_u). error = u_h - u_exact at the nodes. est_element sums to est. -->'
    write (un, '(a)', iostat=ios) '<VTKFile type="UnstructuredGrid" version="1.0" byte_order="LittleEndian">'
    write (un, '(a)', iostat=ios) '  <UnstructuredGrid>'
    write (un, '(a)', iostat=ios) '    <FieldData>'
    call int_array(un, 'level', 1, [level], ios, 'NumberOfTuples="1" ')
    call real_array(un, 'TimeValue', 1, [real(level, dp)], ios, 'NumberOfTuples="1" ')
    call real_array(un, 'h', 1, [h], ios, 'NumberOfTuples="1" ')
    if (fld%has_est) call real_array(un, 'est', 1, [fld%est], ios, 'NumberOfTuples="1" ')
    write (un, '(a)', iostat=ios) '    </FieldData>'
    write (un, '(a)', iostat=ios) '    <Piece NumberOfPoints="' // itoa(mesh%nnode) // '" NumberOfCells="' // &
      itoa(mesh%ntri) // '">'
    write (un, '(a)', iostat=ios) '      <PointData Scalars="u_h">'
    call real_array(un, 'u_h', 1, u, ios)
    if (allocated(fld%u_exact)) then
      call real_array(un, 'u_exact', 1, fld%u_exact, ios)
      call real_array(un, 'error', 1, u - fld%u_exact, ios)
    end if
    if (allocated(fld%contact)) call int_array(un, 'contact_status', 1, fld%contact, ios)
    if (allocated(fld%q_h)) call real_array(un, 'q_h', 3, pad_z(fld%q_h), ios)
    write (un, '(a)', iostat=ios) '      </PointData>'
    if (allocated(fld%est_element)) then
      write (un, '(a)', iostat=ios) '      <CellData Scalars="est_element">'
    else
      write (un, '(a)', iostat=ios) '      <CellData>'
    end if
    if (allocated(fld%est_element)) call real_array(un, 'est_element', 1, fld%est_element, ios)
    if (allocated(fld%lambda_centroid)) call real_array(un, 'lambda_h', 3, pad_z(fld%lambda_centroid), ios)
    if (allocated(fld%lambda_vertices)) call real_array(un, 'lambda_h_vertices', 6, &
                                                        reshape(fld%lambda_vertices, [6 * mesh%ntri]), ios)
    write (un, '(a)', iostat=ios) '      </CellData>'
    write (un, '(a)', iostat=ios) '      <Points>'
    call real_array(un, 'Points', 3, pad_z(mesh%xy), ios)
    write (un, '(a)', iostat=ios) '      </Points>'
    write (un, '(a)', iostat=ios) '      <Cells>'
    write (un, '(a)', iostat=ios) '        <DataArray type="Int64" Name="connectivity" format="ascii">'
    do t = 1, mesh%ntri
      write (un, '(3(1x,i0))', iostat=ios) mesh%tri(:, t) - 1
    end do
    write (un, '(a)', iostat=ios) '        </DataArray>'
    write (un, '(a)', iostat=ios) '        <DataArray type="Int64" Name="offsets" format="ascii">'
    write (un, '(8(1x,i0))', iostat=ios) (3 * t, t=1, mesh%ntri)
    write (un, '(a)', iostat=ios) '        </DataArray>'
    write (un, '(a)', iostat=ios) '        <DataArray type="UInt8" Name="types" format="ascii">'
    write (un, '(20(1x,i0))', iostat=ios) (vtk_triangle, i=1, mesh%ntri)
    write (un, '(a)', iostat=ios) '        </DataArray>'
    write (un, '(a)', iostat=ios) '      </Cells>'
    write (un, '(a)', iostat=ios) '    </Piece>'
    write (un, '(a)', iostat=ios) '  </UnstructuredGrid>'
    write (un, '(a)', iostat=ios) '</VTKFile>'
    call finish(un, path, ios, st)
  end subroutine vtk_write_level

  !> Write the collection of levels 1..nlevel of the run `output` to
  !> temp_name(vtk_collection_path(output)); the caller commits.
  subroutine vtk_write_collection(output, nlevel, st)
    character(len=*), intent(in) :: output
    integer, intent(in) :: nlevel
    type(status_t), intent(out) :: st
    character(len=:), allocatable :: path
    character(len=256) :: msg
    integer :: un, ios, level
    path = vtk_collection_path(output)
    open (newunit=un, file=temp_name(path), status='replace', action='write', iostat=ios, iomsg=msg)
    if (ios /= 0) then
      call set_error(st, DS_ERR_IO, 'cannot write ' // path // ': ' // trim(msg))
      return
    end if
    write (un, '(a)', iostat=ios) '<?xml version="1.0"?>'
    write (un, '(a)', iostat=ios) '<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">'
    write (un, '(a)', iostat=ios) '  <Collection>'
    do level = 1, nlevel
      write (un, '(a)', iostat=ios) '    <DataSet timestep="' // itoa(level) // '" group="" part="0" file="' // &
        base_name(vtk_level_path(output, level)) // '"/>'
    end do
    write (un, '(a)', iostat=ios) '  </Collection>'
    write (un, '(a)', iostat=ios) '</VTKFile>'
    call finish(un, path, ios, st)
  end subroutine vtk_write_collection

  !> Commit the level files 1..nlevel and the collection of the run `output` (all written
  !> under their temporary names).  On failure the remaining temporary files are removed.
  subroutine vtk_commit_run(output, nlevel, st)
    character(len=*), intent(in) :: output
    integer, intent(in) :: nlevel
    type(status_t), intent(out) :: st
    integer :: level
    do level = 1, nlevel
      call file_commit(vtk_level_path(output, level), st)
      if (st%code /= 0) exit
    end do
    if (st%code == 0) call file_commit(vtk_collection_path(output), st)
    if (st%code /= 0) call vtk_discard_run(output, nlevel)
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

  ! ------------------------------------------------------------------ private
  !> One real DataArray of `ncomp` components (values in tuple order), four per line.
  subroutine real_array(un, name, ncomp, v, ios, extra)
    integer, intent(in) :: un, ncomp
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: v(:)
    integer, intent(inout) :: ios
    character(len=*), intent(in), optional :: extra   !! further attributes, e.g. NumberOfTuples
    integer :: k, k1, io
    character(len=:), allocatable :: attrs
    attrs = ''
    if (present(extra)) attrs = extra
    if (ncomp > 1) attrs = attrs // 'NumberOfComponents="' // itoa(ncomp) // '" '
    write (un, '(a)', iostat=io) '        <DataArray type="Float64" Name="' // name // '" ' // attrs // &
      'format="ascii">'
    if (io /= 0) ios = io
    do k = 1, size(v), 4
      k1 = min(size(v), k + 3)
      write (un, '(4es25.16e3)', iostat=io) v(k:k1)
      if (io /= 0) ios = io
    end do
    write (un, '(a)', iostat=io) '        </DataArray>'
    if (io /= 0) ios = io
  end subroutine real_array

  !> One Int32 DataArray.
  subroutine int_array(un, name, ncomp, v, ios, extra)
    integer, intent(in) :: un, ncomp
    character(len=*), intent(in) :: name
    integer, intent(in) :: v(:)
    integer, intent(inout) :: ios
    character(len=*), intent(in), optional :: extra
    integer :: io
    character(len=:), allocatable :: attrs
    attrs = ''
    if (present(extra)) attrs = extra
    if (ncomp > 1) attrs = attrs // 'NumberOfComponents="' // itoa(ncomp) // '" '
    write (un, '(a)', iostat=io) '        <DataArray type="Int32" Name="' // name // '" ' // attrs // &
      'format="ascii">'
    if (io /= 0) ios = io
    write (un, '(20(1x,i0))', iostat=io) v
    if (io /= 0) ios = io
    write (un, '(a)', iostat=io) '        </DataArray>'
    if (io /= 0) ios = io
  end subroutine int_array

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

  !> Close the unit; on a write error delete the temporary file and report.
  subroutine finish(un, path, ios, st)
    integer, intent(in) :: un, ios
    character(len=*), intent(in) :: path
    type(status_t), intent(inout) :: st
    integer :: io
    close (un, iostat=io)
    if (ios /= 0 .or. io /= 0) then
      call file_delete(temp_name(path))
      call set_error(st, DS_ERR_IO, 'error while writing ' // trim(path))
    end if
  end subroutine finish
end module dualsig_io_vtk
