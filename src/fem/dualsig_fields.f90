!> Functions of position: source terms, exact solutions and their gradients.
!>
!> A field is an object with a type-bound `value`, so that it can carry its own data (an
!> amplitude, a scale, a compiled expression, a table of values): no module needs `save`
!> state to pass parameters to a source term.  Every library routine takes
!> `class(field_t)` / `class(vector_field_t)`.
!>
!> Plain functions of (x, y) (F77 callers' EXTERNAL functions, the scene catalogue) are
!> wrapped by `function_field(fn)` / `function_vector_field(fn)`; they need not be pure.
module dualsig_fields
  use dualsig_kinds, only: dp
  implicit none
  private

  public :: scalar_field, vector_field
  public :: field_t, vector_field_t, function_field_t, function_vector_field_t
  public :: function_field, function_vector_field

  abstract interface
    !> A scalar function of the point (x, y).
    real(dp) function scalar_field(x, y)
      import :: dp
      real(dp), intent(in) :: x, y
    end function scalar_field

    !> A vector function of the point (x, y), e.g. the gradient of an exact solution.
    function vector_field(x, y) result(v)
      import :: dp
      real(dp), intent(in) :: x, y
      real(dp) :: v(2)
    end function vector_field
  end interface

  !> A scalar field of position: f%value(x, y); f%values_at(x, y, v) at many points at once
  !> (v(i) = f%value(x(i), y(i)); a field whose evaluation has a per-call overhead, such as
  !> a compiled expression, overrides it); f%range_on_triangle(tri, lo, hi, known[, enough,
  !> rough]): lo <= f <= hi on the triangle when known (a field that can enclose its values, such as a compiled
  !> expression by interval arithmetic, overrides the default known = .false.), and rough
  !> where f may have a kink or a jump inside the triangle;
  !> f%evaluation_cost(): the cost of one evaluation in units of a short formula's (1 by
  !> default; a compiled expression gives its length over 64 instructions),
  !> which the cubature divides its budget of pieces by.
  type, abstract :: field_t
  contains
    procedure(field_value), deferred :: value
    procedure :: values_at => field_values
    procedure :: range_on_triangle => field_range_on_triangle
    procedure :: evaluation_cost => field_evaluation_cost
  end type field_t

  !> A vector field of position: g%value(x, y) of size 2.
  type, abstract :: vector_field_t
  contains
    procedure(vector_field_value), deferred :: value
  end type vector_field_t

  abstract interface
    real(dp) function field_value(self, x, y)
      import :: dp, field_t
      class(field_t), intent(in) :: self
      real(dp), intent(in) :: x, y
    end function field_value

    function vector_field_value(self, x, y) result(v)
      import :: dp, vector_field_t
      class(vector_field_t), intent(in) :: self
      real(dp), intent(in) :: x, y
      real(dp) :: v(2)
    end function vector_field_value
  end interface

  !> A scalar field given by a plain function of (x, y).
  type, extends(field_t) :: function_field_t
    procedure(scalar_field), pointer, nopass :: fn => null()
  contains
    procedure :: value => function_field_value
  end type function_field_t

  !> A vector field given by a plain function of (x, y).
  type, extends(vector_field_t) :: function_vector_field_t
    procedure(vector_field), pointer, nopass :: fn => null()
  contains
    procedure :: value => function_vector_field_value
  end type function_vector_field_t

contains

  !> v(i) = self%value(x(i), y(i)) for every i (the default of field_t%values_at).
  recursive subroutine field_values(self, x, y, v)
    class(field_t), intent(in) :: self
    real(dp), intent(in) :: x(:), y(:)
    real(dp), intent(out) :: v(:)
    integer :: i
    do i = 1, size(x)
      v(i) = self%value(x(i), y(i))
    end do
  end subroutine field_values

  !> No enclosure (the default of field_t%range_on_triangle): known = .false.
  subroutine field_range_on_triangle(self, tri, lo, hi, known, enough, rough)
    class(field_t), intent(in) :: self
    real(dp), intent(in) :: tri(2, 3)        !! the vertices
    real(dp), intent(out) :: lo, hi
    logical, intent(out) :: known
    real(dp), intent(in), optional :: enough(2)  !! an enclosure within this suffices (no sharper one needed)
    logical, intent(out), optional :: rough      !! f may kink or jump inside (known only)
    if (present(rough)) rough = .false.
    lo = -huge(1.0_dp)
    hi = huge(1.0_dp)
    known = .false.
  end subroutine field_range_on_triangle

  !> One unit (the default of field_t%evaluation_cost: a plain function's cost is not known).
  pure real(dp) function field_evaluation_cost(self) result(cost)
    class(field_t), intent(in) :: self
    cost = 1.0_dp
  end function field_evaluation_cost

  !> The field of the plain function fn.
  function function_field(fn) result(field)
    procedure(scalar_field) :: fn
    type(function_field_t) :: field
    field%fn => fn
  end function function_field

  !> The vector field of the plain function fn.
  function function_vector_field(fn) result(field)
    procedure(vector_field) :: fn
    type(function_vector_field_t) :: field
    field%fn => fn
  end function function_vector_field

  ! recursive: fn may itself evaluate a function field (an F77 source wrapping a scene's f)
  recursive real(dp) function function_field_value(self, x, y) result(v)
    class(function_field_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    v = self%fn(x, y)
  end function function_field_value

  recursive function function_vector_field_value(self, x, y) result(v)
    class(function_vector_field_t), intent(in) :: self
    real(dp), intent(in) :: x, y
    real(dp) :: v(2)
    v = self%fn(x, y)
  end function function_vector_field_value
end module dualsig_fields
