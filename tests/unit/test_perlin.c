/* Unit tests of Perlin's improved noise and the A6 octave sum (docs/textures.md). */
#include <math.h>
#include <string.h>

#include "../harness.h"
#include "rt/perlin.h"

/* Where the expected values come from:
 * - noise(3.14, 42, 7) = 0.13691995878400012 is the value of Ken Perlin's reference Java
 *   implementation quoted by the Rosetta Code task "Perlin noise".
 * - The others were computed by an independent Python script (below), written from
 *   Perlin's published algorithm in a different shape than src/shade/perlin.c: the gradient
 *   rule is turned into explicit vectors, and the trilinear interpolation is written
 *   as a weighted sum over the eight corners instead of nested lerps. It reproduces
 *   the Rosetta Code value to the last digit.
 *
 *   P = <Perlin's 256-entry permutation, src/shade/perlin.c>; P = P + P
 *   def gvec(h):
 *       h &= 15; g = [0, 0, 0]
 *       pi = 0 if h < 8 else 1
 *       qi = 1 if h < 4 else (0 if h in (12, 14) else 2)
 *       g[pi] += -1 if h & 1 else 1
 *       g[qi] += -1 if h & 2 else 1
 *       return g
 *   def fade(t): return 6*t**5 - 15*t**4 + 10*t**3
 *   def noise(x, y, z):
 *       fl = [floor(x), floor(y), floor(z)]; X, Y, Z = [int(f) % 256 for f in fl]
 *       f = [x - fl[0], y - fl[1], z - fl[2]]; s = [fade(c) for c in f]; tot = 0
 *       for i, j, k in product((0, 1), repeat=3):
 *           g = gvec(P[P[P[X+i]+Y+j]+Z+k])
 *           d = g[0]*(f[0]-i) + g[1]*(f[1]-j) + g[2]*(f[2]-k)
 *           w = (s[0] if i else 1-s[0]) * (s[1] if j else 1-s[1]) * (s[2] if k else 1-s[2])
 *           tot += w * d
 *       return tot
 *   def octs(x, y, z, n): return sum(noise(x*2**i, y*2**i, z*2**i)/2**i for i in range(n))
 */
static void test_published_value(void)
{
    CHECK_NEAR(perlin_noise3(3.14, 42, 7), 0.13691995878400012, 1e-12);
}

static void test_independent_values(void)
{
    CHECK_NEAR(perlin_noise3(0.5, 0.5, 0.5), -0.25, 1e-12);
    CHECK_NEAR(perlin_noise3(1.5, 2.5, 3.5), 0.125, 1e-12);
    CHECK_NEAR(perlin_noise3(0.1, 0.1, 0.1), 0.18616071435448325, 1e-9);
    CHECK_NEAR(perlin_noise3(0.25, -1.75, 3.5), -0.39061832427978516, 1e-9);
    CHECK_NEAR(perlin_noise3(100.5, 200.25, -300.125), -0.07540614157915115, 1e-9);
}

static void test_negative_coordinates(void)
{
    /* floor (not truncation) and the AND with 255 on negative cells. */
    CHECK_NEAR(perlin_noise3(-4.2, 10, 6), 0.14207999999999998, 1e-9);
    CHECK_NEAR(perlin_noise3(-4.2, 10, 0), -0.14207999999999998, 1e-9);
    CHECK_NEAR(perlin_noise3(-7.3, -2.6, -0.45), 0.32598078535253144, 1e-9);
}

static void test_zero_at_lattice_points(void)
{
    for (int x = -300; x <= 300; x += 37)
        for (int y = -5; y <= 5; y++)
            for (int z = -260; z <= 260; z += 65)
                CHECK_NEAR(perlin_noise3(x, y, z), 0.0, 0.0);
}

static void test_period_256(void)
{
    /* The lattice repeats every 256 cells in each axis (the permutation is mod 256). */
    double pts[][3] = {{0.3, 0.7, 0.11}, {-5.25, 3.5, 17.9}, {12.01, -0.5, -0.99}};
    for (int i = 0; i < 3; i++) {
        double n = perlin_noise3(pts[i][0], pts[i][1], pts[i][2]);
        CHECK_NEAR(perlin_noise3(pts[i][0] + 256, pts[i][1], pts[i][2]), n, 1e-9);
        CHECK_NEAR(perlin_noise3(pts[i][0], pts[i][1] - 256, pts[i][2]), n, 1e-9);
        CHECK_NEAR(perlin_noise3(pts[i][0], pts[i][1], pts[i][2] + 512), n, 1e-9);
    }
}

/* Small deterministic generator for the sampling tests (64-bit LCG, Knuth's MMIX). */
static double next_uniform(unsigned long long *s)
{
    *s = *s * 6364136223846793005ULL + 1442695040888963407ULL;
    return (double)(*s >> 11) / 9007199254740992.0; /* [0, 1) */
}

static void test_range(void)
{
    unsigned long long s = 12345;
    double lo = 0, hi = 0;
    for (int i = 0; i < 200000; i++) {
        double x = next_uniform(&s) * 600 - 300, y = next_uniform(&s) * 600 - 300,
               z = next_uniform(&s) * 600 - 300;
        double n = perlin_noise3(x, y, z);
        lo = fmin(lo, n);
        hi = fmax(hi, n);
    }
    CHECK_MSG(lo >= -1.1 && hi <= 1.1, "noise range [%g, %g]", lo, hi);
    /* ... and it is not degenerate: the samples spread over most of the range. */
    CHECK_MSG(lo < -0.6 && hi > 0.6, "noise range [%g, %g] suspiciously narrow", lo, hi);
}

static void test_continuity(void)
{
    /* The quintic fade makes the noise C2; its slope is bounded (a few units), so a
     * step of 1e-6 changes it by far less than 1e-4, also across cell borders. */
    unsigned long long s = 777;
    for (int i = 0; i < 20000; i++) {
        double x = next_uniform(&s) * 40 - 20, y = next_uniform(&s) * 40 - 20,
               z = next_uniform(&s) * 40 - 20;
        if (i % 4 == 0)
            x = floor(x) - 5e-7; /* straddle a cell border */
        double n = perlin_noise3(x, y, z);
        CHECK(fabs(perlin_noise3(x + 1e-6, y, z) - n) < 1e-4);
        CHECK(fabs(perlin_noise3(x, y + 1e-6, z) - n) < 1e-4);
        CHECK(fabs(perlin_noise3(x, y, z - 1e-6) - n) < 1e-4);
    }
}

static void test_non_finite_input(void)
{
    /* Not a number a texture can produce from a finite scene, but it must not crash
     * or invoke undefined behaviour (UBSan checks the float->int conversion). */
    CHECK(isfinite(perlin_noise3(HUGE_VAL, 0.5, 0.5)));
    CHECK(isfinite(perlin_noise3((double)NAN, 0.5, 0.5)));
    CHECK(isfinite(perlin_noise3(0.5, -1e300, 0.5)));
}

static void test_octaves(void)
{
    CHECK_NEAR(perlin_octaves(0.3, 0.7, 1.9, 0), 0.0, 0.0);
    CHECK_NEAR(perlin_octaves(0.3, 0.7, 1.9, -2), 0.0, 0.0);
    CHECK_NEAR(perlin_octaves(0.3, 0.7, 1.9, 1), perlin_noise3(0.3, 0.7, 1.9), 0.0);
    /* The sum written out for 3 octaves. */
    double x = -1.3, y = 2.2, z = 0.45;
    double want = perlin_noise3(x, y, z) + perlin_noise3(2 * x, 2 * y, 2 * z) / 2 +
                  perlin_noise3(4 * x, 4 * y, 4 * z) / 4;
    CHECK_NEAR(perlin_octaves(x, y, z, 3), want, 1e-15);
    /* Independent values (the Python script above: octs). */
    CHECK_NEAR(perlin_octaves(0.3, 0.7, 1.9, 4), 0.67565347277166, 1e-9);
    CHECK_NEAR(perlin_octaves(-1.3, 2.2, 0.45, 3), -0.5030409633141568, 1e-9);
    /* At (0.5,0.5,0.5) every octave after the first samples a lattice point. */
    CHECK_NEAR(perlin_octaves(0.5, 0.5, 0.5, 5), -0.25, 1e-15);
}

/* -noise_cutoff's octave weights: 1 up to half a cell per footprint, 0 from a whole
 * cell, smooth and decreasing between; width 0 is the plain octave sum to the bit. */
static void test_octave_cutoff(void)
{
    CHECK_NEAR(perlin_octave_weight(0.0, 7), 1.0, 0.0);
    CHECK_NEAR(perlin_octave_weight(0.25, 1), 1.0, 0.0);  /* c = 0.5 */
    CHECK_NEAR(perlin_octave_weight(0.5, 1), 0.0, 0.0);   /* c = 1 */
    CHECK_NEAR(perlin_octave_weight(3.0, 0), 0.0, 0.0);
    CHECK_NEAR(perlin_octave_weight(0.375, 1), 0.5, 1e-12); /* c = 3/4: halfway */
    double prev = 1.0;
    for (int k = 0; k <= 100; k++) {
        double w = perlin_octave_weight(0.5 + 0.005 * k, 0);
        CHECK(w <= prev && w >= 0.0 && w <= 1.0);
        CHECK(prev - w < 0.03); /* no jump */
        prev = w;
    }
    for (int i = 0; i < 500; i++) {
        double x = 0.731 * i - 90.0, y = 0.377 * i, z = 5.0 - 0.119 * i;
        double a = perlin_octaves(x, y, z, 6), b = perlin_octaves_cutoff(x, y, z, 6, 0.0);
        CHECK(memcmp(&a, &b, sizeof a) == 0);
        /* width 1/8: octaves 0..2 whole, 3.. left out */
        CHECK_NEAR(perlin_octaves_cutoff(x, y, z, 6, 0.125), perlin_octaves(x, y, z, 3), 0.0);
        /* width 3/16 (c = 3/4 for octave 2): octave 2 at half weight */
        double half = perlin_octaves(x, y, z, 2) + 0.5 * (perlin_octaves(x, y, z, 3) -
                                                          perlin_octaves(x, y, z, 2));
        CHECK_NEAR(perlin_octaves_cutoff(x, y, z, 6, 0.1875), half, 1e-12);
    }
}

static const TestCase tests[] = {
    {"perlin: published reference value", test_published_value},
    {"perlin: independent values", test_independent_values},
    {"perlin: negative coordinates", test_negative_coordinates},
    {"perlin: zero at lattice points", test_zero_at_lattice_points},
    {"perlin: period 256", test_period_256},
    {"perlin: range over 200000 samples", test_range},
    {"perlin: continuity", test_continuity},
    {"perlin: non-finite input", test_non_finite_input},
    {"perlin: octave sum", test_octaves},
    {"perlin: octave cut-off weights (-noise_cutoff)", test_octave_cutoff},
};
RT_TEST_MAIN(tests)
