/* Small helpers shared by the benchmark's tracers (embree_ref.c, grid_ref.c). */
#ifndef RT_BENCH_UTIL_H
#define RT_BENCH_UTIL_H

#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "rt/camera.h"

/* Monotonic clock, seconds. */
static inline double now_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

/* CPU time of the whole process (all threads), seconds: on a loaded machine the rate
 * per CPU second is the steadier figure (rays / CPU time = rays per second per core
 * while the process runs). */
static inline double cpu_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static inline int cmp_double(const void *a, const void *b)
{
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

/* Median of v[0..n-1] (n >= 1); sorts v. */
static inline double median(double *v, int n)
{
    qsort(v, (size_t)n, sizeof *v, cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

/* One pass of nthreads workers (at most 64): worker i runs fn(workers + i * stride),
 * worker 0 on the calling thread. Returns the pass's wall time in seconds; a thread
 * that cannot start ends the benchmark (tool names it). */
static inline double bench_run_pass(void *(*fn)(void *), void *workers, size_t stride,
                                    int nthreads, const char *tool)
{
    pthread_t th[64];
    char *w = workers;
    double t0 = now_s();
    for (int i = 1; i < nthreads; i++) {
        if (pthread_create(&th[i], NULL, fn, w + (size_t)i * stride) != 0) {
            fprintf(stderr, "%s: cannot start threads\n", tool);
            exit(1);
        }
    }
    fn(w);
    for (int i = 1; i < nthreads; i++)
        pthread_join(th[i], NULL);
    return now_s() - t0;
}

/* The primary ray of every pixel (row by row), made once before the timed passes of
 * both tracers: ray generation is the harness's work, not the traversal's. */
static inline void bench_make_rays(const Camera *cam, int w, int h, Vec3 *org, Vec3 *dir)
{
    for (int j = 0; j < h; j++)
        for (int i = 0; i < w; i++) {
            float u, v;
            camera_pixel_to_screen(i, j, w, h, &u, &v);
            Ray r = camera_generate_ray(cam, u, v);
            org[(size_t)j * w + i] = r.origin;
            dir[(size_t)j * w + i] = r.dir;
        }
}

#endif
