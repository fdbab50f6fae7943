/* Reconstruction filters (A7 and its extra credit): box, tent, Gaussian, Mitchell-
 * Netravali. One ops table each, looked up by the name the option carries. */
#include "rt/filter.h"
#include "rt/cpu.h"

#include <math.h>
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif
#include <stdint.h>
#include <stdio.h>
#include <string.h>

/* A square of half-width r, edges included, compared in float: the course's filter
 * pictures draw the edge samples white. */
static float box_weight(const Filter *f, float x, float y)
{
    return fabsf(x) <= f->r && fabsf(y) <= f->r ? 1.0f : 0.0f;
}

static float box_weight_1d(const Filter *f, float x) { return fabsf(x) <= f->r ? 1.0f : 0.0f; }

static double radius_extent(const Filter *f) { return (double)f->r; }

/* A cone: radial, not separable. d in float, 1 - d/r in double (this mix reproduces
 * every byte of the course's tent pictures, e.g. exactly 85/255 at d = 1, r = 1.5). */
static float tent_weight(const Filter *f, float x, float y)
{
    float d = sqrtf(x * x + y * y);
    if (!(d < f->r))
        return 0.0f;
    return (float)(1.0 - (double)d / (double)f->r);
}

/* Not cut off at 2 sigma: the course's pictures keep the small weights in the corners
 * of the support square. */
static float gaussian_weight(const Filter *f, float x, float y)
{
    float d2 = x * x + y * y;
    double s = (double)f->r;
    return (float)exp(-(double)d2 / (2.0 * s * s));
}

/* The separable Gaussian of the film (random positions: each sample's 2(2R+1) weights
 * towards the pixels around it) in float, exp by filter_expf's operations (at R = 1
 * and 2 two exps a position and factors between its weights: FILTER_STEPS); the 2-D
 * weight above (fixed positions and the filter pictures, which reproduce the course's
 * images to the bit) keeps libm. GCC/clang vector extensions: four lanes in the plain
 * build (SSE2), eight in the AVX2 functions, sixteen in the AVX-512 ones. Every lane of
 * every width runs the same IEEE single operations in the same order (this file is
 * built with -ffp-contract=off, so no multiply and add is fused, and nothing here is an
 * FMA intrinsic): a weight's bits depend neither on its lane nor on the width nor on
 * the CPU, so neither do the images (test_gaussian_paths). Until 2026-11 the weights
 * were the double exp rounded to float, which needed a double exp with a cheaper
 * estimate and a fallback near float rounding boundaries in every vector path; this
 * float exp is within about an ulp of that, needs no fallback, and took a 16-sample
 * jittered Gaussian render of course line 17a from 186.4 to 181.6 ms (bench/REPORT.txt). */
typedef float V4f __attribute__((vector_size(16)));
typedef int32_t V4i __attribute__((vector_size(16)));
typedef double V4d __attribute__((vector_size(32)));
typedef float V8f __attribute__((vector_size(32)));
typedef int32_t V8i __attribute__((vector_size(32)));
typedef float V16f __attribute__((vector_size(64)));
typedef int32_t V16i __attribute__((vector_size(64)));

/* exp(t) for t <= 0, in float lanes. t below -104 (exp under half the smallest
 * subnormal float) and NaN are taken as -104, whose exp rounds to 0. k = round(t / ln 2)
 * from the rounding of t log2(e) + 1.5 * 2^23, whose low mantissa bits hold it (no
 * conversion instruction: every width does the same); r = t - k ln 2 with ln 2 split in
 * two (Cody and Waite: the high part has 9 significant bits, so k times it is exact for
 * the |k| <= 150 here, and t less it is exact), |r| <= ln(2)/2 + tiny; exp(r) by its
 * Taylor series to degree 7 (truncation r^8/8! e^|r| below 7.3e-9 relative, a tenth of
 * an ulp), its terms in pairs and then in powers of r^2 with r + 1 added last: a
 * shorter chain than Horner's, as accurate (within an ulp; the loops were latency-bound
 * with Horner's); then times 2^k as two normal powers of two, 2^(k-h) and 2^h with
 * h = floor(k/2) (both at least 2^-75): p 2^(k-h) is exact and the second product
 * rounds once, into the subnormals too (t < -87.3), as one product by 2^k would. At
 * t = 0 exactly 1. */
#define FILTER_EXPF(NAME, VF, VI, ...)                                                     \
    __attribute__((always_inline __VA_ARGS__)) static inline VF NAME##_core(VF t, VI *kp)  \
    {                                                                                      \
        VF kf = t * 0x1.715476p0f + 0x1.8p23f;                                             \
        VI k = (VI)kf - 0x4b400000; /* the bits of 1.5 * 2^23 */                           \
        kf -= 0x1.8p23f;                                                                   \
        VF r = t - kf * 0x1.63p-1f;                                                        \
        r = r - kf * -0x1.bd0106p-13f;                                                     \
        VF r2 = r * r;                                                                     \
        VF p23 = r * 0x1.555556p-3f + 0.5f;                                                \
        VF p45 = r * 0x1.111112p-7f + 0x1.555556p-5f;                                      \
        VF p67 = r * 0x1.a01a02p-13f + 0x1.6c16c2p-10f;                                    \
        VF q = (p67 * r2 + p45) * r2 + p23;                                                \
        *kp = k;                                                                           \
        return (q * r2 + r) + 1.0f;                                                        \
    }                                                                                      \
    __attribute__((always_inline __VA_ARGS__)) static inline VF NAME(VF t)                \
    {                                                                                      \
        const VF lo = (VF){0} - 104.0f;                                                    \
        VI keep = t >= lo; /* all ones where t >= -104 (false for NaN) */                  \
        t = (VF)(((VI)t & keep) | ((VI)lo & ~keep));                                       \
        VI k;                                                                              \
        VF p = NAME##_core(t, &k);                                                         \
        VI h = k >> 1;                                                                     \
        VF s1 = (VF)((k - h + 127) << 23), s2 = (VF)((h + 127) << 23);                     \
        return p * s1 * s2;                                                                \
    }                                                                                      \
    /* The same bits for -87 <= t <= 88 (no clamp; 2^k normal, so p 2^k rounds once as    \
     * p 2^(k-h) 2^h does): the Gaussian's steps, whose arguments stay within +-16. */     \
    __attribute__((always_inline __VA_ARGS__)) static inline VF NAME##_mid(VF t)          \
    {                                                                                      \
        VI k;                                                                              \
        VF p = NAME##_core(t, &k);                                                         \
        return p * (VF)((k + 127) << 23);                                                  \
    }

/* exp(x^2 times -1/(2 sigma^2)), that factor rounded to float once (gauss_factor). */
#define FILTER_GAUSSIAN(GAUSS, EXPF, VF, ...)                                              \
    __attribute__((always_inline __VA_ARGS__)) static inline VF GAUSS(VF x, float neg_inv) \
    {                                                                                      \
        return EXPF((x * x) * neg_inv);                                                    \
    }

static float gauss_factor(const Filter *f) { return f->gauss_ni; }

/* The film's weights of positions p towards the 2R + 1 pixels around at R = 1 and 2,
 * two exps a position instead of 2R + 1. With u = p - 0.5 (one float subtraction, the
 * same float as the argument towards the pixel itself), ni = gauss_factor and g(x) =
 * exp(ni x^2): g(u - j) = g(u) exp(j^2 ni) E^j and g(u + j) = g(u) exp(j^2 ni) / E^j,
 * E = exp(-2 ni u). So the weights towards pixels -j and +j are the offsets u - j and
 * u + j exactly (the other paths round p - 0.5 - R + k to float: the same for the
 * centre, within an ulp of the offset for the others). exp(ni) and exp(4 ni) are libm's,
 * rounded to float once (filter_init); E^2 is E E. Accuracy (test_gaussian_steps):
 * within a few ulps of the exact Gaussian at those offsets, as the three exps were at
 * theirs. Range: the steps need ni >= -8 (sigma >= 1/4: every R = 1 or 2 the film uses)
 * and |u| <= 1/2 (positions in [0, 1]: the film's), so that -2 ni u lies in [-8, 8], g
 * in [e^-2, 1] and every product above e^-50: all normal, no clamp (expf's _mid form).
 * A lane outside (NaN, a position far off) takes the arguments p + (k - R - 0.5) in
 * float and three or five exps, the other gaussian_offsets paths' bits for it. Every
 * width runs this macro's float operations in one order: the same bits per lane. ALL:
 * whether every lane of a mask is set. */
#define FILTER_STEPS(NAME, EXPF, GAUSS, VF, VI, ALL, ...)                                  \
    __attribute__((always_inline __VA_ARGS__)) static inline void NAME(                    \
        VF p, int R, float ni, float e1, float e4, VF *w)                                  \
    {                                                                                      \
        VF u = p - 0.5f;                                                                   \
        VI in = (u >= -0.5f) & (u <= 0.5f); /* false for NaN */                            \
        u = (VF)((VI)u & in);               /* 0 where not: no overflow below */           \
        VF g = EXPF##_mid((u * u) * ni);                                                   \
        VF e = EXPF##_mid(u * (-2.0f * ni)); /* -2 ni exact */                             \
        VF h1 = g * e1;                                                                    \
        if (R == 1) {                                                                      \
            w[0] = h1 * e;                                                                 \
            w[1] = g;                                                                      \
            w[2] = h1 / e;                                                                 \
        } else {                                                                           \
            VF h4 = g * e4, e2 = e * e;                                                    \
            w[0] = h4 * e2;                                                                \
            w[1] = h1 * e;                                                                 \
            w[2] = g;                                                                      \
            w[3] = h1 / e;                                                                 \
            w[4] = h4 / e2;                                                                \
        }                                                                                  \
        if (!ALL(in)) {                                                                    \
            FILTER_STEP_OUT(0, VF, VI, GAUSS);                                             \
            FILTER_STEP_OUT(1, VF, VI, GAUSS);                                             \
            FILTER_STEP_OUT(2, VF, VI, GAUSS);                                             \
            if (R == 2) {                                                                  \
                FILTER_STEP_OUT(3, VF, VI, GAUSS);                                         \
                FILTER_STEP_OUT(4, VF, VI, GAUSS);                                         \
            }                                                                              \
        }                                                                                  \
    }
/* Lane by lane: weight k as it is where in is set, else by its float argument. Written
 * out (not a loop over k: GCC kept w[] in memory then). */
#define FILTER_STEP_OUT(k, VF, VI, GAUSS)                                                  \
    w[k] = (VF)(((VI)w[k] & in) | ((VI)GAUSS(p + ((float)((k) - R) - 0.5f), ni) & ~in))

/* Whether R's weights go by FILTER_STEPS. */
static bool gaussian_steps_ok(const Filter *f, int R)
{
    return (R == 1 || R == 2) && gauss_factor(f) >= -8.0f;
}

static inline bool all4(V4i m) { return (m[0] & m[1] & m[2] & m[3]) != 0; }

FILTER_EXPF(expf4, V4f, V4i, )
FILTER_GAUSSIAN(gaussian4, expf4, V4f, )
FILTER_STEPS(steps4, expf4, gaussian4, V4f, V4i, all4, )

float filter_expf(float t)
{
    V4f v = {t, t, t, t};
    return expf4(v)[0];
}

/* The plain build's batch, four lanes a step; a last partial group through a padded
 * copy. */
static void gaussian_batch(const Filter *f, const float *x, float *w, int n)
{
    float ni = gauss_factor(f);
    for (int i = 0; i < n; i += 4) {
        int m = n - i < 4 ? n - i : 4;
        V4f a = {0.0f};
        memcpy(&a, x + i, (size_t)m * sizeof x[0]);
        a = gaussian4(a, ni);
        memcpy(w + i, &a, (size_t)m * sizeof w[0]);
    }
}

/* gaussian_offsets' FILTER_STEPS, R a constant where called (the stores unrolled). */
__attribute__((always_inline)) static inline void gaussian_steps_plain(const Filter *f,
                                                                       const float *pos, int n,
                                                                       int R, float *w,
                                                                       size_t plane)
{
    float ni = gauss_factor(f);
    for (int i = 0; i < n; i += 4) {
        int m = n - i < 4 ? n - i : 4;
        V4f p = {0.0f}, g[5];
        if (m == 4) /* one load (a copy of m floats into p stalled the load after) */
            memcpy(&p, pos + i, sizeof p);
        else
            memcpy(&p, pos + i, (size_t)m * sizeof pos[0]);
        steps4(p, R, ni, f->gauss_e1, f->gauss_e4, g);
        if (m == 4) {
            for (int k = 0; k <= 2 * R; k++)
                memcpy(w + (size_t)k * plane + (size_t)i, &g[k], sizeof g[k]);
        } else {
            for (int k = 0; k <= 2 * R; k++)
                memcpy(w + (size_t)k * plane + (size_t)i, &g[k], (size_t)m * sizeof w[0]);
        }
    }
}

/* filter_weights_1d_offsets for the Gaussian: four positions at a time, R = 1 and 2 by
 * FILTER_STEPS, other R by their 2R+1 arguments made in the lanes (the same double
 * operations and one rounding to float as the generic loop); the weights stored
 * straight into the planes. */
static void gaussian_offsets(const Filter *f, const float *pos, int n, int R, float *w,
                             size_t plane)
{
    if (gaussian_steps_ok(f, R)) {
        if (R == 1)
            gaussian_steps_plain(f, pos, n, 1, w, plane);
        else
            gaussian_steps_plain(f, pos, n, 2, w, plane);
        return;
    }
    float ni = gauss_factor(f);
    for (int i = 0; i < n; i += 4) {
        int m = n - i < 4 ? n - i : 4;
        V4f p = {0.0f};
        memcpy(&p, pos + i, (size_t)m * sizeof pos[0]);
        V4d b = __builtin_convertvector(p, V4d) - 0.5 - (double)R;
        for (int k = 0; k <= 2 * R; k++) {
            V4f g = gaussian4(__builtin_convertvector(b + (double)k, V4f), ni);
            memcpy(w + (size_t)k * plane + (size_t)i, &g, (size_t)m * sizeof w[0]);
        }
    }
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define FILTER_AVX512 target("avx512f,avx512vl,avx512bw,avx512dq")
#define FILTER_AVX2 target("avx2")

FILTER_EXPF(expf16, V16f, V16i, , FILTER_AVX512)
FILTER_GAUSSIAN(gaussian16, expf16, V16f, , FILTER_AVX512)
FILTER_EXPF(expf8, V8f, V8i, , FILTER_AVX2)
FILTER_GAUSSIAN(gaussian8, expf8, V8f, , FILTER_AVX2)

__attribute__((always_inline, FILTER_AVX512)) static inline bool all16(V16i m)
{
    return _mm512_cmpeq_epi32_mask((__m512i)m, _mm512_setzero_si512()) == 0;
}

__attribute__((always_inline, FILTER_AVX2)) static inline bool all8(V8i m)
{
    return _mm256_movemask_ps((__m256)m) == 0xff;
}

FILTER_STEPS(steps16, expf16, gaussian16, V16f, V16i, all16, , FILTER_AVX512)
FILTER_STEPS(steps8, expf8, gaussian8, V8f, V8i, all8, , FILTER_AVX2)

/* How the vector paths make a position's weights: FILTER_STEPS (R = 1, 2), or the
 * arguments by FILTER_FLOAT_ARG_R's float add or by the double steps. */
enum { ARG_STEPS, ARG_FLOAT, ARG_DOUBLE };

/* The batch sixteen weights a step; the last group masked (its padding lanes compute
 * exp(0)). */
__attribute__((FILTER_AVX512)) static void gaussian_batch_avx512(const Filter *f,
                                                                 const float *x, float *w,
                                                                 int n)
{
    float ni = gauss_factor(f);
    for (int i = 0; i < n; i += 16) {
        __mmask16 m = n - i >= 16 ? (__mmask16)0xffff : (__mmask16)((1u << (n - i)) - 1);
        V16f g = gaussian16((V16f)_mm512_maskz_loadu_ps(m, x + i), ni);
        _mm512_mask_storeu_ps(w + i, m, (__m512)g);
    }
}

/* The arguments towards the pixels around, in the vector paths. For R <=
 * FILTER_FLOAT_ARG_R the argument towards pixel k - R is p + (k - R - 0.5) in one float
 * add, the exact sum rounded to float once: the other paths' ((double)p - 0.5 - R) + k
 * rounded to float is the same float for every float p at R = 1 and 2 (all 2^32 bit
 * patterns compared, bench/REPORT.txt film20; those double steps are exact unless p is
 * tiny or huge against R + 0.5, and then no float rounding boundary lies within their
 * error). Not for large R: at R = 16, with the sum near 16.5, a double step rounds p =
 * 2^-26 (1 + 2^-23) onto the float halfway point -0.5 + 2^-26 (two such p of all
 * 2^32), so larger R make the arguments by the double steps (vcvtpd2ps, as the vector
 * extension's conversion; k is an exact small integer in double). */
enum { FILTER_FLOAT_ARG_R = 2 };

/* The argument towards pixel k - R of sixteen positions p (b0, b1: its halves as
 * (double)p - 0.5 - R) by the double steps. */
__attribute__((always_inline, FILTER_AVX512)) static inline __m512 gaussian_arg16(__m512d b0,
                                                                                __m512d b1,
                                                                                int k)
{
    __m512d kv = _mm512_set1_pd((double)k);
    return _mm512_insertf32x8(_mm512_castps256_ps512(_mm512_cvtpd_ps(_mm512_add_pd(b0, kv))),
                              _mm512_cvtpd_ps(_mm512_add_pd(b1, kv)), 1);
}

/* Sixteen weights of lanes m: two groups of eight bstride floats apart (8: one row). */
__attribute__((always_inline, FILTER_AVX512)) static inline void
gaussian_store16(float *dst, __mmask16 m, size_t bstride, __m512 g)
{
    if (bstride == 8) {
        _mm512_mask_storeu_ps(dst, m, g);
    } else {
        _mm256_mask_storeu_ps(dst, (__mmask8)m, _mm512_castps512_ps256(g));
        _mm256_mask_storeu_ps(dst + bstride, (__mmask8)(m >> 8), _mm512_extractf32x8_ps(g, 1));
    }
}

/* gaussian_offsets' loop in AVX-512, sixteen positions a step, the last masked (its
 * padding lanes compute the weights of position 0). The groups of eight positions lie
 * bstride floats apart in w (8: one row; filter_weights_1d_blocks: the film's tile
 * rows). */
__attribute__((always_inline, FILTER_AVX512)) static inline void
gaussian_offsets16(const Filter *f, const float *pos, int n, int R, float *w, size_t plane,
                   size_t bstride, int mode)
{
    float ni = gauss_factor(f);
    bool float_arg = mode == ARG_FLOAT;
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512d half = _mm512_set1_pd(0.5), dr = _mm512_set1_pd((double)R);
    for (int i = 0; i < n; i += 16) {
        __mmask16 m = n - i >= 16 ? (__mmask16)0xffff : (__mmask16)((1u << (n - i)) - 1);
        __m512 p = _mm512_maskz_loadu_ps(m, pos + i);
        if (mode == ARG_STEPS) {
            V16f g[5];
            steps16((V16f)p, R, ni, f->gauss_e1, f->gauss_e4, g);
            float *dst = w + (size_t)(i / 8) * bstride;
            gaussian_store16(dst, m, bstride, (__m512)g[0]);
            gaussian_store16(dst + plane, m, bstride, (__m512)g[1]);
            gaussian_store16(dst + 2 * plane, m, bstride, (__m512)g[2]);
            if (R == 2) {
                gaussian_store16(dst + 3 * plane, m, bstride, (__m512)g[3]);
                gaussian_store16(dst + 4 * plane, m, bstride, (__m512)g[4]);
            }
            continue;
        }
        __m512 c = _mm512_set1_ps(-(float)R - 0.5f); /* k - R - 0.5, exact */
        __m512d b0 = _mm512_setzero_pd(), b1 = b0;
        if (!float_arg) {
            b0 = _mm512_sub_pd(_mm512_sub_pd(_mm512_cvtps_pd(_mm512_castps512_ps256(p)), half), dr);
            b1 = _mm512_sub_pd(_mm512_sub_pd(_mm512_cvtps_pd(_mm512_extractf32x8_ps(p, 1)), half),
                               dr);
        }
        /* Three planes a step (k, k + 1, k + 2; past 2R computed and not stored): their
         * exp chains interleave (a plane at a time, the chain's latency was the loop's
         * time: the film's calls have 2 x 16 groups of eight). */
        for (int k = 0; k <= 2 * R; k += 3) {
            __m512 x0, x1, x2;
            if (float_arg) {
                x0 = _mm512_add_ps(p, c);
                c = _mm512_add_ps(c, one);
                x1 = _mm512_add_ps(p, c);
                c = _mm512_add_ps(c, one);
                x2 = _mm512_add_ps(p, c);
                c = _mm512_add_ps(c, one);
            } else {
                x0 = gaussian_arg16(b0, b1, k);
                x1 = gaussian_arg16(b0, b1, k + 1);
                x2 = gaussian_arg16(b0, b1, k + 2);
            }
            __m512 g0 = (__m512)gaussian16((V16f)x0, ni);
            __m512 g1 = (__m512)gaussian16((V16f)x1, ni);
            __m512 g2 = (__m512)gaussian16((V16f)x2, ni);
            float *dst = w + (size_t)k * plane + (size_t)(i / 8) * bstride;
            gaussian_store16(dst, m, bstride, g0);
            if (k + 1 <= 2 * R)
                gaussian_store16(dst + plane, m, bstride, g1);
            if (k + 2 <= 2 * R)
                gaussian_store16(dst + 2 * plane, m, bstride, g2);
        }
    }
}

__attribute__((FILTER_AVX512)) static void gaussian_offsets_avx512(const Filter *f,
                                                                   const float *pos, int n,
                                                                   int R, float *w,
                                                                   size_t plane)
{
    if (gaussian_steps_ok(f, R) && R == 1) /* R a constant in the loop: unrolled */
        gaussian_offsets16(f, pos, n, 1, w, plane, 8, ARG_STEPS);
    else if (gaussian_steps_ok(f, R))
        gaussian_offsets16(f, pos, n, 2, w, plane, 8, ARG_STEPS);
    else if (R <= FILTER_FLOAT_ARG_R)
        gaussian_offsets16(f, pos, n, R, w, plane, 8, ARG_FLOAT);
    else
        gaussian_offsets16(f, pos, n, R, w, plane, 8, ARG_DOUBLE);
}

/* filter_weights_1d_blocks for the Gaussian with AVX-512: two groups a step. */
__attribute__((FILTER_AVX512)) static void gaussian_blocks_avx512(const Filter *f,
                                                                  const float *pos, int nblk,
                                                                  int R, float *w, size_t plane,
                                                                  size_t bstride)
{
    if (gaussian_steps_ok(f, R) && R == 1) /* R a constant in the loop: unrolled */
        gaussian_offsets16(f, pos, 8 * nblk, 1, w, plane, bstride, ARG_STEPS);
    else if (gaussian_steps_ok(f, R))
        gaussian_offsets16(f, pos, 8 * nblk, 2, w, plane, bstride, ARG_STEPS);
    else if (R <= FILTER_FLOAT_ARG_R)
        gaussian_offsets16(f, pos, 8 * nblk, R, w, plane, bstride, ARG_FLOAT);
    else
        gaussian_offsets16(f, pos, 8 * nblk, R, w, plane, bstride, ARG_DOUBLE);
}

/* The AVX2 batch: eight weights a step, the last group through masked loads and
 * stores. */
__attribute__((FILTER_AVX2)) static void gaussian_batch_avx2(const Filter *f, const float *x,
                                                             float *w, int n)
{
    float ni = gauss_factor(f);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (int i = 0; i < n; i += 8) {
        __m256i m = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - i), lane);
        V8f g = gaussian8((V8f)_mm256_maskload_ps(x + i, m), ni);
        _mm256_maskstore_ps(w + i, m, (__m256)g);
    }
}

/* gaussian_arg16 in AVX2, eight positions (b0, b1: four each). */
__attribute__((always_inline, FILTER_AVX2)) static inline __m256 gaussian_arg8(__m256d b0,
                                                                             __m256d b1, int k)
{
    __m256d kv = _mm256_set1_pd((double)k);
    return _mm256_set_m128(_mm256_cvtpd_ps(_mm256_add_pd(b1, kv)),
                           _mm256_cvtpd_ps(_mm256_add_pd(b0, kv)));
}

/* Eight weights: all (whole) or the lanes of m. */
__attribute__((always_inline, FILTER_AVX2)) static inline void
gaussian_store8(float *dst, __m256i m, bool whole, __m256 g)
{
    if (whole)
        _mm256_storeu_ps(dst, g);
    else
        _mm256_maskstore_ps(dst, m, g);
}

/* gaussian_offsets16's loop in AVX2, eight positions a step (one group). */
__attribute__((always_inline, FILTER_AVX2)) static inline void
gaussian_offsets8(const Filter *f, const float *pos, int n, int R, float *w, size_t plane,
                  size_t bstride, int mode)
{
    float ni = gauss_factor(f);
    bool float_arg = mode == ARG_FLOAT;
    const __m256 one = _mm256_set1_ps(1.0f);
    const __m256d half = _mm256_set1_pd(0.5), dr = _mm256_set1_pd((double)R);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    for (int i = 0; i < n; i += 8) {
        __m256i m = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - i), lane);
        __m256 p = n - i >= 8 ? _mm256_loadu_ps(pos + i) : _mm256_maskload_ps(pos + i, m);
        if (mode == ARG_STEPS) {
            V8f g[5];
            steps8((V8f)p, R, ni, f->gauss_e1, f->gauss_e4, g);
            float *dst = w + (size_t)(i / 8) * bstride;
            bool whole = n - i >= 8;
            gaussian_store8(dst, m, whole, (__m256)g[0]);
            gaussian_store8(dst + plane, m, whole, (__m256)g[1]);
            gaussian_store8(dst + 2 * plane, m, whole, (__m256)g[2]);
            if (R == 2) {
                gaussian_store8(dst + 3 * plane, m, whole, (__m256)g[3]);
                gaussian_store8(dst + 4 * plane, m, whole, (__m256)g[4]);
            }
            continue;
        }
        __m256 c = _mm256_set1_ps(-(float)R - 0.5f); /* k - R - 0.5, exact */
        __m256d b0 = _mm256_setzero_pd(), b1 = b0;
        if (!float_arg) {
            b0 = _mm256_sub_pd(_mm256_sub_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(p)), half), dr);
            b1 = _mm256_sub_pd(_mm256_sub_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(p, 1)), half),
                               dr);
        }
        /* Three planes a step, as gaussian_offsets16's. */
        for (int k = 0; k <= 2 * R; k += 3) {
            __m256 x0, x1, x2;
            if (float_arg) {
                x0 = _mm256_add_ps(p, c);
                c = _mm256_add_ps(c, one);
                x1 = _mm256_add_ps(p, c);
                c = _mm256_add_ps(c, one);
                x2 = _mm256_add_ps(p, c);
                c = _mm256_add_ps(c, one);
            } else {
                x0 = gaussian_arg8(b0, b1, k);
                x1 = gaussian_arg8(b0, b1, k + 1);
                x2 = gaussian_arg8(b0, b1, k + 2);
            }
            __m256 g0 = (__m256)gaussian8((V8f)x0, ni);
            __m256 g1 = (__m256)gaussian8((V8f)x1, ni);
            __m256 g2 = (__m256)gaussian8((V8f)x2, ni);
            float *dst = w + (size_t)k * plane + (size_t)(i / 8) * bstride;
            bool whole = n - i >= 8;
            gaussian_store8(dst, m, whole, g0);
            if (k + 1 <= 2 * R)
                gaussian_store8(dst + plane, m, whole, g1);
            if (k + 2 <= 2 * R)
                gaussian_store8(dst + 2 * plane, m, whole, g2);
        }
    }
}

__attribute__((FILTER_AVX2)) static void gaussian_offsets_avx2(const Filter *f,
                                                               const float *pos, int n,
                                                               int R, float *w, size_t plane)
{
    if (gaussian_steps_ok(f, R) && R == 1) /* R a constant in the loop: unrolled */
        gaussian_offsets8(f, pos, n, 1, w, plane, 8, ARG_STEPS);
    else if (gaussian_steps_ok(f, R))
        gaussian_offsets8(f, pos, n, 2, w, plane, 8, ARG_STEPS);
    else if (R <= FILTER_FLOAT_ARG_R)
        gaussian_offsets8(f, pos, n, R, w, plane, 8, ARG_FLOAT);
    else
        gaussian_offsets8(f, pos, n, R, w, plane, 8, ARG_DOUBLE);
}

/* filter_weights_1d_blocks for the Gaussian with AVX2: one group a step. */
__attribute__((FILTER_AVX2)) static void gaussian_blocks_avx2(const Filter *f,
                                                              const float *pos, int nblk,
                                                              int R, float *w, size_t plane,
                                                              size_t bstride)
{
    if (gaussian_steps_ok(f, R) && R == 1) /* R a constant in the loop: unrolled */
        gaussian_offsets8(f, pos, 8 * nblk, 1, w, plane, bstride, ARG_STEPS);
    else if (gaussian_steps_ok(f, R))
        gaussian_offsets8(f, pos, 8 * nblk, 2, w, plane, bstride, ARG_STEPS);
    else if (R <= FILTER_FLOAT_ARG_R)
        gaussian_offsets8(f, pos, 8 * nblk, R, w, plane, bstride, ARG_FLOAT);
    else
        gaussian_offsets8(f, pos, 8 * nblk, R, w, plane, bstride, ARG_DOUBLE);
}
#define HAVE_AVX2_BATCH 1
#endif

/* The width the Gaussian's batches use: 0 the plain build, 1 AVX2, 2 AVX-512.
 * filter_gaussian_path_set lowers it (tests hold each path to the plain build's bits);
 * it is set before any render starts, never by a render thread. */
static int gaussian_path_cap = 2;

void filter_gaussian_path_set(int cap) { gaussian_path_cap = cap; }

static void gaussian_weights_1d(const Filter *f, const float *x, float *w, int n)
{
#ifdef HAVE_AVX2_BATCH
    /* Asked on every call (a load): a copy cached in a static that render threads
     * write would be a data race. */
    if (gaussian_path_cap >= 2 && cpu_has_avx512()) {
        gaussian_batch_avx512(f, x, w, n);
        return;
    }
    if (gaussian_path_cap >= 1 && cpu_has_avx2()) {
        gaussian_batch_avx2(f, x, w, n);
        return;
    }
#endif
    gaussian_batch(f, x, w, n);
}

static void gaussian_weights_1d_offsets(const Filter *f, const float *pos, int n, int R,
                                        float *w, size_t plane)
{
#ifdef HAVE_AVX2_BATCH
    if (gaussian_path_cap >= 2 && cpu_has_avx512()) {
        gaussian_offsets_avx512(f, pos, n, R, w, plane);
        return;
    }
    if (gaussian_path_cap >= 1 && cpu_has_avx2()) {
        gaussian_offsets_avx2(f, pos, n, R, w, plane);
        return;
    }
#endif
    gaussian_offsets(f, pos, n, R, w, plane);
}

static float gaussian_weight_1d(const Filter *f, float x)
{
    float w;
    gaussian_weights_1d(f, &x, &w, 1);
    return w;
}

static double gaussian_extent(const Filter *f) { return 2.0 * (double)f->r; }

/* Mitchell and Netravali's cubic (SIGGRAPH 1988) with B = C = 1/3, their recommended
 * compromise between blurring and ringing, on [-2, 2] stretched to [-r, r] and scaled to
 * 1 at the centre. Separable, as pbrt uses it. Negative lobes sharpen edges. */
static double mitchell_1d(double t)
{
    const double B = 1.0 / 3.0, C = 1.0 / 3.0;
    t = fabs(t);
    double v;
    if (t < 1.0)
        v = ((12 - 9 * B - 6 * C) * t * t * t + (-18 + 12 * B + 6 * C) * t * t + (6 - 2 * B));
    else if (t < 2.0)
        v = ((-B - 6 * C) * t * t * t + (6 * B + 30 * C) * t * t + (-12 * B - 48 * C) * t +
             (8 * B + 24 * C));
    else
        v = 0.0;
    return v / (6 - 2 * B);
}

static float mitchell_weight_1d(const Filter *f, float x)
{
    return (float)mitchell_1d(2.0 * (double)x / (double)f->r);
}

static float mitchell_weight(const Filter *f, float x, float y)
{
    return (float)(mitchell_1d(2.0 * (double)x / (double)f->r) *
                   mitchell_1d(2.0 * (double)y / (double)f->r));
}

static const FilterOps box_ops = {.name = "box", .param = "radius", .weight = box_weight,
                                  .weight_1d = box_weight_1d, .extent = radius_extent};
static const FilterOps tent_ops = {.name = "tent", .param = "radius", .weight = tent_weight,
                                   .extent = radius_extent};
static const FilterOps gaussian_ops = {.name = "gaussian",
                                       .param = "sigma",
                                       .weight = gaussian_weight,
                                       .weight_1d = gaussian_weight_1d,
                                       .weights_1d = gaussian_weights_1d,
                                       .weights_1d_offsets = gaussian_weights_1d_offsets,
                                       .extent = gaussian_extent};
static const FilterOps mitchell_ops = {.name = "mitchell",
                                       .param = "radius",
                                       .weight = mitchell_weight,
                                       .weight_1d = mitchell_weight_1d,
                                       .extent = radius_extent,
                                       .negative_lobes = true};

void filter_weights_1d(const Filter *f, const float *x, float *w, int n)
{
    if (f->ops->weights_1d) {
        f->ops->weights_1d(f, x, w, n);
        return;
    }
    for (int i = 0; i < n; i++)
        w[i] = f->ops->weight_1d(f, x[i]);
}

void filter_weights_1d_offsets(const Filter *f, const float *pos, int n, int R, float *w,
                               size_t plane)
{
    if (f->ops->weights_1d_offsets) {
        f->ops->weights_1d_offsets(f, pos, n, R, w, plane);
        return;
    }
    enum { CHUNK = 256 };
    float arg[CHUNK];
    for (int i0 = 0; i0 < n; i0 += CHUNK) {
        int m = n - i0 < CHUNK ? n - i0 : CHUNK;
        for (int k = 0; k <= 2 * R; k++) {
            for (int i = 0; i < m; i++)
                arg[i] = (float)((double)pos[i0 + i] - 0.5 - (double)R + (double)k);
            filter_weights_1d(f, arg, w + (size_t)k * plane + (size_t)i0, m);
        }
    }
}

void filter_weights_1d_blocks(const Filter *f, const float *pos, int nblk, int R, float *w,
                              size_t plane, size_t bstride)
{
#ifdef HAVE_AVX2_BATCH
    /* The Gaussian in one call (the film's tile rows: 2 x 16 groups of eight positions
     * a call), sixteen positions a step with AVX-512, eight with AVX2; other filters,
     * or neither instruction set, a group at a time through filter_weights_1d_offsets.
     * Every path gives the plain build's bits. */
    if (f->ops == &gaussian_ops) {
        if (gaussian_path_cap >= 2 && cpu_has_avx512()) {
            gaussian_blocks_avx512(f, pos, nblk, R, w, plane, bstride);
            return;
        }
        if (gaussian_path_cap >= 1 && cpu_has_avx2()) {
            gaussian_blocks_avx2(f, pos, nblk, R, w, plane, bstride);
            return;
        }
    }
#endif
    for (int v = 0; v < nblk; v++)
        filter_weights_1d_offsets(f, pos + 8 * v, 8, R, w + (size_t)v * bstride, plane);
}

bool filter_is_box(const Filter *f) { return f->ops == &box_ops; }

bool filter_has_negative_lobes(const Filter *f) { return f->ops->negative_lobes; }

const FilterOps *const filter_registry[] = {&box_ops, &tent_ops, &gaussian_ops, &mitchell_ops,
                                            NULL};

const FilterOps *filter_find(const char *name)
{
    for (size_t i = 0; filter_registry[i]; i++)
        if (strcmp(filter_registry[i]->name, name) == 0)
            return filter_registry[i];
    return NULL;
}

bool filter_init(Filter *f, const FilterOps *ops, float r, char *why, size_t whylen)
{
    memset(f, 0, sizeof *f);
    if (!(r > 0.0f) || !(r <= FILTER_MAX_RADIUS)) {
        snprintf(why, whylen, "%s %g is out of range (0, %g]", ops->param, (double)r,
                 (double)FILTER_MAX_RADIUS);
        return false;
    }
    f->ops = ops;
    f->r = r;
    /* A sample of pixel i + k lies at least |k| - 0.5 pixels from the centre of pixel i,
     * so pixels up to ceil(extent - 0.5) away can contribute ("conservative integer
     * support radius"; box 2.3 reaches 2 pixels, not 3). */
    double R = ceil(ops->extent(f) - 0.5);
    f->support = R > 0.0 ? (int)R : 0;
    if (ops == &gaussian_ops) {
        double s = (double)r;
        f->gauss_ni = (float)(-1.0 / (2.0 * s * s));
        f->gauss_e1 = (float)exp((double)f->gauss_ni);
        f->gauss_e4 = (float)exp(4.0 * (double)f->gauss_ni);
    }
    return true;
}

void filter_init_default(Filter *f)
{
    char why[8];
    filter_init(f, &box_ops, 0.5f, why, sizeof why);
}
