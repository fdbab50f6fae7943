/* The set-up's parallel loop (rt/par.h): every chunk runs exactly once, on a worker
 * index in range, with any number of helpers; nested and concurrent calls run inline;
 * a helper does join in; the helpers come back after par_release. */
#include <pthread.h>
#include <stdatomic.h>
#include <time.h>

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

static const TestCase tests[] = {
    {"par: every chunk runs exactly once, workers in range", test_every_chunk_once},
    {"par: a nested par_for runs inline on its thread", test_nested_runs_inline},
    {"par: concurrent callers both complete", test_concurrent_callers},
    {"par: a helper joins in, again after par_release", test_helper_joins_in},
    {"par: a helper sleeping between jobs joins the next", test_sleeping_helper_joins_in},
};

RT_TEST_MAIN(tests)
