/* RayCastFast (semantics.md 7.5): nearest hit and shadow queries through the grid's
 * cells, front to back, with marking (mailboxing) so a primitive spanning many cells is
 * intersected at most once per ray. Reads the grid only; per-ray state is in ctx. */
#include "grid_internal.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "rt/geom.h"

static inline bool test_prim(const GridPrim *p, const Ray *ray, Hit *hit, float tmin,
                             RenderCtx *ctx)
{
    return p->path ? xform_path_intersect(p->path, p->obj, ray, hit, tmin, ctx)
                   : obj_intersect(p->obj, ray, hit, tmin, ctx);
}

/* Cell entry e: a packed triangle inline (grid_pack.c), anything else through its ops.
 * Both do exactly what Triangle::intersect does, so the hit is the same to the bit. */
static inline __attribute__((always_inline)) bool test_entry(const Grid *g, uint32_t e, const Ray *ray, Hit *hit, float tmin,
                              RenderCtx *ctx)
{
    uint32_t p = GRID_ITEM_INDEX(e);
    if (!(e & GRID_ITEM_TRI))
        return test_prim(&g->prims[p], ray, hit, tmin, ctx);
    const PackedTri *pt = &g->tri[p];
    ctx->stats.intersections++;
    float t;
    if (!triangle_ray_t(pt->v0, pt->e1, pt->e2, ray, &t) || !(t > tmin) ||
        !hit_accepts(hit, t, pt->id))
        return false;
    const Object3D *o = g->prims[p].obj;
    hit->t = t;
    hit->normal = triangle_normal(o);
    hit->material = o->material;
    hit->id = pt->id;
    return true;
}

/* A fresh stamp for this ray, or 0 when there is no usable mailbox. Stamps wrap after
 * 2^32 - 1 rays: then every slot is cleared, so no stale stamp can match. */
static inline uint32_t begin_ray(const Grid *g, RenderCtx *ctx)
{
    if (!ctx->mailbox || ctx->num_mailbox < g->num_prims || g->num_prims == 0)
        return 0;
    uint32_t s = ++ctx->ray_stamp;
    if (s == 0) {
        memset(ctx->mailbox, 0, (size_t)ctx->num_mailbox * sizeof *ctx->mailbox);
        s = ctx->ray_stamp = 1;
    }
    return s;
}

/* Whether entry p must be tested now. With marking, an entry already stamped for this
 * ray is skipped: its earlier test already found its nearest hit beyond tmin, which a
 * second test could only repeat. Without marking, repeats are tested and counted. */
static inline bool should_test(const Grid *g, uint32_t *mb, uint32_t stamp, uint32_t p,
                               RenderCtx *ctx)
{
    if (!mb)
        return true;
    if (mb[p] == stamp) {
        if (g->marking) {
            ctx->stats.mailbox_skips++;
            return false;
        }
        ctx->stats.repeat_tests++;
        return true;
    }
    mb[p] = stamp;
    return true;
}

/* Float rounding of the march grows with the size of the coordinates it works with:
 * o + t*d and the border crossings (lo - o)/d carry an error of a few ulps of
 * |o| + |box|. The cells are padded against a fixed margin (g->pad), so a ray whose
 * origin is so far away that this error exceeds the margin (thousands of box sizes,
 * e.g. a secondary ray leaving a distant plane hit) may be walked through the wrong
 * cells. Such rays test every bounded primitive instead: rare, slow, exact. */
static float march_error(const Grid *g, const Ray *ray)
{
    float m = fabsf(ray->origin.x);
    if (fabsf(ray->origin.y) > m)
        m = fabsf(ray->origin.y);
    if (fabsf(ray->origin.z) > m)
        m = fabsf(ray->origin.z);
    return 4.0f * FLT_EPSILON * (m + g->box_mag);
}

/* True when the march cannot be trusted for this ray AND the ray passes near enough
 * to the box to hit something in it (a far ray that misses the widened box is left to
 * march_init, which rejects it). */
static bool ray_too_far(const Grid *g, const Ray *ray, float tmin)
{
    float err = march_error(g, ray);
    if (err < g->min_pad)
        return false;
    if (!isfinite(err))
        return true;
    BBox wide = g->box;
    wide.min = v3_sub(wide.min, v3(g->pad[0] + err, g->pad[1] + err, g->pad[2] + err));
    wide.max = v3_add(wide.max, v3(g->pad[0] + err, g->pad[1] + err, g->pad[2] + err));
    float t0, t1;
    return bbox_ray_interval(&wide, ray->origin, ray->dir, &t0, &t1) && t1 >= tmin;
}

static bool brute_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin,
                            RenderCtx *ctx)
{
    bool found = false;
    for (uint32_t p = 0; p < g->num_prims; p++)
        found |= test_prim(&g->prims[p], ray, hit, tmin, ctx);
    return found;
}

bool grid_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin, RenderCtx *ctx)
{
    bool found = false;
    /* 1. Infinite primitives first: their hit bounds the march (early rejection). */
    for (uint32_t u = 0; u < g->num_unbounded; u++)
        found |= test_prim(&g->unbounded[u], ray, hit, tmin, ctx);

    if (ray_too_far(g, ray, tmin))
        return brute_intersect(g, ray, hit, tmin, ctx) || found;
    MarchingInfo mi;
    if (!march_init(&mi, &g->box, g->n, g->pad, ray, tmin, ctx))
        return found;
    uint32_t stamp = begin_ray(g, ctx);
    uint32_t *mb = stamp ? ctx->mailbox : NULL;
    const uint32_t *start = g->cell_start, *items = g->cell_items;
    do {
        /* 4. The cell starts beyond the best hit: nothing in it or later is nearer. */
        if (mi.t > hit->t)
            break;
        uint32_t c = grid_cell_index(g, mi.cell[0], mi.cell[1], mi.cell[2]);
        for (uint32_t e = start[c], end = start[c + 1]; e < end; e++) {
            uint32_t item = items[e];
            if (should_test(g, mb, stamp, GRID_ITEM_INDEX(item), ctx))
                found |= test_entry(g, item, ray, hit, tmin, ctx);
        }
        /* 3. A hit inside this cell or an earlier one is final: every primitive that
         * could be hit sooner lies in a cell already tested (cells are padded, so this
         * holds up to float rounding at borders). A hit beyond it stays a candidate. */
        if (hit->t <= march_exit_t(&mi))
            break;
    } while (march_next(&mi, ctx));
    return found;
}

bool grid_occluded(const Grid *g, const Ray *ray, float tmin, float tmax, RenderCtx *ctx)
{
    /* hit_accepts with t = tmax and id 0 takes exactly the hits with t < tmax. */
    Hit h = hit_none();
    h.t = tmax;
    h.id = 0;
    for (uint32_t u = 0; u < g->num_unbounded; u++)
        if (test_prim(&g->unbounded[u], ray, &h, tmin, ctx))
            return true;

    if (ray_too_far(g, ray, tmin))
        return brute_intersect(g, ray, &h, tmin, ctx);
    MarchingInfo mi;
    if (!march_init(&mi, &g->box, g->n, g->pad, ray, tmin, ctx))
        return false;
    uint32_t stamp = begin_ray(g, ctx);
    uint32_t *mb = stamp ? ctx->mailbox : NULL;
    const uint32_t *start = g->cell_start, *items = g->cell_items;
    do {
        if (mi.t > tmax)
            break;
        uint32_t c = grid_cell_index(g, mi.cell[0], mi.cell[1], mi.cell[2]);
        for (uint32_t e = start[c], end = start[c + 1]; e < end; e++) {
            uint32_t item = items[e];
            if (should_test(g, mb, stamp, GRID_ITEM_INDEX(item), ctx) &&
                test_entry(g, item, ray, &h, tmin, ctx))
                return true; /* the first occluder settles it */
        }
    } while (march_next(&mi, ctx));
    return false;
}
