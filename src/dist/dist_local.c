/* The single-process side of rt/dist.h, linked into ./raytracer: no job, one rank. */
#include "rt/dist.h"

#include <string.h>

const char dist_program_name[] = "raytracer";

bool dist_init(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    return true;
}

int dist_finish(int status) { return status; }
bool dist_is_root(void) { return true; }
int dist_size(void) { return 1; }
bool dist_stdout_forwarded(void) { return false; }
int dist_launcher_rank(void) { return -1; }
const char *dist_describe(void)
{
    return "not in this binary (make mpi builds ./raytracer-mpi, which has it)";
}

Scene *dist_scene_load(const char *path, SetupCache *cache, bool identify, Diag *diag)
{
    return scene_load_with(path, NULL, cache, identify, diag);
}

bool dist_render(const DistJob *job, RtStats *stats_out, volatile int *cancel)
{
    RtStats st;
    memset(&st, 0, sizeof st);
    bool ok = job->render(job->user, job->x0, job->y0, job->w, job->h, job->color, job->depth,
                          job->normals, &st, cancel);
    if (stats_out)
        *stats_out = st;
    return ok;
}

bool dist_root_ok(bool ok) { return ok; }

void dist_max(double *v, int n)
{
    (void)v;
    (void)n;
}

void dist_report(FILE *out) { (void)out; }
