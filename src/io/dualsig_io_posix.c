/*
 * dualsig_io_posix.c -- the POSIX calls behind dualsig_io_files (Fortran, iso_c_binding).
 *
 * 1. Output files through C stdio.  gfortran 12 drops the errors of write(2) on formatted
 *    and stream units: a WRITE, FLUSH or CLOSE on a full file system returns iostat = 0 and
 *    the file is silently cut.  Output files are therefore written here: every fwrite,
 *    fflush, fsync and fclose is checked and the first errno is returned to Fortran.
 *
 * 2. Temporary files removed on SIGINT, SIGTERM and SIGHUP.  Fortran registers the name
 *    of every temporary file it creates (dualsig_temp_register) and unregisters it when the
 *    file is renamed or deleted.  The handler is async-signal-safe: it walks a fixed-size
 *    table of paths, unlink(2)s every registered one, restores the default action and
 *    re-raises the signal, so the process still dies of it (exit status 128 + signal).
 *    A slot is published by setting its flag after the path is copied (a signal fence
 *    orders the two), so the handler never sees a half-written path.
 *
 * 3. dualsig_signals_hold / _release block and unblock these signals around the renames
 *    that commit a run's files, so a run's files are committed (or rolled back) as a set.
 *
 * 4. getpid(2) for the per-process temporary names, link(2), rename(2), unlink(2) with
 *    their errno, and strerror for the messages.
 *
 * 5. dualsig_file_kind: stat(2) of an input file before it is opened, so that readers take
 *    regular files only (a FIFO would block the open, a device or a directory never ends).
 *
 * Every int-returning function returns 0 or an errno value unless stated otherwise.
 */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <unistd.h>

#define DS_TEMP_SLOTS 256      /* temporary files registered at the same time */
#define DS_TEMP_PATH 4096      /* longest registered path, with its terminating NUL */

static char temp_path[DS_TEMP_SLOTS][DS_TEMP_PATH];
static volatile sig_atomic_t temp_used[DS_TEMP_SLOTS];
static const int cleanup_signals[] = {SIGINT, SIGTERM, SIGHUP};
#define DS_NSIGNALS ((int)(sizeof cleanup_signals / sizeof cleanup_signals[0]))
static sigset_t held_old_mask;
static int held = 0;

/* ------------------------------------------------------------------ process */

int dualsig_process_id(void) { return (int)getpid(); }

/* ------------------------------------------------------------------ files */

/* Open `path` for writing (created or truncated).  Returns the FILE* or NULL with *err. */
void *dualsig_file_open(const char *path, int *err)
{
    FILE *fp = fopen(path, "w");
    *err = fp ? 0 : errno;
    return fp;
}

/* Write n bytes. */
int dualsig_file_write(void *fp, const char *buf, size_t n)
{
    if (n == 0) return 0;
    errno = 0;
    if (fwrite(buf, 1, n, (FILE *)fp) != n) return errno ? errno : EIO;
    return 0;
}

/* Flush, fsync (where the file supports it) and close; the first error is returned and
 * the stream is closed in any case. */
int dualsig_file_close(void *fp)
{
    FILE *f = (FILE *)fp;
    int err = 0;
    if (fflush(f) != 0) err = errno ? errno : EIO;
    if (err == 0 && fsync(fileno(f)) != 0 && errno != EINVAL && errno != ENOTSUP && errno != EROFS)
        err = errno;
    if (fclose(f) != 0 && err == 0) err = errno ? errno : EIO;
    return err;
}

int dualsig_file_rename(const char *from, const char *to) { return rename(from, to) == 0 ? 0 : errno; }
int dualsig_file_link(const char *from, const char *to) { return link(from, to) == 0 ? 0 : errno; }
int dualsig_file_unlink(const char *path) { return unlink(path) == 0 ? 0 : errno; }

/* The text of errno value err in buf (at most len - 1 characters, NUL-terminated);
 * returns its length. */
int dualsig_errno_text(int err, char *buf, int len)
{
    if (len <= 0) return 0;
    snprintf(buf, (size_t)len, "%s", strerror(err));
    return (int)strlen(buf);
}

/* The kind of the file `path` (symbolic links followed): 0 a regular file (its size in
 * *size), 1 a directory, 2 a FIFO, 3 a character or block device, 4 a socket or anything
 * else; a negative value is -errno of a failed stat(2) (e.g. -ENOENT).  Never opens it. */
int dualsig_file_kind(const char *path, long long *size)
{
    struct stat sb;
    *size = 0;
    if (stat(path, &sb) != 0) return errno ? -errno : -EIO;
    if (S_ISREG(sb.st_mode)) {
        *size = (long long)sb.st_size;
        return 0;
    }
    if (S_ISDIR(sb.st_mode)) return 1;
    if (S_ISFIFO(sb.st_mode)) return 2;
    if (S_ISCHR(sb.st_mode) || S_ISBLK(sb.st_mode)) return 3;
    return 4;
}

/* 1 when the paths a and b name the same existing file (same device and inode, symbolic
 * links followed), else 0.  Never opens them. */
int dualsig_same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (stat(a, &sa) != 0 || stat(b, &sb) != 0) return 0;
    return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

/* ------------------------------------------------------------------ temporary files */

/* Register a temporary file for removal on a signal.  Returns 0, ENAMETOOLONG, or ENOSPC
 * when the table is full (the file is then not removed on a signal). */
int dualsig_temp_register(const char *path)
{
    size_t n = strlen(path);
    if (n >= DS_TEMP_PATH) return ENAMETOOLONG;
    for (int k = 0; k < DS_TEMP_SLOTS; k++) {
        if (temp_used[k]) continue;
        memcpy(temp_path[k], path, n + 1);
        atomic_signal_fence(memory_order_seq_cst);
        temp_used[k] = 1;
        return 0;
    }
    return ENOSPC;
}

/* Forget every registration of `path`. */
void dualsig_temp_unregister(const char *path)
{
    for (int k = 0; k < DS_TEMP_SLOTS; k++) {
        if (temp_used[k] && strcmp(temp_path[k], path) == 0) {
            temp_used[k] = 0;
            atomic_signal_fence(memory_order_seq_cst);
        }
    }
}

/* The number of registered temporary files (for the tests). */
int dualsig_temp_count(void)
{
    int n = 0;
    for (int k = 0; k < DS_TEMP_SLOTS; k++) n += temp_used[k] ? 1 : 0;
    return n;
}

/* ------------------------------------------------------------------ signals */

static void cleanup_handler(int sig)
{
    int saved = errno;
    sigset_t unblock;
    for (int k = 0; k < DS_TEMP_SLOTS; k++)
        if (temp_used[k]) unlink(temp_path[k]);
    signal(sig, SIG_DFL);
    sigemptyset(&unblock);
    sigaddset(&unblock, sig);
    sigprocmask(SIG_UNBLOCK, &unblock, NULL);
    raise(sig);
    errno = saved;     /* not reached: the default action ends the process */
}

/* Install the handler for SIGINT, SIGTERM and SIGHUP (a signal ignored at start, as under
 * nohup, stays ignored).  Returns 0 or the errno of sigaction. */
int dualsig_cleanup_install(void)
{
    struct sigaction sa, old;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = cleanup_handler;
    sigemptyset(&sa.sa_mask);
    for (int k = 0; k < DS_NSIGNALS; k++) sigaddset(&sa.sa_mask, cleanup_signals[k]);
    for (int k = 0; k < DS_NSIGNALS; k++) {
        if (sigaction(cleanup_signals[k], NULL, &old) != 0) return errno;
        if (old.sa_handler == SIG_IGN) continue;
        if (sigaction(cleanup_signals[k], &sa, NULL) != 0) return errno;
    }
    return 0;
}

/* Block SIGINT, SIGTERM and SIGHUP until dualsig_signals_release (not nested). */
void dualsig_signals_hold(void)
{
    sigset_t set;
    if (held) return;
    sigemptyset(&set);
    for (int k = 0; k < DS_NSIGNALS; k++) sigaddset(&set, cleanup_signals[k]);
    if (sigprocmask(SIG_BLOCK, &set, &held_old_mask) == 0) held = 1;
}

/* Restore the signal mask of dualsig_signals_hold; a signal that arrived meanwhile is
 * delivered now. */
void dualsig_signals_release(void)
{
    if (!held) return;
    held = 0;
    sigprocmask(SIG_SETMASK, &held_old_mask, NULL);
}
