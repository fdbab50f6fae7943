/* Private to src/geom: the Triangle layout, shared by triangle.c (one triangle) and
 * mesh.c (a whole mesh in one block), so both build the same objects. */
#ifndef RT_GEOM_TRIANGLE_INTERNAL_H
#define RT_GEOM_TRIANGLE_INTERNAL_H

#include "rt/object3d.h"

typedef struct Triangle {
    Object3D base;
    Vec3 v0, e1, e2;   /* v1 = v0 + e1, v2 = v0 + e2 */
    Vec3 normal;       /* normalize(e1 x e2) */
    Vec3 v1, v2;
} Triangle;

/* The ops table of every Triangle (defined in triangle.c). */
extern const Object3DOps triangle_ops;

#endif
