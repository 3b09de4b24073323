!> Small string helpers for messages and tables.
module dualsig_strings
  use dualsig_kinds, only: dp, i8
  implicit none
  private

  public :: itoa, i8toa, rtoa, lower, distinct_text

  !> Most significant digits ever needed for a real(dp) to read back exactly.
  integer, parameter :: max_digits = 17

contains

  !> Decimal form of an integer without blanks.
  pure function itoa(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write (buf, '(i0)') i
    s = trim(buf)
  end function itoa

  !> Decimal form of a 64-bit integer without blanks.
  pure function i8toa(i) result(s)
    integer(i8), intent(in) :: i
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write (buf, '(i0)') i
    s = trim(buf)
  end function i8toa

  !> The shortest scientific form of x that reads back to the same value; a zero exponent
  !> is dropped (1.5E+000 -> 1.5).
  function rtoa(x) result(s)
    real(dp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=40) :: buf, fmt
    real(dp) :: back
    integer :: d, ios
    do d = 1, max_digits
      write (fmt, '(a,i0,a,i0,a)') '(es', d + 8, '.', d, 'e3)'
      write (buf, fmt) x
      read (buf, *, iostat=ios) back
      if (ios == 0 .and. back == x) exit
    end do
    s = trim(adjustl(buf))
    if (index(s, 'E+000') > 0) s = s(1:index(s, 'E+000') - 1)
  end function rtoa

  !> The distinct values of v, ascending, separated by blanks ('' when v is empty).
  pure function distinct_text(v) result(s)
    integer, intent(in) :: v(:)
    character(len=:), allocatable :: s
    integer :: lo
    s = ''
    if (size(v) == 0) return
    lo = minval(v)
    do
      s = s // ' ' // itoa(lo)
      if (.not. any(v > lo)) exit
      lo = minval(v, mask=v > lo)
    end do
    s = s(2:)
  end function distinct_text

  !> s with ASCII upper-case letters turned to lower case.
  pure function lower(s) result(t)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: t
    integer :: k
    t = s
    do k = 1, len(s)
      if (s(k:k) >= 'A' .and. s(k:k) <= 'Z') t(k:k) = achar(iachar(s(k:k)) + 32)
    end do
  end function lower
end module dualsig_strings
