/* Sphere (A1): |o + t d - c|^2 = r^2, solved for any (non-unit) direction. */
#include "rt/geom.h"
#include "rt/prim.h"
#include "rt/arena.h"

#include <float.h>

typedef struct Sphere {
    Object3D base;
    Vec3 center;
    float radius;
} Sphere;

/* The root intersect and occluded both take: the nearer one past tmin, else the
 * farther one (a camera inside the sphere sees its inside: A2 scene2_05). False when
 * neither lies past tmin. */
static inline bool sphere_root(const Sphere *s, const Ray *ray, float tmin, float *t_out)
{
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
    float h = r2 - v3_dot(f, f);
    float disc = a * h;
    /* The sign of h, not of disc: under a Transform a is the squared length of the
     * object-space direction (1e-24 under UniformScale 1e12), and a * h of a ray
     * missing the sphere by up to some 18 radii underflowed to -0, which passed
     * disc < 0 (UniformScale 1e12 of a radius 2e-12: every ray of the picture "hit"
     * it). */
    if (h < 0.0f)
        return false;
    /* sqrt(a h) as sqrt(a) sqrt(h) where the product is not a normal float: it
     * overflowed (UniformScale 1e-10 of a radius 2e10: a 1e20, h 4e20, so the roots
     * were infinite and the sphere a flat disc) or lost bits below FLT_MIN. Elsewhere
     * sqrtf(disc) as before, so such images keep their bytes. */
    float sd = disc >= FLT_MIN && disc <= FLT_MAX ? sqrtf(disc) : sqrtf(a) * sqrtf(h);
    float c = v3_dot(oc, oc) - r2;
    float q = -(b + copysignf(sd, b));
    float t0 = q / a, t1 = q != 0.0f ? c / q : -t0;
    if (t0 > t1) {
        float tmp = t0;
        t0 = t1;
        t1 = tmp;
    }
    float t = t0;
    if (!(t > tmin))
        t = t1;
    *t_out = t;
    return t > tmin;
}

static bool sphere_intersect(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                             RenderCtx *ctx)
{
    const Sphere *s = (const Sphere *)self;
    ctx->stats.intersections++;
    float t;
    if (!sphere_root(s, ray, tmin, &t) || !hit_accepts(hit, t, self->id))
        return false;
    return obj_record_hit(self, hit, t, v3_normalize(v3_sub(ray_at(ray, t), s->center)));
}

static bool sphere_occluded(const Object3D *self, const Ray *ray, float tmin, float tmax,
                            RenderCtx *ctx)
{
    ctx->stats.intersections++;
    float t;
    return sphere_root((const Sphere *)self, ray, tmin, &t) && t < tmax;
}

/* The box of the ball, mapped by to_world (its 8 corners' box: not tight under
 * rotation, but it encloses the ellipsoid). */
static BBox sphere_bounds(const Object3D *self, const Mat4 *to_world)
{
    return to_world ? bbox_transform(&self->bbox, to_world) : self->bbox;
}

/* ---- cell occupancy (accelerators that bin into boxes), in double precision ---- */

typedef struct DVec {
    double x[3];
} DVec;

static DVec dvec(Vec3 v)
{
    DVec d = {{(double)v.x, (double)v.y, (double)v.z}};
    return d;
}

/* Relative slack for the sphere surface tests: the hit point of a quadratic solve lies
 * within a few float ulps of the surface; 1e-5 of the size is far above that. */
#define SURFACE_SLACK 1e-5

/* The sphere's surface against the box [lo, hi] (world = object space). */
static bool surface_overlaps_box(const Sphere *s, const double lo[3], const double hi[3])
{
    DVec c = dvec(s->center);
    double r = (double)s->radius;
    double eta = SURFACE_SLACK * (fabs(r) + fabs(c.x[0]) + fabs(c.x[1]) + fabs(c.x[2]));
    double dmin2 = 0.0, dmax2 = 0.0;
    for (int a = 0; a < 3; a++) {
        double below = lo[a] - c.x[a], above = c.x[a] - hi[a];
        double out = below > 0 ? below : above > 0 ? above : 0.0;
        dmin2 += out * out;
        double far = fmax(fabs(c.x[a] - lo[a]), fabs(hi[a] - c.x[a]));
        dmax2 += far * far;
    }
    /* Only the surface can be hit: skip cells wholly outside, or wholly inside. */
    return sqrt(dmin2) <= r + eta && sqrt(dmax2) >= r - eta;
}

/* A transformed sphere (ellipsoid) against a cell, tested in the sphere's object space
 * where the cell becomes a parallelepiped: out if even its bounding sphere misses the
 * sphere, out if all 8 corners lie inside (convexity: then the whole cell does). */
static bool ellipsoid_overlaps_box(const Sphere *s, const PrimXform *xf, const double lo[3],
                                   const double hi[3])
{
    const Mat4 *inv = &xf->inv;
    DVec c = dvec(s->center);
    double r = (double)s->radius;
    double frob = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            frob += (double)inv->m[i][j] * (double)inv->m[i][j];
    frob = sqrt(frob);
    double mid[3], half = 0.0;
    for (int a = 0; a < 3; a++) {
        mid[a] = 0.5 * (lo[a] + hi[a]);
        half += 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
    }
    half = sqrt(half);
    double q[3], d2 = 0.0;
    for (int i = 0; i < 3; i++) {
        q[i] = (double)inv->m[i][3];
        for (int j = 0; j < 3; j++)
            q[i] += (double)inv->m[i][j] * mid[j];
        d2 += (q[i] - c.x[i]) * (q[i] - c.x[i]);
    }
    double slack = SURFACE_SLACK * (fabs(r) + fabs(c.x[0]) + fabs(c.x[1]) + fabs(c.x[2]));
    if (sqrt(d2) > r + frob * half + slack)
        return false;
    for (int corner = 0; corner < 8; corner++) {
        double p[3] = {(corner & 1) ? hi[0] : lo[0], (corner & 2) ? hi[1] : lo[1],
                       (corner & 4) ? hi[2] : lo[2]};
        double e2 = 0.0;
        for (int i = 0; i < 3; i++) {
            double qi = (double)inv->m[i][3];
            for (int j = 0; j < 3; j++)
                qi += (double)inv->m[i][j] * p[j];
            e2 += (qi - c.x[i]) * (qi - c.x[i]);
        }
        if (sqrt(e2) >= r - slack)
            return true; /* a corner outside: the surface may cross the cell */
    }
    return false;
}

/* A tight world box: the ball's, or under Transforms the exact box of the ellipsoid
 * M(S) (centre M c, half extent r * |row a of M|) with the surface slack. */
static void sphere_cell_bounds(const Object3D *self, const PrimXform *xf, double lo[3],
                               double hi[3])
{
    const Sphere *s = (const Sphere *)self;
    if (!xf) {
        for (int a = 0; a < 3; a++) {
            double c = (double)v3_comp(s->center, a), r = fabs((double)s->radius);
            lo[a] = c - r;
            hi[a] = c + r;
        }
        return;
    }
    const Mat4 *m = &xf->m;
    DVec c = dvec(s->center);
    for (int a = 0; a < 3; a++) {
        double w = (double)m->m[a][3], len = 0.0;
        for (int j = 0; j < 3; j++) {
            w += (double)m->m[a][j] * c.x[j];
            len += (double)m->m[a][j] * (double)m->m[a][j];
        }
        double e = fabs((double)s->radius) * sqrt(len);
        lo[a] = w - e * (1.0 + SURFACE_SLACK);
        hi[a] = w + e * (1.0 + SURFACE_SLACK);
    }
}

static bool sphere_overlaps_box(const Object3D *self, const PrimXform *xf, const double lo[3],
                                const double hi[3])
{
    const Sphere *s = (const Sphere *)self;
    return xf ? ellipsoid_overlaps_box(s, xf, lo, hi) : surface_overlaps_box(s, lo, hi);
}

static const Object3DOps sphere_ops = {.type_name = "Sphere",
                                       .kind = OBJ_SPHERE,
                                       .intersect = sphere_intersect,
                                       .occluded = sphere_occluded,
                                       .bounds = sphere_bounds,
                                       .cell_bounds = sphere_cell_bounds,
                                       .overlaps_box = sphere_overlaps_box};

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
