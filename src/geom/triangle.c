/* Triangle (A2): Moller-Trumbore (geom.h) with precomputed edges; normal from the winding. */
#include "rt/geom.h"
#include "rt/prim.h"
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
    return obj_record_hit(self, hit, t, tr->normal);
}

static bool triangle_occluded(const Object3D *self, const Ray *ray, float tmin, float tmax,
                              RenderCtx *ctx)
{
    const Triangle *tr = (const Triangle *)self;
    ctx->stats.intersections++;
    float t;
    return triangle_ray_t(tr->v0, tr->e1, tr->e2, ray, &t) && t > tmin && t < tmax;
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

/* Whether the projections p0..p2 of the triangle onto an axis miss [-rad, rad]. */
static inline bool separated(double p0, double p1, double p2, double rad)
{
    return d_min3(p0, p1, p2) > rad || d_max3(p0, p1, p2) < -rad;
}

/* Separating-axis test (Akenine-Moller, "Fast 3D Triangle-Box Overlap Testing", 2001):
 * the 3 box normals first (cheapest, they reject most candidates), the triangle
 * normal, then the 9 directions edge x box axis, written out since the box axes are
 * unit vectors: e x X = (0, ez, -ey), e x Y = (-ez, 0, ex), e x Z = (ey, -ex, 0). */
bool triangle_box_overlap(double v[3][3], const double h[3])
{
    for (int a = 0; a < 3; a++)
        if (separated(v[0][a], v[1][a], v[2][a], h[a]))
            return false;
    double e[3][3];
    for (int a = 0; a < 3; a++) {
        e[0][a] = v[1][a] - v[0][a];
        e[1][a] = v[2][a] - v[1][a];
        e[2][a] = v[0][a] - v[2][a];
    }
    double nrm[3];
    d3_cross(e[0], e[1], nrm);
    double rad = h[0] * fabs(nrm[0]) + h[1] * fabs(nrm[1]) + h[2] * fabs(nrm[2]);
    if (fabs(d3_dot(nrm, v[0])) > rad)
        return false;
    for (int i = 0; i < 3; i++) {
        double ex = e[i][0], ey = e[i][1], ez = e[i][2];
        double fx = fabs(ex), fy = fabs(ey), fz = fabs(ez);
        if (separated(ez * v[0][1] - ey * v[0][2], ez * v[1][1] - ey * v[1][2],
                      ez * v[2][1] - ey * v[2][2], h[1] * fz + h[2] * fy))
            return false;
        if (separated(ex * v[0][2] - ez * v[0][0], ex * v[1][2] - ez * v[1][0],
                      ex * v[2][2] - ez * v[2][0], h[0] * fz + h[2] * fx))
            return false;
        if (separated(ey * v[0][0] - ex * v[0][1], ey * v[1][0] - ex * v[1][1],
                      ey * v[2][0] - ex * v[2][1], h[0] * fy + h[1] * fx))
            return false;
    }
    return true;
}

/* The vertices in world space (to_world: the Transforms above it, or NULL). */
static void world_vertices(const Triangle *t, const PrimXform *xf, Vec3 w[3])
{
    w[0] = t->v0;
    w[1] = t->v1;
    w[2] = t->v2;
    if (xf)
        for (int i = 0; i < 3; i++)
            w[i] = mat4_point(&xf->m, w[i]);
}

static void triangle_cell_bounds(const Object3D *self, const PrimXform *xf, double lo[3],
                                 double hi[3])
{
    Vec3 w[3];
    world_vertices((const Triangle *)self, xf, w);
    for (int a = 0; a < 3; a++) {
        double x0 = (double)v3_comp(w[0], a), x1 = (double)v3_comp(w[1], a),
               x2 = (double)v3_comp(w[2], a);
        lo[a] = d_min3(x0, x1, x2);
        hi[a] = d_max3(x0, x1, x2);
    }
}

/* The triangle against the box: its world vertices relative to the box centre. */
static bool triangle_overlaps_box(const Object3D *self, const PrimXform *xf,
                                  const double lo[3], const double hi[3])
{
    Vec3 w[3];
    world_vertices((const Triangle *)self, xf, w);
    double v[3][3], h[3];
    for (int a = 0; a < 3; a++) {
        double mid = 0.5 * (lo[a] + hi[a]);
        h[a] = 0.5 * (hi[a] - lo[a]);
        for (int k = 0; k < 3; k++)
            v[k][a] = (double)v3_comp(w[k], a) - mid;
    }
    return triangle_box_overlap(v, h);
}

const Object3DOps triangle_ops = {.type_name = "Triangle",
                                  .kind = OBJ_TRIANGLE,
                                  .intersect = triangle_intersect,
                                  .occluded = triangle_occluded,
                                  .bounds = triangle_bounds,
                                  .cell_bounds = triangle_cell_bounds,
                                  .overlaps_box = triangle_overlaps_box};

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
