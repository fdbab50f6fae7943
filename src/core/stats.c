/* The course's RAY TRACING STATISTICS block (raytracing_stats.C layout, spec stats.md). */
#include "rt/stats.h"

#include <math.h>
#include <time.h>

void stats_merge(RtStats *into, const RtStats *from)
{
    into->nonshadow_rays += from->nonshadow_rays;
    into->shadow_rays += from->shadow_rays;
    into->intersections += from->intersections;
    into->cells_traversed += from->cells_traversed;
    into->mailbox_skips += from->mailbox_skips;
    into->repeat_tests += from->repeat_tests;
}

double clock_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + (double)ts.tv_nsec * 1e-9;
}

static double ratio(double a, double b) { return b > 0.0 ? a / b : 0.0; }

void stats_print(FILE *out, const StatsReport *r)
{
    /* Whole seconds, 0 bumped to 1, as the course's time(NULL) difference. */
    long secs = (long)floor(r->elapsed_seconds);
    if (secs <= 0)
        secs = 1;
    unsigned long long rays = r->counts.nonshadow_rays + r->counts.shadow_rays;
    double elapsed = r->elapsed_seconds > 0.0 ? r->elapsed_seconds : 1e-9;
    double pixels = (double)r->width * (double)r->height;

    fprintf(out, "********************************************\n");
    fprintf(out, "RAY TRACING STATISTICS\n");
    fprintf(out, "  total time                 %ld:%02ld:%02ld\n", secs / 3600,
            (secs / 60) % 60, secs % 60);
    fprintf(out, "  num pixels                 %d (%dx%d)\n", r->width * r->height, r->width,
            r->height);
    if (r->bounds)
        fprintf(out, "  scene bounds               %f %f %f  -> %f %f %f\n",
                (double)r->bounds->min.x, (double)r->bounds->min.y, (double)r->bounds->min.z,
                (double)r->bounds->max.x, (double)r->bounds->max.y, (double)r->bounds->max.z);
    else
        fprintf(out, "  scene bounds               NULL\n");
    if (r->nx > 0)
        fprintf(out, "  num grid cells             %d (%dx%dx%d)\n", r->nx * r->ny * r->nz,
                r->nx, r->ny, r->nz);
    else
        fprintf(out, "  num grid cells             NULL\n");
    fprintf(out, "  num non-shadow rays        %llu\n", (unsigned long long)r->counts.nonshadow_rays);
    fprintf(out, "  num shadow rays            %llu\n", (unsigned long long)r->counts.shadow_rays);
    fprintf(out, "  total intersections        %llu\n", (unsigned long long)r->counts.intersections);
    fprintf(out, "  total cells traversed      %llu\n", (unsigned long long)r->counts.cells_traversed);
    /* Precise elapsed time here: the course's whole-second division would make this
     * equal to the ray count for every sub-second render (docs/statistics.md). */
    fprintf(out, "  rays per second            %0.1f\n", (double)rays / elapsed);
    fprintf(out, "  rays per pixel             %0.1f\n", ratio((double)rays, pixels));
    fprintf(out, "  intersections per ray      %0.1f\n",
            ratio((double)r->counts.intersections, (double)rays));
    fprintf(out, "  cells traversed per ray    %0.1f\n",
            ratio((double)r->counts.cells_traversed, (double)rays));
    fprintf(out, "********************************************\n");
}
