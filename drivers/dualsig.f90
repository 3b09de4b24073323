!> dualsig: batch driver.  Usage: dualsig FILE.nml
!>
!> Runs every run of the namelist file and writes its error tables.  Exit status:
!> 0 success, 1 usage, 2 bad input or failed run (message on standard error; the failing
!> run writes no file, unless it stopped at a later level: then its tables hold the levels
!> before, with a STOPPED header line), 3 finished but some solve reached its iteration
!> limit.  The last line on standard output gives the total wall time and the peak
!> memory of the process ('dualsig: total 12.3 s, peak memory 85.2 MB'); phases of a level
!> lasting 2 s or more are reported on standard error as they end.  On SIGINT, SIGTERM or SIGHUP the temporary files are removed and the program
!> dies of the signal (status 128 + signal number in a shell).
program dualsig
  use, intrinsic :: iso_fortran_env, only: error_unit, output_unit
  use dualsig_kinds, only: dp
  use dualsig_clock, only: wall_seconds, peak_memory_mb
  use dualsig_status, only: status_t, is_ok, DS_OK
  use dualsig_driver, only: run_namelist_file
  use dualsig_io_files, only: cleanup_on_signals
  use dualsig_heap, only: heap_keep_freed
  implicit none
  character(len=:), allocatable :: path
  type(status_t) :: st
  integer :: n, exit_code
  real(dp) :: t_start
  character(len=12) :: seconds, megabytes

  if (command_argument_count() /= 1) then
    write (error_unit, '(a)') 'usage: dualsig FILE.nml   (see doc/user-guide.md for the namelist groups)'
    stop 1, quiet=.true.
  end if
  call get_command_argument(1, length=n)
  allocate (character(len=n) :: path)
  call get_command_argument(1, path)
  t_start = wall_seconds()
  call cleanup_on_signals()
  call heap_keep_freed()          ! freed blocks reused, not faulted in again (dualsig_heap)
  call run_namelist_file(path, st)
  write (seconds, '(f12.2)') wall_seconds() - t_start
  write (megabytes, '(f12.1)') peak_memory_mb()
  write (output_unit, '(a)') 'dualsig: total ' // trim(adjustl(seconds)) // ' s, peak memory ' // &
    trim(adjustl(megabytes)) // ' MB'
  flush (output_unit)
  exit_code = 0
  if (.not. is_ok(st)) then
    write (error_unit, '(a)') 'dualsig: error: ' // st%msg
    exit_code = 2
  else if (st%code /= DS_OK) then
    write (error_unit, '(a)') 'dualsig: warning: ' // st%msg
    exit_code = 3
  end if
  ! release everything before stopping (a leak checker sees what is left at STOP)
  deallocate (path)
  if (allocated(st%msg)) deallocate (st%msg)
  if (exit_code /= 0) stop exit_code, quiet=.true.
end program dualsig
