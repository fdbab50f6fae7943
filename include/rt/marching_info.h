/* MarchingInfo: the 3D-DDA of Amanatides & Woo ("A Fast Voxel Traversal Algorithm for
 * Ray Tracing", 1987) over a uniform grid of nx*ny*nz cells (course class MarchingInfo,
 * docs/grid.md). Pure arithmetic: it knows the grid only by its box and resolution. */
#ifndef RT_MARCHING_INFO_H
#define RT_MARCHING_INFO_H

#include <stdbool.h>
#include "rt/bbox.h"
#include "rt/ray.h"
#include "rt/ray_tree.h"
#include "rt/render_ctx.h"

typedef struct MarchingInfo {
    float t;          /* entry t of the current cell (tmin when the ray started inside) */
    float t_next[3];  /* t where the ray crosses the next boundary along each axis; +inf
                         when the ray is parallel to that axis */
    int cell[3];      /* current cell (i, j, k) */
    int step[3];      /* +1 or -1 per axis (+1 for parallel axes, never used) */
    int n[3];         /* resolution */
    Vec3 normal;      /* unit normal of the face the current cell was entered through:
                         -step[a]*e_a; for a start inside the box, the face the ray would
                         have entered through along its dominant axis */
    bool started_inside; /* the current cell is the first one and the march began inside
                            the box at tmin (no face crossed) */
    /* Boundary k of axis a lies at t = base[a] + k*dt[a]: t_next is recomputed from the
     * boundary index instead of accumulated, so its error does not grow along the ray. */
    float base[3], dt[3];
    /* march_next_band: how far along the ray (in t) the band beyond each face reaches
     * (march_band_width over the direction's component; 0 when parallel), and the axes
     * held in it (bits). */
    float band_t[3];
    unsigned held;
} MarchingInfo;

/* One axis of a march's slab test (Kay & Kajiya) for a ray not parallel to that axis:
 * the t's where the ray crosses the slab's two planes lo and hi (inv = 1 / the ray's
 * direction on the axis, o its origin), the later of the entries kept in *t_enter with
 * its axis in *enter_axis, the earlier of the exits in *t_exit. Every march start (the
 * course's march_init and the grid cast's lean ones) uses it, so all of them compute
 * the same t's bit for bit. */
static inline __attribute__((always_inline)) void march_slab_axis(float lo, float hi, float o,
                                                                  float inv, int axis,
                                                                  float *t_enter, float *t_exit,
                                                                  int *enter_axis)
{
    float t0 = (lo - o) * inv, t1 = (hi - o) * inv;
    if (inv < 0.0f) {
        float tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    if (t0 > *t_enter) {
        *t_enter = t0;
        *enter_axis = axis;
    }
    if (t1 < *t_exit)
        *t_exit = t1;
}

/* Starts a march of ray over the grid whose cells tile box (n[a] cells per axis; every
 * axis of box must have max > min). pad (>= 0, per axis, world units) widens only the
 * slab test that decides whether and where the ray meets the grid, so rays meeting the
 * box within pad of its border still visit the border cells (the grid's insertion pads
 * cells the same way). Returns false when the ray misses the (padded) box, the box lies
 * entirely at t < tmin, or the direction is zero. On success the first cell is current;
 * when ctx is non-NULL it is counted in ctx->stats.cells_traversed and recorded in
 * ctx->tree when that is non-NULL. */
bool march_init(MarchingInfo *mi, const BBox *box, const int n[3], const float pad[3],
                const Ray *ray, float tmin, RenderCtx *ctx);

/* The width of the band beyond the faces of box that march_next_band (and the grid's own
 * march) still walks on axis a: where a triangle test can accept a point outside the
 * box (its edge tolerance, RT_TRI_EDGE_TOL and RT_TRI_FAR_TOL of rt/geom.h, times the
 * box's sides, which bound every edge, plus rounding), but no more than the cells'
 * padding pad, which holds such triangles in the border cells. */
float march_band_width(const BBox *box, float pad);

/* Cell index of coordinate x on an axis whose cells start at lo and measure
 * 1/inv_size, clamped to [0, n-1] in float first so a far or NaN coordinate cannot
 * overflow the int conversion. (The march and the grid's ray packets.) */
static inline int march_cell_of(float x, float lo, float inv_size, int n)
{
    float f = (x - lo) * inv_size;
    if (!(f >= 0.0f))
        return 0;
    if (f >= (float)n)
        return n - 1;
    int c = (int)f;
    return c < n ? c : n - 1;
}

/* Internal helpers of march_init/march_next (inline: the march is the hot loop). */
static inline Vec3 march_axis_normal(int axis, int sign)
{
    Vec3 n = {0.0f, 0.0f, 0.0f};
    float s = (float)sign;
    if (axis == 0)
        n.x = s;
    else if (axis == 1)
        n.y = s;
    else
        n.z = s;
    return n;
}

/* Counts the current cell (A6: one "cell traversed" per visited cell, the first one
 * included) and records it for the GUI's ray tree. */
static inline void march_enter_cell(const MarchingInfo *mi, RenderCtx *ctx)
{
    if (!ctx)
        return;
    ctx->stats.cells_traversed++;
    if (ctx->tree) {
        Vec3 zero = {0.0f, 0.0f, 0.0f};
        ray_tree_add_cell(ctx->tree, mi->cell[0], mi->cell[1], mi->cell[2],
                          mi->started_inside ? zero : mi->normal);
    }
}

/* Moves to the next cell along the ray (the axis with the smallest t_next; ties go to x,
 * then y, then z). Returns false when the ray leaves the grid. A cell entered is counted
 * and recorded like the first one (every visited cell counts once in -stats' cells
 * traversed).
 * With band (a constant at each call: march_next_band), a step that would leave the
 * grid along an axis holds that axis at its last cell until the ray leaves the band
 * beyond that face (band_t), and the march goes on along the other axes (the grid's
 * single-ray queries: the triangle test accepts points a little outside a triangle, and
 * a ray running along a face of the box just outside it can hit one in a cell it
 * reaches only after crossing the face; docs/grid.md, Exactness). The cells entered so
 * are neither counted nor recorded: the course's march ends at the box. */
static inline bool march_step(MarchingInfo *mi, RenderCtx *ctx, bool band)
{
    for (;;) {
        int a = 0;
        if (mi->t_next[1] < mi->t_next[a])
            a = 1;
        if (mi->t_next[2] < mi->t_next[a])
            a = 2;
        if (!(mi->t_next[a] < INFINITY))
            return false; /* parallel to every remaining axis: nothing more to cross */
        int c = mi->cell[a] + mi->step[a];
        if (c < 0 || c >= mi->n[a]) {
            if (!band || (mi->held & (1u << a)))
                return false; /* out of the grid (and of the band) */
            mi->held |= 1u << a;
            mi->t_next[a] += mi->band_t[a]; /* from the face to the band's side */
            continue;
        }
        mi->cell[a] = c;
        mi->t = mi->t_next[a];
        int k = mi->step[a] > 0 ? c + 1 : c;
        mi->t_next[a] = mi->base[a] + (float)k * mi->dt[a];
        mi->normal = march_axis_normal(a, -mi->step[a]);
        mi->started_inside = false;
        march_enter_cell(mi, band && mi->held ? NULL : ctx);
        return true;
    }
}

static inline bool march_next(MarchingInfo *mi, RenderCtx *ctx)
{
    return march_step(mi, ctx, false);
}

static inline bool march_next_band(MarchingInfo *mi, RenderCtx *ctx)
{
    return march_step(mi, ctx, true);
}

/* t at which the ray leaves the current cell. */
static inline float march_exit_t(const MarchingInfo *mi)
{
    float a = mi->t_next[0] < mi->t_next[1] ? mi->t_next[0] : mi->t_next[1];
    return a < mi->t_next[2] ? a : mi->t_next[2];
}

#endif
