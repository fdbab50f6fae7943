/* Set-up parallelism: a loop split into chunks, run by the calling thread and by helper
 * threads that join in when they get a CPU. For the build steps before the render (OBJ
 * reading, mesh construction, grid binning), and for the render's workers themselves
 * (par_try_for): one process then starts its helper threads once, not once per step
 * and again for the render. */
#ifndef RT_PAR_H
#define RT_PAR_H

#include <pthread.h>
#include <stdbool.h>

/* Most threads a par_for uses: the caller (worker 0) and up to 7 helpers. */
enum { PAR_MAX_WORKERS = 8 };

/* One chunk: i in [0, n), worker in [0, PAR_MAX_WORKERS) names the thread running it
 * (two chunks run concurrently only on different workers), so per-worker scratch needs
 * no locks. */
typedef void (*ParChunkFn)(void *ctx, int i, int worker);

/* Runs fn(ctx, i, worker) once for every i in [0, n) and returns when all have run.
 * Chunks are handed out in increasing i, but run in any order and concurrently: a
 * result must not depend on which worker ran a chunk (callers keep per-chunk outputs
 * and combine them in chunk order). The caller never waits for a helper that has not
 * started: a helper's CPU can take milliseconds to wake on a virtual machine, and then
 * the caller simply runs more chunks itself. A par_for that starts while another is
 * running (another thread, or from inside a chunk) runs all its chunks on the caller. */
void par_for(int n, ParChunkFn fn, void *ctx);

/* A piece of par_background's task. */
typedef void (*ParPieceFn)(void *ctx, int i);

/* Work for the helpers' idle moments, such as preparing what a later step will need
 * while the set-up's serial stretches leave the held helpers (par_hold) waiting:
 * fn(ctx, i) for i = 0..n-1, in this order and one after another (a piece may use the
 * ones before it), each run by a helper that finds no par_for chunk waiting (chunks come
 * first; a job that opens meanwhile waits at most for the piece under way). Returns
 * false, with nothing posted or run, when no helper is wanted or a task is already
 * posted: the caller then does the work itself. */
bool par_background(int n, ParPieceFn fn, void *ctx);
/* Runs on the calling thread the pieces of the posted task that no helper took, waits
 * for the one under way, and returns true when every piece has run (then the task is
 * over and another may be posted); also true when no task is posted. False only in a
 * forked child whose parent had posted one: pieces may have been half run there, and
 * none is run again (the caller must not use their work). */
bool par_background_finish(void);

/* par_for for chunks that are whole threads' work (the render's workers, each pulling
 * jobs from a shared counter until none is left, so a chunk the caller runs after its
 * own finds nothing to do): runs it and returns true when the helpers may take part,
 * i.e. n >= 2, n <= par_threads() and no other par_for is in progress; otherwise
 * false, with nothing run (the caller starts threads of its own). A helper that could
 * not be started is missing as in par_for: its chunks then run on the caller, one
 * after another. */
bool par_try_for(int n, ParChunkFn fn, void *ctx);

/* Starts the helpers now, for par_for calls soon after; between calls they wait
 * (spinning briefly, then asleep until the next job) at most a few milliseconds before
 * they exit (unless held). */
void par_prepare(void);
/* Starts the helpers now and keeps them until par_release: an idle helper spins
 * briefly, then sleeps (no CPU, no timer) until the next job. For a run whose set-up
 * and render come next: each helper is started once, its start-up overlaps the scene's
 * reading, and it is still there for the render. Nothing when no helper is wanted
 * (par_set_helpers(0), one CPU). A forked child does not inherit the hold. */
void par_hold(void);
/* Ends par_hold; idle helpers exit now. A job running meanwhile keeps its helpers, and
 * they linger a few milliseconds after it (as after any par_for) before they exit. */
void par_release(void);
/* Helpers started and not yet exited (for tests). */
int par_helpers_running(void);
/* Whether a caller of par_for is asleep waiting for a helper's chunks (for tests: it
 * yields, awake, for a while first, rt/par.c's PAR_YIELD_NS). */
bool par_caller_asleep(void);

/* Threads a par_for may use now: 1 + the helpers wanted (1: everything on the caller,
 * so splitting work only costs). */
int par_threads(void);

/* Helpers to use: n >= 0 exactly n (at most PAR_MAX_WORKERS - 1; 0: every chunk on
 * the caller); n < 0 (the default) one per online CPU beyond the first. For tests and
 * benchmarks; call it while no par_for runs. */
void par_set_helpers(int n);

/* The run's stop request, for the set-up's long loops (the OBJ reader's lines, the
 * grid build's chunks), which are given no stop flag of their own: main points it at
 * the flag its stop signals set (Ctrl-C, SIGTERM), and those loops poll it every so
 * many lines or primitives and end early, reporting nothing: their caller says
 * "interrupted". flag NULL (the default): never stopped. Set it before the threads that
 * poll start. */
void par_set_stop_flag(const volatile int *flag);
/* Whether a stop was requested (the flag is non-zero). Any thread; a load and a test. */
bool par_stop_requested(void);

/* For any thread started to help a short job: attr makes the new thread start on a
 * CPU other than the caller's (Linux tends to start it on its creator's CPU, where the
 * two then share one CPU for milliseconds while the other idles). Best effort. */
void par_attr_keep_off_this_cpu(pthread_attr_t *attr);
/* Called by such a thread once running: lets it run on every CPU again, so the
 * scheduler stays free to balance later. Best effort. */
void par_thread_release_cpus(void);

#endif
