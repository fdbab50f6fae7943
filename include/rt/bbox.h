/* Axis-aligned bounding boxes (A5). An empty box has min > max. */
#ifndef RT_BBOX_H
#define RT_BBOX_H

#include <stdbool.h>
#include "rt/matrix.h"

typedef struct BBox {
    Vec3 min, max;
} BBox;

BBox bbox_empty(void);                       /* min = +inf, max = -inf */
bool bbox_is_empty(const BBox *b);
BBox bbox_union(BBox a, BBox b);
BBox bbox_add_point(BBox b, Vec3 p);
/* AABB of the 8 corners of b mapped by m (the course's transformed bounding box). Empty
 * stays empty. */
BBox bbox_transform(const BBox *b, const Mat4 *m);
/* Slab test: the [t0, t1] interval of the ray inside the closed box; false on a miss. */
bool bbox_ray_interval(const BBox *b, Vec3 origin, Vec3 dir, float *t0, float *t1);

#endif
