/* Ray-tracing statistics: per-thread counters merged by the driver, and the course's
 * RAY TRACING STATISTICS block (spec stats.md), label for label. */
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

/* Prints the 15-line block. total time is the course's H:MM:SS (whole seconds, 0
 * bumped to 1 like the course); rays per second uses the precise elapsed time. */
void stats_print(FILE *out, const StatsReport *r);

/* Monotonic clock in seconds. */
double clock_now(void);

#endif
