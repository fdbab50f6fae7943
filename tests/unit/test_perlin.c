/* Unit tests of Perlin's improved noise and the A6 octave sum (docs/textures.md). */
#include <math.h>
#include <stdint.h>
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

/* The reference's formulation (Perlin 2002), written out independently: the library's
 * noise must give its bits exactly (images depend on every bit), whatever form a
 * faster version of it takes. */
static const unsigned char REF_P[256] = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225,
    140, 36,  103, 30,  69,  142, 8,   99,  37,  240, 21,  10,  23,  190, 6,   148,
    247, 120, 234, 75,  0,   26,  197, 62,  94,  252, 219, 203, 117, 35,  11,  32,
    57,  177, 33,  88,  237, 149, 56,  87,  174, 20,  125, 136, 171, 168, 68,  175,
    74,  165, 71,  134, 139, 48,  27,  166, 77,  146, 158, 231, 83,  111, 229, 122,
    60,  211, 133, 230, 220, 105, 92,  41,  55,  46,  245, 40,  244, 102, 143, 54,
    65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,  18,  169,
    200, 196, 135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,
    52,  217, 226, 250, 124, 123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212,
    207, 206, 59,  227, 47,  16,  58,  17,  182, 189, 28,  42,  223, 183, 170, 213,
    119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101, 155, 167, 43,  172, 9,
    129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185, 112, 104,
    218, 246, 97,  228, 251, 34,  242, 193, 238, 210, 144, 12,  191, 179, 162, 241,
    81,  51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,  181, 199, 106, 157,
    184, 84,  204, 176, 115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,
    222, 114, 67,  29,  24,  72,  243, 141, 128, 195, 78,  66,  215, 61,  156, 180};

static int ref_p(int i) { return REF_P[i & 255]; }
static double ref_fade(double t) { return t * t * t * (t * (t * 6.0 - 15.0) + 10.0); }
static double ref_lerp(double t, double a, double b) { return a + t * (b - a); }
static double ref_grad(int hash, double x, double y, double z)
{
    int h = hash & 15;
    double u = h < 8 ? x : y;
    double v = h < 4 ? y : (h == 12 || h == 14) ? x : z;
    return ((h & 1) ? -u : u) + ((h & 2) ? -v : v);
}

static double ref_noise(double x, double y, double z)
{
    double fx = floor(x), fy = floor(y), fz = floor(z);
    int X = (int)fx & 255, Y = (int)fy & 255, Z = (int)fz & 255;
    x -= fx;
    y -= fy;
    z -= fz;
    double u = ref_fade(x), v = ref_fade(y), w = ref_fade(z);
    int A = ref_p(X) + Y, AA = ref_p(A) + Z, AB = ref_p(A + 1) + Z;
    int B = ref_p(X + 1) + Y, BA = ref_p(B) + Z, BB = ref_p(B + 1) + Z;
    return ref_lerp(
        w,
        ref_lerp(v, ref_lerp(u, ref_grad(ref_p(AA), x, y, z), ref_grad(ref_p(BA), x - 1, y, z)),
                 ref_lerp(u, ref_grad(ref_p(AB), x, y - 1, z),
                          ref_grad(ref_p(BB), x - 1, y - 1, z))),
        ref_lerp(v,
                 ref_lerp(u, ref_grad(ref_p(AA + 1), x, y, z - 1),
                          ref_grad(ref_p(BA + 1), x - 1, y, z - 1)),
                 ref_lerp(u, ref_grad(ref_p(AB + 1), x, y - 1, z - 1),
                          ref_grad(ref_p(BB + 1), x - 1, y - 1, z - 1))));
}

static void test_bits_of_reference(void)
{
    uint64_t s = 0x9E3779B97F4A7C15ULL;
    long differ = 0;
    for (int i = 0; i < 300000; i++) {
        double c[3];
        for (int k = 0; k < 3; k++) {
            s = s * 6364136223846793005ULL + 1442695040888963407ULL;
            double r = (double)(s >> 11) / 9007199254740992.0 - 0.5;
            c[k] = r * (i % 3 == 0 ? 3000.0 : i % 3 == 1 ? 40.0 : 2.0);
        }
        if (i % 11 == 0)
            c[i % 3] = floor(c[i % 3]); /* on lattice planes: zero distances, -0 */
        double a = perlin_noise3(c[0], c[1], c[2]), b = ref_noise(c[0], c[1], c[2]);
        differ += memcmp(&a, &b, sizeof a) != 0;
    }
    CHECK_MSG(differ == 0, "%ld of 300000 points differ from the reference's bits", differ);
}

/* perlin_octaves_lanes with every lane kernel this CPU runs against perlin_octaves, bit
 * for bit: random points at three scales, points on lattice planes (zero distances,
 * -0), negative cells, huge and non-finite coordinates (the lanes that answer 0),
 * every count of points up to two vectors and more (the partial last vector) and
 * octave counts 0 .. 7. */
/* The lane kernel in use on n points against perlin_octaves: how many differ in a bit
 * (out: scratch for n results). */
static long lanes_differ(const double *x, const double *y, const double *z, int n, int octaves,
                         double *out)
{
    perlin_octaves_lanes(x, y, z, n, octaves, out);
    long differ = 0;
    for (int i = 0; i < n; i++) {
        double want = perlin_octaves(x[i], y[i], z[i], octaves);
        differ += memcmp(&want, &out[i], sizeof want) != 0;
    }
    return differ;
}

static void test_lanes_bits(void)
{
    enum { N = 203 };
    static double x[N], y[N], z[N], out[N];
    const char *def = perlin_lanes_kernel();
    const char *names[] = {"scalar", "avx2", "avx512", "avx512vbmi"};
    int kernels_run = 0;
    long differ = 0, points = 0;
    for (int kn = 0; kn < 4; kn++) {
        if (!perlin_use_lanes_kernel(names[kn]))
            continue;
        kernels_run++;
        uint64_t s = 0x243F6A8885A308D3ULL;
        for (int round = 0; round < 120; round++) {
            int n = round < 20 ? round : N - round % 7;
            int octaves = round % 8;
            for (int i = 0; i < n; i++) {
                double c[3];
                for (int k = 0; k < 3; k++) {
                    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
                    double r = (double)(s >> 11) / 9007199254740992.0 - 0.5;
                    c[k] = r * (round % 3 == 0 ? 3000.0 : round % 3 == 1 ? 40.0 : 2.0);
                }
                if (i % 11 == 3)
                    c[i % 3] = floor(c[i % 3]);
                if (i % 29 == 5)
                    c[(i + 1) % 3] = i % 2 ? 2e9 : -1e300;
                if (i % 37 == 7)
                    c[i % 3] = i % 2 ? (double)NAN : -(double)INFINITY;
                x[i] = c[0];
                y[i] = c[1];
                z[i] = c[2];
            }
            differ += lanes_differ(x, y, z, n, octaves, out);
            points += n;
        }
    }
    CHECK(perlin_use_lanes_kernel(def));
    CHECK_MSG(differ == 0, "%ld of %ld points differ from perlin_octaves' bits", differ, points);
    CHECK(kernels_run >= 1);
    printf("    lane kernels run: %d (default %s)\n", kernels_run, def);
}

/* The lane kernels' shared-cell path (noise_cell: a vector whose lanes all lie in one
 * lattice cell at an octave) against perlin_octaves, bit for bit: vectors of points
 * in one cell of the finest octave (2^-7, so in one cell at every coarser one too),
 * at cells of either sign, at the 255/0 wrap of the permutation (cells -1, 0, 255,
 * 256), on lattice planes (zero distances, -0, the cell's own corner), far out
 * (1e9 and beyond: the lanes answer 0) and with one NaN or infinite lane; vectors
 * that share a cell up to some octave and then straddle two (the test stops at the
 * first miss); 1 to 10 octaves (the kernels remember the last cell of the first 8);
 * and every count 1 .. 19 (the partial last vector's padding). Groups
 * of 8 points: one vector of the AVX-512 kernels, two of AVX2. */
static void test_lanes_cells(void)
{
    enum { N = 64 };
    static double x[N], y[N], z[N], out[N];
    static const double bases[] = {0.0,   1.0,  -1.0,  255.0, 256.0,  -256.0, 511.0,
                                   -0.5,  3.25, -7.75, 1e3,   -4e5,   9e8,    -9.99e8,
                                   1e9,   -2e9, 1e12,  4.5e8, 12.125, -33.5};
    enum { NB = sizeof bases / sizeof bases[0] };
    const char *def = perlin_lanes_kernel();
    const char *names[] = {"scalar", "avx2", "avx512", "avx512vbmi"};
    long differ = 0, points = 0;
    for (int kn = 0; kn < 4; kn++) {
        if (!perlin_use_lanes_kernel(names[kn]))
            continue;
        uint64_t s = 0x452821E638D01377ULL;
        for (int round = 0; round < 400; round++) {
            int n = round < 40 ? 1 + round % 19 : N;
            for (int i = 0; i < n; i++) {
                double c[3];
                for (int k = 0; k < 3; k++) {
                    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
                    double r = (double)(s >> 11) / 9007199254740992.0; /* [0, 1) */
                    /* The group's base: a multiple of 2^-7 (its cell at octave 7)
                     * near one of the bases; a spread below 2^-7 keeps the group in
                     * that cell, one of 2^-2 .. 2^-6 lets it straddle at a coarser
                     * octave (round % 5 picks). */
                    int g = i / 8 + round;
                    double b = bases[(g * 7 + k * 3) % NB] + (double)((g * 13 + k * 5) % 17) / 128.0;
                    double spread = round % 5 == 0 ? ldexp(1.0, -2 - round / 5 % 5) : 1.0 / 128.0;
                    c[k] = b + r * spread;
                    if ((i + k + round) % 6 == 0)
                        c[k] = b; /* on the cell's lattice plane: a zero distance */
                    if ((i + k + round) % 23 == 0 && b == 0.0)
                        c[k] = -0.0;
                }
                if (round % 9 == 4 && i % 8 == round % 8)
                    c[round % 3] = round % 2 ? (double)NAN : (double)INFINITY;
                x[i] = c[0];
                y[i] = c[1];
                z[i] = c[2];
            }
            int octaves = 1 + round % 10; /* beyond the 8 whose last cell PL_FN keeps */
            differ += lanes_differ(x, y, z, n, octaves, out);
            points += n;
        }
    }
    CHECK(perlin_use_lanes_kernel(def));
    CHECK_MSG(differ == 0, "%ld of %ld points differ from perlin_octaves' bits", differ, points);
}

/* The lane kernels keep the cell (and its hashes) of the last one-cell vector at each
 * octave for the next: vectors of 8 points, each in one cell at every octave, whose
 * cells follow a Gray code (each differs from the one before in exactly one of x, y
 * and z: a kernel that compared only some of them would take the wrong hashes), at
 * cells of either sign and at the 255/0 wrap; then the same cell again (the hashes
 * taken from memory). Against perlin_octaves, bit for bit, with every kernel. */
static void test_lanes_memo(void)
{
    enum { G = 16, N = 8 * G };
    static double x[N], y[N], z[N], out[N];
    static const double bases[] = {0.0, -3.0, 254.0, -257.0, 40.0};
    static const int gray[8] = {0, 1, 3, 2, 6, 7, 5, 4};
    const char *def = perlin_lanes_kernel();
    const char *names[] = {"scalar", "avx2", "avx512", "avx512vbmi"};
    long differ = 0, points = 0;
    uint64_t s = 0x9E3779B97F4A7C15ULL;
    for (int kn = 0; kn < 4; kn++) {
        if (!perlin_use_lanes_kernel(names[kn]))
            continue;
        for (size_t b = 0; b < sizeof bases / sizeof bases[0]; b++)
            for (int octaves = 1; octaves <= 9; octaves++) {
                for (int i = 0; i < N; i++) {
                    int g = i / 8, code = gray[(g < 8 ? g : g - 1) % 8];
                    double c[3];
                    for (int k = 0; k < 3; k++) {
                        s = s * 6364136223846793005ULL + 1442695040888963407ULL;
                        double r = (double)(s >> 11) / 9007199254740992.0; /* [0, 1) */
                        /* Within 2^-10 of the cell's corner: one cell at all 9 octaves. */
                        c[k] = bases[b] + (double)(code >> k & 1) + r / 1024.0;
                    }
                    x[i] = c[0];
                    y[i] = c[1];
                    z[i] = c[2];
                }
                differ += lanes_differ(x, y, z, N, octaves, out);
                points += N;
            }
    }
    CHECK(perlin_use_lanes_kernel(def));
    CHECK_MSG(differ == 0, "%ld of %ld points differ from perlin_octaves' bits", differ, points);
}

/* The lane kernels' per-call octave constants and their one test per vector of lane
 * 0's magnitude at the finest octave (below 1e9 there means below it at every
 * octave): counts of octaves past the kernels' table of 64 scales (tiny coordinates,
 * so that 2^69 x still lies in ordinary cells; one-cell vectors and straddling ones),
 * and one-cell vectors whose floors pass 1e9 only at the last octave or the one
 * before (the coarser octaves must still give noise, the finer ones 0). Against
 * perlin_octaves, bit for bit, with every kernel. */
static void test_lanes_octave_table(void)
{
    enum { N = 64 };
    static double x[N], y[N], z[N], out[N];
    const char *def = perlin_lanes_kernel();
    const char *names[] = {"scalar", "avx2", "avx512", "avx512vbmi"};
    long differ = 0, points = 0;
    for (int kn = 0; kn < 4; kn++) {
        if (!perlin_use_lanes_kernel(names[kn]))
            continue;
        uint64_t s = 0xA4093822299F31D0ULL;
        for (int round = 0; round < 48; round++) {
            /* rounds 0..23: 63 .. 70 octaves; 24..47: 1e9 reached at octave o - 1 or o */
            bool deep = round < 24;
            int octaves = deep ? 63 + round % 8 : 2 + round % 12;
            for (int i = 0; i < N; i++) {
                double c[3];
                for (int k = 0; k < 3; k++) {
                    s = s * 6364136223846793005ULL + 1442695040888963407ULL;
                    double r = (double)(s >> 11) / 9007199254740992.0; /* [0, 1) */
                    if (deep) /* 2^-60 .. 2^-58 times a spread: cells 2^-69 wide at the end */
                        c[k] = ldexp(1.0 + (double)((i / 8 + k) % 3), -60) *
                               (1.0 + r * (round % 2 ? 1e-3 : 1e-9));
                    else /* lane 0's floor crosses 1e9 at octave octaves - 1 (or - 2) */
                        c[k] = ldexp(1.0e9, -(octaves - 1 - round % 2)) * (1.0 + 1e-12 * r) *
                               (k == 1 ? -1.0 : 1.0);
                }
                x[i] = c[0];
                y[i] = c[1];
                z[i] = c[2];
            }
            differ += lanes_differ(x, y, z, N, octaves, out);
            points += N;
        }
    }
    CHECK(perlin_use_lanes_kernel(def));
    CHECK_MSG(differ == 0, "%ld of %ld points differ from perlin_octaves' bits", differ, points);
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
    {"perlin: the reference formulation's bits", test_bits_of_reference},
    {"perlin: octave cut-off weights (-noise_cutoff)", test_octave_cutoff},
    {"perlin: the lane kernels give perlin_octaves' bits", test_lanes_bits},
    {"perlin: the lane kernels' shared-cell path gives the same bits", test_lanes_cells},
    {"perlin: the lane kernels' remembered cells give the same bits", test_lanes_memo},
    {"perlin: the lane kernels' octave table and far-out test give the same bits",
     test_lanes_octave_table},
};
RT_TEST_MAIN(tests)
