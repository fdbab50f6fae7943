/* Noise (A6): interpolates its two children with the clamped Perlin octave sum as the
 * weight (docs/textures.md). */
#include "rt/perlin.h"
#include "procedural.h"

/* t = clamp(N(q) + 0.5, 0, 1) on m1: the page only says "clamp and interpolate"; the
 * +0.5 offset and the clamp are what reproduce the official scene6_15. */
static inline float noise_t(double n)
{
    double t = n + 0.5;
    return t <= 0.0 ? 0.0f : t >= 1.0 ? 1.0f : (float)t;
}

static float noise_weight(const ProceduralBlend *b, Vec3 p)
{
    Vec3 q = procedural_texture_point(&b->proc, p);
    return noise_t(perlin_octaves_cutoff((double)q.x, (double)q.y, (double)q.z, b->octaves,
                                         procedural_footprint(b)));
}

/* noise_weight at n points, the noise a vector of points at a time: the same bits. */
static void noise_weights(const ProceduralBlend *b, const Vec3 *p, int n, float *t)
{
    double x[PROCEDURAL_WEIGHTS_MAX], y[PROCEDURAL_WEIGHTS_MAX], z[PROCEDURAL_WEIGHTS_MAX],
        nz[PROCEDURAL_WEIGHTS_MAX];
    procedural_octaves_at(b, p, n, false, x, y, z, nz);
    for (int i = 0; i < n; i++)
        t[i] = noise_t(nz[i]);
}

PROCEDURAL_BLEND_OPS(noise, "Noise", noise_weight);

Material *noise_new(Arena *a, const Mat4 *texture_xf, const Material *m1, const Material *m2,
                    int octaves)
{
    return procedural_blend_new(a, &noise_ops, texture_xf, m1, m2, octaves, 0.0f, 0.0f,
                                noise_weights);
}
