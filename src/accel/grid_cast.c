/* RayCastFast (semantics.md 7.5): nearest hit and shadow queries through the grid's
 * cells, front to back, with marking (mailboxing) so a primitive spanning many cells is
 * intersected at most once per ray. Reads the grid only; per-ray state is in ctx. */
#include "grid_internal.h"

#include <string.h>

#include "rt/geom.h"

static inline bool test_prim(const GridPrim *p, const Ray *ray, Hit *hit, float tmin,
                             RenderCtx *ctx)
{
    return p->path ? xform_path_intersect(p->path, p->obj, ray, hit, tmin, ctx)
                   : obj_intersect(p->obj, ray, hit, tmin, ctx);
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

bool grid_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin, RenderCtx *ctx)
{
    bool found = false;
    /* 1. Infinite primitives first: their hit bounds the march (early rejection). */
    for (uint32_t u = 0; u < g->num_unbounded; u++)
        found |= test_prim(&g->unbounded[u], ray, hit, tmin, ctx);

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
            uint32_t p = items[e];
            if (should_test(g, mb, stamp, p, ctx))
                found |= test_prim(&g->prims[p], ray, hit, tmin, ctx);
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
            uint32_t p = items[e];
            if (should_test(g, mb, stamp, p, ctx) && test_prim(&g->prims[p], ray, &h, tmin, ctx))
                return true; /* the first occluder settles it */
        }
    } while (march_next(&mi, ctx));
    return false;
}
