/* Helpers for end-to-end tests, header-only (each test binary is built from one .c):
 * temporary folders, running the binary under test without a shell (stdout and stderr
 * captured, stdin /dev/null, a time limit), files, and the course's -stats block. */
#ifndef RT_E2E_UTIL_H
#define RT_E2E_UTIL_H

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

/* 1 when this test program is built with AddressSanitizer or ThreadSanitizer (gcc's
 * macros, clang's __has_feature): their runtimes must load first, their shadow memory
 * fits no ulimit -v and their stack frames are larger, so tests that depend on those
 * skip: if (E2E_SANITIZED) harness_skip(why). */
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define E2E_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define E2E_SANITIZED 1
#endif
#endif
#ifndef E2E_SANITIZED
#define E2E_SANITIZED 0
#endif

/* ---- folders and files --------------------------------------------------------- */

/* Creates a fresh folder under $TMPDIR (or /tmp) into buf; NULL on failure. */
static inline char *e2e_tmpdir(char *buf, size_t size, const char *tag)
{
    const char *base = getenv("TMPDIR");
    if (!base || !*base)
        base = "/tmp";
    snprintf(buf, size, "%s/rt_%s.XXXXXX", base, tag);
    return mkdtemp(buf);
}

/* Removes a folder tree made by a test (files and sub-folders). */
static inline void e2e_rmtree(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    char p[PATH_MAX];
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        if (snprintf(p, sizeof p, "%s/%s", dir, e->d_name) >= (int)sizeof p)
            continue;
        struct stat st;
        if (lstat(p, &st) == 0 && S_ISDIR(st.st_mode))
            e2e_rmtree(p);
        else
            unlink(p);
    }
    closedir(d);
    rmdir(dir);
}

/* Number of entries in a folder other than . and ..; -1 when it cannot be opened. */
static inline int e2e_count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
            n++;
    closedir(d);
    return n;
}

static inline bool e2e_exists(const char *path)
{
    struct stat st;
    return stat(path, &st) == 0;
}

/* Whole file, NUL-terminated, malloc'd; NULL when unreadable. */
static inline char *e2e_read_file(const char *path, size_t *len_out)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 4096, len = 0;
    char *buf = malloc(cap + 1);
    size_t n;
    while (buf && (n = fread(buf + len, 1, cap - len, f)) > 0) {
        len += n;
        if (len == cap) {
            char *nb = realloc(buf, cap * 2 + 1);
            if (!nb) {
                free(buf);
                buf = NULL;
                break;
            }
            buf = nb;
            cap *= 2;
        }
    }
    fclose(f);
    if (!buf)
        return NULL;
    buf[len] = '\0';
    if (len_out)
        *len_out = len;
    return buf;
}

static inline bool e2e_write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return false;
    size_t n = strlen(text);
    bool ok = fwrite(text, 1, n, f) == n;
    return fclose(f) == 0 && ok;
}

/* "dir/name" into buf (truncation would be a test-setup bug; callers use PATH_MAX). */
static inline const char *e2e_join(char *buf, size_t size, const char *dir, const char *name)
{
    if (snprintf(buf, size, "%s/%s", dir, name) >= (int)size)
        buf[0] = '\0'; /* too long: an empty path fails loudly in the caller */
    return buf;
}

/* An absolute form of a path, without resolving symbolic links of the last part. */
static inline bool e2e_abspath(const char *path, char *buf, size_t size)
{
    if (path[0] == '/') {
        snprintf(buf, size, "%s", path);
        return true;
    }
    char cwd[PATH_MAX];
    if (!getcwd(cwd, sizeof cwd))
        return false;
    return snprintf(buf, size, "%s/%s", cwd, path) < (int)size;
}

/* ---- running a program --------------------------------------------------------- */

typedef struct E2eRun {
    int status;        /* exit code; 128 + signal when killed; -1 could not run */
    bool timed_out;
    char *out, *err;   /* captured stdout / stderr, NUL-terminated (never NULL) */
    size_t out_len, err_len;
    double seconds;    /* wall time */
} E2eRun;

static inline void e2e_run_free(E2eRun *r)
{
    free(r->out);
    free(r->err);
    r->out = r->err = NULL;
}

static inline double e2e_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static inline void e2e_append(char **buf, size_t *len, size_t *cap, const char *src, size_t n)
{
    if (*len + n + 1 > *cap) {
        size_t c = *cap ? *cap : 1024;
        while (c < *len + n + 1)
            c *= 2;
        char *nb = realloc(*buf, c);
        if (!nb)
            return; /* drop output rather than crash; the checks will then fail */
        *buf = nb;
        *cap = c;
    }
    memcpy(*buf + *len, src, n);
    *len += n;
    (*buf)[*len] = '\0';
}

/* The time limit of one run in seconds: RT_E2E_TIMEOUT, default 600 (renders under
 * the sanitizers are several times slower than optimised ones). */
static inline double e2e_timeout(void)
{
    const char *t = getenv("RT_E2E_TIMEOUT");
    double v = t ? atof(t) : 0.0;
    return v > 0.0 ? v : 600.0;
}

/* Runs argv[0] with argv (NULL-terminated) directly (fork + execv, no shell; argv[0]
 * is a path). Returns false only when the run could not be started. */
static inline bool e2e_run(char *const argv[], E2eRun *r)
{
    memset(r, 0, sizeof *r);
    r->status = -1;
    int po[2], pe[2];
    if (pipe(po) != 0)
        return false;
    if (pipe(pe) != 0) {
        close(po[0]);
        close(po[1]);
        return false;
    }
    fflush(stdout);
    fflush(stderr);
    double t0 = e2e_now();
    pid_t pid = fork();
    if (pid < 0) {
        close(po[0]); close(po[1]); close(pe[0]); close(pe[1]);
        return false;
    }
    if (pid == 0) {
        int devnull = open("/dev/null", O_RDONLY);
        if (devnull >= 0) {
            dup2(devnull, 0);
            close(devnull);
        }
        dup2(po[1], 1);
        dup2(pe[1], 2);
        close(po[0]); close(po[1]); close(pe[0]); close(pe[1]);
        execv(argv[0], argv);
        fprintf(stderr, "e2e: cannot run %s: %s\n", argv[0], strerror(errno));
        _exit(127);
    }
    close(po[1]);
    close(pe[1]);
    size_t ocap = 0, ecap = 0;
    e2e_append(&r->out, &r->out_len, &ocap, "", 0);
    e2e_append(&r->err, &r->err_len, &ecap, "", 0);
    struct pollfd fds[2] = {{po[0], POLLIN, 0}, {pe[0], POLLIN, 0}};
    int open_fds = 2;
    double limit = e2e_timeout();
    char chunk[8192];
    while (open_fds > 0) {
        double left = limit - (e2e_now() - t0);
        if (left <= 0) {
            r->timed_out = true;
            kill(pid, SIGKILL);
            break;
        }
        int ms = left > 1.0 ? 1000 : (int)(left * 1000.0) + 1;
        int n = poll(fds, 2, ms);
        if (n < 0 && errno != EINTR)
            break;
        for (int i = 0; i < 2; i++) {
            if (fds[i].fd < 0 || !(fds[i].revents & (POLLIN | POLLHUP | POLLERR)))
                continue;
            ssize_t got = read(fds[i].fd, chunk, sizeof chunk);
            if (got > 0) {
                if (i == 0)
                    e2e_append(&r->out, &r->out_len, &ocap, chunk, (size_t)got);
                else
                    e2e_append(&r->err, &r->err_len, &ecap, chunk, (size_t)got);
            } else if (got == 0 || errno != EINTR) {
                close(fds[i].fd);
                fds[i].fd = -1;
                open_fds--;
            }
        }
    }
    for (int i = 0; i < 2; i++)
        if (fds[i].fd >= 0)
            close(fds[i].fd);
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
    r->seconds = e2e_now() - t0;
    if (WIFEXITED(st))
        r->status = WEXITSTATUS(st);
    else if (WIFSIGNALED(st))
        r->status = 128 + WTERMSIG(st);
    return true;
}

/* Runs the binary under test (harness_bin()) with the given arguments (NULL-terminated,
 * not including the program name). */
static inline bool e2e_run_bin(const char *bin, const char *const *args, E2eRun *r)
{
    char *argv[128];
    int n = 0;
    argv[n++] = (char *)bin;
    for (int i = 0; args[i] && n < 127; i++)
        argv[n++] = (char *)args[i];
    argv[n] = NULL;
    return e2e_run(argv, r);
}

/* Starts argv (argv[0] a path, NULL-terminated) in the background for a test that
 * signals it: standard input and output on /dev/null, standard error into a pipe whose
 * read end is stored in *err_fd (NULL: /dev/null too). -1 when it cannot start. */
static inline pid_t e2e_spawn(const char *const *argv, int *err_fd)
{
    int errp[2] = {-1, -1};
    if (err_fd && pipe(errp) != 0)
        return -1;
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        int null = open("/dev/null", O_RDWR);
        dup2(null, 0);
        dup2(null, 1);
        dup2(err_fd ? errp[1] : null, 2);
        if (err_fd)
            close(errp[0]);
        execv(argv[0], (char *const *)argv);
        _exit(127);
    }
    if (err_fd) {
        close(errp[1]);
        if (pid < 0)
            close(errp[0]);
        else
            *err_fd = errp[0];
    }
    return pid;
}

/* Waits for pid at most limit_s seconds (a guard against a run that never ends, not a
 * timing condition), then kills it. True when it ended by itself; *status is its wait
 * status either way. */
static inline bool e2e_wait_or_kill(pid_t pid, int limit_s, int *status)
{
    for (int i = 0; i < limit_s * 10; i++) { /* steps of 0.1 s */
        if (waitpid(pid, status, WNOHANG) == pid)
            return true;
        nanosleep(&(struct timespec){0, 100 * 1000 * 1000}, NULL);
    }
    kill(pid, SIGKILL);
    while (waitpid(pid, status, 0) < 0) {
    }
    return false;
}

/* What fd holds (at most size - 1 bytes, as a string), then closes it. */
static inline void e2e_read_close(int fd, char *buf, size_t size)
{
    ssize_t n = read(fd, buf, size - 1);
    buf[n > 0 ? n : 0] = '\0';
    close(fd);
}

/* A stop signal while argv (argv[0] a path) reads its input from the FIFO fifo:
 * starts argv (e2e_spawn), waits until it opens the FIFO for reading (its signal
 * handlers are in place by then), sends sig, then writes the len bytes into the FIFO (a
 * reader that left meets EPIPE, not SIGPIPE) and closes it. True when the run ended by
 * itself within 60 s (a guard against a hang, not a timing condition): its wait status
 * in *status, its standard error in err. False with the reason in err otherwise. */
static inline bool e2e_signal_while_reading(const char *const *argv, const char *fifo,
                                            int sig, const void *bytes, size_t len,
                                            int *status, char *err, size_t errlen)
{
    int errfd = -1;
    *status = 0;
    err[0] = '\0';
    pid_t pid = e2e_spawn(argv, &errfd);
    if (pid <= 0) {
        snprintf(err, errlen, "cannot start %s", argv[0]);
        return false;
    }
    alarm(120); /* the same guard, should the open below never return */
    int fd = open(fifo, O_WRONLY);
    int open_err = errno;
    bool opened = fd >= 0;
    kill(pid, opened ? sig : SIGKILL);
    /* The run may open the FIFO more than once: with -cache the OBJ reader takes the
     * file's identity (open, fstat, close), then opens it again to read. Bytes written
     * between those opens meet EPIPE, and the second open then waited for a writer for
     * ever (test_reliability's sigterm_during_setup, with the OBJ file as its FIFO,
     * failed 7 runs in 20 that way). So the bytes go again to each later reader, until
     * one takes them whole or the run ends (reaped here, then). */
    bool reaped = false;
    struct sigaction ign, old;
    memset(&ign, 0, sizeof ign);
    ign.sa_handler = SIG_IGN;
    sigaction(SIGPIPE, &ign, &old);
    for (int polls = 0; fd >= 0;) {
        ssize_t w = write(fd, bytes, len);
        close(fd);
        fd = -1;
        if (w == (ssize_t)len)
            break;
        /* steps of 10 ms, 60 s at most: the guard again */
        for (; fd < 0 && !reaped && polls < 6000; polls++) {
            reaped = waitpid(pid, status, WNOHANG) == pid;
            fd = reaped ? -1 : open(fifo, O_WRONLY | O_NONBLOCK); /* ENXIO: no reader */
            if (fd < 0 && !reaped)
                nanosleep(&(struct timespec){0, 10 * 1000 * 1000}, NULL);
        }
        if (fd >= 0)
            fcntl(fd, F_SETFL, fcntl(fd, F_GETFL) & ~O_NONBLOCK);
    }
    sigaction(SIGPIPE, &old, NULL);
    bool ended = reaped || e2e_wait_or_kill(pid, 60, status);
    alarm(0);
    e2e_read_close(errfd, err, errlen);
    if (!opened) {
        snprintf(err, errlen, "cannot open the FIFO %s: %s", fifo, strerror(open_err));
        return false;
    }
    if (!ended)
        snprintf(err, errlen, "still running 60 s after the signal");
    return ended;
}

/* A readable one-line summary of a failed run, for CHECK_MSG. */
static inline const char *e2e_describe(const E2eRun *r, char *buf, size_t size)
{
    snprintf(buf, size, "exit %d%s; stderr: %.300s", r->status,
             r->timed_out ? " (timed out)" : "", r->err ? r->err : "");
    return buf;
}

/* ---- the -stats block (docs/statistics.md) -------------------------------------- */

/* Writes a reason into why and returns false (vsnprintf: a long reason is cut). */
static inline bool e2e_why(char *why, size_t size, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static inline bool e2e_why(char *why, size_t size, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(why, size, fmt, ap);
    va_end(ap);
    return false;
}

enum { E2E_STATS_LINES = 15, E2E_STATS_LABELS = 12 };

static const char *const e2e_stats_labels[E2E_STATS_LABELS] = {
    "total time", "num pixels", "scene bounds", "num grid cells",
    "num non-shadow rays", "num shadow rays", "total intersections",
    "total cells traversed", "rays per second", "rays per pixel",
    "intersections per ray", "cells traversed per ray",
};

typedef struct E2eStats {
    bool found;
    char lines[E2E_STATS_LINES][256];      /* the block's lines, without newlines */
    char values[E2E_STATS_LABELS][200];    /* text after each label, leading spaces cut */
    unsigned long long nonshadow, shadow, intersections, cells;
} E2eStats;

/* Finds the block in text (the line "RAY TRACING STATISTICS" and the line before it)
 * and extracts the value of every label, leniently: values[] are filled even when the
 * layout is off, so peer files with another time format can be read too. */
static inline bool e2e_stats_parse(const char *text, E2eStats *s)
{
    memset(s, 0, sizeof *s);
    const char *title = strstr(text, "\nRAY TRACING STATISTICS\n");
    if (!title)
        return false;
    const char *start = title;
    while (start > text && start[-1] != '\n')
        start--;
    const char *p = start;
    for (int i = 0; i < E2E_STATS_LINES && *p; i++) {
        const char *nl = strchr(p, '\n');
        size_t n = nl ? (size_t)(nl - p) : strlen(p);
        if (n >= sizeof s->lines[i])
            n = sizeof s->lines[i] - 1;
        memcpy(s->lines[i], p, n);
        s->lines[i][n] = '\0';
        p = nl ? nl + 1 : p + n;
    }
    for (int k = 0; k < E2E_STATS_LABELS; k++) {
        const char *line = s->lines[k + 2];
        const char *at = strstr(line, e2e_stats_labels[k]);
        if (!at)
            continue;
        at += strlen(e2e_stats_labels[k]);
        while (*at == ' ')
            at++;
        snprintf(s->values[k], sizeof s->values[k], "%s", at);
    }
    s->nonshadow = strtoull(s->values[4], NULL, 10);
    s->shadow = strtoull(s->values[5], NULL, 10);
    s->intersections = strtoull(s->values[6], NULL, 10);
    s->cells = strtoull(s->values[7], NULL, 10);
    s->found = true;
    return true;
}

/* Checks the exact layout of the course's block: 15 lines, 44 asterisks around, the
 * title, the labels with their values in column 30, the formats of
 * time/pixels/bounds/grid cells/ counters/ratios. Writes the first problem into why and
 * returns false. */
static inline bool e2e_stats_layout_ok(const E2eStats *s, int width, int height, char *why,
                                       size_t size)
{
    static const char stars[] = "********************************************";
    if (!s->found)
        return e2e_why(why, size, "no RAY TRACING STATISTICS block on stdout");
    if (strcmp(s->lines[0], stars) != 0 || strcmp(s->lines[14], stars) != 0)
        return e2e_why(why, size, "first/last line is not 44 asterisks: '%s' / '%s'",
                        s->lines[0], s->lines[14]);
    if (strcmp(s->lines[1], "RAY TRACING STATISTICS") != 0)
        return e2e_why(why, size, "line 2 is '%s'", s->lines[1]);
    for (int k = 0; k < E2E_STATS_LABELS; k++) {
        const char *line = s->lines[k + 2];
        char prefix[64];
        snprintf(prefix, sizeof prefix, "  %-27s", e2e_stats_labels[k]);
        if (strncmp(line, prefix, 29) != 0 || line[29] == ' ' || line[29] == '\0')
            return e2e_why(why, size, "line %d: '%s' (want label '%s' and the value in "
                            "column 30)", k + 3, line, e2e_stats_labels[k]);
    }
    /* total time H:MM:SS */
    unsigned hh, mm, ss;
    char again_t[64];
    if (sscanf(s->values[0], "%u:%u:%u", &hh, &mm, &ss) != 3 || mm > 59 || ss > 59 ||
        (snprintf(again_t, sizeof again_t, "%u:%02u:%02u", hh, mm, ss),
         strcmp(again_t, s->values[0]) != 0))
        return e2e_why(why, size, "total time '%s' is not H:MM:SS", s->values[0]);
    char want[128];
    snprintf(want, sizeof want, "%d (%dx%d)", width * height, width, height);
    if (strcmp(s->values[1], want) != 0)
        return e2e_why(why, size, "num pixels '%s', expected '%s'", s->values[1], want);
    if (strcmp(s->values[2], "NULL") != 0) {
        double b[6];
        char again[200];
        if (sscanf(s->values[2], "%lf %lf %lf -> %lf %lf %lf", &b[0], &b[1], &b[2], &b[3],
                   &b[4], &b[5]) != 6)
            return e2e_why(why, size, "scene bounds '%s' unreadable", s->values[2]);
        snprintf(again, sizeof again, "%f %f %f  -> %f %f %f", b[0], b[1], b[2], b[3], b[4],
                 b[5]);
        if (strcmp(again, s->values[2]) != 0)
            return e2e_why(why, size, "scene bounds '%s' not in the format '%s'",
                            s->values[2], again);
    }
    if (strcmp(s->values[3], "NULL") != 0) {
        int n, x, y, z;
        char again[128];
        if (sscanf(s->values[3], "%d (%dx%dx%d)", &n, &x, &y, &z) != 4)
            return e2e_why(why, size, "num grid cells '%s' unreadable", s->values[3]);
        snprintf(again, sizeof again, "%d (%dx%dx%d)", x * y * z, x, y, z);
        if (strcmp(again, s->values[3]) != 0)
            return e2e_why(why, size, "num grid cells '%s', expected '%s'", s->values[3],
                            again);
    }
    for (int k = 4; k < 8; k++) {
        const char *v = s->values[k];
        if (!*v || strspn(v, "0123456789") != strlen(v))
            return e2e_why(why, size, "%s '%s' is not an unsigned integer",
                            e2e_stats_labels[k], v);
    }
    for (int k = 8; k < 12; k++) {
        const char *v = s->values[k];
        const char *dot = strchr(v, '.');
        bool ok = dot && dot > v && strlen(dot) == 2 && dot[1] >= '0' && dot[1] <= '9' &&
                  strspn(v, "0123456789") == (size_t)(dot - v);
        if (!ok && strcmp(v, "nan") != 0 && strcmp(v, "-nan") != 0)
            return e2e_why(why, size, "%s '%s' is not %%0.1f", e2e_stats_labels[k], v);
    }
    /* The ratios follow from the counters; allow printf rounding. */
    double rays = (double)(s->nonshadow + s->shadow);
    double pix = (double)width * height;
    double expect[3] = {rays / pix, rays > 0 ? (double)s->intersections / rays : 0.0,
                        rays > 0 ? (double)s->cells / rays : 0.0};
    for (int k = 0; k < 3; k++) {
        double got = atof(s->values[9 + k]);
        if (rays > 0 && !(got >= expect[k] - 0.051 && got <= expect[k] + 0.051))
            return e2e_why(why, size, "%s is %s, counters give %.3f", e2e_stats_labels[9 + k],
                            s->values[9 + k], expect[k]);
    }
    return true;
}


/* One line "<id>|<arguments>" of the course's commands.txt, split into arguments. */
typedef struct E2eCourseLine {
    char id[16];
    int argc;
    char *argv[64];      /* pointers into text */
    char text[1024];
} E2eCourseLine;

/* A line that is not in commands.txt (same form: arguments run in the course folder). */
static inline void e2e_course_line_set(E2eCourseLine *cl, const char *id, const char *args)
{
    snprintf(cl->id, sizeof cl->id, "%s", id);
    snprintf(cl->text, sizeof cl->text, "%s", args);
    cl->argc = 0;
    for (char *tok = strtok(cl->text, " \t\r"); tok && cl->argc < 63;
         tok = strtok(NULL, " \t\r"))
        cl->argv[cl->argc++] = tok;
    cl->argv[cl->argc] = NULL;
}

static inline bool e2e_course_line(const char *course, const char *id, E2eCourseLine *cl)
{
    char path[PATH_MAX];
    char *all = e2e_read_file(e2e_join(path, sizeof path, course, "commands.txt"), NULL);
    if (!all)
        return false;
    bool found = false;
    size_t idlen = strlen(id);
    for (char *line = all; line && *line;) {
        char *nl = strchr(line, '\n');
        if (nl)
            *nl = '\0';
        if (strncmp(line, id, idlen) == 0 && line[idlen] == '|') {
            e2e_course_line_set(cl, id, line + idlen + 1);
            found = true;
            break;
        }
        line = nl ? nl + 1 : NULL;
    }
    free(all);
    return found;
}

static inline bool e2e_course_has_arg(const E2eCourseLine *cl, const char *flag)
{
    for (int i = 0; i < cl->argc; i++)
        if (strcmp(cl->argv[i], flag) == 0)
            return true;
    return false;
}

/* The course folder, or SKIP when it is absent; a missing binary fails the test. */
static inline const char *e2e_course_or_skip(void)
{
    const char *course = harness_course_dir();
    if (!course)
        harness_skip("course folder absent (set RT_COURSE or put it at ../shared/course)");
    if (access(harness_bin(), X_OK) != 0) {
        harness_fail(__FILE__, __LINE__, "binary under test %s not found (run make first)",
                     harness_bin());
        fflush(stdout);
        _exit(1);
    }
    return course;
}

#endif
