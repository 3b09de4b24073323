!> Measurements for timings and reports: wall-clock seconds, the process's peak and current
!> resident memory.
module dualsig_clock
  use dualsig_kinds, only: dp, i8
  implicit none
  private

  public :: wall_seconds, peak_memory_mb, resident_memory_mb

contains

  !> Wall-clock seconds from an arbitrary origin (differences are elapsed times).
  real(dp) function wall_seconds()
    integer(i8) :: cnt, rate
    call system_clock(cnt, rate)
    wall_seconds = real(cnt, dp) / real(rate, dp)
  end function wall_seconds

  !> Peak resident memory of this process so far, MB (VmHWM of /proc/self/status; 0 if unknown).
  real(dp) function peak_memory_mb()
    peak_memory_mb = status_kb('VmHWM:') / 1024.0_dp
  end function peak_memory_mb

  !> Resident memory of this process now, MB (VmRSS of /proc/self/status; 0 if unknown).
  real(dp) function resident_memory_mb()
    resident_memory_mb = status_kb('VmRSS:') / 1024.0_dp
  end function resident_memory_mb

  !> The kB figure of the line starting with key in /proc/self/status (0 if unknown).
  real(dp) function status_kb(key)
    character(len=*), intent(in) :: key
    character(len=256) :: line
    integer :: u, ios
    integer(i8) :: kb
    status_kb = 0.0_dp
    open (newunit=u, file='/proc/self/status', status='old', action='read', iostat=ios)
    if (ios /= 0) return
    do
      read (u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      if (line(1:len(key)) == key) then
        read (line(len(key) + 1:), *, iostat=ios) kb
        if (ios == 0) status_kb = real(kb, dp)
        exit
      end if
    end do
    close (u)
  end function status_kb
end module dualsig_clock
