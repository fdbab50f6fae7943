/* Private base of the procedural solid textures (A6, docs/textures.md): a texture-space
 * matrix and two borrowed child materials, plus the shared "blend by weight t" ops
 * that Noise, Marble and Wood generate with PROCEDURAL_BLEND_OPS. */
#ifndef RT_SHADE_PROCEDURAL_H
#define RT_SHADE_PROCEDURAL_H

#include <stdbool.h>
#include <stdint.h>
#include "rt/arena.h"
#include "rt/material.h"
#include "rt/matrix.h"

/* Embedded as the first member of every procedural material (so a Material* to one of
 * them is a Procedural*). The matrix is copied in (the caller's may be temporary). */
typedef struct Procedural {
    Material base;
    const Material *m1;     /* "material 1": the first materialIndex, borrowed */
    const Material *m2;     /* "material 2": the second materialIndex, borrowed */
    bool has_xf;            /* false: identity (the course passes NULL) */
    Mat4 xf;                /* world -> texture space: q = xf * p */
    /* Every material below is a PhongMaterial with a zero reflective (transparent)
     * colour: the blend's colour is then zero at every point, and the blends answer
     * without computing their weight (the tracer only asks whether it is zero). */
    bool no_reflective, no_transparent;
    /* Checkerboard: some material it can pick at a point, through nested Checkerboards,
     * is a PhongMaterial (the packet tracer's inline lanes need one); false otherwise. */
    bool reaches_phong;
} Procedural;

/* Noise, Marble and Wood share one layout; Checkerboard ignores the three numbers. */
typedef struct ProceduralBlend {
    Procedural proc;
    int octaves;            /* clamped to [0, PROCEDURAL_MAX_OCTAVES] */
    float frequency;
    float amplitude;
    uint64_t serial;        /* unique within the process: key of the weight cache */
    float xf_scale;         /* largest stretch of xf's linear part (max column length):
                               a world footprint w covers at most w * xf_scale texture
                               units */
    /* t[i] = the weight at world point p[i], i < n, for the footprint 0: the same bits
     * as the material's single-point weight, computed for many points at once
     * (mat_blend_weights). NULL for Checkerboard. */
    void (*weights)(const struct ProceduralBlend *b, const Vec3 *p, int n, float *t);
} ProceduralBlend;

typedef void (*ProceduralWeightsFn)(const ProceduralBlend *b, const Vec3 *p, int n, float *t);

/* The most points a weights function is given at once (its callers split more). */
#define PROCEDURAL_WEIGHTS_MAX 64

/* More octaves add terms below 2^-64 of the first one; the cap keeps an absurd
 * "octaves 2000000000" from turning every shading call into a near-hang. */
#define PROCEDURAL_MAX_OCTAVES 64

/* Allocates a ProceduralBlend-sized object from the arena with the given ops; NULL
 * when out of memory or a child is NULL. A material that picks one child per point
 * (Checkerboard) is made with this alone: no weights, so the packet tracer shades it
 * through its ops. */
ProceduralBlend *procedural_alloc(Arena *a, const MaterialOps *ops, const Mat4 *texture_xf,
                                  const Material *m1, const Material *m2);

/* procedural_alloc plus the three numbers; octaves < 0 count as 0, and more than
 * PROCEDURAL_MAX_OCTAVES as the maximum. */
Material *procedural_blend_new(Arena *a, const MaterialOps *ops, const Mat4 *texture_xf,
                               const Material *m1, const Material *m2, int octaves,
                               float frequency, float amplitude, ProceduralWeightsFn weights);

/* The texture-space points q of world points p[0..n-1] (n <= PROCEDURAL_WEIGHTS_MAX),
 * as doubles in x, y, z, and the octave sum N(q.x, q.y, q.z) in noise, or with grain
 * N(q.x, 0.2 q.y, q.z) (Wood's), each for the footprint 0 (every octave): for the
 * weights functions. */
void procedural_octaves_at(const ProceduralBlend *b, const Vec3 *p, int n, bool grain,
                           double *x, double *y, double *z, double *noise);
/* Tests: procedural_octaves_at's texture points from now on in the lanes of isa
 * ("base": the loop alone; "avx2": eight points a step where the CPU has AVX2); false,
 * nothing changed, when this build or CPU cannot run them. */
bool procedural_points_use_kernel(const char *isa);

/* The texture-space point of world point p: q = M p. */
static inline Vec3 procedural_texture_point(const Procedural *pr, Vec3 p)
{
    return pr->has_xf ? mat4_point(&pr->xf, p) : p;
}

/* The footprint (mat_footprint) in b's texture units: the width below which its noise
 * octaves are left out, 0 when -noise_cutoff is off. */
static inline double procedural_footprint(const ProceduralBlend *b)
{
    return (double)mat_footprint() * (double)b->xf_scale;
}

/* The GL preview shows the first child's material, recursively. Only for materials made
 * by procedural_alloc or procedural_blend_new: procedural.c (phong_blend) takes a
 * material whose preview_material is this function for a ProceduralBlend. */
const Material *procedural_preview(const Material *self);

/* Shading and accessors of a blend with weight t on m1: the
 * children's RESULTS are interpolated, t*m1 + (1-t)*m2, both evaluated at world p. */
Vec3 procedural_blend_shade(const Procedural *pr, float t, const Ray *ray, const Hit *hit,
                            Vec3 dir_to_light, Vec3 light_color);
Vec3 procedural_blend_diffuse(const Procedural *pr, float t, Vec3 p);
Vec3 procedural_blend_reflective(const Procedural *pr, float t, Vec3 p);
Vec3 procedural_blend_transparent(const Procedural *pr, float t, Vec3 p);
float procedural_blend_ior(const Procedural *pr, float t, Vec3 p);

/* The weight of blend b at world point p, i.e. weight(b, p), memoised: the tracer asks
 * a material about the same hit point several times (ambient, each light's shade,
 * reflection, refraction), and each answer costs up to `octaves` noise evaluations.
 * A small per-thread cache keyed by (material, exact bits of p, the footprint's bits)
 * returns the value computed before, so images are bit-identical with or without it. */
typedef float (*ProceduralWeightFn)(const ProceduralBlend *b, Vec3 p);
float procedural_weight(const ProceduralBlend *b, Vec3 p, ProceduralWeightFn weight);

/* One accessor of PROCEDURAL_BLEND_OPS: NAME_WHAT_at blends the children's WHAT
 * (diffuse, reflective, transparent: Vec3; ior: float) by the weight at p. */
#define PROCEDURAL_BLEND_AT(NAME, WHAT, TYPE, WEIGHT)                                      \
    static TYPE NAME##_##WHAT##_at(const Material *self, Vec3 p)                           \
    {                                                                                      \
        const ProceduralBlend *b = (const ProceduralBlend *)self;                          \
        return procedural_blend_##WHAT(&b->proc, procedural_weight(b, p, WEIGHT), p);     \
    }

/* The same for a colour that may be known to be zero everywhere (Procedural's
 * no_reflective, no_transparent): then (0, 0, 0) without the weight. */
#define PROCEDURAL_BLEND_AT_UNLESS(NAME, WHAT, WEIGHT, ZERO)                               \
    static Vec3 NAME##_##WHAT##_at(const Material *self, Vec3 p)                           \
    {                                                                                      \
        const ProceduralBlend *b = (const ProceduralBlend *)self;                          \
        if (b->proc.ZERO)                                                                  \
            return v3(0.0f, 0.0f, 0.0f);                                                   \
        return procedural_blend_##WHAT(&b->proc, procedural_weight(b, p, WEIGHT), p);     \
    }

/* Defines the static ops functions and the one static const ops table NAME_ops of a
 * blending material whose weight at world point p is WEIGHT(const ProceduralBlend *,
 * Vec3 p) -> float in [0,1]. */
#define PROCEDURAL_BLEND_OPS(NAME, TYPE_NAME, WEIGHT)                                      \
    static Vec3 NAME##_shade(const Material *self, const Ray *ray, const Hit *hit,          \
                             Vec3 l, Vec3 c)                                                \
    {                                                                                      \
        const ProceduralBlend *b = (const ProceduralBlend *)self;                          \
        return procedural_blend_shade(&b->proc, procedural_weight(b, hit->point, WEIGHT),  \
                                      ray, hit, l, c);                                     \
    }                                                                                      \
    PROCEDURAL_BLEND_AT(NAME, diffuse, Vec3, WEIGHT)                                       \
    PROCEDURAL_BLEND_AT_UNLESS(NAME, reflective, WEIGHT, no_reflective)                    \
    PROCEDURAL_BLEND_AT_UNLESS(NAME, transparent, WEIGHT, no_transparent)                  \
    PROCEDURAL_BLEND_AT(NAME, ior, float, WEIGHT)                                          \
    static const MaterialOps NAME##_ops = {                                                \
        TYPE_NAME,        NAME##_shade,   NAME##_diffuse_at,  NAME##_reflective_at,        \
        NAME##_transparent_at, NAME##_ior_at, procedural_preview,                          \
    }

/* Marble's weights t[i] = (sin(a[i]) + 1) / 2 rounded to float for n <=
 * PROCEDURAL_WEIGHTS_MAX arguments, bit for bit what libm's sin gives (marble.c): a
 * vector sine of its own where the float cannot differ, else libm's.
 * marble_sine_use_kernel picks its width by name ("base", "avx2", "avx512"; false if
 * this CPU cannot run it): for tests, not while rendering. */
void marble_sine_weights(const double *a, int n, float *t);
bool marble_sine_use_kernel(const char *name);

#endif
