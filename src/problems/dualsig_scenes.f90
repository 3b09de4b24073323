!> Catalogue of problems ("scenes"): source term, problem kind, default boundary parts,
!> and, where known, the exact solution and its gradient.
!>
!> Manufactured solutions live on the unit square (0,1)^2 with the rectangle generator's
!> markers 1 bottom (y = 0), 2 right, 3 top, 4 left.  On the bottom side they have a
!> contact part x < c (u = 0, du/dnu > 0) and a separation part x > c (u > 0,
!> du/dnu = 0), with the transition c = 1/3, which is never a node of a dyadically
!> refined mesh, so it lies strictly inside an edge on every level.  The outward normal
!> on the bottom is nu = (0, -1), so du/dnu = -du/dy there.
!>
!> Building blocks (a_+ = max(a, 0)):
!>   T_a(x) = (x - c)_+^3 (a - x),       S(x) = x^2 (c - x)_+^3,
!>   z(y) = (1 - y)^2 (1 + 2 y),         w(y) = -y (1 - y)^2,     Y(y) = y^2 (3 - 2 y),
!> with z(0) = 1, z'(0) = z'(1) = z(1) = 0; w(0) = w(1) = w'(1) = 0, w'(0) = -1;
!> Y(0) = Y'(0) = Y'(1) = 0, Y(1) = 1.
!>
!> p1_contact (problem P1: -Lap u + u = f, Signorini on all of Gamma):
!>   u = A0 Y(y) + A1 T_a(x) z(y) + A2 S(x) w(y),  a = (4 - c)/3 so that T_a'(1) = 0.
!>   Bottom: u = A1 T_a >= 0, du/dnu = A2 S >= 0, and T_a S = 0.  Left, right, top:
!>   u >= 0 and du/dnu = 0 (separation).
!> p2_contact (problem P2: -Lap u = f, u = 0 on Gamma_u = sides 2,3,4, Signorini on the
!>   bottom): u = B1 T_1(x) z(y) + B2 S(x) w(y).  Bottom: u = B1 T_1 >= 0,
!>   du/dnu = B2 S >= 0, complementary.
!> p1_jump, p2_jump: the same plus A J(x) B(y) with J(x) = (x - d)_+^2 (1 - x)^2 and
!>   B(y) = y^2 (1 - y)^2, d = 0.6: the term and its normal derivative vanish on all of the
!>   boundary, so the Signorini conditions are those of p1_contact / p2_contact, while J'' jumps
!>   by 2 (1 - d)^2 at x = d: f jumps across a line that cuts triangles on every dyadic mesh.
!> f is derived by hand from these formulas; the test suite checks f against finite
!> differences of u and the Signorini conditions along the boundary.
module dualsig_scenes
  use dualsig_kinds, only: dp, pi
  use dualsig_fields, only: field_t, vector_field_t, function_field, function_vector_field
  use dualsig_status, only: status_t, set_error, DS_ERR_INPUT
  use dualsig_problem_kinds, only: PROBLEM_P1, PROBLEM_P2
  implicit none
  private

  public :: scene_t, scene_lookup, scene_names, max_markers, PROBLEM_P1, PROBLEM_P2

  integer, parameter :: max_markers = 16 !! length of the marker lists

  real(dp), parameter :: c = 1.0_dp / 3.0_dp            !! contact/separation transition
  real(dp), parameter :: a_p1 = (4.0_dp - c) / 3.0_dp   !! makes T_a'(1) = 0
  real(dp), parameter :: amp0 = 0.5_dp, amp1 = 10.0_dp, amp2 = 5000.0_dp
  !> p1_jump, p2_jump: the line x = d where f jumps (not a node of a dyadic mesh) and the
  !> amplitude of the jump term A J(x) B(y).
  real(dp), parameter :: d_jump = 0.6_dp, amp_jump = 1000.0_dp

  character(len=*), parameter :: scene_names = &
    'p1_contact, p2_contact, p1_jump, p2_jump, p1_lshape_load, p2_lshape_load, p2_holed_load, ' // &
    'p2_lshape_corner'

  type :: scene_t
    character(len=32) :: name = ''
    integer :: problem = PROBLEM_P2
    logical :: has_exact = .false.
    character(len=16) :: domain = ''           !! 'unit_square' when the exact solution needs it
    integer :: gamma_u_markers(max_markers) = 0 !! default Gamma_u markers (0 = unused slot)
    integer :: gamma_a_markers(max_markers) = 0 !! default Gamma_a markers (0 = unused slot)
    character(len=160) :: description = ''
    integer :: nbreaks = 0                      !! abscissae x where f has a kink (may be 0)
    real(dp) :: x_breaks(4) = 0.0_dp            !! used to split the line integrals of lambda_bar
    class(field_t), allocatable :: f
    class(field_t), allocatable :: u
    class(vector_field_t), allocatable :: grad_u
  end type scene_t

contains

  !> The scene called `name` (case-sensitive), or DS_ERR_INPUT listing the valid names.
  subroutine scene_lookup(name, scene, st)
    character(len=*), intent(in) :: name
    type(scene_t), intent(out) :: scene
    type(status_t), intent(out) :: st
    scene%name = name
    select case (trim(name))
    case ('p1_contact')
      scene%problem = PROBLEM_P1
      scene%has_exact = .true.
      scene%domain = 'unit_square'
      scene%gamma_a_markers(1:4) = [1, 2, 3, 4]
      scene%description = 'P1 on (0,1)^2, manufactured: contact for x<1/3, separation for x>1/3 on y=0'
      scene%nbreaks = 1
      scene%x_breaks(1) = c                     ! f is continuous with a kink at x = c
      allocate (scene%f, source=function_field(p1_contact_f))   ! small: a field object
      allocate (scene%u, source=function_field(p1_contact_u))   ! small: a field object
      allocate (scene%grad_u, source=function_vector_field(p1_contact_grad))   ! small: a field object
    case ('p2_contact')
      scene%problem = PROBLEM_P2
      scene%has_exact = .true.
      scene%domain = 'unit_square'
      scene%gamma_a_markers(1) = 1
      scene%gamma_u_markers(1:3) = [2, 3, 4]
      scene%description = 'P2 on (0,1)^2, manufactured: Signorini on y=0 (contact x<1/3), u=0 elsewhere'
      scene%nbreaks = 1
      scene%x_breaks(1) = c
      allocate (scene%f, source=function_field(p2_contact_f))   ! small: a field object
      allocate (scene%u, source=function_field(p2_contact_u))   ! small: a field object
      allocate (scene%grad_u, source=function_vector_field(p2_contact_grad))   ! small: a field object
    case ('p1_jump')
      scene%problem = PROBLEM_P1
      scene%has_exact = .true.
      scene%domain = 'unit_square'
      scene%gamma_a_markers(1:4) = [1, 2, 3, 4]
      scene%description = 'P1 on (0,1)^2, manufactured as p1_contact plus a term whose f jumps across x = 0.6'
      scene%nbreaks = 2
      scene%x_breaks(1:2) = [c, d_jump]         ! a kink at x = c, a jump at x = d
      allocate (scene%f, source=function_field(p1_jump_f))   ! small: a field object
      allocate (scene%u, source=function_field(p1_jump_u))   ! small: a field object
      allocate (scene%grad_u, source=function_vector_field(p1_jump_grad))   ! small: a field object
    case ('p2_jump')
      scene%problem = PROBLEM_P2
      scene%has_exact = .true.
      scene%domain = 'unit_square'
      scene%gamma_a_markers(1) = 1
      scene%gamma_u_markers(1:3) = [2, 3, 4]
      scene%description = 'P2 on (0,1)^2, manufactured as p2_contact plus a term whose f jumps across x = 0.6'
      scene%nbreaks = 2
      scene%x_breaks(1:2) = [c, d_jump]
      allocate (scene%f, source=function_field(p2_jump_f))   ! small: a field object
      allocate (scene%u, source=function_field(p2_jump_u))   ! small: a field object
      allocate (scene%grad_u, source=function_vector_field(p2_jump_grad))   ! small: a field object
    case ('p1_lshape_load')
      scene%problem = PROBLEM_P1
      scene%gamma_a_markers(1:6) = [1, 2, 3, 4, 5, 6]
      scene%description = 'P1 on the L-shape, f = 4 - 10 (x^2 + y^2): contact set found by the solver'
      allocate (scene%f, source=function_field(lshape_p1_f))   ! small: a field object
    case ('p2_lshape_load')
      scene%problem = PROBLEM_P2
      scene%gamma_a_markers(1:3) = [1, 2, 3]
      scene%gamma_u_markers(1:3) = [4, 5, 6]
      scene%description = 'P2 on the L-shape, f = 20 x + 5 sin(pi y): Signorini on the lower sides'
      allocate (scene%f, source=function_field(lshape_p2_f))   ! small: a field object
    case ('p2_lshape_corner')
      ! (issue 14) a load that is positive at the re-entrant corner (a strong r^(2/3)
      ! singularity with Dirichlet sides there) and negative at the outer corners (contact
      ! and separation, with transitions, on the Signorini sides)
      scene%problem = PROBLEM_P2
      scene%gamma_u_markers(1:2) = [2, 3]
      scene%gamma_a_markers(1:4) = [1, 4, 5, 6]
      scene%description = 'P2 on the L-shape, f = 10 - 15 (x^2 + y^2): u = 0 on the re-entrant sides, ' // &
        'Signorini on the outer ones'
      allocate (scene%f, source=function_field(lshape_corner_f))   ! small: a field object
    case ('p2_holed_load')
      scene%problem = PROBLEM_P2
      scene%gamma_u_markers(1:2) = [4, 8]
      scene%gamma_a_markers(1:6) = [1, 2, 3, 5, 6, 7]
      scene%description = 'P2 on the square with a square hole, f = 10 cos(2 pi x) cos(2 pi y): ' // &
        'u = 0 on the left side of each loop, Signorini elsewhere'
      allocate (scene%f, source=function_field(holed_p2_f))   ! small: a field object
    case default
      call set_error(st, DS_ERR_INPUT, 'unknown scene "' // trim(name) // '"; expected one of: ' &
                     // scene_names)
    end select
  end subroutine scene_lookup

  ! ------------------------------------------------------------------ building blocks
  !> T_a(x) = (x - c)_+^3 (a - x) and its first two derivatives.
  pure subroutine t_block(a, x, t, t1, t2)
    real(dp), intent(in) :: a, x
    real(dp), intent(out) :: t, t1, t2
    real(dp) :: s
    s = max(x - c, 0.0_dp)
    t = s**3 * (a - x)
    t1 = s**2 * (3.0_dp * a + c - 4.0_dp * x)
    t2 = 6.0_dp * s * (a + c - 2.0_dp * x)
  end subroutine t_block

  !> S(x) = x^2 (c - x)_+^3 and its first two derivatives.
  pure subroutine s_block(x, s0, s1, s2)
    real(dp), intent(in) :: x
    real(dp), intent(out) :: s0, s1, s2
    real(dp) :: r
    r = max(c - x, 0.0_dp)
    s0 = x**2 * r**3
    s1 = x * r**2 * (2.0_dp * c - 5.0_dp * x)
    s2 = r * (2.0_dp * c**2 - 16.0_dp * c * x + 20.0_dp * x**2)
  end subroutine s_block

  !> z(y) = (1-y)^2 (1+2y), w(y) = -y (1-y)^2, Y(y) = y^2 (3-2y) with two derivatives each.
  pure subroutine y_blocks(y, z, w, yy)
    real(dp), intent(in) :: y
    real(dp), intent(out) :: z(0:2), w(0:2), yy(0:2)
    z = [1.0_dp - 3.0_dp * y**2 + 2.0_dp * y**3, -6.0_dp * y + 6.0_dp * y**2, -6.0_dp + 12.0_dp * y]
    w = [-y + 2.0_dp * y**2 - y**3, -1.0_dp + 4.0_dp * y - 3.0_dp * y**2, 4.0_dp - 6.0_dp * y]
    yy = [3.0_dp * y**2 - 2.0_dp * y**3, 6.0_dp * y - 6.0_dp * y**2, 6.0_dp - 12.0_dp * y]
  end subroutine y_blocks

  !> J(x) = (x - d)_+^2 (1 - x)^2 and B(y) = y^2 (1 - y)^2 with two derivatives each.
  pure subroutine jump_blocks(x, y, j, b)
    real(dp), intent(in) :: x, y
    real(dp), intent(out) :: j(0:2), b(0:2)
    real(dp) :: r
    r = max(x - d_jump, 0.0_dp)
    j = 0.0_dp
    if (x > d_jump) j = [r**2 * (1.0_dp - x)**2, 2.0_dp * r * (1.0_dp - x)**2 - 2.0_dp * r**2 * (1.0_dp - x), &
                         2.0_dp * (1.0_dp - x)**2 - 8.0_dp * r * (1.0_dp - x) + 2.0_dp * r**2]
    b = [y**2 * (1.0_dp - y)**2, 2.0_dp * y * (1.0_dp - y) * (1.0_dp - 2.0_dp * y), &
         2.0_dp * (1.0_dp - 6.0_dp * y + 6.0_dp * y**2)]
  end subroutine jump_blocks

  pure real(dp) function p1_jump_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    real(dp) :: j(0:2), b(0:2)
    call jump_blocks(x, y, j, b)
    u = p1_contact_u(x, y) + amp_jump * j(0) * b(0)
  end function p1_jump_u

  pure function p1_jump_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    real(dp) :: j(0:2), b(0:2)
    call jump_blocks(x, y, j, b)
    g = p1_contact_grad(x, y) + amp_jump * [j(1) * b(0), j(0) * b(1)]
  end function p1_jump_grad

  !> f = -Lap u + u for p1_jump.
  pure real(dp) function p1_jump_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    real(dp) :: j(0:2), b(0:2)
    call jump_blocks(x, y, j, b)
    f = p1_contact_f(x, y) + amp_jump * (-(j(2) * b(0) + j(0) * b(2)) + j(0) * b(0))
  end function p1_jump_f

  pure real(dp) function p2_jump_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    real(dp) :: j(0:2), b(0:2)
    call jump_blocks(x, y, j, b)
    u = p2_contact_u(x, y) + amp_jump * j(0) * b(0)
  end function p2_jump_u

  pure function p2_jump_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    real(dp) :: j(0:2), b(0:2)
    call jump_blocks(x, y, j, b)
    g = p2_contact_grad(x, y) + amp_jump * [j(1) * b(0), j(0) * b(1)]
  end function p2_jump_grad

  !> f = -Lap u for p2_jump.
  pure real(dp) function p2_jump_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    real(dp) :: j(0:2), b(0:2)
    call jump_blocks(x, y, j, b)
    f = p2_contact_f(x, y) - amp_jump * (j(2) * b(0) + j(0) * b(2))
  end function p2_jump_f

  ! ------------------------------------------------------------------ p1_contact
  pure real(dp) function p1_contact_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    real(dp) :: t(0:2), s(0:2), z(0:2), w(0:2), yy(0:2)
    call t_block(a_p1, x, t(0), t(1), t(2))
    call s_block(x, s(0), s(1), s(2))
    call y_blocks(y, z, w, yy)
    u = amp0 * yy(0) + amp1 * t(0) * z(0) + amp2 * s(0) * w(0)
  end function p1_contact_u

  pure function p1_contact_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    real(dp) :: t(0:2), s(0:2), z(0:2), w(0:2), yy(0:2)
    call t_block(a_p1, x, t(0), t(1), t(2))
    call s_block(x, s(0), s(1), s(2))
    call y_blocks(y, z, w, yy)
    g(1) = amp1 * t(1) * z(0) + amp2 * s(1) * w(0)
    g(2) = amp0 * yy(1) + amp1 * t(0) * z(1) + amp2 * s(0) * w(1)
  end function p1_contact_grad

  !> f = -Lap u + u for p1_contact.
  pure real(dp) function p1_contact_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    real(dp) :: t(0:2), s(0:2), z(0:2), w(0:2), yy(0:2), lap
    call t_block(a_p1, x, t(0), t(1), t(2))
    call s_block(x, s(0), s(1), s(2))
    call y_blocks(y, z, w, yy)
    lap = amp0 * yy(2) + amp1 * (t(2) * z(0) + t(0) * z(2)) + amp2 * (s(2) * w(0) + s(0) * w(2))
    f = -lap + p1_contact_u(x, y)
  end function p1_contact_f

  ! ------------------------------------------------------------------ p2_contact
  pure real(dp) function p2_contact_u(x, y) result(u)
    real(dp), intent(in) :: x, y
    real(dp) :: t(0:2), s(0:2), z(0:2), w(0:2), yy(0:2)
    call t_block(1.0_dp, x, t(0), t(1), t(2))
    call s_block(x, s(0), s(1), s(2))
    call y_blocks(y, z, w, yy)
    u = amp1 * t(0) * z(0) + amp2 * s(0) * w(0)
  end function p2_contact_u

  pure function p2_contact_grad(x, y) result(g)
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    real(dp) :: t(0:2), s(0:2), z(0:2), w(0:2), yy(0:2)
    call t_block(1.0_dp, x, t(0), t(1), t(2))
    call s_block(x, s(0), s(1), s(2))
    call y_blocks(y, z, w, yy)
    g(1) = amp1 * t(1) * z(0) + amp2 * s(1) * w(0)
    g(2) = amp1 * t(0) * z(1) + amp2 * s(0) * w(1)
  end function p2_contact_grad

  !> f = -Lap u for p2_contact.
  pure real(dp) function p2_contact_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    real(dp) :: t(0:2), s(0:2), z(0:2), w(0:2), yy(0:2)
    call t_block(1.0_dp, x, t(0), t(1), t(2))
    call s_block(x, s(0), s(1), s(2))
    call y_blocks(y, z, w, yy)
    f = -(amp1 * (t(2) * z(0) + t(0) * z(2)) + amp2 * (s(2) * w(0) + s(0) * w(2)))
  end function p2_contact_f

  ! ------------------------------------------------------------------ scenes without exact solution
  pure real(dp) function lshape_p1_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = 4.0_dp - 10.0_dp * (x**2 + y**2)
  end function lshape_p1_f

  pure real(dp) function lshape_p2_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = 20.0_dp * x + 5.0_dp * sin(pi * y)
  end function lshape_p2_f

  pure real(dp) function lshape_corner_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = 10.0_dp - 15.0_dp * (x**2 + y**2)
  end function lshape_corner_f

  pure real(dp) function holed_p2_f(x, y) result(f)
    real(dp), intent(in) :: x, y
    f = 10.0_dp * cos(2.0_dp * pi * x) * cos(2.0_dp * pi * y)
  end function holed_p2_f
end module dualsig_scenes
