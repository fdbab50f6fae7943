/* Wood (A6 extra credit): rings around the texture-space y axis, perturbed by noise,
 * blending the two children (docs/textures.md). */
#include <math.h>

#include "rt/perlin.h"
#include "procedural.h"

/* The formula recovered from the official scene6_16 and scene6_18 images:
 *   theta = f (sqrt(x^2 + z^2) + 0.05 y) + a N(x, 0.2 y, z)
 *   v = clamp(sin theta + 0.5, 0, 1),   t = v^2 on m1.
 * Rings around y, slightly slanted along y; the noise is stretched 5x along y (grain). */
static inline float wood_t(const ProceduralBlend *b, double x, double y, double z, double n)
{
    double theta = (double)b->frequency * (sqrt(x * x + z * z) + 0.05 * y) +
                   (double)b->amplitude * n;
    /* Not finite only for a texture point beyond float's range (inf, or 0 * inf):
     * sin 0 there, as Marble does, instead of a NaN weight (t = 1/4). */
    double v = sin(isfinite(theta) ? theta : 0.0) + 0.5;
    v = v <= 0.0 ? 0.0 : v >= 1.0 ? 1.0 : v;
    return (float)(v * v);
}

static float wood_weight(const ProceduralBlend *b, Vec3 p)
{
    Vec3 q = procedural_texture_point(&b->proc, p);
    double x = (double)q.x, y = (double)q.y, z = (double)q.z;
    /* (x, 0.2 y, z) shrinks distances: the footprint bounds the noise's one too. */
    double n = perlin_octaves_cutoff(x, 0.2 * y, z, b->octaves, procedural_footprint(b));
    return wood_t(b, x, y, z, n);
}

/* wood_weight at n points, the noise a vector of points at a time: the same bits. */
static void wood_weights(const ProceduralBlend *b, const Vec3 *p, int n, float *t)
{
    double x[PROCEDURAL_WEIGHTS_MAX], y[PROCEDURAL_WEIGHTS_MAX], z[PROCEDURAL_WEIGHTS_MAX],
        nz[PROCEDURAL_WEIGHTS_MAX];
    procedural_octaves_at(b, p, n, true, x, y, z, nz);
    for (int i = 0; i < n; i++)
        t[i] = wood_t(b, x[i], y[i], z[i], nz[i]);
}

PROCEDURAL_BLEND_OPS(wood, "Wood", wood_weight);

Material *wood_new(Arena *a, const Mat4 *texture_xf, const Material *m1, const Material *m2,
                   int octaves, float frequency, float amplitude)
{
    return procedural_blend_new(a, &wood_ops, texture_xf, m1, m2, octaves, frequency,
                                amplitude, wood_weights);
}
