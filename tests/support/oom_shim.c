/* An allocation-failure injector for the out-of-memory tests (tests/e2e/test_oom.c),
 * preloaded into the binary under test (LD_PRELOAD). It counts the calls to malloc,
 * calloc, realloc, posix_memalign, aligned_alloc and mmap made after it was loaded and
 * makes call number OOM_FAIL_AT fail as the C library does when memory runs out (NULL
 * or MAP_FAILED, errno ENOMEM); every other call goes to the C library. With
 * OOM_COUNT_FILE set it writes the number of calls it saw to that file at exit, so a
 * test knows how many failure points a command has. With OOM_MAX_BYTES set, every call
 * that asks for more bytes than that fails the same way: a program that must never
 * hold some big buffer (a whole image) is shown not to ask for it. Not linked into the
 * program. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <stdatomic.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <sys/mman.h>
#include <sys/syscall.h>
#include <unistd.h>

/* glibc's own entry points: dlsym may allocate before the real functions are known. */
extern void *__libc_malloc(size_t n);
extern void *__libc_calloc(size_t a, size_t b);
extern void *__libc_realloc(void *p, size_t n);
extern void *__libc_memalign(size_t align, size_t n);

static void *(*real_malloc)(size_t);
static void *(*real_calloc)(size_t, size_t);
static void *(*real_realloc)(void *, size_t);
static int (*real_posix_memalign)(void **, size_t, size_t);
static void *(*real_aligned_alloc)(size_t, size_t);
static void *(*real_mmap)(void *, size_t, int, int, int, off_t);

static long fail_at = -1;
static size_t max_bytes = (size_t)-1;
static atomic_long calls;
static atomic_bool armed;

__attribute__((constructor)) static void oom_init(void)
{
    const char *s = getenv("OOM_FAIL_AT");
    if (s)
        fail_at = atol(s);
    const char *m = getenv("OOM_MAX_BYTES");
    if (m)
        max_bytes = (size_t)strtoull(m, NULL, 10);
    real_malloc = (void *(*)(size_t))dlsym(RTLD_NEXT, "malloc");
    real_calloc = (void *(*)(size_t, size_t))dlsym(RTLD_NEXT, "calloc");
    real_realloc = (void *(*)(void *, size_t))dlsym(RTLD_NEXT, "realloc");
    real_posix_memalign = (int (*)(void **, size_t, size_t))dlsym(RTLD_NEXT, "posix_memalign");
    real_aligned_alloc = (void *(*)(size_t, size_t))dlsym(RTLD_NEXT, "aligned_alloc");
    real_mmap = (void *(*)(void *, size_t, int, int, int, off_t))dlsym(RTLD_NEXT, "mmap");
    atomic_store(&armed, true);
}

__attribute__((destructor)) static void oom_fini(void)
{
    const char *path = getenv("OOM_COUNT_FILE");
    if (!path)
        return;
    atomic_store(&armed, false); /* fopen below allocates */
    FILE *f = fopen(path, "w");
    if (f) {
        fprintf(f, "%ld\n", atomic_load(&calls));
        fclose(f);
    }
}

/* Whether this call, for n bytes, is to fail (counting only once armed). */
static bool oom_now_n(size_t n)
{
    if (!atomic_load(&armed))
        return false;
    return atomic_fetch_add(&calls, 1) + 1 == fail_at || n > max_bytes;
}

void *malloc(size_t n)
{
    if (oom_now_n(n)) {
        errno = ENOMEM;
        return NULL;
    }
    return real_malloc ? real_malloc(n) : __libc_malloc(n);
}

void *calloc(size_t a, size_t b)
{
    if (oom_now_n(b && a > (size_t)-1 / b ? (size_t)-1 : a * b)) {
        errno = ENOMEM;
        return NULL;
    }
    return real_calloc ? real_calloc(a, b) : __libc_calloc(a, b);
}

void *realloc(void *p, size_t n)
{
    if (oom_now_n(n)) {
        errno = ENOMEM;
        return NULL;
    }
    return real_realloc ? real_realloc(p, n) : __libc_realloc(p, n);
}

int posix_memalign(void **out, size_t align, size_t n)
{
    if (oom_now_n(n))
        return ENOMEM;
    if (real_posix_memalign)
        return real_posix_memalign(out, align, n);
    *out = __libc_memalign(align, n);
    return *out ? 0 : ENOMEM;
}

void *aligned_alloc(size_t align, size_t n)
{
    if (oom_now_n(n)) {
        errno = ENOMEM;
        return NULL;
    }
    return real_aligned_alloc ? real_aligned_alloc(align, n) : __libc_memalign(align, n);
}

void *mmap(void *addr, size_t n, int prot, int flags, int fd, off_t off)
{
    if (oom_now_n(n)) {
        errno = ENOMEM;
        return MAP_FAILED;
    }
    if (real_mmap)
        return real_mmap(addr, n, prot, flags, fd, off);
    return (void *)syscall(SYS_mmap, addr, n, prot, flags, fd, off);
}
