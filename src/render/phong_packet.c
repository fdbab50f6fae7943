/* The plain Phong hits of a ray packet shaded a group of lanes at a time: the
 * arithmetic of shade_begin and phong_term (rt/material.h), operation for operation in
 * the same order, on columns of lanes (the body is phong_packet_kernel.h). This file
 * holds the SSE2 kernel (four lanes; plain C where there is no SSE2) and the choice of
 * kernel at run time: AVX-512 with 16 lanes, else AVX2 with 8, as the grid's packet walk
 * chooses (grid_packet.c). Each lane's IEEE single-precision result is the same at any
 * width, so colours are the same bits as through the material's ops;
 * tests/unit/test_shading.c holds every kernel to them. */
#include "phong_packet.h"
#include "rt/cpu.h"

#include <pthread.h>
#include <string.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#define PP_ISA 1
#else
#define PP_ISA 0
#endif
#define PP_BEGIN phong_packet_begin_base
#define PP_LIGHT phong_packet_light_base
#define PP_LIGHT_LANES phong_packet_light_lanes_base
#define PP_SETTLE phong_packet_settle_base
#define PP_BRACKET phong_packet_bracket_base
#include "phong_packet_kernel.h"

typedef uint64_t (*BeginFn)(PhongPacket *, int, uint64_t, const PhongParams *const *, bool,
                            Vec3, uint64_t *);
typedef void (*LightFn)(PhongPacket *, int, uint64_t, Vec3, Vec3);
typedef void (*LightLanesFn)(PhongPacket *, int, uint64_t, const LightLanes *);
typedef uint64_t (*SettleFn)(const PhongPacket *, int, uint64_t);
typedef void (*BracketFn)(const float *, const float *, int, float *, float *);

typedef struct PhongKernel {
    const char *name;
    BeginFn begin;
    LightFn light;
    LightLanesFn light_lanes;
    SettleFn settle;
    BracketFn bracket;
} PhongKernel;

static const PhongKernel kernels[] = {
    {PP_ISA ? "sse2" : "generic", phong_packet_begin_base, phong_packet_light_base,
     phong_packet_light_lanes_base, phong_packet_settle_base, phong_packet_bracket_base},
    {"avx2", phong_packet_begin_avx2, phong_packet_light_avx2, phong_packet_light_lanes_avx2,
     phong_packet_settle_avx2,
     phong_packet_bracket_avx2},
    {"avx512", phong_packet_begin_avx512, phong_packet_light_avx512,
     phong_packet_light_lanes_avx512, phong_packet_settle_avx512, phong_packet_bracket_avx512},
};
enum { NUM_KERNELS = sizeof kernels / sizeof kernels[0] };

static const PhongKernel *kernel = &kernels[0];
static pthread_once_t kernel_once = PTHREAD_ONCE_INIT;

/* Whether this CPU runs kernels[i] (the first runs everywhere). */
static bool kernel_usable(int i)
{
    if (i == 0)
        return true;
    if (i == 1)
        return cpu_has_avx2();
    if (i == 2)
        return cpu_has_avx512();
    return false;
}

static void choose_kernel(void)
{
    kernel = &kernels[kernel_usable(2) ? 2 : kernel_usable(1) ? 1 : 0];
}

const char *phong_packet_kernel(void)
{
    pthread_once(&kernel_once, choose_kernel);
    return kernel->name;
}

bool phong_packet_use_kernel(const char *name)
{
    pthread_once(&kernel_once, choose_kernel);
    for (int i = 0; i < NUM_KERNELS; i++)
        if (!strcmp(name, kernels[i].name) && kernel_usable(i)) {
            kernel = &kernels[i];
            return true;
        }
    return false;
}

uint64_t phong_packet_begin(PhongPacket *pp, int n, uint64_t cand,
                            const PhongParams *const *lp, bool shade_back, Vec3 ambient,
                            uint64_t *entering)
{
    pthread_once(&kernel_once, choose_kernel);
    return kernel->begin(pp, n, cand, lp, shade_back, ambient, entering);
}

void phong_packet_light(PhongPacket *pp, int n, uint64_t mask, Vec3 l, Vec3 lc)
{
    kernel->light(pp, n, mask, l, lc);
}

void phong_packet_light_lanes(PhongPacket *pp, int n, uint64_t mask, const LightLanes *ll)
{
    kernel->light_lanes(pp, n, mask, ll);
}

uint64_t phong_packet_settle(const PhongPacket *pp, int n, uint64_t mask)
{
    return kernel->settle(pp, n, mask);
}

void phong_packet_bracket(const float *x, const float *e, int n, float *lo, float *hi)
{
    pthread_once(&kernel_once, choose_kernel);
    kernel->bracket(x, e, n, lo, hi);
}

void phong_packet_colors(const PhongPacket *pp, uint64_t mask, Vec3 *colors)
{
    _Static_assert(sizeof(Vec3) == 3 * sizeof(float), "colours are packed floats");
#if defined(__SSE2__)
    /* Four whole lanes from columns to (r g b) triples: 12 floats in three stores. */
    for (int i = 0; i < ACCEL_PACKET_MAX; i += 4) {
        if ((mask >> i & 15) != 15)
            continue;
        __m128 r = _mm_loadu_ps(pp->cr + i), g = _mm_loadu_ps(pp->cg + i),
               b = _mm_loadu_ps(pp->cb + i);
        __m128 rg_lo = _mm_unpacklo_ps(r, g), rg_hi = _mm_unpackhi_ps(r, g); /* r0 g0 r1 g1, r2 g2 r3 g3 */
        __m128 br_lo = _mm_unpacklo_ps(b, r), br_hi = _mm_unpackhi_ps(b, r); /* b0 r0 b1 r1, b2 r2 b3 r3 */
        __m128 gb_lo = _mm_unpacklo_ps(g, b), gb_hi = _mm_unpackhi_ps(g, b); /* g0 b0 g1 b1, g2 b2 g3 b3 */
        float *out = (float *)(colors + i);
        _mm_storeu_ps(out, _mm_shuffle_ps(rg_lo, br_lo, _MM_SHUFFLE(3, 0, 1, 0)));     /* r0 g0 b0 r1 */
        _mm_storeu_ps(out + 4, _mm_shuffle_ps(gb_lo, rg_hi, _MM_SHUFFLE(1, 0, 3, 2))); /* g1 b1 r2 g2 */
        _mm_storeu_ps(out + 8, _mm_shuffle_ps(br_hi, gb_hi, _MM_SHUFFLE(3, 2, 3, 0))); /* b2 r3 g3 b3 */
        mask &= ~((uint64_t)15 << i);
    }
#endif
    for (; mask; mask &= mask - 1) {
        int i = __builtin_ctzll(mask);
        colors[i] = phong_packet_color(pp, i);
    }
}
