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

/* Four lanes (GCC/clang vector extensions; two SSE2 registers on a plain x86-64
 * build, one AVX register where enabled), or eight (one AVX-512 register): every lane
 * runs the same IEEE operations as the others, so a value's bits do not depend on its
 * lane, on the width or on the build's ISA. */
typedef double V4d __attribute__((vector_size(32)));
typedef float V4f __attribute__((vector_size(16)));
typedef uint64_t V4u __attribute__((vector_size(32)));
typedef int64_t V4i __attribute__((vector_size(32)));
typedef double V8d __attribute__((vector_size(64)));
typedef float V8f __attribute__((vector_size(32)));
typedef uint64_t V8u __attribute__((vector_size(64)));
typedef int64_t V8i __attribute__((vector_size(64)));

/* exp(t) = 2^k exp(r) with k = round(t / ln 2) and |r| <= ln(2)/2 + tiny; exp(r) by its
 * Taylor series to degree 12 (remainder below 3e-16 relative there), summed in
 * Estrin's scheme (pairs, then powers r^2, r^4, r^8: a short dependency chain, so
 * the loop's iterations overlap; a Horner chain of 13 steps was latency-bound and
 * slower than libm). k is read from the bits of the rounding sum (t / ln 2 + 1.5 * 2^52
 * holds round(t / ln 2) in its low mantissa bits) and 2^k is built from its bits: no
 * calls, no branches. ln 2 is split in two (the high part has 32 significant bits, so
 * k * ln2_hi is exact for |k| < 2^21) to keep r accurate. One body for both widths (a
 * macro: the operations, and so the bits, cannot drift apart). */
#define FILTER_EXP_NONPOS(NAME, VD, VU, VI, ...)                                           \
    __attribute__((always_inline __VA_ARGS__)) static inline VD NAME(VD t)                \
    {                                                                                      \
        const double shift = 0x1.8p52, inv_ln2 = 0x1.71547652b82fep0;                      \
        const double ln2_hi = 0x1.62e42feep-1, ln2_lo = 0x1.a39ef35793c76p-33;             \
        const VD lo = (VD){0} - 700.0;                                                     \
        VI keep = t >= lo; /* all ones where t >= -700 (false for NaN) */                  \
        t = (VD)(((VI)t & keep) | ((VI)lo & ~keep));                                       \
        VD kd = t * inv_ln2 + shift;                                                       \
        VU kbits = (VU)kd;                                                                 \
        kd -= shift;                                                                       \
        VD r = t - kd * ln2_hi;                                                            \
        r -= kd * ln2_lo;                                                                  \
        VD r2 = r * r, r4 = r2 * r2, r8 = r4 * r4;                                         \
        VD p01 = r + 1.0;                                                                  \
        VD p23 = r * (1.0 / 6.0) + 0.5;                                                    \
        VD p45 = r * (1.0 / 120.0) + 1.0 / 24.0;                                           \
        VD p67 = r * (1.0 / 5040.0) + 1.0 / 720.0;                                         \
        VD p89 = r * (1.0 / 362880.0) + 1.0 / 40320.0;                                     \
        VD pab = r * (1.0 / 39916800.0) + 1.0 / 3628800.0;                                 \
        VD q0 = p23 * r2 + p01, q1 = p67 * r2 + p45, q2 = pab * r2 + p89;                  \
        VD s0 = q1 * r4 + q0, s1 = r4 * (1.0 / 479001600.0) + q2;                          \
        VD p = s1 * r8 + s0;                                                               \
        /* k = kbits - bits(shift) lies in [-1010, 0]: 2^k is a normal double. */          \
        uint64_t shift_bits;                                                               \
        memcpy(&shift_bits, &shift, sizeof shift_bits);                                    \
        VU sbits = (kbits - shift_bits + 1023u) << 52;                                     \
        return p * (VD)sbits;                                                              \
    }

FILTER_EXP_NONPOS(exp_nonpos4, V4d, V4u, V4i, )

double filter_exp_nonpos(double t)
{
    V4d v = {t, t, t, t};
    return exp_nonpos4(v)[0];
}

/* The separable Gaussian of the film (random positions): exp(-x^2 / (2 sigma^2)) by
 * exp_nonpos4/8, not libm (the 2(2R+1) weights of every sample were a fifth of a
 * jittered 16-sample render of course line 07). The 2-D weight (fixed positions and
 * the filter pictures, which reproduce the course's images to the bit) keeps libm.
 * The exponent is x^2 times -1/(2 sigma^2): within an ulp of the quotient, which moves
 * exp by under 2e-15 relative for the |t| < 18 of any support. Two vectors per step
 * (two independent chains); a last partial group goes through a padded copy. The AVX2
 * build of the four-lane loop and the AVX-512 build of the eight-lane one do the same
 * operations per lane (no FMA: the file is built with -ffp-contract=off). */
#define FILTER_GAUSSIAN_BATCH(NAME, GAUSS, VF, L)                                          \
    __attribute__((always_inline)) static inline void NAME(const Filter *f, const float *x, \
                                                           float *w, int n)                \
    {                                                                                      \
        double s = (double)f->r;                                                           \
        double neg_inv = -1.0 / (2.0 * s * s);                                             \
        int i = 0;                                                                         \
        for (; i + 2 * (L) <= n; i += 2 * (L)) {                                           \
            VF a, b;                                                                       \
            memcpy(&a, x + i, sizeof a);                                                   \
            memcpy(&b, x + i + (L), sizeof b);                                             \
            a = GAUSS(a, neg_inv);                                                         \
            b = GAUSS(b, neg_inv);                                                         \
            memcpy(w + i, &a, sizeof a);                                                   \
            memcpy(w + i + (L), &b, sizeof b);                                             \
        }                                                                                  \
        for (; i < n; i += (L)) {                                                          \
            int m = n - i < (L) ? n - i : (L);                                             \
            VF a = {0.0f};                                                                 \
            memcpy(&a, x + i, (size_t)m * sizeof x[0]);                                    \
            a = GAUSS(a, neg_inv);                                                         \
            memcpy(w + i, &a, (size_t)m * sizeof w[0]);                                    \
        }                                                                                  \
    }

/* exp(x^2 times -1/(2 sigma^2)), rounded to float: the film's separable Gaussian. */
#define FILTER_GAUSSIAN(GAUSS, EXP, VD, VF)                                                \
    __attribute__((always_inline)) static inline VF GAUSS(VF x, double neg_inv)           \
    {                                                                                      \
        VD t = __builtin_convertvector(x * x, VD) * neg_inv;                               \
        return __builtin_convertvector(EXP(t), VF);                                        \
    }

FILTER_GAUSSIAN(gaussian4, exp_nonpos4, V4d, V4f)
FILTER_GAUSSIAN_BATCH(gaussian_batch, gaussian4, V4f, 4)

/* filter_weights_1d_offsets for the Gaussian: L positions at a time, their 2R+1
 * arguments made in the lanes (the same double operations and one rounding to float
 * as the generic loop) and their weights by GAUSS, stored straight into the planes.
 * The film's arguments no longer go through arrays of their own (a tenth of a
 * 16-sample Gaussian render of course line 17a was that pass). */
#define FILTER_GAUSSIAN_OFFSETS(NAME, GAUSS, VD, VF, L)                                    \
    __attribute__((always_inline)) static inline void NAME(const Filter *f, const float *pos, \
                                                           int n, int R, float *w,         \
                                                           size_t plane)                   \
    {                                                                                      \
        double s = (double)f->r;                                                           \
        double neg_inv = -1.0 / (2.0 * s * s);                                             \
        double half = 0.5, dr = (double)R;                                                 \
        int i = 0;                                                                         \
        for (; i + (L) <= n; i += (L)) {                                                   \
            VF p;                                                                          \
            memcpy(&p, pos + i, sizeof p);                                                 \
            VD b = __builtin_convertvector(p, VD) - half - dr;                             \
            for (int k = 0; k <= 2 * R; k++) {                                             \
                VF g = GAUSS(__builtin_convertvector(b + (double)k, VF), neg_inv);         \
                memcpy(w + (size_t)k * plane + (size_t)i, &g, sizeof g);                   \
            }                                                                              \
        }                                                                                  \
        if (i < n) { /* the last partial group through a padded copy */                    \
            int m = n - i;                                                                 \
            VF p = {0.0f};                                                                 \
            memcpy(&p, pos + i, (size_t)m * sizeof pos[0]);                                \
            VD b = __builtin_convertvector(p, VD) - half - dr;                             \
            for (int k = 0; k <= 2 * R; k++) {                                             \
                VF g = GAUSS(__builtin_convertvector(b + (double)k, VF), neg_inv);         \
                memcpy(w + (size_t)k * plane + (size_t)i, &g, (size_t)m * sizeof w[0]);    \
            }                                                                              \
        }                                                                                  \
    }

FILTER_GAUSSIAN_OFFSETS(gaussian_offsets, gaussian4, V4d, V4f, 4)

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define FILTER_AVX512 target("avx512f,avx512vl,avx512bw,avx512dq")

/* Eight lanes, for the AVX-512 functions (a 64-byte vector passed to or from a function
 * built without AVX-512 would change the calling convention). */
FILTER_EXP_NONPOS(exp_nonpos8, V8d, V8u, V8i, , FILTER_AVX512)

/* The AVX-512 Gaussian: a cheaper exp F that decides the float of exp_nonpos8 (E) in
 * nearly every lane, E itself where it cannot. F: t = k ln2/8 + r with k = round(t 8 /
 * ln 2), so |r| <= ln2/16 + tiny; 2^(k/8) = 2^floor(k/8) (vscalefpd) times a table of
 * 2^(j/8), j = k mod 8 (one permute); exp(r) by its Taylor series to degree 5 (Horner,
 * fused multiply-adds: F's own bits never reach an image, only its error bound
 * matters). r = t - k ln2/8 in one fused multiply-add with ln2/8 rounded to one double
 * c (|c - ln2/8| < 3e-18; |k| <= 80 * 8/ln2 < 924, so r is off by < 2.8e-15, and so
 * is F, relatively: E's split of ln 2 is not needed here, and one step less was 6%
 * of the weights' time). Its error against E, over every t >= -80: truncation
 * |r|^6/720 e^|r| < 9.6e-12 (9.53e-12 exactly at r = -ln2/16, the worst; measured:
 * 9.529e-12); the reduction's 2.8e-15; the other roundings (polynomial, table,
 * product) and E's own error (< 1e-15) a few 1e-16: below 9.7e-12 relative
 * (9.53e-12 + 2.8e-15 + 2e-15), so under 2^17 units in the last place of a double in
 * E's binade (an ulp is at least 2^-53 of the value: 9.7e-12 * 2^53 = 87,400 units;
 * measured: 82,200 with ln 2 split, which the one-double c moves by < 25 units), under
 * 2^18 in F's own (at most one binade lower). Rounding to
 * float drops the 29 low mantissa bits L of the double; the rounding boundaries (halfway between two floats)
 * are at L = 2^28 (every other point of the float grid is a float itself). So where
 * |L(F) - 2^28| >= 2^18 no boundary lies between F and E, and (float)F == (float)E:
 * the bits of the other paths. Lanes within 2^18 of a boundary (about one in 1000),
 * with t < -80 (the float may be subnormal or 0) or NaN take E: the vector is computed
 * again by exp_nonpos8 (about one vector in 125). t itself and the argument x are the
 * other paths' (no fused operation there). Tested: test_gaussian_rounding_boundaries
 * (fails when the fallback is dropped) and test_gaussian_paths. Weights alone (L1,
 * 400x400x16's worth): 1.47 ns each with exp_nonpos8, 1.0 with this; the offsets of a
 * 402-wide row (gaussian_offsets_avx512, sigma 0.4, L1, best of 5): 0.72 ns a weight,
 * 0.60 with two vectors at a time, 0.575 with c. */
/* F of t in eight lanes, and in *near the lanes whose F lies within 2^18 units of a
 * float rounding boundary: the low 29 bits L in [2^28 - 2^18, 2^28 + 2^18), i.e. bits
 * 19..28 of (bits - (2^28 - 2^18)) all zero (one subtract and one test). */
__attribute__((always_inline, FILTER_AVX512)) static inline __m512d gaussian_f8(__m512d t,
                                                                              __mmask8 *near)
{
    const __m512d shift = _mm512_set1_pd(0x1.8p52);
    __m512d kd = _mm512_fmadd_pd(t, _mm512_set1_pd(0x1.71547652b82fep3), shift); /* 8/ln2 */
    __m512i kbits = _mm512_castpd_si512(kd);
    kd = _mm512_sub_pd(kd, shift);
    /* ln2/8 in one double (see the bound above: no split needed for F) */
    __m512d r = _mm512_fnmadd_pd(kd, _mm512_set1_pd(0x1.62e42fefa39efp-4), t);
    __m512d p = _mm512_fmadd_pd(_mm512_set1_pd(1.0 / 120.0), r, _mm512_set1_pd(1.0 / 24.0));
    p = _mm512_fmadd_pd(p, r, _mm512_set1_pd(1.0 / 6.0));
    p = _mm512_fmadd_pd(p, r, _mm512_set1_pd(0.5));
    p = _mm512_fmadd_pd(p, r, _mm512_set1_pd(1.0));
    p = _mm512_fmadd_pd(p, r, _mm512_set1_pd(1.0));
    /* 2^(j/8), j = 0..7: the permute reads the low three bits of kbits, k mod 8. */
    const __m512d table = _mm512_setr_pd(0x1p0, 0x1.172b83c7d517bp0, 0x1.306fe0a31b715p0,
                                         0x1.4bfdad5362a27p0, 0x1.6a09e667f3bcdp0,
                                         0x1.8ace5422aa0dbp0, 0x1.ae89f995ad3adp0,
                                         0x1.d5818dcfba487p0);
    __m512d e = _mm512_mul_pd(p, _mm512_permutexvar_pd(kbits, table));
    e = _mm512_scalef_pd(e, _mm512_mul_pd(kd, _mm512_set1_pd(0.125))); /* 2^floor(k/8) */
    const long long half = 1LL << 28, margin = 1LL << 18;
    *near = _mm512_testn_epi64_mask(
        _mm512_sub_epi64(_mm512_castpd_si512(e), _mm512_set1_epi64(half - margin)),
        _mm512_set1_epi64(((1LL << 29) - 1) & ~(2 * margin - 1)));
    return e;
}

__attribute__((always_inline, FILTER_AVX512)) static inline __m256 gaussian8(__m256 x,
                                                                            __m512d neg_inv)
{
    __m512d t = _mm512_mul_pd(_mm512_cvtps_pd(_mm256_mul_ps(x, x)), neg_inv);
    __mmask8 near;
    __m512d e = gaussian_f8(t, &near);
    __mmask8 in = _mm512_cmp_pd_mask(t, _mm512_set1_pd(-80.0), _CMP_GE_OQ);
    __mmask8 bad = (__mmask8)(near | (__mmask8)~in);
    if (bad) {
        V8d exact = exp_nonpos8((V8d)t);
        e = _mm512_mask_blend_pd(bad, e, (__m512d)exact);
    }
    return _mm512_cvtpd_ps(e);
}


/* The batch eight weights at a time; a last partial group through masked loads and
 * stores (its padding lanes compute exp(0)). */
__attribute__((FILTER_AVX512)) static void gaussian_batch_avx512(const Filter *f,
                                                                 const float *x, float *w,
                                                                 int n)
{
    double s = (double)f->r;
    __m512d neg_inv = _mm512_set1_pd(-1.0 / (2.0 * s * s));
    for (int i = 0; i < n; i += 8) {
        __mmask8 m = n - i >= 8 ? (__mmask8)0xff : (__mmask8)((1u << (n - i)) - 1);
        _mm256_mask_storeu_ps(w + i, m, gaussian8(_mm256_maskz_loadu_ps(m, x + i), neg_inv));
    }
}


/* gaussian_offsets' loop in AVX-512, sixteen positions per step. For R <=
 * FILTER_FLOAT_ARG_R the argument towards pixel k - R is p + (k - R - 0.5) in one float
 * add, the exact sum rounded to float once: the other paths' ((double)p - 0.5 - R) + k
 * rounded to float is the same float for every float p at R = 1 and 2 (all 2^32 bit
 * patterns compared, bench/REPORT.txt film20; those double steps are exact unless p is
 * tiny or huge against R + 0.5, and then no float rounding boundary lies within their
 * error). Not for large R: at R = 16, with the sum near 16.5, a double step rounds p =
 * 2^-26 (1 + 2^-23) onto the float halfway point -0.5 + 2^-26 (two such p of all
 * 2^32), so larger R make the arguments by the double steps (vcvtpd2ps, as the vector
 * extension's conversion; k is an exact small integer in double). The squares for 16
 * lanes at once; t, F and the boundary test as gaussian8's, eight lanes per half (two
 * independent exp chains: one vector at a time the exp's steps were latency-bound,
 * 0.72 against 0.60 ns a weight in L1). Lanes whose square is above `far` (t might be
 * below -80) or NaN take E, as gaussian8's t < -80 lanes do: far is below 80 /
 * (-neg_inv) by more than the product's rounding, so d2 <= far gives t >= -80. The
 * last group is masked (its padding lanes compute the weights of position 0). Weights
 * of a 402-wide row in L1 (sigma 0.4, best of 7): 0.58-0.60 ns each with the double
 * arguments and eight-lane squares, 0.51-0.52 with these. */
enum { FILTER_FLOAT_ARG_R = 2 };

__attribute__((always_inline, FILTER_AVX512)) static inline void
gaussian_offsets16(const Filter *f, const float *pos, int n, int R, float *w, size_t plane,
                   size_t bstride, bool float_arg)
{
    double s = (double)f->r, ni = -1.0 / (2.0 * s * s);
    __m512d neg_inv = _mm512_set1_pd(ni);
    __m512 far = _mm512_set1_ps((float)(80.0 / -ni * (1.0 - 0x1p-20)));
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512d half = _mm512_set1_pd(0.5), dr = _mm512_set1_pd((double)R);
    for (int i = 0; i < n; i += 16) {
        __mmask16 m = n - i >= 16 ? (__mmask16)0xffff : (__mmask16)((1u << (n - i)) - 1);
        __m512 p = _mm512_maskz_loadu_ps(m, pos + i);
        __m512 c = _mm512_set1_ps(-(float)R - 0.5f); /* k - R - 0.5, exact */
        __m512d b0 = _mm512_setzero_pd(), b1 = b0;
        if (!float_arg) {
            b0 = _mm512_sub_pd(_mm512_sub_pd(_mm512_cvtps_pd(_mm512_castps512_ps256(p)), half), dr);
            b1 = _mm512_sub_pd(_mm512_sub_pd(_mm512_cvtps_pd(_mm512_extractf32x8_ps(p, 1)), half),
                               dr);
        }
        for (int k = 0; k <= 2 * R; k++, c = _mm512_add_ps(c, one)) {
            __m512 x;
            if (float_arg) {
                x = _mm512_add_ps(p, c);
            } else {
                __m512d kv = _mm512_set1_pd((double)k);
                x = _mm512_insertf32x8(_mm512_castps256_ps512(_mm512_cvtpd_ps(_mm512_add_pd(b0, kv))),
                                       _mm512_cvtpd_ps(_mm512_add_pd(b1, kv)), 1);
            }
            __m512 d2 = _mm512_mul_ps(x, x);
            __m512d t0 = _mm512_mul_pd(_mm512_cvtps_pd(_mm512_castps512_ps256(d2)), neg_inv);
            __m512d t1 = _mm512_mul_pd(_mm512_cvtps_pd(_mm512_extractf32x8_ps(d2, 1)), neg_inv);
            __mmask8 n0, n1;
            __m512d e0 = gaussian_f8(t0, &n0), e1 = gaussian_f8(t1, &n1);
            unsigned bad = ~(unsigned)_mm512_cmp_ps_mask(d2, far, _CMP_LE_OQ) & 0xffffu;
            bad |= (unsigned)n0 | (unsigned)n1 << 8;
            if (bad) {
                if (bad & 0xffu)
                    e0 = _mm512_mask_blend_pd((__mmask8)bad, e0, (__m512d)exp_nonpos8((V8d)t0));
                if (bad >> 8)
                    e1 = _mm512_mask_blend_pd((__mmask8)(bad >> 8), e1,
                                              (__m512d)exp_nonpos8((V8d)t1));
            }
            float *dst = w + (size_t)k * plane + (size_t)(i / 8) * bstride;
            if (bstride == 8) {
                __m512 g = _mm512_insertf32x8(_mm512_castps256_ps512(_mm512_cvtpd_ps(e0)),
                                              _mm512_cvtpd_ps(e1), 1);
                _mm512_mask_storeu_ps(dst, m, g);
            } else { /* groups i / 8 and i / 8 + 1 apart (filter_weights_1d_blocks) */
                _mm256_mask_storeu_ps(dst, (__mmask8)m, _mm512_cvtpd_ps(e0));
                _mm256_mask_storeu_ps(dst + bstride, (__mmask8)(m >> 8), _mm512_cvtpd_ps(e1));
            }
        }
    }
}

__attribute__((FILTER_AVX512)) static void gaussian_offsets_avx512(const Filter *f,
                                                                   const float *pos, int n,
                                                                   int R, float *w,
                                                                   size_t plane)
{
    if (R <= FILTER_FLOAT_ARG_R)
        gaussian_offsets16(f, pos, n, R, w, plane, 8, true);
    else
        gaussian_offsets16(f, pos, n, R, w, plane, 8, false);
}

/* filter_weights_1d_blocks for the Gaussian with AVX-512: gaussian_offsets16 with the
 * groups of eight bstride floats apart, two groups a step. (A group at a time through
 * gaussian_offsets_avx512 left half of every sixteen-lane step empty: on a Zen 4 host
 * the AVX2 blocks were then faster, bench/REPORT.txt.) */
__attribute__((FILTER_AVX512)) static void gaussian_blocks_avx512(const Filter *f,
                                                                  const float *pos, int nblk,
                                                                  int R, float *w, size_t plane,
                                                                  size_t bstride)
{
    if (R <= FILTER_FLOAT_ARG_R)
        gaussian_offsets16(f, pos, 8 * nblk, R, w, plane, bstride, true);
    else
        gaussian_offsets16(f, pos, 8 * nblk, R, w, plane, bstride, false);
}

/* The AVX2 + FMA Gaussian (Zen 3 and other CPUs without AVX-512): the cheaper exp F of
 * gaussian_f8 and its boundary test, four doubles a vector, eight weights a step.
 * AVX2 has neither vscalefpd nor a permute of eight doubles, so two steps differ in
 * how, not in what (gaussian_w8 says how): 2^(j/8) comes from the same eight doubles
 * held as their 32-bit halves (one vpermd each), and 2^floor(k/8) is added into the
 * exponent field of the table's high dword. kbits = S + k with S = bits(1.5 * 2^52) =
 * 0x4338 << 48, whose low 48 bits are zero: the low dword of kbits is k modulo 2^32,
 * and k << 17 modulo 2^32 holds j = k mod 8 in bits 17..19 and floor(k/8) modulo 2^12
 * in bits 20..31, the high dword's exponent field; stored less j << 17, the table's
 * high dword plus k << 17 is the high dword of 2^(j/8) 2^floor(k/8) (for t >= -80:
 * k >= -924, floor(k/8) >= -116, a normal double). F = p times that: the same double
 * as gaussian_f8's (p 2^(j/8)) 2^floor(k/8) in every lane (a normal product scaled by
 * a power of two, exactly). The other steps (k, r, the degree-5 series in the same
 * fused order) are gaussian_f8's operations, so the bound above holds as it stands.
 * Re-derived for this copy: |r| <= ln2/16 + tiny = 0.0433217; the series' truncation
 * is r^6/720 e^xi (xi between r and 0), relative to e^r at most |r|^6/720 e^|r| =
 * 6.61e-9 / 720 * 1.0443 = 9.59e-12 (at r = -ln2/16 exactly 9.53e-12); c = ln2/8 in
 * one double is off by < 3e-18, times |k| <= 924: r, and so F relatively, off by <
 * 2.8e-15; the table's entries (within 6.9e-17 relative of 2^(j/8), checked), the fused
 * steps of the series and the product a few 1e-16; E's own error < 1e-15. In all <
 * 9.7e-12 relative: under 9.7e-12 * 2^53 = 87,400 < 2^17 units in the last place of E's
 * binade, under 2^18 in F's (at most one binade lower). So lanes whose F's low 29 bits
 * lie 2^18 or more from 2^28 round to E's float, and the others, with those whose t may
 * be below -80 (d2 above `far`) or NaN, take E: exp_nonpos4's operations (its copy
 * exp_nonpos4_avx2, no FMA in it: -ffp-contract=off) in an out-of-line call, once in
 * about 125 groups of eight. The arguments and t are the other paths' operations (no
 * fused step before F). Tests: test_gaussian_rounding_boundaries (fails with the
 * fallback removed and with a margin of 2^16), test_weights_offsets_boundaries (fails
 * with the fallback removed), test_gaussian_paths (fails without the range test).
 * Offsets of a 402-wide row, sigma 0.4, in L1 on this Zen 3 (shared, min of 400):
 * 2.56 ns a weight with exp_nonpos4 (the AVX2 build of the plain loop), 1.55 with F
 * four lanes a step with per-half tests, 1.16 with the table, scaling and test on
 * eight lanes' dwords, 1.01-1.13 with sixteen positions a step. */
#define FILTER_AVX2_FMA target("avx2,fma")

/* E in the AVX2 functions' own copy (a 32-byte vector passed to a function built
 * without AVX would change the calling convention): exp_nonpos4's operations (no
 * FMA: -ffp-contract=off), so its bits. */
FILTER_EXP_NONPOS(exp_nonpos4_avx2, V4d, V4u, V4i, , FILTER_AVX2_FMA)

/* t = k ln2/8 + r and exp(r) by the degree-5 series, four lanes: F as gaussian_f8's up
 * to the roundings of its steps, which only its error bound sees. Two changes shorten
 * the chain from the square to F (this loop is latency-bound: perf puts its samples on
 * the ends of the chains), each from gaussian_f8's: (1) k = round(d2 k8) with k8 =
 * neg_inv 8/ln2 (one double), made from the square d2 beside t = d2 neg_inv instead of
 * after it: d2 k8 lies within 3 double roundings of t 8/ln2 (relative 3.4e-16, |t 8/ln2|
 * < 924: 3.1e-13 absolute), so k differs from round(t 8/ln2) only by a tie's choice and
 * |r| <= ln2/16 + 3e-14, which moves the truncation bound below by under 1e-23; (2)
 * the series in Estrin's form, (1 + r) + r^2 ((1/2 + r/6) + r^2 (1/24 + r/120)): three
 * dependent steps after r instead of Horner's five (its roundings: under 2 units of
 * 2^-53 against Horner's, both within the few 1e-16 counted above). Weights of a 400 x
 * 400 x 16 film's tile rows (the film's planes, sigma 0.4, min of 8 x 15 frames on the
 * loaded Zen 3 host): 1.196 -> 1.092 ns each; each alone 1.174 and 1.205 (bench/
 * REPORT.txt, gauss24; film21 measured Estrin alone slower in L1: 1.09 against 1.0). */
__attribute__((always_inline, FILTER_AVX2_FMA)) static inline __m256d
gaussian_series4(__m256d t, __m256d d2, __m256d k8, __m256i *kbits)
{
    const __m256d shift = _mm256_set1_pd(0x1.8p52);
    __m256d kd = _mm256_fmadd_pd(d2, k8, shift);
    *kbits = _mm256_castpd_si256(kd);
    kd = _mm256_sub_pd(kd, shift);
    __m256d r = _mm256_fnmadd_pd(kd, _mm256_set1_pd(0x1.62e42fefa39efp-4), t);
    __m256d r2 = _mm256_mul_pd(r, r);
    __m256d a = _mm256_add_pd(r, _mm256_set1_pd(1.0));
    __m256d b = _mm256_fmadd_pd(r, _mm256_set1_pd(1.0 / 6.0), _mm256_set1_pd(0.5));
    __m256d c = _mm256_fmadd_pd(r, _mm256_set1_pd(1.0 / 120.0), _mm256_set1_pd(1.0 / 24.0));
    return _mm256_fmadd_pd(r2, _mm256_fmadd_pd(r2, c, b), a);
}

/* The lanes of F (four) that must take E: F's low 29 bits within 2^18 of 2^28 (bits
 * 19..28 of bits - (2^28 - 2^18) all zero), t < -80 or NaN. */
__attribute__((always_inline, FILTER_AVX2_FMA)) static inline __m256d gaussian_bad4(__m256d e,
                                                                                  __m256d t)
{
    const long long half = 1LL << 28, margin = 1LL << 18;
    __m256i low = _mm256_and_si256(
        _mm256_sub_epi64(_mm256_castpd_si256(e), _mm256_set1_epi64x(half - margin)),
        _mm256_set1_epi64x(((1LL << 29) - 1) & ~(2 * margin - 1)));
    __m256d near = _mm256_castsi256_pd(_mm256_cmpeq_epi64(low, _mm256_setzero_si256()));
    return _mm256_or_pd(near, _mm256_cmp_pd(t, _mm256_set1_pd(-80.0), _CMP_NGE_UQ));
}

/* E in the lanes of F (e0, e1 of t0, t1) that must take it: out of line, once in
 * about 125 groups, so that its constants do not crowd the loop's registers. */
__attribute__((noinline, FILTER_AVX2_FMA)) static void gaussian_fix8(__m256d *e0, __m256d *e1,
                                                                    __m256d t0, __m256d t1)
{
    __m256d b0 = gaussian_bad4(*e0, t0), b1 = gaussian_bad4(*e1, t1);
    if (_mm256_movemask_pd(b0))
        *e0 = _mm256_blendv_pd(*e0, (__m256d)exp_nonpos4_avx2((V4d)t0), b0);
    if (_mm256_movemask_pd(b1))
        *e1 = _mm256_blendv_pd(*e1, (__m256d)exp_nonpos4_avx2((V4d)t1), b1);
}

/* The weights of eight arguments x: the squares in float (as GAUSS), t in double per
 * half, F, and E in the lanes that need it. The table lookup, the scaling and the
 * boundary test run on the eight lanes' 32-bit halves at once:
 * - idx: the low dwords of both halves' kbits (k mod 2^32; vpermd reads k mod 8), in
 *   the in-lane order of vshufps (a0 a1 b0 b1 | a2 a3 b2 b3);
 * - the table's low and high dwords by one vpermd each; 2^floor(k/8) added to the
 *   high dword's exponent field (bits 20..31): idx << 17 holds k mod 8 in bits 17..19
 *   and floor(k/8) mod 2^12 in 20..31, so the high dwords are stored less (j << 17)
 *   and the sum is the high dword of 2^(j/8) 2^floor(k/8) exactly (modulo 2^32; a
 *   normal double for t >= -80);
 * - vpunpckldq / vpunpckhdq interleave low and high dwords back into the doubles of
 *   half a (lanes 0..3) and half b (4..7);
 * - F = p times that power of two: the same double as gaussian_f8's (p * 2^(j/8)) *
 *   2^floor(k/8), the scaling of a normal product being exact;
 * - the boundary test on F's low dwords (bits 19..28 are in the low dword, and the
 *   low 32 bits of a 64-bit subtraction are the 32-bit subtraction's), and d2 above
 *   `far` (t might be below -80: gaussian_offsets16's bound) or NaN; either sends the
 *   group to the exact test per half (gaussian_bad4) and E in its lanes. */
__attribute__((always_inline, FILTER_AVX2_FMA)) static inline __m256 gaussian_w8(__m256 x,
                                                                               __m256d neg_inv,
                                                                               __m256d k8,
                                                                               __m256 far)
{
    __m256 d2 = _mm256_mul_ps(x, x);
    __m256d q0 = _mm256_cvtps_pd(_mm256_castps256_ps128(d2));
    __m256d q1 = _mm256_cvtps_pd(_mm256_extractf128_ps(d2, 1));
    __m256d t0 = _mm256_mul_pd(q0, neg_inv);
    __m256d t1 = _mm256_mul_pd(q1, neg_inv);
    __m256i k0, k1;
    __m256d p0 = gaussian_series4(t0, q0, k8, &k0), p1 = gaussian_series4(t1, q1, k8, &k1);
    /* gaussian_f8's table of 2^(j/8): the low dwords, and the high dwords less j << 17 */
    const __m256i tab_lo = _mm256_setr_epi32(0x0, 0x3c7d517b, 0x0a31b715, (int)0xd5362a27,
                                             0x667f3bcd, 0x422aa0db, (int)0x995ad3ad,
                                             (int)0xdcfba487);
    const __m256i tab_hi = _mm256_setr_epi32(
        0x3ff00000, 0x3ff172b8 - (1 << 17), 0x3ff306fe - (2 << 17), 0x3ff4bfda - (3 << 17),
        0x3ff6a09e - (4 << 17), 0x3ff8ace5 - (5 << 17), 0x3ffae89f - (6 << 17),
        0x3ffd5818 - (7 << 17));
    __m256i idx = _mm256_castps_si256(_mm256_shuffle_ps(
        _mm256_castsi256_ps(k0), _mm256_castsi256_ps(k1), _MM_SHUFFLE(2, 0, 2, 0)));
    __m256i lo = _mm256_permutevar8x32_epi32(tab_lo, idx);
    __m256i hi = _mm256_add_epi32(_mm256_permutevar8x32_epi32(tab_hi, idx),
                                  _mm256_slli_epi32(idx, 17));
    __m256d e0 = _mm256_mul_pd(p0, _mm256_castsi256_pd(_mm256_unpacklo_epi32(lo, hi)));
    __m256d e1 = _mm256_mul_pd(p1, _mm256_castsi256_pd(_mm256_unpackhi_epi32(lo, hi)));
    const int half = 1 << 28, margin = 1 << 18;
    __m256i low = _mm256_castps_si256(_mm256_shuffle_ps(
        _mm256_castpd_ps(e0), _mm256_castpd_ps(e1), _MM_SHUFFLE(2, 0, 2, 0)));
    low = _mm256_and_si256(_mm256_sub_epi32(low, _mm256_set1_epi32(half - margin)),
                           _mm256_set1_epi32(((1 << 29) - 1) & ~(2 * margin - 1)));
    __m256 bad = _mm256_or_ps(_mm256_castsi256_ps(_mm256_cmpeq_epi32(low, _mm256_setzero_si256())),
                              _mm256_cmp_ps(d2, far, _CMP_NLE_UQ));
    if (_mm256_movemask_ps(bad))
        gaussian_fix8(&e0, &e1, t0, t1);
    return _mm256_set_m128(_mm256_cvtpd_ps(e1), _mm256_cvtpd_ps(e0));
}

/* `far` of gaussian_w8: below 80 / (-neg_inv) by more than d2 * neg_inv's rounding,
 * so d2 <= far gives t >= -80. */
__attribute__((always_inline, FILTER_AVX2_FMA)) static inline __m256 gaussian_far8(double neg_inv)
{
    return _mm256_set1_ps((float)(80.0 / -neg_inv * (1.0 - 0x1p-20)));
}

/* k8 of gaussian_series4: neg_inv 8/ln2 rounded to double, once per call. */
__attribute__((always_inline, FILTER_AVX2_FMA)) static inline __m256d gaussian_k8(double neg_inv)
{
    return _mm256_set1_pd(neg_inv * 0x1.71547652b82fep3);
}

/* gaussian_offsets' loop: arguments as gaussian_offsets16's (R <= FILTER_FLOAT_ARG_R:
 * one float add, sixteen positions a step, four exp chains of four; else the double
 * steps, rounded to float by vcvtpd2ps as the vector extension's conversion), weights
 * by gaussian_w8; then eight positions a step, the last group through masked loads
 * and stores (padding lanes: the weights of position 0). The weights of positions
 * 8v .. 8v+7 (group v) start at w + v bstride: bstride 8 for a row's contiguous planes
 * (filter_weights_1d_offsets), more for filter_weights_1d_blocks' groups. */
__attribute__((always_inline, FILTER_AVX2_FMA)) static inline void
gaussian_offsets8(const Filter *f, const float *pos, int n, int R, float *w, size_t plane,
                  size_t bstride, bool float_arg)
{
    double s = (double)f->r, ni = -1.0 / (2.0 * s * s);
    __m256d neg_inv = _mm256_set1_pd(ni);
    __m256 far = gaussian_far8(ni);
    __m256d k8 = gaussian_k8(ni);
    const __m256 one = _mm256_set1_ps(1.0f);
    const __m256d half = _mm256_set1_pd(0.5), dr = _mm256_set1_pd((double)R);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    int i = 0;
    if (float_arg)
        for (; i + 16 <= n; i += 16) {
            __m256 pa = _mm256_loadu_ps(pos + i), pb = _mm256_loadu_ps(pos + i + 8);
            __m256 c = _mm256_set1_ps(-(float)R - 0.5f);
            for (int k = 0; k <= 2 * R; k++, c = _mm256_add_ps(c, one)) {
                float *dst = w + (size_t)k * plane + (size_t)(i / 8) * bstride;
                __m256 ga = gaussian_w8(_mm256_add_ps(pa, c), neg_inv, k8, far);
                __m256 gb = gaussian_w8(_mm256_add_ps(pb, c), neg_inv, k8, far);
                _mm256_storeu_ps(dst, ga);
                _mm256_storeu_ps(dst + bstride, gb);
            }
        }
    for (; i < n; i += 8) {
        __m256i m = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - i), lane);
        __m256 p = _mm256_maskload_ps(pos + i, m);
        __m256 c = _mm256_set1_ps(-(float)R - 0.5f); /* k - R - 0.5, exact */
        __m256d b0 = _mm256_setzero_pd(), b1 = b0;
        if (!float_arg) {
            b0 = _mm256_sub_pd(_mm256_sub_pd(_mm256_cvtps_pd(_mm256_castps256_ps128(p)), half), dr);
            b1 = _mm256_sub_pd(_mm256_sub_pd(_mm256_cvtps_pd(_mm256_extractf128_ps(p, 1)), half),
                               dr);
        }
        for (int k = 0; k <= 2 * R; k++, c = _mm256_add_ps(c, one)) {
            __m256 x;
            if (float_arg) {
                x = _mm256_add_ps(p, c);
            } else {
                __m256d kv = _mm256_set1_pd((double)k);
                x = _mm256_set_m128(_mm256_cvtpd_ps(_mm256_add_pd(b1, kv)),
                                    _mm256_cvtpd_ps(_mm256_add_pd(b0, kv)));
            }
            float *dst = w + (size_t)k * plane + (size_t)(i / 8) * bstride;
            if (n - i >= 8)
                _mm256_storeu_ps(dst, gaussian_w8(x, neg_inv, k8, far));
            else
                _mm256_maskstore_ps(dst, m, gaussian_w8(x, neg_inv, k8, far));
        }
    }
}

/* The batch (filter_weights_1d: adaptive pixels' weights, single weights) by
 * gaussian_w8, eight at a time; a last partial group through masked loads and stores
 * (its padding lanes compute exp(0)). */
__attribute__((FILTER_AVX2_FMA)) static void gaussian_batch_avx2(const Filter *f,
                                                                 const float *x, float *w,
                                                                 int n)
{
    double s = (double)f->r, ni = -1.0 / (2.0 * s * s);
    __m256d neg_inv = _mm256_set1_pd(ni);
    __m256 far = gaussian_far8(ni);
    __m256d k8 = gaussian_k8(ni);
    const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
    int i = 0;
    for (; i + 8 <= n; i += 8)
        _mm256_storeu_ps(w + i, gaussian_w8(_mm256_loadu_ps(x + i), neg_inv, k8, far));
    if (i < n) {
        __m256i m = _mm256_cmpgt_epi32(_mm256_set1_epi32(n - i), lane);
        _mm256_maskstore_ps(w + i, m, gaussian_w8(_mm256_maskload_ps(x + i, m), neg_inv, k8, far));
    }
}

__attribute__((FILTER_AVX2_FMA)) static void gaussian_offsets_avx2(const Filter *f,
                                                                   const float *pos, int n,
                                                                   int R, float *w, size_t plane)
{
    if (R <= FILTER_FLOAT_ARG_R)
        gaussian_offsets8(f, pos, n, R, w, plane, 8, true);
    else
        gaussian_offsets8(f, pos, n, R, w, plane, 8, false);
}

/* filter_weights_1d_blocks for the Gaussian with AVX2 + FMA: gaussian_offsets8 with the
 * groups bstride floats apart. */
__attribute__((FILTER_AVX2_FMA)) static void gaussian_blocks_avx2(const Filter *f,
                                                                  const float *pos, int nblk,
                                                                  int R, float *w, size_t plane,
                                                                  size_t bstride)
{
    if (R <= FILTER_FLOAT_ARG_R)
        gaussian_offsets8(f, pos, 8 * nblk, R, w, plane, bstride, true);
    else
        gaussian_offsets8(f, pos, 8 * nblk, R, w, plane, bstride, false);
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
    if (gaussian_path_cap >= 1 && cpu_has_avx2_fma()) {
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
    if (gaussian_path_cap >= 1 && cpu_has_avx2_fma()) {
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

static const FilterOps box_ops = {"box", "radius", box_weight, box_weight_1d, NULL, NULL,
                                  radius_extent};
static const FilterOps tent_ops = {"tent", "radius", tent_weight, NULL, NULL, NULL,
                                   radius_extent};
static const FilterOps gaussian_ops = {"gaussian", "sigma", gaussian_weight,
                                       gaussian_weight_1d, gaussian_weights_1d,
                                       gaussian_weights_1d_offsets, gaussian_extent};
static const FilterOps mitchell_ops = {"mitchell", "radius", mitchell_weight,
                                       mitchell_weight_1d, NULL, NULL, radius_extent};

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
        if (gaussian_path_cap >= 1 && cpu_has_avx2_fma()) {
            gaussian_blocks_avx2(f, pos, nblk, R, w, plane, bstride);
            return;
        }
    }
#endif
    for (int v = 0; v < nblk; v++)
        filter_weights_1d_offsets(f, pos + 8 * v, 8, R, w + (size_t)v * bstride, plane);
}

bool filter_is_box(const Filter *f) { return f->ops == &box_ops; }

bool filter_has_negative_lobes(const Filter *f) { return f->ops == &mitchell_ops; }

static const FilterOps *const all_filters[] = {&box_ops, &tent_ops, &gaussian_ops,
                                               &mitchell_ops};

const FilterOps *filter_find(const char *name)
{
    for (size_t i = 0; i < sizeof all_filters / sizeof all_filters[0]; i++)
        if (strcmp(all_filters[i]->name, name) == 0)
            return all_filters[i];
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
    return true;
}

void filter_init_default(Filter *f)
{
    char why[8];
    filter_init(f, &box_ops, 0.5f, why, sizeof why);
}
