/* Deterministic random numbers for the randomised tests (splitmix64): a test seeds
 * rng_state and gets the same scenes and rays on every machine and run. Each test file
 * that includes this has its own state. */
#ifndef RT_TEST_RNG_H
#define RT_TEST_RNG_H

#include <stdint.h>

#include "rt/vec.h"

static uint64_t rng_state;

static inline uint64_t rng_next(void)
{
    uint64_t z = (rng_state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/* Uniform in [lo, hi), from the top 53 bits. */
static inline float frand(float lo, float hi)
{
    double u = (double)(rng_next() >> 11) * (1.0 / 9007199254740992.0);
    return lo + (float)u * (hi - lo);
}

static inline int irand(int n) { return (int)(rng_next() % (uint64_t)n); }

static inline Vec3 vrand(float lo, float hi)
{
    return v3(frand(lo, hi), frand(lo, hi), frand(lo, hi));
}

/* A random unit vector (rejection from the unit ball, away from its centre). */
static inline Vec3 unit_rand(void)
{
    for (;;) {
        Vec3 v = vrand(-1, 1);
        float l = v3_length(v);
        if (l > 0.05f && l <= 1.0f)
            return v3_scale(v, 1.0f / l);
    }
}

#endif
