!> File-system helpers: checked output files, per-process temporary names, commits of a set
!> of files with roll-back, deletion, directories, clean-up on signals.
!>
!> Output files are written under a temporary name (`temp_name`: the target name, the
!> process id and `.part`) through `text_open` / `text_put` / `text_close`, which go through
!> C stdio (dualsig_io_posix.c) because gfortran 12 drops write errors: every write, the
!> flush, the fsync and the close are checked, and a failure removes the temporary file and
!> names the target in the message.  `file_commit_all` renames the temporary files of a run
!> over their targets as a set: a failed rename restores the files already replaced from
!> their backups (hard links made just before), so either all targets are new or all are
!> as before.  SIGINT, SIGTERM and SIGHUP are held during the commit.
!>
!> Every temporary file is registered with the signal handler of `cleanup_on_signals`,
!> which removes the registered files before the process dies of the signal.
module dualsig_io_files
  use, intrinsic :: iso_c_binding, only: c_int, c_char, c_null_char, c_ptr, c_null_ptr, c_associated, c_size_t, &
                                         c_long_long
  use dualsig_kinds, only: dp, i8
  use dualsig_status, only: status_t, set_error, DS_ERR_IO
  use dualsig_strings, only: itoa
  implicit none
  private

  public :: file_exists, file_delete, file_commit, file_commit_all, ensure_parent_dir, temp_name
  public :: text_file_t, text_open, text_put, text_close, text_abandon
  public :: cleanup_on_signals, temp_files_registered, errno_text, memory_available_gb
  public :: regular_file_size, same_file, input_file_ok

  !> An output file being written under its temporary name.
  type :: text_file_t
    type(c_ptr) :: fp = c_null_ptr                 !! the C stream (FILE *)
    character(len=:), allocatable :: path          !! the target (committed name)
    integer :: err = 0                             !! errno of the first failed write, 0 if none
  end type text_file_t

  interface
    integer(c_int) function c_process_id() bind(c, name='dualsig_process_id')
      import :: c_int
    end function c_process_id
    type(c_ptr) function c_open(path, err) bind(c, name='dualsig_file_open')
      import :: c_ptr, c_char, c_int
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int), intent(out) :: err
    end function c_open
    integer(c_int) function c_write(fp, buf, n) bind(c, name='dualsig_file_write')
      import :: c_ptr, c_char, c_int, c_size_t
      type(c_ptr), value :: fp
      character(kind=c_char), intent(in) :: buf(*)
      integer(c_size_t), value :: n
    end function c_write
    integer(c_int) function c_close(fp) bind(c, name='dualsig_file_close')
      import :: c_ptr, c_int
      type(c_ptr), value :: fp
    end function c_close
    integer(c_int) function c_rename(old, new) bind(c, name='dualsig_file_rename')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: old(*), new(*)
    end function c_rename
    integer(c_int) function c_link(old, new) bind(c, name='dualsig_file_link')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: old(*), new(*)
    end function c_link
    integer(c_int) function c_unlink(path) bind(c, name='dualsig_file_unlink')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
    end function c_unlink
    integer(c_int) function c_errno_text(err, buf, n) bind(c, name='dualsig_errno_text')
      import :: c_int, c_char
      integer(c_int), value :: err, n
      character(kind=c_char), intent(out) :: buf(*)
    end function c_errno_text
    integer(c_int) function c_temp_register(path) bind(c, name='dualsig_temp_register')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: path(*)
    end function c_temp_register
    subroutine c_temp_unregister(path) bind(c, name='dualsig_temp_unregister')
      import :: c_char
      character(kind=c_char), intent(in) :: path(*)
    end subroutine c_temp_unregister
    integer(c_int) function c_temp_count() bind(c, name='dualsig_temp_count')
      import :: c_int
    end function c_temp_count
    integer(c_int) function c_file_kind(path, nbytes) bind(c, name='dualsig_file_kind')
      import :: c_int, c_char, c_long_long
      character(kind=c_char), intent(in) :: path(*)
      integer(c_long_long), intent(out) :: nbytes
    end function c_file_kind
    integer(c_int) function c_same_file(a, b) bind(c, name='dualsig_same_file')
      import :: c_int, c_char
      character(kind=c_char), intent(in) :: a(*), b(*)
    end function c_same_file
    integer(c_int) function c_cleanup_install() bind(c, name='dualsig_cleanup_install')
      import :: c_int
    end function c_cleanup_install
    subroutine c_signals_hold() bind(c, name='dualsig_signals_hold')
    end subroutine c_signals_hold
    subroutine c_signals_release() bind(c, name='dualsig_signals_release')
    end subroutine c_signals_release
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

  !> True when `path` names an existing directory.
  logical function is_directory(path)
    character(len=*), intent(in) :: path
    inquire (file=trim(path) // '/.', exist=is_directory)
  end function is_directory

  !> The temporary name under which `path` is written before it is committed:
  !> `<path>.<process id>.part`, so that two runs writing the same output never share one.
  function temp_name(path) result(tmp)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: tmp
    tmp = trim(path) // '.' // itoa(int(c_process_id())) // '.part'
  end function temp_name

  !> The name of the backup of `path` made while a set of files is committed.
  function backup_name(path) result(bak)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: bak
    bak = trim(path) // '.' // itoa(int(c_process_id())) // '.bak'
  end function backup_name

  !> The text of the C errno value `err`.
  function errno_text(err) result(text)
    integer, intent(in) :: err
    character(len=:), allocatable :: text
    character(kind=c_char, len=200) :: buf
    integer :: n
    n = c_errno_text(int(err, c_int), buf, int(len(buf), c_int))
    text = buf(1:max(0, min(n, len(buf))))
  end function errno_text

  !> Whether `path` is a regular file, checked with stat(2) before anything opens it (a FIFO
  !> would block the open, a device such as /dev/zero or a directory is no input file).
  !> ok: nbytes is its size; otherwise why says what it is ('a directory', 'a FIFO (named
  !> pipe)', ..., or the error of stat, e.g. 'No such file or directory').
  logical function regular_file_size(path, nbytes, why) result(ok)
    character(len=*), intent(in) :: path
    integer(i8), intent(out) :: nbytes
    character(len=:), allocatable, intent(out) :: why
    integer(c_long_long) :: sz
    integer(c_int) :: kind
    kind = c_file_kind(path // c_null_char, sz)
    nbytes = int(sz, i8)
    ok = kind == 0
    select case (kind)
    case (0)
      why = ''
    case (1)
      why = 'a directory'
    case (2)
      why = 'a FIFO (named pipe)'
    case (3)
      why = 'a device'
    case (4)
      why = 'a socket or special file'
    case default
      why = errno_text(-int(kind))
    end select
  end function regular_file_size

  !> Before an input file is opened: it must be a regular file (a FIFO would block the
  !> open, a device such as /dev/zero never ends, a directory holds nothing).  Otherwise
  !> DS_ERR_IO in st: prefix // 'not a regular file but <what it is> (expected ' //
  !> expected // '; it was not opened)'.  A path stat(2) cannot see is left to the open,
  !> which names the error.  nbytes: the file's size, -1 if unknown.
  logical function input_file_ok(path, prefix, expected, nbytes, st) result(ok)
    character(len=*), intent(in) :: path, prefix, expected
    integer(i8), intent(out) :: nbytes
    type(status_t), intent(inout) :: st
    character(len=:), allocatable :: why
    ok = regular_file_size(path, nbytes, why)
    if (ok) return
    nbytes = -1
    if (why == 'a directory' .or. why == 'a FIFO (named pipe)' .or. why == 'a device' .or. &
        why == 'a socket or special file') then
      call set_error(st, DS_ERR_IO, prefix // 'not a regular file but ' // why // ' (expected ' // expected // &
        '; it was not opened)')
    else
      ok = .true.                            ! the open reports a missing or unreadable file
    end if
  end function input_file_ok

  !> True when the paths a and b name the same existing file (same device and inode, links
  !> followed: 'x.txt', './x.txt' and a link to it are the same file).
  logical function same_file(a, b)
    character(len=*), intent(in) :: a, b
    same_file = c_same_file(a // c_null_char, b // c_null_char) == 1
  end function same_file

  !> Delete `path` if it exists and forget it as a temporary file (errors are ignored:
  !> used for clean-up).
  subroutine file_delete(path)
    character(len=*), intent(in) :: path
    integer(c_int) :: rc
    rc = c_unlink(trim(path) // c_null_char)
    call c_temp_unregister(trim(path) // c_null_char)
  end subroutine file_delete

  !> Remove the files registered as temporary files on SIGINT, SIGTERM and SIGHUP before the
  !> process dies of the signal (the programs call this once at start).
  subroutine cleanup_on_signals()
    integer(c_int) :: rc
    rc = c_cleanup_install()
  end subroutine cleanup_on_signals

  !> The number of temporary files currently registered for removal on a signal.
  integer function temp_files_registered()
    temp_files_registered = int(c_temp_count())
  end function temp_files_registered

  !> The memory available for new processes without swapping, in GB (10^9 bytes): the
  !> MemAvailable line of /proc/meminfo; a negative value when it cannot be read.
  function memory_available_gb() result(gb)
    real(dp) :: gb
    character(len=256) :: line
    integer :: u, ios
    real(dp) :: kb
    gb = -1.0_dp
    open (newunit=u, file='/proc/meminfo', status='old', action='read', iostat=ios)
    if (ios /= 0) return
    do
      read (u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      if (line(1:13) /= 'MemAvailable:') cycle
      read (line(14:), *, iostat=ios) kb
      if (ios == 0) gb = kb * 1024.0_dp / 1.0e9_dp
      exit
    end do
    close (u)
  end function memory_available_gb

  ! ------------------------------------------------------------------ checked output files

  !> Create temp_name(path) for writing (replacing a leftover of the same name) and
  !> register it for removal on a signal.
  subroutine text_open(tf, path, st)
    type(text_file_t), intent(out) :: tf
    character(len=*), intent(in) :: path
    type(status_t), intent(out) :: st
    character(len=:), allocatable :: tmp
    integer(c_int) :: err
    tf%path = trim(path)
    tmp = temp_name(path)
    err = c_temp_register(tmp // c_null_char)
    tf%fp = c_open(tmp // c_null_char, err)
    if (.not. c_associated(tf%fp)) then
      call c_temp_unregister(tmp // c_null_char)
      call set_error(st, DS_ERR_IO, 'cannot write ' // tf%path // ': cannot create ' // tmp // ': ' // &
        errno_text(int(err)))
    end if
  end subroutine text_open

  !> Append `line` and a line feed (nothing after a failed write: the first error is kept
  !> for text_close).
  subroutine text_put(tf, line)
    type(text_file_t), intent(inout) :: tf
    character(len=*), intent(in) :: line
    integer(c_int) :: err
    if (tf%err /= 0 .or. .not. c_associated(tf%fp)) return
    err = c_write(tf%fp, line, int(len(line), c_size_t))
    if (err == 0) err = c_write(tf%fp, new_line('a'), 1_c_size_t)
    tf%err = int(err)
  end subroutine text_put

  !> Flush, sync and close the file.  On any failure of a write, the flush, the sync or the
  !> close the temporary file is deleted and st names the target and the system's reason
  !> (e.g. "No space left on device").  The caller commits the file.
  subroutine text_close(tf, st)
    type(text_file_t), intent(inout) :: tf
    type(status_t), intent(out) :: st
    integer(c_int) :: err
    if (.not. c_associated(tf%fp)) then
      call set_error(st, DS_ERR_IO, 'cannot write ' // tf%path // ': not open')
      return
    end if
    err = c_close(tf%fp)
    tf%fp = c_null_ptr
    if (tf%err == 0) tf%err = int(err)
    if (tf%err /= 0) then
      call file_delete(temp_name(tf%path))
      call set_error(st, DS_ERR_IO, 'cannot write ' // tf%path // ': ' // errno_text(tf%err) // &
        ' (nothing written: the temporary file ' // temp_name(tf%path) // ' was removed)')
    end if
  end subroutine text_close

  !> Close the file if open and delete its temporary file (after another error).
  subroutine text_abandon(tf)
    type(text_file_t), intent(inout) :: tf
    integer(c_int) :: err
    if (c_associated(tf%fp)) err = c_close(tf%fp)
    tf%fp = c_null_ptr
    if (allocated(tf%path)) call file_delete(temp_name(tf%path))
  end subroutine text_abandon

  ! ------------------------------------------------------------------ commits

  !> Rename temp_name(path) to path, replacing an existing file atomically.
  subroutine file_commit(path, st)
    character(len=*), intent(in) :: path
    type(status_t), intent(out) :: st
    character(len=len_trim(path)) :: one(1)
    one(1) = path
    call file_commit_all(one, st)
  end subroutine file_commit

  !> Commit the files `paths` (written under temp_name) as a set: rename each temporary file
  !> over its target, an existing target first kept as a backup (a hard link).  If a rename
  !> fails, the targets already replaced are restored from their backups (or removed when
  !> they did not exist before) and every temporary file of the set is deleted: either all
  !> targets are the new files or all are as before.  SIGINT, SIGTERM and SIGHUP are held
  !> meanwhile (a signal that arrives is delivered after the commit).
  subroutine file_commit_all(paths, st)
    character(len=*), intent(in) :: paths(:)
    type(status_t), intent(out) :: st
    logical :: backed_up(size(paths))
    integer :: k, j, failed
    integer(c_int) :: err
    character(len=:), allocatable :: target, msg
    backed_up = .false.
    failed = 0
    call c_signals_hold()
    do k = 1, size(paths)
      target = trim(paths(k))
      if (is_directory(target)) then
        msg = 'cannot replace ' // target // ': it is a directory'
        failed = k
        exit
      end if
      if (file_exists(target)) then
        call file_delete(backup_name(target))
        err = c_link(target // c_null_char, backup_name(target) // c_null_char)
        if (err /= 0) then
          msg = 'cannot keep a backup ' // backup_name(target) // ' of ' // target // ': ' // errno_text(int(err))
          failed = k
          exit
        end if
        backed_up(k) = .true.
      end if
      err = c_rename(temp_name(target) // c_null_char, target // c_null_char)
      if (err /= 0) then
        msg = 'cannot rename ' // temp_name(target) // ' to ' // target // ': ' // errno_text(int(err))
        if (backed_up(k)) call file_delete(backup_name(target))
        backed_up(k) = .false.
        failed = k
        exit
      end if
      call c_temp_unregister(temp_name(target) // c_null_char)
    end do
    if (failed > 0) then
      do j = failed - 1, 1, -1
        target = trim(paths(j))
        if (backed_up(j)) then
          err = c_rename(backup_name(target) // c_null_char, target // c_null_char)
          if (err /= 0) msg = msg // '; restoring ' // target // ' from ' // backup_name(target) // &
            ' failed: ' // errno_text(int(err))
        else
          call file_delete(target)
        end if
      end do
      do j = failed, size(paths)
        call file_delete(temp_name(paths(j)))
      end do
      call set_error(st, DS_ERR_IO, msg // ' (no file of the set was replaced)')
    else
      do j = 1, size(paths)
        if (backed_up(j)) call file_delete(backup_name(paths(j)))
      end do
    end if
    call c_signals_release()
  end subroutine file_commit_all

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
