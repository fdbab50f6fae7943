/* The image loop: bands of rows handed out to worker threads through an atomic
 * counter. A pixel depends only on its coordinates, and the tiles only on the image
 * size, so images and counters are identical for any thread count. */
#include "rt/render.h"
#include "rt/par.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

typedef struct RenderJob {
    const RayTracer *rt;
    const Camera *camera;
    RenderTarget *target;
    RenderRowFn row_done;
    void *user;
    volatile int *cancel;
    atomic_int next_row;  /* next band of TILE rows */
    atomic_int failed;
    const struct Worker *first; /* worker 0, run by the calling thread */
} RenderJob;

/* Each worker on cache lines of its own: its counters change at every cell and test,
 * and two threads writing one line would bounce it between the cores. */
typedef struct Worker {
    _Alignas(128) RenderJob *job;
    RenderCtx ctx;
    pthread_t thread;
    bool started;
} Worker;

int render_default_threads(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

/* Rows are rendered in bands of TILE rows, each band in TILE x TILE tiles: a tile's
 * primary rays (and then their shadow rays) go through the grid as one packet. */
#define TILE RENDER_TILE
_Static_assert(TILE * TILE <= GRID_PACKET_MAX, "a tile must fit in one ray packet");

static void store_pixel(RenderTarget *t, int x, int y, Vec3 c, const Hit *hit)
{
    if (t->color)
        image_set(t->color, x, y, c);
    bool any = hit->material != NULL && isfinite(hit->t);
    if (t->depth) {
        float g = 0.0f;
        if (any) {
            /* Near = white, far = black, linear between dmin and dmax (A1). */
            float d = hit->t < t->depth_min ? t->depth_min
                    : hit->t > t->depth_max ? t->depth_max : hit->t;
            g = (t->depth_max - d) / (t->depth_max - t->depth_min);
        }
        image_set(t->depth, x, y, v3(g, g, g));
    }
    if (t->normals) {
        Vec3 n = any ? v3(fabsf(hit->normal.x), fabsf(hit->normal.y), fabsf(hit->normal.z))
                     : v3(0, 0, 0);
        image_set(t->normals, x, y, n);
    }
}

void render_tile_order(int k, int *dx, int *dy)
{
    int x = 0, y = 0;
    for (int b = 0; (1 << (2 * b)) < TILE * TILE; b++) {
        x |= ((k >> (2 * b)) & 1) << b;
        y |= ((k >> (2 * b + 1)) & 1) << b;
    }
    *dx = x;
    *dy = y;
}

static void render_band(RenderJob *job, RenderCtx *ctx, int y0, int y1)
{
    RenderTarget *t = job->target;
    float tmin = camera_tmin(job->camera);
    Ray rays[TILE * TILE];
    Hit hits[TILE * TILE];
    Vec3 colors[TILE * TILE];
    int px[TILE * TILE], py[TILE * TILE];
    for (int x0 = 0; x0 < t->width; x0 += TILE) {
        int n = 0;
        for (int k = 0; k < TILE * TILE; k++) {
            int dx, dy;
            render_tile_order(k, &dx, &dy);
            int x = x0 + dx, y = y0 + dy;
            if (x >= t->width || y >= y1)
                continue;
            float u, v;
            camera_pixel_to_screen(x, y, t->width, t->height, &u, &v);
            rays[n] = camera_generate_ray(job->camera, u, v);
            px[n] = x;
            py[n++] = y;
        }
        raytracer_trace_packet(job->rt, ctx, rays, n, tmin, colors, hits);
        for (int i = 0; i < n; i++)
            store_pixel(t, px[i], py[i], colors[i], &hits[i]);
    }
}

static void *worker_main(void *arg)
{
    Worker *w = arg;
    if (w != w->job->first)
        par_thread_release_cpus(); /* started off the creator's CPU; now free */
    RenderJob *job = w->job;
    for (;;) {
        if (job->cancel && *job->cancel)
            break;
        int band = atomic_fetch_add(&job->next_row, 1);
        int h = job->target->height;
        if (band >= (h + TILE - 1) / TILE)
            break;
        int y0 = band * TILE, y1 = y0 + TILE < h ? y0 + TILE : h;
        render_band(job, &w->ctx, y0, y1);
        if (job->row_done)
            for (int y = y0; y < y1; y++)
                job->row_done(job->user, y);
    }
    return NULL;
}

bool render_image(const RayTracer *rt, const Camera *camera, RenderTarget *target,
                  int threads, RtStats *stats_out, RenderRowFn row_done, void *user,
                  volatile int *cancel)
{
    if (threads <= 0)
        threads = render_default_threads();
    int bands = (target->height + TILE - 1) / TILE;
    if (threads > bands && bands > 0)
        threads = bands;
    if (threads < 1)
        threads = 1;

    RenderJob job = {rt, camera, target, row_done, user, cancel, 0, 0, NULL};
    Worker *workers = aligned_alloc(_Alignof(Worker), (size_t)threads * sizeof *workers);
    if (!workers)
        return false;
    memset(workers, 0, (size_t)threads * sizeof *workers);
    bool ok = true;
    for (int i = 0; i < threads; i++) {
        workers[i].job = &job;
        if (!render_ctx_init(&workers[i].ctx, rt)) {
            ok = false;
            break;
        }
    }
    if (ok) {
        /* Worker 0 runs on this thread: -threads 1 starts no thread at all. */
        /* The workers start on other CPUs than this one (rt/par.h): on a small image
         * a worker sharing this CPU for its first milliseconds would cost more than
         * it brings. */
        job.first = &workers[0];
        pthread_attr_t attr;
        bool attr_ok = pthread_attr_init(&attr) == 0;
        if (attr_ok)
            par_attr_keep_off_this_cpu(&attr);
        for (int i = 1; i < threads; i++)
            workers[i].started = pthread_create(&workers[i].thread, attr_ok ? &attr : NULL,
                                                worker_main, &workers[i]) == 0;
        if (attr_ok)
            pthread_attr_destroy(&attr);
        worker_main(&workers[0]);
        /* A thread that failed to start loses nothing: the others take its rows. */
        for (int i = 1; i < threads; i++)
            if (workers[i].started)
                pthread_join(workers[i].thread, NULL);
    }
    RtStats total = {0};
    for (int i = 0; i < threads; i++) {
        stats_merge(&total, &workers[i].ctx.stats);
        render_ctx_free(&workers[i].ctx);
    }
    free(workers);
    if (stats_out)
        *stats_out = total;
    if (cancel && *cancel)
        return false;
    return ok;
}
