/* -visualize_grid: the first occupied cell along a ray as a hit (t = the cell's entry,
 * normal = the face entered), coloured by the course palette of its entry count. */
#include "grid_internal.h"

#include <pthread.h>
#include <stdlib.h>

#include "rt/arena.h"
#include "rt/material.h"

/* The reference palette recovered from the official images: index = count (1..17,
 * 17 standing for 17 or more). */
static const float palette_rgb[17][3] = {
    {1.0f, 1.0f, 1.0f}, {1.0f, 0.0f, 1.0f}, {0.7f, 0.0f, 1.0f}, {0.3f, 0.0f, 1.0f},
    {0.0f, 0.0f, 1.0f}, {0.0f, 0.3f, 1.0f}, {0.0f, 0.7f, 1.0f}, {0.0f, 1.0f, 1.0f},
    {0.0f, 1.0f, 0.7f}, {0.0f, 1.0f, 0.3f}, {0.0f, 1.0f, 0.0f}, {0.3f, 1.0f, 0.0f},
    {0.7f, 1.0f, 0.0f}, {1.0f, 1.0f, 0.0f}, {1.0f, 0.7f, 0.0f}, {1.0f, 0.3f, 0.0f},
    {1.0f, 0.0f, 0.0f},
};

/* The materials are made once, by whichever thread asks first, and freed at exit (a
 * process-lifetime table). */
static pthread_once_t palette_once = PTHREAD_ONCE_INIT;
static Arena palette_arena;
static const Material *palette[17];

/* At exit: valgrind and leak checkers then see no block left reachable. */
static void palette_release(void)
{
    for (int i = 0; i < 17; i++)
        palette[i] = NULL;
    arena_free(&palette_arena);
}

static void palette_init(void)
{
    arena_init(&palette_arena);
    atexit(palette_release);
    for (int i = 0; i < 17; i++) {
        PhongParams p = phong_defaults();
        p.diffuse = v3(palette_rgb[i][0], palette_rgb[i][1], palette_rgb[i][2]);
        p.specular = v3(0.0f, 0.0f, 0.0f);
        p.exponent = 1.0f;
        palette[i] = phong_new(&palette_arena, &p);
    }
}

const Material *grid_palette_material(int count)
{
    pthread_once(&palette_once, palette_init);
    int i = count < 1 ? 0 : count > 17 ? 16 : count - 1;
    return palette[i];
}

bool grid_visualize_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin,
                              RenderCtx *ctx)
{
    /* The visualisation draws the course cells exactly: no padding. */
    static const float no_pad[3] = {0.0f, 0.0f, 0.0f};
    const uint32_t *course = grid_course_counts(g);
    MarchingInfo mi;
    if (!course || !march_init(&mi, &g->box, g->n, no_pad, ray, tmin, ctx))
        return false;
    do {
        uint32_t count = course[grid_cell_index(g, mi.cell[0], mi.cell[1], mi.cell[2])];
        if (count > 0) {
            if (!(mi.t < hit->t))
                return false;
            const Material *m = grid_palette_material(count > 17 ? 17 : (int)count);
            if (!m)
                return false;
            hit->t = mi.t;
            hit->normal = mi.normal;
            hit->material = m;
            hit->id = RT_NO_ID;
            return true;
        }
    } while (march_next(&mi, ctx));
    return false;
}

bool grid_visualize_occluded(const Grid *g, const Ray *ray, float tmin, float tmax,
                             RenderCtx *ctx)
{
    Hit h = hit_none();
    return grid_visualize_intersect(g, ray, &h, tmin, ctx) && h.t < tmax;
}
