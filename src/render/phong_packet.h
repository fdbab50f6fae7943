/* The plain Phong hits of a ray packet shaded together, a group of lanes at a time
 * (internal to src/render: raytracer_trace_packet's fast path). */
#ifndef RT_RENDER_PHONG_PACKET_H
#define RT_RENDER_PHONG_PACKET_H

#include <stdint.h>
#include "rt/accel.h"
#include "rt/material.h"

/* Lanes 0 .. ACCEL_PACKET_MAX-1 in columns. A lane holds a hit on a PhongMaterial: its
 * facing normal, the direction towards the eye, the
 * material's colours and exponent, and the colour summed so far. Lanes without such a
 * hit hold zeros or another lane's material and are never read back. */
typedef struct PhongPacket {
    float nx[ACCEL_PACKET_MAX], ny[ACCEL_PACKET_MAX], nz[ACCEL_PACKET_MAX];
    float vx[ACCEL_PACKET_MAX], vy[ACCEL_PACKET_MAX], vz[ACCEL_PACKET_MAX];
    float dr[ACCEL_PACKET_MAX], dg[ACCEL_PACKET_MAX], db[ACCEL_PACKET_MAX];
    float sr[ACCEL_PACKET_MAX], sg[ACCEL_PACKET_MAX], sb[ACCEL_PACKET_MAX];
    float e[ACCEL_PACKET_MAX];
    float cr[ACCEL_PACKET_MAX], cg[ACCEL_PACKET_MAX], cb[ACCEL_PACKET_MAX];
    /* The colour summed so far with the bracket's upper powers (lanes of brk only). */
    float hr[ACCEL_PACKET_MAX], hg[ACCEL_PACKET_MAX], hb[ACCEL_PACKET_MAX];
    uint64_t no_pow; /* lanes whose specular term needs no powf (phong_term's rule) */
    /* Lanes whose colour goes only to bytes and whose material allows the bracket
     * (below): set by the caller before phong_packet_begin to the lanes that may take
     * it, narrowed there. ebits is the OR of those lanes' integer exponents. */
    uint64_t brk;
    unsigned ebits;
    /* Set by the caller before phong_packet_begin: NULL, or the one PhongMaterial every
     * lane of cand hit (a tile inside one mesh), when lp is not read at all (its lanes
     * need not be filled) and no group is checked for mixed materials. */
    const PhongParams *same;
} PhongPacket;

/* The power bracket, for colours that go straight to bytes (raytracer_trace_packet_bytes).
 * powf(x, e) is the hot path's one libm call; for an integer exponent 0 <= e <= 128
 * (PHONG_BRACKET_EXP_MAX) and 0 <= x <= 1.0625 the kernel instead computes x^e by
 * repeated squaring in double (relative error below 2^-45), rounds it to float p, and
 * widens it to [p_lo, p_hi]: PHONG_BRACKET_ULPS floats each side (p_lo not below +0),
 * counted on the float's bits. The C library's powf(x, e) lies in that bracket (glibc's
 * is within one ulp of x^e; tests/unit/test_shading.c checks it for every exponent of
 * the range over millions of x, and fails if a libm does not). The colour is then
 * summed twice, once with the lows (cr, cg, cb) and once with the highs (hr, hg, hb),
 * by the same operations as with powf's power. Those operations are products by the
 * specular and light colours, which must be >= 0 (and are finite when the result is),
 * and sums: every one is monotone non-decreasing in the power, and so is the byte
 * quantisation (image_color_to_byte). So when both sums are finite and quantise to the
 * same byte in every channel, powf's colour quantises to that byte too; otherwise
 * (phong_packet_settle's lanes, rare) the caller shades the lane again with powf. */
#define PHONG_BRACKET_EXP_MAX 128
#define PHONG_BRACKET_ULPS 4

/* The lanes of cand (below n) hold a hit on a PhongMaterial: the
 * caller has put the hit's normal (as intersected) into nx, ny, nz, the ray direction
 * into vx, vy, vz, and lp[i] = its parameters (or set pp->same); every other lane below
 * n holds zeros there and lp[i] = NULL. As shade_begin for those lanes: the side (n . d), the facing
 * normal, -normalize(d) into vx, vy, vz, the material's colours and the ambient term
 * a * diffuse. Returns the lanes to shade: cand without its back faces unless
 * shade_back (those are black); *entering gets the returned lanes with n . d < 0.
 * pp->brk is read as the lanes that may take the power bracket and left as those of
 * them shaded whose material allows it (an integer exponent 0 .. PHONG_BRACKET_EXP_MAX,
 * specular colour >= 0); 0 keeps powf everywhere, the same bits as phong_term. */
uint64_t phong_packet_begin(PhongPacket *pp, int n, uint64_t cand,
                            const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                            uint64_t *entering);
/* Adds the term of the directional light (direction l to the light, colour lc) to the
 * lanes of mask (below n): phong_term's arithmetic, lane by lane the same bits, except
 * that lanes of pp->brk take the power bracket (above) when lc >= 0 in every channel
 * and max(n.h, 0) <= 1.0625, and powf otherwise. */
void phong_packet_light(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);

/* One light that is not the same for every lane (a point light), lane by lane in
 * columns: the direction towards it and its colour there (light_illuminate's answers
 * at the lane's hit point). Lanes that are not asked may hold anything finite. */
typedef struct LightLanes {
    float x[ACCEL_PACKET_MAX], y[ACCEL_PACKET_MAX], z[ACCEL_PACKET_MAX];
    float r[ACCEL_PACKET_MAX], g[ACCEL_PACKET_MAX], b[ACCEL_PACKET_MAX];
} LightLanes;

/* phong_packet_light with each lane's own direction and colour from ll: the same
 * arithmetic lane by lane, never the power bracket (the caller clears pp->brk). */
void phong_packet_light_lanes(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll);

/* The lanes of mask & pp->brk whose low and high colours (the bracket above) are not
 * both finite or do not quantise to the same three bytes: these need powf. */
uint64_t phong_packet_settle(const PhongPacket *pp, int n, uint64_t mask);

/* lo[i], hi[i] = the bracket of x[i]^e[i] as the kernel in use computes it, for
 * i < n (a multiple of PHONG_PACKET_GROUP), each e[i] an integer exponent
 * 0 .. PHONG_BRACKET_EXP_MAX and 0 <= x[i] <= 1.0625. For tests. */
void phong_packet_bracket(const float *x, const float *e, int n, float *lo, float *hi);

/* colors[i] = phong_packet_color(pp, i) for the lanes of mask. */
void phong_packet_colors(const PhongPacket *pp, uint64_t mask, Vec3 *colors);

/* phong_packet_begin, _light and _settle work on groups of up to PHONG_PACKET_GROUP lanes: n is a
 * multiple of it. */
enum { PHONG_PACKET_GROUP = 16 };
_Static_assert(ACCEL_PACKET_MAX % PHONG_PACKET_GROUP == 0, "a packet is whole groups");

/* The kernel in use ("avx512", "avx2", "sse2" or "generic": the best this CPU runs);
 * phong_packet_use_kernel picks one by name (false if this CPU cannot run it). For
 * tests and measurements. */
const char *phong_packet_kernel(void);
bool phong_packet_use_kernel(const char *name);

/* The copy of the quick blend lanes' light loop in use (raytracer.c: "avx512", "avx2"
 * or "base", the widest this CPU runs); raytracer_blend_use_kernel picks one by name
 * (false if this CPU cannot run it). For tests; not while rendering. */
bool raytracer_blend_use_kernel(const char *name);

/* The kernels (phong_packet_kernel.h), for phong_packet.c's choice. */
uint64_t phong_packet_begin_base(PhongPacket *pp, int n, uint64_t cand,
                                 const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                                 uint64_t *entering);
void phong_packet_light_base(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);
void phong_packet_light_lanes_base(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll);
uint64_t phong_packet_settle_base(const PhongPacket *pp, int n, uint64_t mask);
uint64_t phong_packet_settle_avx2(const PhongPacket *pp, int n, uint64_t mask);
uint64_t phong_packet_settle_avx512(const PhongPacket *pp, int n, uint64_t mask);
void phong_packet_bracket_base(const float *x, const float *e, int n, float *lo, float *hi);
void phong_packet_bracket_avx2(const float *x, const float *e, int n, float *lo, float *hi);
void phong_packet_bracket_avx512(const float *x, const float *e, int n, float *lo, float *hi);
uint64_t phong_packet_begin_avx2(PhongPacket *pp, int n, uint64_t cand,
                                 const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                                 uint64_t *entering);
void phong_packet_light_avx2(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);
void phong_packet_light_lanes_avx2(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll);
uint64_t phong_packet_begin_avx512(PhongPacket *pp, int n, uint64_t cand,
                                   const PhongParams *const *lp, bool shade_back,
                                   Vec3 ambient, uint64_t *entering);
void phong_packet_light_avx512(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);
void phong_packet_light_lanes_avx512(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll);

static inline Vec3 phong_packet_color(const PhongPacket *pp, int i)
{
    return v3(pp->cr[i], pp->cg[i], pp->cb[i]);
}

#endif
