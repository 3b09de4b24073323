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
 * Not under a memory limit: with RLIMIT_AS or RLIMIT_DATA finite (ulimit -v, -d) large
 * allocations are expected to fail, and a heap without mmap then fails OpenBLAS too: its
 * worker threads take a 128 MB buffer with malloc, which (with M_MMAP_MAX = 0) only the
 * main arena's brk can serve; when brk fails under the limit, the worker retries forever
 * and the process hangs at exit waiting for it (seen in the out-of-memory tests, one run in
 * a few under load; gdb: blas_memory_alloc -> malloc -> new_heap -> mmap, main thread in
 * blas_thread_shutdown_).
 *
 * Returns 0 when both settings took, 1 when glibc refused one, 2 without glibc or under
 * AddressSanitizer (whose allocator ignores mallopt), 3 under a memory limit (nothing done
 * in cases 2 and 3).  For programs (bin/dualsig, the benchmarks); a library never changes the
 * allocator of its caller by itself.
 */
#define _GNU_SOURCE            /* RTLD_DEFAULT */
#include <dlfcn.h>
#include <limits.h>
#include <sys/resource.h>
#if defined(__GLIBC__) || defined(__linux__)
#include <malloc.h>
#endif

#if defined(__GLIBC__) && defined(M_MMAP_MAX) && defined(M_TRIM_THRESHOLD) && !defined(__SANITIZE_ADDRESS__)
#define DS_HEAP_POLICY 1
#else
#define DS_HEAP_POLICY 0
#endif

/* 1 when the process runs without an address-space or data-segment limit. */
static int no_memory_limit(void)
{
    struct rlimit as, data;
    if (getrlimit(RLIMIT_AS, &as) != 0 || getrlimit(RLIMIT_DATA, &data) != 0) return 0;
    return as.rlim_cur == RLIM_INFINITY && data.rlim_cur == RLIM_INFINITY;
}

/* 1 when the process runs under AddressSanitizer's allocator, which ignores mallopt: seen
 * at run time, since this file may be compiled without -fsanitize while the Fortran is
 * (make check-asan). */
static int sanitizer_allocator(void) { return dlsym(RTLD_DEFAULT, "__asan_init") != NULL; }

/* 1 when dualsig_heap_keep_freed would act here (glibc, no AddressSanitizer, no limit). */
int dualsig_heap_policy_available(void)
{
    return DS_HEAP_POLICY && !sanitizer_allocator() && no_memory_limit();
}

int dualsig_heap_keep_freed(void)
{
#if DS_HEAP_POLICY
    if (sanitizer_allocator()) return 2;
    if (!no_memory_limit()) return 3;
    int ok = mallopt(M_MMAP_MAX, 0) == 1;
    ok = (mallopt(M_TRIM_THRESHOLD, INT_MAX) == 1) && ok;
    return ok ? 0 : 1;
#else
    return 2;
#endif
}
