!> Checked allocation: the status of a failed `allocate` turned into an out-of-memory error.
!>
!> Every allocation of the library whose size comes from the input (mesh size, matrix
!> size, a count read from a file) is written
!>
!>     allocate (x(n), y(n), stat=ist)
!>     if (alloc_failed(ist, st, 'the load vector', 2 * n, BYTES_REAL)) return
!>
!> so that running out of memory is a DS_ERR_MEMORY status with a message such as
!> "out of memory allocating the stiffness matrix (3.2 GB)", never a runtime abort.
!> `alloc_check` is the same for pure procedures.  Allocations of a fixed small size
!> carry the comment `! small: ...` instead (tools/check_alloc.py checks both).
!>
module dualsig_alloc
  use, intrinsic :: iso_fortran_env, only: int32, int64
  use dualsig_status, only: status_t, set_alloc_error, is_error
  implicit none
  private

  public :: alloc_failed, alloc_check, has_failed, BYTES_REAL, BYTES_INT, BYTES_LOGICAL

  integer, parameter :: BYTES_REAL = 8      !! bytes of a real(dp)
  integer, parameter :: BYTES_INT = 4       !! bytes of a default integer
  integer, parameter :: BYTES_LOGICAL = 4   !! bytes of a default logical

  !> True, with `st` set to DS_ERR_MEMORY, when the allocation status `ist` is non-zero.
  interface alloc_failed
    module procedure alloc_failed_i32, alloc_failed_i64
  end interface alloc_failed

  !> Set `st` to DS_ERR_MEMORY when the allocation status `ist` is non-zero (pure).
  interface alloc_check
    module procedure alloc_check_i32, alloc_check_i64
  end interface alloc_check

contains

  !> alloc_failed for a default-integer element count.
  logical function alloc_failed_i32(ist, st, what, nelem, elem_bytes) result(failed)
    integer, intent(in) :: ist                  !! the stat= of the allocate
    type(status_t), intent(inout) :: st  !! set on failure, untouched otherwise
    character(len=*), intent(in) :: what        !! what was allocated ("the stiffness matrix")
    integer(int32), intent(in) :: nelem         !! number of elements requested (all arrays)
    integer, intent(in) :: elem_bytes           !! bytes per element (BYTES_REAL, ...)
    failed = ist /= 0
    if (failed) call report(st, int(nelem, int64) * elem_bytes, what)
  end function alloc_failed_i32

  !> alloc_failed for a 64-bit element count.
  logical function alloc_failed_i64(ist, st, what, nelem, elem_bytes) result(failed)
    integer, intent(in) :: ist                  !! the stat= of the allocate
    type(status_t), intent(inout) :: st  !! set on failure, untouched otherwise
    character(len=*), intent(in) :: what        !! what was allocated
    integer(int64), intent(in) :: nelem         !! number of elements requested (all arrays)
    integer, intent(in) :: elem_bytes           !! bytes per element
    failed = ist /= 0
    if (failed) call report(st, nelem * elem_bytes, what)
  end function alloc_failed_i64

  !> alloc_check for a default-integer element count.
  pure subroutine alloc_check_i32(ist, st, what, nelem, elem_bytes)
    integer, intent(in) :: ist                  !! the stat= of the allocate
    type(status_t), intent(inout) :: st  !! set on failure, untouched otherwise
    character(len=*), intent(in) :: what        !! what was allocated
    integer(int32), intent(in) :: nelem         !! number of elements requested
    integer, intent(in) :: elem_bytes           !! bytes per element
    if (ist /= 0) call report(st, int(nelem, int64) * elem_bytes, what)
  end subroutine alloc_check_i32

  !> alloc_check for a 64-bit element count.
  pure subroutine alloc_check_i64(ist, st, what, nelem, elem_bytes)
    integer, intent(in) :: ist                  !! the stat= of the allocate
    type(status_t), intent(inout) :: st  !! set on failure, untouched otherwise
    character(len=*), intent(in) :: what        !! what was allocated
    integer(int64), intent(in) :: nelem         !! number of elements requested
    integer, intent(in) :: elem_bytes           !! bytes per element
    if (ist /= 0) call report(st, nelem * elem_bytes, what)
  end subroutine alloc_check_i64

  !> True when st holds an error (a routine passes its status on to the routines it calls,
  !> then checks it with this).
  pure logical function has_failed(st)
    type(status_t), intent(in) :: st            !! the status
    has_failed = is_error(st)
  end function has_failed

  !> Set st to the out-of-memory error naming what was allocated and its size.
  pure subroutine report(st, nbytes, what)
    type(status_t), intent(inout) :: st         !! the caller's status
    integer(int64), intent(in) :: nbytes        !! size of the failed request
    character(len=*), intent(in) :: what        !! what was allocated
    call set_alloc_error(st, nbytes, what)
  end subroutine report
end module dualsig_alloc
