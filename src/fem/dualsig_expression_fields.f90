!> Fields given by compiled expressions (the expression language of `dualsig_expression`,
!> doc/expressions.md): a user's source f, boundary data g or exact solution u written as
!> text, and the gradient of u obtained from the same expression by automatic
!> differentiation.
!>
!> A value that is not finite (1/0, log(-1), sqrt(0)'s derivative) is returned as it is:
!> the caller checks the points it will use with `expression_check_finite` first and names
!> the point (and the triangle) in its message.
module dualsig_expression_fields
  use dualsig_kinds, only: dp
  use dualsig_fields, only: field_t, vector_field_t
  use dualsig_expression, only: expression_t, expression_value, expression_value_grad, expression_eval
  use dualsig_expression_range, only: expression_range
  implicit none
  private

  public :: expression_field_t, expression_gradient_t, expression_field, expression_gradient, expression_cost

  !> The scalar field of a compiled expression: value(x, y) = expression_value(expr, x, y).
  type, extends(field_t) :: expression_field_t
    type(expression_t) :: expr                   !! the compiled expression
  contains
    procedure :: value => expression_field_value
    procedure :: values_at => expression_field_values
    procedure :: range_on_triangle => expression_field_range
    procedure :: evaluation_cost => expression_field_cost
  end type expression_field_t

  !> Instructions of the expression machine that one unit of field_t%evaluation_cost stands
  !> for (a formula such as -2*pi**2*sin(pi*x)*sin(pi*y) takes 12).
  real(dp), parameter :: cost_unit_instructions = 64.0_dp

  !> The gradient of a compiled expression, by forward-mode automatic differentiation:
  !> value(x, y) = (d/dx, d/dy) of expr at (x, y).
  type, extends(vector_field_t) :: expression_gradient_t
    type(expression_t) :: expr                   !! the compiled expression (of u, not of grad u)
  contains
    procedure :: value => expression_gradient_value
  end type expression_gradient_t

contains

  !> The field of a compiled expression.
  function expression_field(expr) result(field)
    type(expression_t), intent(in) :: expr
    type(expression_field_t) :: field
    field%expr = expr
  end function expression_field

  !> The gradient field of a compiled expression.
  function expression_gradient(expr) result(field)
    type(expression_t), intent(in) :: expr
    type(expression_gradient_t) :: field
    field%expr = expr
  end function expression_gradient

  real(dp) function expression_field_value(self, x, y) result(v)
    class(expression_field_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    v = expression_value(self%expr, x, y)
  end function expression_field_value

  !> The values at many points, the expression run instruction by instruction over blocks of
  !> points (expression_eval: the same operations per point as expression_value).
  subroutine expression_field_values(self, x, y, v)
    class(expression_field_t), intent(in) :: self
    real(dp), intent(in) :: x(:), y(:)
    real(dp), intent(out) :: v(:)
    call expression_eval(self%expr, x, y, v)
  end subroutine expression_field_values

  !> An enclosure of the values on a triangle by interval arithmetic (expression_range); the
  !> whole real line where none is found.
  subroutine expression_field_range(self, tri, lo, hi, known, enough, rough)
    class(expression_field_t), intent(in) :: self
    real(dp), intent(in) :: tri(2, 3)
    real(dp), intent(out) :: lo, hi
    logical, intent(out) :: known
    real(dp), intent(in), optional :: enough(2)
    logical, intent(out), optional :: rough
    call expression_range(self%expr, tri, lo, hi, enough, rough)
    known = .true.
  end subroutine expression_field_range

  !> The cost of one evaluation (field_t%evaluation_cost): expression_cost of its expression.
  pure real(dp) function expression_field_cost(self) result(cost)
    class(expression_field_t), intent(in) :: self
    cost = expression_cost(self%expr)
  end function expression_field_cost

  !> The cost of one evaluation of expr in units of field_t%evaluation_cost: its number of
  !> instructions over cost_unit_instructions, at least 1.
  pure real(dp) function expression_cost(expr) result(cost)
    type(expression_t), intent(in) :: expr
    cost = max(1.0_dp, real(expr%n, dp) / cost_unit_instructions)
  end function expression_cost

  function expression_gradient_value(self, x, y) result(g)
    class(expression_gradient_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    real(dp) :: g(2)
    real(dp) :: v
    call expression_value_grad(self%expr, x, y, v, g)
  end function expression_gradient_value
end module dualsig_expression_fields
