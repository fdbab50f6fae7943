/* The packet Phong kernel (phong_packet_kernel.h) in AVX2, eight lanes a group. Chosen
 * at run time by phong_packet.c when the CPU has AVX2; without FMA (and the file is
 * built with -ffp-contract=off besides), so every lane rounds like the scalar code. */
#include "phong_packet.h"

#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#include <immintrin.h>
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC target("avx2")
#endif
#define PP_ISA 2
#define PP_BEGIN phong_packet_begin_avx2
#define PP_LIGHT phong_packet_light_avx2
#define PP_LIGHT_LANES phong_packet_light_lanes_avx2
#define PP_SETTLE phong_packet_settle_avx2
#define PP_BRACKET phong_packet_bracket_avx2
#include "phong_packet_kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#endif
#else
/* Never chosen on other targets; defined so the dispatch table links. */
uint64_t phong_packet_begin_avx2(PhongPacket *pp, int n, uint64_t cand,
                                 const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                                 uint64_t *entering)
{
    return phong_packet_begin_base(pp, n, cand, lp, shade_back, ambient, entering);
}

void phong_packet_light_avx2(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc)
{
    phong_packet_light_base(pp, n, mask, l, lc);
}

void phong_packet_light_lanes_avx2(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll)
{
    phong_packet_light_lanes_base(pp, n, mask, ll);
}

uint64_t phong_packet_settle_avx2(const PhongPacket *pp, int n, uint64_t mask)
{
    return phong_packet_settle_base(pp, n, mask);
}

void phong_packet_bracket_avx2(const float *x, const float *e, int n, float *lo, float *hi)
{
    phong_packet_bracket_base(x, e, n, lo, hi);
}
#endif
