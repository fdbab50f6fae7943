/* The instruction-set cap of rt/cpu.h and its names. */
#include "rt/cpu.h"

CpuIsa cpu_isa_cap = CPU_ISA_AVX512;

static const char *const isa_names[] = {"base", "avx2", "avx512"};

bool cpu_isa_find(const char *name, CpuIsa *isa)
{
    for (int i = 0; i < 3; i++)
        if (!strcmp(name, isa_names[i])) {
            *isa = (CpuIsa)i;
            return true;
        }
    return false;
}

CpuIsa cpu_isa_best(void)
{
    return cpu_avx512_present() ? CPU_ISA_AVX512
           : cpu_avx2_present() ? CPU_ISA_AVX2
                                : CPU_ISA_BASE;
}

const char *cpu_isa_name(CpuIsa isa) { return isa_names[isa]; }
