/* Ray-tracing statistics: per-thread counters merged by the driver, and the course's
 * RAY TRACING STATISTICS block (docs/statistics.md), label for label. */
#ifndef RT_STATS_H
#define RT_STATS_H

#include <stdint.h>
#include <stdio.h>
#include "rt/bbox.h"

/* Plain counters; each render thread owns one (no atomics, no sharing). */
typedef struct RtStats {
    uint64_t nonshadow_rays;   /* +1 per traceRay call (primary, reflected, refracted) */
    uint64_t shadow_rays;      /* +1 per shadow ray cast */
    uint64_t intersections;    /* +1 per Sphere/Plane/Triangle intersection routine run */
    uint64_t cells_traversed;  /* +1 per grid cell a march visits */
    uint64_t mailbox_skips;    /* grid: tests avoided because the primitive was marked */
    uint64_t repeat_tests;     /* grid: a primitive tested twice for one ray (0 with marking) */
} RtStats;

void stats_merge(RtStats *into, const RtStats *from);

typedef struct StatsReport {
    int width, height;
    const BBox *bounds;        /* NULL prints "NULL" */
    int nx, ny, nz;            /* 0,0,0 = no grid: prints "NULL" */
    double elapsed_seconds;    /* monotonic wall time of the render */
    RtStats counts;
} StatsReport;

/* Prints the 15-line block, every figure the course's way: total time is H:MM:SS in
 * whole seconds (stats_course_seconds), rays per second is
 * stats_course_rays_per_second. */
void stats_print(FILE *out, const StatsReport *r);
/* The whole seconds the course prints as total time: floor(elapsed), and 1 when that
 * is 0 (the course's time(NULL) difference, bumped from 0 to 1). */
long stats_course_seconds(double elapsed_seconds);
/* The course's rays per second: rays / stats_course_seconds(elapsed), divided in single
 * precision like the course (so a render under a second shows the ray count). */
double stats_course_rays_per_second(uint64_t rays, double elapsed_seconds);
/* The precise rate (for -timings): rays / elapsed; 0 when elapsed is not positive. */
double stats_rays_per_second(uint64_t rays, double elapsed_seconds);

#endif
