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
!> rejected.
!>
!> No module state: every field is an object (dualsig_fields' field_t / vector_field_t) that
!> carries its rectangle (`stress_field_t`, `stress_gradient_t`) or its base field and scales
!> (`scaled_field_t`, `scaled_gradient_t`), so any number of stress scenes coexist.
!>
!> Test and driver support (drivers/support/, archive libdualsig_support.a): not part of the
!> installed library.
module dualsig_stress_problems
  use dualsig_kinds, only: dp, pi
  use dualsig_fields, only: field_t, vector_field_t
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_scenes, only: scene_t
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  implicit none
  private

  public :: stress_problem, stress_scaled_scene, stress_problem_names, cancel_offset
  public :: stress_field_t, stress_gradient_t, scaled_field_t, scaled_gradient_t

  character(len=*), parameter :: stress_problem_names = &
    'p2_full_contact, p2_no_contact, p1_full_contact, p1_offset, p2_zero_load, p1_zero_load'

  !> The constant part of 'p1_offset'.
  real(dp), parameter :: cancel_offset = 1.0e6_dp

  ! the manufactured solutions (which_problem of stress_field_t / stress_gradient_t)
  integer, parameter :: FULL2 = 1, NONE2 = 2, FULL1 = 3, OFFSET1 = 4, ZERO_LOAD = 5
  ! what a stress_field_t evaluates
  integer, parameter :: WHAT_F = 1, WHAT_U = 2

  !> f or u of a manufactured problem on (0,lx) x (0,ly).
  type, extends(field_t) :: stress_field_t
    integer :: which_problem = ZERO_LOAD
    integer :: what = WHAT_F
    real(dp) :: lx = 1.0_dp, ly = 1.0_dp
  contains
    procedure :: value => stress_field_value
  end type stress_field_t

  !> grad u of a manufactured problem on (0,lx) x (0,ly).
  type, extends(vector_field_t) :: stress_gradient_t
    integer :: which_problem = ZERO_LOAD
    real(dp) :: lx = 1.0_dp, ly = 1.0_dp
  contains
    procedure :: value => stress_gradient_value
  end type stress_gradient_t

  !> scale * base(x / l, y / l): the rescaled f (scale = s / L^2) or u (scale = s).
  type, extends(field_t) :: scaled_field_t
    class(field_t), allocatable :: base
    real(dp) :: scale = 1.0_dp
    real(dp) :: l = 1.0_dp
  contains
    procedure :: value => scaled_field_value
  end type scaled_field_t

  !> scale * base(x / l, y / l): the rescaled grad u (scale = s / L).
  type, extends(vector_field_t) :: scaled_gradient_t
    class(vector_field_t), allocatable :: base
    real(dp) :: scale = 1.0_dp
    real(dp) :: l = 1.0_dp
  contains
    procedure :: value => scaled_gradient_value
  end type scaled_gradient_t

contains

  !> The manufactured problem `name` on (0,rx) x (0,ry) (see the module header).
  subroutine stress_problem(name, rx, ry, scene, st)
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: rx, ry
    type(scene_t), intent(out) :: scene
    type(status_t), intent(out) :: st
    integer :: which
    if (.not. (rx > 0.0_dp .and. ry > 0.0_dp)) then
      call set_error(st, DS_ERR_INPUT, 'stress_problem: the rectangle sides must be positive')
      return
    end if
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
      which = FULL2
    case ('p2_no_contact')
      which = NONE2
    case ('p1_full_contact')
      which = FULL1
    case ('p1_offset')
      which = OFFSET1
    case default
      which = ZERO_LOAD
    end select
    allocate (scene%f, source=stress_field_t(which_problem=which, what=WHAT_F, lx=rx, ly=ry))
    allocate (scene%u, source=stress_field_t(which_problem=which, what=WHAT_U, lx=rx, ly=ry))
    allocate (scene%grad_u, source=stress_gradient_t(which_problem=which, lx=rx, ly=ry))
  end subroutine stress_problem

  !> The scene `base` (exact solution on the unit square) rescaled to u_s(x) = s u(x/L) on
  !> (0,L)^2 (see the module header); L must be 1 for P1.
  subroutine stress_scaled_scene(base, s, l, scene, st)
    type(scene_t), intent(in) :: base
    real(dp), intent(in) :: s, l
    type(scene_t), intent(out) :: scene
    type(status_t), intent(out) :: st
    type(scaled_field_t) :: sf, su
    type(scaled_gradient_t) :: sg
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
    ! f_s(x) = s / L^2 f(x / L) for P2; for P1 (L = 1) this is s f.
    allocate (sf%base, source=base%f)
    sf%scale = s / l**2
    sf%l = l
    allocate (su%base, source=base%u)
    su%scale = s
    su%l = l
    allocate (sg%base, source=base%grad_u)
    sg%scale = s / l
    sg%l = l
    ! (allocate with source=, not an intrinsic assignment to the polymorphic components:
    ! gfortran 12 allocates the declared type's size there and overruns the heap)
    scene = base
    deallocate (scene%f, scene%u, scene%grad_u)
    allocate (scene%f, source=sf)
    allocate (scene%u, source=su)
    allocate (scene%grad_u, source=sg)
    scene%domain = 'rectangle'
    scene%x_breaks = l * base%x_breaks
  end subroutine stress_scaled_scene

  ! ------------------------------------------------------------------ rescaled fields
  recursive real(dp) function scaled_field_value(self, x, y) result(v)
    class(scaled_field_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    v = self%scale * self%base%value(x / self%l, y / self%l)
  end function scaled_field_value

  recursive function scaled_gradient_value(self, x, y) result(g)
    class(scaled_gradient_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    g = self%scale * self%base%value(x / self%l, y / self%l)
  end function scaled_gradient_value

  ! ------------------------------------------------------------------ manufactured fields
  real(dp) function stress_field_value(self, x, y) result(v)
    class(stress_field_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    if (self%what == WHAT_U) then
      select case (self%which_problem)
      case (FULL2)
        v = full2_u(self%lx, self%ly, x, y)
      case (NONE2)
        v = none2_u(self%lx, self%ly, x, y)
      case (FULL1)
        v = full1_u(self%lx, self%ly, x, y)
      case (OFFSET1)
        v = offset1_u(self%lx, self%ly, x, y)
      case default
        v = zero_f(x, y)
      end select
    else
      select case (self%which_problem)
      case (FULL2)
        v = full2_f(self%lx, self%ly, x, y)
      case (NONE2)
        v = none2_f(self%lx, self%ly, x, y)
      case (FULL1)
        v = full1_f(self%lx, self%ly, x, y)
      case (OFFSET1)
        v = offset1_f(self%lx, self%ly, x, y)
      case default
        v = zero_f(x, y)
      end select
    end if
  end function stress_field_value

  function stress_gradient_value(self, x, y) result(g)
    class(stress_gradient_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    select case (self%which_problem)
    case (FULL2)
      g = full2_grad(self%lx, self%ly, x, y)
    case (NONE2)
      g = none2_grad(self%lx, self%ly, x, y)
    case (FULL1)
      g = full1_grad(self%lx, self%ly, x, y)
    case (OFFSET1)
      g = offset1_grad(self%lx, self%ly, x, y)
    case default
      g = zero_grad(x, y)
    end select
  end function stress_gradient_value

  ! ------------------------------------------------------------------ p2_full_contact
  pure real(dp) function full2_u(lx, ly, x, y) result(u)
    real(dp), intent(in) :: lx, ly, x, y
    u = -sin(pi * x / lx) * y * (ly - y) / ly**2
  end function full2_u

  pure function full2_grad(lx, ly, x, y) result(g)
    real(dp), intent(in) :: lx, ly, x, y
    real(dp) :: g(2)
    g(1) = -pi / lx * cos(pi * x / lx) * y * (ly - y) / ly**2
    g(2) = -sin(pi * x / lx) * (ly - 2.0_dp * y) / ly**2
  end function full2_grad

  !> -Lap u = -S ((pi/lx)^2 g + 2 / ly^2), g = y (ly - y) / ly^2.
  pure real(dp) function full2_f(lx, ly, x, y) result(f)
    real(dp), intent(in) :: lx, ly, x, y
    f = -sin(pi * x / lx) * ((pi / lx)**2 * y * (ly - y) / ly**2 + 2.0_dp / ly**2)
  end function full2_f

  ! ------------------------------------------------------------------ p2_no_contact
  pure real(dp) function none2_u(lx, ly, x, y) result(u)
    real(dp), intent(in) :: lx, ly, x, y
    u = sin(pi * x / lx) * (1.0_dp - (y / ly)**2)
  end function none2_u

  pure function none2_grad(lx, ly, x, y) result(g)
    real(dp), intent(in) :: lx, ly, x, y
    real(dp) :: g(2)
    g(1) = pi / lx * cos(pi * x / lx) * (1.0_dp - (y / ly)**2)
    g(2) = -2.0_dp * sin(pi * x / lx) * y / ly**2
  end function none2_grad

  !> -Lap u = S ((pi/lx)^2 (1 - (y/ly)^2) + 2 / ly^2).
  pure real(dp) function none2_f(lx, ly, x, y) result(f)
    real(dp), intent(in) :: lx, ly, x, y
    f = sin(pi * x / lx) * ((pi / lx)**2 * (1.0_dp - (y / ly)**2) + 2.0_dp / ly**2)
  end function none2_f

  ! ------------------------------------------------------------------ p1_full_contact
  pure real(dp) function full1_u(lx, ly, x, y) result(u)
    real(dp), intent(in) :: lx, ly, x, y
    u = -sin(pi * x / lx) * sin(pi * y / ly)
  end function full1_u

  pure function full1_grad(lx, ly, x, y) result(g)
    real(dp), intent(in) :: lx, ly, x, y
    real(dp) :: g(2)
    g(1) = -pi / lx * cos(pi * x / lx) * sin(pi * y / ly)
    g(2) = -pi / ly * sin(pi * x / lx) * cos(pi * y / ly)
  end function full1_grad

  !> -Lap u + u = ((pi/lx)^2 + (pi/ly)^2 + 1) u.
  pure real(dp) function full1_f(lx, ly, x, y) result(f)
    real(dp), intent(in) :: lx, ly, x, y
    f = ((pi / lx)**2 + (pi / ly)**2 + 1.0_dp) * full1_u(lx, ly, x, y)
  end function full1_f

  ! ------------------------------------------------------------------ p1_offset
  pure real(dp) function offset1_u(lx, ly, x, y) result(u)
    real(dp), intent(in) :: lx, ly, x, y
    u = cancel_offset + cos(pi * x / lx) * cos(pi * y / ly)
  end function offset1_u

  pure function offset1_grad(lx, ly, x, y) result(g)
    real(dp), intent(in) :: lx, ly, x, y
    real(dp) :: g(2)
    g(1) = -pi / lx * sin(pi * x / lx) * cos(pi * y / ly)
    g(2) = -pi / ly * cos(pi * x / lx) * sin(pi * y / ly)
  end function offset1_grad

  !> -Lap u + u = cancel_offset + ((pi/lx)^2 + (pi/ly)^2 + 1) C(x) cos(pi y / ly).
  pure real(dp) function offset1_f(lx, ly, x, y) result(f)
    real(dp), intent(in) :: lx, ly, x, y
    f = cancel_offset + ((pi / lx)**2 + (pi / ly)**2 + 1.0_dp) * cos(pi * x / lx) * cos(pi * y / ly)
  end function offset1_f

  ! ------------------------------------------------------------------ zero load
  pure real(dp) function zero_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = 0.0_dp * (x + y)
  end function zero_f

  pure function zero_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    g = 0.0_dp * (x + y)
  end function zero_grad
end module dualsig_stress_problems
