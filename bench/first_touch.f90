!> The cost of memory the process has not touched before, against memory it rewrites: one
!> array of 1 GB written twice, each write timed (doc/performance.md, "The P1 dual cheaper").
!> On the 2-core VM of 2026-11-26 the first write took 0.40-1.18 s and the second 0.04 s:
!> the kernel zeroes and maps every fresh page, so a solver's cost follows the memory it
!> allocates anew, not only the work it does.
!>
!> Standalone (no library): gfortran -O2 bench/first_touch.f90 -o /tmp/first_touch && /tmp/first_touch
program first_touch
  use, intrinsic :: iso_fortran_env, only: dp => real64, i8 => int64, output_unit
  implicit none
  integer(i8), parameter :: n = 125000000_i8       ! 1 GB of real64
  real(dp), allocatable :: a(:)
  integer(i8) :: c0, c1, rate
  integer :: ist
  call system_clock(count_rate=rate)
  call system_clock(c0)
  allocate (a(n), stat=ist)
  if (ist /= 0) then
    write (output_unit, '(a)') 'first_touch: cannot allocate 1 GB'
    error stop 1
  end if
  a = 1.0_dp
  call system_clock(c1)
  write (output_unit, '(a, f8.3, a)') 'first write of 1 GB: ', real(c1 - c0, dp) / real(rate, dp), ' s'
  call system_clock(c0)
  a = a + 1.0_dp
  call system_clock(c1)
  write (output_unit, '(a, f8.3, a, f4.1, a)') 'second write of 1 GB:', real(c1 - c0, dp) / real(rate, dp), &
    ' s (check ', a(n / 2), ')'
end program first_touch
