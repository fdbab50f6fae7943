/* The MPI side of rt/dist.h, linked into ./raytracer-mpi (mk/mpi.mk): image-parallel
 * rendering of a replicated scene. Rank 0 reads the scene and its OBJ files and
 * broadcasts their bytes; every rank builds the same scene and grid; rank 0 hands out
 * bands of rows first-come first-served (a work queue: a rank that draws an expensive
 * band simply asks for fewer), renders bands itself on a second thread, and gathers
 * the pixels. Under mpirun rank 0 starts MPI on a thread of its own while it parses,
 * builds and starts rendering (start-up, below). One thread of a rank calls MPI at a
 * time (MPI_THREAD_SERIALIZED): rank 0's start-up thread, then its main thread; a
 * worker's main thread. No rank waits inside a blocking MPI call: MPI libraries
 * busy-poll there (OpenMPI unless told otherwise), which would take a core from the
 * renderers of a rank sharing it; every wait is a test and a growing sleep (nap).
 * docs/distributed.md describes the protocol and its costs. */
#define _POSIX_C_SOURCE 200809L
#include "rt/dist.h"
#include "rt/bigmem.h"
#include "rt/image.h"

#include <mpi.h>
#include <pthread.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

enum { TAG_RESULT = 1, TAG_WORK = 2 };

static int g_rank, g_size;
static char g_describe[96];

/* ---- waiting without spinning ----------------------------------------------------- */

/* A wait's sleeps start at NAP_MIN_NS and double up to NAP_MAX_NS: a message that is
 * already there costs one test, one that comes soon is seen within twice the time
 * waited, and a long wait (a rank done with its tiles, waiting for the others) costs
 * a wake-up per NAP_MAX_NS, about 0.1% of a core. */
enum { NAP_MIN_NS = 20 * 1000, NAP_MAX_NS = 1000 * 1000 };

/* Sleeps *ns (interrupted by a signal: shorter) and doubles it up to NAP_MAX_NS. */
static void nap(long *ns)
{
    struct timespec ts = {0, *ns};
    nanosleep(&ts, NULL);
    *ns = *ns >= NAP_MAX_NS / 2 ? NAP_MAX_NS : 2 * *ns;
}

/* Completes *req, napping between tests (MPI_Wait would spin). */
static void wait_request(MPI_Request *req, MPI_Status *st)
{
    long ns = NAP_MIN_NS;
    for (;;) {
        int done = 0;
        MPI_Test(req, &done, st ? st : MPI_STATUS_IGNORE);
        if (done)
            return;
        nap(&ns);
    }
}

/* The collectives the job uses, each started non-blocking and waited for by napping. */
static void bcast(void *p, int n, MPI_Datatype type)
{
    MPI_Request req;
    MPI_Ibcast(p, n, type, 0, MPI_COMM_WORLD, &req);
    wait_request(&req, NULL);
}

static void reduce_to_root(void *v, void *sum, int n, MPI_Datatype type, MPI_Op op)
{
    MPI_Request req;
    if (g_rank == 0)
        MPI_Ireduce(MPI_IN_PLACE, v, n, type, op, 0, MPI_COMM_WORLD, &req);
    else
        MPI_Ireduce(v, sum, n, type, op, 0, MPI_COMM_WORLD, &req);
    wait_request(&req, NULL);
}

/* MPI counts are ints: big blocks go in pieces. */
static void bcast_bytes(uint8_t *p, size_t n)
{
    const size_t piece = (size_t)1 << 30;
    for (size_t off = 0; off < n; off += piece) {
        size_t k = n - off < piece ? n - off : piece;
        bcast(p + off, (int)k, MPI_BYTE);
    }
}

static void join_init(void);

/* Something only this rank can see went wrong (out of memory): end the whole job. */
static void die(const char *what)
{
    fprintf(stderr, "raytracer-mpi: error: rank %d: %s; aborting the job\n", g_rank, what);
    join_init();
    MPI_Abort(MPI_COMM_WORLD, 1);
    _exit(1);
}

/* ---- job start, end, abort ---------------------------------------------------------- */

/* mpirun ends a job whose rank died (or that was interrupted) by sending SIGTERM to
 * the rest; rank 0 says so once. Images are only ever renamed into place whole, so
 * nothing half-written is left under the output's name. */
static void on_abort(int sig)
{
    (void)sig;
    image_write_abort(); /* a temporary file being written goes too */
    if (g_rank == 0) {
        static const char msg[] = "raytracer-mpi: the job was aborted (a rank died or mpirun "
                                  "was interrupted); no image written\n";
        ssize_t n = write(2, msg, sizeof msg - 1);
        (void)n;
    }
    _exit(1);
}

/* ---- start-up beside rank 0's own work --------------------------------------------- */

/* MPI_Init takes 40-100 ms of every job on one machine (plugins, the PMIx handshake;
 * docs/distributed.md), all of it before a rank could do anything. Rank 0 needs MPI
 * only once it has something to send: when the launcher tells a process its rank and
 * the job's size before MPI_Init (OpenMPI's mpirun sets OMPI_COMM_WORLD_RANK and
 * OMPI_COMM_WORLD_SIZE), rank 0 calls MPI_Init_thread on a thread of its own and goes
 * on at once: it parses the scene, builds its grid and starts rendering tiles, and
 * what it has to broadcast meanwhile (the scene's bytes, its answers) waits in
 * g_pending. The first call that needs MPI (dist_render once rank 0's render thread is
 * running, or dist_finish, dist_max, dist_describe, die) joins that thread and sends
 * what waited, in the order it was queued: every rank makes the same collectives in
 * the same order as without the overlap. Any other rank, or a process the launcher
 * told nothing (a singleton, another launcher), initialises first as before. Only one
 * thread calls MPI at a time, not always the same one: MPI_THREAD_SERIALIZED. */
static pthread_t g_init_thread;
static bool g_init_pending;    /* MPI_Init_thread runs on g_init_thread */
static int g_init_rc, g_init_provided;
static double g_init_ms;       /* MPI_Init_thread's wall time (-timings) */
static bool g_init_beside;     /* it ran beside rank 0's set-up (g_init_thread) */

/* Root's broadcasts queued while MPI starts: count elements of type at data (owned:
 * freed once sent). Four at most (the scene's length and bytes, dist_root_ok's answer,
 * the root's thread count); more is a bug. */
typedef struct Pending {
    void *data;
    uint64_t count;
    MPI_Datatype type;
} Pending;
enum { MAX_PENDING = 8 };
static Pending g_pending[MAX_PENDING];
static int g_npending;
/* Started by an MPI launcher (dist_stdout_forwarded). */
static bool g_launched;

static double now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec * 1e3 + (double)ts.tv_nsec * 1e-6;
}

/* A non-negative decimal number from the environment, or -1. */
static int env_count(const char *name)
{
    const char *v = getenv(name);
    if (!v || !*v)
        return -1;
    long n = 0;
    for (const char *p = v; *p; p++) {
        if (*p < '0' || *p > '9' || n > 1000000)
            return -1;
        n = n * 10 + (*p - '0');
    }
    return (int)n;
}

static void *init_main(void *arg)
{
    (void)arg;
    double t0 = now_ms();
    /* No argc/argv: main reads them at the same time (MPI-2 allows NULL). */
    g_init_rc = MPI_Init_thread(NULL, NULL, MPI_THREAD_SERIALIZED, &g_init_provided);
    g_init_ms = now_ms() - t0;
    return NULL;
}

/* What dist_describe prints (MPI initialised). */
static void describe(void)
{
    char version[MPI_MAX_LIBRARY_VERSION_STRING];
    int len = 0;
    MPI_Get_library_version(version, &len);
    version[strcspn(version, ",\n")] = '\0';
    snprintf(g_describe, sizeof g_describe, "yes, this run has %d rank%s (%.60s)", g_size,
             g_size == 1 ? "" : "s", version);
}

/* Waits for rank 0's MPI_Init_thread (when it runs on its own thread); no queued
 * broadcast is sent. A failure ends the process: nothing has been written yet. */
static void join_init(void)
{
    if (!g_init_pending)
        return;
    pthread_join(g_init_thread, NULL);
    g_init_pending = false;
    int rank = -1, size = -1;
    if (g_init_rc == MPI_SUCCESS) {
        MPI_Comm_rank(MPI_COMM_WORLD, &rank);
        MPI_Comm_size(MPI_COMM_WORLD, &size);
    }
    if (g_init_rc != MPI_SUCCESS || g_init_provided < MPI_THREAD_SERIALIZED || rank != g_rank ||
        size != g_size) {
        fprintf(stderr, "raytracer-mpi: error: %s\n",
                g_init_rc != MPI_SUCCESS ? "MPI_Init failed"
                : g_init_provided < MPI_THREAD_SERIALIZED
                    ? "the MPI library cannot be called from more than one thread"
                    : "MPI's rank and size differ from the launcher's "
                      "OMPI_COMM_WORLD_RANK and OMPI_COMM_WORLD_SIZE");
        if (g_init_rc == MPI_SUCCESS)
            MPI_Abort(MPI_COMM_WORLD, 1);
        _exit(1);
    }
    describe();
}

/* Joins MPI's start (join_init) and sends the root's queued broadcasts. Every function
 * below that calls MPI calls this first. */
static void ready(void)
{
    join_init();
    for (int k = 0; k < g_npending; k++) {
        Pending *q = &g_pending[k];
        if (q->type == MPI_BYTE)
            bcast_bytes(q->data, q->count);
        else
            bcast(q->data, (int)q->count, q->type);
        free(q->data);
    }
    g_npending = 0;
}

/* A broadcast of the root's count elements of type (elem bytes each: no MPI call may
 * ask while MPI starts) at p: sent now, or queued while MPI starts. take: p is malloc'd
 * and becomes the queue's (freed once sent); without take it is copied. Returns false
 * when a copy cannot be made (out of memory). */
static bool root_bcast(void *p, uint64_t count, MPI_Datatype type, size_t elem, bool take)
{
    if (!g_init_pending) {
        if (type == MPI_BYTE)
            bcast_bytes(p, count);
        else
            bcast(p, (int)count, type);
        if (take)
            free(p);
        return true;
    }
    void *data = p;
    if (!take && (data = malloc((size_t)count * elem)))
        memcpy(data, p, (size_t)count * elem);
    if (!data || g_npending == MAX_PENDING)
        return false;
    g_pending[g_npending++] = (Pending){data, count, type};
    return true;
}

const char dist_program_name[] = "raytracer-mpi";

bool dist_init(int *argc, char ***argv)
{
    /* Started by a launcher: its own variables, read before MPI_Init (a singleton's
     * MPI_Init sets OpenMPI's in this process): OpenMPI's mpirun, a PMIx launcher
     * (OpenMPI 5's prterun, srun --mpi=pmix) or a PMI one (MPICH's mpiexec, srun
     * --mpi=pmi2). */
    g_launched = env_count("OMPI_COMM_WORLD_SIZE") >= 0 || env_count("PMIX_RANK") >= 0 ||
                 env_count("PMI_RANK") >= 0;
    int env_rank = env_count("OMPI_COMM_WORLD_RANK");
    int env_size = env_count("OMPI_COMM_WORLD_SIZE");
    if (env_rank == 0 && env_size > 0) {
        g_rank = 0;
        g_size = env_size;
        g_init_pending = pthread_create(&g_init_thread, NULL, init_main, NULL) == 0;
        g_init_beside = g_init_pending;
        if (g_init_pending)
            return true;
    }
    int provided = 0;
    double t0 = now_ms();
    if (MPI_Init_thread(argc, argv, MPI_THREAD_SERIALIZED, &provided) != MPI_SUCCESS) {
        fprintf(stderr, "raytracer-mpi: error: MPI_Init failed\n");
        return false;
    }
    g_init_ms = now_ms() - t0;
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    describe();
    return true;
}

int dist_finish(int status)
{
    ready();
    /* The root's status is everyone's: a write error on rank 0 fails the whole job. */
    bcast(&status, 1, MPI_INT);
    /* From here the outcome is settled and reported. When a rank leaves with status 1
     * (a scene error) mpirun sends SIGTERM to the ranks still in MPI_Finalize; that is
     * no abort, and on_abort on rank 0 would add "the job was aborted" after the real
     * message (about one run in ten at -np 4). */
    signal(SIGTERM, SIG_IGN);
    MPI_Finalize();
    return status;
}

bool dist_is_root(void) { return g_rank == 0; }
int dist_size(void) { return g_size; }

bool dist_stdout_forwarded(void) { return g_launched; }

int dist_launcher_rank(void)
{
    /* The variables dist_init takes as "started by a launcher", in the same order of
     * trust: OpenMPI's own first (it may set the PMIx one too). */
    static const char *const names[] = {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        int rank = env_count(names[i]);
        if (rank >= 0)
            return rank;
    }
    return -1;
}
const char *dist_describe(void)
{
    ready();
    return g_describe;
}

/* A broadcast from the root: the root's part is a small eager send, complete at once
 * (an all-reduce here made rank 0 wait 40-80 ms for the second rank's set-up before it
 * could start rendering). */
bool dist_root_ok(bool ok)
{
    int v = ok ? 1 : 0;
    if (g_rank == 0) {
        if (!root_bcast(&v, 1, MPI_INT, sizeof v, false))
            die("out of memory");
    } else {
        bcast(&v, 1, MPI_INT);
    }
    return v != 0;
}

void dist_max(double *v, int n)
{
    ready();
    reduce_to_root(v, NULL, n, MPI_DOUBLE, MPI_MAX);
}

/* ---- the scene, broadcast --------------------------------------------------------- */

/* The job's signal handling, set when the job starts its work (main installs its own
 * stop handlers after dist_init; these replace two of them). SIGTERM is how mpirun
 * ends a job whose rank died or that was interrupted: stop at once, since the others
 * are going too. Ctrl-C from a terminal reaches every rank: only rank 0 acts on it
 * (main's handler: it hands out no more tiles and tells the others). */
static void job_signals(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_abort;
    sigemptyset(&sa.sa_mask);
    sigaction(SIGTERM, &sa, NULL);
    if (g_rank != 0)
        signal(SIGINT, SIG_IGN);
}

Scene *dist_scene_load(const char *path, SetupCache *cache, bool identify, Diag *diag)
{
    if (g_size == 1)
        return scene_load_with(path, NULL, cache, identify, diag);
    job_signals();
    if (g_rank == 0) {
        SceneFiles *files = scene_files_new(true);
        if (!files)
            die("out of memory");
        Scene *s = scene_load_with(path, files, cache, identify, diag);
        uint8_t *packed = NULL;
        size_t n = 0;
        if (s && !scene_files_pack(files, &packed, &n))
            die("out of memory");
        scene_files_free(files);
        uint64_t len = s ? (uint64_t)n : 0; /* 0: the scene failed; rank 0 has said why */
        /* Sent now, or once MPI has started (ready): the bytes become the queue's. */
        if (!root_bcast(&len, 1, MPI_UINT64_T, sizeof len, false) ||
            (len > 0 && !root_bcast(packed, len, MPI_BYTE, 1, true)))
            die("out of memory");
        return s;
    }
    uint64_t len = 0;
    bcast(&len, 1, MPI_UINT64_T);
    if (len == 0)
        return NULL;
    uint8_t *packed = bigmem_alloc(len);
    if (!packed)
        die("out of memory for the scene files");
    bcast_bytes(packed, len);
    SceneFiles *files = scene_files_unpack(packed, len);
    if (!files)
        die("could not unpack the scene files");
    Diag quiet;
    diag_init(&quiet, NULL);
    Scene *s = scene_load_with(path, files, cache, false, &quiet); /* only the root writes */
    scene_files_free(files);
    if (!s)
        die(quiet.last[0] ? quiet.last : "the scene failed to load from rank 0's bytes");
    bigmem_free(packed);
    return s;
}

/* ---- rendering -------------------------------------------------------------------- */

/* The rectangle is cut into bands of whole 8-row packet bands of the full image (so
 * the counters add up to a single process's exactly), guided and as they are handed
 * out: each tile takes a share 1/(2 N) of the rows still to hand out on N ranks, so
 * the first tiles are big (few messages, few film margins traced twice), the last are
 * the smallest, and the rank that finishes last has at most a small tile to go. Cut
 * at hand-out time, not in advance, so that a rank that starts late (rank 0 renders
 * while the others are still starting MPI and building their scene) gets a share of
 * what is left, not one of the first, biggest tiles: cut in advance, a second rank
 * arriving 0.5 s late at 1080p took a 272-row tile and finished 0.6 s after rank 0.
 * A tile has at least as many packet bands as the root has threads (each band keeps
 * one render thread busy) and at most what keeps a tile's message within
 * TILE_MAX_BYTES. */
enum { TILE_MAX_BYTES = 16 << 20 };

typedef struct Farm {
    const DistJob *full;     /* the whole rectangle (and the root's images) */
    int min_rows, max_rows;  /* a tile's rows (max_rows: buffers) */
    /* The root's work queue (lock): rows [next_row, end_row) are still to hand out;
     * tile t (t < ntiles) is rows [lo[t], hi[t]), clipped to the rectangle. */
    pthread_mutex_t lock;
    int next_row, end_row, ntiles, cap_tiles;
    int *lo, *hi;
    atomic_int done;         /* rows finished (progress) */
    volatile int *cancel;
    RtStats local;           /* the root's own tiles */
    bool local_failed;
    double t0;               /* the root: when its dist_render started (now_ms) */
    /* The root's "rows done" line (progress): the rows it last showed (-1: none yet);
     * when stderr is no terminal (log), when the last line was written (now_ms). */
    int shown;
    bool log;
    double logged_at;
} Farm;

/* -timings under MPI (dist_report): what the root saw of its last dist_render, per
 * rank, in ms after that render's start on the root's clock: the first request (rank
 * 0: its first tile taken), the last tile placed, and the tiles rendered. */
typedef struct RankLog {
    double first, last;
    int tiles;
} RankLog;
static RankLog *g_log;
static int g_log_tiles;

/* The root: cuts the next tile off the queue, a guided share of min_rows..max_rows
 * rows (multiples of RENDER_TILE); its number, or -1 when none is left. */
static int take_tile(Farm *f)
{
    pthread_mutex_lock(&f->lock);
    int t = -1;
    if (f->next_row < f->end_row && f->ntiles < f->cap_tiles) {
        int rows = (f->end_row - f->next_row) / (2 * g_size);
        rows = (rows + RENDER_TILE - 1) / RENDER_TILE * RENDER_TILE;
        rows = rows < f->min_rows ? f->min_rows : rows > f->max_rows ? f->max_rows : rows;
        t = f->ntiles++;
        f->lo[t] = f->next_row;
        f->next_row += rows;
        f->hi[t] = f->next_row < f->end_row ? f->next_row : f->end_row;
    }
    pthread_mutex_unlock(&f->lock);
    return t;
}

/* Rows [*y0, *y1) of the full image clipped to the rectangle. */
static void clip_rows(const Farm *f, int *y0, int *y1)
{
    int top = f->full->y0 + f->full->h;
    *y0 = *y0 < f->full->y0 ? f->full->y0 : *y0;
    *y1 = *y1 > top ? top : *y1;
}

/* The root: tile t's rows, clipped. */
static void tile_rows(Farm *f, int t, int *y0, int *y1)
{
    pthread_mutex_lock(&f->lock);
    *y0 = f->lo[t];
    *y1 = f->hi[t];
    pthread_mutex_unlock(&f->lock);
    clip_rows(f, y0, y1);
}

/* The images of the tile of rows [lo, hi), rendered; pixels in *buf: colour, depth,
 * normals (those requested), each w x rows Vec3 bottom row first. */
static bool render_tile(Farm *f, int lo, int hi, Vec3 *buf, RtStats *stats)
{
    const DistJob *full = f->full;
    int y0 = lo, y1 = hi;
    clip_rows(f, &y0, &y1);
    int w = full->w, rows = y1 - y0;
    size_t n = (size_t)w * (size_t)rows;
    Image img[3];
    Image *want[3] = {full->color, full->depth, full->normals}, *out[3] = {NULL, NULL, NULL};
    Vec3 *p = buf;
    for (int k = 0; k < 3; k++) {
        if (!want[k])
            continue;
        img[k] = (Image){.width = w, .height = rows, .pixels = p};
        out[k] = &img[k];
        p += n;
    }
    return full->render(full->user, full->x0, y0, w, rows, out[0], out[1], out[2], stats,
                        NULL);
}

static int outputs(const DistJob *t)
{
    return (t->color != NULL) + (t->depth != NULL) + (t->normals != NULL);
}

/* Copies a tile's pixels (render_tile's layout) into the root's images. */
static void place_tile(Farm *f, int t, const Vec3 *buf)
{
    const DistJob *full = f->full;
    int y0, y1;
    tile_rows(f, t, &y0, &y1);
    size_t n = (size_t)full->w * (size_t)(y1 - y0);
    atomic_fetch_add(&f->done, y1 - y0);
    Image *imgs[3] = {full->color, full->depth, full->normals};
    for (int k = 0; k < 3; k++) {
        if (!imgs[k])
            continue;
        memcpy(imgs[k]->pixels + (size_t)(y0 - full->y0) * (size_t)full->w, buf,
               n * sizeof *buf);
        buf += n;
    }
}

/* Rank 0's own rendering thread: it takes tiles from the same queue as the others. */
static void *local_main(void *arg)
{
    Farm *f = arg;
    size_t cap = (size_t)f->full->w * (size_t)f->max_rows * (size_t)outputs(f->full);
    Vec3 *buf = bigmem_alloc(cap * sizeof *buf);
    if (!buf) {
        f->local_failed = true;
        return NULL;
    }
    for (;;) {
        if (*f->cancel)
            break;
        int t = take_tile(f);
        if (t < 0)
            break;
        if (g_log && g_log[0].first < 0)
            g_log[0].first = now_ms() - f->t0;
        pthread_mutex_lock(&f->lock);
        int lo = f->lo[t], hi = f->hi[t];
        pthread_mutex_unlock(&f->lock);
        if (!render_tile(f, lo, hi, buf, &f->local)) {
            f->local_failed = true;
            break;
        }
        place_tile(f, t, buf);
        if (g_log) { /* only this thread writes rank 0's entry; read after the join */
            g_log[0].tiles++;
            g_log[0].last = now_ms() - f->t0;
        }
    }
    bigmem_free(buf);
    return NULL;
}

/* "rows done", when the job asks for it (DistJob.progress): on a terminal rewritten in
 * place; into a pipe or a file (under OpenMPI's mpirun stderr always is one; a batch
 * job's log) as whole lines at ./raytracer's cadence (rt/progress.h): one once both 5%
 * more rows are done and 30 s have passed since the last, and the final one (last).
 * Redrawn there with carriage returns, every tile added ~40 bytes to one endless line
 * of the log. */
static void progress(Farm *f, bool last)
{
    int d = atomic_load(&f->done), h = f->full->h;
    if (f->log) {
        double now = now_ms();
        int step = (h + PROGRESS_LOG_STEPS - 1) / PROGRESS_LOG_STEPS;
        bool due = d < h && d - (f->shown > 0 ? f->shown : 0) >= step &&
                   now - f->logged_at >= PROGRESS_LOG_SECONDS * 1e3;
        if (!last && !due)
            return;
        f->shown = d;
        f->logged_at = now;
        fprintf(stderr, "raytracer-mpi: %d/%d rows on %d ranks\n", d, h, g_size);
        fflush(stderr);
        return;
    }
    if (d == f->shown && !last)
        return;
    f->shown = d;
    fprintf(stderr, "\rraytracer-mpi: %d/%d rows on %d ranks%s", d, h, g_size,
            last ? "\n" : "");
    fflush(stderr);
}

/* Requests a worker keeps in flight. Two (the answer naming its next tile on its way
 * while it renders one) saved the round trip between tiles but made the tail long: a
 * worker then always holds a tile cut one tile earlier, and at 1080p on 2 ranks it
 * finished 45-73 ms after rank 0 (-timings, 4 runs); with one, 9-21 ms, and the job's
 * wall time fell 50-100 ms (paired runs, bench/REPORT.txt). The round trip is short:
 * rank 0 answers as soon as it sees a request, before it receives the pixels. Rank 0
 * answers every request; once the queue is empty every answer is "no more", so a
 * worker's last REQUESTS_IN_FLIGHT answers are all "no more". */
enum { REQUESTS_IN_FLIGHT = 1 };

/* Tile buffers and the scene's bytes are big and touched once per job: they come from
 * rt/bigmem.h (huge pages), which saves a page fault per 4 KB (a 272-row 1080p tile is
 * 6 MB; ~100 ms of faults over a job's buffers here). */

/* Rank 0's answer to a request: the tile's number and its rows [lo, hi) (unclipped);
 * number -1: no more. */
enum { ANSWER_INTS = 3 };

/* Bytes of a tile's message: the header (two ints: the tile finished, -1 for a bare
 * request, and one unused) and its pixels. */
static size_t tile_message_bytes(const Farm *f, int rows)
{
    return 2 * sizeof(int) +
           (size_t)f->full->w * (size_t)rows * (size_t)outputs(f->full) * sizeof(Vec3);
}

/* Rank 0: serves tile requests until every other rank has been told "no more" once for
 * each request it keeps in flight, while local_main renders on its own thread. A
 * request is a message of the tile just finished (with its pixels) or a bare one; the
 * answer is the next tile, cut now (tile -1: no more), sent as soon as the request is
 * seen, before its pixels are received and placed, so the worker renders again while
 * they are copied. Between messages the thread naps, so it costs next to nothing
 * beside the renderers on the same cores. */
static void serve(Farm *f)
{
    size_t cap = tile_message_bytes(f, f->max_rows);
    uint8_t *msg = bigmem_alloc(cap);
    if (!msg)
        die("out of memory");
    bool tty = progress_wanted(f->full->progress, stderr);
    int active = (g_size - 1) * REQUESTS_IN_FLIGHT;
    long ns = NAP_MIN_NS;
    while (active > 0) {
        int flag = 0;
        MPI_Message handle;
        MPI_Status st;
        MPI_Improbe(MPI_ANY_SOURCE, TAG_RESULT, MPI_COMM_WORLD, &flag, &handle, &st);
        if (!flag) {
            if (tty)
                progress(f, false);
            nap(&ns);
            continue;
        }
        ns = NAP_MIN_NS;
        int count = 0;
        MPI_Get_count(&st, MPI_BYTE, &count);
        if (count < (int)sizeof(int) || (size_t)count > cap)
            die("malformed message from a rank");
        int next = *f->cancel ? -1 : take_tile(f);
        int answer[ANSWER_INTS] = {-1, 0, 0};
        if (next < 0) {
            active--;
        } else {
            answer[0] = next;
            pthread_mutex_lock(&f->lock);
            answer[1] = f->lo[next];
            answer[2] = f->hi[next];
            pthread_mutex_unlock(&f->lock);
        }
        MPI_Send(answer, ANSWER_INTS, MPI_INT, st.MPI_SOURCE, TAG_WORK, MPI_COMM_WORLD);
        /* A big message may need its sender's progress to arrive (a rendezvous over a
         * network): its worker tests its sends between naps, so this is short. */
        MPI_Request req;
        MPI_Imrecv(msg, count, MPI_BYTE, &handle, &req);
        wait_request(&req, NULL);
        int finished;
        memcpy(&finished, msg, sizeof finished);
        RankLog *log = g_log && st.MPI_SOURCE > 0 && st.MPI_SOURCE < g_size
                           ? &g_log[st.MPI_SOURCE] : NULL;
        if (log && log->first < 0)
            log->first = now_ms() - f->t0;
        pthread_mutex_lock(&f->lock);
        bool known = finished >= 0 && finished < f->ntiles;
        pthread_mutex_unlock(&f->lock);
        if (known) {
            place_tile(f, finished, (const Vec3 *)(void *)(msg + 2 * sizeof(int)));
            if (log) {
                log->tiles++;
                log->last = now_ms() - f->t0;
            }
        }
        if (tty)
            progress(f, false);
    }
    bigmem_free(msg);
    if (tty)
        progress(f, false);
}

/* A worker's tile buffers: a tile waits for the render thread (TODO), is rendered,
 * waits for the main thread to send it (DONE), and is on its way (SENDING) until its
 * send completes. REQUESTS_IN_FLIGHT tiles are held at most between answer and send;
 * the other slots let sends that are slow to complete overlap the next renders. */
enum { SLOT_FREE, SLOT_TODO, SLOT_RENDERING, SLOT_DONE, SLOT_SENDING };
enum { NSLOTS = REQUESTS_IN_FLIGHT + 2 };

typedef struct Worker {
    Farm *farm;
    RtStats *stats;
    pthread_mutex_t lock;
    pthread_cond_t wake;       /* the render thread: a tile to render, or stop */
    pthread_cond_t rendered;   /* the main thread: a tile is rendered (or failed) */
    int state[NSLOTS], tile[NSLOTS][ANSWER_INTS]; /* tile: rank 0's answer */
    uint8_t *buf[NSLOTS];      /* each a whole message: header and pixels */
    MPI_Request send[NSLOTS];
    bool stop, failed;
} Worker;

/* A worker's render thread: renders TODO slots in the order they were handed out
 * (lowest tile first) until told to stop. */
static void *worker_render_main(void *arg)
{
    Worker *w = arg;
    pthread_mutex_lock(&w->lock);
    for (;;) {
        int s = -1;
        for (int k = 0; k < NSLOTS; k++)
            if (w->state[k] == SLOT_TODO && (s < 0 || w->tile[k][0] < w->tile[s][0]))
                s = k;
        if (s < 0) {
            if (w->stop)
                break;
            pthread_cond_wait(&w->wake, &w->lock);
            continue;
        }
        w->state[s] = SLOT_RENDERING;
        pthread_mutex_unlock(&w->lock);
        Vec3 *pix = (Vec3 *)(void *)(w->buf[s] + 2 * sizeof(int));
        bool ok = render_tile(w->farm, w->tile[s][1], w->tile[s][2], pix, w->stats);
        pthread_mutex_lock(&w->lock);
        w->state[s] = SLOT_DONE;
        pthread_cond_signal(&w->rendered);
        if (!ok) {
            w->failed = true;
            break;
        }
    }
    pthread_mutex_unlock(&w->lock);
    return NULL;
}

/* True when a tile waits to be sent (w->lock held). */
static bool slot_rendered(const Worker *w)
{
    for (int k = 0; k < NSLOTS; k++)
        if (w->state[k] == SLOT_DONE)
            return true;
    return false;
}

/* Other ranks: the main thread talks to rank 0 (only it calls MPI), a second thread
 * renders. The main thread keeps REQUESTS_IN_FLIGHT requests out, hands each tile
 * named in an answer to the render thread, sends each rendered tile (the send is the
 * next request) and tests the sends, so a transfer that needs this side's progress
 * moves on while the next tile renders. While an answer or a send is outstanding it
 * naps between tests; with neither (its next tiles in hand, its sends complete) it
 * sleeps until the render thread finishes a tile. */
static void work(Farm *f, RtStats *stats)
{
    Worker w;
    memset(&w, 0, sizeof w);
    w.farm = f;
    w.stats = stats;
    size_t cap = tile_message_bytes(f, f->max_rows);
    for (int k = 0; k < NSLOTS; k++)
        if (!(w.buf[k] = bigmem_alloc(cap)))
            die("out of memory");
    pthread_mutex_init(&w.lock, NULL);
    pthread_cond_init(&w.wake, NULL);
    pthread_cond_init(&w.rendered, NULL);
    pthread_t th;
    if (pthread_create(&th, NULL, worker_render_main, &w) != 0)
        die("could not start a render thread");
    /* Fault injection for the tests (tests/e2e/test_mpi.c): this rank dies on rank 0's
     * first answer (a tile, or no more work), as a crashed or killed node would; always
     * before the counters are gathered, so the job can never complete. */
    const char *kill_rank = getenv("RT_MPI_TEST_KILL_RANK");
    bool die_on_tile = kill_rank && atoi(kill_rank) == g_rank;
    int bare[2] = {-1, 0};
    for (int k = 0; k < REQUESTS_IN_FLIGHT; k++)
        MPI_Send(bare, (int)sizeof bare, MPI_BYTE, 0, TAG_RESULT, MPI_COMM_WORLD);
    int in_flight = REQUESTS_IN_FLIGHT;
    int answer[ANSWER_INTS] = {-1, 0, 0};
    MPI_Request answer_req;
    MPI_Irecv(answer, ANSWER_INTS, MPI_INT, 0, TAG_WORK, MPI_COMM_WORLD, &answer_req);
    int held[REQUESTS_IN_FLIGHT][ANSWER_INTS], nheld = 0; /* tiles waiting for a slot */
    long ns = NAP_MIN_NS;
    for (;;) {
        bool moved = false;
        int got = 0;
        if (in_flight > 0)
            MPI_Test(&answer_req, &got, MPI_STATUS_IGNORE);
        if (got) {
            moved = true;
            in_flight--;
            if (die_on_tile)
                raise(SIGKILL);
            if (answer[0] >= 0) {
                if (answer[2] <= answer[1] || answer[2] - answer[1] > f->max_rows ||
                    nheld == REQUESTS_IN_FLIGHT)
                    die("malformed answer from rank 0");
                memcpy(held[nheld++], answer, sizeof answer);
            }
            if (in_flight > 0)
                MPI_Irecv(answer, ANSWER_INTS, MPI_INT, 0, TAG_WORK, MPI_COMM_WORLD,
                          &answer_req);
        }
        bool busy = false, sending = false;
        pthread_mutex_lock(&w.lock);
        if (w.failed) {
            pthread_mutex_unlock(&w.lock);
            die("could not render a tile (out of memory?)");
        }
        for (int k = 0; k < NSLOTS; k++) {
            if (w.state[k] == SLOT_SENDING) {
                int sent = 0;
                MPI_Test(&w.send[k], &sent, MPI_STATUS_IGNORE);
                if (sent) {
                    w.state[k] = SLOT_FREE;
                    moved = true;
                }
            }
            if (w.state[k] == SLOT_DONE) {
                int y0 = w.tile[k][1], y1 = w.tile[k][2];
                clip_rows(f, &y0, &y1);
                memcpy(w.buf[k], &w.tile[k][0], sizeof(int));
                MPI_Isend(w.buf[k], (int)tile_message_bytes(f, y1 - y0), MPI_BYTE, 0,
                          TAG_RESULT, MPI_COMM_WORLD, &w.send[k]);
                w.state[k] = SLOT_SENDING;
                in_flight++;
                moved = true;
                if (in_flight == 1) /* the answer Irecv stopped after the last answer */
                    MPI_Irecv(answer, ANSWER_INTS, MPI_INT, 0, TAG_WORK, MPI_COMM_WORLD,
                              &answer_req);
            }
            if (w.state[k] == SLOT_FREE && nheld > 0) {
                memcpy(w.tile[k], held[0], sizeof held[0]);
                memmove(held, held + 1, (size_t)--nheld * sizeof held[0]);
                w.state[k] = SLOT_TODO;
                pthread_cond_signal(&w.wake);
                moved = true;
            }
            busy = busy || w.state[k] != SLOT_FREE;
            sending = sending || w.state[k] == SLOT_SENDING;
        }
        bool finished = in_flight == 0 && nheld == 0 && !busy;
        if (finished) {
            w.stop = true;
            pthread_cond_signal(&w.wake);
        }
        bool idle = !finished && !moved && in_flight == 0 && nheld == 0 && !sending;
        /* Idle: a tile is with the render thread (busy), none is rendered (it would
         * have been sent), so the render thread will signal. */
        while (idle && !w.failed && !slot_rendered(&w))
            pthread_cond_wait(&w.rendered, &w.lock);
        pthread_mutex_unlock(&w.lock);
        if (finished)
            break;
        if (moved || idle)
            ns = NAP_MIN_NS;
        else
            nap(&ns);
    }
    pthread_join(th, NULL);
    pthread_cond_destroy(&w.rendered);
    pthread_cond_destroy(&w.wake);
    pthread_mutex_destroy(&w.lock);
    for (int k = 0; k < NSLOTS; k++)
        bigmem_free(w.buf[k]);
}

bool dist_render(const DistJob *job, RtStats *stats_out, volatile int *cancel)
{
    static volatile int never;
    if (!cancel)
        cancel = &never;
    if (g_size == 1) {
        RtStats st;
        memset(&st, 0, sizeof st);
        bool ok = job->render(job->user, job->x0, job->y0, job->w, job->h, job->color,
                              job->depth, job->normals, &st, cancel);
        if (stats_out)
            *stats_out = st;
        /* MPI's start ran beside the render: joined before any file is written, so a
         * failed start leaves no image. */
        ready();
        return ok;
    }
    Farm f;
    memset(&f, 0, sizeof f);
    f.full = job;
    f.cancel = cancel;
    f.t0 = now_ms();
    /* Everyone must cut the same tiles: rank 0's thread count decides. */
    int root_threads = job->threads > 0 ? job->threads : render_default_threads();
    if (g_rank != 0)
        bcast(&root_threads, 1, MPI_INT);
    else if (!root_bcast(&root_threads, 1, MPI_INT, sizeof root_threads, false))
        die("out of memory");
    int min_rows = RENDER_TILE * (root_threads < 64 ? root_threads : 64);
    while (min_rows < job->min_tile_rows)
        min_rows += RENDER_TILE;
    /* The largest tile: within TILE_MAX_BYTES, and no taller than the rectangle needs. */
    int lo = job->y0 / RENDER_TILE * RENDER_TILE, hi = job->y0 + job->h;
    size_t row_bytes = (size_t)job->w * (size_t)outputs(job) * sizeof(Vec3);
    size_t fit = row_bytes ? TILE_MAX_BYTES / row_bytes : (size_t)(hi - lo);
    if (fit > (size_t)(hi - lo))
        fit = (size_t)(hi - lo);
    f.max_rows = (int)fit / RENDER_TILE * RENDER_TILE;
    if (f.max_rows < min_rows)
        f.max_rows = min_rows;
    f.min_rows = min_rows;
    f.next_row = lo;
    f.end_row = hi;
    pthread_mutex_init(&f.lock, NULL);
    atomic_init(&f.done, 0);
    f.shown = -1;
    f.log = isatty(STDERR_FILENO) != 1;
    f.logged_at = now_ms();
    if (g_rank == 0) {
        /* Every tile but the last has min_rows rows or more. */
        f.cap_tiles = (hi - lo) / min_rows + 1;
        f.lo = malloc((size_t)f.cap_tiles * sizeof *f.lo);
        f.hi = malloc((size_t)f.cap_tiles * sizeof *f.hi);
        if (!f.lo || !f.hi)
            die("out of memory");
        /* the per-rank log (-timings); none when out of memory */
        free(g_log);
        if ((g_log = calloc((size_t)g_size, sizeof *g_log)))
            for (int r = 0; r < g_size; r++)
                g_log[r].first = -1.0;
    }

    RtStats mine;
    memset(&mine, 0, sizeof mine);
    int cancelled = 0;
    if (g_rank == 0) {
        pthread_t th;
        bool started = pthread_create(&th, NULL, local_main, &f) == 0;
        /* MPI's start (when it runs beside this) and the queued broadcasts: the other
         * ranks get the scene while this rank's render thread is already at work. */
        ready();
        serve(&f);
        if (started)
            pthread_join(th, NULL);
        else
            local_main(&f); /* no thread: render what is left here */
        if (f.local_failed)
            die("could not render a tile (out of memory?)");
        if (progress_wanted(job->progress, stderr))
            progress(&f, true);
        mine = f.local;
        cancelled = *cancel; /* the signal that stopped rank 0, for everyone's status */
    } else {
        work(&f, &mine);
    }
    g_log_tiles = f.ntiles;
    free(f.lo);
    free(f.hi);
    pthread_mutex_destroy(&f.lock);
    bcast(&cancelled, 1, MPI_INT);
    /* RtStats is plain 64-bit counters (rt/stats.h): summed as an array. */
    enum { NCOUNTS = sizeof(RtStats) / sizeof(uint64_t) };
    _Static_assert(sizeof(RtStats) == NCOUNTS * sizeof(uint64_t), "RtStats: counters only");
    uint64_t counts[NCOUNTS];
    memcpy(counts, &mine, sizeof mine);
    reduce_to_root(counts, NULL, NCOUNTS, MPI_UINT64_T, MPI_SUM);
    if (stats_out) {
        memset(stats_out, 0, sizeof *stats_out);
        if (g_rank == 0)
            memcpy(stats_out, counts, sizeof *stats_out);
    }
    if (cancelled) {
        *cancel = cancelled;
        return false;
    }
    return true;
}

void dist_report(FILE *out)
{
    fprintf(out, "timings: mpi: MPI_Init %.1f ms %s", g_init_ms,
            g_init_beside ? "beside rank 0's set-up and render" : "before the set-up");
    if (!g_log) {
        fputc('\n', out);
        return;
    }
    /* A rank is done at its last tile (or, with none, at its first request): the one
     * done first waited for the last, the tail of the queue. */
    double first_done = 0.0, last_done = 0.0;
    for (int r = 0; r < g_size; r++) {
        double d = g_log[r].tiles ? g_log[r].last : g_log[r].first;
        first_done = r == 0 || d < first_done ? d : first_done;
        last_done = d > last_done ? d : last_done;
    }
    /* The count is of the tiles cut from the queue, all ranks together; each rank's
     * entry counts the ones it rendered (they add up to it). "1 tile", not "1 tiles":
     * a small image is a single tile. */
    fprintf(out, "; %d %s handed out to %d ranks, the first rank done %.1f ms before the "
            "last; per rank, the tiles it rendered and ms after rank 0's render start "
            "(first request, last tile placed):", g_log_tiles,
            g_log_tiles == 1 ? "tile" : "tiles", g_size, last_done - first_done);
    /* A rank with no tile placed has no last time: "-", not a 0.0 that reads as a
     * tile placed at the render's start (a rank that joined after rank 0 had rendered
     * everything). */
    for (int r = 0; r < g_size; r++) {
        fprintf(out, " %d: %d %s %.1f ", r, g_log[r].tiles,
                g_log[r].tiles == 1 ? "tile" : "tiles", g_log[r].first);
        if (g_log[r].tiles)
            fprintf(out, "%.1f", g_log[r].last);
        else
            fputc('-', out);
        fputs(r + 1 < g_size ? "," : "", out);
    }
    fputc('\n', out);
}
