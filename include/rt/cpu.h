/* What the CPU running the program can execute, for the code compiled for one
 * instruction set beyond the build's baseline (the grid's packet walks, the Phong
 * kernels, camera rays, the sampler, the filter, the film, the noise).
 *
 * Every such choice asks here, so the feature set a kind of kernel needs is written
 * once. The answers are loads from the CPU model that the compiler's runtime fills in
 * before main (a constructor), cheap enough for a per-call check, and read-only after
 * that, so render threads may ask at any time without synchronisation. Not valid in
 * constructors of this program. On other architectures or compilers both are false:
 * the portable code runs. */
#ifndef RT_CPU_H
#define RT_CPU_H

#include <stdbool.h>
#include <string.h>

#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
#define RT_CPU_X86 1
#endif

/* The widest instruction set the program may use (-isa): every answer below is also
 * capped by it, so a lower cap runs the code a CPU without the wider set would run.
 * The images do not depend on it (every kernel gives the portable code's bits); it is
 * there to show that, and to compare speeds. Set by main before any render and never
 * while render threads run. */
typedef enum { CPU_ISA_BASE, CPU_ISA_AVX2, CPU_ISA_AVX512 } CpuIsa;
extern CpuIsa cpu_isa_cap;

/* The CPU's own answers, whatever the cap: AVX2 (eight floats or four doubles a
 * vector), and the AVX-512 subsets the 16-lane kernels use: F, VL, BW and DQ (every
 * AVX-512 CPU since Skylake-SP has all four). */
static inline bool cpu_avx2_present(void)
{
#ifdef RT_CPU_X86
    return __builtin_cpu_supports("avx2");
#else
    return false;
#endif
}

static inline bool cpu_avx512_present(void)
{
#ifdef RT_CPU_X86
    return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512vl") &&
           __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512dq");
#else
    return false;
#endif
}

/* AVX2, where the cap allows it. */
static inline bool cpu_has_avx2(void)
{
    return cpu_isa_cap >= CPU_ISA_AVX2 && cpu_avx2_present();
}

/* AVX2 and FMA3 (fused multiply-add on those vectors): every AVX2 CPU of Intel and AMD
 * has both, but they are separate CPUID bits, so a kernel built for both asks for both. */
static inline bool cpu_has_avx2_fma(void)
{
#ifdef RT_CPU_X86
    return cpu_has_avx2() && __builtin_cpu_supports("fma");
#else
    return false;
#endif
}

/* AVX-512, where the cap allows it. */
static inline bool cpu_has_avx512(void)
{
    return cpu_isa_cap >= CPU_ISA_AVX512 && cpu_avx512_present();
}

/* cpu_has_avx512 and VBMI (byte permutes across a whole vector: Ice Lake, Zen 4 and
 * later), for the noise's table lookups in registers. */
static inline bool cpu_has_avx512vbmi(void)
{
#ifdef RT_CPU_X86
    return cpu_has_avx512() && __builtin_cpu_supports("avx512vbmi");
#else
    return false;
#endif
}

/* The instruction set named name ("base", "avx2", "avx512") in *isa; false for
 * another name. */
bool cpu_isa_find(const char *name, CpuIsa *isa);

/* The widest instruction set this CPU has (whatever the cap), and an isa's name. */
CpuIsa cpu_isa_best(void);
const char *cpu_isa_name(CpuIsa isa);

/* Whether this CPU runs the copy of a kernel built for the instruction set named isa:
 * "base" (the build's baseline: always), "avx2" or "avx512" (cpu_has_avx2,
 * cpu_has_avx512); false for any other name. For the modules that keep one copy of a
 * kernel per instruction set and choose among them by name (tests force each). */
static inline bool cpu_runs(const char *isa)
{
    if (!strcmp(isa, "base"))
        return true;
    if (!strcmp(isa, "avx2"))
        return cpu_has_avx2();
    if (!strcmp(isa, "avx512"))
        return cpu_has_avx512();
    return false;
}

#endif
