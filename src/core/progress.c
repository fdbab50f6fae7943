/* The progress line (rt/progress.h): workers add to atomic counters; one thread wakes
 * every 100 ms, formats the line and redraws it with a carriage return on a terminal,
 * or, into a file or a pipe, appends it as a whole line now and then. */
#include "rt/progress.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "rt/clock.h"

/* At most ten redraws a second: smooth enough to read, too few to cost anything. */
#define PROGRESS_PERIOD_NS 100000000L

/* Into a log (not a terminal) a redraw cannot overwrite anything: ten carriage-return
 * updates a second made ~2 MB of log an hour. There a line is appended only once both
 * 5% more of the work is done and 30 s have passed since the last line (or the start)
 * (PROGRESS_LOG_STEPS, PROGRESS_LOG_SECONDS), so a run leaves at most 19 such lines,
 * 30 s apart at least, plus the final line that progress_finish appends. The text of a
 * line is the terminal's, so a script reads either the same way. */

struct Progress {
    _Atomic uint64_t done, rays;
    uint64_t total;
    FILE *out;
    const char *what;
    double t0;
    size_t drawn;            /* length of the longest line drawn (what must be erased) */
    bool log;                /* out is not a terminal: whole lines, rarely (see above) */
    uint64_t logged;         /* log: units done at the last line appended */
    double logged_at;        /* log: clock_now() of the last line (or of the start) */
    pthread_t thread;
    pthread_mutex_t lock;    /* guards stop; the drawer waits on wake */
    pthread_cond_t wake;
    bool stop;
};

bool progress_wanted(ProgressMode mode, FILE *out)
{
    if (mode == PROGRESS_NEVER || !out)
        return false;
    if (mode == PROGRESS_ALWAYS)
        return true;
    return isatty(fileno(out)) == 1;
}

static void format_duration(char *buf, size_t size, double seconds)
{
    if (!(seconds >= 0.0))
        seconds = 0.0;
    if (seconds > 359999.0)
        seconds = 359999.0; /* 99:59:59 at most: an estimate beyond that says nothing */
    long s = (long)(seconds + 0.5);
    if (s >= 3600)
        snprintf(buf, size, "%ld:%02ld:%02ld", s / 3600, s / 60 % 60, s % 60);
    else
        snprintf(buf, size, "%ld:%02ld", s / 60, s % 60);
}

void progress_format(char *buf, size_t size, const char *what, uint64_t done, uint64_t total,
                     uint64_t rays, double elapsed_seconds)
{
    if (done > total)
        done = total;
    int percent = total ? (int)(done * 100 / total) : 100;
    char elapsed[32], left[32] = "", rate[48] = "";
    format_duration(elapsed, sizeof elapsed, elapsed_seconds);
    if (done > 0 && done < total) {
        char t[24];
        format_duration(t, sizeof t, elapsed_seconds * (double)(total - done) / (double)done);
        snprintf(left, sizeof left, ", %s left", t);
    }
    if (rays > 0 && elapsed_seconds > 0.0) {
        double r = (double)rays / elapsed_seconds;
        if (r >= 1e6)
            snprintf(rate, sizeof rate, "  %.2f Mrays/s", r * 1e-6);
        else if (r >= 1e3)
            snprintf(rate, sizeof rate, "  %.0f krays/s", r * 1e-3);
        else
            snprintf(rate, sizeof rate, "  %.0f rays/s", r);
    }
    snprintf(buf, size, "%s %3d%%%s  %s elapsed%s", what, percent, rate, elapsed, left);
}

/* The log's rule: whether a line is due with done units after now. The last line of
 * a finished run is left to progress_finish, which always writes one. */
static bool log_line_due(const Progress *p, uint64_t done, double now)
{
    uint64_t step = (p->total + PROGRESS_LOG_STEPS - 1) / PROGRESS_LOG_STEPS;
    return done < p->total && done - p->logged >= step &&
           now - p->logged_at >= PROGRESS_LOG_SECONDS;
}

/* Draws the line (a terminal) or appends it when one is due (a log; every time when
 * final). */
static void draw(Progress *p, bool final)
{
    char line[160];
    uint64_t done = atomic_load_explicit(&p->done, memory_order_relaxed);
    double now = clock_now();
    if (p->log) {
        if (!final && !log_line_due(p, done, now))
            return;
        p->logged = done;
        p->logged_at = now;
    }
    progress_format(line, sizeof line, p->what, done, p->total,
                    atomic_load_explicit(&p->rays, memory_order_relaxed), now - p->t0);
    if (p->log) {
        fprintf(p->out, "%s\n", line);
        fflush(p->out);
        return;
    }
    size_t n = strlen(line);
    /* Blanks over what a longer earlier line left (no terminal escape needed). */
    fprintf(p->out, "\r%s%*s", line, p->drawn > n ? (int)(p->drawn - n) : 0, "");
    fflush(p->out);
    if (n > p->drawn)
        p->drawn = n;
}

static void *drawer_main(void *arg)
{
    Progress *p = arg;
    pthread_mutex_lock(&p->lock);
    while (!p->stop) {
        struct timespec until;
        clock_gettime(CLOCK_MONOTONIC, &until);
        until.tv_nsec += PROGRESS_PERIOD_NS;
        if (until.tv_nsec >= 1000000000L) {
            until.tv_nsec -= 1000000000L;
            until.tv_sec++;
        }
        int rc = 0; /* 0: woken early (spurious or stop); else timed out (or an error) */
        while (!p->stop && rc == 0)
            rc = pthread_cond_timedwait(&p->wake, &p->lock, &until);
        if (p->stop)
            break;
        pthread_mutex_unlock(&p->lock);
        draw(p, false);
        pthread_mutex_lock(&p->lock);
    }
    pthread_mutex_unlock(&p->lock);
    return NULL;
}

Progress *progress_start(ProgressMode mode, FILE *out, const char *what, uint64_t total)
{
    if (total == 0 || !progress_wanted(mode, out))
        return NULL;
    Progress *p = calloc(1, sizeof *p);
    if (!p)
        return NULL;
    atomic_init(&p->done, 0);
    atomic_init(&p->rays, 0);
    p->total = total;
    p->out = out;
    p->what = what;
    p->t0 = clock_now();
    p->log = isatty(fileno(out)) != 1;
    p->logged_at = p->t0;
    pthread_condattr_t ca;
    bool ok = pthread_condattr_init(&ca) == 0;
    ok = ok && pthread_condattr_setclock(&ca, CLOCK_MONOTONIC) == 0 &&
         pthread_cond_init(&p->wake, &ca) == 0;
    pthread_condattr_destroy(&ca);
    if (!ok) {
        free(p);
        return NULL;
    }
    pthread_mutex_init(&p->lock, NULL);
    /* On a terminal the first line is drawn here, so even a short run shows (and
     * erases) it; a log gets its first line when one is due. */
    draw(p, false);
    if (pthread_create(&p->thread, NULL, drawer_main, p) != 0) {
        if (p->drawn > 0)
            fprintf(out, "\r%*s\r", (int)p->drawn, "");
        pthread_cond_destroy(&p->wake);
        pthread_mutex_destroy(&p->lock);
        free(p);
        return NULL;
    }
    return p;
}

void progress_add(Progress *p, uint64_t units, uint64_t rays)
{
    if (!p)
        return;
    atomic_fetch_add_explicit(&p->done, units, memory_order_relaxed);
    if (rays)
        atomic_fetch_add_explicit(&p->rays, rays, memory_order_relaxed);
}

uint64_t progress_done(const Progress *p)
{
    return p ? atomic_load_explicit(&((Progress *)p)->done, memory_order_relaxed) : 0;
}

void progress_finish(Progress *p)
{
    if (!p)
        return;
    pthread_mutex_lock(&p->lock);
    p->stop = true;
    pthread_cond_signal(&p->wake);
    pthread_mutex_unlock(&p->lock);
    pthread_join(p->thread, NULL);
    if (p->log)
        draw(p, true); /* where the work ended: 100%, or how far a stopped run got */
    else if (p->drawn > 0) {
        fprintf(p->out, "\r%*s\r", (int)p->drawn, "");
        fflush(p->out);
    }
    pthread_cond_destroy(&p->wake);
    pthread_mutex_destroy(&p->lock);
    free(p);
}
