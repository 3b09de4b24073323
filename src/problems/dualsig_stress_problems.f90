!> Problems for the stress suite (`make stress`), as scenes (dualsig_scenes' scene_t):
!> manufactured solutions with extreme contact sets on any rectangle, and the catalogue's
!> manufactured scenes rescaled.
!>
!> Manufactured problems on R = (0,lx) x (0,ly), S(x) = sin(pi x / lx), C(x) = cos(pi x / lx),
!> markers of mesh_rectangle (1 bottom, 2 right, 3 top, 4 left):
!> - 'p2_full_contact':  u = -S(x) y (ly - y) / ly^2, P2 with Gamma_a = 1, Gamma_u = 2,3,4.
!>   On the bottom u = 0 and du/dnu = -du/dy = S(x) / ly >= 0: contact on all of Gamma_a.
!> - 'p2_no_contact':    u = S(x) (1 - (y/ly)^2), P2 as above.  On the bottom u = S > 0 and
!>   du/dnu = 0: separation on all of Gamma_a (the constraint is never active inside it).
!> - 'p1_full_contact':  u = -S(x) sin(pi y / ly), P1.  u = 0 on Gamma and du/dnu =
!>   pi/lx S or pi/ly sin(pi y/ly) >= 0: contact on all of Gamma.
!> - 'p1_offset':        u = cancel_offset + C(x) cos(pi y / ly), P1.  u > 0 and du/dnu = 0 on
!>   Gamma (separation); the energy (f,u) ~ cancel_offset^2 |R| dwarfs the error, so the gap
!>   energy_hi - energy_lo cancels catastrophically (Remark 6.1).
!> - 'p2_zero_load', 'p1_zero_load': f = 0, u = 0.
!> f = -Lap u (P2) or -Lap u + u (P1), derived by hand from these formulas.
!>
!> Rescaled scenes (`stress_scaled_scene`): for a scene with exact solution u on the unit
!> square, u_s(x) = s u(x / L) on (0,L)^2.  For P2 (-Lap u = f) it solves the same problem
!> with f_s(x) = s / L^2 f(x / L), so relative errors and effectivities are invariant under
!> both s and L.  For P1 (-Lap u + u = f) only s is a symmetry (f_s = s f); L /= 1 is
!> rejected.  The wrapper keeps the base scene in module variables: one rescaled scene at
!> a time (a later call replaces the earlier one).
module dualsig_stress_problems
  use dualsig_kinds, only: dp, pi
  use dualsig_fields, only: scalar_field, vector_field
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_scenes, only: scene_t
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  implicit none
  private

  public :: stress_problem, stress_scaled_scene, stress_problem_names, cancel_offset

  character(len=*), parameter :: stress_problem_names = &
    'p2_full_contact, p2_no_contact, p1_full_contact, p1_offset, p2_zero_load, p1_zero_load'

  !> The constant part of 'p1_offset'.
  real(dp), parameter :: cancel_offset = 1.0e6_dp

  ! ---- state of the current problem (rectangle) and of the current rescaled scene
  real(dp), save :: lx = 1.0_dp, ly = 1.0_dp
  real(dp), save :: s_scale = 1.0_dp, l_scale = 1.0_dp
  procedure(scalar_field), pointer, save :: base_f => null(), base_u => null()
  procedure(vector_field), pointer, save :: base_grad => null()

contains

  !> The manufactured problem `name` on (0,rx) x (0,ry) (see the module header).  Replaces
  !> the rectangle of an earlier call (one rectangle at a time).
  subroutine stress_problem(name, rx, ry, scene, st)
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: rx, ry
    type(scene_t), intent(out) :: scene
    type(status_t), intent(out) :: st
    if (.not. (rx > 0.0_dp .and. ry > 0.0_dp)) then
      call set_error(st, DS_ERR_INPUT, 'stress_problem: the rectangle sides must be positive')
      return
    end if
    lx = rx
    ly = ry
    scene%name = name
    scene%has_exact = .true.
    scene%domain = 'rectangle'
    select case (trim(name))
    case ('p2_full_contact', 'p2_no_contact', 'p2_zero_load')
      scene%problem = PROBLEM_P2
      scene%gamma_a_markers(1) = 1
      scene%gamma_u_markers(1:3) = [2, 3, 4]
    case ('p1_full_contact', 'p1_offset', 'p1_zero_load')
      scene%problem = PROBLEM_P1
      scene%gamma_a_markers(1:4) = [1, 2, 3, 4]
    case default
      call set_error(st, DS_ERR_INPUT, 'unknown stress problem "' // trim(name) // '"; expected one of: ' // &
        stress_problem_names)
      return
    end select
    scene%description = 'stress problem ' // trim(name)
    select case (trim(name))
    case ('p2_full_contact')
      scene%f => full2_f
      scene%u => full2_u
      scene%grad_u => full2_grad
    case ('p2_no_contact')
      scene%f => none2_f
      scene%u => none2_u
      scene%grad_u => none2_grad
    case ('p1_full_contact')
      scene%f => full1_f
      scene%u => full1_u
      scene%grad_u => full1_grad
    case ('p1_offset')
      scene%f => offset1_f
      scene%u => offset1_u
      scene%grad_u => offset1_grad
    case default
      scene%f => zero_f
      scene%u => zero_f
      scene%grad_u => zero_grad
    end select
  end subroutine stress_problem

  !> The scene `base` (exact solution on the unit square) rescaled to u_s(x) = s u(x/L) on
  !> (0,L)^2 (see the module header); L must be 1 for P1.
  subroutine stress_scaled_scene(base, s, l, scene, st)
    type(scene_t), intent(in) :: base
    real(dp), intent(in) :: s, l
    type(scene_t), intent(out) :: scene
    type(status_t), intent(out) :: st
    if (.not. base%has_exact) then
      call set_error(st, DS_ERR_INPUT, 'stress_scaled_scene: scene ' // trim(base%name) // ' has no exact solution')
      return
    end if
    if (.not. (s > 0.0_dp .and. l > 0.0_dp)) then
      call set_error(st, DS_ERR_INPUT, 'stress_scaled_scene: expected s > 0 and L > 0')
      return
    end if
    if (base%problem == PROBLEM_P1 .and. l /= 1.0_dp) then
      call set_error(st, DS_ERR_INPUT, 'stress_scaled_scene: -Lap u + u = f (P1) is not invariant under ' // &
        'a change of length scale; only L = 1 is allowed for P1')
      return
    end if
    scene = base
    s_scale = s
    l_scale = l
    base_f => base%f
    base_u => base%u
    base_grad => base%grad_u
    scene%f => scaled_f
    scene%u => scaled_u
    scene%grad_u => scaled_grad
    scene%domain = 'rectangle'
    scene%x_breaks = l * base%x_breaks
  end subroutine stress_scaled_scene

  ! ------------------------------------------------------------------ rescaled scene
  !> f_s(x) = s / L^2 f(x / L) for P2; for P1 (L = 1) this is s f.
  real(dp) function scaled_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = s_scale / l_scale**2 * base_f(x / l_scale, y / l_scale)
  end function scaled_f

  real(dp) function scaled_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    u = s_scale * base_u(x / l_scale, y / l_scale)
  end function scaled_u

  function scaled_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    g = s_scale / l_scale * base_grad(x / l_scale, y / l_scale)
  end function scaled_grad

  ! ------------------------------------------------------------------ p2_full_contact
  real(dp) function full2_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    u = -sin(pi * x / lx) * y * (ly - y) / ly**2
  end function full2_u

  function full2_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    g(1) = -pi / lx * cos(pi * x / lx) * y * (ly - y) / ly**2
    g(2) = -sin(pi * x / lx) * (ly - 2.0_dp * y) / ly**2
  end function full2_grad

  !> -Lap u = -S ((pi/lx)^2 g + 2 / ly^2), g = y (ly - y) / ly^2.
  real(dp) function full2_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = -sin(pi * x / lx) * ((pi / lx)**2 * y * (ly - y) / ly**2 + 2.0_dp / ly**2)
  end function full2_f

  ! ------------------------------------------------------------------ p2_no_contact
  real(dp) function none2_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    u = sin(pi * x / lx) * (1.0_dp - (y / ly)**2)
  end function none2_u

  function none2_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    g(1) = pi / lx * cos(pi * x / lx) * (1.0_dp - (y / ly)**2)
    g(2) = -2.0_dp * sin(pi * x / lx) * y / ly**2
  end function none2_grad

  !> -Lap u = S ((pi/lx)^2 (1 - (y/ly)^2) + 2 / ly^2).
  real(dp) function none2_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = sin(pi * x / lx) * ((pi / lx)**2 * (1.0_dp - (y / ly)**2) + 2.0_dp / ly**2)
  end function none2_f

  ! ------------------------------------------------------------------ p1_full_contact
  real(dp) function full1_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    u = -sin(pi * x / lx) * sin(pi * y / ly)
  end function full1_u

  function full1_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    g(1) = -pi / lx * cos(pi * x / lx) * sin(pi * y / ly)
    g(2) = -pi / ly * sin(pi * x / lx) * cos(pi * y / ly)
  end function full1_grad

  !> -Lap u + u = ((pi/lx)^2 + (pi/ly)^2 + 1) u.
  real(dp) function full1_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = ((pi / lx)**2 + (pi / ly)**2 + 1.0_dp) * full1_u(x, y)
  end function full1_f

  ! ------------------------------------------------------------------ p1_offset
  real(dp) function offset1_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    u = cancel_offset + cos(pi * x / lx) * cos(pi * y / ly)
  end function offset1_u

  function offset1_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    g(1) = -pi / lx * sin(pi * x / lx) * cos(pi * y / ly)
    g(2) = -pi / ly * cos(pi * x / lx) * sin(pi * y / ly)
  end function offset1_grad

  !> -Lap u + u = cancel_offset + ((pi/lx)^2 + (pi/ly)^2 + 1) C(x) cos(pi y / ly).
  real(dp) function offset1_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = cancel_offset + ((pi / lx)**2 + (pi / ly)**2 + 1.0_dp) * cos(pi * x / lx) * cos(pi * y / ly)
  end function offset1_f

  ! ------------------------------------------------------------------ zero load
  real(dp) function zero_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = 0.0_dp * (x + y)
  end function zero_f

  function zero_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    g = 0.0_dp * (x + y)
  end function zero_grad
end module dualsig_stress_problems
