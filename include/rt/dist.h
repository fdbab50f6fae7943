/* How this process takes part in a render: alone (src/dist/dist_local.c, linked into
 * ./raytracer) or as one rank of an MPI job (src/dist/dist_mpi.c, ./raytracer-mpi).
 * main.c calls these at fixed points and runs the same code either way; every rank
 * runs main with the same options. Only the root (rank 0) prints and writes files. */
#ifndef RT_DIST_H
#define RT_DIST_H

#include <stdbool.h>
#include <stdio.h>
#include "rt/render.h"
#include "rt/scene.h"

/* The binary's name for its messages, -h and --version ("raytracer" or
 * "raytracer-mpi"; main passes it to diag_set_program). */
extern const char dist_program_name[];

/* Starts the job (MPI_Init); false when that failed (a message was printed). */
bool dist_init(int *argc, char ***argv);
/* Ends the job; every rank returns the root's status (its exit status). */
int dist_finish(int status);
/* True on the process that prints and writes (always, when alone). */
bool dist_is_root(void);
/* Number of processes in the job (1 when alone). */
int dist_size(void);
/* True when an MPI launcher (mpirun, srun) started this process: its standard output
 * is then the launcher's channel, a pseudo-terminal under OpenMPI's mpirun whatever
 * mpirun's own standard output is (a file, a pipe), so it cannot be told from here
 * whether an image written there would reach a terminal. Always false when alone. */
bool dist_stdout_forwarded(void);
/* The rank an MPI launcher gave this process, read from the launcher's environment
 * (OpenMPI's OMPI_COMM_WORLD_RANK, PMIx's PMIX_RANK, PMI's PMI_RANK) without starting
 * MPI; -1 when none did (a singleton, a plain process), and always -1 when alone
 * (./raytracer is no MPI program: under mpirun each copy is a process of its own).
 * For -merge, which needs no MPI: under mpirun only rank 0 merges. */
int dist_launcher_rank(void);
/* A short description for --version ("MPI (OpenMPI ...)" or "no"). */
const char *dist_describe(void);

/* Loads the scene on every rank: the root reads path and its OBJ files and sends their
 * bytes to the others, which build the same scene from them (no shared file system
 * needed). Errors are reported to diag on the root only; every rank returns NULL.
 * cache: the set-up cache (-cache; NULL: none), used by every rank's load. identify:
 * the root keys the scene's inputs (scene_load_with) for a part image's record. */
Scene *dist_scene_load(const char *path, SetupCache *cache, bool identify, Diag *diag);

/* Renders the rectangle of w x h pixels at (x0, y0) (full-image pixels, y from the
 * bottom) into the images given (each w x h; NULL: not wanted), adding its counters to
 * *stats; false on failure or cancel. main's: render_image or, with antialiasing, the
 * film (which renders the filter's margin too, so the pixels equal the whole render's). */
typedef bool (*DistRectFn)(void *user, int x0, int y0, int w, int h, Image *color,
                           Image *depth, Image *normals, RtStats *stats,
                           volatile int *cancel);

typedef struct DistJob {
    int x0, y0, w, h;          /* the rectangle to render (y from the bottom) */
    /* The root's images of the rectangle. On other ranks they are only read for which
     * outputs are requested (their pixels may be NULL) and are left untouched. */
    Image *color, *depth, *normals;
    int threads;               /* the root's -threads (0: all cores): tiles are cut to it */
    int min_tile_rows;         /* at least this many rows per tile (film margins) */
    /* The root's "rows done" line on stderr, when there are other ranks: -progress
     * (PROGRESS_ALWAYS) draws it, -quiet or the preview (PROGRESS_NEVER) not, else
     * only when stderr is a terminal. Under OpenMPI's mpirun it never is (the ranks'
     * stderr is a pipe to mpirun), so there the line needs -progress, and it comes as
     * whole lines at the cadence of rt/progress.h's log. */
    ProgressMode progress;
    DistRectFn render;
    void *user;
} DistJob;

/* Renders job's rectangle over all ranks: the root hands out tiles (bands of whole
 * 8-row packet bands) first-come first-served, renders some itself, and gathers every
 * pixel into its images. stats_out: the counters summed over all ranks, on the root. A
 * cancel seen by the root (it stops handing out tiles; the value is main's, the
 * stopping signal) is copied into *cancel on every rank, and every rank returns
 * false. */
bool dist_render(const DistJob *job, RtStats *stats_out, volatile int *cancel);

/* The root's ok, on every rank (every rank calls it at the same point; the others'
 * ok is ignored), so a failure only the root can have (its images' memory: the other
 * ranks allocate nothing) stops them all at the same step. The root does not wait for
 * the others: it sends its answer and goes on (a collective that waited would hold the
 * root's render until the last rank has built its scene and grid). */
bool dist_root_ok(bool ok);

/* v[0..n-1] becomes the maximum over all ranks, on the root (phase times). */
void dist_max(double *v, int n);

/* -timings, on the root after dist_render: MPI's start-up time and how the last
 * render's tiles went (per rank: tiles, first request, last tile; the tail). Nothing
 * when alone. */
void dist_report(FILE *out);

#endif
