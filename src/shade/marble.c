/* Marble (A6): veins from sin(frequency*x + amplitude*N(q)), blending the two children
 * (docs/textures.md). */
#include <math.h>

#include "rt/perlin.h"
#include "procedural.h"

/* t = (sin(f x + a N(x,y,z)) + 1) / 2 on m1; already in [0,1]. The (M+1)/2 mapping is
 * what reproduces the official scene6_15 (clamping M or |M| does not). Double precision
 * like the noise itself. */
static inline float marble_t(const ProceduralBlend *b, double x, double n)
{
    double m = sin((double)b->frequency * x + (double)b->amplitude * n);
    return (float)((m + 1.0) * 0.5);
}

static float marble_weight(const ProceduralBlend *b, Vec3 p)
{
    Vec3 q = procedural_texture_point(&b->proc, p);
    double n = perlin_octaves_cutoff((double)q.x, (double)q.y, (double)q.z, b->octaves,
                                     procedural_footprint(b));
    return marble_t(b, (double)q.x, n);
}

/* marble_weight at n points, the noise a vector of points at a time: the same bits
 * (the footprint is 0, so the cut-off sum is the plain one). */
static void marble_weights(const ProceduralBlend *b, const Vec3 *p, int n, float *t)
{
    double x[PROCEDURAL_WEIGHTS_MAX], y[PROCEDURAL_WEIGHTS_MAX], z[PROCEDURAL_WEIGHTS_MAX],
        nz[PROCEDURAL_WEIGHTS_MAX];
    procedural_octaves_at(b, p, n, false, x, y, z, nz);
    for (int i = 0; i < n; i++)
        t[i] = marble_t(b, x[i], nz[i]);
}

PROCEDURAL_BLEND_OPS(marble, "Marble", marble_weight);

Material *marble_new(Arena *a, const Mat4 *texture_xf, const Material *m1, const Material *m2,
                     int octaves, float frequency, float amplitude)
{
    return procedural_blend_new(a, &marble_ops, texture_xf, m1, m2, octaves, frequency,
                                amplitude, marble_weights);
}
