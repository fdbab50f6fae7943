/* Ken Perlin's improved noise (2002 reference algorithm), double precision. */
#ifndef RT_PERLIN_H
#define RT_PERLIN_H

#include <stdbool.h>

/* Noise at (x,y,z): 0 at integer lattice points, roughly in [-1, 1]. */
double perlin_noise3(double x, double y, double z);
/* N(p) = sum_{i<octaves} noise(2^i p) / 2^i; 0 when octaves <= 0 (A6 page). */
double perlin_octaves(double x, double y, double z, int octaves);
/* The weight of octave i (lattice period 2^-i) for a pixel footprint of `width` texture
 * units (-noise_cutoff): 1 while a lattice cell spans two footprints or more, 0 once the
 * footprint covers a whole cell (the octave's detail would alias: it averages out to
 * 0 over the pixel, which is what the noise's mean is), and a smoothstep in between
 * so no seam shows where an octave leaves. width <= 0: 1 for every octave. */
double perlin_octave_weight(double width, int i);
/* perlin_octaves with each octave scaled by perlin_octave_weight(width, i); octaves of
 * weight 0 are not evaluated. width <= 0 gives perlin_octaves' bits exactly. */
double perlin_octaves_cutoff(double x, double y, double z, int octaves, double width);

/* out[i] = perlin_octaves(x[i], y[i], z[i], octaves) for i < n, the same bits, computed
 * several points at a time (one point per vector lane: 8 with AVX-512, 4 with AVX2,
 * one by one elsewhere). For the shading of whole ray packets. */
void perlin_octaves_lanes(const double *x, const double *y, const double *z, int n,
                          int octaves, double *out);
/* The lane kernel in use ("avx512", "avx2" or "scalar": the best this CPU runs);
 * perlin_use_lanes_kernel picks one by name (false if this CPU cannot run it). For
 * tests and measurements: not while other threads shade. */
const char *perlin_lanes_kernel(void);
bool perlin_use_lanes_kernel(const char *name);

#endif
