/* The accelerator "none" (the course's RayCast): every primitive of the table for every
 * ray, in depth-first order, as the tree walk over the scene's Group does. */
#include "rt/accel.h"

/* Runs of leaves under the same Transforms take the ray into object space once, as the
 * tree walk does at its Transform node, and the winning normal back once: the same
 * arithmetic in the same order, so t and normal are the tree walk's to the bit. */
static bool none_intersect(const void *self, const Ray *ray, Hit *hit, float tmin,
                           RenderCtx *ctx)
{
    const PrimTable *t = self;
    const Prim *p = t->prims, *end = t->prims + t->num_prims;
    bool found = false;
    while (p < end) {
        const PrimXform *xf = p->xf;
        if (!xf) {
            found |= obj_intersect(p->obj, ray, hit, tmin, ctx);
            p++;
            continue;
        }
        float tmin_local = tmin;
        Ray local = transform_path_to_object(&xf->path, ray, &tmin_local);
        bool run = false;
        for (; p < end && p->xf == xf; p++)
            run |= obj_intersect(p->obj, &local, hit, tmin_local, ctx);
        if (run)
            hit->normal = transform_path_normal_to_world(&xf->path, hit->normal);
        found |= run;
    }
    return found;
}

/* The course's shadow loop tests every primitive (no early exit), and the statistics
 * follow it. Hits at t >= tmax do not count: the search starts at t = tmax with id 0,
 * which hit_accepts never lets an equal t beat. */
static bool none_occluded(const void *self, const Ray *ray, float tmin, float tmax,
                          RenderCtx *ctx)
{
    Hit h = hit_none();
    h.t = tmax;
    h.id = 0;
    return none_intersect(self, ray, &h, tmin, ctx);
}

static void *none_create(const PrimTable *t, const AccelConfig *cfg, Diag *diag)
{
    (void)cfg;
    (void)diag;
    return (void *)t; /* the table is all it reads */
}

const AccelOps accel_none_ops = {
    .name = "none",
    .summary = "no acceleration: every ray tests every primitive",
    .create = none_create,
    .intersect = none_intersect,
    .occluded = none_occluded,
};
