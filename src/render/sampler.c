/* Samplers (A7 and its extra credit): centre, uniform, random, jittered, n-rooks. One
 * ops table each, looked up by the name the option carries. */
#include "rt/sampler.h"
#include "rt/cpu.h"

#include <math.h>
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif
#include <stdio.h>
#include <string.h>

/* splitmix64's finaliser (Steele, Lea, Flood 2014): a bijection of 64-bit words whose
 * output bits all depend on all input bits, so hashing the sample's counters gives
 * independent-looking draws without any generator state to share between threads. */
static uint64_t mix64(uint64_t z)
{
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
}

/* The first two rounds of sampler_random depend only on the seed and the pixel: a
 * pixel's samplers hash them once and draw with pixel_draw (same bits as
 * sampler_random, a third of the hashing). */
static uint64_t pixel_key(uint64_t seed, int x, int y)
{
    return mix64(mix64(seed) ^ ((uint64_t)(uint32_t)x << 32 | (uint32_t)y));
}

static float pixel_draw(uint64_t key, uint32_t stream, uint32_t index, uint32_t dim)
{
    uint64_t h = mix64(key ^ ((uint64_t)stream << 48 | (uint64_t)(dim & 0xffff) << 32 | index));
    /* The top 24 bits: every value k * 2^-24 is exact in float and below 1. */
    return (float)(h >> 40) * 0x1p-24f;
}

float sampler_random(uint64_t seed, uint32_t stream, int x, int y, uint32_t index,
                     uint32_t dim)
{
    return pixel_draw(pixel_key(seed, x, y), stream, index, dim);
}

/* (a + xi) / k in float, kept inside the stratum [a/k, (a+1)/k): a + xi can round up to
 * a + 1 in float when a >= 1. */
static float in_stratum(int a, float xi, int k)
{
    float v = ((float)a + xi) / (float)k;
    float hi = (float)(a + 1) / (float)k;
    return v < hi ? v : nextafterf(hi, 0.0f);
}

static void center_pixel(const Sampler *s, int x, int y, float *xy)
{
    (void)s;
    (void)x;
    (void)y;
    xy[0] = 0.5f;
    xy[1] = 0.5f;
}

/* The strata of the k x k grid's n2 = 2 k^2 coordinates in the interleaved order of
 * xy (2i: column a, 2i + 1: row b of sample i = a + k*b), as floats (exact), and each
 * stratum's end (a + 1) / k in float (jittered_pixel's bound, the same float add and
 * divide as in_stratum's), padded with zeros to a multiple of four: the vector loops
 * below read whole vectors. Made once per thread and k (a pure function of k). */
typedef float SamplerV4f __attribute__((vector_size(16)));
typedef int32_t SamplerV4i __attribute__((vector_size(16)));

typedef struct Strata {
    int k;
    float st[2 * SAMPLER_MAX_COUNT + 4];
    float hi[2 * SAMPLER_MAX_COUNT + 4];
} Strata;

static const Strata *grid_strata(int k)
{
    static _Thread_local Strata g;
    if (g.k != k) {
        int j = 0;
        float kf = (float)k;
        for (int b = 0; b < k; b++)
            for (int a = 0; a < k; a++, j += 2) {
                g.st[j] = (float)a;
                g.st[j + 1] = (float)b;
                g.hi[j] = (g.st[j] + 1.0f) / kf;
                g.hi[j + 1] = (g.st[j + 1] + 1.0f) / kf;
            }
        for (; j % 4; j++)
            g.st[j] = g.hi[j] = 0.0f;
        g.k = k;
    }
    return &g;
}

/* The centres of a k x k grid, sample s = a + k*b in column a, row b (the course's
 * order, which fixes the order of the filter's sums): ((float)a + 0.5f) / k, four
 * coordinates per step (the same float add and divide in every lane). */
static void uniform_pixel(const Sampler *s, int x, int y, float *xy)
{
    (void)x;
    (void)y;
    int k = s->k, n2 = 2 * s->count, j = 0;
    const float *st = grid_strata(k)->st;
    float kf = (float)k;
    SamplerV4f kv = {kf, kf, kf, kf};
    for (; j + 4 <= n2; j += 4) {
        SamplerV4f a;
        memcpy(&a, st + j, sizeof a);
        SamplerV4f v = (a + 0.5f) / kv;
        memcpy(xy + j, &v, sizeof v);
    }
    for (; j < n2; j++)
        xy[j] = (st[j] + 0.5f) / kf;
}

static void random_pixel(const Sampler *s, int x, int y, float *xy)
{
    uint64_t key = pixel_key(s->seed, x, y);
    for (int i = 0; i < s->count; i++) {
        xy[2 * i] = pixel_draw(key, s->stream, (uint32_t)i, 0);
        xy[2 * i + 1] = pixel_draw(key, s->stream, (uint32_t)i, 1);
    }
}

/* Jittered sampling, batched: the pixel's 2 k^2 draws first (interleaved: draw 2i + d
 * is sample i's dimension d), then all in_stratum placements four at a time (AVX-512:
 * sixteen, jittered_pixel_avx512). The
 * counters of draw j are (index j / 2, dim j % 2); key ^ (stream << 48 | dim << 32 |
 * index) is key ^ stream << 48 ^ dim << 32 ^ index (disjoint bit fields). Every lane
 * runs pixel_draw's and in_stratum's operations (the same 64-bit integer steps, the
 * same float add, divide and compare; nextafterf(hi, 0) of a positive hi is the float
 * whose bits are one less), so the positions are the same bits as one at a time (the
 * one-at-a-time loop: 32 scalar hashes and 64 scalar divisions per pixel at 16
 * samples). */
static void jittered_draws(uint64_t key, uint32_t stream, int n2, float *u)
{
    for (int j = 0; j < n2; j++)
        u[j] = pixel_draw(key, stream, (uint32_t)(j >> 1), (uint32_t)(j & 1));
}

/* The placements of the n2 draws u (interleaved as xy) four at a time: in_stratum's
 * float add, divide and compare in every lane; the stratum's end from the table (the
 * same float), and nextafterf(hi, 0) of a positive hi is the float whose bits are one
 * less. */
static void jittered_place(const Strata *g, int k, int n2, const float *u, float *xy)
{
    int j = 0;
    float kf = (float)k;
    SamplerV4f kv = {kf, kf, kf, kf};
    for (; j + 4 <= n2; j += 4) {
        SamplerV4f a, xi, hi;
        memcpy(&a, g->st + j, sizeof a);
        memcpy(&xi, u + j, sizeof xi);
        memcpy(&hi, g->hi + j, sizeof hi);
        SamplerV4f v = (a + xi) / kv;
        SamplerV4i below = (SamplerV4i)hi - 1;
        SamplerV4i keep = v < hi;
        SamplerV4f r = (SamplerV4f)(((SamplerV4i)v & keep) | (below & ~keep));
        memcpy(xy + j, &r, sizeof r);
    }
    for (; j < n2; j++)
        xy[j] = in_stratum((int)g->st[j], u[j], k);
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* AVX-512: the draws and their placements sixteen coordinates at a time (a 16-sample
 * pixel in two steps), without a round trip through memory between them. Draws eight
 * hashes per step (native 64-bit multiplies, vpmullq; AVX2 has none, and emulated in
 * 32-bit multiplies the hash measured no faster than scalar code on the Zen 4 host,
 * though twice as fast on Zen 3: jittered_pixel_avx2); (float) of h >> 40
 * < 2^24 is exact in any conversion. The placement is jittered_place's, sixteen lanes
 * (one division per 16 coordinates instead of two per 4: the 4-lane divisions were
 * most of the sampler's time on 16-sample renders). Lanes past n2 compute draws that
 * are never stored. Chosen by sampler_init from the CPU (valgrind's CPU has no
 * AVX-512: it runs the plain loops). */
#define SAMPLER_AVX512 target("avx512f,avx512dq,avx512vl")

__attribute__((always_inline, SAMPLER_AVX512)) static inline __m256
jittered_draws8(__m512i base, int j0)
{
    /* key ^ (stream << 48 | dim << 32 | index) with dim = j & 1, index = j >> 1 for
     * j = j0 + i (j0 even): dim is i & 1, index j0 / 2 + i / 2, so the counters are a
     * constant vector plus j0 / 2 (one add and one xor instead of six steps) */
    const long long d1 = 1LL << 32;
    __m512i ctr = _mm512_add_epi64(_mm512_setr_epi64(0, d1, 1, d1 | 1, 2, d1 | 2, 3, d1 | 3),
                                   _mm512_set1_epi64(j0 >> 1));
    __m512i z = _mm512_xor_si512(base, ctr);
    z = _mm512_add_epi64(z, _mm512_set1_epi64((long long)0x9e3779b97f4a7c15ULL));
    z = _mm512_mullo_epi64(_mm512_xor_si512(z, _mm512_srli_epi64(z, 30)),
                           _mm512_set1_epi64((long long)0xbf58476d1ce4e5b9ULL));
    z = _mm512_mullo_epi64(_mm512_xor_si512(z, _mm512_srli_epi64(z, 27)),
                           _mm512_set1_epi64((long long)0x94d049bb133111ebULL));
    z = _mm512_xor_si512(z, _mm512_srli_epi64(z, 31));
    return _mm256_mul_ps(_mm512_cvtepu64_ps(_mm512_srli_epi64(z, 40)), _mm256_set1_ps(0x1p-24f));
}

/* Coordinates j0 .. j0+15 (mask m: those below n2) of the draws u placed into xy. With
 * k a power of two (pow2), (a + u) / k is (a + u) * (1/k): 1/k is exact and so is the
 * product (a + u >= 2^-24 or 0: no underflow), the same float as the quotient, without
 * the division's latency (most of the function's time at 16 samples). */
__attribute__((always_inline, SAMPLER_AVX512)) static inline void
jittered_place16(const Strata *g, __m512 kv, bool pow2, int j0, __mmask16 m, __m512 u,
                 float *xy)
{
    __m512 a = _mm512_maskz_loadu_ps(m, g->st + j0);
    __m512 hi = _mm512_maskz_loadu_ps(m, g->hi + j0);
    __m512 v = pow2 ? _mm512_mul_ps(_mm512_add_ps(a, u), kv) : _mm512_div_ps(_mm512_add_ps(a, u), kv);
    __m512i below = _mm512_sub_epi32(_mm512_castps_si512(hi), _mm512_set1_epi32(1));
    __mmask16 keep = _mm512_cmp_ps_mask(v, hi, _CMP_LT_OQ);
    __m512 r = _mm512_mask_blend_ps(keep, _mm512_castsi512_ps(below), v);
    _mm512_mask_storeu_ps(xy + j0, m, r);
}

__attribute__((always_inline, SAMPLER_AVX512)) static inline __mmask16 sampler_mask16(int left)
{
    return left >= 16 ? (__mmask16)0xffff : (__mmask16)((1u << left) - 1);
}

__attribute__((SAMPLER_AVX512)) static void jittered_pixel_avx512(const Strata *g, int k,
                                                                 uint64_t key,
                                                                 uint32_t stream, int n2,
                                                                 float *xy)
{
    __m512i base = _mm512_set1_epi64((long long)(key ^ (uint64_t)stream << 48));
    bool pow2 = (k & (k - 1)) == 0;
    __m512 kv = _mm512_set1_ps(pow2 ? 1.0f / (float)k : (float)k);
    /* 32 coordinates a step (16 samples: one): four independent hash chains */
    for (int j0 = 0; j0 < n2; j0 += 32) {
        __m256 d0 = jittered_draws8(base, j0), d1 = jittered_draws8(base, j0 + 8);
        __m256 d2 = jittered_draws8(base, j0 + 16), d3 = jittered_draws8(base, j0 + 24);
        jittered_place16(g, kv, pow2, j0, sampler_mask16(n2 - j0),
                         _mm512_insertf32x8(_mm512_castps256_ps512(d0), d1, 1), xy);
        if (j0 + 16 < n2)
            jittered_place16(g, kv, pow2, j0 + 16, sampler_mask16(n2 - j0 - 16),
                             _mm512_insertf32x8(_mm512_castps256_ps512(d2), d3, 1), xy);
    }
}

/* jittered_place in the lanes of jittered_pixel_avx512 (for sampler_jittered_place). */
__attribute__((SAMPLER_AVX512)) static void jittered_place_avx512(const Strata *g, int k,
                                                                 int n2, const float *u,
                                                                 float *xy)
{
    bool pow2 = (k & (k - 1)) == 0;
    __m512 kv = _mm512_set1_ps(pow2 ? 1.0f / (float)k : (float)k);
    for (int j0 = 0; j0 < n2; j0 += 16) {
        __mmask16 m = sampler_mask16(n2 - j0);
        jittered_place16(g, kv, pow2, j0, m, _mm512_maskz_loadu_ps(m, u + j0), xy);
    }
}
#define SAMPLER_HAVE_AVX512 1

/* AVX2: jittered_pixel_avx512's steps in four 64-bit lanes a hash and eight coordinates
 * a placement. AVX2 has no 64-bit multiply: z * C modulo 2^64 is lo(z) lo(C) + (hi(z)
 * lo(C) + lo(z) hi(C)) 2^32 (three vpmuludq; the dropped hi hi term is a multiple of
 * 2^64), the same integer as mix64's. A 16-sample pixel on the Zen 3 host (no
 * AVX-512; CPU time, best of 300 x 1000 pixels): 75-79 ns with the scalar draws and
 * plain lanes, 25-35 ns this way. */
#define SAMPLER_AVX2 target("avx2")

__attribute__((always_inline, SAMPLER_AVX2)) static inline __m256i sampler_mul64(__m256i z,
                                                                                uint64_t c)
{
    __m256i lo = _mm256_set1_epi64x((long long)(c & 0xffffffffu));
    __m256i hi = _mm256_set1_epi64x((long long)(c >> 32));
    __m256i cross = _mm256_add_epi64(_mm256_mul_epu32(_mm256_srli_epi64(z, 32), lo),
                                     _mm256_mul_epu32(z, hi));
    return _mm256_add_epi64(_mm256_mul_epu32(z, lo), _mm256_slli_epi64(cross, 32));
}

/* mix64 of four counters, then h >> 40 (below 2^24: the low dword holds it). */
__attribute__((always_inline, SAMPLER_AVX2)) static inline __m256i sampler_mix4(__m256i z)
{
    z = _mm256_add_epi64(z, _mm256_set1_epi64x((long long)0x9e3779b97f4a7c15ULL));
    z = sampler_mul64(_mm256_xor_si256(z, _mm256_srli_epi64(z, 30)), 0xbf58476d1ce4e5b9ULL);
    z = sampler_mul64(_mm256_xor_si256(z, _mm256_srli_epi64(z, 27)), 0x94d049bb133111ebULL);
    z = _mm256_xor_si256(z, _mm256_srli_epi64(z, 31));
    return _mm256_srli_epi64(z, 40);
}

/* Draws j0 .. j0+7 (j0 even) as floats: pixel_draw's counters dim = j & 1 (bit 32),
 * index = j >> 1 xor-ed into base = key ^ stream << 48. The two hash vectors hold draws
 * j0 + {0, 1, 4, 5} and j0 + {2, 3, 6, 7}, so that vshufps of their low dwords lists
 * j0 .. j0+7 in order; (float) of a value below 2^24 is exact in the int32 conversion. */
__attribute__((always_inline, SAMPLER_AVX2)) static inline __m256 jittered_draws8_avx2(__m256i base,
                                                                                   int j0)
{
    const long long d1 = 1LL << 32;
    __m256i h = _mm256_set1_epi64x(j0 >> 1);
    __m256i a = _mm256_xor_si256(base, _mm256_add_epi64(h, _mm256_setr_epi64x(0, d1, 2, d1 | 2)));
    __m256i b = _mm256_xor_si256(base, _mm256_add_epi64(h, _mm256_setr_epi64x(1, d1 | 1, 3, d1 | 3)));
    a = sampler_mix4(a);
    b = sampler_mix4(b);
    __m256i v = _mm256_castps_si256(_mm256_shuffle_ps(_mm256_castsi256_ps(a), _mm256_castsi256_ps(b),
                                                      _MM_SHUFFLE(2, 0, 2, 0)));
    return _mm256_mul_ps(_mm256_cvtepi32_ps(v), _mm256_set1_ps(0x1p-24f));
}

/* Coordinates j0 .. j0+7 (those below n2) of the draws u placed into xy, as
 * jittered_place16 (k a power of two: times the exact 1/k). */
__attribute__((always_inline, SAMPLER_AVX2)) static inline void
jittered_place8(const Strata *g, __m256 kv, bool pow2, int j0, int n2, __m256 u, float *xy)
{
    __m256 a, hi;
    __m256i m = _mm256_setzero_si256();
    bool whole = n2 - j0 >= 8;
    if (whole) {
        a = _mm256_loadu_ps(g->st + j0);
        hi = _mm256_loadu_ps(g->hi + j0);
    } else {
        m = _mm256_cmpgt_epi32(_mm256_set1_epi32(n2 - j0), _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        a = _mm256_maskload_ps(g->st + j0, m);
        hi = _mm256_maskload_ps(g->hi + j0, m);
    }
    __m256 v = pow2 ? _mm256_mul_ps(_mm256_add_ps(a, u), kv) : _mm256_div_ps(_mm256_add_ps(a, u), kv);
    __m256 below = _mm256_castsi256_ps(_mm256_sub_epi32(_mm256_castps_si256(hi), _mm256_set1_epi32(1)));
    __m256 r = _mm256_blendv_ps(below, v, _mm256_cmp_ps(v, hi, _CMP_LT_OQ));
    if (whole)
        _mm256_storeu_ps(xy + j0, r);
    else
        _mm256_maskstore_ps(xy + j0, m, r);
}

__attribute__((SAMPLER_AVX2)) static void jittered_pixel_avx2(const Strata *g, int k,
                                                             uint64_t key, uint32_t stream,
                                                             int n2, float *xy)
{
    __m256i base = _mm256_set1_epi64x((long long)(key ^ (uint64_t)stream << 48));
    bool pow2 = (k & (k - 1)) == 0;
    __m256 kv = _mm256_set1_ps(pow2 ? 1.0f / (float)k : (float)k);
    /* 16 coordinates a step: four independent hash chains */
    for (int j0 = 0; j0 < n2; j0 += 16) {
        __m256 d0 = jittered_draws8_avx2(base, j0), d1 = jittered_draws8_avx2(base, j0 + 8);
        jittered_place8(g, kv, pow2, j0, n2, d0, xy);
        if (j0 + 8 < n2)
            jittered_place8(g, kv, pow2, j0 + 8, n2, d1, xy);
    }
}

/* jittered_place in the lanes of jittered_pixel_avx2 (for sampler_jittered_place). */
__attribute__((SAMPLER_AVX2)) static void jittered_place_avx2(const Strata *g, int k, int n2,
                                                             const float *u, float *xy)
{
    bool pow2 = (k & (k - 1)) == 0;
    __m256 kv = _mm256_set1_ps(pow2 ? 1.0f / (float)k : (float)k);
    for (int j0 = 0; j0 < n2; j0 += 8) {
        __m256i m = _mm256_cmpgt_epi32(_mm256_set1_epi32(n2 - j0),
                                       _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
        jittered_place8(g, kv, pow2, j0, n2, _mm256_maskload_ps(u + j0, m), xy);
    }
}
#endif

/* One random position in each cell of the k x k grid, cells in the uniform order. */
static void jittered_pixel(const Sampler *s, int x, int y, float *xy)
{
    int k = s->k, n2 = 2 * s->count;
    uint64_t key = pixel_key(s->seed, x, y);
    const Strata *g = grid_strata(k);
#ifdef SAMPLER_HAVE_AVX512
    if (s->vec == 2) {
        jittered_pixel_avx512(g, k, key, s->stream, n2, xy);
        return;
    }
    if (s->vec == 1) {
        jittered_pixel_avx2(g, k, key, s->stream, n2, xy);
        return;
    }
#endif
    float u[2 * SAMPLER_MAX_COUNT + 4];
    jittered_draws(key, s->stream, n2, u);
    jittered_place(g, k, n2, u, xy);
}

void sampler_jittered_place(const Sampler *s, const float *u, float *xy)
{
    const Strata *g = grid_strata(s->k);
#ifdef SAMPLER_HAVE_AVX512
    if (s->vec == 2) {
        jittered_place_avx512(g, s->k, 2 * s->count, u, xy);
        return;
    }
    if (s->vec == 1) {
        jittered_place_avx2(g, s->k, 2 * s->count, u, xy);
        return;
    }
#endif
    jittered_place(g, s->k, 2 * s->count, u, xy);
}

/* N-rooks (Shirley 1991): sample s lies in row stratum s of n and in column stratum
 * perm(s), perm a random permutation per pixel, so both projections are stratified for
 * any n, not only squares. */
static void nrooks_pixel(const Sampler *s, int x, int y, float *xy)
{
    int n = s->count;
    uint64_t key = pixel_key(s->seed, x, y);
    int perm[SAMPLER_MAX_COUNT];
    for (int i = 0; i < n; i++)
        perm[i] = i;
    /* Fisher-Yates with draws from dimension 2 (0 and 1 are the positions). */
    for (int i = n - 1; i > 0; i--) {
        float r = pixel_draw(key, s->stream, (uint32_t)i, 2);
        int j = (int)(r * (float)(i + 1));
        if (j > i)
            j = i;
        int t = perm[i];
        perm[i] = perm[j];
        perm[j] = t;
    }
    for (int i = 0; i < n; i++) {
        float u = pixel_draw(key, s->stream, (uint32_t)i, 0);
        float v = pixel_draw(key, s->stream, (uint32_t)i, 1);
        xy[2 * i] = in_stratum(perm[i], u, n);
        xy[2 * i + 1] = in_stratum(i, v, n);
    }
}

/* Poisson-disk-like positions by Mitchell's best-candidate algorithm (1991): sample i
 * is the best of POISSON_CANDIDATES random candidates, the one farthest from the
 * samples placed before it, so samples keep apart like a Poisson-disk pattern without
 * a radius to tune, and the count is always exact. Candidate c of sample i is draw
 * i * POISSON_CANDIDATES + c of the pixel's stream; the work is quadratic in the count,
 * hence its lower maximum. */
#define POISSON_CANDIDATES 8
#define POISSON_MAX_COUNT 256

static void poisson_pixel(const Sampler *s, int x, int y, float *xy)
{
    uint64_t key = pixel_key(s->seed, x, y);
    for (int i = 0; i < s->count; i++) {
        float best_d = -1.0f, bu = 0.0f, bv = 0.0f;
        for (int c = 0; c < (i == 0 ? 1 : POISSON_CANDIDATES); c++) {
            uint32_t draw = (uint32_t)(i * POISSON_CANDIDATES + c);
            float u = pixel_draw(key, s->stream, draw, 0);
            float v = pixel_draw(key, s->stream, draw, 1);
            float d = 2.0f; /* squared distance to the nearest placed sample */
            for (int j = 0; j < i; j++) {
                float du = u - xy[2 * j], dv = v - xy[2 * j + 1];
                float dd = du * du + dv * dv;
                d = dd < d ? dd : d;
            }
            if (d > best_d) {
                best_d = d;
                bu = u;
                bv = v;
            }
        }
        xy[2 * i] = bu;
        xy[2 * i + 1] = bv;
    }
}

static const SamplerOps center_ops = {"center", false, true, center_pixel, 0};
static const SamplerOps uniform_ops = {"uniform", true, true, uniform_pixel, 0};
static const SamplerOps random_ops = {"random", false, false, random_pixel, 0};
static const SamplerOps jittered_ops = {"jittered", true, false, jittered_pixel, 0};
static const SamplerOps nrooks_ops = {"nrooks", false, false, nrooks_pixel, 0};
static const SamplerOps poisson_ops = {"poisson", false, false, poisson_pixel,
                                       POISSON_MAX_COUNT};

static const SamplerOps *const all_samplers[] = {&center_ops, &uniform_ops, &random_ops,
                                                 &jittered_ops, &nrooks_ops, &poisson_ops};

const SamplerOps *sampler_find(const char *name)
{
    for (size_t i = 0; i < sizeof all_samplers / sizeof all_samplers[0]; i++)
        if (strcmp(all_samplers[i]->name, name) == 0)
            return all_samplers[i];
    return NULL;
}

void sampler_init_center(Sampler *s)
{
    memset(s, 0, sizeof *s);
    s->ops = &center_ops;
    s->count = 1;
    s->k = 1;
}

bool sampler_init(Sampler *s, const SamplerOps *ops, int count, uint64_t seed, char *why,
                  size_t whylen)
{
    memset(s, 0, sizeof *s);
    int most = ops->max_count > 0 ? ops->max_count : SAMPLER_MAX_COUNT;
    if (count < 1 || count > most) {
        snprintf(why, whylen, "%d samples per pixel is out of range 1..%d", count, most);
        return false;
    }
    int k = 1;
    if (ops->square) {
        while ((k + 1) * (k + 1) <= count)
            k++;
        if (k * k != count) {
            snprintf(why, whylen, "%d is not a square number of samples (1, 4, 9, 16, ...; "
                     "nearest: %d or %d)", count, k * k, (k + 1) * (k + 1));
            return false;
        }
    }
    if (ops == &center_ops && count != 1) {
        snprintf(why, whylen, "the centre sampler takes exactly one sample");
        return false;
    }
    s->ops = ops;
    s->count = count;
    s->k = k;
    s->seed = seed;
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    s->vec = cpu_has_avx512() ? 2 : cpu_has_avx2() ? 1 : 0;
#endif
    return true;
}
