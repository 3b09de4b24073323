!> The allocator policy of dualsig's programs (dualsig_heap_policy.c): keep freed memory for
!> reuse instead of returning every large block to the kernel.
!>
!> A multigrid hierarchy rebuilt per active-set step, a Galerkin product or a matrix of the
!> next level is allocated, used and freed many times per run.  glibc maps each block above
!> 32 MB afresh and the kernel faults it in page by page, on a shared VM at about 1.2 s per
!> GB: measured on the P2 dual at level 9 of p2_contact (doc/performance.md), its solver
!> phases took 1.77 s instead of 2.37 s with the freed memory kept, at 4 % more peak memory.
!> bin/dualsig and bin/dualsig_bench call heap_keep_freed first; the library itself never
!> does (it would change its caller's allocator).  Nothing is changed under a memory
!> limit (ulimit -v or -d): there OpenBLAS's threads need mmap (dualsig_heap_policy.c).
module dualsig_heap
  use, intrinsic :: iso_c_binding, only: c_int
  implicit none
  private

  public :: heap_keep_freed, heap_policy_available

  interface
    integer(c_int) function c_keep_freed() bind(c, name='dualsig_heap_keep_freed')
      import :: c_int
    end function c_keep_freed
    integer(c_int) function c_available() bind(c, name='dualsig_heap_policy_available')
      import :: c_int
    end function c_available
  end interface

contains

  !> .true. when heap_keep_freed can act here (glibc, not under AddressSanitizer, no
  !> address-space or data limit on the process).
  logical function heap_policy_available()
    heap_policy_available = c_available() == 1
  end function heap_policy_available

  !> Keep freed memory in the process's heap for reuse (module header).  applied (optional):
  !> .true. when the C library took the settings (glibc), .false. otherwise (nothing changed:
  !> another C library, AddressSanitizer, a memory limit).
  subroutine heap_keep_freed(applied)
    logical, intent(out), optional :: applied
    integer(c_int) :: code
    code = c_keep_freed()
    if (present(applied)) applied = code == 0
  end subroutine heap_keep_freed
end module dualsig_heap
