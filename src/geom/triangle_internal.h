/* Private to src/geom: the Triangle layout, shared by triangle.c (one triangle) and
 * mesh.c (a whole mesh in one block), so both build the same objects. */
#ifndef RT_GEOM_TRIANGLE_INTERNAL_H
#define RT_GEOM_TRIANGLE_INTERNAL_H

#include "rt/object3d.h"

typedef struct Triangle {
    Object3D base;
    Vec3 v0, e1, e2;   /* v1 = v0 + e1, v2 = v0 + e2 */
    Vec3 normal;       /* normalize(e1 x e2) (v3_unit_cross) */
    Vec3 v1, v2;
} Triangle;

/* The ops table of every Triangle (defined in triangle.c). */
extern const Object3DOps triangle_ops;

/* The one Triangle constructor, on memory the caller provides (triangle_new: one arena
 * block; mesh.c: a whole mesh in one block). Writes every field but the padding. */
static inline void triangle_init(Triangle *t, Vec3 v0, Vec3 v1, Vec3 v2, const Material *m)
{
    t->base.ops = &triangle_ops;
    t->base.material = m;
    t->base.bounded = true;
    t->base.id = RT_NO_ID;
    /* Folded from the empty box as bbox_add_point folds (the same NaN and -0 rules). */
    BBox b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    b.min = v3_min(v3_min(v3_min(b.min, v0), v1), v2);
    b.max = v3_max(v3_max(v3_max(b.max, v0), v1), v2);
    t->base.bbox = b;
    t->v0 = v0;
    t->v1 = v1;
    t->v2 = v2;
    t->e1 = v3_sub(v1, v0);
    t->e2 = v3_sub(v2, v0);
    t->normal = v3_unit_cross(t->e1, t->e2);
}

#endif
