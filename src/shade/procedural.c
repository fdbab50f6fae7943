/* Shared parts of the procedural solid textures (semantics.md 5): allocation with the
 * texture matrix copied in, the GL preview rule, and the weighted blend of two children. */
#include "procedural.h"

ProceduralBlend *procedural_alloc(Arena *a, const MaterialOps *ops, const Mat4 *texture_xf,
                                  const Material *m1, const Material *m2)
{
    if (!a || !m1 || !m2)
        return NULL;
    ProceduralBlend *b = arena_alloc(a, sizeof *b);
    if (!b)
        return NULL;
    b->proc.base.ops = ops;
    b->proc.m1 = m1;
    b->proc.m2 = m2;
    b->proc.has_xf = texture_xf != NULL;
    b->proc.xf = texture_xf ? *texture_xf : mat4_identity();
    return b;
}

Material *procedural_blend_new(Arena *a, const MaterialOps *ops, const Mat4 *texture_xf,
                               const Material *m1, const Material *m2, int octaves,
                               float frequency, float amplitude)
{
    ProceduralBlend *b = procedural_alloc(a, ops, texture_xf, m1, m2);
    if (!b)
        return NULL;
    b->octaves = octaves < 0 ? 0 : octaves > PROCEDURAL_MAX_OCTAVES ? PROCEDURAL_MAX_OCTAVES
                                                                     : octaves;
    b->frequency = frequency;
    b->amplitude = amplitude;
    return &b->proc.base;
}

const Material *procedural_preview(const Material *self)
{
    /* m1 may itself be procedural: recurse until a PhongMaterial answers. */
    return mat_preview(((const Procedural *)self)->m1);
}

/* The blends below skip the child whose weight is exactly 0: t*a + (1-t)*b with t = 1
 * is a*1 + b*0 = a in IEEE arithmetic for any finite b, so the result is the same bit
 * for bit, and Noise/Wood (clamped weights) often sit at 0 or 1. */

Vec3 procedural_blend_shade(const Procedural *pr, float t, const Ray *ray, const Hit *hit,
                            Vec3 dir_to_light, Vec3 light_color)
{
    if (t >= 1.0f)
        return mat_shade(pr->m1, ray, hit, dir_to_light, light_color);
    if (t <= 0.0f)
        return mat_shade(pr->m2, ray, hit, dir_to_light, light_color);
    return v3_lerp(mat_shade(pr->m1, ray, hit, dir_to_light, light_color),
                   mat_shade(pr->m2, ray, hit, dir_to_light, light_color), t);
}

Vec3 procedural_blend_diffuse(const Procedural *pr, float t, Vec3 p)
{
    if (t >= 1.0f)
        return mat_diffuse_at(pr->m1, p);
    if (t <= 0.0f)
        return mat_diffuse_at(pr->m2, p);
    return v3_lerp(mat_diffuse_at(pr->m1, p), mat_diffuse_at(pr->m2, p), t);
}

Vec3 procedural_blend_reflective(const Procedural *pr, float t, Vec3 p)
{
    if (t >= 1.0f)
        return mat_reflective_at(pr->m1, p);
    if (t <= 0.0f)
        return mat_reflective_at(pr->m2, p);
    return v3_lerp(mat_reflective_at(pr->m1, p), mat_reflective_at(pr->m2, p), t);
}

Vec3 procedural_blend_transparent(const Procedural *pr, float t, Vec3 p)
{
    if (t >= 1.0f)
        return mat_transparent_at(pr->m1, p);
    if (t <= 0.0f)
        return mat_transparent_at(pr->m2, p);
    return v3_lerp(mat_transparent_at(pr->m1, p), mat_transparent_at(pr->m2, p), t);
}

float procedural_blend_ior(const Procedural *pr, float t, Vec3 p)
{
    /* Interpolated like the colours (semantics.md 5.6, unverified by the references). */
    if (t >= 1.0f)
        return mat_ior_at(pr->m1, p);
    if (t <= 0.0f)
        return mat_ior_at(pr->m2, p);
    return t * mat_ior_at(pr->m1, p) + (1.0f - t) * mat_ior_at(pr->m2, p);
}
