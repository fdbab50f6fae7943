/* The image loop: rows handed out to worker threads through an atomic counter. A
 * pixel depends only on its coordinates, so images and counters are identical for
 * any thread count. */
#include "rt/render.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <unistd.h>

typedef struct RenderJob {
    const RayTracer *rt;
    const Camera *camera;
    RenderTarget *target;
    RenderRowFn row_done;
    void *user;
    volatile int *cancel;
    atomic_int next_row;
    atomic_int failed;
} RenderJob;

typedef struct Worker {
    RenderJob *job;
    RenderCtx ctx;
    pthread_t thread;
    bool started;
} Worker;

int render_default_threads(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

static void render_row(RenderJob *job, RenderCtx *ctx, int y)
{
    RenderTarget *t = job->target;
    float tmin = camera_tmin(job->camera);
    for (int x = 0; x < t->width; x++) {
        float u, v;
        camera_pixel_to_screen(x, y, t->width, t->height, &u, &v);
        Ray ray = camera_generate_ray(job->camera, u, v);
        Hit hit;
        Vec3 c = raytracer_trace(job->rt, ctx, &ray, tmin, 0, 1.0f, 1.0f, &hit);
        if (t->color)
            image_set(t->color, x, y, c);
        bool any = hit.material != NULL && isfinite(hit.t);
        if (t->depth) {
            float g = 0.0f;
            if (any) {
                /* Near = white, far = black, linear between dmin and dmax (A1). */
                float d = hit.t < t->depth_min ? t->depth_min
                        : hit.t > t->depth_max ? t->depth_max : hit.t;
                g = (t->depth_max - d) / (t->depth_max - t->depth_min);
            }
            image_set(t->depth, x, y, v3(g, g, g));
        }
        if (t->normals) {
            Vec3 n = any ? v3(fabsf(hit.normal.x), fabsf(hit.normal.y), fabsf(hit.normal.z))
                         : v3(0, 0, 0);
            image_set(t->normals, x, y, n);
        }
    }
}

static void *worker_main(void *arg)
{
    Worker *w = arg;
    RenderJob *job = w->job;
    for (;;) {
        if (job->cancel && *job->cancel)
            break;
        int y = atomic_fetch_add(&job->next_row, 1);
        if (y >= job->target->height)
            break;
        render_row(job, &w->ctx, y);
        if (job->row_done)
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
    if (threads > target->height && target->height > 0)
        threads = target->height;
    if (threads < 1)
        threads = 1;

    RenderJob job = {rt, camera, target, row_done, user, cancel, 0, 0};
    Worker *workers = calloc((size_t)threads, sizeof *workers);
    if (!workers)
        return false;
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
        for (int i = 1; i < threads; i++)
            workers[i].started =
                pthread_create(&workers[i].thread, NULL, worker_main, &workers[i]) == 0;
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
