/* Triangle (A2): Moller-Trumbore (geom.h) with precomputed edges; normal from the winding. */
#include "rt/geom.h"
#include "rt/arena.h"

#include "triangle_internal.h"

static bool triangle_intersect(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                               RenderCtx *ctx)
{
    const Triangle *tr = (const Triangle *)self;
    ctx->stats.intersections++;
    float t;
    if (!triangle_ray_t(tr->v0, tr->e1, tr->e2, ray, &t))
        return false;
    if (!(t > tmin) || !hit_accepts(hit, t, self->id))
        return false;
    hit->t = t;
    hit->normal = tr->normal;
    hit->material = self->material;
    hit->id = self->id;
    return true;
}

/* The box of the three vertices mapped to world space. */
static BBox triangle_bounds(const Object3D *self, const Mat4 *to_world)
{
    const Triangle *t = (const Triangle *)self;
    if (!to_world)
        return self->bbox;
    BBox b = bbox_empty();
    b = bbox_add_point(b, mat4_point(to_world, t->v0));
    b = bbox_add_point(b, mat4_point(to_world, t->v1));
    return bbox_add_point(b, mat4_point(to_world, t->v2));
}

const Object3DOps triangle_ops = {"Triangle", OBJ_TRIANGLE, triangle_intersect,
                                  triangle_bounds};

Object3D *triangle_new(Arena *a, Vec3 v0, Vec3 v1, Vec3 v2, const Material *m)
{
    Triangle *t = arena_alloc(a, sizeof *t);
    if (!t)
        return NULL;
    triangle_init(t, v0, v1, v2, m);
    return &t->base;
}

void triangle_vertices(const Object3D *o, Vec3 out[3])
{
    const Triangle *t = (const Triangle *)o;
    out[0] = t->v0;
    out[1] = t->v1;
    out[2] = t->v2;
}

Vec3 triangle_normal(const Object3D *o) { return ((const Triangle *)o)->normal; }
