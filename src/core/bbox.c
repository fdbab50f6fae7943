/* Axis-aligned bounding boxes (A5 BoundingBox). */
#include "rt/bbox.h"

#include <math.h>

BBox bbox_empty(void)
{
    BBox b = {{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}};
    return b;
}

bool bbox_is_empty(const BBox *b)
{
    return !(b->min.x <= b->max.x && b->min.y <= b->max.y && b->min.z <= b->max.z);
}

BBox bbox_union(BBox a, BBox b)
{
    BBox r = {v3_min(a.min, b.min), v3_max(a.max, b.max)};
    return r;
}

BBox bbox_add_point(BBox b, Vec3 p)
{
    BBox r = {v3_min(b.min, p), v3_max(b.max, p)};
    return r;
}

BBox bbox_transform(const BBox *b, const Mat4 *m)
{
    if (bbox_is_empty(b))
        return *b;
    BBox r = bbox_empty();
    for (int i = 0; i < 8; i++) {
        Vec3 c = v3((i & 1) ? b->max.x : b->min.x, (i & 2) ? b->max.y : b->min.y,
                    (i & 4) ? b->max.z : b->min.z);
        r = bbox_add_point(r, mat4_point(m, c));
    }
    return r;
}

bool bbox_ray_interval(const BBox *b, Vec3 o, Vec3 d, float *t0, float *t1)
{
    float lo = -INFINITY, hi = INFINITY;
    for (int a = 0; a < 3; a++) {
        float oa = v3_comp(o, a), da = v3_comp(d, a);
        float mn = v3_comp(b->min, a), mx = v3_comp(b->max, a);
        if (da == 0.0f) {
            if (oa < mn || oa > mx)
                return false;
            continue;
        }
        float inv = 1.0f / da;
        float ta = (mn - oa) * inv, tb = (mx - oa) * inv;
        if (ta > tb) {
            float t = ta;
            ta = tb;
            tb = t;
        }
        if (ta > lo)
            lo = ta;
        if (tb < hi)
            hi = tb;
    }
    if (lo > hi)
        return false;
    *t0 = lo;
    *t1 = hi;
    return true;
}
