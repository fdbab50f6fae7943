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

/* Moller-Trumbore ("Fast, Minimum Storage Ray/Triangle Intersection", 1997) on
 * v0 and the edges e1 = v1 - v0, e2 = v2 - v0: the t of the ray's crossing of the
 * closed triangle, false when it misses or is parallel. The one formula of
 * Triangle::intersect and of the grid's packed triangles, so both give the same t. */
/* Edges are inclusive with a tolerance in barycentric units (the course's A7 images
 * count every sample that lies on an edge in exact arithmetic as a hit, and the floor of
 * its checkerboard scene reaches exactly this far beyond its edges): u, v >= -1e-5 and
 * u + v <= 1 + 1e-6 (the edge opposite v0 is widened less: the course's pictures leave
 * a pixel 6.8e-6 beyond it empty). */
#define RT_TRI_EDGE_TOL 1e-5f
#define RT_TRI_FAR_TOL 1e-6f
static inline bool triangle_ray_t(Vec3 v0, Vec3 e1, Vec3 e2, const Ray *ray, float *t_out)
{
    /* Everything is computed, then the tests are combined without branches: the
     * outcome of u, v tests is close to random over a cell's triangles, so branches on
     * them mispredict. A zero det (parallel ray or degenerate triangle) makes u, v
     * infinite or NaN, which every comparison below rejects. */
    Vec3 p = v3_cross(ray->dir, e2);
    float det = v3_dot(e1, p);
    float inv = 1.0f / det;
    Vec3 s = v3_sub(ray->origin, v0);
    float u = v3_dot(s, p) * inv;
    Vec3 q = v3_cross(s, e1);
    float v = v3_dot(ray->dir, q) * inv;
    *t_out = v3_dot(e2, q) * inv;
    return (det != 0.0f) & (u >= -RT_TRI_EDGE_TOL) & (v >= -RT_TRI_EDGE_TOL) &
           (u + v <= 1.0f + RT_TRI_FAR_TOL);
}
void triangle_vertices(const Object3D *tri, Vec3 out[3]);
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
Ray xform_path_to_object(const XformPath *path, const Ray *ray, float *tmin);
Vec3 xform_path_normal_to_world(const XformPath *path, Vec3 n);
bool xform_path_intersect(const XformPath *path, const Object3D *prim, const Ray *ray,
                          Hit *hit, float tmin, RenderCtx *ctx);

/* Numbers every leaf primitive in depth-first order (0..n-1) and returns n. */
uint32_t object_assign_ids(Object3D *root);

#endif
