!> Measurements for timings and reports: wall-clock seconds and the process's peak memory.
module dualsig_clock
  use dualsig_kinds, only: dp, i8
  implicit none
  private

  public :: wall_seconds, peak_memory_mb

contains

  !> Wall-clock seconds from an arbitrary origin (differences are elapsed times).
  real(dp) function wall_seconds()
    integer(i8) :: cnt, rate
    call system_clock(cnt, rate)
    wall_seconds = real(cnt, dp) / real(rate, dp)
  end function wall_seconds

  !> Peak resident memory of this process so far, MB (VmHWM of /proc/self/status; 0 if unknown).
  real(dp) function peak_memory_mb()
    character(len=256) :: line
    integer :: u, ios, kb
    peak_memory_mb = 0.0_dp
    open (newunit=u, file='/proc/self/status', status='old', action='read', iostat=ios)
    if (ios /= 0) return
    do
      read (u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      if (line(1:6) == 'VmHWM:') then
        read (line(7:), *, iostat=ios) kb
        if (ios == 0) peak_memory_mb = kb / 1024.0_dp
        exit
      end if
    end do
    close (u)
  end function peak_memory_mb
end module dualsig_clock
