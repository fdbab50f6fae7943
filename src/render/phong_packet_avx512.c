/* The packet Phong kernel (phong_packet_kernel.h) in AVX-512 (F, VL, BW, DQ), sixteen
 * lanes a group. Chosen at run time by phong_packet.c when the CPU has these. AVX-512 brings FMA: the file is
 * built with -ffp-contract=off (Makefile), so nothing is fused and every lane rounds
 * like the scalar code. */
#include "phong_packet.h"

#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#include <immintrin.h>
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,avx512vl,avx512bw,avx512dq"))), apply_to = function)
#else
#pragma GCC target("avx512f,avx512vl,avx512bw,avx512dq")
#endif
#define PP_ISA 3
#define PP_BEGIN phong_packet_begin_avx512
#define PP_LIGHT phong_packet_light_avx512
#define PP_LIGHT_LANES phong_packet_light_lanes_avx512
#define PP_SETTLE phong_packet_settle_avx512
#define PP_BRACKET phong_packet_bracket_avx512
#include "phong_packet_kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#endif
#else
/* Never chosen on other targets; defined so the dispatch table links. */
uint64_t phong_packet_begin_avx512(PhongPacket *pp, int n, uint64_t cand,
                                 const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                                 uint64_t *entering)
{
    return phong_packet_begin_base(pp, n, cand, lp, shade_back, ambient, entering);
}

void phong_packet_light_avx512(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc)
{
    phong_packet_light_base(pp, n, mask, l, lc);
}

void phong_packet_light_lanes_avx512(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll)
{
    phong_packet_light_lanes_base(pp, n, mask, ll);
}

uint64_t phong_packet_settle_avx512(const PhongPacket *pp, int n, uint64_t mask)
{
    return phong_packet_settle_base(pp, n, mask);
}

void phong_packet_bracket_avx512(const float *x, const float *e, int n, float *lo, float *hi)
{
    phong_packet_bracket_base(x, e, n, lo, hi);
}
#endif
