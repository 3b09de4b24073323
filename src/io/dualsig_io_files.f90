!> Small file-system helpers: existence, atomic replacement, deletion, directories.
!>
!> Output files are written under a temporary name and renamed over the target only
!> when complete (`file_commit`), so a failed run leaves no half-written file and does
!> not overwrite an earlier result.
module dualsig_io_files
  use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char
  use dualsig_status, only: status_t, set_error, DS_ERR_IO
  implicit none
  private

  public :: file_exists, file_delete, file_commit, ensure_parent_dir, temp_name

  interface
    integer(c_int) function c_rename(old, new) bind(c, name='rename')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: old(*), new(*)
    end function c_rename
    integer(c_int) function c_mkdir(path, mode) bind(c, name='mkdir')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int), value :: mode
    end function c_mkdir
  end interface

  integer(c_int), parameter :: dir_mode = int(o'755', c_int)   !! permissions of new directories

contains

  !> True when `path` names an existing file.
  logical function file_exists(path)
    character(len=*), intent(in) :: path
    inquire (file=path, exist=file_exists)
  end function file_exists

  !> The temporary name under which `path` is written before file_commit.
  pure function temp_name(path) result(tmp)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: tmp
    tmp = trim(path) // '.part'
  end function temp_name

  !> Delete `path` if it exists (errors are ignored: used for clean-up).
  subroutine file_delete(path)
    character(len=*), intent(in) :: path
    integer :: u, ios
    if (.not. file_exists(path)) return
    open (newunit=u, file=path, status='old', iostat=ios)
    if (ios == 0) close (u, status='delete', iostat=ios)
  end subroutine file_delete

  !> Rename temp_name(path) to path, replacing an existing file atomically.
  subroutine file_commit(path, st)
    character(len=*), intent(in) :: path
    type(status_t), intent(out) :: st
    if (c_rename(trim(temp_name(path)) // c_null_char, trim(path) // c_null_char) /= 0) then
      call set_error(st, DS_ERR_IO, 'cannot rename ' // temp_name(path) // ' to ' // trim(path))
    end if
  end subroutine file_commit

  !> Create the directories leading to the file `path` (like mkdir -p of its dirname).
  subroutine ensure_parent_dir(path, st)
    character(len=*), intent(in) :: path
    type(status_t), intent(out) :: st
    integer :: k
    integer(c_int) :: rc
    logical :: there
    do k = 2, len_trim(path)
      if (path(k:k) /= '/') cycle
      inquire (file=path(1:k - 1) // '/.', exist=there)
      if (there) cycle
      rc = c_mkdir(path(1:k - 1) // c_null_char, dir_mode)
      inquire (file=path(1:k - 1) // '/.', exist=there)
      if (.not. there) then
        call set_error(st, DS_ERR_IO, 'cannot create the output directory ' // path(1:k - 1))
        return
      end if
    end do
  end subroutine ensure_parent_dir
end module dualsig_io_files
