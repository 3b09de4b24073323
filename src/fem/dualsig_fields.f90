!> Interfaces of user-supplied functions of position: source terms, exact solutions
!> (not required to be pure: F77 callers pass ordinary EXTERNAL functions)
!> and their gradients.  Scenes and the F77 interface supply procedures of these shapes.
module dualsig_fields
  use dualsig_kinds, only: dp
  implicit none
  private

  public :: scalar_field, vector_field

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
end module dualsig_fields
