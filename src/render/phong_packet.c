/* The plain Phong hits of a ray packet shaded four lanes at a time: the arithmetic of
 * shade_begin and phong_term (rt/material.h), operation for operation in the same
 * order, on columns of lanes. Each lane's IEEE single-precision result is the same
 * whether four lanes go through one SSE instruction or one lane through a scalar one
 * (no fused multiply-adds: none are enabled in this build), so colours are the same
 * bits as through the material's ops; tests/unit/test_shading.c holds the two together. */
#include "phong_packet.h"

#include <string.h>

#if defined(__SSE2__)
#include <emmintrin.h>

typedef __m128 F4; /* four lanes; a mask has all bits of a lane set or none */
static inline F4 f4_load(const float *p) { return _mm_loadu_ps(p); }
static inline void f4_store(float *p, F4 a) { _mm_storeu_ps(p, a); }
static inline F4 f4_set(float x) { return _mm_set1_ps(x); }
static inline F4 f4_add(F4 a, F4 b) { return _mm_add_ps(a, b); }
static inline F4 f4_mul(F4 a, F4 b) { return _mm_mul_ps(a, b); }
static inline F4 f4_div(F4 a, F4 b) { return _mm_div_ps(a, b); }
static inline F4 f4_sqrt(F4 a) { return _mm_sqrt_ps(a); }
static inline F4 f4_gt(F4 a, F4 b) { return _mm_cmpgt_ps(a, b); }
static inline F4 f4_le(F4 a, F4 b) { return _mm_cmple_ps(a, b); }
static inline F4 f4_and(F4 m, F4 a) { return _mm_and_ps(m, a); }
static inline F4 f4_sel(F4 m, F4 a, F4 b) { return _mm_or_ps(_mm_and_ps(m, a), _mm_andnot_ps(m, b)); }
static inline F4 f4_neg(F4 a) { return _mm_xor_ps(a, _mm_set1_ps(-0.0f)); }
static inline int f4_bits(F4 m) { return _mm_movemask_ps(m); }
static inline F4 f4_mask(int bits)
{
    return _mm_castsi128_ps(_mm_cmpeq_epi32(_mm_and_si128(_mm_set1_epi32(bits),
                                                          _mm_setr_epi32(1, 2, 4, 8)),
                                            _mm_setr_epi32(1, 2, 4, 8)));
}
#else
/* The same four lanes in plain C, for machines without SSE2. */
#include <math.h>
typedef struct F4 {
    float v[4];
} F4;
static inline F4 f4_load(const float *p) { F4 r; memcpy(r.v, p, sizeof r.v); return r; }
static inline void f4_store(float *p, F4 a) { memcpy(p, a.v, sizeof a.v); }
static inline F4 f4_set(float x) { F4 r = {{x, x, x, x}}; return r; }
#define F4_MAP(name, expr)                                                                   \
    static inline F4 name(F4 a, F4 b)                                                        \
    {                                                                                        \
        F4 r;                                                                                \
        for (int k = 0; k < 4; k++)                                                          \
            r.v[k] = (expr);                                                                 \
        return r;                                                                            \
    }
F4_MAP(f4_add, a.v[k] + b.v[k])
F4_MAP(f4_mul, a.v[k] * b.v[k])
F4_MAP(f4_div, a.v[k] / b.v[k])
static inline F4 f4_sqrt(F4 a) { F4 r; for (int k = 0; k < 4; k++) r.v[k] = sqrtf(a.v[k]); return r; }
/* A mask lane is 1.0f (true) or 0.0f (false). */
F4_MAP(f4_gt, a.v[k] > b.v[k] ? 1.0f : 0.0f)
F4_MAP(f4_le, a.v[k] <= b.v[k] ? 1.0f : 0.0f)
static inline F4 f4_and(F4 m, F4 a) { F4 r; for (int k = 0; k < 4; k++) r.v[k] = m.v[k] != 0.0f ? a.v[k] : 0.0f; return r; }
static inline F4 f4_sel(F4 m, F4 a, F4 b) { F4 r; for (int k = 0; k < 4; k++) r.v[k] = m.v[k] != 0.0f ? a.v[k] : b.v[k]; return r; }
static inline F4 f4_neg(F4 a) { F4 r; for (int k = 0; k < 4; k++) r.v[k] = -a.v[k]; return r; }
static inline int f4_bits(F4 m) { int b = 0; for (int k = 0; k < 4; k++) b |= (m.v[k] != 0.0f) << k; return b; }
static inline F4 f4_mask(int bits) { F4 r; for (int k = 0; k < 4; k++) r.v[k] = (float)(bits >> k & 1); return r; }
#endif

/* Whether a material's specular term may skip powf whatever the lane (phong_term's
 * rule without its per-lane part, |n|^2 <= 1.125). */
static bool params_no_pow(const PhongParams *p)
{
    return v3_is_zero(p->specular) && p->exponent >= 0.0f && p->exponent <= 1000.0f;
}

/* Lanes i .. i+3 of the material columns from lp, one lane at a time (lanes without
 * parameters get zeros); returns the lanes whose material passes params_no_pow. */
static int fill_params_lanes(PhongPacket *pp, int i, const PhongParams *const *lp)
{
    int ok = 0;
    for (int k = i; k < i + 4; k++) {
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
        ok |= params_no_pow(p) ? 1 << (k - i) : 0;
    }
    return ok;
}

uint64_t phong_packet_begin(PhongPacket *pp, int n, uint64_t cand,
                            const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                            uint64_t *entering)
{
    F4 zero = f4_set(0.0f), one = f4_set(1.0f), nn_max = f4_set(1.125f);
    F4 ax = f4_set(ambient.x), ay = f4_set(ambient.y), az = f4_set(ambient.z);
    uint64_t phong = 0, in_bits = 0;
    pp->no_pow = 0;
    for (int i = 0; i < n; i += 4) {
        int m = (int)(cand >> i & 15);
        if (!m)
            continue;
        /* shade_begin: dn = n . d decides the side; a back face (dn > 0) is black
         * without -shade_back, else seen with its normal turned. */
        F4 nx = f4_load(pp->nx + i), ny = f4_load(pp->ny + i), nz = f4_load(pp->nz + i);
        F4 x = f4_load(pp->vx + i), y = f4_load(pp->vy + i), z = f4_load(pp->vz + i);
        F4 dn = f4_add(f4_add(f4_mul(nx, x), f4_mul(ny, y)), f4_mul(nz, z));
        int back = f4_bits(f4_gt(dn, zero)) & m;
        int in = f4_bits(f4_gt(zero, dn)) & m;
        if (!shade_back) {
            m &= ~back;
        } else if (back) {
            F4 flip = f4_mask(back);
            nx = f4_sel(flip, f4_neg(nx), nx);
            ny = f4_sel(flip, f4_neg(ny), ny);
            nz = f4_sel(flip, f4_neg(nz), nz);
            f4_store(pp->nx + i, nx);
            f4_store(pp->ny + i, ny);
            f4_store(pp->nz + i, nz);
        }
        phong |= (uint64_t)m << i;
        in_bits |= (uint64_t)in << i;
        if (!m)
            continue;
        /* The material's colours: broadcast when the four lanes share one. */
        const PhongParams *p = lp[i + __builtin_ctz((unsigned)m)];
        int ok;
        if ((lp[i] == p || !lp[i]) && (lp[i + 1] == p || !lp[i + 1]) &&
            (lp[i + 2] == p || !lp[i + 2]) && (lp[i + 3] == p || !lp[i + 3])) {
            f4_store(pp->dr + i, f4_set(p->diffuse.x));
            f4_store(pp->dg + i, f4_set(p->diffuse.y));
            f4_store(pp->db + i, f4_set(p->diffuse.z));
            f4_store(pp->sr + i, f4_set(p->specular.x));
            f4_store(pp->sg + i, f4_set(p->specular.y));
            f4_store(pp->sb + i, f4_set(p->specular.z));
            f4_store(pp->e + i, f4_set(p->exponent));
            ok = params_no_pow(p) ? 15 : 0;
        } else {
            ok = fill_params_lanes(pp, i, lp);
        }
        /* phong_term's rule for leaving powf out (its comment says why it is exact). */
        if (ok) {
            F4 nn = f4_add(f4_add(f4_mul(nx, nx), f4_mul(ny, ny)), f4_mul(nz, nz));
            ok &= f4_bits(f4_le(nn, nn_max));
            pp->no_pow |= (uint64_t)(ok & m) << i;
        }
        /* v = -normalize(d): length sqrtf((x x + y y) + z z), then d times 1/length. */
        F4 len = f4_sqrt(f4_add(f4_add(f4_mul(x, x), f4_mul(y, y)), f4_mul(z, z)));
        F4 pos = f4_gt(len, zero);
        F4 r = f4_div(one, len);
        f4_store(pp->vx + i, f4_neg(f4_sel(pos, f4_mul(x, r), x)));
        f4_store(pp->vy + i, f4_neg(f4_sel(pos, f4_mul(y, r), y)));
        f4_store(pp->vz + i, f4_neg(f4_sel(pos, f4_mul(z, r), z)));
        /* The ambient term: ambient times the diffuse colour. */
        f4_store(pp->cr + i, f4_mul(ax, f4_load(pp->dr + i)));
        f4_store(pp->cg + i, f4_mul(ay, f4_load(pp->dg + i)));
        f4_store(pp->cb + i, f4_mul(az, f4_load(pp->db + i)));
    }
    *entering = in_bits & phong;
    return phong;
}

void phong_packet_light(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc)
{
    F4 zero = f4_set(0.0f), one = f4_set(1.0f);
    F4 lx = f4_set(l.x), ly = f4_set(l.y), lz = f4_set(l.z);
    for (int i = 0; i < n; i += 4) {
        int m = (int)(mask >> i & 15);
        if (!m)
            continue;
        F4 nx = f4_load(pp->nx + i), ny = f4_load(pp->ny + i), nz = f4_load(pp->nz + i);
        F4 nl = f4_add(f4_add(f4_mul(nx, lx), f4_mul(ny, ly)), f4_mul(nz, lz));
        F4 lit = f4_gt(nl, zero);
        F4 diffuse = f4_and(lit, nl); /* nl > 0 ? nl : 0 */
        F4 specular = zero;
        int need = m & f4_bits(lit) & ~(int)(pp->no_pow >> i & 15);
        if (need) {
            /* h = normalize(l + v); nh = n . h; powf(max(nh, 0), e) where needed. */
            F4 hx = f4_add(lx, f4_load(pp->vx + i));
            F4 hy = f4_add(ly, f4_load(pp->vy + i));
            F4 hz = f4_add(lz, f4_load(pp->vz + i));
            F4 len = f4_sqrt(f4_add(f4_add(f4_mul(hx, hx), f4_mul(hy, hy)), f4_mul(hz, hz)));
            F4 pos = f4_gt(len, zero);
            F4 r = f4_div(one, len);
            hx = f4_sel(pos, f4_mul(hx, r), hx);
            hy = f4_sel(pos, f4_mul(hy, r), hy);
            hz = f4_sel(pos, f4_mul(hz, r), hz);
            F4 nh = f4_add(f4_add(f4_mul(nx, hx), f4_mul(ny, hy)), f4_mul(nz, hz));
            float base[4], s[4] = {0.0f, 0.0f, 0.0f, 0.0f};
            f4_store(base, f4_and(f4_gt(nh, zero), nh));
            for (int k = 0; k < 4; k++)
                if (need >> k & 1)
                    s[k] = powf(base[k], pp->e[i + k]);
            specular = f4_load(s);
        }
        /* c = diffuse colour * diffuse + specular colour * specular; term = lc * c. */
        F4 cr = f4_add(f4_mul(f4_load(pp->dr + i), diffuse), f4_mul(f4_load(pp->sr + i), specular));
        F4 cg = f4_add(f4_mul(f4_load(pp->dg + i), diffuse), f4_mul(f4_load(pp->sg + i), specular));
        F4 cb = f4_add(f4_mul(f4_load(pp->db + i), diffuse), f4_mul(f4_load(pp->sb + i), specular));
        F4 on = f4_mask(m);
        F4 r0 = f4_load(pp->cr + i), g0 = f4_load(pp->cg + i), b0 = f4_load(pp->cb + i);
        f4_store(pp->cr + i, f4_sel(on, f4_add(r0, f4_mul(f4_set(lc.x), cr)), r0));
        f4_store(pp->cg + i, f4_sel(on, f4_add(g0, f4_mul(f4_set(lc.y), cg)), g0));
        f4_store(pp->cb + i, f4_sel(on, f4_add(b0, f4_mul(f4_set(lc.z), cb)), b0));
    }
}
