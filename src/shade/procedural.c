/* Shared parts of the procedural solid textures (docs/textures.md): allocation with the
 * texture matrix copied in, the GL preview rule, and the weighted blend of two children. */
#include "procedural.h"
#include "rt/cpu.h"
#include "rt/perlin.h"

#include <math.h>
#include <stdatomic.h>
#include <stdint.h>
#include <string.h>
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif

/* The footprint of the point being shaded (rt/material.h); 0: full detail. */
static _Thread_local float shading_footprint;

void mat_set_footprint(float world_width) { shading_footprint = world_width; }
float mat_footprint(void) { return shading_footprint; }

/* Serial numbers of the blends, the key of the weight cache below (0 = empty slot). */
static atomic_uint_fast64_t next_serial = 1;

/* Is m's reflective (which = 0) or transparent (1) colour zero at every point? Known
 * for PhongMaterials and for procedurals (from their children, made before them);
 * false for anything else. */
static bool zero_everywhere(const Material *m, int which)
{
    PhongParams pp;
    if (phong_params(m, &pp))
        return v3_is_zero(which == 0 ? pp.reflective : pp.transparent);
    if (m->ops->preview_material == procedural_preview) {
        const Procedural *pr = (const Procedural *)m;
        return which == 0 ? pr->no_reflective : pr->no_transparent;
    }
    return false;
}

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
    b->proc.no_reflective = zero_everywhere(m1, 0) && zero_everywhere(m2, 0);
    b->proc.no_transparent = zero_everywhere(m1, 1) && zero_everywhere(m2, 1);
    b->proc.reaches_phong = false;
    b->octaves = 0;
    b->frequency = b->amplitude = 0.0f;
    b->serial = 0;
    b->xf_scale = 1.0f;
    b->weights = NULL;
    return b;
}

Material *procedural_blend_new(Arena *a, const MaterialOps *ops, const Mat4 *texture_xf,
                               const Material *m1, const Material *m2, int octaves,
                               float frequency, float amplitude, ProceduralWeightsFn weights)
{
    ProceduralBlend *b = procedural_alloc(a, ops, texture_xf, m1, m2);
    if (!b)
        return NULL;
    b->weights = weights;
    b->octaves = octaves < 0 ? 0 : octaves > PROCEDURAL_MAX_OCTAVES ? PROCEDURAL_MAX_OCTAVES
                                                                     : octaves;
    b->frequency = frequency;
    b->amplitude = amplitude;
    b->serial = atomic_fetch_add(&next_serial, 1);
    /* Column j of the linear part is the image of the world axis j; the longest one
     * is the stretch of a world step into texture space (exactly, for the uniform
     * scales and rotations of the course's scenes; within sqrt(3) for any matrix). */
    b->xf_scale = 1.0f;
    if (b->proc.has_xf) {
        float most = 0.0f;
        for (int j = 0; j < 3; j++) {
            const float(*m)[4] = b->proc.xf.m;
            float len = sqrtf(m[0][j] * m[0][j] + m[1][j] * m[1][j] + m[2][j] * m[2][j]);
            most = len > most ? len : most;
        }
        b->xf_scale = most;
    }
    return &b->proc.base;
}

/* One cache per render thread, big enough for a whole ray packet. The packet tracer
 * asks about its (up to 64) hit points in passes -- every point's diffuse colour, then
 * every point's shading per light, then every point's reflective and transparent
 * colours -- so a point's weight must survive 63 other points (and their nested blends
 * and mirror bounces) between two questions; an 8-slot cache missed about 3 times in 4
 * and the noise was computed nearly 4 times per hit. 4-way sets, the newest entry first
 * and the oldest dropped. Entries are keyed by the blend's serial number (never reused
 * within the process, unlike its address once a scene is freed) and the exact bits of
 * the world point and of the footprint; the weight is a pure function of them, so a hit
 * returns exactly what a call would. */
#define WEIGHT_SETS 128
#define WEIGHT_WAYS 4

typedef struct WeightSlot {
    uint64_t serial;        /* 0: empty (serials start at 1) */
    uint32_t bits[3];
    float footprint;        /* the footprint the weight was computed for */
    float weight;
} WeightSlot;

static _Thread_local WeightSlot weight_cache[WEIGHT_SETS][WEIGHT_WAYS];

float procedural_weight(const ProceduralBlend *b, Vec3 p, ProceduralWeightFn weight)
{
    uint32_t bits[3];
    memcpy(&bits[0], &p.x, sizeof bits[0]);
    memcpy(&bits[1], &p.y, sizeof bits[1]);
    memcpy(&bits[2], &p.z, sizeof bits[2]);
    /* The set depends on the point too, so blends nested in each other rarely share a
     * set at the same point. */
    uint64_t h = b->serial * 0x9E3779B97F4A7C15ULL;
    h ^= bits[0] ^ ((uint64_t)bits[1] << 11) ^ ((uint64_t)bits[2] << 23);
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ULL;
    WeightSlot *set = weight_cache[h >> 57 & (WEIGHT_SETS - 1)];
    for (int k = 0; k < WEIGHT_WAYS; k++) {
        const WeightSlot *s = &set[k];
        if (s->serial == b->serial && s->bits[0] == bits[0] && s->bits[1] == bits[1] &&
            s->bits[2] == bits[2] && s->footprint == shading_footprint)
            return s->weight;
    }
    float t = weight(b, p);
    memmove(&set[1], &set[0], (WEIGHT_WAYS - 1) * sizeof set[0]);
    set[0].serial = b->serial;
    memcpy(set[0].bits, bits, sizeof bits);
    set[0].footprint = shading_footprint;
    set[0].weight = t;
    return t;
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

/* The three colour accessors blend alike; only the child's accessor differs. */
typedef Vec3 (*ColorAt)(const Material *m, Vec3 p);

static Vec3 blend_color(const Procedural *pr, float t, Vec3 p, ColorAt at)
{
    if (t >= 1.0f)
        return at(pr->m1, p);
    if (t <= 0.0f)
        return at(pr->m2, p);
    return v3_lerp(at(pr->m1, p), at(pr->m2, p), t);
}

Vec3 procedural_blend_diffuse(const Procedural *pr, float t, Vec3 p)
{
    return blend_color(pr, t, p, mat_diffuse_at);
}

Vec3 procedural_blend_reflective(const Procedural *pr, float t, Vec3 p)
{
    return blend_color(pr, t, p, mat_reflective_at);
}

Vec3 procedural_blend_transparent(const Procedural *pr, float t, Vec3 p)
{
    return blend_color(pr, t, p, mat_transparent_at);
}

float procedural_blend_ior(const Procedural *pr, float t, Vec3 p)
{
    /* Interpolated like the colours (no official image shows a refracting blend). */
    if (t >= 1.0f)
        return mat_ior_at(pr->m1, p);
    if (t <= 0.0f)
        return mat_ior_at(pr->m2, p);
    return t * mat_ior_at(pr->m1, p) + (1.0f - t) * mat_ior_at(pr->m2, p);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* procedural_octaves_at's points eight at a time, for CPUs with AVX2 (no FMA, so
 * nothing can fuse): p's 24 floats in three loads, split into x, y and z by blends and
 * permutes, then mat4_point's products and sums in its order and the conversions to
 * double, the same IEEE operations in every lane as the loop. Returns the points done
 * (a multiple of 8). */
__attribute__((target("avx2"))) static int texture_points_avx2(const Procedural *pr,
                                                               const Vec3 *p, int n,
                                                               double *x, double *y,
                                                               double *z, double *y5)
{
    _Static_assert(sizeof(Vec3) == 3 * sizeof(float), "a point is three packed floats");
    const float *f = (const float *)(const void *)p;
    /* a: x0 y0 z0 x1 y1 z1 x2 y2, b: z2 x3 y3 z3 x4 y4 z4 x5, c: y5 z5 x6 y6 z6 x7 y7 z7.
     * Blended, each lane holds one point's coordinate (x: a0 b1 c2 a3 b4 c5 a6 b7, the
     * points 0 3 6 1 4 7 2 5), which the permute puts in order. */
    const __m256i px = _mm256_setr_epi32(0, 3, 6, 1, 4, 7, 2, 5);
    const __m256i py = _mm256_setr_epi32(1, 4, 7, 2, 5, 0, 3, 6);
    const __m256i pz = _mm256_setr_epi32(2, 5, 0, 3, 6, 1, 4, 7);
    const float (*m)[4] = pr->xf.m;
    int i = 0;
    for (; i + 8 <= n; i += 8) {
        __m256 a = _mm256_loadu_ps(f + 3 * i), b = _mm256_loadu_ps(f + 3 * i + 8),
               c = _mm256_loadu_ps(f + 3 * i + 16);
        __m256 vx = _mm256_permutevar8x32_ps(
            _mm256_blend_ps(_mm256_blend_ps(a, b, 0x92), c, 0x24), px);
        __m256 vy = _mm256_permutevar8x32_ps(
            _mm256_blend_ps(_mm256_blend_ps(a, b, 0x24), c, 0x49), py);
        __m256 vz = _mm256_permutevar8x32_ps(
            _mm256_blend_ps(_mm256_blend_ps(a, b, 0x49), c, 0x92), pz);
        __m256 q[3] = {vx, vy, vz};
        if (pr->has_xf)
            for (int r = 0; r < 3; r++)
                q[r] = _mm256_add_ps(
                    _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(_mm256_set1_ps(m[r][0]), vx),
                                                _mm256_mul_ps(_mm256_set1_ps(m[r][1]), vy)),
                                  _mm256_mul_ps(_mm256_set1_ps(m[r][2]), vz)),
                    _mm256_set1_ps(m[r][3]));
        double *out[3] = {x + i, y + i, z + i};
        for (int r = 0; r < 3; r++) {
            _mm256_storeu_pd(out[r], _mm256_cvtps_pd(_mm256_castps256_ps128(q[r])));
            _mm256_storeu_pd(out[r] + 4, _mm256_cvtps_pd(_mm256_extractf128_ps(q[r], 1)));
        }
        _mm256_storeu_pd(y5 + i, _mm256_mul_pd(_mm256_set1_pd(0.2), _mm256_loadu_pd(y + i)));
        _mm256_storeu_pd(y5 + i + 4,
                         _mm256_mul_pd(_mm256_set1_pd(0.2), _mm256_loadu_pd(y + i + 4)));
    }
    return i;
}
#define HAVE_TEXTURE_POINTS_AVX2 1
#endif

/* Whether procedural_octaves_at may take the AVX2 points (tests turn it off). Written
 * only by procedural_points_use_kernel, before any render thread. */
static bool points_vector = true;

bool procedural_points_use_kernel(const char *isa)
{
    if (!strcmp(isa, "base")) {
        points_vector = false;
        return true;
    }
#ifdef HAVE_TEXTURE_POINTS_AVX2
    if (!strcmp(isa, "avx2") && cpu_has_avx2()) {
        points_vector = true;
        return true;
    }
#endif
    return false;
}

void procedural_octaves_at(const ProceduralBlend *b, const Vec3 *p, int n, bool grain,
                           double *x, double *y, double *z, double *noise)
{
    double y5[PROCEDURAL_WEIGHTS_MAX];
    int i0 = 0;
#ifdef HAVE_TEXTURE_POINTS_AVX2
    /* Asked on every call (a load). */
    if (points_vector && cpu_has_avx2())
        i0 = texture_points_avx2(&b->proc, p, n, x, y, z, y5);
#endif
    for (int i = i0; i < n; i++) {
        Vec3 q = procedural_texture_point(&b->proc, p[i]);
        x[i] = (double)q.x;
        y[i] = (double)q.y;
        z[i] = (double)q.z;
        y5[i] = 0.2 * y[i];
    }
    perlin_octaves_lanes(x, grain ? y5 : y, z, n, b->octaves, noise);
}

/* A blend with a weights function, both of whose children are PhongMaterials. */
static const ProceduralBlend *phong_blend(const Material *m)
{
    if (m->ops->preview_material != procedural_preview)
        return NULL;
    const ProceduralBlend *b = (const ProceduralBlend *)m;
    if (!b->weights || !phong_params_of(b->proc.m1) || !phong_params_of(b->proc.m2))
        return NULL;
    return b;
}

bool mat_phong_blend(const Material *m, const PhongParams **p1, const PhongParams **p2,
                     bool *plain)
{
    const ProceduralBlend *b = phong_blend(m);
    if (!b)
        return false;
    *p1 = phong_params_of(b->proc.m1);
    *p2 = phong_params_of(b->proc.m2);
    *plain = b->proc.no_reflective && b->proc.no_transparent;
    return true;
}

void mat_blend_weights(const Material *m, const Vec3 *p, int n, float *t)
{
    const ProceduralBlend *b = (const ProceduralBlend *)m;
    for (int i = 0; i < n; i += PROCEDURAL_WEIGHTS_MAX) {
        int k = n - i < PROCEDURAL_WEIGHTS_MAX ? n - i : PROCEDURAL_WEIGHTS_MAX;
        b->weights(b, p + i, k, t + i);
    }
}
