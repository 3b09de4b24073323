/*
 * dualsig_heap_policy.c -- the C side of dualsig_heap (Fortran, iso_c_binding).
 *
 * glibc serves every allocation above its mmap threshold (at most 32 MB) by a fresh
 * mmap(2) and returns it to the kernel on free.  dualsig's large arrays (matrices, factors,
 * the operators of a multigrid hierarchy rebuilt per active-set step) are far larger, so
 * every one of them is faulted in page by page again, although an array of the same size
 * was freed a moment before.  dualsig_heap_keep_freed turns this off for the process:
 * M_MMAP_MAX = 0 takes every block from the heap (glibc still falls back on mmap when the
 * heap cannot grow), and M_TRIM_THRESHOLD = INT_MAX keeps freed memory for reuse instead
 * of trimming the heap.  Peak memory stays the peak of live data (plus fragmentation);
 * memory is returned to the kernel when the process ends.
 *
 * Returns 0 when both settings took, 1 when glibc refused one, 2 without glibc or under
 * AddressSanitizer (whose allocator ignores mallopt; nothing done).  For programs (bin/dualsig, the benchmarks); a library never changes the
 * allocator of its caller by itself.
 */
#include <limits.h>
#if defined(__GLIBC__) || defined(__linux__)
#include <malloc.h>
#endif

#if defined(__GLIBC__) && defined(M_MMAP_MAX) && defined(M_TRIM_THRESHOLD) && !defined(__SANITIZE_ADDRESS__)
#define DS_HEAP_POLICY 1
#else
#define DS_HEAP_POLICY 0
#endif

/* 1 when dualsig_heap_keep_freed can act in this build (glibc, no AddressSanitizer). */
int dualsig_heap_policy_available(void) { return DS_HEAP_POLICY; }

int dualsig_heap_keep_freed(void)
{
#if DS_HEAP_POLICY
    int ok = mallopt(M_MMAP_MAX, 0) == 1;
    ok = (mallopt(M_TRIM_THRESHOLD, INT_MAX) == 1) && ok;
    return ok ? 0 : 1;
#else
    return 2;
#endif
}
