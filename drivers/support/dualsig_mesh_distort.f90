!> Stress meshes: generators of deliberately bad meshes of a rectangle, for the stress suite
!> (`make stress`) and for anyone who wants to test a solver off the comfortable meshes.
!>
!> - `mesh_corner_graded`: a conforming, isotropically graded mesh of the rectangle
!>   (x0,x1) x (y0,y1), refined geometrically towards the corner (x0,y0).  Layer k
!>   (k = 0 .. nlayer-1) of the reference square [0,1]^2 is [0,2^-k]^2 \ [0,2^-(k+1)]^2, made
!>   of three squares of side a = 2^-(k+1); the core [0,2^-nlayer]^2 is one square.  The
!>   sides shared with the next (finer) layer carry that layer's midpoint, which is used as
!>   the apex of a fan of three triangles, so the mesh is conforming (no hanging nodes).
!>   Neighbouring element sizes differ by a factor 2 at most, the sizes of the whole mesh by
!>   about 2^nlayer, and every angle is >= atan(1/2) = 26.5 degrees on the square (the
!>   rectangle's aspect ratio changes the angles).  Uniform refinement keeps the grading.
!> - `graded_coords`: n + 1 grid coordinates from a to b whose cell sizes grow geometrically
!>   with last / first = ratio, for `mesh_tensor_grid` (boundary layers, needles).
!> - `mesh_tensor_grid`: the tensor grid of given x and y lines, every cell split along its
!>   diagonal (x_i, y_j)-(x_i+1, y_j+1).  With very different x and y spacings its triangles
!>   are needles (smallest angle atan(hy/hx)).
!> Needles, thin domains and anisotropic families also come from `mesh_rectangle` with
!> nx /= ny.  Every generator uses the markers of `mesh_rectangle`: 1 bottom (y = y0),
!> 2 right (x = x1), 3 top (y = y1), 4 left (x = x0), and finishes with mesh_build_topology
!> (triangles counter-clockwise, see dualsig_mesh).
module dualsig_mesh_distort
  use dualsig_kinds, only: dp, geom_rel_tol
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_mesh, only: mesh_t, mesh_build_topology
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: mesh_corner_graded, mesh_tensor_grid, graded_coords

  !> Largest number of layers of mesh_corner_graded (the core has side 2^-max_layers).
  integer, parameter :: max_layers = 40

contains

  !> Mesh of (x0,x1) x (y0,y1) graded geometrically towards (x0,y0) with `nlayer` layers
  !> (>= 1): element sizes from about (x1-x0)/2 down to (x1-x0) 2^-nlayer (see the module header).
  subroutine mesh_corner_graded(mesh, x0, x1, y0, y1, nlayer, st)
    type(mesh_t), intent(out) :: mesh
    real(dp), intent(in) :: x0, x1, y0, y1
    integer, intent(in) :: nlayer
    type(status_t), intent(out) :: st
    real(dp), allocatable :: ref(:,:)       ! nodes on the reference square
    integer, allocatable :: tri(:,:)
    real(dp) :: a, c
    integer :: k, nt, nn
    logical :: mid
    if (nlayer < 1 .or. nlayer > max_layers) then
      call set_error(st, DS_ERR_INPUT, 'mesh_corner_graded: nlayer = ' // itoa(nlayer) // &
        ' (expected 1 .. ' // itoa(max_layers) // ')')
      return
    end if
    if (.not. (x1 > x0 .and. y1 > y0)) then
      call set_error(st, DS_ERR_INPUT, 'mesh_corner_graded: expected x0 < x1 and y0 < y1')
      return
    end if
    allocate (ref(2, 8 * nlayer + 4), tri(3, 8 * nlayer + 2))
    nn = 0
    nt = 0
    do k = 0, nlayer - 1
      a = 0.5_dp**(k + 1)
      mid = k < nlayer - 1               ! the next layer has two cells along each shared side
      ! S1 = [a,2a] x [0,a]: fan from the midpoint (a, a/2) of its left side
      if (mid) then
        call add_tri([a, 0.5_dp * a], [a, 0.0_dp], [2 * a, 0.0_dp])
        call add_tri([a, 0.5_dp * a], [2 * a, 0.0_dp], [2 * a, a])
        call add_tri([a, 0.5_dp * a], [2 * a, a], [a, a])
      else
        call add_tri([a, 0.0_dp], [2 * a, 0.0_dp], [2 * a, a])
        call add_tri([a, 0.0_dp], [2 * a, a], [a, a])
      end if
      ! S2 = [a,2a] x [a,2a]
      call add_tri([a, a], [2 * a, a], [2 * a, 2 * a])
      call add_tri([a, a], [2 * a, 2 * a], [a, 2 * a])
      ! S3 = [0,a] x [a,2a]: fan from the midpoint (a/2, a) of its bottom side
      if (mid) then
        call add_tri([0.5_dp * a, a], [a, a], [a, 2 * a])
        call add_tri([0.5_dp * a, a], [a, 2 * a], [0.0_dp, 2 * a])
        call add_tri([0.5_dp * a, a], [0.0_dp, 2 * a], [0.0_dp, a])
      else
        call add_tri([0.0_dp, a], [a, a], [a, 2 * a])
        call add_tri([0.0_dp, a], [a, 2 * a], [0.0_dp, 2 * a])
      end if
    end do
    c = 0.5_dp**nlayer
    call add_tri([0.0_dp, 0.0_dp], [c, 0.0_dp], [c, c])
    call add_tri([0.0_dp, 0.0_dp], [c, c], [0.0_dp, c])
    mesh%nnode = nn
    mesh%ntri = nt
    allocate (mesh%xy(2, nn))
    mesh%xy(1, :) = x0 + (x1 - x0) * ref(1, 1:nn)
    mesh%xy(2, :) = y0 + (y1 - y0) * ref(2, 1:nn)
    mesh%xy(1, :) = merge(x1, mesh%xy(1, :), ref(1, 1:nn) == 1.0_dp)   ! the far sides exact
    mesh%xy(2, :) = merge(y1, mesh%xy(2, :), ref(2, 1:nn) == 1.0_dp)
    mesh%tri = tri(:, 1:nt)
    call box_boundary(mesh, x0, x1, y0, y1)
    call mesh_build_topology(mesh, st)
    if (st%code /= 0) st%msg = 'mesh_corner_graded: ' // st%msg

  contains

    !> Append the triangle (p, q, r), counter-clockwise on the reference square.  Its
    !> vertices are dyadic rationals, exact in binary, so nodes are shared by exact equality.
    subroutine add_tri(p, q, r)
      real(dp), intent(in) :: p(2), q(2), r(2)
      nt = nt + 1
      tri(:, nt) = [node_id(p), node_id(q), node_id(r)]
    end subroutine add_tri

    integer function node_id(p) result(id)
      real(dp), intent(in) :: p(2)
      do id = 1, nn
        if (all(ref(:, id) == p)) return
      end do
      nn = nn + 1
      ref(:, nn) = p
      id = nn
    end function node_id
  end subroutine mesh_corner_graded

  !> n + 1 coordinates from a to b (both exact) whose n cell sizes form a geometric sequence
  !> with (last size) / (first size) = ratio (> 0; ratio < 1 refines towards b, 1 is uniform).
  pure function graded_coords(a, b, n, ratio) result(x)
    real(dp), intent(in) :: a, b, ratio
    integer, intent(in) :: n
    real(dp) :: x(0:n)
    real(dp) :: q, w(n)
    integer :: i
    if (n == 1 .or. ratio == 1.0_dp) then
      w = 1.0_dp
    else
      q = ratio**(1.0_dp / real(n - 1, dp))
      w = [(q**(i - 1), i=1, n)]
    end if
    x(0) = a
    do i = 1, n
      x(i) = a + (b - a) * (sum(w(1:i)) / sum(w))
    end do
    x(n) = b
  end function graded_coords

  !> Tensor grid of the rectangle (xs(0), xs(n)) x (ys(0), ys(m)) with the given grid lines
  !> (strictly increasing), every cell split into two counter-clockwise triangles along its
  !> diagonal (xs(i), ys(j)) - (xs(i+1), ys(j+1)).  Nodes are numbered row by row.
  subroutine mesh_tensor_grid(mesh, xs, ys, st)
    type(mesh_t), intent(out) :: mesh
    real(dp), intent(in) :: xs(0:), ys(0:)
    type(status_t), intent(out) :: st
    integer :: nx, ny, i, j, t, p00
    nx = size(xs) - 1
    ny = size(ys) - 1
    if (nx < 1 .or. ny < 1) then
      call set_error(st, DS_ERR_INPUT, 'mesh_tensor_grid: expected at least two x and two y lines')
      return
    end if
    if (any(xs(1:nx) <= xs(0:nx - 1)) .or. any(ys(1:ny) <= ys(0:ny - 1))) then
      call set_error(st, DS_ERR_INPUT, 'mesh_tensor_grid: the grid lines must be strictly increasing')
      return
    end if
    mesh%nnode = (nx + 1) * (ny + 1)
    mesh%ntri = 2 * nx * ny
    allocate (mesh%xy(2, mesh%nnode), mesh%tri(3, mesh%ntri))
    do j = 0, ny
      do i = 0, nx
        mesh%xy(:, 1 + i + j * (nx + 1)) = [xs(i), ys(j)]
      end do
    end do
    t = 0
    do j = 0, ny - 1
      do i = 0, nx - 1
        p00 = 1 + i + j * (nx + 1)
        mesh%tri(:, t + 1) = [p00, p00 + 1, p00 + nx + 2]
        mesh%tri(:, t + 2) = [p00, p00 + nx + 2, p00 + nx + 1]
        t = t + 2
      end do
    end do
    call box_boundary(mesh, xs(0), xs(nx), ys(0), ys(ny))
    call mesh_build_topology(mesh, st)
    if (st%code /= 0) st%msg = 'mesh_tensor_grid: ' // st%msg
  end subroutine mesh_tensor_grid

  !> The boundary edges of a conforming triangulation of the rectangle (x0,x1) x (y0,y1):
  !> the triangle sides with both ends on the same side of the rectangle (each belongs to
  !> exactly one triangle), with the markers 1 bottom, 2 right, 3 top, 4 left.
  subroutine box_boundary(mesh, x0, x1, y0, y1)
    type(mesh_t), intent(inout) :: mesh
    real(dp), intent(in) :: x0, x1, y0, y1
    integer, allocatable :: nodes(:,:), marker(:)
    real(dp) :: tol, p(2), q(2)
    integer :: t, k, nb, side
    tol = geom_rel_tol * hypot(x1 - x0, y1 - y0)
    allocate (nodes(2, 3 * mesh%ntri), marker(3 * mesh%ntri))
    nb = 0
    do t = 1, mesh%ntri
      do k = 1, 3
        p = mesh%xy(:, mesh%tri(k, t))
        q = mesh%xy(:, mesh%tri(mod(k, 3) + 1, t))
        side = 0
        if (abs(p(2) - y0) <= tol .and. abs(q(2) - y0) <= tol) side = 1
        if (abs(p(1) - x1) <= tol .and. abs(q(1) - x1) <= tol) side = 2
        if (abs(p(2) - y1) <= tol .and. abs(q(2) - y1) <= tol) side = 3
        if (abs(p(1) - x0) <= tol .and. abs(q(1) - x0) <= tol) side = 4
        if (side == 0) cycle
        nb = nb + 1
        nodes(:, nb) = mesh%tri([k, mod(k, 3) + 1], t)
        marker(nb) = side
      end do
    end do
    mesh%nbedge = nb
    mesh%bedge_nodes = nodes(:, 1:nb)
    mesh%bedge_marker = marker(1:nb)
  end subroutine box_boundary
end module dualsig_mesh_distort
