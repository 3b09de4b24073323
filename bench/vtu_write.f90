!> Write time and size of one .vtu file, ascii against binary (make bench-vtu, see
!> doc/user-guide.md#size-and-speed-of-the-vtu-encodings).
!>
!> Usage: dualsig_vtu_bench N DIR
!> The unit square cut into N x N squares, each cut into two triangles ((N+1)^2 nodes, 2 N^2
!> triangles; N = 256 is level 8 of the uniform runs), with the arrays of a P2 run with
!> dual analysis (u_h, u_exact, error, contact_status, est_element, lambda_h,
!> lambda_h_vertices) filled by smooth functions.  Writes DIR/bench_ascii.vtu and
!> DIR/bench_binary.vtu three times each and prints the bytes and the shortest write time
!> (vtk_write_level and the commit), then the time and size of zlib's levels 1, 4, 6 and 9
!> on the largest array (lambda_h_vertices).
program dualsig_vtu_bench
  use, intrinsic :: iso_c_binding, only: c_int8_t
  use, intrinsic :: iso_fortran_env, only: int64
  use dualsig_kinds, only: dp
  use dualsig_status, only: status_t
  use dualsig_mesh, only: mesh_t
  use dualsig_mesh_generate, only: mesh_rectangle
  use dualsig_io_vtk, only: vtk_fields_t, vtk_write_level, vtu_binary_text, vtu_zlib_level, VTU_ASCII, VTU_BINARY
  use dualsig_io_files, only: file_commit
  implicit none
  integer, parameter :: repeats = 3
  type(mesh_t) :: mesh
  type(status_t) :: st
  type(vtk_fields_t) :: fld
  real(dp), allocatable :: u(:), x(:), y(:)
  character(len=:), allocatable :: text, dir
  character(len=512) :: arg
  integer(c_int8_t), allocatable :: bytes(:)
  integer :: n, k, f, r, zlevels(4) = [1, 4, 6, 9]
  integer(int64) :: c0, c1, rate, sz
  real(dp) :: best
  character(len=6), parameter :: formats(2) = [character(len=6) :: VTU_ASCII, VTU_BINARY]

  call get_command_argument(1, arg)
  read (arg, *) n
  call get_command_argument(2, arg)
  dir = trim(arg)
  call mesh_rectangle(mesh, 0.0_dp, 1.0_dp, 0.0_dp, 1.0_dp, n, n, 'right', st)
  if (st%code /= 0) error stop 'mesh_rectangle failed'
  x = mesh%xy(1, :)
  y = mesh%xy(2, :)
  u = sin(3.0_dp * x) * sin(2.0_dp * y) * (1.0_dp + x) / 3.0_dp
  fld%u_exact = u + 1.0e-4_dp * sin(40.0_dp * x)
  fld%contact = merge(1, -1, y <= 0.0_dp)
  fld%est_element = [(1.0e-6_dp * (1.0_dp + sin(real(k, dp))), k=1, mesh%ntri)]
  fld%lambda_centroid = reshape([(cos(1.0e-3_dp * k), k=1, 2 * mesh%ntri)], [2, mesh%ntri])
  fld%lambda_vertices = reshape([(cos(1.0e-3_dp * k) + 1.0e-7_dp * k, k=1, 6 * mesh%ntri)], [6, mesh%ntri])
  fld%has_est = .true.
  fld%est = sum(fld%est_element)
  write (*, '(a,i0,a,i0,a,i0,a)') 'vtu bench: N = ', n, ': ', mesh%nnode, ' nodes, ', mesh%ntri, ' triangles'
  do f = 1, 2
    best = huge(1.0_dp)
    do r = 1, repeats
      call system_clock(c0, rate)
      call vtk_write_level(dir // '/bench_' // trim(formats(f)) // '.vtu', mesh, 1, 1.0_dp / n, u, fld, st, formats(f))
      if (st%code == 0) call file_commit(dir // '/bench_' // trim(formats(f)) // '.vtu', st)
      call system_clock(c1)
      if (st%code /= 0) error stop 'write failed'
      best = min(best, real(c1 - c0, dp) / real(rate, dp))
    end do
    inquire (file=dir // '/bench_' // trim(formats(f)) // '.vtu', size=sz)
    write (*, '(a6,a,i11,a,f8.3,a)') formats(f), ': ', sz, ' bytes, write ', best, ' s (best of 3)'
  end do
  bytes = transfer(reshape(fld%lambda_vertices, [6 * mesh%ntri]), bytes)
  do k = 1, size(zlevels)
    best = huge(1.0_dp)
    do r = 1, repeats
      call system_clock(c0, rate)
      call vtu_binary_text(bytes, text, st, zlevels(k))
      call system_clock(c1)
      best = min(best, real(c1 - c0, dp) / real(rate, dp))
    end do
    write (*, '(a,i0,a,i0,a,i0,a,f7.3,a,a)') 'zlib level ', zlevels(k), ', lambda_h_vertices: ', size(bytes), &
      ' bytes -> ', len(text), ' characters, ', best, ' s', trim(merge(' (the level used)', '                 ', &
      zlevels(k) == vtu_zlib_level))
  end do
end program dualsig_vtu_bench
