/* Whole input files read into memory in one go (the scene file, OBJ files): malloc'd or
 * in an arena buffer, NUL-terminated, big regular files read by two CPUs. Also the
 * identity of a file and where a write through symbolic links lands. */
#include "rt/file.h"

#include <errno.h>
#include <limits.h>
#include <fcntl.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/vfs.h>
#endif

#include "rt/arena.h"
#include "rt/par.h"

/* The buffer functions of file_read_all (malloc) or file_read_reusable (arena buffer). */
static void *buf_alloc(size_t n, bool reusable)
{
    return reusable ? arena_buffer_new(n) : malloc(n);
}
static void *buf_realloc(void *p, size_t n, bool reusable)
{
    return reusable ? arena_buffer_resize(p, n) : realloc(p, n);
}
static void buf_free(void *p, bool reusable)
{
    if (reusable)
        arena_buffer_free(p);
    else
        free(p);
}

/* A big regular file is read by pread in chunks, in parallel (rt/par.h): the page
 * faults of the fresh buffer are most of the cost, and they are taken by two CPUs. */
enum { READ_CHUNK = 128 << 10 };

typedef struct ReadJob {
    int fd;
    char *buf;
    size_t size;
    atomic_bool failed;   /* a chunk came short (the file changed) or failed */
} ReadJob;

static void read_chunk(void *ctx, int i, int worker)
{
    (void)worker;
    ReadJob *job = ctx;
    if (par_stop_requested()) { /* read_all_id tells a stop from a failure */
        atomic_store(&job->failed, true);
        return;
    }
    size_t off = (size_t)i * READ_CHUNK, end = job->size - off > READ_CHUNK ? off + READ_CHUNK
                                                                            : job->size;
    while (off < end) {
        ssize_t got = pread(job->fd, job->buf + off, end - off, (off_t)off);
        if (got <= 0) {
            if (got < 0 && errno == EINTR)
                continue;
            atomic_store(&job->failed, true);
            return;
        }
        off += (size_t)got;
    }
}

/* The whole regular file of size bytes into buf by read_chunk; false when it did not
 * work out (the caller then reads it the ordinary way, from the start). */
static bool read_parallel(FILE *f, char *buf, size_t size)
{
    ReadJob job;
    job.fd = fileno(f);
    job.buf = buf;
    job.size = size;
    atomic_init(&job.failed, false);
    par_for((int)(size / READ_CHUNK + (size % READ_CHUNK != 0)), read_chunk, &job);
    if (atomic_load(&job.failed))
        return false;
    char c;
    return pread(job.fd, &c, 1, (off_t)size) == 0; /* nothing was appended meanwhile */
}

/* File systems known to set ctime on every change (Linux statfs magic numbers): ext2/3/4,
 * XFS, Btrfs, tmpfs, overlayfs, ZFS, F2FS, NFS, Lustre, GPFS, CephFS. Elsewhere (FAT,
 * exFAT, NTFS through FUSE, unknown) the identity is not trusted. */
static bool fs_keeps_ctime(int fd)
{
#ifdef __linux__
    static const unsigned long known[] = {0xEF53, 0x58465342, 0x9123683E, 0x01021994,
                                          0x794C7630, 0x2FC12FC1, 0xF2F52010, 0x6969,
                                          0x0BD00BD0, 0x47504653, 0x00C36400};
    struct statfs fs;
    if (fstatfs(fd, &fs) != 0)
        return false;
    for (size_t i = 0; i < sizeof known / sizeof known[0]; i++)
        if ((unsigned long)fs.f_type == known[i])
            return true;
    return false;
#else
    (void)fd;
    return false;
#endif
}

static void identity_of(const struct stat *st, FileIdentity *id)
{
    memset(id, 0, sizeof *id);
    id->dev = (uint64_t)st->st_dev;
    id->ino = (uint64_t)st->st_ino;
    id->size = (uint64_t)st->st_size;
    id->mtime_s = (int64_t)st->st_mtim.tv_sec;
    id->mtime_ns = (int64_t)st->st_mtim.tv_nsec;
    id->ctime_s = (int64_t)st->st_ctim.tv_sec;
    id->ctime_ns = (int64_t)st->st_ctim.tv_nsec;
}

bool file_identity(const char *path, FileIdentity *id)
{
    /* O_NONBLOCK: only the identity is wanted, so a FIFO's open must not wait for a
     * writer (it did, and no stop signal cut that wait: obj_file naming a FIFO with
     * -cache); a FIFO or a device is no regular file and is refused below. The open of
     * a regular file does not change. */
    int fd = open(path, O_RDONLY | O_CLOEXEC | O_NONBLOCK);
    if (fd < 0)
        return false;
    struct stat st;
    bool ok = fstat(fd, &st) == 0;
    int e = errno;
    if (ok && !S_ISREG(st.st_mode)) {
        ok = false;
        e = EINVAL;
    } else if (ok && !fs_keeps_ctime(fd)) {
        ok = false;
        e = ENOTSUP;
    }
    close(fd);
    if (ok)
        identity_of(&st, id);
    errno = e;
    return ok;
}

bool file_identity_settled(const FileIdentity *id)
{
    struct timespec now;
    if (clock_gettime(CLOCK_REALTIME, &now) != 0)
        return false;
    int64_t limit = (int64_t)now.tv_sec - RT_FILE_SETTLED_SECONDS;
    /* Whole seconds compared: a time in the second `limit` is at most 2 s before now
     * rounded down, so it counts as settled only when strictly below. */
    return id->mtime_s < limit && id->ctime_s < limit;
}

static bool read_all_id(const char *path, char **out, size_t *len, bool reusable, bool stdin_ok,
                        FileIdentity *id, bool *stable);

/* Reads in progress from something other than a regular file (a pipe, a FIFO, a
 * terminal): those can wait for ever, in the open of a FIFO without a writer or in a
 * read with no bytes coming, and under SA_RESTART a stop signal does not cut that wait,
 * so the loop's look at the stop flag came only when input came (Ctrl-C at a terminal
 * waiting for "-input -" did nothing). The signal handler asks file_input_waiting. */
static atomic_int g_waiting_reads;

bool file_input_waiting(void) { return atomic_load(&g_waiting_reads) > 0; }

/* Whether path (or standard input, for "-") is anything but a regular file or a folder;
 * a path that cannot be looked up is left to fopen to report. */
static bool may_wait(const char *path, bool is_stdin)
{
    struct stat st;
    int r = is_stdin ? fstat(STDIN_FILENO, &st) : stat(path, &st);
    return r == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
}

/* A read that failed after its buffer was made: buf freed, f closed, errno = err. */
static bool read_failed(FILE *f, char *buf, bool reusable, int err)
{
    buf_free(buf, reusable);
    fclose(f);
    errno = err;
    return false;
}

static bool read_all(const char *path, char **out, size_t *len, bool reusable, bool stdin_ok)
{
    return read_all_id(path, out, len, reusable, stdin_ok, NULL, NULL);
}

/* read_all, and with id the identity before the read and whether it held (stable). */
static bool read_all_id_now(const char *path, char **out, size_t *len, bool reusable,
                            bool stdin_ok, FileIdentity *id, bool *stable);

static bool read_all_id(const char *path, char **out, size_t *len, bool reusable, bool stdin_ok,
                        FileIdentity *id, bool *stable)
{
    bool wait = may_wait(path, stdin_ok && strcmp(path, "-") == 0);
    if (wait)
        atomic_fetch_add(&g_waiting_reads, 1);
    bool ok = read_all_id_now(path, out, len, reusable, stdin_ok, id, stable);
    if (wait)
        atomic_fetch_sub(&g_waiting_reads, 1);
    return ok;
}

static bool read_all_id_now(const char *path, char **out, size_t *len, bool reusable,
                            bool stdin_ok, FileIdentity *id, bool *stable)
{
    if (stable)
        *stable = false;
    /* "-" is standard input for the scene (file_read_all) only; a duplicate, so
     * fclose leaves descriptor 0 open. An OBJ file may really be called "-". */
    int in = stdin_ok && strcmp(path, "-") == 0 ? dup(STDIN_FILENO) : -1;
    FILE *f = in >= 0 ? fdopen(in, "rb") : fopen(path, "rb");
    if (!f) {
        if (in >= 0)
            close(in);
        return false;
    }
    struct stat st;
    if (fstat(fileno(f), &st) != 0) {
        int e = errno;
        fclose(f);
        errno = e;
        return false;
    }
    if (S_ISDIR(st.st_mode)) {
        fclose(f);
        errno = EISDIR;
        return false;
    }
    bool known = id && S_ISREG(st.st_mode) && fs_keeps_ctime(fileno(f));
    if (id)
        identity_of(&st, id);
    if (S_ISREG(st.st_mode) && (uintmax_t)st.st_size > RT_FILE_MAX_BYTES) {
        fclose(f);
        errno = EFBIG;
        return false;
    }
    /* A big file is read in parallel next (read_parallel, then the OBJ reader's pieces):
     * wake the helpers now, so the read gives them time to get a CPU. */
    if (S_ISREG(st.st_mode) && (uintmax_t)st.st_size >= RT_FILE_PAR_MIN_BYTES)
        par_prepare();
    /* Regular files: one fread of the known size. Pipes and the like: grow as we go. */
    size_t cap = S_ISREG(st.st_mode) && st.st_size > 0 ? (size_t)st.st_size + 1 : 65536;
    char *buf = buf_alloc(cap, reusable);
    size_t n = 0;
    if (!buf) {
        fclose(f);
        errno = ENOMEM;
        return false;
    }
    bool whole = S_ISREG(st.st_mode) && (uintmax_t)st.st_size >= RT_FILE_PAR_MIN_BYTES &&
                 par_threads() > 1 && read_parallel(f, buf, cap - 1);
    if (whole)
        n = cap - 1;
    while (!whole) {
        /* A stop (Ctrl-C) ends the read: EINTR, which the callers do not report. */
        if (par_stop_requested())
            return read_failed(f, buf, reusable, EINTR);
        if (n + 1 >= cap) {
            /* Full: a regular file usually ends right here (cap is its size + 1), so
             * look for one more byte before doubling the buffer. The doubling was a
             * fresh mapping twice the size, a copy and an munmap on every OBJ file
             * read by one thread (1.3 MB of the 40k bunny: 2 MB huge pages zeroed). */
            char more;
            size_t one = fread(&more, 1, 1, f);
            if (one == 0) {
                if (ferror(f))
                    return read_failed(f, buf, reusable, errno ? errno : EIO);
                break;
            }
            if (cap >= RT_FILE_MAX_BYTES)
                return read_failed(f, buf, reusable, EFBIG);
            char *nb = buf_realloc(buf, cap * 2, reusable);
            if (!nb)
                return read_failed(f, buf, reusable, ENOMEM);
            buf = nb;
            cap *= 2;
            buf[n++] = more;
        }
        size_t want = cap - 1 - n;
        size_t got = fread(buf + n, 1, want > RT_FILE_STOP_BYTES ? RT_FILE_STOP_BYTES : want, f);
        n += got;
        if (got == 0) {
            if (ferror(f))
                return read_failed(f, buf, reusable, errno ? errno : EIO);
            break;
        }
        /* The end was seen: stop here. A terminal's end of file (Ctrl-D) is one read of
         * 0 bytes, not a lasting state, and a further fread would wait for a second
         * Ctrl-D (glibc reads large requests straight from the descriptor). A stop
         * that came during this read is still obeyed, at the loop's top. */
        if (feof(f) && !par_stop_requested())
            break;
    }
    if (known) {
        struct stat after;
        FileIdentity now;
        if (fstat(fileno(f), &after) == 0) {
            identity_of(&after, &now);
            *stable = memcmp(&now, id, sizeof now) == 0 && (uint64_t)n == id->size;
        }
    }
    fclose(f);
    buf[n] = '\0';
    *out = buf;
    *len = n;
    return true;
}

bool file_read_all(const char *path, char **out, size_t *len)
{
    return read_all(path, out, len, false, true);
}

bool file_read_reusable(const char *path, char **out, size_t *len)
{
    return read_all(path, out, len, true, false);
}

bool file_read_reusable_identified(const char *path, char **out, size_t *len, FileIdentity *id,
                                   bool *stable)
{
    return read_all_id(path, out, len, true, false, id, stable);
}

bool file_same(const char *a, const char *b)
{
    struct stat sa, sb;
    return stat(a, &sa) == 0 && stat(b, &sb) == 0 && sa.st_dev == sb.st_dev &&
           sa.st_ino == sb.st_ino;
}

char *file_link_target(const char *path, int *err)
{
    char *cur = strdup(path);
    /* Linux gives up after 40 links in one lookup (ELOOP): the same bound here. */
    for (int hops = 0; cur; hops++) {
        struct stat lst;
        if (lstat(cur, &lst) != 0 || !S_ISLNK(lst.st_mode))
            return cur;
        if (hops == 40) {
            free(cur);
            *err = ELOOP;
            return NULL;
        }
        /* An existing target by its canonical name (what the rename will replace). */
        char *real = realpath(cur, NULL);
        if (real) {
            free(cur);
            return real;
        }
        /* Dangling: follow the link one step. A relative link is read from the folder
         * holding it: "<that folder>/<link text>", the kernel resolving the rest. */
        char text[PATH_MAX];
        ssize_t n = readlink(cur, text, sizeof text - 1);
        if (n < 0) {
            *err = errno;
            free(cur);
            return NULL;
        }
        text[n] = '\0';
        const char *slash = strrchr(cur, '/');
        size_t dirlen = text[0] == '/' || !slash ? 0 : (size_t)(slash - cur) + 1;
        char *next = malloc(dirlen + (size_t)n + 1);
        if (next) {
            memcpy(next, cur, dirlen);
            memcpy(next + dirlen, text, (size_t)n + 1);
        }
        free(cur);
        cur = next;
    }
    *err = ENOMEM;
    return NULL;
}
