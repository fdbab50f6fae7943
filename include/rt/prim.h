/* The flat primitive table: the scene tree flattened once (scene -> table) into its
 * leaves, each with its shape, the Transforms above it (interned, with their composed
 * matrices), its world-space box and its id. Every accelerator is built from it
 * (rt/accel.h); nothing in it changes after prim_table_build. */
#ifndef RT_PRIM_H
#define RT_PRIM_H

#include <stdbool.h>
#include <stdint.h>
#include "rt/geom.h"

typedef struct Scene Scene;

/* A chain of Transforms shared by the leaves below it, with the composed matrices the
 * accelerators' build geometry uses. Intersection goes through path step by step
 * (transform_path_intersect), so hits are bit-identical to the tree walk. */
typedef struct PrimXform {
    XformPath path;   /* outermost first; depth >= 1 */
    Mat4 m;           /* object -> world: M1 * M2 * ... * Mk */
    Mat4 inv;         /* world -> object: Mk^-1 * ... * M1^-1 */
} PrimXform;

/* One leaf of the scene. */
typedef struct Prim {
    const Object3D *obj;   /* the leaf (Sphere, Triangle, Plane, ...) */
    const PrimXform *xf;   /* the Transforms above it; NULL when there are none */
    BBox bounds;           /* world space (obj->ops->bounds); empty when unbounded */
    uint32_t id;           /* obj->id: depth-first index, the hit tie-breaker */
    bool bounded;          /* false for Plane: no box, tested for every ray; false too
                              for a leaf whose box is out of PRIM_MAX_COORD (kept out) */
} Prim;

/* Leaves whose world box is not finite or reaches past +-PRIM_MAX_COORD on some axis (a
 * sphere of radius 3e38, a triangle at +-3e38) are kept out of every accelerator's
 * cells: they are tested for every ray, like planes. Cells over such a box would have
 * infinite or meaningless sizes, while the leaf's own intersect copes with it; 1e30
 * leaves the accelerators' float arithmetic (box sides, pads, cell sizes) far from
 * overflow. Images are the same with and without an accelerator either way. */
#define PRIM_MAX_COORD 1e30f

typedef struct PrimTable {
    Prim *prims;             /* every leaf in depth-first order */
    uint32_t num_prims;
    uint32_t num_bounded;    /* how many of them are bounded (kept-out leaves not) */
    BBox scene_bounds;       /* the scene's box (the root's, built up the tree as the
                                course does: a Transform boxes its child's box); when
                                leaves were kept out, the box of the bounded ones */
    uint32_t num_kept_out;   /* bounded leaves kept out for their huge boxes */
    uint32_t first_kept_out; /* index in prims of the first of them */
    PrimXform **xforms;      /* the interned chains (owned) */
    uint32_t num_xforms, cap_xforms;
} PrimTable;

/* Flattens scene->root (NULL root: an empty table). False when out of memory, or when a
 * stop was requested (par_stop_requested, rt/par.h: looked at between chunks of a big
 * group's leaves); the table is then empty and needs no prim_table_free. */
bool prim_table_build(PrimTable *t, const Scene *scene);
void prim_table_free(PrimTable *t);

/* The leaf's intersect, through its Transforms when it has any (the tree walk's
 * arithmetic). */
static inline bool prim_intersect(const Object3D *obj, const PrimXform *xf, const Ray *ray,
                                  Hit *hit, float tmin, RenderCtx *ctx)
{
    return xf ? transform_path_intersect(&xf->path, obj, ray, hit, tmin, ctx)
              : obj_intersect(obj, ray, hit, tmin, ctx);
}

/* The leaf's occluded (tmin < t < tmax), through its Transforms when it has any. */
static inline bool prim_occluded(const Object3D *obj, const PrimXform *xf, const Ray *ray,
                                 float tmin, float tmax, RenderCtx *ctx)
{
    return xf ? transform_path_occluded(&xf->path, obj, ray, tmin, tmax, ctx)
              : obj_occluded(obj, ray, tmin, tmax, ctx);
}

#endif
