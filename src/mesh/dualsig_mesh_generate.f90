!> Built-in structured mesh generators.
!>
!> All generators build a tensor grid of square (or rectangular) cells, keep the cells that
!> belong to the domain, split every kept cell into two counter-clockwise triangles along
!> one of its diagonals, share nodes between neighbouring cells (no duplicate nodes; grid
!> nodes touched by no kept cell are dropped), list every cell side that borders a removed
!> cell or the outside of the grid as a boundary edge with a marker, and finish with
!> `mesh_build_topology`.  Nodes are numbered row by row (y index outer, x index inner).
!>
!> Boundary markers:
!> - `mesh_rectangle`     (x0,x1) x (y0,y1):
!>     1 bottom (y = y0), 2 right (x = x1), 3 top (y = y1), 4 left (x = x0).
!> - `mesh_lshape`        (-1,1)^2 \ [0,1) x (-1,0]  (the square minus its lower-right quadrant),
!>   the six sides numbered counter-clockwise starting at the bottom:
!>     1 y = -1, x in [-1,0];   2 x = 0, y in [-1,0];   3 y = 0, x in [0,1];
!>     4 x = 1,  y in [0,1];    5 y = 1, x in [-1,1];   6 x = -1, y in [-1,1].
!>   The re-entrant corner is the origin (between sides 2 and 3).
!> - `mesh_holed_square`  (0,1)^2 \ [1/4,3/4]^2  (two boundary loops):
!>     outer sides 1 bottom (y = 0), 2 right (x = 1), 3 top (y = 1), 4 left (x = 0);
!>     hole sides  5 bottom (y = 1/4), 6 right (x = 3/4), 7 top (y = 3/4), 8 left (x = 1/4).
module dualsig_mesh_generate
  use dualsig_kinds, only: dp, i8, geom_rel_tol
  use dualsig_status, only: status_t, set_error, is_ok, DS_ERR_INPUT
  use dualsig_mesh, only: mesh_t, mesh_build_topology
  use dualsig_strings, only: lower
  use dualsig_alloc, only: alloc_failed, BYTES_INT, BYTES_REAL, BYTES_LOGICAL
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_positive_inf
  implicit none
  private

  public :: mesh_rectangle, mesh_lshape, mesh_holed_square

  ! sides of a grid cell, counter-clockwise, as used for boundary edges
  integer, parameter :: SIDE_BOTTOM = 1, SIDE_RIGHT = 2, SIDE_TOP = 3, SIDE_LEFT = 4

  character(len=*), parameter :: valid_patterns = "'right', 'left', 'union_jack'"

contains

  !> Structured mesh of the rectangle (x0,x1) x (y0,y1): nx x ny cells, each split into two
  !> triangles.  pattern: 'right' (diagonal from (i,j) to (i+1,j+1) in every cell), 'left'
  !> (from (i+1,j) to (i,j+1)), 'union_jack' (right and left alternating like a
  !> checkerboard, so that four diagonals meet at every other interior node).
  !> Markers: 1 bottom, 2 right, 3 top, 4 left.
  subroutine mesh_rectangle(mesh, x0, x1, y0, y1, nx, ny, pattern, st)
    type(mesh_t), intent(out) :: mesh
    real(dp), intent(in) :: x0, x1, y0, y1
    integer, intent(in) :: nx, ny
    character(len=*), intent(in) :: pattern
    type(status_t), intent(out) :: st
    character(len=*), parameter :: who = 'mesh_rectangle'
    logical, allocatable :: active(:,:), diag_right(:,:)
    integer, allocatable :: bside(:), bcell(:,:), marker(:)
    character(len=:), allocatable :: pat
    character(len=300) :: buf
    real(dp) :: cell_area, dx, dy, aspect
    integer :: i, j, b, ist

    if (nx < 1 .or. ny < 1) then
      write (buf, '(a,i0,a,i0,a)') who // ': nx = ', nx, ', ny = ', ny, &
        ' (expected cell counts >= 1)'
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    if (.not. (x1 > x0 .and. y1 > y0)) then
      write (buf, '(a,4(es12.4,a))') who // ': (x0,x1) x (y0,y1) = (', x0, ',', x1, ') x (', &
        y0, ',', y1, ') (expected x0 < x1 and y0 < y1)'
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    if (.not. grid_size_ok(int(nx, i8), int(ny, i8))) then
      write (buf, '(a,i0,a,i0,a)') who // ': nx = ', nx, ', ny = ', ny, &
        ' give more triangles than a default integer can count (expected smaller values)'
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    ! twice a triangle's area must be a normal double (an area that underflows or overflows
    ! fails the mesh check as "zero or negative area", a vertex order the caller cannot fix)
    ! (in steps that cannot overflow: the sides first, then the area against huge)
    dx = x1 / nx - x0 / nx
    dy = y1 / ny - y0 / ny
    if (.not. (dx > 0.0_dp .and. dy > 0.0_dp)) then
      cell_area = 0.0_dp
    else if (x1 / 2 - x0 / 2 >= huge(1.0_dp) / 2 .or. y1 / 2 - y0 / 2 >= huge(1.0_dp) / 2) then
      cell_area = ieee_value(1.0_dp, ieee_positive_inf)
    else if (exponent(dx) + exponent(dy) >= maxexponent(1.0_dp)) then
      cell_area = ieee_value(1.0_dp, ieee_positive_inf)
    else
      cell_area = dx * dy
    end if
    if (.not. (ieee_is_finite(cell_area) .and. cell_area >= tiny(1.0_dp))) then
      write (buf, '(a,4(es12.4e3,a),es12.4e3,a)') who // ': x0, x1, y0, y1 = ', x0, ', ', x1, ', ', y0, ', ', y1, &
        ' give cells of area ', cell_area, ', which double precision cannot hold (expected a domain whose ' // &
        'cells have an area between 1e-307 and 1e307: rescale the coordinates)'
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    ! a triangle's area over its longest side squared: r / (2 (1 + r^2)), r the cells' aspect
    aspect = min(dx, dy) / max(dx, dy)
    if (0.5_dp * aspect / (1.0_dp + aspect**2) <= geom_rel_tol) then
      write (buf, '(a,4(es12.4e3,a),2(i0,a),2(es12.4e3,a))') who // ': x0, x1, y0, y1 = ', x0, ', ', x1, ', ', &
        y0, ', ', y1, ' and nx, ny = ', nx, ', ', ny, ' give cells of ', dx, ' by ', dy, &
        ', whose triangles are degenerate (expected cells of aspect ratio below 1e12)'
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    pat = lower(trim(adjustl(pattern)))
    allocate (active(0:nx - 1, 0:ny - 1), diag_right(0:nx - 1, 0:ny - 1), stat=ist)
    if (alloc_failed(ist, st, 'the cells of the grid', 2 * nx * ny, BYTES_LOGICAL)) return
    active = .true.
    select case (pat)
    case ('right')
      diag_right = .true.
    case ('left')
      diag_right = .false.
    case ('union_jack')
      do j = 0, ny - 1
        do i = 0, nx - 1
          diag_right(i, j) = mod(i + j, 2) == 0
        end do
      end do
    case default
      call set_error(st, DS_ERR_INPUT, who // ": unknown pattern '" // trim(pattern) // &
        "' (expected one of " // valid_patterns // ")")
      return
    end select

    call masked_grid(mesh, grid_coords(x0, x1, nx), grid_coords(y0, y1, ny), active, &
                     diag_right, bside, bcell, st)
    if (.not. is_ok(st)) return
    allocate (marker(size(bside)), stat=ist)
    if (alloc_failed(ist, st, 'the boundary markers', size(bside), BYTES_INT)) return
    do b = 1, size(bside)
      marker(b) = bside(b)     ! every cell side on the boundary is a side of the rectangle
    end do
    call finish(mesh, marker, who, st)
  end subroutine mesh_rectangle

  !> Structured mesh of the L-shaped domain (-1,1)^2 \ [0,1) x (-1,0]: the union of three
  !> n x n-cell squares [-1,0]x[-1,0], [-1,0]x[0,1], [0,1]x[0,1] with 'right' diagonals.
  !> Markers 1..6 counter-clockwise from the bottom side y = -1 (see the module header).
  subroutine mesh_lshape(mesh, n, st)
    type(mesh_t), intent(out) :: mesh
    integer, intent(in) :: n
    type(status_t), intent(out) :: st
    character(len=*), parameter :: who = 'mesh_lshape'
    logical, allocatable :: active(:,:), diag_right(:,:)
    integer, allocatable :: bside(:), bcell(:,:), marker(:)
    character(len=200) :: buf
    integer :: b, i, j, ist

    if (n < 1 .or. .not. grid_size_ok(2_i8 * n, 2_i8 * n)) then
      write (buf, '(a,i0,a)') who // ': n = ', n, &
        ' (expected a number of cells per unit length >= 1 and not huge)'
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    allocate (active(0:2 * n - 1, 0:2 * n - 1), diag_right(0:2 * n - 1, 0:2 * n - 1), stat=ist)
    if (alloc_failed(ist, st, 'the cells of the grid', 8 * n * n, BYTES_LOGICAL)) return
    active = .true.
    active(n:2 * n - 1, 0:n - 1) = .false.          ! the lower-right quadrant
    diag_right = .true.
    call masked_grid(mesh, grid_coords(-1.0_dp, 1.0_dp, 2 * n), grid_coords(-1.0_dp, 1.0_dp, 2 * n), &
                     active, diag_right, bside, bcell, st)
    if (.not. is_ok(st)) return
    allocate (marker(size(bside)), stat=ist)
    if (alloc_failed(ist, st, 'the boundary markers', size(bside), BYTES_INT)) return
    do b = 1, size(bside)
      i = bcell(1, b)
      j = bcell(2, b)
      select case (bside(b))
      case (SIDE_BOTTOM)
        marker(b) = merge(1, 3, j == 0)           ! y = -1, else y = 0 (x in [0,1])
      case (SIDE_RIGHT)
        marker(b) = merge(4, 2, i == 2 * n - 1)   ! x = 1, else x = 0 (y in [-1,0])
      case (SIDE_TOP)
        marker(b) = 5
      case default
        marker(b) = 6
      end select
    end do
    call finish(mesh, marker, who, st)
  end subroutine mesh_lshape

  !> Structured mesh of the unit square with a square hole, (0,1)^2 \ [1/4,3/4]^2: a
  !> 4n x 4n grid of the unit square, 'right' diagonals, with the central 2n x 2n cells
  !> removed, so that the hole sides lie on grid lines.  Two boundary loops.
  !> Markers: outer 1 bottom, 2 right, 3 top, 4 left; hole 5 bottom, 6 right, 7 top, 8 left.
  subroutine mesh_holed_square(mesh, n, st)
    type(mesh_t), intent(out) :: mesh
    integer, intent(in) :: n
    type(status_t), intent(out) :: st
    character(len=*), parameter :: who = 'mesh_holed_square'
    logical, allocatable :: active(:,:), diag_right(:,:)
    integer, allocatable :: bside(:), bcell(:,:), marker(:)
    character(len=200) :: buf
    integer :: b, i, j, m, ist

    if (n < 1 .or. .not. grid_size_ok(4_i8 * n, 4_i8 * n)) then
      write (buf, '(a,i0,a)') who // ': n = ', n, &
        ' (expected a number of cells per quarter side >= 1 and not huge)'
      call set_error(st, DS_ERR_INPUT, trim(buf))
      return
    end if
    m = 4 * n
    allocate (active(0:m - 1, 0:m - 1), diag_right(0:m - 1, 0:m - 1), stat=ist)
    if (alloc_failed(ist, st, 'the cells of the grid', 2 * m * m, BYTES_LOGICAL)) return
    active = .true.
    active(n:3 * n - 1, n:3 * n - 1) = .false.        ! the hole
    diag_right = .true.
    call masked_grid(mesh, grid_coords(0.0_dp, 1.0_dp, m), grid_coords(0.0_dp, 1.0_dp, m), &
                     active, diag_right, bside, bcell, st)
    if (.not. is_ok(st)) return
    allocate (marker(size(bside)), stat=ist)
    if (alloc_failed(ist, st, 'the boundary markers', size(bside), BYTES_INT)) return
    do b = 1, size(bside)
      i = bcell(1, b)
      j = bcell(2, b)
      select case (bside(b))
      case (SIDE_BOTTOM)
        marker(b) = merge(1, 7, j == 0)       ! y = 0, else the hole's top y = 3/4
      case (SIDE_RIGHT)
        marker(b) = merge(2, 8, i == m - 1)   ! x = 1, else the hole's left x = 1/4
      case (SIDE_TOP)
        marker(b) = merge(3, 5, j == m - 1)   ! y = 1, else the hole's bottom y = 1/4
      case default
        marker(b) = merge(4, 6, i == 0)       ! x = 0, else the hole's right x = 3/4
      end select
    end do
    call finish(mesh, marker, who, st)
  end subroutine mesh_holed_square

  ! ------------------------------------------------------------------ helpers

  !> Store the boundary markers and build the topology; errors are prefixed with `who`.
  subroutine finish(mesh, marker, who, st)
    type(mesh_t), intent(inout) :: mesh
    integer, intent(in) :: marker(:)
    character(len=*), intent(in) :: who
    type(status_t), intent(out) :: st
    mesh%bedge_marker = marker
    call mesh_build_topology(mesh, st)
    if (st%code /= 0) st%msg = who // ': ' // st%msg      ! keep the code, name the source
  end subroutine finish

  !> True when the counts of a grid of nx x ny cells fit a default integer: nodes, triangles
  !> (2 per cell) and the half-edges mesh_build_topology counts (3 per triangle).
  pure logical function grid_size_ok(nx, ny) result(ok)
    integer(i8), intent(in) :: nx, ny
    real(dp), parameter :: half_edges_per_cell = 6.0_dp
    ! in real arithmetic: the product can exceed even a 64-bit integer
    ok = half_edges_per_cell * real(nx + 1, dp) * real(ny + 1, dp) < real(huge(1), dp)
  end function grid_size_ok

  !> The n+1 equispaced grid coordinates from a to b, with both ends exact.
  pure function grid_coords(a, b, n) result(x)
    real(dp), intent(in) :: a, b
    integer, intent(in) :: n
    real(dp) :: x(0:n)
    integer :: i
    do i = 0, n
      x(i) = a + (b - a) * (real(i, dp) / real(n, dp))
    end do
    x(0) = a
    x(n) = b
  end function grid_coords

  !> Nodes, triangles and boundary edges of the kept cells of a tensor grid.
  !>
  !> xs(0:nx), ys(0:ny) are the grid lines; cell (i,j) = [xs(i),xs(i+1)] x [ys(j),ys(j+1)] is
  !> kept when active(i,j); diag_right(i,j) selects the diagonal (i,j)-(i+1,j+1), otherwise
  !> (i+1,j)-(i,j+1).  On return bside(b) (SIDE_BOTTOM..SIDE_LEFT) and bcell(:,b) = [i,j]
  !> tell which cell side boundary edge b is; bedge_marker is left for the caller.
  subroutine masked_grid(mesh, xs, ys, active, diag_right, bside, bcell, st)
    type(mesh_t), intent(inout) :: mesh
    real(dp), intent(in) :: xs(0:), ys(0:)
    logical, intent(in) :: active(0:, 0:), diag_right(0:, 0:)
    integer, allocatable, intent(out) :: bside(:), bcell(:,:)
    type(status_t), intent(inout) :: st
    integer, allocatable :: id(:,:)
    logical, allocatable :: pad(:,:)
    integer :: nx, ny, i, j, k, t, nb, nn, p00, p10, p11, p01, ist

    nx = size(xs) - 1
    ny = size(ys) - 1
    ! the kept-cell mask with a frame of removed cells around it
    allocate (pad(-1:nx, -1:ny), id(0:nx, 0:ny), stat=ist)
    if (alloc_failed(ist, st, 'the nodes of the grid', 2 * (nx + 2) * (ny + 2), BYTES_INT)) return
    pad = .false.
    pad(0:nx - 1, 0:ny - 1) = active
    ! --- nodes: grid points touched by a kept cell ---
    id = 0
    nn = 0
    do j = 0, ny
      do i = 0, nx
        if (any(pad(i - 1:i, j - 1:j))) then
          nn = nn + 1
          id(i, j) = nn
        end if
      end do
    end do
    mesh%nnode = nn
    allocate (mesh%xy(2, nn), stat=ist)
    if (alloc_failed(ist, st, 'the nodes of the mesh', 2 * nn, BYTES_REAL)) return
    do j = 0, ny
      do i = 0, nx
        if (id(i, j) > 0) mesh%xy(:, id(i, j)) = [xs(i), ys(j)]
      end do
    end do

    ! --- triangles and boundary edges ---
    mesh%ntri = 2 * count(active)
    allocate (mesh%tri(3, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the triangles of the mesh', 3 * mesh%ntri, BYTES_INT)) return
    nb = 0
    do j = 0, ny - 1
      do i = 0, nx - 1
        if (.not. active(i, j)) cycle
        do k = SIDE_BOTTOM, SIDE_LEFT
          if (.not. neighbour_active(k, i, j)) nb = nb + 1
        end do
      end do
    end do
    mesh%nbedge = nb
    allocate (mesh%bedge_nodes(2, nb), bside(nb), bcell(2, nb), stat=ist)
    if (alloc_failed(ist, st, 'the boundary edges of the mesh', 5 * nb, BYTES_INT)) return
    t = 0
    nb = 0
    do j = 0, ny - 1
      do i = 0, nx - 1
        if (.not. active(i, j)) cycle
        p00 = id(i, j)
        p10 = id(i + 1, j)
        p11 = id(i + 1, j + 1)
        p01 = id(i, j + 1)
        if (diag_right(i, j)) then
          mesh%tri(:, t + 1) = [p00, p10, p11]
          mesh%tri(:, t + 2) = [p00, p11, p01]
        else
          mesh%tri(:, t + 1) = [p00, p10, p01]
          mesh%tri(:, t + 2) = [p10, p11, p01]
        end if
        t = t + 2
        do k = SIDE_BOTTOM, SIDE_LEFT
          if (neighbour_active(k, i, j)) cycle
          nb = nb + 1
          bside(nb) = k
          bcell(:, nb) = [i, j]
          select case (k)        ! counter-clockwise around the cell
          case (SIDE_BOTTOM)
            mesh%bedge_nodes(:, nb) = [p00, p10]
          case (SIDE_RIGHT)
            mesh%bedge_nodes(:, nb) = [p10, p11]
          case (SIDE_TOP)
            mesh%bedge_nodes(:, nb) = [p11, p01]
          case default
            mesh%bedge_nodes(:, nb) = [p01, p00]
          end select
        end do
      end do
    end do

  contains

    !> True when the cell across side k of cell (ci,cj) exists and is kept.
    pure logical function neighbour_active(k, ci, cj) result(yes)
      integer, intent(in) :: k, ci, cj
      select case (k)
      case (SIDE_BOTTOM)
        yes = pad(ci, cj - 1)
      case (SIDE_RIGHT)
        yes = pad(ci + 1, cj)
      case (SIDE_TOP)
        yes = pad(ci, cj + 1)
      case default
        yes = pad(ci - 1, cj)
      end select
    end function neighbour_active
  end subroutine masked_grid
end module dualsig_mesh_generate
