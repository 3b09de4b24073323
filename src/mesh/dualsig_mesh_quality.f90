!> Size and shape statistics of a triangular mesh.
!>
!> The convergence analysis of the paper assumes an alpha-beta regular family of meshes:
!> every angle >= alpha and the ratio between any two sides < beta.  `min_angle_deg` gives
!> the alpha of a mesh; for beta, `max_tri_side_ratio` is the worst ratio longest/shortest
!> side inside one triangle (shape regularity) and `global_side_ratio` = h / h_min the ratio
!> between any two sides of the whole mesh (quasi-uniformity).
!>
!> Flags.  A single mesh cannot violate a property of a family, but it can be far from what
!> the analysis assumes; `mesh_quality` flags (and `mesh_quality_report` prints):
!> - `flag_small_angle`: an angle below alpha (default quality_alpha_deg);
!> - `flag_shape`: a triangle whose longest / shortest side exceeds beta (default
!>   quality_beta), i.e. a needle or a flat triangle;
!> - `flag_graded`: h / h_min above quality_grading (not quasi-uniform, a strongly graded mesh).
!> `flagged` is true when any of them is set.
module dualsig_mesh_quality
  use dualsig_kinds, only: dp, pi
  use dualsig_mesh, only: mesh_t, mesh_triangle_area
  implicit none
  private

  public :: mesh_quality_t, mesh_quality, mesh_quality_report
  public :: quality_alpha_deg, quality_beta, quality_grading

  !> Default flag thresholds: smallest acceptable angle (degrees), largest acceptable ratio
  !> longest / shortest side inside one triangle, largest acceptable h / h_min.
  real(dp), parameter :: quality_alpha_deg = 5.0_dp
  real(dp), parameter :: quality_beta = 10.0_dp
  real(dp), parameter :: quality_grading = 100.0_dp

  type :: mesh_quality_t
    integer :: nnode = 0                       !! number of nodes
    integer :: ntri = 0                        !! number of triangles
    integer :: nedge = 0                       !! number of edges (0 without topology)
    integer :: nbedge = 0                      !! number of boundary edges
    integer :: nbnode = 0                      !! number of boundary nodes (0 without topology)
    integer :: ncorner = 0                     !! number of polygon corners (0 without topology)
    integer :: nloop = 0                       !! number of boundary loops (1 + holes)
    real(dp) :: h = 0.0_dp                     !! longest side of all triangles (the mesh size)
    real(dp) :: h_min = 0.0_dp                 !! shortest side of all triangles
    real(dp) :: min_angle_deg = 0.0_dp         !! smallest interior angle, degrees
    real(dp) :: max_angle_deg = 0.0_dp         !! largest interior angle, degrees
    real(dp) :: max_tri_side_ratio = 0.0_dp    !! max over triangles of longest / shortest side
    real(dp) :: global_side_ratio = 0.0_dp     !! h / h_min: ratio of the longest to the shortest side
    real(dp) :: area = 0.0_dp                  !! total area (sum of the signed triangle areas)
    real(dp) :: min_tri_area = 0.0_dp          !! smallest signed triangle area
    real(dp) :: alpha_deg = quality_alpha_deg  !! threshold used for flag_small_angle
    real(dp) :: beta = quality_beta            !! threshold used for flag_shape
    real(dp) :: grading = quality_grading      !! threshold used for flag_graded
    logical :: flag_small_angle = .false.      !! min_angle_deg < alpha_deg
    logical :: flag_shape = .false.            !! max_tri_side_ratio > beta
    logical :: flag_graded = .false.           !! global_side_ratio > grading
    logical :: flagged = .false.               !! any of the three flags
  end type mesh_quality_t

contains

  !> Counts, mesh size, side ratios, extreme angles, area and flags of `mesh`.  Degenerate
  !> sides (zero length) give the ratios the value huge(1.0_dp).  alpha_deg, beta, grading
  !> (optional) replace the default flag thresholds of the module header.
  function mesh_quality(mesh, alpha_deg, beta, grading) result(q)
    type(mesh_t), intent(in) :: mesh
    real(dp), intent(in), optional :: alpha_deg, beta, grading
    type(mesh_quality_t) :: q
    integer :: t, k
    real(dp) :: p(2, 3), d(2, 3), side(3), ang, a, longest, shortest

    q%nnode = mesh%nnode
    q%ntri = mesh%ntri
    q%nedge = mesh%nedge
    q%nbedge = mesh%nbedge
    q%nloop = mesh%nloop
    if (present(alpha_deg)) q%alpha_deg = alpha_deg
    if (present(beta)) q%beta = beta
    if (present(grading)) q%grading = grading
    if (allocated(mesh%node_on_boundary)) q%nbnode = count(mesh%node_on_boundary)
    if (allocated(mesh%node_is_corner)) q%ncorner = count(mesh%node_is_corner)
    if (mesh%ntri < 1) return

    q%h = 0.0_dp
    q%h_min = huge(1.0_dp)
    q%min_angle_deg = huge(1.0_dp)
    q%max_angle_deg = 0.0_dp
    q%max_tri_side_ratio = 0.0_dp
    q%area = 0.0_dp
    q%min_tri_area = huge(1.0_dp)
    do t = 1, mesh%ntri
      p = mesh%xy(:, mesh%tri(:, t))
      do k = 1, 3
        d(:, k) = p(:, mod(k, 3) + 1) - p(:, k)     ! local edge k: vertex k -> k+1
        side(k) = sqrt(d(1, k)**2 + d(2, k)**2)
      end do
      longest = maxval(side)
      shortest = minval(side)
      q%h = max(q%h, longest)
      q%h_min = min(q%h_min, shortest)
      q%max_tri_side_ratio = max(q%max_tri_side_ratio, side_ratio(longest, shortest))
      do k = 1, 3
        ! angle at vertex k+1 between the reversed edge k and edge k+1
        ang = angle_between(-d(:, k), d(:, mod(k, 3) + 1))
        q%min_angle_deg = min(q%min_angle_deg, ang)
        q%max_angle_deg = max(q%max_angle_deg, ang)
      end do
      a = mesh_triangle_area(mesh, t)
      q%area = q%area + a
      q%min_tri_area = min(q%min_tri_area, a)
    end do
    q%global_side_ratio = side_ratio(q%h, q%h_min)
    q%flag_small_angle = q%min_angle_deg < q%alpha_deg
    q%flag_shape = q%max_tri_side_ratio > q%beta
    q%flag_graded = q%global_side_ratio > q%grading
    q%flagged = q%flag_small_angle .or. q%flag_shape .or. q%flag_graded
  end function mesh_quality

  !> Write a short human-readable summary of `q` to `unit`.  Write errors are ignored:
  !> the report is informational only.
  subroutine mesh_quality_report(q, unit)
    type(mesh_quality_t), intent(in) :: q
    integer, intent(in) :: unit
    integer :: ios
    character(len=256) :: iom
    write (unit, '(a)', iostat=ios, iomsg=iom) 'mesh quality'
    write (unit, '(a,i0,a,i0,a,i0)', iostat=ios, iomsg=iom) '  nodes ', q%nnode, &
      ', triangles ', q%ntri, ', edges ', q%nedge
    write (unit, '(a,i0,a,i0,a,i0,a,i0)', iostat=ios, iomsg=iom) '  boundary edges ', q%nbedge, &
      ', boundary nodes ', q%nbnode, ', corners ', q%ncorner, ', loops ', q%nloop
    write (unit, '(a,es12.5,a,es12.5,a,es12.5)', iostat=ios, iomsg=iom) '  h (longest side) ', &
      q%h, ', h_min (shortest side) ', q%h_min, ', h/h_min ', q%global_side_ratio
    write (unit, '(a,f9.4,a,f9.4,a)', iostat=ios, iomsg=iom) '  angles ', q%min_angle_deg, &
      ' .. ', q%max_angle_deg, ' degrees'
    write (unit, '(a,es12.5)', iostat=ios, iomsg=iom) &
      '  max longest/shortest side in one triangle ', q%max_tri_side_ratio
    write (unit, '(a,es22.15,a,es12.5)', iostat=ios, iomsg=iom) '  area ', q%area, &
      ', smallest triangle area ', q%min_tri_area
    if (q%flag_small_angle) write (unit, '(a,f9.4,a,f6.2,a)', iostat=ios, iomsg=iom) &
      '  FLAG small angle: ', q%min_angle_deg, ' degrees < alpha = ', q%alpha_deg, &
      ' (the alpha-beta regularity of the analysis is violated)'
    if (q%flag_shape) write (unit, '(a,es10.3,a,es10.3,a)', iostat=ios, iomsg=iom) &
      '  FLAG shape: longest/shortest side ', q%max_tri_side_ratio, ' > beta = ', q%beta, &
      ' in one triangle (needle or flat triangle)'
    if (q%flag_graded) write (unit, '(a,es10.3,a,es10.3,a)', iostat=ios, iomsg=iom) &
      '  FLAG graded: h/h_min ', q%global_side_ratio, ' > ', q%grading, ' (not quasi-uniform)'
  end subroutine mesh_quality_report

  !> Ratio long / short, huge(1.0_dp) for a zero-length short side.
  pure real(dp) function side_ratio(long, short) result(r)
    real(dp), intent(in) :: long, short
    if (short > 0.0_dp) then
      r = long / short
    else
      r = huge(1.0_dp)
    end if
  end function side_ratio

  !> Angle in degrees between the vectors u and v (0 when one of them is zero).
  pure real(dp) function angle_between(u, v) result(deg)
    real(dp), intent(in) :: u(2), v(2)
    real(dp), parameter :: rad_to_deg = 180.0_dp / pi
    deg = rad_to_deg * atan2(abs(u(1) * v(2) - u(2) * v(1)), u(1) * v(1) + u(2) * v(2))
  end function angle_between
end module dualsig_mesh_quality
