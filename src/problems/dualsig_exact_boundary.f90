!> Does an exact solution belong to the boundary conditions of a run?  A scene's (or a
!> user's) u_exact solves its own problem: u = 0 on Gamma_u and the Signorini conditions
!> u >= 0, du/dnu >= 0, u du/dnu = 0 on Gamma_a (all of Gamma for P1).  On another domain
!> (a hole in the unit square) or with other boundary parts (Gamma_u and Gamma_a swapped)
!> it is the solution of a different problem, and the error columns and effectivities
!> computed from it are meaningless (eff < 1 in certified rows was seen that way).
!>
!> exact_boundary_check samples u_exact and its gradient at the three Gauss points of every
!> boundary edge of the (coarse) mesh (not at rational fractions, where a manufactured
!> sin(k pi x) tends to vanish), with the outward normal nu of the edge (boundary edges run
!> with the domain on their left, so nu = (t_y, -t_x) for the unit tangent t), and returns
!> DS_ERR_INPUT naming the first point where a condition fails by more than exact_bc_tol
!> relative to the scales of u and grad u: max|u| and max|grad u| over the nodes, the
!> centroids and the samples, and max|grad u| times the mesh diameter for u.  Points where
!> the gradient is not finite (a corner singularity) are skipped.
module dualsig_exact_boundary
  use dualsig_kinds, only: dp
  use dualsig_mesh, only: mesh_t, mesh_diameter
  use dualsig_fields, only: field_t, vector_field_t
  use dualsig_problem_kinds, only: PROBLEM_P1
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_strings, only: itoa, rtoa
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  implicit none
  private

  public :: exact_boundary_check, exact_bc_tol

  !> A condition holds when violated by at most this, relative to max|u| or max|grad u|
  !> (the expressions and scenes are exact up to rounding).
  real(dp), parameter :: exact_bc_tol = 1.0e-8_dp
  !> The sample points on each boundary edge (fractions of the edge from its first node):
  !> the Gauss points 1/2 -+ sqrt(15)/10 and 1/2.
  real(dp), parameter :: fractions(3) = [0.5_dp - sqrt(15.0_dp) / 10.0_dp, 0.5_dp, 0.5_dp + sqrt(15.0_dp) / 10.0_dp]

contains

  !> DS_ERR_INPUT in st when u_exact (gradient grad_exact) does not satisfy the boundary
  !> conditions of problem `kind` with the parts gamma_u (u = 0) and the rest of the
  !> boundary Signorini (see the module header).  `what` names u_exact in the message.
  subroutine exact_boundary_check(mesh, kind, gamma_u, u_exact, grad_exact, what, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: kind
    integer, intent(in) :: gamma_u(:)
    class(field_t), intent(in) :: u_exact
    class(vector_field_t), intent(in) :: grad_exact
    character(len=*), intent(in) :: what
    type(status_t), intent(inout) :: st
    real(dp) :: u_scale, g_scale
    call sample_scales(mesh, u_exact, grad_exact, u_scale, g_scale)
    if (.not. (u_scale > 0.0_dp)) return               ! u_exact = 0 on the boundary samples and nodes
    call check_edges(mesh, kind, gamma_u, u_exact, grad_exact, what, u_scale, g_scale, st)
  end subroutine exact_boundary_check

  !> max|u| and max|grad u| (where finite) over the nodes, the centroids and the boundary
  !> samples; u's scale at least max|grad u| times the mesh diameter.
  subroutine sample_scales(mesh, u_exact, grad_exact, u_scale, g_scale)
    type(mesh_t), intent(in) :: mesh
    class(field_t), intent(in) :: u_exact
    class(vector_field_t), intent(in) :: grad_exact
    real(dp), intent(out) :: u_scale, g_scale
    real(dp) :: p(2)
    integer :: i, j, k
    u_scale = 0.0_dp
    g_scale = 0.0_dp
    do i = 1, mesh%nnode
      call add_point(mesh%xy(:, i))
    end do
    do i = 1, mesh%ntri
      call add_point(sum(mesh%xy(:, mesh%tri(:, i)), dim=2) / 3.0_dp)
    end do
    do j = 1, mesh%nbedge
      do k = 1, size(fractions)
        p = edge_point(mesh, j, fractions(k))
        call add_point(p)
      end do
    end do
    u_scale = max(u_scale, g_scale * mesh_diameter(mesh))
  contains
    subroutine add_point(q)
      real(dp), intent(in) :: q(2)
      real(dp) :: v, g(2)
      v = u_exact%value(q(1), q(2))
      if (ieee_is_finite(v)) u_scale = max(u_scale, abs(v))
      g = grad_exact%value(q(1), q(2))
      if (all(ieee_is_finite(g))) g_scale = max(g_scale, norm2(g))
    end subroutine add_point
  end subroutine sample_scales

  !> The conditions at the samples of every boundary edge (module header).
  subroutine check_edges(mesh, kind, gamma_u, u_exact, grad_exact, what, u_scale, g_scale, st)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: kind
    integer, intent(in) :: gamma_u(:)
    class(field_t), intent(in) :: u_exact
    class(vector_field_t), intent(in) :: grad_exact
    character(len=*), intent(in) :: what
    real(dp), intent(in) :: u_scale, g_scale
    type(status_t), intent(inout) :: st
    real(dp) :: p(2), g(2), nu(2), t(2), u, dn, tol_u, tol_g
    integer :: j, k
    logical :: on_gamma_u
    character(len=:), allocatable :: fail
    tol_u = exact_bc_tol * u_scale
    tol_g = exact_bc_tol * g_scale
    do j = 1, mesh%nbedge
      on_gamma_u = kind /= PROBLEM_P1 .and. any(gamma_u == mesh%bedge_marker(j))
      t = mesh%xy(:, mesh%bedge_nodes(2, j)) - mesh%xy(:, mesh%bedge_nodes(1, j))
      t = t / norm2(t)
      nu = [t(2), -t(1)]
      do k = 1, size(fractions)
        p = edge_point(mesh, j, fractions(k))
        u = u_exact%value(p(1), p(2))
        fail = ''
        if (on_gamma_u) then
          if (.not. abs(u) <= tol_u) fail = 'u = ' // rtoa(u) // ' on Gamma_u (expected u = 0)'
        else
          g = grad_exact%value(p(1), p(2))
          if (.not. all(ieee_is_finite(g))) cycle
          dn = dot_product(g, nu)
          if (.not. u >= -tol_u) then
            fail = 'u = ' // rtoa(u) // ' < 0 on the Signorini part (expected u >= 0)'
          else if (.not. dn >= -tol_g) then
            fail = 'du/dnu = ' // rtoa(dn) // ' < 0 on the Signorini part (expected du/dnu >= 0)'
          else if (u > tol_u .and. dn > tol_g) then
            fail = 'u = ' // rtoa(u) // ' and du/dnu = ' // rtoa(dn) // ' both > 0 on the Signorini part ' // &
              '(expected u du/dnu = 0)'
          end if
        end if
        if (len(fail) > 0) then
          call set_error(st, DS_ERR_INPUT, what // ' does not satisfy the boundary conditions of this run at (' // &
            rtoa(p(1)) // ', ' // rtoa(p(2)) // ') on boundary marker ' // itoa(mesh%bedge_marker(j)) // ': ' // &
            fail // '; it solves another problem (another domain or other Gamma_u / Gamma_a), and its error ' // &
            'columns would be meaningless')
          return
        end if
      end do
    end do
  end subroutine check_edges

  !> The point at fraction s of boundary edge j from its first node.
  pure function edge_point(mesh, j, s) result(p)
    type(mesh_t), intent(in) :: mesh
    integer, intent(in) :: j
    real(dp), intent(in) :: s
    real(dp) :: p(2)
    p = (1.0_dp - s) * mesh%xy(:, mesh%bedge_nodes(1, j)) + s * mesh%xy(:, mesh%bedge_nodes(2, j))
  end function edge_point
end module dualsig_exact_boundary
