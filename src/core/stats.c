/* The course's RAY TRACING STATISTICS block (raytracing_stats.C layout;
 * docs/statistics.md). */
#include "rt/stats.h"

#include <math.h>

void stats_merge(RtStats *into, const RtStats *from)
{
    into->nonshadow_rays += from->nonshadow_rays;
    into->shadow_rays += from->shadow_rays;
    into->intersections += from->intersections;
    into->cells_traversed += from->cells_traversed;
    into->mailbox_skips += from->mailbox_skips;
    into->repeat_tests += from->repeat_tests;
}

static double ratio(double a, double b) { return b > 0.0 ? a / b : 0.0; }

long stats_course_seconds(double elapsed_seconds)
{
    /* Whole seconds, 0 bumped to 1, as the course's time(NULL) difference (NaN and
     * absurd values are kept in range: the cast must not overflow). */
    if (!(elapsed_seconds >= 1.0))
        return 1;
    if (elapsed_seconds > 1e15)
        return 1000000000000000L;
    return (long)floor(elapsed_seconds);
}

double stats_course_rays_per_second(uint64_t rays, double elapsed_seconds)
{
    /* The course: float(num_rays) / float(delta_time), delta_time the whole seconds it
     * prints as total time. A render under a second therefore shows the ray count. */
    return (double)((float)rays / (float)stats_course_seconds(elapsed_seconds));
}

double stats_rays_per_second(uint64_t rays, double elapsed_seconds)
{
    return elapsed_seconds > 0.0 ? (double)rays / elapsed_seconds : 0.0;
}

void stats_print(FILE *out, const StatsReport *r)
{
    long secs = stats_course_seconds(r->elapsed_seconds);
    unsigned long long rays = r->counts.nonshadow_rays + r->counts.shadow_rays;
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
    fprintf(out, "  rays per second            %0.1f\n",
            stats_course_rays_per_second(rays, r->elapsed_seconds));
    fprintf(out, "  rays per pixel             %0.1f\n", ratio((double)rays, pixels));
    fprintf(out, "  intersections per ray      %0.1f\n",
            ratio((double)r->counts.intersections, (double)rays));
    fprintf(out, "  cells traversed per ray    %0.1f\n",
            ratio((double)r->counts.cells_traversed, (double)rays));
    fprintf(out, "********************************************\n");
}
