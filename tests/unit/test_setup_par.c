/* The set-up's parallel loop (rt/par.h): every chunk runs exactly once, on a worker
 * index in range, with any number of helpers; nested and concurrent calls run inline;
 * a helper does join in; the helpers come back after par_release; par_hold keeps one
 * helper across jobs until par_release; par_try_for runs or declines whole; the
 * background task's pieces run once each, in order, on a held helper or on the caller. */
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "../harness.h"
#include "rt/par.h"

enum { N_CHUNKS = 3000 };

typedef struct Count {
    atomic_int hits[N_CHUNKS];
    atomic_int max_worker;
    atomic_int bad_worker;
} Count;

static void count_chunk(void *ctx, int i, int worker)
{
    Count *c = ctx;
    atomic_fetch_add(&c->hits[i], 1);
    if (worker < 0 || worker >= PAR_MAX_WORKERS)
        atomic_fetch_add(&c->bad_worker, 1);
    int m = atomic_load(&c->max_worker);
    while (worker > m && !atomic_compare_exchange_weak(&c->max_worker, &m, worker))
        ;
}

static void check_counts(Count *c, int n, int helpers)
{
    int wrong = 0;
    for (int i = 0; i < n; i++)
        wrong += atomic_load(&c->hits[i]) != 1;
    CHECK_MSG(wrong == 0, "%d of %d chunks did not run exactly once (%d helpers)", wrong, n,
              helpers);
    CHECK_INT(atomic_load(&c->bad_worker), 0);
    CHECK_MSG(atomic_load(&c->max_worker) <= helpers, "worker %d with %d helpers",
              atomic_load(&c->max_worker), helpers);
}

static void test_every_chunk_once(void)
{
    static const int helpers[] = {0, 1, 2, 3, 7, -1};
    static const int sizes[] = {0, 1, 2, 5, 64, N_CHUNKS};
    for (size_t h = 0; h < sizeof helpers / sizeof helpers[0]; h++) {
        par_set_helpers(helpers[h]);
        int expect_max = helpers[h] < 0 ? PAR_MAX_WORKERS - 1 : helpers[h];
        CHECK(par_threads() >= 1 && par_threads() <= PAR_MAX_WORKERS);
        if (helpers[h] >= 0)
            CHECK_INT(par_threads(), 1 + helpers[h]);
        for (size_t s = 0; s < sizeof sizes / sizeof sizes[0]; s++) {
            static Count c;
            memset(&c, 0, sizeof c);
            par_for(sizes[s], count_chunk, &c);
            check_counts(&c, sizes[s], expect_max);
        }
    }
    par_set_helpers(-1);
}

/* A par_for from inside a chunk runs its chunks on that thread, as worker 0. */
typedef struct Nested {
    atomic_int inner_hits;
    atomic_int inner_wrong_thread;
    atomic_int inner_wrong_worker;
} Nested;

typedef struct Inner {
    Nested *n;
    pthread_t self;
} Inner;

static void inner_chunk(void *ctx, int i, int worker)
{
    (void)i;
    Inner *in = ctx;
    atomic_fetch_add(&in->n->inner_hits, 1);
    if (!pthread_equal(pthread_self(), in->self))
        atomic_fetch_add(&in->n->inner_wrong_thread, 1);
    if (worker != 0)
        atomic_fetch_add(&in->n->inner_wrong_worker, 1);
}

static void outer_chunk(void *ctx, int i, int worker)
{
    (void)i;
    (void)worker;
    Inner in = {ctx, pthread_self()};
    par_for(10, inner_chunk, &in);
}

static void test_nested_runs_inline(void)
{
    par_set_helpers(1);
    Nested n;
    memset(&n, 0, sizeof n);
    par_for(20, outer_chunk, &n);
    CHECK_INT(atomic_load(&n.inner_hits), 200);
    CHECK_INT(atomic_load(&n.inner_wrong_thread), 0);
    CHECK_INT(atomic_load(&n.inner_wrong_worker), 0);
    par_set_helpers(-1);
}

/* Two threads calling par_for at once: both loops complete, each chunk once. */
static void *concurrent_caller(void *arg)
{
    for (int r = 0; r < 50; r++) {
        memset(arg, 0, sizeof(Count));
        par_for(N_CHUNKS, count_chunk, arg);
        Count *c = arg;
        for (int i = 0; i < N_CHUNKS; i++)
            if (atomic_load(&c->hits[i]) != 1)
                return arg; /* failure: reported by the caller */
    }
    return NULL;
}

static void test_concurrent_callers(void)
{
    par_set_helpers(1);
    static Count a, b;
    pthread_t t;
    CHECK(pthread_create(&t, NULL, concurrent_caller, &a) == 0);
    void *mine = concurrent_caller(&b);
    void *theirs = NULL;
    pthread_join(t, &theirs);
    CHECK_MSG(mine == NULL && theirs == NULL, "a chunk did not run exactly once");
    par_set_helpers(-1);
}

/* With one helper, a helper does take chunks. Chunk 0, on the caller, waits for the
 * event "a helper ran a chunk" (a condition variable, no clock): chunks 1-3 are left to
 * take, so a working helper always ends the wait. The 60 s bound only turns a broken
 * helper into a failure instead of a hung test. */
typedef struct Join {
    pthread_mutex_t lock;
    pthread_cond_t seen_cond;
    bool helper_seen;
    bool gave_up;
} Join;

static void join_chunk(void *ctx, int i, int worker)
{
    Join *j = ctx;
    pthread_mutex_lock(&j->lock);
    if (worker != 0) {
        j->helper_seen = true;
        pthread_cond_broadcast(&j->seen_cond);
    } else if (i == 0) {
        struct timespec limit;
        clock_gettime(CLOCK_REALTIME, &limit);
        limit.tv_sec += 60;
        while (!j->helper_seen && !j->gave_up)
            if (pthread_cond_timedwait(&j->seen_cond, &j->lock, &limit) != 0)
                j->gave_up = true;
    }
    pthread_mutex_unlock(&j->lock);
}

static void test_helper_joins_in(void)
{
    for (int round = 0; round < 2; round++) {
        par_set_helpers(1);
        Join j = {PTHREAD_MUTEX_INITIALIZER, PTHREAD_COND_INITIALIZER, false, false};
        par_for(4, join_chunk, &j);
        CHECK_MSG(j.helper_seen && !j.gave_up, "no helper ran a chunk (round %d)", round);
        pthread_cond_destroy(&j.seen_cond);
        pthread_mutex_destroy(&j.lock);
        /* After a release the helpers exit; the next loop starts them again. */
        par_release();
    }
    par_prepare();
    par_set_helpers(-1);
}

/* A helper idle longer than its spin sleeps until the next job: that job must still
 * find it (woken, or restarted once it has gone), here four times in a row with a
 * pause of 1 ms between the jobs (beyond the spin, within the lingering). */
static void test_sleeping_helper_joins_in(void)
{
    par_set_helpers(1);
    par_prepare();
    for (int round = 0; round < 4; round++) {
        Join j = {PTHREAD_MUTEX_INITIALIZER, PTHREAD_COND_INITIALIZER, false, false};
        par_for(4, join_chunk, &j);
        CHECK_MSG(j.helper_seen && !j.gave_up, "no helper ran a chunk (round %d)", round);
        pthread_cond_destroy(&j.seen_cond);
        pthread_mutex_destroy(&j.lock);
        struct timespec pause = {0, 1000000L};
        nanosleep(&pause, NULL);
    }
    par_release();
    par_set_helpers(-1);
}

/* par_hold: the helper that ran a chunk of one job is the one that runs a chunk of the
 * next, even after a pause far beyond the lingering of an unheld helper (each thread
 * marks itself in a thread-local on its first chunk: a new thread would find no mark);
 * par_release then ends it (it is gone, waited for without a clock but with a 60 s
 * bound so a broken release fails instead of hanging). */
static _Thread_local int t_marked;

typedef struct Mark {
    Join j;
    atomic_int helper_was_marked; /* a helper chunk found its thread marked */
    atomic_int helper_new;        /* a helper chunk found it unmarked */
} Mark;

static void mark_chunk(void *ctx, int i, int worker)
{
    Mark *m = ctx;
    if (worker != 0)
        atomic_fetch_add(t_marked ? &m->helper_was_marked : &m->helper_new, 1);
    t_marked = 1;
    join_chunk(&m->j, i, worker);
}

static bool wait_helpers_gone(void)
{
    for (int i = 0; i < 60000 && par_helpers_running() > 0; i++) {
        struct timespec ms = {0, 1000000L};
        nanosleep(&ms, NULL);
    }
    return par_helpers_running() == 0;
}

static void test_hold_keeps_helper(void)
{
    par_set_helpers(1);
    par_release();
    CHECK_MSG(wait_helpers_gone(), "a released helper did not exit");
    par_hold();
    CHECK_INT(par_helpers_running(), 1);
    for (int round = 0; round < 3; round++) {
        Mark m;
        memset(&m, 0, sizeof m);
        m.j = (Join){PTHREAD_MUTEX_INITIALIZER, PTHREAD_COND_INITIALIZER, false, false};
        par_for(4, mark_chunk, &m);
        CHECK_MSG(m.j.helper_seen && !m.j.gave_up, "no helper ran a chunk (round %d)", round);
        if (round > 0)
            CHECK_MSG(atomic_load(&m.helper_new) == 0 && atomic_load(&m.helper_was_marked) > 0,
                      "round %d: a new helper thread (%d chunks) instead of the held one",
                      round, atomic_load(&m.helper_new));
        pthread_cond_destroy(&m.j.seen_cond);
        pthread_mutex_destroy(&m.j.lock);
        /* Ten times the lingering of an unheld helper (PAR_LINGER_NS, 3 ms). */
        struct timespec pause = {0, 30000000L};
        nanosleep(&pause, NULL);
        CHECK_INT(par_helpers_running(), 1);
    }
    par_release();
    CHECK_MSG(wait_helpers_gone(), "the held helper did not exit after par_release");
    par_set_helpers(-1);
}

/* A caller of par_for waiting for a helper's chunk does not go to sleep at once (it
 * yields, awake, for PAR_YIELD_NS, 2 ms: a sleeping vCPU takes 0.07 ms and more to
 * wake), and does sleep in the end. The caller's chunk notes when it ended; the
 * helper's chunk, running on meanwhile, looks at the caller whenever that was 0.3 to
 * 1 ms ago (past the 50 us spin; the caller's wait began after its chunk ended, so it
 * has waited less), where it must be awake however loaded the machine, and then stays
 * until the caller sleeps (a 10 s bound so a caller that never sleeps fails). */
typedef struct Waiter {
    _Atomic int64_t caller_end_ns; /* when the caller's chunk ended (0: not yet) */
    atomic_int looked, asleep_early, slept, helper_chunks;
} Waiter;

static int64_t mono_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (int64_t)t.tv_sec * 1000000000LL + t.tv_nsec;
}

static void waiter_chunk(void *ctx, int i, int worker)
{
    (void)i;
    Waiter *w = ctx;
    if (worker == 0) {
        /* Until the helper has taken the other chunk (10 s at most), so that the caller
         * does not run both. */
        int64_t t0 = mono_ns();
        while (atomic_load(&w->helper_chunks) == 0 && mono_ns() - t0 < 10000000000LL)
            ;
        atomic_store(&w->caller_end_ns, mono_ns());
        return;
    }
    atomic_fetch_add(&w->helper_chunks, 1);
    int64_t start = mono_ns();
    for (;;) {
        int64_t t = mono_ns(), end = atomic_load(&w->caller_end_ns);
        if (end == 0) {
            if (t - start > 10000000000LL)
                return; /* the caller never ran its chunk: nothing to look at */
            continue;
        }
        bool asleep = par_caller_asleep();
        /* The look counts as early only if it also ended within 1 ms: a helper that
         * lost its CPU between the clock and the look may see a caller that rightly
         * slept (on a loaded machine). */
        int64_t t_after = mono_ns();
        if (t - end >= 300000 && t_after - end < 1000000) {
            atomic_fetch_add(&w->looked, 1);
            atomic_fetch_add(&w->asleep_early, asleep);
        } else if (t - end >= 1000000 && (asleep || t - end > 10000000000LL)) {
            atomic_store(&w->slept, asleep);
            return;
        }
    }
}

static void test_waiting_caller_yields_then_sleeps(void)
{
    par_set_helpers(1);
    par_hold();
    int rounds = 0, looked = 0, asleep_early = 0, slept = 0;
    for (int round = 0; round < 10; round++) {
        Waiter w;
        memset(&w, 0, sizeof w);
        par_for(2, waiter_chunk, &w);
        if (atomic_load(&w.helper_chunks) != 1 || atomic_load(&w.caller_end_ns) == 0)
            continue; /* one thread ran both chunks (the helper was late) */
        rounds++;
        looked += atomic_load(&w.looked);
        asleep_early += atomic_load(&w.asleep_early);
        slept += atomic_load(&w.slept);
    }
    CHECK_MSG(rounds > 0, "the helper never ran a chunk beside the caller");
    CHECK_MSG(asleep_early == 0, "the waiting caller slept within 1 ms of its chunk: %d of %d looks",
              asleep_early, looked);
    CHECK_MSG(slept == rounds, "the waiting caller went to sleep in %d of %d rounds", slept,
              rounds);
    if (looked == 0)
        printf("  (no look within 1 ms of the caller's chunk: a loaded machine)\n");
    par_release();
    CHECK_MSG(wait_helpers_gone(), "the held helper did not exit after par_release");
    par_set_helpers(-1);
}

/* No helper wanted (-threads 1): par_hold starts none, par_try_for declines. */
static void count_two(void *ctx, int i, int worker)
{
    (void)worker;
    atomic_fetch_add(&((atomic_int *)ctx)[i], 1);
}

static void test_no_helper_wanted(void)
{
    par_release();
    CHECK_MSG(wait_helpers_gone(), "a released helper did not exit");
    par_set_helpers(0);
    par_hold();
    CHECK_INT(par_helpers_running(), 0);
    atomic_int hits[2] = {0, 0};
    CHECK(!par_try_for(2, count_two, hits));
    CHECK_INT(atomic_load(&hits[0]) + atomic_load(&hits[1]), 0);
    par_release();
    par_set_helpers(-1);
}

/* par_try_for runs every chunk once when the helpers can take part, and declines (nothing
 * run) for one chunk, for more chunks than threads, and inside another job. */
static void try_inner(void *ctx, int i, int worker)
{
    (void)i;
    (void)worker;
    atomic_int *hits = ctx;
    if (par_try_for(2, count_two, hits + 2))
        atomic_fetch_add(&hits[4], 1); /* must not happen: a job is in progress */
}

static void test_try_for(void)
{
    par_set_helpers(2);
    for (int n = 2; n <= 3; n++) {
        atomic_int hits[3] = {0, 0, 0};
        CHECK(par_try_for(n, count_two, hits));
        for (int i = 0; i < 3; i++)
            CHECK_INT(atomic_load(&hits[i]), i < n ? 1 : 0);
    }
    atomic_int none[4] = {0, 0, 0, 0};
    CHECK(!par_try_for(1, count_two, none));
    CHECK(!par_try_for(4, count_two, none));
    CHECK_INT(atomic_load(&none[0]) + atomic_load(&none[1]) + atomic_load(&none[2]), 0);
    atomic_int nest[5] = {0, 0, 0, 0, 0};
    par_for(2, try_inner, nest);
    CHECK_INT(atomic_load(&nest[4]), 0);
    CHECK_INT(atomic_load(&nest[2]) + atomic_load(&nest[3]), 0);
    par_set_helpers(-1);
}

#if defined(__SANITIZE_THREAD__)
#define RT_TEST_TSAN 1
#elif defined(__has_feature)
#if __has_feature(thread_sanitizer)
#define RT_TEST_TSAN 1
#endif
#endif

/* A child forked while a helper is held has none, holds nothing, and its par_for still
 * runs every chunk (its own helper, started there). */
static void test_fork_child(void)
{
    par_set_helpers(1);
    par_hold();
    CHECK_INT(par_helpers_running(), 1);
    pid_t pid = fork();
    if (pid == 0) {
        int bad = par_helpers_running() != 0;
#ifdef RT_TEST_TSAN
        par_set_helpers(0); /* TSan cannot start threads in a multi-threaded fork's child */
#endif
        static Count c;
        memset(&c, 0, sizeof c);
        par_for(64, count_chunk, &c);
        for (int i = 0; i < 64; i++)
            bad |= atomic_load(&c.hits[i]) != 1;
        par_release();
        _exit(bad ? 1 : 0);
    }
    CHECK(pid > 0);
    int st = 0;
    if (pid > 0)
        CHECK(waitpid(pid, &st, 0) == pid && WIFEXITED(st) && WEXITSTATUS(st) == 0);
    CHECK_INT(par_helpers_running(), 1); /* the parent's is still held */
    par_release();
    CHECK_MSG(wait_helpers_gone(), "the held helper did not exit after par_release");
    par_set_helpers(-1);
}

/* par_background: each piece once, in order (a piece finds all before it done), one at a
 * time; a held helper takes them while the caller waits for none (seen: a piece run on
 * a thread other than the caller's); par_background_finish then returns with all run;
 * a second task may follow; a task is refused while one is posted. */
enum { N_PIECES = 40 };

typedef struct Pieces {
    atomic_int ran[N_PIECES];
    atomic_int started;     /* pieces begun */
    atomic_int out_of_order;
    atomic_int overlapped;  /* a piece began while another ran */
    atomic_int running;
    atomic_int on_helper;
    pthread_t caller;
    atomic_int hold;        /* piece 0 waits while set */
} Pieces;

static void piece(void *ctx, int i)
{
    Pieces *p = ctx;
    if (atomic_fetch_add(&p->running, 1) != 0)
        atomic_fetch_add(&p->overlapped, 1);
    if (!pthread_equal(pthread_self(), p->caller))
        atomic_fetch_add(&p->on_helper, 1); /* before started: the tests wait for that */
    if (atomic_fetch_add(&p->started, 1) != i)
        atomic_fetch_add(&p->out_of_order, 1);
    for (int k = 0; k < 60000 && i == 0 && atomic_load(&p->hold); k++) {
        struct timespec ms = {0, 1000000L};
        nanosleep(&ms, NULL);
    }
    struct timespec busy = {0, 100000L}; /* long enough for finish to come meanwhile */
    nanosleep(&busy, NULL);
    atomic_fetch_add(&p->ran[i], 1);
    atomic_fetch_sub(&p->running, 1);
}

static void check_pieces(Pieces *p, int n)
{
    for (int i = 0; i < n; i++)
        CHECK_MSG(atomic_load(&p->ran[i]) == 1, "piece %d ran %d times", i,
                  atomic_load(&p->ran[i]));
    CHECK_INT(atomic_load(&p->out_of_order), 0);
    CHECK_INT(atomic_load(&p->overlapped), 0);
}

static void test_background(void)
{
    par_set_helpers(1);
    par_hold();
    for (int round = 0; round < 2; round++) {
        static Pieces p;
        memset(&p, 0, sizeof p);
        p.caller = pthread_self();
        CHECK(par_background(N_PIECES, piece, &p));
        CHECK(!par_background(N_PIECES, piece, &p)); /* one task at a time */
        /* The helper takes pieces without the caller (a minute's bound against a hang). */
        for (int k = 0; k < 60000 && atomic_load(&p.on_helper) == 0; k++) {
            struct timespec ms = {0, 1000000L};
            nanosleep(&ms, NULL);
        }
        CHECK_MSG(atomic_load(&p.on_helper) > 0, "round %d: no piece ran on the helper",
                  round);
        /* A par_for meanwhile runs every chunk as ever. */
        static Count c;
        memset(&c, 0, sizeof c);
        par_for(64, count_chunk, &c);
        for (int i = 0; i < 64; i++)
            CHECK_INT(atomic_load(&c.hits[i]), 1);
        CHECK(par_background_finish());
        check_pieces(&p, N_PIECES);
        CHECK(par_background_finish()); /* nothing posted: nothing to do */
    }
    par_release();
    CHECK_MSG(wait_helpers_gone(), "the held helper did not exit after par_release");
    /* Helpers wanted but none running: the caller runs every piece in finish. */
    static Pieces q;
    memset(&q, 0, sizeof q);
    q.caller = pthread_self();
    CHECK(par_background(N_PIECES, piece, &q));
    CHECK(par_background_finish());
    check_pieces(&q, N_PIECES);
    /* No helper wanted (-threads 1): refused, nothing run. */
    par_set_helpers(0);
    CHECK(!par_background(N_PIECES, piece, &q));
    CHECK_INT(atomic_load(&q.started), N_PIECES);
    par_set_helpers(-1);
}

/* A child forked while a task's piece runs on the parent's helper does not run it
 * again: its finish says the work is lost; the parent's completes. */
static void test_background_fork(void)
{
    par_set_helpers(1);
    par_hold();
    static Pieces p;
    memset(&p, 0, sizeof p);
    p.caller = pthread_self();
    atomic_store(&p.hold, 1);
    CHECK(par_background(3, piece, &p));
    for (int k = 0; k < 60000 && atomic_load(&p.started) == 0; k++) {
        struct timespec ms = {0, 1000000L};
        nanosleep(&ms, NULL);
    }
    CHECK_INT(atomic_load(&p.on_helper), 1); /* piece 0, held on the helper */
    pid_t pid = fork();
    if (pid == 0) {
        alarm(60); /* a finish waiting for the parent's piece would hang: fail instead */
        int bad = par_background_finish() ? 1 : 0; /* lost: false, nothing run */
        bad |= atomic_load(&p.ran[1]) != 0;
        bad |= !par_background_finish(); /* and then nothing is posted */
        _exit(bad);
    }
    CHECK(pid > 0);
    int st = 0;
    if (pid > 0)
        CHECK(waitpid(pid, &st, 0) == pid && WIFEXITED(st) && WEXITSTATUS(st) == 0);
    atomic_store(&p.hold, 0);
    CHECK(par_background_finish());
    check_pieces(&p, 3);
    par_release();
    CHECK_MSG(wait_helpers_gone(), "the held helper did not exit after par_release");
    par_set_helpers(-1);
}

static const TestCase tests[] = {
    {"par: every chunk runs exactly once, workers in range", test_every_chunk_once},
    {"par: a nested par_for runs inline on its thread", test_nested_runs_inline},
    {"par: concurrent callers both complete", test_concurrent_callers},
    {"par: a helper joins in, again after par_release", test_helper_joins_in},
    {"par: a helper sleeping between jobs joins the next", test_sleeping_helper_joins_in},
    {"par: a held helper serves every job until par_release ends it", test_hold_keeps_helper},
    {"par: a caller waiting for a helper's chunk stays awake a while, then sleeps",
     test_waiting_caller_yields_then_sleeps},
    {"par: no helper wanted: par_hold starts none, par_try_for declines", test_no_helper_wanted},
    {"par: par_try_for runs each chunk once or declines", test_try_for},
    {"par: a forked child holds no helper and its par_for works", test_fork_child},
    {"par: background pieces once each, in order, on the helper or in finish",
     test_background},
    {"par: a forked child does not run a background task again", test_background_fork},
};

RT_TEST_MAIN(tests)
