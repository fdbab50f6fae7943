/* Sphere (A1): |o + t d - c|^2 = r^2, solved for any (non-unit) direction. */
#include "rt/geom.h"
#include "rt/arena.h"
#include "rt/grid.h"

typedef struct Sphere {
    Object3D base;
    Vec3 center;
    float radius;
} Sphere;

static bool sphere_intersect(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                             RenderCtx *ctx)
{
    const Sphere *s = (const Sphere *)self;
    ctx->stats.intersections++;
    Vec3 oc = v3_sub(ray->origin, s->center);
    float a = v3_dot(ray->dir, ray->dir);
    float b = 2.0f * v3_dot(ray->dir, oc);
    float c = v3_dot(oc, oc) - s->radius * s->radius;
    float disc = b * b - 4.0f * a * c;
    if (disc < 0.0f || a == 0.0f)
        return false;
    float sq = sqrtf(disc);
    /* The nearer root when it lies past tmin, else the farther one: a camera inside
     * the sphere sees its inside (A2 scene2_05). */
    float t = (-b - sq) / (2.0f * a);
    if (!(t > tmin))
        t = (-b + sq) / (2.0f * a);
    if (!(t > tmin) || !hit_accepts(hit, t, self->id))
        return false;
    hit->t = t;
    hit->normal = v3_normalize(v3_sub(ray_at(ray, t), s->center));
    hit->material = self->material;
    hit->id = self->id;
    return true;
}

static void sphere_insert(const Object3D *self, Grid *grid, XformPath *path)
{
    grid_insert_sphere(grid, self, path);
}

static const Object3DOps sphere_ops = {"Sphere", OBJ_SPHERE, sphere_intersect, sphere_insert};

Object3D *sphere_new(Arena *a, Vec3 center, float radius, const Material *m)
{
    Sphere *s = arena_alloc(a, sizeof *s);
    if (!s)
        return NULL;
    s->base.ops = &sphere_ops;
    s->base.material = m;
    s->base.bounded = true;
    s->base.id = RT_NO_ID;
    float r = fabsf(radius);
    s->base.bbox.min = v3_sub(center, v3(r, r, r));
    s->base.bbox.max = v3_add(center, v3(r, r, r));
    s->center = center;
    s->radius = radius;
    return &s->base;
}

Vec3 sphere_center(const Object3D *o) { return ((const Sphere *)o)->center; }
float sphere_radius(const Object3D *o) { return ((const Sphere *)o)->radius; }
