!> Working precision and package-wide numerical constants of dualsig.
!>
!> Every real in the package is `real(dp)`.  Tolerances that are not arguments of a
!> procedure are named here, with their meaning, so that none is buried in code.
module dualsig_kinds
  use, intrinsic :: iso_fortran_env, only: real64, int64
  implicit none
  private

  public :: dp, i8
  public :: geom_rel_tol, corner_sin_tol, area_sum_rel_tol, pi

  integer, parameter :: dp = real64   !! working precision
  integer, parameter :: i8 = int64    !! 64-bit integers (nonzero counts on large meshes)

  !> Relative tolerance for geometric coincidence tests (points, areas), relative to the
  !> square of the mesh diameter for areas and to the diameter for lengths.
  real(dp), parameter :: geom_rel_tol = 1.0e-12_dp
  !> Two consecutive boundary edges form a polygon corner when the sine of the angle
  !> between their directions exceeds this value.
  real(dp), parameter :: corner_sin_tol = 1.0e-10_dp
  !> The triangle areas of a mesh must sum to the area its boundary loops enclose (shoelace
  !> formula) within this tolerance, relative to the sum: more means overlapping (folded)
  !> triangles.  Rounding of both sums is a few ulps per triangle; a fold that overlaps less
  !> than this fraction of the domain passes this check (mixed orientations are caught
  !> before it, whatever their size).
  real(dp), parameter :: area_sum_rel_tol = 1.0e-9_dp
  real(dp), parameter :: pi = 3.14159265358979323846264338327950288_dp
end module dualsig_kinds
