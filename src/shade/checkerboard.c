/* Checkerboard (A6): unit 3D checker cells in texture space, each cell delegating every
 * query to one of the two child materials (docs/textures.md). */
#include <math.h>

#include "procedural.h"

/* s = floor(x) + floor(y) + floor(z) in texture space; even -> m1, odd -> m2. floor
 * (not truncation) keeps the pattern regular across 0 (-0.5 lies in cell -1); the
 * parity of the sum is taken on doubles so huge coordinates cannot overflow an int. */
static const Material *checkerboard_select(const Material *self, Vec3 p)
{
    const Procedural *pr = (const Procedural *)self;
    Vec3 q = procedural_texture_point(pr, p);
    double s = floor((double)q.x) + floor((double)q.y) + floor((double)q.z);
    /* fmod of an integral double is exact; |s| beyond 2^53 (or non-finite) has no
     * meaningful parity and falls to m1. */
    return fabs(fmod(s, 2.0)) == 1.0 ? pr->m2 : pr->m1;
}

static Vec3 checkerboard_shade(const Material *self, const Ray *ray, const Hit *hit, Vec3 l,
                               Vec3 c)
{
    return mat_shade(checkerboard_select(self, hit->point), ray, hit, l, c);
}
static Vec3 checkerboard_diffuse_at(const Material *self, Vec3 p)
{
    return mat_diffuse_at(checkerboard_select(self, p), p);
}
static Vec3 checkerboard_reflective_at(const Material *self, Vec3 p)
{
    return mat_reflective_at(checkerboard_select(self, p), p);
}
static Vec3 checkerboard_transparent_at(const Material *self, Vec3 p)
{
    return mat_transparent_at(checkerboard_select(self, p), p);
}
static float checkerboard_ior_at(const Material *self, Vec3 p)
{
    return mat_ior_at(checkerboard_select(self, p), p);
}

static const MaterialOps checkerboard_ops = {
    "Checkerboard",      checkerboard_shade,  checkerboard_diffuse_at, checkerboard_reflective_at,
    checkerboard_transparent_at, checkerboard_ior_at, procedural_preview,
};

/* Whether m is a PhongMaterial or a Checkerboard that can pick one (its flag, set when
 * it was made: the children exist before their parent, so no walk is needed). */
static bool leads_to_phong(const Material *m)
{
    return phong_params_of(m) ||
           (m->ops == &checkerboard_ops && ((const Procedural *)m)->reaches_phong);
}

Material *checkerboard_new(Arena *a, const Mat4 *texture_xf, const Material *m1,
                           const Material *m2)
{
    ProceduralBlend *b = procedural_alloc(a, &checkerboard_ops, texture_xf, m1, m2);
    if (!b)
        return NULL;
    b->proc.reaches_phong = leads_to_phong(m1) || leads_to_phong(m2);
    return &b->proc.base;
}

const Material *mat_checker_child(const Material *m, Vec3 p)
{
    return m->ops == &checkerboard_ops ? checkerboard_select(m, p) : NULL;
}

bool mat_checker_reaches_phong(const Material *m)
{
    return m->ops == &checkerboard_ops && ((const Procedural *)m)->reaches_phong;
}
