/* Ken Perlin's improved noise (SIGGRAPH 2002, "Improving Noise"), in double precision as
 * the course's perlin_noise.C, plus the A6 octave sum (docs/textures.md). */
#include "rt/perlin.h"
#include "rt/cpu.h"

#include <math.h>
#include <pthread.h>
#include <stdint.h>
#include <string.h>

/* Ken Perlin's published permutation of 0..255 (a constant of the algorithm). The
 * algorithm indexes up to P[P[P[X+1]+Y+1]+Z+1] <= 511; perm() takes the index modulo
 * 256 instead of storing the table twice. The first three entries follow the 256
 * again: the lane kernels below gather the 32-bit word at byte i (0 <= i <= 255),
 * whose two low bytes are P[i] and P[(i + 1) mod 256] on a little-endian x86, the two
 * values every step of the hash asks for. */
static const unsigned char PERLIN_PERM[256 + 3] = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225,
    140, 36,  103, 30,  69,  142, 8,   99,  37,  240, 21,  10,  23,  190, 6,   148,
    247, 120, 234, 75,  0,   26,  197, 62,  94,  252, 219, 203, 117, 35,  11,  32,
    57,  177, 33,  88,  237, 149, 56,  87,  174, 20,  125, 136, 171, 168, 68,  175,
    74,  165, 71,  134, 139, 48,  27,  166, 77,  146, 158, 231, 83,  111, 229, 122,
    60,  211, 133, 230, 220, 105, 92,  41,  55,  46,  245, 40,  244, 102, 143, 54,
    65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,  18,  169,
    200, 196, 135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,
    52,  217, 226, 250, 124, 123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212,
    207, 206, 59,  227, 47,  16,  58,  17,  182, 189, 28,  42,  223, 183, 170, 213,
    119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101, 155, 167, 43,  172, 9,
    129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185, 112, 104,
    218, 246, 97,  228, 251, 34,  242, 193, 238, 210, 144, 12,  191, 179, 162, 241,
    81,  51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,  181, 199, 106, 157,
    184, 84,  204, 176, 115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,
    222, 114, 67,  29,  24,  72,  243, 141, 128, 195, 78,  66,  215, 61,  156, 180,
    151, 160, 137, /* P[0], P[1], P[2] again */
};

/* P[i] for i in 0..511: the doubled table without a mutable global (threads share it). */
static inline int perm(int i) { return PERLIN_PERM[i & 255]; }

/* 6t^5 - 15t^4 + 10t^3: the 2002 quintic, with zero first and second derivatives at 0
 * and 1 (the reason the improved noise has no lattice artefacts). Horner form as in the
 * reference code. */
static inline double fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }

static inline double lerp(double t, double a, double b) { return a + t * (b - a); }

/* Dot product of (x,y,z) with one of the 12 cube-edge gradients (16 with 4 repeated),
 * selected by the low four hash bits exactly as the reference does. Branches: the
 * scalar path (CPUs without AVX2) keeps them, as branch-free scalar forms (tables, bit
 * masks) measured slower there on a render's coherent points; noise3_avx2 below has
 * none. */
static inline double grad(int hash, double x, double y, double z)
{
    int h = hash & 15;
    double u = h < 8 ? x : y;
    double v = h < 4 ? y : (h == 12 || h == 14) ? x : z;
    return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
}

/* The reference evaluation, one corner at a time (the grads branch on the hashes). */
static double noise3_scalar(double x, double y, double z)
{
    double fx = floor(x), fy = floor(y), fz = floor(z);
    /* The lattice cell modulo 256, also for negative coordinates: floor then AND with 255
     * on the two's-complement integer (the course's int arithmetic). Coordinates far
     * beyond the int range are meaningless for a texture; clamp before converting so the
     * conversion is defined (no UB on huge or non-finite input). */
    if (!(fabs(fx) < 1e9) || !(fabs(fy) < 1e9) || !(fabs(fz) < 1e9))
        return 0.0;
    int X = (int)fx & 255, Y = (int)fy & 255, Z = (int)fz & 255;
    x -= fx;
    y -= fy;
    z -= fz;
    double u = fade(x), v = fade(y), w = fade(z);

    /* Hashes of the eight cell corners: P[P[P[X+i]+Y+j]+Z+k]. */
    int A = perm(X) + Y, AA = perm(A) + Z, AB = perm(A + 1) + Z;
    int B = perm(X + 1) + Y, BA = perm(B) + Z, BB = perm(B + 1) + Z;

    return lerp(w,
                lerp(v, lerp(u, grad(perm(AA), x, y, z), grad(perm(BA), x - 1, y, z)),
                     lerp(u, grad(perm(AB), x, y - 1, z), grad(perm(BB), x - 1, y - 1, z))),
                lerp(v,
                     lerp(u, grad(perm(AA + 1), x, y, z - 1),
                          grad(perm(BA + 1), x - 1, y, z - 1)),
                     lerp(u, grad(perm(AB + 1), x, y - 1, z - 1),
                          grad(perm(BB + 1), x - 1, y - 1, z - 1))));
}

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* The same evaluation with the eight corners in the lanes of two AVX2 vectors: lo holds
 * the corners at x (cell corner i = 0), hi those at x - 1, each in the order (y, z),
 * (y - 1, z), (y, z - 1), (y - 1, z - 1), so lane l of the x lerp is the reference's
 * lerp(u, corner(0, j, k), corner(1, j, k)); the y lerp pairs lanes 0/1 and 2/3, the z
 * lerp the two results. grad without branches: the selections of u and v are bit masks
 * from the hash's compares, the negations flips of the sign bit (exactly IEEE
 * negation). Every value is the same operation on the same operands as in
 * noise3_scalar (no FMA: the target adds none, and the file is built without fusing),
 * so the same bits, with no branch on the hashes. The branches mispredicted (callgrind's
 * simulator, course line 17a: 6.3 per call for one centred sample per pixel, 3.5 for
 * 16 uniform samples, 4.0 for 16 jittered ones; cpu-clock samples put a quarter more
 * time in the noise for jittered than for uniform samples), and the instructions per
 * call fall from 306 to 194. */
typedef double PerlinV4d __attribute__((vector_size(32)));
typedef int64_t PerlinV4i __attribute__((vector_size(32)));
typedef uint64_t PerlinV4u __attribute__((vector_size(32)));

__attribute__((target("avx2"))) static inline PerlinV4d
grad4(PerlinV4i h, PerlinV4d x, PerlinV4d y, PerlinV4d z)
{
    h &= 15;
    PerlinV4i xi = (PerlinV4i)x, yi = (PerlinV4i)y, zi = (PerlinV4i)z;
    PerlinV4i to_x = h < 8;                       /* u = x, else y */
    PerlinV4i v_y = h < 4;                        /* v = y */
    PerlinV4i v_x = (h == 12) | (h == 14);        /* v = x (never with v_y) */
    PerlinV4u u = (PerlinV4u)((xi & to_x) | (yi & ~to_x));
    PerlinV4u v = (PerlinV4u)((yi & v_y) | (xi & v_x) | (zi & ~(v_y | v_x)));
    u ^= ((PerlinV4u)h & 1) << 63;
    v ^= ((PerlinV4u)h & 2) << 62;
    return (PerlinV4d)u + (PerlinV4d)v;
}

__attribute__((target("avx2"))) static double noise3_avx2(double x, double y, double z)
{
    double fx = floor(x), fy = floor(y), fz = floor(z);
    if (!(fabs(fx) < 1e9) || !(fabs(fy) < 1e9) || !(fabs(fz) < 1e9))
        return 0.0;
    int X = (int)fx & 255, Y = (int)fy & 255, Z = (int)fz & 255;
    x -= fx;
    y -= fy;
    z -= fz;
    double u = fade(x), v = fade(y), w = fade(z);
    int A = perm(X) + Y, AA = perm(A) + Z, AB = perm(A + 1) + Z;
    int B = perm(X + 1) + Y, BA = perm(B) + Z, BB = perm(B + 1) + Z;
    double x1 = x - 1, y1 = y - 1, z1 = z - 1;
    PerlinV4i hlo = {perm(AA), perm(AB), perm(AA + 1), perm(AB + 1)};
    PerlinV4i hhi = {perm(BA), perm(BB), perm(BA + 1), perm(BB + 1)};
    PerlinV4d ys = {y, y1, y, y1}, zs = {z, z, z1, z1};
    PerlinV4d glo = grad4(hlo, (PerlinV4d){x, x, x, x}, ys, zs);
    PerlinV4d ghi = grad4(hhi, (PerlinV4d){x1, x1, x1, x1}, ys, zs);
    PerlinV4d lx = glo + u * (ghi - glo); /* lerp(u, lo, hi) lane by lane */
    double l00 = lx[0], l10 = lx[1], l01 = lx[2], l11 = lx[3];
    return lerp(w, lerp(v, l00, l10), lerp(v, l01, l11));
}
#define PERLIN_HAVE_AVX2 1

/* The lane kernels (perlin_lanes.h): one point per lane, the permutation read by
 * gathers of the byte table (each lane's word at byte i, its low byte kept). */
#include <immintrin.h>

static const int *perm_words(void) { return (const int *)(const void *)PERLIN_PERM; }

/* The lane kernels' noise_cell (perlin_lanes.h): for hash h & 15 and corner c = i + 2j +
 * 4k of a cell, which of the twelve vectors d[axis * 4 + bit * 2 + negated] (the
 * distances x - i', y - j', z - k' for bits i', j', k' of 0 and 1, and their
 * negations) grad adds as u (CELL_U) and as v (CELL_V): u is x (h < 8) or y;
 * v is y (h < 4), x (h 12 and 14) or z; bit 0 of h negates u, bit 1 negates v. */
#define CELL_U(h, i, j) (((h) < 8 ? 2 * (i) : 4 + 2 * (j)) + ((h) & 1))
#define CELL_V(h, i, j, k)                                                                   \
    (((h) < 4 ? 4 + 2 * (j) : (h) == 12 || (h) == 14 ? 2 * (i) : 8 + 2 * (k)) + ((h) >> 1 & 1))

/* AVX-512 (F, VL, DQ): eight doubles a vector, the ints in a 256-bit vector. */
#define PL_TARGET __attribute__((target("avx512f,avx512vl,avx512dq,avx512bw")))
#define PL_W 8
#define PL_D __m512d
#define PL_I __m256i
#define PL_(name) name##_x8
#define PL_FN octaves_lanes_avx512
PL_TARGET static inline __m512d d_set_x8(double a) { return _mm512_set1_pd(a); }
PL_TARGET static inline __m512d d_load_x8(const double *p) { return _mm512_loadu_pd(p); }
PL_TARGET static inline void d_store_x8(double *p, __m512d a) { _mm512_storeu_pd(p, a); }
PL_TARGET static inline __m512d d_add_x8(__m512d a, __m512d b) { return _mm512_add_pd(a, b); }
PL_TARGET static inline __m512d d_sub_x8(__m512d a, __m512d b) { return _mm512_sub_pd(a, b); }
PL_TARGET static inline __m512d d_mul_x8(__m512d a, __m512d b) { return _mm512_mul_pd(a, b); }
PL_TARGET static inline __m512d d_neg_x8(__m512d a)
{
    return _mm512_xor_pd(a, _mm512_set1_pd(-0.0));
}
PL_TARGET static inline __m512d d_floor_x8(__m512d a)
{
    return _mm512_roundscale_pd(a, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
}
PL_TARGET static inline double d_lane0_x8(__m512d a) { return _mm512_cvtsd_f64(a); }
PL_TARGET static inline bool d_one_cell_x8(__m512d fx, __m512d fy, __m512d fz)
{
    __m512d x0 = _mm512_broadcastsd_pd(_mm512_castpd512_pd128(fx));
    __m512d y0 = _mm512_broadcastsd_pd(_mm512_castpd512_pd128(fy));
    __m512d z0 = _mm512_broadcastsd_pd(_mm512_castpd512_pd128(fz));
    __mmask8 same = _mm512_cmp_pd_mask(fx, x0, _CMP_EQ_OQ) &
                    _mm512_cmp_pd_mask(fy, y0, _CMP_EQ_OQ) &
                    _mm512_cmp_pd_mask(fz, z0, _CMP_EQ_OQ);
    return same == 0xFF;
}
PL_TARGET static inline __m512d d_zero_unless_small_x8(__m512d r, __m512d fx, __m512d fy,
                                                       __m512d fz)
{
    __m512d lim = _mm512_set1_pd(1e9);
    __mmask8 ok = _mm512_cmp_pd_mask(_mm512_abs_pd(fx), lim, _CMP_LT_OQ) &
                  _mm512_cmp_pd_mask(_mm512_abs_pd(fy), lim, _CMP_LT_OQ) &
                  _mm512_cmp_pd_mask(_mm512_abs_pd(fz), lim, _CMP_LT_OQ);
    return _mm512_maskz_mov_pd(ok, r);
}
PL_TARGET static inline __m256i i_trunc_x8(__m512d a) { return _mm512_cvttpd_epi32(a); }
PL_TARGET static inline __m256i i_set_x8(int a) { return _mm256_set1_epi32(a); }
PL_TARGET static inline __m256i i_add_x8(__m256i a, __m256i b) { return _mm256_add_epi32(a, b); }
PL_TARGET static inline __m256i i_and_x8(__m256i a, __m256i b) { return _mm256_and_si256(a, b); }
/* P[i & 255] + 256 P[(i + 1) & 255] per lane (and higher bytes above). */
PL_TARGET static inline __m256i i_perm2_x8(__m256i i)
{
    return _mm256_i32gather_epi32(perm_words(), _mm256_and_si256(i, _mm256_set1_epi32(255)), 1);
}
PL_TARGET static inline __m256i i_byte0_x8(__m256i w)
{
    return _mm256_and_si256(w, _mm256_set1_epi32(255));
}
PL_TARGET static inline __m256i i_byte1_x8(__m256i w)
{
    return _mm256_and_si256(_mm256_srli_epi32(w, 8), _mm256_set1_epi32(255));
}
/* grad: u and v selected by the hash's compares, negated by flipping the sign bit
 * (exactly IEEE negation), as grad4. */
PL_TARGET static inline __m512d grad_x8(__m256i h, __m512d x, __m512d y, __m512d z)
{
    h = _mm256_and_si256(h, _mm256_set1_epi32(15));
    __mmask8 to_x = _mm256_cmplt_epi32_mask(h, _mm256_set1_epi32(8));
    __mmask8 v_y = _mm256_cmplt_epi32_mask(h, _mm256_set1_epi32(4));
    __mmask8 v_x = _mm256_cmpeq_epi32_mask(h, _mm256_set1_epi32(12)) |
                   _mm256_cmpeq_epi32_mask(h, _mm256_set1_epi32(14));
    __mmask8 neg_u = _mm256_test_epi32_mask(h, _mm256_set1_epi32(1));
    __mmask8 neg_v = _mm256_test_epi32_mask(h, _mm256_set1_epi32(2));
    __m512d sign = _mm512_set1_pd(-0.0);
    __m512d u = _mm512_mask_blend_pd(to_x, y, x);
    __m512d v = _mm512_mask_blend_pd(v_y, _mm512_mask_blend_pd(v_x, z, x), y);
    u = _mm512_mask_xor_pd(u, neg_u, u, sign);
    v = _mm512_mask_xor_pd(v, neg_v, v, sign);
    return _mm512_add_pd(u, v);
}
#include "perlin_lanes.h"
#undef PL_TARGET
#undef PL_W
#undef PL_D
#undef PL_I
#undef PL_
#undef PL_FN

/* AVX-512 with VBMI: the same eight lanes, the hashes in bytes. Every step of the hash
 * is wanted modulo 256 only (perm takes its index modulo 256, grad the low four bits),
 * so byte arithmetic, which wraps, gives the same values; the table's 256 bytes sit
 * in four registers and a lookup of 64 bytes is two two-register byte permutes and a
 * blend on the index's top bit, instead of a gather from memory (whose latency the
 * three dependent steps of the hash serialise). The eight points' bytes fill a
 * 64-bit quarter of a vector: [X, X+1] looked up gives [P(X), P(X+1)], plus Y the
 * quarters [A, B]; [A, A+1, B, B+1] gives, plus Z, [AA, AB, BA, BB]; those and their
 * +1 give the eight corner hashes at once, in the quarters 0 .. 7: AA, AB, BA, BB,
 * AA+1, AB+1, BA+1, BB+1. */
#define VB_TARGET __attribute__((target("avx512f,avx512vl,avx512dq,avx512bw,avx512vbmi")))

/* P[idx & 255] for every byte of idx: the table in t[0..3], 64 bytes each. */
VB_TARGET static inline __m512i vb_lookup(__m512i idx, const __m512i *t)
{
    __m512i lo = _mm512_permutex2var_epi8(t[0], idx, t[1]);
    __m512i hi = _mm512_permutex2var_epi8(t[2], idx, t[3]);
    return _mm512_mask_blend_epi8(_mm512_movepi8_mask(idx), lo, hi);
}

/* grad for the lanes of one corner (the masks' byte c of each quarter: bits 8c..8c+7). */
VB_TARGET static inline __m512d vb_grad(int c, __mmask64 to_x, __mmask64 v_y, __mmask64 v_x,
                                        __mmask64 neg_u, __mmask64 neg_v, __m512d x,
                                        __m512d y, __m512d z)
{
    __m512d sign = _mm512_set1_pd(-0.0);
    __m512d u = _mm512_mask_blend_pd((__mmask8)(to_x >> (8 * c)), y, x);
    __m512d v = _mm512_mask_blend_pd((__mmask8)(v_y >> (8 * c)),
                                     _mm512_mask_blend_pd((__mmask8)(v_x >> (8 * c)), z, x), y);
    u = _mm512_mask_xor_pd(u, (__mmask8)(neg_u >> (8 * c)), u, sign);
    v = _mm512_mask_xor_pd(v, (__mmask8)(neg_v >> (8 * c)), v, sign);
    return _mm512_add_pd(u, v);
}

/* The low bytes of eight ints (the cell modulo 256) in the low quarter. */
VB_TARGET static inline __m128i vb_bytes(__m512d f)
{
    return _mm256_cvtepi32_epi8(_mm512_cvttpd_epi32(f));
}

VB_TARGET static inline __m512d noise_v8(__m512d x, __m512d y, __m512d z, __m512d fx,
                                        __m512d fy, __m512d fz)
{
    const __m512i t[4] = {_mm512_loadu_si512(PERLIN_PERM), _mm512_loadu_si512(PERLIN_PERM + 64),
                          _mm512_loadu_si512(PERLIN_PERM + 128),
                          _mm512_loadu_si512(PERLIN_PERM + 192)};
    const long long ones = 0x0101010101010101LL;
    __m128i X = vb_bytes(fx), Y = vb_bytes(fy), Z = vb_bytes(fz);
    __m512d one = _mm512_set1_pd(1.0);
    __m512d x0 = _mm512_sub_pd(x, fx), y0 = _mm512_sub_pd(y, fy), z0 = _mm512_sub_pd(z, fz);
    __m512d u = fade_x8(x0), v = fade_x8(y0), w = fade_x8(z0);
    /* [X, X+1] -> [P(X) + Y, P(X+1) + Y] = [A, B] */
    __m128i i1 = _mm_add_epi8(_mm_unpacklo_epi64(X, X), _mm_set_epi64x(ones, 0));
    __m128i ab = _mm_add_epi8(_mm512_castsi512_si128(vb_lookup(_mm512_zextsi128_si512(i1), t)),
                              _mm_unpacklo_epi64(Y, Y));
    /* [A, A+1, B, B+1] -> [AA, AB, BA, BB] */
    __m256i i2 = _mm256_add_epi8(
        _mm256_permute4x64_epi64(_mm256_zextsi128_si256(ab), _MM_SHUFFLE(1, 1, 0, 0)),
        _mm256_set_epi64x(ones, 0, ones, 0));
    __m256i h2 = _mm256_add_epi8(_mm512_castsi512_si256(vb_lookup(_mm512_zextsi256_si512(i2), t)),
                                 _mm256_broadcastq_epi64(Z));
    /* [AA, AB, BA, BB, AA+1, AB+1, BA+1, BB+1] -> the corner hashes */
    __m512i i3 = _mm512_add_epi8(_mm512_broadcast_i64x4(h2),
                                 _mm512_set_epi64(ones, ones, ones, ones, 0, 0, 0, 0));
    __m512i h = _mm512_and_si512(vb_lookup(i3, t), _mm512_set1_epi8(15));
    __mmask64 to_x = _mm512_cmplt_epu8_mask(h, _mm512_set1_epi8(8));
    __mmask64 v_y = _mm512_cmplt_epu8_mask(h, _mm512_set1_epi8(4));
    __mmask64 v_x = _mm512_cmpeq_epi8_mask(h, _mm512_set1_epi8(12)) |
                    _mm512_cmpeq_epi8_mask(h, _mm512_set1_epi8(14));
    __mmask64 neg_u = _mm512_test_epi8_mask(h, _mm512_set1_epi8(1));
    __mmask64 neg_v = _mm512_test_epi8_mask(h, _mm512_set1_epi8(2));
    __m512d x1 = _mm512_sub_pd(x0, one), y1 = _mm512_sub_pd(y0, one), z1 = _mm512_sub_pd(z0, one);
    __m512d g000 = vb_grad(0, to_x, v_y, v_x, neg_u, neg_v, x0, y0, z0);
    __m512d g010 = vb_grad(1, to_x, v_y, v_x, neg_u, neg_v, x0, y1, z0);
    __m512d g100 = vb_grad(2, to_x, v_y, v_x, neg_u, neg_v, x1, y0, z0);
    __m512d g110 = vb_grad(3, to_x, v_y, v_x, neg_u, neg_v, x1, y1, z0);
    __m512d g001 = vb_grad(4, to_x, v_y, v_x, neg_u, neg_v, x0, y0, z1);
    __m512d g011 = vb_grad(5, to_x, v_y, v_x, neg_u, neg_v, x0, y1, z1);
    __m512d g101 = vb_grad(6, to_x, v_y, v_x, neg_u, neg_v, x1, y0, z1);
    __m512d g111 = vb_grad(7, to_x, v_y, v_x, neg_u, neg_v, x1, y1, z1);
    __m512d r = lerp_x8(w, lerp_x8(v, lerp_x8(u, g000, g100), lerp_x8(u, g010, g110)),
                        lerp_x8(v, lerp_x8(u, g001, g101), lerp_x8(u, g011, g111)));
    return d_zero_unless_small_x8(r, fx, fy, fz);
}

#define PL_OWN_NOISE 1
#define PL_TARGET VB_TARGET
#define PL_W 8
#define PL_D __m512d
#define PL_I __m256i
#define PL_(name) name##_v8
#define PL_FN octaves_lanes_avx512vbmi
#define d_set_v8 d_set_x8
#define d_load_v8 d_load_x8
#define d_store_v8 d_store_x8
#define d_add_v8 d_add_x8
#define d_sub_v8 d_sub_x8
#define d_mul_v8 d_mul_x8
#define d_neg_v8 d_neg_x8
#define d_floor_v8 d_floor_x8
#define d_lane0_v8 d_lane0_x8
#define d_one_cell_v8 d_one_cell_x8
#include "perlin_lanes.h"
#undef PL_OWN_NOISE
#undef PL_TARGET
#undef PL_W
#undef PL_D
#undef PL_I
#undef PL_
#undef PL_FN

/* AVX2: four doubles a vector, the ints in a 128-bit vector. */
#define PL_TARGET __attribute__((target("avx2")))
#define PL_W 4
#define PL_D __m256d
#define PL_I __m128i
#define PL_(name) name##_x4
#define PL_FN octaves_lanes_avx2
PL_TARGET static inline __m256d d_set_x4(double a) { return _mm256_set1_pd(a); }
PL_TARGET static inline __m256d d_load_x4(const double *p) { return _mm256_loadu_pd(p); }
PL_TARGET static inline void d_store_x4(double *p, __m256d a) { _mm256_storeu_pd(p, a); }
PL_TARGET static inline __m256d d_add_x4(__m256d a, __m256d b) { return _mm256_add_pd(a, b); }
PL_TARGET static inline __m256d d_sub_x4(__m256d a, __m256d b) { return _mm256_sub_pd(a, b); }
PL_TARGET static inline __m256d d_mul_x4(__m256d a, __m256d b) { return _mm256_mul_pd(a, b); }
PL_TARGET static inline __m256d d_neg_x4(__m256d a)
{
    return _mm256_xor_pd(a, _mm256_set1_pd(-0.0));
}
PL_TARGET static inline __m256d d_floor_x4(__m256d a)
{
    return _mm256_round_pd(a, _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC);
}
PL_TARGET static inline double d_lane0_x4(__m256d a) { return _mm256_cvtsd_f64(a); }
PL_TARGET static inline bool d_one_cell_x4(__m256d fx, __m256d fy, __m256d fz)
{
    __m256d x0 = _mm256_permute4x64_pd(fx, 0), y0 = _mm256_permute4x64_pd(fy, 0),
            z0 = _mm256_permute4x64_pd(fz, 0);
    __m256d same = _mm256_and_pd(_mm256_and_pd(_mm256_cmp_pd(fx, x0, _CMP_EQ_OQ),
                                               _mm256_cmp_pd(fy, y0, _CMP_EQ_OQ)),
                                 _mm256_cmp_pd(fz, z0, _CMP_EQ_OQ));
    return _mm256_movemask_pd(same) == 15;
}
PL_TARGET static inline __m256d d_zero_unless_small_x4(__m256d r, __m256d fx, __m256d fy,
                                                       __m256d fz)
{
    __m256d lim = _mm256_set1_pd(1e9), sign = _mm256_set1_pd(-0.0);
    __m256d ok = _mm256_and_pd(
        _mm256_and_pd(_mm256_cmp_pd(_mm256_andnot_pd(sign, fx), lim, _CMP_LT_OQ),
                      _mm256_cmp_pd(_mm256_andnot_pd(sign, fy), lim, _CMP_LT_OQ)),
        _mm256_cmp_pd(_mm256_andnot_pd(sign, fz), lim, _CMP_LT_OQ));
    return _mm256_and_pd(ok, r);
}
PL_TARGET static inline __m128i i_trunc_x4(__m256d a) { return _mm256_cvttpd_epi32(a); }
PL_TARGET static inline __m128i i_set_x4(int a) { return _mm_set1_epi32(a); }
PL_TARGET static inline __m128i i_add_x4(__m128i a, __m128i b) { return _mm_add_epi32(a, b); }
PL_TARGET static inline __m128i i_and_x4(__m128i a, __m128i b) { return _mm_and_si128(a, b); }
PL_TARGET static inline __m128i i_perm2_x4(__m128i i)
{
    return _mm_i32gather_epi32(perm_words(), _mm_and_si128(i, _mm_set1_epi32(255)), 1);
}
PL_TARGET static inline __m128i i_byte0_x4(__m128i w) { return _mm_and_si128(w, _mm_set1_epi32(255)); }
PL_TARGET static inline __m128i i_byte1_x4(__m128i w)
{
    return _mm_and_si128(_mm_srli_epi32(w, 8), _mm_set1_epi32(255));
}
PL_TARGET static inline __m256d grad_x4(__m128i h, __m256d x, __m256d y, __m256d z)
{
    return (__m256d)grad4((PerlinV4i)_mm256_cvtepi32_epi64(h), (PerlinV4d)x, (PerlinV4d)y,
                          (PerlinV4d)z);
}
#include "perlin_lanes.h"
#undef PL_TARGET
#undef PL_W
#undef PL_D
#undef PL_I
#undef PL_
#undef PL_FN
#endif

/* The portable lane kernel: the scalar code point by point. */
static void octaves_lanes_scalar(const double *x, const double *y, const double *z, int n,
                                 int octaves, double *out)
{
    for (int i = 0; i < n; i++)
        out[i] = perlin_octaves(x[i], y[i], z[i], octaves);
}

typedef void (*LanesFn)(const double *, const double *, const double *, int, int, double *);

typedef struct LanesKernel {
    const char *name;
    LanesFn fn;
    bool (*usable)(void);
} LanesKernel;

static bool always(void) { return true; }

static const LanesKernel lanes_kernels[] = {
    {"scalar", octaves_lanes_scalar, always},
#ifdef PERLIN_HAVE_AVX2
    {"avx2", octaves_lanes_avx2, cpu_has_avx2},
    {"avx512", octaves_lanes_avx512, cpu_has_avx512},
    {"avx512vbmi", octaves_lanes_avx512vbmi, cpu_has_avx512vbmi},
#endif
};
enum { NUM_LANES_KERNELS = sizeof lanes_kernels / sizeof lanes_kernels[0] };

static const LanesKernel *lanes_kernel = &lanes_kernels[0];
static pthread_once_t lanes_once = PTHREAD_ONCE_INIT;

static void choose_lanes_kernel(void)
{
    for (int i = NUM_LANES_KERNELS - 1; i > 0; i--)
        if (lanes_kernels[i].usable()) {
            lanes_kernel = &lanes_kernels[i];
            return;
        }
}

const char *perlin_lanes_kernel(void)
{
    pthread_once(&lanes_once, choose_lanes_kernel);
    return lanes_kernel->name;
}

bool perlin_use_lanes_kernel(const char *name)
{
    pthread_once(&lanes_once, choose_lanes_kernel);
    for (int i = 0; i < NUM_LANES_KERNELS; i++)
        if (!strcmp(name, lanes_kernels[i].name) && lanes_kernels[i].usable()) {
            lanes_kernel = &lanes_kernels[i];
            return true;
        }
    return false;
}

void perlin_octaves_lanes(const double *x, const double *y, const double *z, int n,
                          int octaves, double *out)
{
    pthread_once(&lanes_once, choose_lanes_kernel);
    lanes_kernel->fn(x, y, z, n, octaves, out);
}

double perlin_noise3(double x, double y, double z)
{
#ifdef PERLIN_HAVE_AVX2
    if (cpu_has_avx2())
        return noise3_avx2(x, y, z);
#endif
    return noise3_scalar(x, y, z);
}

double perlin_octaves(double x, double y, double z, int octaves)
{
    /* N(p) = sum_{i<octaves} noise(2^i p) / 2^i (A6 page). Scaling by powers of two is
     * exact in double, so this equals the course's loop bit for bit. */
    double sum = 0.0, scale = 1.0;
    for (int i = 0; i < octaves; i++) {
        sum += perlin_noise3(x * scale, y * scale, z * scale) / scale;
        scale *= 2.0;
    }
    return sum;
}

double perlin_octave_weight(double width, int i)
{
    if (!(width > 0.0))
        return 1.0;
    /* Lattice cells of octave i per footprint: c = width * 2^i. Below 1/2 the octave
     * is resolved (Nyquist: two samples per cell); at 1 and beyond it is not. */
    double c = ldexp(width, i);
    if (c <= 0.5)
        return 1.0;
    if (c >= 1.0)
        return 0.0;
    double s = (1.0 - c) * 2.0; /* 1 at c = 1/2, 0 at c = 1 */
    return s * s * (3.0 - 2.0 * s);
}

double perlin_octaves_cutoff(double x, double y, double z, int octaves, double width)
{
    if (!(width > 0.0))
        return perlin_octaves(x, y, z, octaves);
    double sum = 0.0, scale = 1.0;
    for (int i = 0; i < octaves; i++) {
        double w = perlin_octave_weight(width, i);
        if (w == 0.0)
            break; /* every finer octave has weight 0 too */
        sum += w * (perlin_noise3(x * scale, y * scale, z * scale) / scale);
        scale *= 2.0;
    }
    return sum;
}
