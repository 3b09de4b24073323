!> dualsig: batch driver.  Usage: dualsig FILE.nml
!>
!> Runs every run of the namelist file and writes its error tables.  Exit status:
!> 0 success, 1 usage, 2 bad input or failed run (message on standard error, no table
!> written for the failing run), 3 finished but some solve reached its iteration limit.
program dualsig
  use, intrinsic :: iso_fortran_env, only: error_unit
  use dualsig_status, only: status_t, is_ok, DS_OK
  use dualsig_driver, only: run_namelist_file
  implicit none
  character(len=:), allocatable :: path
  type(status_t) :: st
  integer :: n

  if (command_argument_count() /= 1) then
    write (error_unit, '(a)') 'usage: dualsig FILE.nml   (see README.md for the namelist groups)'
    stop 1, quiet=.true.
  end if
  call get_command_argument(1, length=n)
  allocate (character(len=n) :: path)
  call get_command_argument(1, path)
  call run_namelist_file(path, st)
  if (.not. is_ok(st)) then
    write (error_unit, '(a)') 'dualsig: error: ' // st%msg
    stop 2, quiet=.true.
  else if (st%code /= DS_OK) then
    write (error_unit, '(a)') 'dualsig: warning: ' // st%msg
    stop 3, quiet=.true.
  end if
end program dualsig
