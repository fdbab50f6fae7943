/* Marble (A6): veins from sin(frequency*x + amplitude*N(q)), blending the two children
 * (docs/textures.md). */
#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <string.h>

#include "rt/perlin.h"
#include "procedural.h"
#include "rt/cpu.h"

/* The sine's argument f x + a N, 0 where it is not finite: a texture point beyond
 * float's range (a texture Transform "UniformScale 1e38" at x = 10) is infinite, and
 * sin(inf) or 0 * inf is NaN, which made the material's every colour NaN (written as
 * black, also in a mirror's reflection of it). The pattern means nothing out there;
 * sin 0 = 0 gives the even mix, t = 1/2. */
static inline double marble_arg(const ProceduralBlend *b, double x, double n)
{
    double arg = (double)b->frequency * x + (double)b->amplitude * n;
    return isfinite(arg) ? arg : 0.0;
}

/* t = (sin(f x + a N(x,y,z)) + 1) / 2 on m1; already in [0,1]. The (M+1)/2 mapping is
 * what reproduces the official scene6_15 (clamping M or |M| does not). Double precision
 * like the noise itself. */
static inline float marble_t(const ProceduralBlend *b, double x, double n)
{
    double m = sin(marble_arg(b, x, n));
    return (float)((m + 1.0) * 0.5);
}

static float marble_weight(const ProceduralBlend *b, Vec3 p)
{
    Vec3 q = procedural_texture_point(&b->proc, p);
    double n = perlin_octaves_cutoff((double)q.x, (double)q.y, (double)q.z, b->octaves,
                                     procedural_footprint(b));
    return marble_t(b, (double)q.x, n);
}

/* Marble's sine a vector of arguments at a time (marble_sine_kernel.h) at the width
 * of each instruction set: two doubles in the baseline's vectors (SSE2 on x86-64), four
 * in AVX2, eight in AVX-512; the widest this CPU runs is chosen once. */
#define MARBLE_SIN_MAX 1e5
typedef void (*MarbleSineFn)(const double *, int, double *);
#define MS_NAME marble_sines_base
#define MS_W 2
#include "marble_sine_kernel.h"
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define MARBLE_WIDE 1
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif
#define MS_NAME marble_sines_avx2
#define MS_W 4
#include "marble_sine_kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#pragma clang attribute push(__attribute__((target("avx512f"))), apply_to = function)
#else
#pragma GCC pop_options
#pragma GCC push_options
#pragma GCC target("avx512f")
#endif
#define MS_NAME marble_sines_avx512
#define MS_W 8
#include "marble_sine_kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif

static MarbleSineFn marble_sines = marble_sines_base;
static pthread_once_t marble_once = PTHREAD_ONCE_INIT;

static const struct {
    const char *isa;
    MarbleSineFn fn;
} marble_kernels[] = {
    {"base", marble_sines_base},
#if defined(MARBLE_WIDE)
    {"avx2", marble_sines_avx2},
    {"avx512", marble_sines_avx512},
#endif
};

static bool marble_set(const char *name)
{
    for (size_t i = 0; i < sizeof marble_kernels / sizeof marble_kernels[0]; i++)
        if (!strcmp(name, marble_kernels[i].isa) && cpu_runs(name)) {
            marble_sines = marble_kernels[i].fn;
            return true;
        }
    return false;
}

static void marble_choose(void)
{
    if (!marble_set("avx512"))
        marble_set("avx2");
}

bool marble_sine_use_kernel(const char *name)
{
    pthread_once(&marble_once, marble_choose);
    return marble_set(name);
}

/* t[i] = (float)((sin(a[i]) + 1) / 2) with libm's sin, bit for bit, for n <=
 * PROCEDURAL_WEIGHTS_MAX: the kernel's double lies within 5e-16 of (sin(a) + 1) / 2
 * and libm's (under one unit in the last place of sin, then the add's rounding)
 * within 1.2e-16, so when the kernel's lies more than 1e-15 inside the interval that
 * rounds to its float (half the spacing of the floats below it), libm's rounds to the
 * same float. Else (and for |a| beyond MARBLE_SIN_MAX, NaN, or weights that are not
 * positive normal floats) libm's sin itself. */
void marble_sine_weights(const double *a, int n, float *t)
{
    enum { PAD = 8 }; /* the widest kernel's doubles */
    double arg[PROCEDURAL_WEIGHTS_MAX], td[PROCEDURAL_WEIGHTS_MAX];
    _Static_assert(PROCEDURAL_WEIGHTS_MAX % PAD == 0, "whole vectors");
    int m = (n + PAD - 1) / PAD * PAD;
    memcpy(arg, a, (size_t)n * sizeof *arg);
    for (int i = n; i < m; i++)
        arg[i] = 0.0;
    pthread_once(&marble_once, marble_choose);
    marble_sines(arg, m, td);
    for (int i = 0; i < n; i++) {
        float tf = (float)td[i];
        uint32_t bits;
        memcpy(&bits, &tf, sizeof bits);
        uint32_t e = bits >> 23 & 0xff;
        if (fabs(a[i]) <= MARBLE_SIN_MAX && e != 0 && e != 0xff && !(bits >> 31)) {
            /* Half the spacing of the floats below tf (the smaller one when tf is a
             * power of two): 2^(e - 127 - 24), or 2^(e - 127 - 25). */
            uint64_t hb = (uint64_t)(e - 127 - 24 + 1023 - ((bits & 0x7fffff) == 0)) << 52;
            double half;
            memcpy(&half, &hb, sizeof half);
            if (fabs(td[i] - (double)tf) < half - 1e-15) {
                t[i] = tf;
                continue;
            }
        }
        t[i] = (float)((sin(a[i]) + 1.0) * 0.5);
    }
}

/* marble_weight at n points, the noise a vector of points at a time: the same bits
 * (the footprint is 0, so the cut-off sum is the plain one; marble_t's argument, its
 * sine by marble_sine_weights). */
static void marble_weights(const ProceduralBlend *b, const Vec3 *p, int n, float *t)
{
    double x[PROCEDURAL_WEIGHTS_MAX], y[PROCEDURAL_WEIGHTS_MAX], z[PROCEDURAL_WEIGHTS_MAX],
        nz[PROCEDURAL_WEIGHTS_MAX];
    procedural_octaves_at(b, p, n, false, x, y, z, nz);
    double a[PROCEDURAL_WEIGHTS_MAX];
    for (int i = 0; i < n; i++)
        a[i] = marble_arg(b, x[i], nz[i]);
    marble_sine_weights(a, n, t);
}

PROCEDURAL_BLEND_OPS(marble, "Marble", marble_weight);

Material *marble_new(Arena *a, const Mat4 *texture_xf, const Material *m1, const Material *m2,
                     int octaves, float frequency, float amplitude)
{
    return procedural_blend_new(a, &marble_ops, texture_xf, m1, m2, octaves, frequency,
                                amplitude, marble_weights);
}
