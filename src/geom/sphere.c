/* Sphere (A1): |o + t d - c|^2 = r^2, solved for any (non-unit) direction. */
#include "rt/geom.h"
#include "rt/arena.h"

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
    /* a t^2 + 2 b t + c = 0 with b = d.oc. The textbook discriminant b^2 - a c cancels
     * catastrophically for far origins (its error grows like eps |oc|^2: a ray from
     * 4000 units away "hits" spheres it misses by units). Written as a (r^2 - |f|^2)
     * with f = oc - (b/a) d, the offset of the closest approach, it stays accurate;
     * the roots come from q = -(b + sign(b) sqrt(disc)) without cancellation either
     * (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray
     * Tracing Gems, 2019). */
    Vec3 oc = v3_sub(ray->origin, s->center);
    float a = v3_dot(ray->dir, ray->dir);
    if (a == 0.0f)
        return false;
    float b = v3_dot(ray->dir, oc);
    Vec3 f = v3_sub(oc, v3_scale(ray->dir, b / a));
    float r2 = s->radius * s->radius;
    float disc = a * (r2 - v3_dot(f, f));
    if (disc < 0.0f)
        return false;
    float c = v3_dot(oc, oc) - r2;
    float q = -(b + copysignf(sqrtf(disc), b));
    float t0 = q / a, t1 = q != 0.0f ? c / q : -t0;
    if (t0 > t1) {
        float tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    /* The nearer root when it lies past tmin, else the farther one: a camera inside
     * the sphere sees its inside (A2 scene2_05). */
    float t = t0;
    if (!(t > tmin))
        t = t1;
    if (!(t > tmin) || !hit_accepts(hit, t, self->id))
        return false;
    hit->t = t;
    hit->normal = v3_normalize(v3_sub(ray_at(ray, t), s->center));
    hit->material = self->material;
    hit->id = self->id;
    return true;
}

/* The box of the ball, mapped by to_world (its 8 corners' box: not tight under
 * rotation, but it encloses the ellipsoid). */
static BBox sphere_bounds(const Object3D *self, const Mat4 *to_world)
{
    return to_world ? bbox_transform(&self->bbox, to_world) : self->bbox;
}

static const Object3DOps sphere_ops = {"Sphere", OBJ_SPHERE, sphere_intersect, sphere_bounds};

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
