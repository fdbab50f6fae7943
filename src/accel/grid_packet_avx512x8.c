/* The packet walk compiled for AVX-512 (F, VL, BW, DQ) with 8-lane ray groups, as the
 * AVX2 kernel: its comparisons and blends in mask registers. Chosen only on request
 * (grid_packet_use_kernel, bench/grid_ref -kernel avx512x8), to compare 16 lanes with
 * 2 x 8 on the same instruction set. AVX-512 brings FMA, and a compiler may fuse
 * a*b+c when allowed: this file is built with -ffp-contract=off (Makefile), so every
 * lane rounds like the scalar code (grid_packet_kernel.h). */
#include "grid_packet.h"

#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx512f,avx512vl,avx512bw,avx512dq"))), \
                             apply_to = function)
#else
#pragma GCC target("avx512f,avx512vl,avx512bw,avx512dq")
#endif
#define PK_W 8
#define PK_WALK grid_packet_walk_avx512x8
#define PK_PREP grid_packet_prep_avx512x8
#define PK_SPREAD grid_packet_spread_avx512x8
#include "grid_packet_kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#endif
#else
/* Never chosen on other targets; defined so the dispatch table links. */
void grid_packet_walk_avx512x8(const Grid *g, Packet *pk, RenderCtx *ctx)
{
    grid_packet_walk_generic(g, pk, ctx);
}

uint64_t grid_packet_prep_avx512x8(const Grid *g, Packet *pk, uint64_t cand,
                                   const float *tmax, uint64_t *single_out)
{
    return grid_packet_prep_generic(g, pk, cand, tmax, single_out);
}

float grid_packet_spread_avx512x8(const Grid *g, const Packet *pk, uint64_t walk)
{
    return grid_packet_spread_generic(g, pk, walk);
}
#endif
