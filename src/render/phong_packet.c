/* The plain Phong hits of a ray packet shaded a group of lanes at a time: the
 * arithmetic of shade_begin and phong_term (rt/material.h), operation for operation in
 * the same order, on columns of lanes (the body is phong_packet_kernel.h). This file
 * holds the SSE2 kernel (four lanes; plain C where there is no SSE2) and the choice of
 * kernel at run time: AVX-512 with 16 lanes, else AVX2 with 8, as the grid's packet walk
 * chooses (grid_packet.c). Each lane's IEEE single-precision result is the same at any
 * width, so colours are the same bits as through the material's ops;
 * tests/unit/test_shading.c holds every kernel to them. */
#include "phong_packet.h"

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
#include "phong_packet_kernel.h"

typedef uint64_t (*BeginFn)(PhongPacket *, int, uint64_t, const PhongParams *const *, bool,
                            Vec3, uint64_t *);
typedef void (*LightFn)(PhongPacket *, int, uint64_t, Vec3, Vec3);

typedef struct PhongKernel {
    const char *name;
    BeginFn begin;
    LightFn light;
} PhongKernel;

static const PhongKernel kernels[] = {
    {PP_ISA ? "sse2" : "generic", phong_packet_begin_base, phong_packet_light_base},
    {"avx2", phong_packet_begin_avx2, phong_packet_light_avx2},
    {"avx512", phong_packet_begin_avx512, phong_packet_light_avx512},
};
enum { NUM_KERNELS = sizeof kernels / sizeof kernels[0] };

static const PhongKernel *kernel = &kernels[0];
static pthread_once_t kernel_once = PTHREAD_ONCE_INIT;

/* Whether this CPU runs kernels[i] (the first runs everywhere). */
static bool kernel_usable(int i)
{
    if (i == 0)
        return true;
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
    __builtin_cpu_init();
    if (i == 1)
        return __builtin_cpu_supports("avx2");
    if (i == 2)
        return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
               __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq");
#endif
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
