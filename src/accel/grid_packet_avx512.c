/* The packet walk compiled for AVX-512 (F, VL, BW, DQ) with 16-lane ray groups: each
 * 4x4-pixel group of a packet is one 512-bit register per coordinate, its comparisons
 * and blends in mask registers. Chosen at run time by grid_packet.c when the CPU has
 * these. AVX-512 brings FMA, and a compiler may fuse a*b+c when allowed:
 * this file is built with -ffp-contract=off (Makefile), so every lane rounds like the
 * scalar code (grid_packet_kernel.h). */
#include "grid_packet.h"

#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,avx512vl,avx512bw,avx512dq"))), \
                             apply_to = function)
#else
#pragma GCC target("avx512f,avx512vl,avx512bw,avx512dq")
#endif
#define PK_W 16
#define PK_WALK grid_packet_walk_avx512
#define PK_PREP grid_packet_prep_avx512
#define PK_SPREAD grid_packet_spread_avx512
#include "grid_packet_kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#endif
#else
/* Never chosen on other targets; defined so the dispatch table links. */
void grid_packet_walk_avx512(const Grid *g, Packet *pk, RenderCtx *ctx)
{
    grid_packet_walk_generic(g, pk, ctx);
}

uint64_t grid_packet_prep_avx512(const Grid *g, Packet *pk, uint64_t cand, const float *tmax,
                                 uint64_t *single_out)
{
    return grid_packet_prep_generic(g, pk, cand, tmax, single_out);
}

float grid_packet_spread_avx512(const Grid *g, const Packet *pk, uint64_t walk)
{
    return grid_packet_spread_generic(g, pk, walk);
}
#endif
