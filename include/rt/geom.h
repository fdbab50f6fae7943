/* Constructors and read-only accessors of the concrete Object3D types. Objects are
 * allocated from the scene's arena and never freed individually. Constructors return
 * NULL only when the arena is out of memory. */
#ifndef RT_GEOM_H
#define RT_GEOM_H

#include "rt/object3d.h"

/* Group: children are set one by one (the parser knows numObjects up front). */
Object3D *group_new(Arena *a, int capacity);
void group_set_child(Object3D *group, int index, Object3D *child); /* index < capacity */
/* Recomputes the box/bounded flag from the children; call after the last child. */
void group_finish(Object3D *group);
int group_count(const Object3D *group);
const Object3D *group_child(const Object3D *group, int index);

Object3D *sphere_new(Arena *a, Vec3 center, float radius, const Material *m);
Vec3 sphere_center(const Object3D *sphere);
float sphere_radius(const Object3D *sphere);

/* Points P with dot(P, normal) = offset; normal used as given for the front side. */
Object3D *plane_new(Arena *a, Vec3 normal, float offset, const Material *m);
Vec3 plane_normal(const Object3D *plane);
float plane_offset(const Object3D *plane);
Vec3 plane_unit_normal(const Object3D *plane);  /* the normal its hits record */

Object3D *triangle_new(Arena *a, Vec3 v0, Vec3 v1, Vec3 v2, const Material *m);
/* A TriangleMesh: a Group of n Triangles (verts[faces[i][0..2]], material m), the same
 * objects and box as triangle_new per face, group_set_child in face order and
 * group_finish, with all triangles in one arena block. Every index in faces must be a
 * valid index into verts. NULL when out of memory. */
Object3D *triangle_mesh_new(Arena *a, const Vec3 *verts, const int (*faces)[3], int n,
                            const Material *m);
/* The same, with the triangles built in block (from arena_buffer_new, e.g. the OBJ text
 * once parsed), which the arena adopts, so its pages are not faulted in twice. Takes
 * ownership of block in every case (NULL: like triangle_mesh_new). */
Object3D *triangle_mesh_new_in(Arena *a, void *block, const Vec3 *verts,
                               const int (*faces)[3], int n, const Material *m);

/* Edges are inclusive with a tolerance in barycentric units (the course's A7 images
 * count every sample that lies on an edge in exact arithmetic as a hit, and the floor of
 * its checkerboard scene reaches exactly this far beyond its edges): u, v >= -1e-5 and
 * u + v <= 1 + 1e-6 (the edge opposite v0 is widened less: the course's pictures leave
 * a pixel 6.8e-6 beyond it empty). */
#define RT_TRI_EDGE_TOL 1e-5f
#define RT_TRI_FAR_TOL 1e-6f

/* Moller-Trumbore ("Fast, Minimum Storage Ray/Triangle Intersection", 1997) on v0 and
 * the edges e1 = v1 - v0, e2 = v2 - v0, written once for every width: T is float, or a
 * GCC vector of floats (the grid's 4-lane batches, grid_cast.c; the packets' 8 lanes,
 * grid_packet_kernel.h), and the arguments may mix scalars and vectors of T. Declares
 * det, u, v and t (the names given) in the enclosing block: the ray crosses the
 * triangle at t when det != 0, u >= -RT_TRI_EDGE_TOL, v >= -RT_TRI_EDGE_TOL and
 * u + v <= 1 + RT_TRI_FAR_TOL (every width tests exactly these). Each lane does
 * the same IEEE operations in the same order (never fused), so every width gives the
 * scalar's bits. A zero det (parallel ray or degenerate triangle) makes u, v infinite or
 * NaN, which every one of those comparisons rejects. */
#define RT_MOLLER_TRUMBORE(T, one, ox, oy, oz, dx, dy, dz, v0x, v0y, v0z, e1x, e1y, e1z, \
                           e2x, e2y, e2z, det, u, v, t)                                 \
    RT_MT_DIR(T, one, dx, dy, dz, e1x, e1y, e1z, e2x, e2y, e2z, mt_px_, mt_py_, mt_pz_,   \
              det, mt_inv_);                                                            \
    RT_MT_ORIGIN(T, ox, oy, oz, dx, dy, dz, v0x, v0y, v0z, e1x, e1y, e1z, e2x, e2y, e2z, \
                 mt_px_, mt_py_, mt_pz_, mt_inv_, u, v, t)
/* Its two halves: what depends on the direction alone (p = d x e2, det and its
 * reciprocal: the same for every ray of a packet that shares one direction, so the
 * packet walk makes them once per triangle for those), then the rest. */
#define RT_MT_DIR(T, one, dx, dy, dz, e1x, e1y, e1z, e2x, e2y, e2z, px, py, pz, det, inv) \
    T px = (dy) * (e2z) - (dz) * (e2y), py = (dz) * (e2x) - (dx) * (e2z);                 \
    T pz = (dx) * (e2y) - (dy) * (e2x);                                                   \
    T det = (e1x) * px + (e1y) * py + (e1z) * pz;                                         \
    T inv = (one) / det
#define RT_MT_ORIGIN(T, ox, oy, oz, dx, dy, dz, v0x, v0y, v0z, e1x, e1y, e1z, e2x, e2y, e2z, \
                     px, py, pz, inv, u, v, t)                                              \
    T mt_sx_ = (ox) - (v0x), mt_sy_ = (oy) - (v0y), mt_sz_ = (oz) - (v0z);                  \
    T u = (mt_sx_ * (px) + mt_sy_ * (py) + mt_sz_ * (pz)) * (inv);                          \
    T mt_qx_ = mt_sy_ * (e1z) - mt_sz_ * (e1y), mt_qy_ = mt_sz_ * (e1x) - mt_sx_ * (e1z);     \
    T mt_qz_ = mt_sx_ * (e1y) - mt_sy_ * (e1x);                                             \
    T v = ((dx) * mt_qx_ + (dy) * mt_qy_ + (dz) * mt_qz_) * (inv);                          \
    T t = ((e2x) * mt_qx_ + (e2y) * mt_qy_ + (e2z) * mt_qz_) * (inv)

/* The scalar width: the t of the ray's crossing of the closed triangle, false when it
 * misses or is parallel. The one formula of Triangle::intersect and of the grid's
 * packed triangles, so both give the same t. Everything is computed, then the tests
 * are combined without branches: the outcome of the u, v tests is close to random over
 * a cell's triangles, so branches on them mispredict. */
static inline bool triangle_ray_t(Vec3 v0, Vec3 e1, Vec3 e2, const Ray *ray, float *t_out)
{
    const Vec3 o = ray->origin, d = ray->dir;
    RT_MOLLER_TRUMBORE(float, 1.0f, o.x, o.y, o.z, d.x, d.y, d.z, v0.x, v0.y, v0.z, e1.x,
                       e1.y, e1.z, e2.x, e2.y, e2.z, det, u, v, t);
    *t_out = t;
    return (det != 0.0f) & (u >= -RT_TRI_EDGE_TOL) & (v >= -RT_TRI_EDGE_TOL) &
           (u + v <= 1.0f + RT_TRI_FAR_TOL);
}
void triangle_vertices(const Object3D *tri, Vec3 out[3]);
/* Separating-axis test of the triangle v (vertices relative to the box centre) against
 * the box of half extents h: the exact answer in double (Triangle's overlaps_box and
 * the grid's triangle fast path). */
bool triangle_box_overlap(double v[3][3], const double h[3]);
Vec3 triangle_normal(const Object3D *tri);  /* normalize((v1-v0) x (v2-v0)) */

/* Transform with matrix m (object -> parent space). Returns NULL when m is singular.
 * Its intersect keeps t in the parent's units (the direction is not renormalised) but
 * treats a positive tmin as a distance in the child's space: the child gets
 * tmin * |parent direction| / |child direction|. */
Object3D *transform_new(Arena *a, const Mat4 *m, Object3D *child);
const Mat4 *transform_matrix(const Object3D *xf);          /* object -> parent */
const Mat4 *transform_inverse(const Object3D *xf);         /* parent -> object */
const Object3D *transform_child(const Object3D *xf);

/* The exact arithmetic of nested Transform::intersect, for a primitive reached through
 * path (the flat primitive table): bit-identical t and normal to the tree walk. The two
 * halves: the ray in the primitive's object space (and *tmin rescaled as each Transform
 * does: a positive tmin is a distance in the primitive's own space), and an object-space
 * normal back in world space (normalised at every level, as the tree walk does). */
Ray transform_path_to_object(const XformPath *path, const Ray *ray, float *tmin);
Vec3 transform_path_normal_to_world(const XformPath *path, Vec3 n);
bool transform_path_intersect(const XformPath *path, const Object3D *prim, const Ray *ray,
                              Hit *hit, float tmin, RenderCtx *ctx);
/* A lower bound on the factor by which transform_path_to_object shrinks a positive
 * tmin along path, for any ray direction (1/Frobenius norm of each level's inverse, less
 * a margin for rounding; at most 1). An accelerator that culls by distance along the ray
 * must start at tmin times this factor: a leaf under a shrinking Transform accepts hits
 * at world t below tmin (a distance in its own space). */
float transform_path_tmin_scale(const XformPath *path);
/* The same for a shadow ray (obj_occluded through path): no normal to bring back. */
bool transform_path_occluded(const XformPath *path, const Object3D *prim, const Ray *ray,
                             float tmin, float tmax, RenderCtx *ctx);

/* Numbers every leaf primitive in depth-first order (0..n-1) and returns n. */
uint32_t group_assign_ids(Object3D *root);

#endif
