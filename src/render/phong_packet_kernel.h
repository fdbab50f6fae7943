/* The body of phong_packet_begin and phong_packet_light for one instruction set, on
 * groups of PP_W lanes (phong_packet.h states what they compute). Included once per
 * kernel: phong_packet.c (PP_ISA 0, plain C, or 1, SSE2), phong_packet_avx2.c (2) and
 * phong_packet_avx512.c (3), each defining PP_ISA, PP_BEGIN, PP_LIGHT, PP_LIGHT_LANES,
 * PP_SETTLE and PP_BRACKET first.
 *
 * Every operation is one IEEE single-precision add, multiply, divide, square root or
 * comparison, lane by lane in the order of shade_begin and phong_term (rt/material.h);
 * the result of each lane is the same whatever the width, and the same as the scalar
 * code's, so long as nothing is fused: the files with FMA at hand are built with
 * -ffp-contract=off (Makefile). tests/unit/test_shading.c holds every kernel to the
 * materials' ops. The one exception is the power bracket (phong_packet.h): lanes of
 * pp->brk take x^e by repeated squaring in double instead of powf, their colours
 * summed with the bracket's low and high powers; phong_packet_settle says where the
 * two do not give one byte, and only there the caller needs powf's colour. */
#include <float.h>
#include <math.h>
#include <string.h>

#if PP_ISA == 3
#define PP_W 16
typedef __m512 V;
typedef __mmask16 M;
static inline V v_load(const float *p) { return _mm512_loadu_ps(p); }
static inline void v_store(float *p, V a) { _mm512_storeu_ps(p, a); }
static inline V v_set(float x) { return _mm512_set1_ps(x); }
static inline V v_add(V a, V b) { return _mm512_add_ps(a, b); }
static inline V v_mul(V a, V b) { return _mm512_mul_ps(a, b); }
static inline V v_div(V a, V b) { return _mm512_div_ps(a, b); }
static inline V v_sqrt(V a) { return _mm512_sqrt_ps(a); }
static inline M m_gt(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_GT_OQ); }
static inline M m_le(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_LE_OQ); }
static inline V v_sel(M m, V a, V b) { return _mm512_mask_blend_ps(m, b, a); }
static inline V v_and(M m, V a) { return _mm512_maskz_mov_ps(m, a); }
static inline V v_neg(V a)
{
    return _mm512_castsi512_ps(_mm512_xor_si512(_mm512_castps_si512(a),
                                                _mm512_set1_epi32((int)0x80000000u)));
}
static inline unsigned m_bits(M m) { return (unsigned)m; }
static inline M m_of(unsigned bits) { return (M)bits; }
static inline M m_ne(V a, V b) { return _mm512_cmp_ps_mask(a, b, _CMP_NEQ_UQ); }
/* trunc(min(max(c, 0), 255)) as store_tile_bytes and image_color_to_byte take it, of
 * c already times 255, back in float. */
static inline V v_clamp_trunc(V c)
{
    c = _mm512_min_ps(_mm512_max_ps(c, _mm512_setzero_ps()), _mm512_set1_ps(255.0f));
    return _mm512_cvtepi32_ps(_mm512_cvttps_epi32(c));
}
/* lo, hi = the power bracket of base^e (phong_packet.h) in the lanes whose integer
 * exponent (e converted by truncation) has only bits of ebits; garbage elsewhere. With
 * same, every lane that is read has the exponent ebits itself: the AVX2 copy then
 * multiplies without per-lane selects (the same products: a lane's r is multiplied
 * where its exponent has the bit, and kept where not); the others ignore it. */
static inline void v_pow_bracket(V base, V e, unsigned ebits, bool same, V *lo, V *hi)
{
    (void)same;
    __m512i ei = _mm512_cvttps_epi32(e);
    __m512d x0 = _mm512_cvtps_pd(_mm512_castps512_ps256(base));
    __m512d x1 = _mm512_cvtps_pd(_mm512_extractf32x8_ps(base, 1));
    __m512d r0 = _mm512_set1_pd(1.0), r1 = r0;
    for (unsigned bit = 1;; bit <<= 1) {
        __mmask16 on = _mm512_test_epi32_mask(ei, _mm512_set1_epi32((int)bit));
        r0 = _mm512_mask_mul_pd(r0, (__mmask8)on, r0, x0);
        r1 = _mm512_mask_mul_pd(r1, (__mmask8)(on >> 8), r1, x1);
        if (bit * 2 > ebits)
            break;
        x0 = _mm512_mul_pd(x0, x0);
        x1 = _mm512_mul_pd(x1, x1);
    }
    __m512 p = _mm512_insertf32x8(_mm512_castps256_ps512(_mm512_cvtpd_ps(r0)),
                                  _mm512_cvtpd_ps(r1), 1);
    __m512i b = _mm512_castps_si512(p), k = _mm512_set1_epi32(PHONG_BRACKET_ULPS);
    *lo = _mm512_castsi512_ps(_mm512_max_epi32(_mm512_sub_epi32(b, k), _mm512_setzero_si512()));
    *hi = _mm512_castsi512_ps(_mm512_add_epi32(b, k));
}
#elif PP_ISA == 2
#define PP_W 8
typedef __m256 V;
typedef __m256 M; /* a lane has all bits set or none */
static inline V v_load(const float *p) { return _mm256_loadu_ps(p); }
static inline void v_store(float *p, V a) { _mm256_storeu_ps(p, a); }
static inline V v_set(float x) { return _mm256_set1_ps(x); }
static inline V v_add(V a, V b) { return _mm256_add_ps(a, b); }
static inline V v_mul(V a, V b) { return _mm256_mul_ps(a, b); }
static inline V v_div(V a, V b) { return _mm256_div_ps(a, b); }
static inline V v_sqrt(V a) { return _mm256_sqrt_ps(a); }
static inline M m_gt(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_GT_OQ); }
static inline M m_le(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_LE_OQ); }
static inline V v_sel(M m, V a, V b) { return _mm256_blendv_ps(b, a, m); }
static inline V v_and(M m, V a) { return _mm256_and_ps(m, a); }
static inline V v_neg(V a) { return _mm256_xor_ps(a, _mm256_set1_ps(-0.0f)); }
static inline unsigned m_bits(M m) { return (unsigned)_mm256_movemask_ps(m); }
static inline M m_of(unsigned bits)
{
    __m256i b = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    return _mm256_castsi256_ps(
        _mm256_cmpeq_epi32(_mm256_and_si256(_mm256_set1_epi32((int)bits), b), b));
}
static inline M m_ne(V a, V b) { return _mm256_cmp_ps(a, b, _CMP_NEQ_UQ); }
static inline V v_clamp_trunc(V c)
{
    c = _mm256_min_ps(_mm256_max_ps(c, _mm256_setzero_ps()), _mm256_set1_ps(255.0f));
    return _mm256_cvtepi32_ps(_mm256_cvttps_epi32(c));
}
static inline void v_pow_bracket(V base, V e, unsigned ebits, bool same, V *lo, V *hi)
{
    __m256i ei = _mm256_cvttps_epi32(e);
    __m256d x0 = _mm256_cvtps_pd(_mm256_castps256_ps128(base));
    __m256d x1 = _mm256_cvtps_pd(_mm256_extractf128_ps(base, 1));
    __m256d r0 = _mm256_set1_pd(1.0), r1 = r0;
    for (unsigned bit = 1; same; bit <<= 1) {
        if (ebits & bit) {
            r0 = _mm256_mul_pd(r0, x0);
            r1 = _mm256_mul_pd(r1, x1);
        }
        if (bit * 2 > ebits)
            break;
        x0 = _mm256_mul_pd(x0, x0);
        x1 = _mm256_mul_pd(x1, x1);
    }
    for (unsigned bit = 1; !same; bit <<= 1) {
        __m256i bv = _mm256_set1_epi32((int)bit);
        __m256i on = _mm256_cmpeq_epi32(_mm256_and_si256(ei, bv), bv);
        __m256d on0 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_castsi256_si128(on)));
        __m256d on1 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(_mm256_extracti128_si256(on, 1)));
        r0 = _mm256_blendv_pd(r0, _mm256_mul_pd(r0, x0), on0);
        r1 = _mm256_blendv_pd(r1, _mm256_mul_pd(r1, x1), on1);
        if (bit * 2 > ebits)
            break;
        x0 = _mm256_mul_pd(x0, x0);
        x1 = _mm256_mul_pd(x1, x1);
    }
    __m256 p = _mm256_insertf128_ps(_mm256_castps128_ps256(_mm256_cvtpd_ps(r0)),
                                    _mm256_cvtpd_ps(r1), 1);
    __m256i b = _mm256_castps_si256(p), k = _mm256_set1_epi32(PHONG_BRACKET_ULPS);
    *lo = _mm256_castsi256_ps(_mm256_max_epi32(_mm256_sub_epi32(b, k), _mm256_setzero_si256()));
    *hi = _mm256_castsi256_ps(_mm256_add_epi32(b, k));
}
#elif PP_ISA == 1
#define PP_W 4
typedef __m128 V;
typedef __m128 M; /* a lane has all bits set or none */
static inline V v_load(const float *p) { return _mm_loadu_ps(p); }
static inline void v_store(float *p, V a) { _mm_storeu_ps(p, a); }
static inline V v_set(float x) { return _mm_set1_ps(x); }
static inline V v_add(V a, V b) { return _mm_add_ps(a, b); }
static inline V v_mul(V a, V b) { return _mm_mul_ps(a, b); }
static inline V v_div(V a, V b) { return _mm_div_ps(a, b); }
static inline V v_sqrt(V a) { return _mm_sqrt_ps(a); }
static inline M m_gt(V a, V b) { return _mm_cmpgt_ps(a, b); }
static inline M m_le(V a, V b) { return _mm_cmple_ps(a, b); }
static inline V v_sel(M m, V a, V b) { return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)); }
static inline V v_and(M m, V a) { return _mm_and_ps(m, a); }
static inline V v_neg(V a) { return _mm_xor_ps(a, _mm_set1_ps(-0.0f)); }
static inline unsigned m_bits(M m) { return (unsigned)_mm_movemask_ps(m); }
static inline M m_of(unsigned bits)
{
    __m128i b = _mm_setr_epi32(1, 2, 4, 8);
    return _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32((int)bits), b), b));
}
static inline M m_ne(V a, V b) { return _mm_cmpneq_ps(a, b); }
static inline V v_clamp_trunc(V c)
{
    c = _mm_min_ps(_mm_max_ps(c, _mm_setzero_ps()), _mm_set1_ps(255.0f));
    return _mm_cvtepi32_ps(_mm_cvttps_epi32(c));
}
static inline void v_pow_bracket(V base, V e, unsigned ebits, bool same, V *lo, V *hi)
{
    (void)same;
    __m128i ei = _mm_cvttps_epi32(e);
    __m128d x0 = _mm_cvtps_pd(base), x1 = _mm_cvtps_pd(_mm_movehl_ps(base, base));
    __m128d r0 = _mm_set1_pd(1.0), r1 = r0;
    for (unsigned bit = 1;; bit <<= 1) {
        __m128i bv = _mm_set1_epi32((int)bit);
        __m128i on = _mm_cmpeq_epi32(_mm_and_si128(ei, bv), bv);
        __m128d on0 = _mm_castsi128_pd(_mm_unpacklo_epi32(on, on));
        __m128d on1 = _mm_castsi128_pd(_mm_unpackhi_epi32(on, on));
        r0 = _mm_or_pd(_mm_and_pd(on0, _mm_mul_pd(r0, x0)), _mm_andnot_pd(on0, r0));
        r1 = _mm_or_pd(_mm_and_pd(on1, _mm_mul_pd(r1, x1)), _mm_andnot_pd(on1, r1));
        if (bit * 2 > ebits)
            break;
        x0 = _mm_mul_pd(x0, x0);
        x1 = _mm_mul_pd(x1, x1);
    }
    __m128 p = _mm_movelh_ps(_mm_cvtpd_ps(r0), _mm_cvtpd_ps(r1));
    __m128i b = _mm_castps_si128(p), k = _mm_set1_epi32(PHONG_BRACKET_ULPS);
    /* b - k, or +0 where b < k (b >= 0: the power is >= +0). */
    __m128i keep = _mm_cmpgt_epi32(b, _mm_set1_epi32(PHONG_BRACKET_ULPS - 1));
    *lo = _mm_castsi128_ps(_mm_and_si128(keep, _mm_sub_epi32(b, k)));
    *hi = _mm_castsi128_ps(_mm_add_epi32(b, k));
}
#else
/* Four lanes in plain C, for machines without SSE2. */
#define PP_W 4
typedef struct V {
    float v[PP_W];
} V;
typedef unsigned M; /* lane k is bit k */
static inline V v_load(const float *p) { V r; memcpy(r.v, p, sizeof r.v); return r; }
static inline void v_store(float *p, V a) { memcpy(p, a.v, sizeof a.v); }
static inline V v_set(float x) { V r; for (int k = 0; k < PP_W; k++) r.v[k] = x; return r; }
#define PP_MAP(name, expr)                                                                   \
    static inline V name(V a, V b)                                                           \
    {                                                                                        \
        V r;                                                                                 \
        for (int k = 0; k < PP_W; k++)                                                       \
            r.v[k] = (expr);                                                                 \
        return r;                                                                            \
    }
PP_MAP(v_add, a.v[k] + b.v[k])
PP_MAP(v_mul, a.v[k] * b.v[k])
PP_MAP(v_div, a.v[k] / b.v[k])
static inline V v_sqrt(V a) { V r; for (int k = 0; k < PP_W; k++) r.v[k] = sqrtf(a.v[k]); return r; }
static inline M m_gt(V a, V b) { M m = 0; for (int k = 0; k < PP_W; k++) m |= (unsigned)(a.v[k] > b.v[k]) << k; return m; }
static inline M m_le(V a, V b) { M m = 0; for (int k = 0; k < PP_W; k++) m |= (unsigned)(a.v[k] <= b.v[k]) << k; return m; }
static inline V v_sel(M m, V a, V b) { V r; for (int k = 0; k < PP_W; k++) r.v[k] = m >> k & 1 ? a.v[k] : b.v[k]; return r; }
static inline V v_and(M m, V a) { V r; for (int k = 0; k < PP_W; k++) r.v[k] = m >> k & 1 ? a.v[k] : 0.0f; return r; }
static inline V v_neg(V a) { V r; for (int k = 0; k < PP_W; k++) r.v[k] = -a.v[k]; return r; }
static inline unsigned m_bits(M m) { return m; }
static inline M m_of(unsigned bits) { return bits; }
static inline M m_ne(V a, V b) { M m = 0; for (int k = 0; k < PP_W; k++) m |= (unsigned)(a.v[k] != b.v[k]) << k; return m; }
static inline V v_clamp_trunc(V c)
{
    V r;
    for (int k = 0; k < PP_W; k++) {
        float x = c.v[k] > 0.0f ? c.v[k] : 0.0f;
        r.v[k] = (float)(int)(x < 255.0f ? x : 255.0f);
    }
    return r;
}
static inline void v_pow_bracket(V base, V e, unsigned ebits, bool same, V *lo, V *hi)
{
    (void)same;
    for (int k = 0; k < PP_W; k++) {
        unsigned ei = e.v[k] >= 0.0f && e.v[k] <= (float)PHONG_BRACKET_EXP_MAX ? (unsigned)e.v[k] : 0u;
        double x = base.v[k], r = 1.0;
        for (unsigned bit = 1;; bit <<= 1) {
            if (ei & bit)
                r *= x;
            if (bit * 2 > ebits)
                break;
            x *= x;
        }
        float p = (float)r;
        uint32_t b;
        memcpy(&b, &p, sizeof b);
        uint32_t bl = b >= PHONG_BRACKET_ULPS ? b - PHONG_BRACKET_ULPS : 0u;
        uint32_t bh = b + PHONG_BRACKET_ULPS;
        memcpy(&lo->v[k], &bl, sizeof bl);
        memcpy(&hi->v[k], &bh, sizeof bh);
    }
}
#endif

#define PP_ALL ((1u << PP_W) - 1u)

/* Whether a material's specular term may skip powf whatever the lane (phong_term's
 * rule without its per-lane part, |n|^2 <= 1.125). */
static bool params_no_pow(const PhongParams *p)
{
    return v3_is_zero(p->specular) && p->exponent >= 0.0f && p->exponent <= 1000.0f;
}

/* Whether a material allows the power bracket (phong_packet.h): an integer exponent
 * 0 <= e <= PHONG_BRACKET_EXP_MAX and a specular colour >= 0 in every channel (the
 * specular term's multiplier, so that the colour is monotone in the power). */
static bool params_bracket(const PhongParams *p)
{
    float e = p->exponent;
    return e >= 0.0f && e <= (float)PHONG_BRACKET_EXP_MAX && e == (float)(int)e &&
           p->specular.x >= 0.0f && p->specular.y >= 0.0f && p->specular.z >= 0.0f;
}

/* Lanes i .. i+PP_W-1 of the material columns from lp, one lane at a time (lanes
 * without parameters get zeros); returns the lanes whose material passes
 * params_no_pow, and in *brk those whose material passes params_bracket. */
static unsigned fill_params_lanes(PhongPacket *pp, int i, const PhongParams *const *lp,
                                  unsigned *brk)
{
    unsigned ok = 0, b = 0;
    for (int k = i; k < i + PP_W; k++) {
        const PhongParams *p = lp[k];
        if (!p) {
            pp->dr[k] = pp->dg[k] = pp->db[k] = 0.0f;
            pp->sr[k] = pp->sg[k] = pp->sb[k] = 0.0f;
            pp->e[k] = 0.0f;
            continue;
        }
        pp->dr[k] = p->diffuse.x;
        pp->dg[k] = p->diffuse.y;
        pp->db[k] = p->diffuse.z;
        pp->sr[k] = p->specular.x;
        pp->sg[k] = p->specular.y;
        pp->sb[k] = p->specular.z;
        pp->e[k] = p->exponent;
        ok |= params_no_pow(p) ? 1u << (k - i) : 0u;
        b |= params_bracket(p) ? 1u << (k - i) : 0u;
    }
    *brk = b;
    return ok;
}

/* Whether every lane of lp[i .. i+PP_W-1] is p or NULL. */
static bool params_uniform(const PhongParams *const *lp, int i, const PhongParams *p)
{
    for (int k = i; k < i + PP_W; k++)
        if (lp[k] != p && lp[k])
            return false;
    return true;
}

uint64_t PP_BEGIN(PhongPacket *pp, int n, uint64_t cand, const PhongParams *const *lp,
                  bool shade_back, Vec3 ambient, uint64_t *entering);
uint64_t PP_BEGIN(PhongPacket *pp, int n, uint64_t cand, const PhongParams *const *lp,
                  bool shade_back, Vec3 ambient, uint64_t *entering)
{
    V zero = v_set(0.0f), one = v_set(1.0f), nn_max = v_set(1.125f);
    V ax = v_set(ambient.x), ay = v_set(ambient.y), az = v_set(ambient.z);
    uint64_t phong = 0, in_bits = 0, may = pp->brk;
    const PhongParams *same = pp->same; /* every lane of cand on it: lp is not read */
    const PhongParams *last = NULL;
    unsigned last_ok = 0, last_brk = 0;
    pp->no_pow = 0;
    pp->brk = 0;
    pp->ebits = 0;
    for (int i = 0; i < n; i += PP_W) {
        unsigned m = (unsigned)(cand >> i) & PP_ALL;
        if (!m)
            continue;
        /* shade_begin: dn = n . d decides the side; a back face (dn > 0) is black
         * without -shade_back, else seen with its normal turned. */
        V nx = v_load(pp->nx + i), ny = v_load(pp->ny + i), nz = v_load(pp->nz + i);
        V x = v_load(pp->vx + i), y = v_load(pp->vy + i), z = v_load(pp->vz + i);
        V dn = v_add(v_add(v_mul(nx, x), v_mul(ny, y)), v_mul(nz, z));
        unsigned back = m_bits(m_gt(dn, zero)) & m;
        unsigned in = m_bits(m_gt(zero, dn)) & m;
        if (!shade_back) {
            m &= ~back;
        } else if (back) {
            M flip = m_of(back);
            nx = v_sel(flip, v_neg(nx), nx);
            ny = v_sel(flip, v_neg(ny), ny);
            nz = v_sel(flip, v_neg(nz), nz);
            v_store(pp->nx + i, nx);
            v_store(pp->ny + i, ny);
            v_store(pp->nz + i, nz);
        }
        phong |= (uint64_t)m << i;
        in_bits |= (uint64_t)in << i;
        if (!m)
            continue;
        /* The material's colours: broadcast when the lanes share one. */
        const PhongParams *p = same ? same : lp[i + __builtin_ctz(m)];
        unsigned ok, brk;
        bool uniform = same || params_uniform(lp, i, p);
        if (uniform) {
            v_store(pp->dr + i, v_set(p->diffuse.x));
            v_store(pp->dg + i, v_set(p->diffuse.y));
            v_store(pp->db + i, v_set(p->diffuse.z));
            v_store(pp->sr + i, v_set(p->specular.x));
            v_store(pp->sg + i, v_set(p->specular.y));
            v_store(pp->sb + i, v_set(p->specular.z));
            v_store(pp->e + i, v_set(p->exponent));
            if (p != last) { /* the material's rules, asked once per run of groups */
                last = p;
                last_ok = params_no_pow(p) ? PP_ALL : 0u;
                last_brk = params_bracket(p) ? PP_ALL : 0u;
            }
            ok = last_ok;
            brk = last_brk;
        } else {
            ok = fill_params_lanes(pp, i, lp, &brk);
        }
        /* phong_term's rule for leaving powf out (its comment says why it is exact). */
        if (ok) {
            V nn = v_add(v_add(v_mul(nx, nx), v_mul(ny, ny)), v_mul(nz, nz));
            ok &= m_bits(m_le(nn, nn_max));
            pp->no_pow |= (uint64_t)(ok & m) << i;
        }
        /* The bracket where powf would run (lanes without powf need no bracket). */
        brk &= m & ~ok & (unsigned)(may >> i);
        pp->brk |= (uint64_t)brk << i;
        if (brk && uniform) /* the exponents of those lanes: integers 0 .. 128 */
            pp->ebits |= (unsigned)(int)p->exponent;
        else
            for (unsigned b = brk; b; b &= b - 1)
                pp->ebits |= (unsigned)(int)pp->e[i + __builtin_ctz(b)];
        /* v = -normalize(d): length sqrtf((x x + y y) + z z), then d times 1/length. */
        V len = v_sqrt(v_add(v_add(v_mul(x, x), v_mul(y, y)), v_mul(z, z)));
        M pos = m_gt(len, zero);
        V r = v_div(one, len);
        v_store(pp->vx + i, v_neg(v_sel(pos, v_mul(x, r), x)));
        v_store(pp->vy + i, v_neg(v_sel(pos, v_mul(y, r), y)));
        v_store(pp->vz + i, v_neg(v_sel(pos, v_mul(z, r), z)));
        /* The ambient term: ambient times the diffuse colour (the bracket's high sum
         * starts there too). */
        V a_r = v_mul(ax, v_load(pp->dr + i)), a_g = v_mul(ay, v_load(pp->dg + i)),
          a_b = v_mul(az, v_load(pp->db + i));
        v_store(pp->cr + i, a_r);
        v_store(pp->cg + i, a_g);
        v_store(pp->cb + i, a_b);
        v_store(pp->hr + i, a_r);
        v_store(pp->hg + i, a_g);
        v_store(pp->hb + i, a_b);
    }
    *entering = in_bits & phong;
    return phong;
}

/* PP_LIGHT and PP_LIGHT_LANES: one light's term, its direction and colour the same for
 * every lane (ll NULL: l, lc) or each lane's own (ll's columns, no bracket). Always
 * inlined with ll a constant, so each caller is compiled for its own case. */
static inline __attribute__((always_inline)) void pp_light(PhongPacket *pp, int n,
                                                           uint64_t mask, Vec3 l, Vec3 lc,
                                                           const LightLanes *ll)
{
    V zero = v_set(0.0f), one = v_set(1.0f), x_max = v_set(1.0625f);
    V lx = v_set(l.x), ly = v_set(l.y), lz = v_set(l.z);
    V lr = v_set(lc.x), lg = v_set(lc.y), lb = v_set(lc.z);
    /* The bracket needs the light's colour >= 0 too (the other multiplier). */
    uint64_t brk = !ll && lc.x >= 0.0f && lc.y >= 0.0f && lc.z >= 0.0f ? pp->brk : 0;
    for (int i = 0; i < n; i += PP_W) {
        unsigned m = (unsigned)(mask >> i) & PP_ALL;
        if (!m)
            continue;
        if (ll) {
            lx = v_load(ll->x + i), ly = v_load(ll->y + i), lz = v_load(ll->z + i);
            lr = v_load(ll->r + i), lg = v_load(ll->g + i), lb = v_load(ll->b + i);
        }
        V nx = v_load(pp->nx + i), ny = v_load(pp->ny + i), nz = v_load(pp->nz + i);
        V nl = v_add(v_add(v_mul(nx, lx), v_mul(ny, ly)), v_mul(nz, lz));
        M lit = m_gt(nl, zero);
        V diffuse = v_and(lit, nl); /* nl > 0 ? nl : 0 */
        V spec_lo = zero, spec_hi = zero;
        unsigned need = m & m_bits(lit) & ~((unsigned)(pp->no_pow >> i) & PP_ALL);
        if (need) {
            /* h = normalize(l + v); nh = n . h; powf(max(nh, 0), e) where needed. */
            V hx = v_add(lx, v_load(pp->vx + i));
            V hy = v_add(ly, v_load(pp->vy + i));
            V hz = v_add(lz, v_load(pp->vz + i));
            V len = v_sqrt(v_add(v_add(v_mul(hx, hx), v_mul(hy, hy)), v_mul(hz, hz)));
            M pos = m_gt(len, zero);
            V r = v_div(one, len);
            hx = v_sel(pos, v_mul(hx, r), hx);
            hy = v_sel(pos, v_mul(hy, r), hy);
            hz = v_sel(pos, v_mul(hz, r), hz);
            V nh = v_add(v_add(v_mul(nx, hx), v_mul(ny, hy)), v_mul(nz, hz));
            V x = v_and(m_gt(nh, zero), nh);
            /* The bracket where the lane's material and this light allow it and x is
             * at most 1.0625 (the power stays far from overflow); powf elsewhere. */
            unsigned br = need & ((unsigned)(brk >> i) & PP_ALL) & m_bits(m_le(x, x_max));
            unsigned slow = need & ~br;
            if (br) {
                V lo, hi;
                v_pow_bracket(x, v_load(pp->e + i), pp->ebits, pp->same != NULL, &lo, &hi);
                M on = m_of(br);
                spec_lo = v_and(on, lo);
                spec_hi = v_and(on, hi);
            }
            if (slow) {
                float base[PP_W], s[PP_W];
                v_store(base, x);
                memset(s, 0, sizeof s);
                for (unsigned b = slow; b; b &= b - 1) {
                    int k = __builtin_ctz(b);
                    s[k] = powf(base[k], pp->e[i + k]);
                }
                V sp = v_load(s);
                M on = m_of(slow);
                spec_lo = v_sel(on, sp, spec_lo);
                spec_hi = v_sel(on, sp, spec_hi);
            }
        }
        /* c = diffuse colour * diffuse + specular colour * specular; term = lc * c. */
        V dr = v_mul(v_load(pp->dr + i), diffuse), dg = v_mul(v_load(pp->dg + i), diffuse),
          db = v_mul(v_load(pp->db + i), diffuse);
        V sr = v_load(pp->sr + i), sg = v_load(pp->sg + i), sb = v_load(pp->sb + i);
        M on = m_of(m);
        V r0 = v_load(pp->cr + i), g0 = v_load(pp->cg + i), b0 = v_load(pp->cb + i);
        v_store(pp->cr + i, v_sel(on, v_add(r0, v_mul(lr, v_add(dr, v_mul(sr, spec_lo)))), r0));
        v_store(pp->cg + i, v_sel(on, v_add(g0, v_mul(lg, v_add(dg, v_mul(sg, spec_lo)))), g0));
        v_store(pp->cb + i, v_sel(on, v_add(b0, v_mul(lb, v_add(db, v_mul(sb, spec_lo)))), b0));
        /* The same sums with the bracket's highs, where a lane of the group has one. */
        if (!ll && ((unsigned)(pp->brk >> i) & m)) {
            V r1 = v_load(pp->hr + i), g1 = v_load(pp->hg + i), b1 = v_load(pp->hb + i);
            v_store(pp->hr + i, v_sel(on, v_add(r1, v_mul(lr, v_add(dr, v_mul(sr, spec_hi)))), r1));
            v_store(pp->hg + i, v_sel(on, v_add(g1, v_mul(lg, v_add(dg, v_mul(sg, spec_hi)))), g1));
            v_store(pp->hb + i, v_sel(on, v_add(b1, v_mul(lb, v_add(db, v_mul(sb, spec_hi)))), b1));
        }
    }
}

void PP_LIGHT(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);
void PP_LIGHT(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc)
{
    pp_light(pp, n, mask, l, lc, NULL);
}

void PP_LIGHT_LANES(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll);
void PP_LIGHT_LANES(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll)
{
    pp_light(pp, n, mask, v3(0, 0, 0), v3(0, 0, 0), ll);
}

uint64_t PP_SETTLE(const PhongPacket *pp, int n, uint64_t mask);
uint64_t PP_SETTLE(const PhongPacket *pp, int n, uint64_t mask)
{
    V scale = v_set(255.0f), big = v_set(FLT_MAX), nbig = v_set(-FLT_MAX);
    uint64_t out = 0;
    mask &= pp->brk;
    for (int i = 0; i < n; i += PP_W) {
        unsigned m = (unsigned)(mask >> i) & PP_ALL;
        if (!m)
            continue;
        const float *lo[3] = {pp->cr + i, pp->cg + i, pp->cb + i};
        const float *hi[3] = {pp->hr + i, pp->hg + i, pp->hb + i};
        unsigned bad = 0;
        for (int c = 0; c < 3; c++) {
            V a = v_load(lo[c]), b = v_load(hi[c]);
            /* Finite, both (NaN fails both comparisons). */
            unsigned fin = m_bits(m_le(a, big)) & m_bits(m_le(nbig, a)) & m_bits(m_le(b, big)) &
                           m_bits(m_le(nbig, b));
            bad |= ~fin | m_bits(m_ne(v_clamp_trunc(v_mul(a, scale)),
                                      v_clamp_trunc(v_mul(b, scale))));
        }
        out |= (uint64_t)(bad & m) << i;
    }
    return out;
}

void PP_BRACKET(const float *x, const float *e, int n, float *lo, float *hi);
void PP_BRACKET(const float *x, const float *e, int n, float *lo, float *hi)
{
    unsigned ebits = 0;
    for (int k = 0; k < n; k++)
        ebits |= (unsigned)(int)e[k];
    for (int i = 0; i < n; i += PP_W) {
        V a, b;
        v_pow_bracket(v_load(x + i), v_load(e + i), ebits, false, &a, &b);
        v_store(lo + i, a);
        v_store(hi + i, b);
    }
}
