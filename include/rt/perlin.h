/* Ken Perlin's improved noise (2002 reference algorithm), double precision. */
#ifndef RT_PERLIN_H
#define RT_PERLIN_H

/* Noise at (x,y,z): 0 at integer lattice points, roughly in [-1, 1]. */
double perlin_noise3(double x, double y, double z);
/* N(p) = sum_{i<octaves} noise(2^i p) / 2^i; 0 when octaves <= 0 (A6 page). */
double perlin_octaves(double x, double y, double z, int octaves);

#endif
