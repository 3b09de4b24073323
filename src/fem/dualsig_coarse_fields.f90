!> Fields defined on the coarse mesh and evaluated anywhere in the domain: a load given per
!> region (an expression for each region of the coarse triangles: Gmsh physical surfaces,
!> Triangle region attributes) and a load given by its nodal values (the P1 interpolant on
!> the coarse mesh).
!>
!> The refined meshes of an analysis lie inside the coarse one (uniform refinement does
!> not move nodes), so a point of a refined triangle is found in the coarse mesh by point
!> location: a bucket grid over the bounding box, each cell listing the coarse triangles
!> whose bounding boxes meet it.  The triangle whose smallest barycentric coordinate at the
!> point is largest is taken: for a point inside a triangle that is the triangle itself;
!> on a side shared by two triangles either one (a region load jumps there, which is a
!> side of every refined mesh, so integrals over refined triangles never see the jump).
module dualsig_coarse_fields
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t
  use dualsig_mesh, only: mesh_t
  use dualsig_expression, only: expression_t, expression_value
  use dualsig_expression_range, only: expression_range
  use dualsig_expression_fields, only: expression_cost
  use dualsig_alloc, only: alloc_failed, has_failed, BYTES_INT, BYTES_REAL
  use dualsig_status, only: status_t
  implicit none
  private

  public :: point_locator_t, locator_build, locator_find
  public :: region_field_t, region_field, nodal_field_t, nodal_field

  !> Bucket grid over the coarse triangles.
  type :: point_locator_t
    integer :: ntri = 0
    real(dp), allocatable :: xy(:,:)            !! (2, nnode) coarse nodes
    integer, allocatable :: tri(:,:)            !! (3, ntri) coarse triangles
    real(dp) :: x0 = 0.0_dp, y0 = 0.0_dp        !! lower left corner of the grid
    real(dp) :: dx = 1.0_dp, dy = 1.0_dp        !! cell sizes
    integer :: nx = 1, ny = 1                   !! cells per direction
    integer, allocatable :: head(:)             !! (nx*ny + 1) cell c lists items(head(c):head(c+1)-1)
    integer, allocatable :: items(:)            !! triangles of the cells
  end type point_locator_t

  !> f = expression k(t) on coarse triangle t (k(t) = tri_expr(t)).
  type, extends(field_t) :: region_field_t
    type(point_locator_t) :: loc
    integer, allocatable :: tri_expr(:)         !! (ntri) expression of each coarse triangle
    type(expression_t), allocatable :: exprs(:) !! the expressions of the regions
  contains
    procedure :: value => region_field_value
    procedure :: range_on_triangle => region_field_range
    procedure :: evaluation_cost => region_field_cost
  end type region_field_t

  !> f = the P1 interpolant of nodal values on the coarse mesh.
  type, extends(field_t) :: nodal_field_t
    type(point_locator_t) :: loc
    real(dp), allocatable :: values(:)          !! (nnode) at the coarse nodes
  contains
    procedure :: value => nodal_field_value
  end type nodal_field_t

contains

  !> The bucket grid of `mesh` (about one triangle per cell).  Out of memory:
  !> DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  subroutine locator_build(mesh, loc, st)
    type(mesh_t), intent(in) :: mesh
    type(point_locator_t), intent(out) :: loc
    type(status_t), intent(inout) :: st
    real(dp) :: x1, y1, w, h, lo(2), hi(2)
    integer :: t, i, j, i0, i1, j0, j1, c, ncell, ist
    integer, allocatable :: cnt(:), fill(:)
    loc%ntri = mesh%ntri
    allocate (loc%xy(2, mesh%nnode), loc%tri(3, mesh%ntri), stat=ist)
    if (alloc_failed(ist, st, 'the coarse mesh of the load', 2 * mesh%nnode + 2 * mesh%ntri, BYTES_REAL)) return
    loc%xy(:, :) = mesh%xy(:, 1:mesh%nnode)
    loc%tri(:, :) = mesh%tri(:, 1:mesh%ntri)
    loc%x0 = minval(loc%xy(1, :))
    loc%y0 = minval(loc%xy(2, :))
    x1 = maxval(loc%xy(1, :))
    y1 = maxval(loc%xy(2, :))
    w = max(x1 - loc%x0, tiny(1.0_dp))
    h = max(y1 - loc%y0, tiny(1.0_dp))
    loc%nx = max(1, min(1024, nint(sqrt(real(mesh%ntri, dp) * w / h))))
    loc%ny = max(1, min(1024, nint(sqrt(real(mesh%ntri, dp) * h / w))))
    loc%dx = w / loc%nx
    loc%dy = h / loc%ny
    ncell = loc%nx * loc%ny
    allocate (cnt(ncell), fill(ncell), loc%head(ncell + 1), stat=ist)
    if (alloc_failed(ist, st, 'the point locator of the load', 3 * ncell + 1, BYTES_INT)) return
    cnt = 0
    do t = 1, mesh%ntri                           ! count, then fill (CSR)
      call cell_range(t)
      do j = j0, j1
        do i = i0, i1
          c = (j - 1) * loc%nx + i
          cnt(c) = cnt(c) + 1
        end do
      end do
    end do
    loc%head(1) = 1
    do c = 1, ncell
      loc%head(c + 1) = loc%head(c) + cnt(c)
    end do
    allocate (loc%items(loc%head(ncell + 1) - 1), stat=ist)
    if (alloc_failed(ist, st, 'the point locator of the load', loc%head(ncell + 1) - 1, BYTES_INT)) return
    fill = loc%head(1:ncell)
    do t = 1, mesh%ntri
      call cell_range(t)
      do j = j0, j1
        do i = i0, i1
          c = (j - 1) * loc%nx + i
          loc%items(fill(c)) = t
          fill(c) = fill(c) + 1
        end do
      end do
    end do
  contains
    !> The cells met by the bounding box of triangle t.
    subroutine cell_range(t)
      integer, intent(in) :: t
      lo = minval(loc%xy(:, loc%tri(:, t)), dim=2)
      hi = maxval(loc%xy(:, loc%tri(:, t)), dim=2)
      i0 = cell_index(lo(1), loc%x0, loc%dx, loc%nx)
      i1 = cell_index(hi(1), loc%x0, loc%dx, loc%nx)
      j0 = cell_index(lo(2), loc%y0, loc%dy, loc%ny)
      j1 = cell_index(hi(2), loc%y0, loc%dy, loc%ny)
    end subroutine cell_range
  end subroutine locator_build

  !> The cell (1..n) of coordinate v on a grid starting at v0 with cells of size d.
  pure integer function cell_index(v, v0, d, n) result(i)
    real(dp), intent(in) :: v, v0, d
    integer, intent(in) :: n
    i = min(n, max(1, int((v - v0) / d) + 1))
  end function cell_index

  !> The coarse triangle t of the point (x, y) and the barycentric coordinates lambda of the
  !> point in it: the triangle of the point's cell with the largest smallest coordinate;
  !> when no triangle of the cell contains the point (a point outside the mesh), every
  !> triangle is searched.
  pure subroutine locator_find(loc, x, y, t, lambda)
    type(point_locator_t), intent(in) :: loc
    real(dp), intent(in) :: x, y
    integer, intent(out) :: t
    real(dp), intent(out) :: lambda(3)
    real(dp), parameter :: inside_tol = -1.0e-12_dp
    real(dp) :: best, lam(3)
    integer :: c, k, s
    c = (cell_index(y, loc%y0, loc%dy, loc%ny) - 1) * loc%nx + cell_index(x, loc%x0, loc%dx, loc%nx)
    best = -huge(1.0_dp)
    t = 0
    lambda = 0.0_dp
    do k = loc%head(c), loc%head(c + 1) - 1
      s = loc%items(k)
      lam = barycentric(loc, s, x, y)
      if (minval(lam) > best) then
        best = minval(lam)
        t = s
        lambda = lam
      end if
    end do
    if (best >= inside_tol) return
    do s = 1, loc%ntri
      lam = barycentric(loc, s, x, y)
      if (minval(lam) > best) then
        best = minval(lam)
        t = s
        lambda = lam
      end if
    end do
  end subroutine locator_find

  !> Barycentric coordinates of (x, y) in coarse triangle s.
  pure function barycentric(loc, s, x, y) result(lam)
    type(point_locator_t), intent(in) :: loc
    integer, intent(in) :: s
    real(dp), intent(in) :: x, y
    real(dp) :: lam(3)
    real(dp) :: a(2), b(2), c(2), det
    a = loc%xy(:, loc%tri(1, s))
    b = loc%xy(:, loc%tri(2, s))
    c = loc%xy(:, loc%tri(3, s))
    det = (b(1) - a(1)) * (c(2) - a(2)) - (c(1) - a(1)) * (b(2) - a(2))
    lam(2) = ((x - a(1)) * (c(2) - a(2)) - (c(1) - a(1)) * (y - a(2))) / det
    lam(3) = ((b(1) - a(1)) * (y - a(2)) - (x - a(1)) * (b(2) - a(2))) / det
    lam(1) = 1.0_dp - lam(2) - lam(3)
  end function barycentric

  !> The region field of `mesh`: coarse triangle t takes expression exprs(tri_expr(t)).
  !> Out of memory: DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  function region_field(mesh, tri_expr, exprs, st) result(field)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: tri_expr(:)
    type(expression_t), intent(in) :: exprs(:)
    type(status_t), intent(inout) :: st
    type(region_field_t) :: field
    call locator_build(mesh, field%loc, st)
    if (has_failed(st)) return
    field%tri_expr = tri_expr
    field%exprs = exprs
  end function region_field

  !> The P1 interpolant of `values` (one per node) on `mesh`.  Out of memory:
  !> DS_ERR_MEMORY in st (without st the program stops, see dualsig_alloc).
  function nodal_field(mesh, values, st) result(field)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in) :: values(:)
    type(status_t), intent(inout) :: st
    type(nodal_field_t) :: field
    call locator_build(mesh, field%loc, st)
    if (has_failed(st)) return
    field%values = values
  end function nodal_field

  real(dp) function region_field_value(self, x, y) result(v)
    class(region_field_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    integer :: t
    real(dp) :: lambda(3)
    call locator_find(self%loc, x, y, t, lambda)
    v = expression_value(self%exprs(self%tri_expr(t)), x, y)
  end function region_field_value

  !> An enclosure of the values on a triangle (a piece of a refined triangle, inside one
  !> coarse triangle): the interval enclosure (expression_range) of the expression of the
  !> coarse triangle of its centroid, when its vertices lie in that coarse triangle too
  !> (barycentric coordinates >= inside_tol: a vertex on a side shared with another region
  !> belongs to both); otherwise (a triangle not from a refinement of the coarse mesh) the
  !> union of the enclosures of the expressions found at its vertices and centroid.
  subroutine region_field_range(self, tri, lo, hi, known, enough, rough)
    class(region_field_t), intent(in) :: self
    real(dp), intent(in) :: tri(2, 3)
    real(dp), intent(out) :: lo, hi
    logical, intent(out) :: known
    real(dp), intent(in), optional :: enough(2)
    logical, intent(out), optional :: rough
    real(dp), parameter :: inside_tol = -1.0e-12_dp
    real(dp) :: p(2, 4), lambda(3), l1, h1
    integer :: k, t, e(4)
    logical :: kinked
    p(:, 1:3) = tri
    p(:, 4) = sum(tri, dim=2) / 3.0_dp
    known = .true.
    call locator_find(self%loc, p(1, 4), p(2, 4), t, lambda)
    e(4) = self%tri_expr(t)
    if (all([(minval(barycentric(self%loc, t, p(1, k), p(2, k))) >= inside_tol, k = 1, 3)])) then
      call expression_range(self%exprs(e(4)), tri, lo, hi, enough, rough)
      return
    end if
    do k = 1, 3
      call locator_find(self%loc, p(1, k), p(2, k), t, lambda)
      e(k) = self%tri_expr(t)
    end do
    ! the piece meets an interface between regions with other expressions: f may jump there
    if (present(rough)) rough = any(e(1:3) /= e(4))
    lo = huge(1.0_dp)
    hi = -huge(1.0_dp)
    do k = 1, 4
      if (any(e(1:k - 1) == e(k))) cycle
      call expression_range(self%exprs(e(k)), tri, l1, h1, rough=kinked)
      lo = min(lo, l1)
      hi = max(hi, h1)
      if (present(rough)) rough = rough .or. kinked
    end do
  end subroutine region_field_range

  !> The cost of one evaluation (field_t%evaluation_cost): that of the longest expression.
  pure real(dp) function region_field_cost(self) result(cost)
    class(region_field_t), intent(in) :: self
    integer :: k
    cost = 1.0_dp
    do k = 1, size(self%exprs)
      cost = max(cost, expression_cost(self%exprs(k)))
    end do
  end function region_field_cost

  real(dp) function nodal_field_value(self, x, y) result(v)
    class(nodal_field_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    integer :: t
    real(dp) :: lambda(3)
    call locator_find(self%loc, x, y, t, lambda)
    v = dot_product(lambda, self%values(self%loc%tri(:, t)))
  end function nodal_field_value
end module dualsig_coarse_fields
