!> Error reporting for library code: a status code plus a message.
!>
!> One idiom everywhere: `is_ok(st)` (no error: success or a warning) decides whether to go
!> on; `is_error(st)` and `is_warning(st)` tell the two apart; codes are never compared
!> with literals.
!>
!> Library procedures never stop the program.  They take a `type(status_t), intent(out)`
!> argument, set `code` (0 = success) and, on failure, a message that names the file,
!> the item and what was expected.  The driver turns a non-zero code into an exit status.
module dualsig_status
  implicit none
  private

  public :: status_t, set_error, set_warning, is_ok, is_error, is_warning, set_alloc_error
  public :: DS_OK, DS_WARN_NOT_CONVERGED, DS_WARN_NOT_CERTIFIED, DS_ERR_INPUT, DS_ERR_MESH, DS_ERR_IO, &
            DS_ERR_NUMERIC, DS_ERR_LAPACK, DS_ERR_MEMORY

  !> Status codes.  Codes > 0 and < 100 are warnings (the result exists but is
  !> not fully trustworthy); codes >= 100 are errors (no result).
  integer, parameter :: DS_OK = 0                   !! success
  integer, parameter :: DS_WARN_NOT_CONVERGED = 1   !! iteration limit reached
  integer, parameter :: DS_WARN_NOT_CERTIFIED = 2   !! a bound was computed but is not guaranteed
  integer, parameter :: DS_ERR_INPUT = 100          !! invalid argument or namelist value
  integer, parameter :: DS_ERR_MESH = 101           !! malformed or unsupported mesh
  integer, parameter :: DS_ERR_IO = 102             !! file could not be read or written
  integer, parameter :: DS_ERR_NUMERIC = 103        !! breakdown, NaN, divergence
  integer, parameter :: DS_ERR_LAPACK = 104         !! LAPACK returned info /= 0
  integer, parameter :: DS_ERR_MEMORY = 105         !! an allocation failed (out of memory)

  type :: status_t
    integer :: code = DS_OK                     !! DS_OK, a warning or an error code
    character(len=:), allocatable :: msg        !! human-readable explanation
  end type status_t

contains

  !> Record an error (code >= 100) with its message.
  pure subroutine set_error(st, code, msg)
    type(status_t), intent(inout) :: st
    integer, intent(in) :: code
    character(len=*), intent(in) :: msg
    st%code = code
    st%msg = msg
  end subroutine set_error

  !> Record an out-of-memory error: "out of memory allocating <what> (<size>)", the size
  !> in B, KB, MB, GB or TB.  Every size-dependent allocation of the library has stat= and
  !> reports through this (dualsig_alloc).
  pure subroutine set_alloc_error(st, nbytes, what)
    use, intrinsic :: iso_fortran_env, only: int64
    type(status_t), intent(inout) :: st
    integer(int64), intent(in) :: nbytes             !! the size of the failed request
    character(len=*), intent(in) :: what             !! what it was for
    character(len=2), parameter :: unit(0:4) = ['B ', 'KB', 'MB', 'GB', 'TB']
    character(len=32) :: buf
    real :: x
    integer :: k
    x = real(max(nbytes, 0_int64))
    k = 0
    do while (x >= 1000.0 .and. k < 4)
      x = x / 1000.0
      k = k + 1
    end do
    if (k == 0 .or. x >= 100.0) then
      write (buf, '(i0)') nint(x)
    else
      write (buf, '(f0.1)') x
    end if
    st%code = DS_ERR_MEMORY
    st%msg = 'out of memory allocating ' // what // ' (' // trim(buf) // ' ' // trim(unit(k)) // ')'
  end subroutine set_alloc_error

  !> Record a warning unless an error is already recorded.
  pure subroutine set_warning(st, code, msg)
    type(status_t), intent(inout) :: st
    integer, intent(in) :: code
    character(len=*), intent(in) :: msg
    if (st%code >= DS_ERR_INPUT) return
    st%code = code
    st%msg = msg
  end subroutine set_warning

  !> True when no error was recorded (warnings count as ok).
  pure logical function is_ok(st)
    type(status_t), intent(in) :: st
    is_ok = st%code < DS_ERR_INPUT
  end function is_ok

  !> True when an error was recorded.
  pure logical function is_error(st)
    type(status_t), intent(in) :: st
    is_error = st%code >= DS_ERR_INPUT
  end function is_error

  !> True when a warning (and no error) was recorded.
  pure logical function is_warning(st)
    type(status_t), intent(in) :: st
    is_warning = st%code > DS_OK .and. st%code < DS_ERR_INPUT
  end function is_warning
end module dualsig_status
