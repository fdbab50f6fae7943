/* Object3D: the polymorphic scene object (course class Object3D) as a C struct with a
 * static const ops table per concrete type (SQLite's vtable shape; docs/architecture.md). */
#ifndef RT_OBJECT3D_H
#define RT_OBJECT3D_H

#include <stdbool.h>
#include <stdint.h>
#include "rt/bbox.h"
#include "rt/ray.h"
#include "rt/render_ctx.h"

typedef struct Arena Arena;
typedef struct PrimXform PrimXform;

/* What a type is, for the few places that tell types apart instead of calling the ops:
 * the walks of the tree (Group and Transform: prim_table.c, group.c's ids, the preview),
 * and leaves some code takes by kind for speed or drawing (the grid's triangle and sphere
 * records and packed triangles, the packets' planes, the GL preview). A new leaf type
 * that needs none of them is OBJ_OTHER: everything then goes through its ops
 * (docs/architecture.md, "A new primitive"). */
typedef enum ObjKind {
    OBJ_GROUP,
    OBJ_SPHERE,
    OBJ_PLANE,
    OBJ_TRIANGLE,
    OBJ_TRANSFORM,
    OBJ_OTHER
} ObjKind;

/* Maximum nesting of Groups/Transforms the parser accepts (and the grid flattens). */
enum { RT_MAX_NESTING = 64 };

/* The chain of Transform objects above a primitive, outermost first (the flat primitive
 * table, rt/prim.h). */
typedef struct XformPath {
    const Object3D *xf[RT_MAX_NESTING];
    int depth;
} XformPath;

typedef struct Object3DOps {
    const char *type_name;   /* "Sphere", for diagnostics */
    ObjKind kind;
    /* Nearest hit with tmin < t that hit_accepts(hit, t, id); on success overwrites
     * hit->t, normal, material, id and returns true. Leaves count one intersection in
     * ctx->stats; groups and transforms do not count. Never writes to self. */
    bool (*intersect)(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                      RenderCtx *ctx);
    /* Shadow rays: is anything of self hit with tmin < t < tmax? Exactly intersect's
     * answer for a hit holding (t = tmax, id 0), which hit_accepts lets only t < tmax
     * beat, from the same arithmetic, without making the normal. A leaf counts one
     * intersection, as intersect does; a Group stops at its first occluder. Every type
     * has it (called for every shadow ray, it is not checked for NULL); a type with
     * nothing cheaper can use obj_occluded_by_intersect. */
    bool (*occluded)(const Object3D *self, const Ray *ray, float tmin, float tmax,
                     RenderCtx *ctx);
    /* Leaves: the world-space box of the leaf placed by to_world (object -> world; NULL:
     * the identity); empty when unbounded. Groups and transforms: NULL (the primitive
     * table walks them, rt/prim.h). */
    BBox (*bounds)(const Object3D *self, const Mat4 *to_world);
    /* Cell occupancy, for accelerators that bin leaves into boxes (the grid's marching
     * sets); xf: the Transforms above the leaf (NULL: none). Both may be NULL: then the
     * leaf occupies every box its bounds meet. cell_bounds: a tight world box, in
     * double, holding every point intersect can return. overlaps_box: whether the
     * surface may cross the closed world box [lo, hi] (with rounding slack: never false
     * for a box holding a point intersect can return). */
    void (*cell_bounds)(const Object3D *self, const PrimXform *xf, double lo[3],
                        double hi[3]);
    bool (*overlaps_box)(const Object3D *self, const PrimXform *xf, const double lo[3],
                         const double hi[3]);
} Object3DOps;

/* A leaf's constructor (sphere_new) allocates it from the arena and sets every field:
 * ops, material, bbox and bounded (what the parent Group's and Transform's boxes are made
 * from), and id = RT_NO_ID (group_assign_ids numbers the leaves once the tree is whole). */
struct Object3D {
    const Object3DOps *ops;      /* always the first member */
    const Material *material;    /* leaves only; borrowed, the Scene owns it */
    BBox bbox;                   /* in the space of this object's parent (before any enclosing Transform) */
    bool bounded;                /* false for Plane (and groups of planes only) */
    uint32_t id;                 /* leaves: depth-first index 0..n-1; RT_NO_ID otherwise */
};

static inline bool obj_intersect(const Object3D *o, const Ray *r, Hit *h, float tmin,
                                 RenderCtx *ctx)
{
    return o->ops->intersect(o, r, h, tmin, ctx);
}
/* A leaf's hit at t with normal n: fills hit (t, normal, the leaf's material and id)
 * and returns true, the last step of every leaf's intersect. */
static inline bool obj_record_hit(const Object3D *o, Hit *hit, float t, Vec3 n)
{
    hit->t = t;
    hit->normal = n;
    hit->material = o->material;
    hit->id = o->id;
    return true;
}
static inline bool obj_occluded(const Object3D *o, const Ray *r, float tmin, float tmax,
                                RenderCtx *ctx)
{
    return o->ops->occluded(o, r, tmin, tmax, ctx);
}
/* An occluded op made from the type's own intersect (a (tmax, id 0) hit). */
static inline bool obj_occluded_by_intersect(const Object3D *self, const Ray *r, float tmin,
                                             float tmax, RenderCtx *ctx)
{
    Hit h = hit_none();
    h.t = tmax;
    h.id = 0;
    return self->ops->intersect(self, r, &h, tmin, ctx);
}
static inline ObjKind obj_kind(const Object3D *o) { return o->ops->kind; }

#endif
