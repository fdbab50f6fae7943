/* The plain Phong hits of a ray packet shaded together, a group of lanes at a time
 * (internal to src/render: raytracer_trace_packet's fast path). */
#ifndef RT_RENDER_PHONG_PACKET_H
#define RT_RENDER_PHONG_PACKET_H

#include <stdint.h>
#include "rt/accel.h"
#include "rt/material.h"

/* Lanes 0 .. ACCEL_PACKET_MAX-1 in columns. A lane holds a hit on a PhongMaterial seen
 * under directional lights: its facing normal, the direction towards the eye, the
 * material's colours and exponent, and the colour summed so far. Lanes without such a
 * hit hold zeros or another lane's material and are never read back. */
typedef struct PhongPacket {
    float nx[ACCEL_PACKET_MAX], ny[ACCEL_PACKET_MAX], nz[ACCEL_PACKET_MAX];
    float vx[ACCEL_PACKET_MAX], vy[ACCEL_PACKET_MAX], vz[ACCEL_PACKET_MAX];
    float dr[ACCEL_PACKET_MAX], dg[ACCEL_PACKET_MAX], db[ACCEL_PACKET_MAX];
    float sr[ACCEL_PACKET_MAX], sg[ACCEL_PACKET_MAX], sb[ACCEL_PACKET_MAX];
    float e[ACCEL_PACKET_MAX];
    float cr[ACCEL_PACKET_MAX], cg[ACCEL_PACKET_MAX], cb[ACCEL_PACKET_MAX];
    uint64_t no_pow; /* lanes whose specular term needs no powf (phong_term's rule) */
} PhongPacket;

/* The lanes of cand (below n) hold a hit on a PhongMaterial: the
 * caller has put the hit's normal (as intersected) into nx, ny, nz, the ray direction
 * into vx, vy, vz, and lp[i] = its parameters; every other lane below n holds zeros
 * there and lp[i] = NULL. As shade_begin for those lanes: the side (n . d), the facing
 * normal, -normalize(d) into vx, vy, vz, the material's colours and the ambient term
 * a * diffuse. Returns the lanes to shade: cand without its back faces unless
 * shade_back (those are black); *entering gets the returned lanes with n . d < 0. */
uint64_t phong_packet_begin(PhongPacket *pp, int n, uint64_t cand,
                            const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                            uint64_t *entering);
/* Adds the term of the directional light (direction l to the light, colour lc) to the
 * lanes of mask (below n): phong_term's arithmetic, lane by lane the same bits. */
void phong_packet_light(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);

/* colors[i] = phong_packet_color(pp, i) for the lanes of mask. */
void phong_packet_colors(const PhongPacket *pp, uint64_t mask, Vec3 *colors);

/* phong_packet_begin and _light work on groups of up to PHONG_PACKET_GROUP lanes: n is a
 * multiple of it. */
enum { PHONG_PACKET_GROUP = 16 };
_Static_assert(ACCEL_PACKET_MAX % PHONG_PACKET_GROUP == 0, "a packet is whole groups");

/* The kernel in use ("avx512", "avx2", "sse2" or "generic": the best this CPU runs);
 * phong_packet_use_kernel picks one by name (false if this CPU cannot run it). For
 * tests and measurements. */
const char *phong_packet_kernel(void);
bool phong_packet_use_kernel(const char *name);

/* The kernels (phong_packet_kernel.h), for phong_packet.c's choice. */
uint64_t phong_packet_begin_base(PhongPacket *pp, int n, uint64_t cand,
                                 const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                                 uint64_t *entering);
void phong_packet_light_base(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);
uint64_t phong_packet_begin_avx2(PhongPacket *pp, int n, uint64_t cand,
                                 const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                                 uint64_t *entering);
void phong_packet_light_avx2(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);
uint64_t phong_packet_begin_avx512(PhongPacket *pp, int n, uint64_t cand,
                                   const PhongParams *const *lp, bool shade_back,
                                   Vec3 ambient, uint64_t *entering);
void phong_packet_light_avx512(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc);

static inline Vec3 phong_packet_color(const PhongPacket *pp, int i)
{
    return v3(pp->cr[i], pp->cg[i], pp->cb[i]);
}

#endif
