/* The body of phong_packet_begin and phong_packet_light for one instruction set, on
 * groups of PP_W lanes (phong_packet.h states what they compute). Included once per
 * kernel: phong_packet.c (PP_ISA 0, plain C, and 1, SSE2), phong_packet_avx.c (2, AVX2,
 * and 3, AVX-512), each defining PP_ISA, PP_BEGIN and PP_LIGHT first.
 *
 * Every operation is one IEEE single-precision add, multiply, divide, square root or
 * comparison, lane by lane in the order of shade_begin and phong_term (rt/material.h);
 * the result of each lane is the same whatever the width, and the same as the scalar
 * code's, so long as nothing is fused: the files with FMA at hand are built with
 * -ffp-contract=off (Makefile). tests/unit/test_shading.c holds every kernel to the
 * materials' ops. */
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
#endif

#define PP_ALL ((1u << PP_W) - 1u)

/* Whether a material's specular term may skip powf whatever the lane (phong_term's
 * rule without its per-lane part, |n|^2 <= 1.125). */
static bool params_no_pow(const PhongParams *p)
{
    return v3_is_zero(p->specular) && p->exponent >= 0.0f && p->exponent <= 1000.0f;
}

/* Lanes i .. i+PP_W-1 of the material columns from lp, one lane at a time (lanes
 * without parameters get zeros); returns the lanes whose material passes
 * params_no_pow. */
static unsigned fill_params_lanes(PhongPacket *pp, int i, const PhongParams *const *lp)
{
    unsigned ok = 0;
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
    }
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
    uint64_t phong = 0, in_bits = 0;
    pp->no_pow = 0;
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
        const PhongParams *p = lp[i + __builtin_ctz(m)];
        unsigned ok;
        if (params_uniform(lp, i, p)) {
            v_store(pp->dr + i, v_set(p->diffuse.x));
            v_store(pp->dg + i, v_set(p->diffuse.y));
            v_store(pp->db + i, v_set(p->diffuse.z));
            v_store(pp->sr + i, v_set(p->specular.x));
            v_store(pp->sg + i, v_set(p->specular.y));
            v_store(pp->sb + i, v_set(p->specular.z));
            v_store(pp->e + i, v_set(p->exponent));
            ok = params_no_pow(p) ? PP_ALL : 0u;
        } else {
            ok = fill_params_lanes(pp, i, lp);
        }
        /* phong_term's rule for leaving powf out (its comment says why it is exact). */
        if (ok) {
            V nn = v_add(v_add(v_mul(nx, nx), v_mul(ny, ny)), v_mul(nz, nz));
            ok &= m_bits(m_le(nn, nn_max));
            pp->no_pow |= (uint64_t)(ok & m) << i;
        }
        /* v = -normalize(d): length sqrtf((x x + y y) + z z), then d times 1/length. */
        V len = v_sqrt(v_add(v_add(v_mul(x, x), v_mul(y, y)), v_mul(z, z)));
        M pos = m_gt(len, zero);
        V r = v_div(one, len);
        v_store(pp->vx + i, v_neg(v_sel(pos, v_mul(x, r), x)));
        v_store(pp->vy + i, v_neg(v_sel(pos, v_mul(y, r), y)));
        v_store(pp->vz + i, v_neg(v_sel(pos, v_mul(z, r), z)));
        /* The ambient term: ambient times the diffuse colour. */
        v_store(pp->cr + i, v_mul(ax, v_load(pp->dr + i)));
        v_store(pp->cg + i, v_mul(ay, v_load(pp->dg + i)));
        v_store(pp->cb + i, v_mul(az, v_load(pp->db + i)));
    }
    *entering = in_bits & phong;
    return phong;
}

void PP_LIGHT(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);
void PP_LIGHT(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc)
{
    V zero = v_set(0.0f), one = v_set(1.0f);
    V lx = v_set(l.x), ly = v_set(l.y), lz = v_set(l.z);
    V lr = v_set(lc.x), lg = v_set(lc.y), lb = v_set(lc.z);
    for (int i = 0; i < n; i += PP_W) {
        unsigned m = (unsigned)(mask >> i) & PP_ALL;
        if (!m)
            continue;
        V nx = v_load(pp->nx + i), ny = v_load(pp->ny + i), nz = v_load(pp->nz + i);
        V nl = v_add(v_add(v_mul(nx, lx), v_mul(ny, ly)), v_mul(nz, lz));
        M lit = m_gt(nl, zero);
        V diffuse = v_and(lit, nl); /* nl > 0 ? nl : 0 */
        V specular = zero;
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
            float base[PP_W], s[PP_W];
            v_store(base, v_and(m_gt(nh, zero), nh));
            memset(s, 0, sizeof s);
            for (unsigned b = need; b; b &= b - 1) {
                int k = __builtin_ctz(b);
                s[k] = powf(base[k], pp->e[i + k]);
            }
            specular = v_load(s);
        }
        /* c = diffuse colour * diffuse + specular colour * specular; term = lc * c. */
        V cr = v_add(v_mul(v_load(pp->dr + i), diffuse), v_mul(v_load(pp->sr + i), specular));
        V cg = v_add(v_mul(v_load(pp->dg + i), diffuse), v_mul(v_load(pp->sg + i), specular));
        V cb = v_add(v_mul(v_load(pp->db + i), diffuse), v_mul(v_load(pp->sb + i), specular));
        M on = m_of(m);
        V r0 = v_load(pp->cr + i), g0 = v_load(pp->cg + i), b0 = v_load(pp->cb + i);
        v_store(pp->cr + i, v_sel(on, v_add(r0, v_mul(lr, cr)), r0));
        v_store(pp->cg + i, v_sel(on, v_add(g0, v_mul(lg, cg)), g0));
        v_store(pp->cb + i, v_sel(on, v_add(b0, v_mul(lb, cb)), b0));
    }
}
