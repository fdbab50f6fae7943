/* Plane (A2): points P with P.n = offset; infinite, so never inside the grid. */
#include "rt/geom.h"
#include "rt/arena.h"

typedef struct Plane {
    Object3D base;
    Vec3 normal;       /* as given */
    Vec3 unit_normal;
    float offset;
} Plane;

static bool plane_intersect(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                            RenderCtx *ctx)
{
    const Plane *p = (const Plane *)self;
    ctx->stats.intersections++;
    float denom = v3_dot(p->normal, ray->dir);
    if (denom == 0.0f)
        return false;
    float t = (p->offset - v3_dot(p->normal, ray->origin)) / denom;
    if (!(t > tmin) || !hit_accepts(hit, t, self->id))
        return false;
    return obj_record_hit(self, hit, t, p->unit_normal);
}

static bool plane_occluded(const Object3D *self, const Ray *ray, float tmin, float tmax,
                           RenderCtx *ctx)
{
    const Plane *p = (const Plane *)self;
    ctx->stats.intersections++;
    float denom = v3_dot(p->normal, ray->dir);
    if (denom == 0.0f)
        return false;
    float t = (p->offset - v3_dot(p->normal, ray->origin)) / denom;
    return t > tmin && t < tmax;
}

/* Infinite: no box (accelerators test it for every ray). */
static BBox plane_bounds(const Object3D *self, const Mat4 *to_world)
{
    (void)self;
    (void)to_world;
    return bbox_empty();
}

/* Unbounded: never binned, so no occupancy ops. */
static const Object3DOps plane_ops = {.type_name = "Plane", .kind = OBJ_PLANE,
                                      .intersect = plane_intersect,
                                      .occluded = plane_occluded, .bounds = plane_bounds};

Object3D *plane_new(Arena *a, Vec3 normal, float offset, const Material *m)
{
    Plane *p = arena_alloc(a, sizeof *p);
    if (!p)
        return NULL;
    p->base.ops = &plane_ops;
    p->base.material = m;
    p->base.bounded = false;
    p->base.bbox = bbox_empty();
    p->base.id = RT_NO_ID;
    p->normal = normal;
    p->unit_normal = v3_normalize_wide(normal);
    p->offset = offset;
    return &p->base;
}

Vec3 plane_normal(const Object3D *o) { return ((const Plane *)o)->normal; }
float plane_offset(const Object3D *o) { return ((const Plane *)o)->offset; }
Vec3 plane_unit_normal(const Object3D *o) { return ((const Plane *)o)->unit_normal; }
