/* Samplers (A7): where the samples of a pixel lie. A sampler fills the offsets of all
 * samples of one pixel at once; offsets are in [0,1)^2 inside the pixel, (0,0) its
 * bottom-left corner, single precision. Random positions come from a counter-based
 * generator: they depend only on (pixel, sample index, seed), never on the order in
 * which pixels are rendered or on the thread that renders them. */
#ifndef RT_SAMPLER_H
#define RT_SAMPLER_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

/* Largest count of samples per pixel any sampler accepts (-h, README.txt). */
#define SAMPLER_MAX_COUNT 1024

typedef struct Sampler Sampler;

typedef struct SamplerOps {
    const char *name;        /* the option is -<name>_samples ("uniform"); "center" has none */
    bool square;             /* the count must be k*k (a k x k grid of strata) */
    bool fixed;              /* the same offsets in every pixel (no randomness) */
    /* Offsets of the samples of pixel (x, y) of the full image into xy[2*s], xy[2*s+1]
     * for s = 0..count-1. */
    void (*pixel)(const Sampler *s, int x, int y, float *xy);
    int max_count;           /* most samples it accepts; 0: SAMPLER_MAX_COUNT */
} SamplerOps;

struct Sampler {
    const SamplerOps *ops;
    int count;               /* samples per pixel, 1..SAMPLER_MAX_COUNT */
    int k;                   /* square samplers: count = k * k */
    uint64_t seed;           /* -seed; every random draw hashes it in */
    uint32_t stream;         /* a second, independent stream for the same seed (the
                                adaptive sampler's refinement pass uses stream 1) */
    int vec;                 /* the jittered sampler's vector code (sampler_init, from
                                the CPU): 2 AVX-512 F/DQ/VL, eight draws hashed per
                                instruction; 1 AVX2, four; 0 the plain loops */
};

/* The sampler whose option is -<name>_samples, or "center"; NULL when unknown. */
const SamplerOps *sampler_find(const char *name);
/* One centred sample per pixel: the course's default (the A6 pixel-centre ray). */
void sampler_init_center(Sampler *s);
/* Sets up a sampler of kind ops with count samples. False with a one-line reason in why
 * (count < 1 or too large, not a square for a square sampler). */
bool sampler_init(Sampler *s, const SamplerOps *ops, int count, uint64_t seed, char *why,
                  size_t whylen);

static inline void sampler_pixel(const Sampler *s, int x, int y, float *xy)
{
    s->ops->pixel(s, x, y, xy);
}

/* The generator: a uniform float in [0,1) from (seed, stream, x, y, index, dim), 24 bits
 * of a 64-bit hash (splitmix64 finaliser over the packed counters). Exposed for tests. */
float sampler_random(uint64_t seed, uint32_t stream, int x, int y, uint32_t index,
                     uint32_t dim);

/* For tests: places the 2 * count draws u (interleaved like xy: u[2i + d] is sample i's
 * draw in dimension d, in [0,1)) into the strata of the jittered sampler s as its
 * pixels do, in the same lanes (s->vec's), into xy. */
void sampler_jittered_place(const Sampler *s, const float *u, float *xy);

#endif
