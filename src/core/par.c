/* Set-up parallelism (rt/par.h): one job at a time, its chunks handed out under a spin
 * lock to the caller and to detached helper threads that linger briefly between jobs,
 * or stay (asleep when idle) from par_hold to par_release. */
#ifdef __linux__
#define _GNU_SOURCE /* pthread_attr_setaffinity_np, sched_getcpu */
#endif
#include "rt/par.h"

#include <pthread.h>
#include <sched.h>
#include <stdatomic.h>
#include <stdint.h>
#include <time.h>
#include <unistd.h>

/* How long an idle helper waits for the next job before it exits. The serial stretches
 * between two parallel steps of the set-up (the rest of the scene after its OBJ file,
 * the grid's walk) last about a millisecond on the 40k bunny, while a new thread took
 * from 0.05 to 5 ms to get a CPU on the 2-core virtual machines measured (its vCPU is
 * asleep). So a helper that is already running is kept a while. */
#define PAR_LINGER_NS 3000000LL
/* How long of that an idle helper spins before it sleeps until the next job (or the
 * deadline). Back-to-back jobs (the OBJ file's read, parse and placement) follow each
 * other within microseconds and find it spinning; across a longer serial stretch a
 * spinning helper would burn a whole CPU for nothing (it did: the 40k bunny's set-up
 * took 53-75 ms of CPU with -threads 2 against 34-37 ms with one), while a sleeping one
 * costs nothing and, woken late, only leaves more chunks to the caller. */
#define PAR_SPIN_NS 50000LL
/* Past PAR_SPIN_NS, a caller of par_for waiting for the chunks a helper still runs keeps
 * looking between sched_yield calls, up to PAR_YIELD_NS after it began to wait, before
 * it sleeps. Why: on the 2-core virtual machines measured, a thread put to sleep woke
 * 0.07-0.15 ms after its condition variable was signalled on a quiet host (the median;
 * 0.3-1.5 ms at the 90th percentile, several ms at worst: an idle vCPU is slow to wake),
 * and the caller, asleep when the helper finishes, ends the job that much late: at the
 * end of each set-up step the helper took the last chunk of, and at the end of every
 * render with threads (the render's workers are one par_try_for: the first to run out
 * of bands waits for the other's last part, ~0.35 ms at 1080p). Yielding, it keeps its
 * vCPU awake on a quiet host and gives the CPU away on a busy one; what it burns is at
 * most the rest of the helper's chunk. (An idle helper does not: yielding between jobs
 * burnt up to 2 ms per gap of the set-up, ~9 gaps a run, too dear for small renders.) */
#define PAR_YIELD_NS 2000000LL

/* Everything below is guarded by g_lock. A spin lock, not a mutex: a thread put to
 * sleep on a contended mutex can take milliseconds to wake on those machines, and the
 * lock is held for a few instructions only. */
static atomic_flag g_lock = ATOMIC_FLAG_INIT;
static struct {
    ParChunkFn fn;
    void *ctx;
    int n, next, done;
    bool open;
} g_job;
static bool g_alive[PAR_MAX_WORKERS]; /* helper slots 1.. taken (0 is the caller) */
static int64_t g_deadline;            /* idle helpers exit after it (CLOCK_MONOTONIC ns) */
static bool g_hold;                   /* par_hold: idle helpers stay until par_release */
static int g_want = -1;               /* par_set_helpers; < 0: automatic */
static bool g_running;                /* a par_for is in progress */
/* par_background's task: pieces next.. wait for a helper; busy: one is running (they
 * run one at a time, in order); lost: a forked child's copy, whose helper is gone. */
static struct {
    ParPieceFn fn;
    void *ctx;
    int n, next, done;
    bool posted, busy, lost;
} g_bg;
static pthread_once_t g_once = PTHREAD_ONCE_INIT;

/* Sleeping helpers wait on g_wake under g_sleep_lock; g_sleepers (under g_sleep_lock)
 * counts them. A helper counts itself and checks for a job under g_sleep_lock before
 * it waits, and whoever opens a job (or ends the lingering) takes g_sleep_lock before
 * it looks at g_sleepers, so no wake-up is lost. The caller of par_for waiting for
 * the last chunk a helper holds sleeps on g_done the same way (g_caller_waits, and the
 * helper finishing the last chunk looks at it under g_sleep_lock). */
static pthread_mutex_t g_sleep_lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t g_wake;
static pthread_cond_t g_done;   /* the caller of par_for waits on it for the last chunk */
static bool g_caller_waits;     /* under g_sleep_lock */
static int g_sleepers;
static bool g_wake_ok; /* g_wake and g_done were initialised (on CLOCK_MONOTONIC) */

static inline void cpu_relax(void)
{
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}

static void lock(void)
{
    while (atomic_flag_test_and_set_explicit(&g_lock, memory_order_acquire))
        cpu_relax();
}

static void unlock(void) { atomic_flag_clear_explicit(&g_lock, memory_order_release); }

static int64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (int64_t)t.tv_sec * 1000000000LL + t.tv_nsec;
}

/* g_wake on the clock of the deadlines (also in a forked child, where nobody waits on
 * it); g_wake_ok false when that cannot be had. */
static void wake_init(void)
{
    pthread_condattr_t ca;
    g_wake_ok = false;
    if (pthread_condattr_init(&ca) != 0)
        return;
    g_wake_ok = pthread_condattr_setclock(&ca, CLOCK_MONOTONIC) == 0 &&
                pthread_cond_init(&g_wake, &ca) == 0 && pthread_cond_init(&g_done, &ca) == 0;
    pthread_condattr_destroy(&ca);
}

/* A forked child has only the forking thread: forget the parent's helpers (and a lock
 * one of them may have held at the fork). */
static void reset_in_child(void)
{
    atomic_flag_clear(&g_lock);
    for (int w = 0; w < PAR_MAX_WORKERS; w++)
        g_alive[w] = false;
    g_job.open = false;
    g_running = false;
    g_hold = false; /* the child has no helper to keep; its own start anew */
    g_bg.busy = false;
    g_bg.lost = g_bg.posted; /* a piece may have been half run: none is run again */
    pthread_mutex_init(&g_sleep_lock, NULL);
    g_sleepers = 0;
    g_caller_waits = false;
    wake_init();
}

static int g_auto; /* helpers by default: online CPUs - 1 (set once) */

static void init_once(void)
{
    pthread_atfork(NULL, NULL, reset_in_child);
    wake_init();
    long h = sysconf(_SC_NPROCESSORS_ONLN) - 1;
    g_auto = h < 0 ? 0 : h > PAR_MAX_WORKERS - 1 ? PAR_MAX_WORKERS - 1 : (int)h;
}

/* Whether a chunk is waiting for a helper (under g_lock). */
static bool chunk_waiting(void) { return g_job.open && g_job.next < g_job.n; }

/* Whether a piece of the background task may be taken now (under g_lock). */
static bool piece_waiting(void)
{
    return g_bg.posted && !g_bg.lost && !g_bg.busy && g_bg.next < g_bg.n;
}

/* Runs the next piece (under g_lock, which it releases and takes again). */
static void run_piece(void)
{
    int i = g_bg.next++;
    g_bg.busy = true;
    ParPieceFn fn = g_bg.fn;
    void *ctx = g_bg.ctx;
    unlock();
    fn(ctx, i);
    lock(); /* the release of the next unlock publishes the piece's writes */
    g_bg.done++;
    g_bg.busy = false;
}

/* An idle helper's sleep: until a job opens or the deadline passes (a little past it:
 * the caller rechecks). Without a usable condition variable it just yields. */
static void helper_sleep(void)
{
    if (!g_wake_ok) {
        sched_yield();
        return;
    }
    pthread_mutex_lock(&g_sleep_lock);
    g_sleepers++;
    lock();
    bool wait = !chunk_waiting() && !piece_waiting();
    int64_t until = g_deadline;
    bool held = g_hold;
    unlock();
    if (wait && held) {
        pthread_cond_wait(&g_wake, &g_sleep_lock); /* par_for or par_release wakes it */
    } else if (wait) {
        if (until < now_ns() + 1000)
            until = now_ns() + 1000;
        struct timespec ts = {(time_t)(until / 1000000000LL), (long)(until % 1000000000LL)};
        pthread_cond_timedwait(&g_wake, &g_sleep_lock, &ts);
    }
    g_sleepers--;
    pthread_mutex_unlock(&g_sleep_lock);
}

/* The caller's sleep until the job's last chunk is done (helper_done wakes it), or a
 * millisecond at most (the caller rechecks). */
static void caller_sleep(void)
{
    if (!g_wake_ok) {
        sched_yield();
        return;
    }
    pthread_mutex_lock(&g_sleep_lock);
    g_caller_waits = true;
    lock();
    bool wait = g_job.done < g_job.n;
    unlock();
    if (wait) {
        int64_t until = now_ns() + 1000000LL;
        struct timespec ts = {(time_t)(until / 1000000000LL), (long)(until % 1000000000LL)};
        pthread_cond_timedwait(&g_done, &g_sleep_lock, &ts);
    }
    g_caller_waits = false;
    pthread_mutex_unlock(&g_sleep_lock);
}

/* A helper finished the job's last chunk: wakes the caller if it sleeps. */
static void helper_done(void)
{
    pthread_mutex_lock(&g_sleep_lock);
    if (g_caller_waits)
        pthread_cond_signal(&g_done);
    pthread_mutex_unlock(&g_sleep_lock);
}

/* Wakes the sleeping helpers (a job opened, or the lingering ended). */
static void wake_helpers(void)
{
    if (!g_wake_ok)
        return;
    pthread_mutex_lock(&g_sleep_lock);
    if (g_sleepers > 0)
        pthread_cond_broadcast(&g_wake);
    pthread_mutex_unlock(&g_sleep_lock);
}

static void *helper_main(void *arg)
{
    int worker = (int)(intptr_t)arg;
    int64_t idle_since = -1; /* when this helper last found nothing to do */
    for (;;) {
        int64_t t = now_ns();
        lock();
        if (chunk_waiting()) {
            int i = g_job.next++;
            ParChunkFn fn = g_job.fn;
            void *ctx = g_job.ctx;
            unlock();
            fn(ctx, i, worker);
            lock(); /* the release of this unlock publishes the chunk's writes */
            bool last = ++g_job.done == g_job.n;
            unlock();
            if (last && g_wake_ok)
                helper_done();
            idle_since = -1;
            continue;
        }
        /* Idle: a piece of the background task, if one waits (par_for's chunks come
         * first: a job that opens meanwhile waits at most for the piece). */
        if (piece_waiting()) {
            run_piece();
            unlock();
            idle_since = -1;
            continue;
        }
        if (!g_job.open && !g_hold && t > g_deadline) {
            g_alive[worker] = false;
            unlock();
            return NULL;
        }
        unlock();
        if (idle_since < 0)
            idle_since = t;
        if (t - idle_since < PAR_SPIN_NS) {
            cpu_relax();
            continue;
        }
        helper_sleep();
        idle_since = -1;
    }
}

static int helpers_wanted(void)
{
    pthread_once(&g_once, init_once);
    int want = g_want < 0 ? g_auto : g_want;
    return want < PAR_MAX_WORKERS - 1 ? want : PAR_MAX_WORKERS - 1;
}

/* (par.h) Linux tends to start a new thread on its creator's CPU, and a helper that never
 * sleeps then halves the creator's speed until the load balancer moves one of them
 * (measured: about half the runs, for milliseconds). So helpers start on the other
 * CPUs. Best effort: without the call the helper runs anywhere. */
void par_attr_keep_off_this_cpu(pthread_attr_t *attr)
{
#ifdef __linux__
    int me = sched_getcpu();
    cpu_set_t set;
    CPU_ZERO(&set);
    if (me < 0 || sched_getaffinity(0, sizeof set, &set) != 0 || !CPU_ISSET(me, &set))
        return;
    CPU_CLR(me, &set);
    if (CPU_COUNT(&set) > 0)
        pthread_attr_setaffinity_np(attr, sizeof set, &set);
#else
    (void)attr;
#endif
}

void par_thread_release_cpus(void)
{
#ifdef __linux__
    cpu_set_t set;
    CPU_ZERO(&set);
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    for (long c = 0; c < n && c < CPU_SETSIZE; c++)
        CPU_SET((int)c, &set);
    sched_setaffinity(0, sizeof set, &set); /* best effort */
#endif
}

/* Starts the helpers that are wanted and not running. A helper that cannot be started
 * is simply missing: the caller runs its chunks. */
static void ensure_helpers(void)
{
    int want = helpers_wanted();
    for (int w = 1; w <= want; w++) {
        lock();
        bool start = !g_alive[w];
        g_alive[w] = true;
        unlock();
        if (!start)
            continue;
        pthread_attr_t attr;
        pthread_t tid;
        bool ok = pthread_attr_init(&attr) == 0;
        ok = ok && pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED) == 0;
        if (ok)
            par_attr_keep_off_this_cpu(&attr);
        ok = ok && pthread_create(&tid, &attr, helper_main, (void *)(intptr_t)w) == 0;
        pthread_attr_destroy(&attr);
        if (!ok) {
            lock();
            g_alive[w] = false;
            unlock();
        }
    }
}

void par_prepare(void)
{
    if (helpers_wanted() == 0)
        return;
    int64_t t = now_ns();
    lock();
    if (g_deadline < t + PAR_LINGER_NS)
        g_deadline = t + PAR_LINGER_NS;
    unlock();
    ensure_helpers();
}

void par_hold(void)
{
    /* Without a condition variable an idle helper only yields: held, it would spin. */
    if (helpers_wanted() == 0 || !g_wake_ok)
        return;
    lock();
    g_hold = true;
    unlock();
    ensure_helpers();
}

void par_release(void)
{
    lock();
    g_hold = false;
    g_deadline = 0;
    unlock();
    wake_helpers(); /* to exit now */
}

int par_helpers_running(void)
{
    int n = 0;
    lock();
    for (int w = 1; w < PAR_MAX_WORKERS; w++)
        n += g_alive[w];
    unlock();
    return n;
}

bool par_caller_asleep(void)
{
    pthread_mutex_lock(&g_sleep_lock);
    bool asleep = g_caller_waits;
    pthread_mutex_unlock(&g_sleep_lock);
    return asleep;
}

void par_set_helpers(int n) { g_want = n; }

int par_threads(void) { return 1 + helpers_wanted(); }

/* par_for and par_try_for; shared_only: give up (false, nothing run) rather than run inline
 * when the helpers cannot take part as asked. */
static bool run_job(int n, ParChunkFn fn, void *ctx, bool shared_only)
{
    if (n <= 0)
        return true;
    if (shared_only && (n == 1 || n > 1 + helpers_wanted()))
        return false;
    lock();
    bool inline_only = g_running || n == 1;
    if (!inline_only)
        g_running = true;
    unlock();
    if (shared_only && inline_only)
        return false;
    if (inline_only || helpers_wanted() == 0) {
        for (int i = 0; i < n; i++)
            fn(ctx, i, 0);
        if (!inline_only) {
            lock();
            g_running = false;
            unlock();
        }
        return true;
    }
    int64_t t = now_ns();
    lock();
    g_job.fn = fn;
    g_job.ctx = ctx;
    g_job.n = n;
    g_job.next = 0;
    g_job.done = 0;
    g_job.open = true;
    g_deadline = t + PAR_LINGER_NS;
    unlock();
    wake_helpers();
    ensure_helpers();
    for (;;) {
        lock();
        if (g_job.next >= n) {
            unlock();
            break;
        }
        int i = g_job.next++;
        unlock();
        fn(ctx, i, 0);
        lock();
        g_job.done++;
        unlock();
    }
    /* Only chunks a helper has taken are waited for; they are short, but the helper
     * running one may lose its CPU to another process for a whole time slice: after a
     * short spin and a while of yields the caller sleeps until the last chunk is done. */
    int64_t wait_start = now_ns(), spin_end = wait_start + PAR_SPIN_NS,
            yield_end = wait_start + PAR_YIELD_NS;
    for (;;) {
        lock();
        bool all = g_job.done == n;
        if (all) {
            g_job.open = false;
            g_running = false;
            g_deadline = now_ns() + PAR_LINGER_NS;
        }
        unlock();
        if (all)
            return true;
        int64_t waited = now_ns();
        if (waited < spin_end)
            cpu_relax();
        else if (waited < yield_end)
            sched_yield();
        else
            caller_sleep();
    }
}

void par_for(int n, ParChunkFn fn, void *ctx) { (void)run_job(n, fn, ctx, false); }

bool par_background(int n, ParPieceFn fn, void *ctx)
{
    if (n <= 0 || helpers_wanted() == 0 || !g_wake_ok)
        return false;
    lock();
    bool free_slot = !g_bg.posted;
    if (free_slot) {
        g_bg.fn = fn;
        g_bg.ctx = ctx;
        g_bg.n = n;
        g_bg.next = g_bg.done = 0;
        g_bg.posted = true;
        g_bg.busy = g_bg.lost = false;
    }
    unlock();
    if (free_slot)
        wake_helpers();
    return free_slot;
}

bool par_background_finish(void)
{
    int64_t spin_end = -1;
    for (;;) {
        lock();
        if (!g_bg.posted || g_bg.lost || g_bg.done == g_bg.n) {
            bool ok = !g_bg.lost;
            g_bg.posted = g_bg.lost = false;
            unlock();
            return ok;
        }
        if (piece_waiting()) {
            run_piece();
            unlock();
            continue;
        }
        unlock();
        /* A helper runs a piece (short): spin a while, then give the CPU up, which it
         * may need (it may have lost its CPU to another process). */
        int64_t t = now_ns();
        if (spin_end < 0)
            spin_end = t + PAR_SPIN_NS;
        if (t < spin_end)
            cpu_relax();
        else
            sched_yield();
    }
}

bool par_try_for(int n, ParChunkFn fn, void *ctx) { return run_job(n, fn, ctx, true); }

/* ---- the stop request (rt/par.h) ---- */

/* Set once, before the set-up's threads poll it; the flag itself is a signal handler's. */
static const volatile int *g_stop_flag;

void par_set_stop_flag(const volatile int *flag) { g_stop_flag = flag; }

bool par_stop_requested(void)
{
    const volatile int *f = g_stop_flag;
    return f && *f != 0;
}
