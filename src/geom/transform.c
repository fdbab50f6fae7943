/* Transform (A2): intersects its child in object space. The ray direction is NOT
 * renormalised, so the object-space t is the world t; only tmin is rescaled. */
#include "rt/geom.h"
#include "rt/arena.h"

typedef struct Transform {
    Object3D base;
    Mat4 m;        /* object -> parent */
    Mat4 inv;      /* parent -> object */
    Object3D *child;
} Transform;

/* The two steps shared by Transform::intersect and the grid's flattened paths, so
 * both produce the same floats. */
static inline Ray to_object(const Transform *x, const Ray *r)
{
    Ray o = {mat4_point(&x->inv, r->origin), mat4_dir(&x->inv, r->dir)};
    return o;
}

/* tmin for the child. The ray parameter t is the same in both spaces, but a positive
 * tmin (the epsilon of secondary rays) is a distance, measured in the space of the
 * primitive that is hit: like a tracer that renormalises the direction in object space,
 * t must exceed tmin / |object-space direction| (for a unit world direction). A ray
 * leaving the floor 0.0006 in front of a cube scaled by 0.25 (course scene 11) thus
 * still hits the cube's face, 0.0024 away in the cube's own units, as the course's
 * picture shows (output6_11a). tmin <= 0 (camera rays) stays as it is. */
static inline float tmin_to_object(float tmin, Vec3 d_parent, Vec3 d_object)
{
    if (!(tmin > 0.0f) || !isfinite(tmin))
        return tmin;
    float scale = v3_length(d_parent) / v3_length(d_object);
    return isfinite(scale) && scale > 0.0f ? tmin * scale : tmin;
}

static inline Vec3 normal_to_parent(const Transform *x, Vec3 n)
{
    return v3_normalize(mat4_dir_transposed(&x->inv, n));
}

static bool transform_intersect(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                                RenderCtx *ctx)
{
    const Transform *x = (const Transform *)self;
    Ray local = to_object(x, ray);
    if (!obj_intersect(x->child, &local, hit, tmin_to_object(tmin, ray->dir, local.dir), ctx))
        return false;
    hit->normal = normal_to_parent(x, hit->normal);
    return true;
}

static bool transform_occluded(const Object3D *self, const Ray *ray, float tmin, float tmax,
                               RenderCtx *ctx)
{
    const Transform *x = (const Transform *)self;
    Ray local = to_object(x, ray);
    return obj_occluded(x->child, &local, tmin_to_object(tmin, ray->dir, local.dir), tmax,
                        ctx);
}

static const Object3DOps transform_ops = {.type_name = "Transform", .kind = OBJ_TRANSFORM,
                                          .intersect = transform_intersect,
                                          .occluded = transform_occluded};

Object3D *transform_new(Arena *a, const Mat4 *m, Object3D *child)
{
    Mat4 inv;
    if (!child || !mat4_inverse(m, &inv))
        return NULL;
    Transform *x = arena_alloc(a, sizeof *x);
    if (!x)
        return NULL;
    x->base.ops = &transform_ops;
    x->base.id = RT_NO_ID;
    x->base.bounded = child->bounded;
    x->base.bbox = child->bounded ? bbox_transform(&child->bbox, m) : bbox_empty();
    x->m = *m;
    x->inv = inv;
    x->child = child;
    return &x->base;
}

const Mat4 *transform_matrix(const Object3D *o) { return &((const Transform *)o)->m; }
const Mat4 *transform_inverse(const Object3D *o) { return &((const Transform *)o)->inv; }
const Object3D *transform_child(const Object3D *o) { return ((const Transform *)o)->child; }

Ray transform_path_to_object(const XformPath *path, const Ray *ray, float *tmin)
{
    Ray r = *ray;
    for (int i = 0; i < path->depth; i++) {
        Ray local = to_object((const Transform *)path->xf[i], &r);
        *tmin = tmin_to_object(*tmin, r.dir, local.dir);
        r = local;
    }
    return r;
}

float transform_path_tmin_scale(const XformPath *path)
{
    /* |inv d| <= ||inv||_F |d| at each level, so each level's factor
     * |d_parent| / |d_object| is at least 1 / ||inv||_F (3x3 part, in double). */
    double s = 1.0;
    for (int i = 0; i < path->depth; i++) {
        const Mat4 *inv = transform_inverse(path->xf[i]);
        double f = 0.0;
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++)
                f += (double)inv->m[r][c] * (double)inv->m[r][c];
        f = sqrt(f);
        if (!(f > 0.0) || !isfinite(f))
            return 0.0f; /* no bound: the caller starts at 0 */
        s /= f;
    }
    /* Float rounding of tmin * scale at each level is a few ulps; 1/1024 covers it. */
    s *= 1.0 - 1.0 / 1024.0;
    return s < 1.0 ? (float)s : 1.0f;
}

Vec3 transform_path_normal_to_world(const XformPath *path, Vec3 n)
{
    for (int i = path->depth - 1; i >= 0; i--)
        n = normal_to_parent((const Transform *)path->xf[i], n);
    return n;
}

bool transform_path_occluded(const XformPath *path, const Object3D *prim, const Ray *ray,
                             float tmin, float tmax, RenderCtx *ctx)
{
    Ray r = transform_path_to_object(path, ray, &tmin);
    return obj_occluded(prim, &r, tmin, tmax, ctx);
}

bool transform_path_intersect(const XformPath *path, const Object3D *prim, const Ray *ray,
                              Hit *hit, float tmin, RenderCtx *ctx)
{
    Ray r = transform_path_to_object(path, ray, &tmin);
    if (!obj_intersect(prim, &r, hit, tmin, ctx))
        return false;
    hit->normal = transform_path_normal_to_world(path, hit->normal);
    return true;
}
