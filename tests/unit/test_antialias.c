/* Unit tests of antialiasing: sampler positions (range, strata, lattice, n-rooks rows
 * and columns, determinism, seeds), filter weights (symmetry, support radii), and the
 * film: a pixel rectangle equals the crop of the full render, a tiny memory budget
 * (many strips) gives the same bytes, and one centred sample with the default box is
 * the plain image loop's image. */
#include "harness.h"
#include "rt/film.h"
#include "rt/grid.h"
#include "rt/render.h"
#include "rt/scene.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

static void make_sampler(Sampler *s, const char *name, int n, uint64_t seed)
{
    char why[160];
    CHECK_MSG(sampler_init(s, sampler_find(name), n, seed, why, sizeof why), "%s", why);
}

/* Jittered sampling's rule: (a + xi) / k in float, and the largest float below the
 * stratum's end where that rounds up to it. */
static float jitter_rule(int a, float xi, int k)
{
    float v = ((float)a + xi) / (float)k, hi = (float)(a + 1) / (float)k;
    return v < hi ? v : nextafterf(hi, 0.0f);
}

static void test_sampler_ranges_and_strata(void)
{
    static const char *names[] = {"uniform", "random", "jittered", "nrooks", "poisson"};
    static const int counts[] = {1, 4, 9, 16, 36, 7};
    float xy[2 * SAMPLER_MAX_COUNT];
    for (int k = 0; k < 5; k++)
        for (int c = 0; c < 6; c++) {
            Sampler s;
            char why[160];
            bool ok = sampler_init(&s, sampler_find(names[k]), counts[c], 3, why, sizeof why);
            CHECK(ok == (counts[c] != 7 || !sampler_find(names[k])->square));
            if (!ok)
                continue;
            for (int y = -2; y < 40; y += 7)
                for (int x = 0; x < 300; x += 13) {
                    sampler_pixel(&s, x, y, xy);
                    int n = s.count, kk = s.k;
                    for (int i = 0; i < n; i++) {
                        float px = xy[2 * i], py = xy[2 * i + 1];
                        CHECK(px >= 0.0f && px < 1.0f && py >= 0.0f && py < 1.0f);
                        int a = i % kk, b = i / kk;
                        if (!strcmp(names[k], "uniform")) {
                            CHECK(px == ((float)a + 0.5f) / (float)kk);
                            CHECK(py == ((float)b + 0.5f) / (float)kk);
                        } else if (!strcmp(names[k], "jittered")) {
                            CHECK(px >= (float)a / (float)kk && px < (float)(a + 1) / (float)kk);
                            CHECK(py >= (float)b / (float)kk && py < (float)(b + 1) / (float)kk);
                            /* The bits of the rule, one sample at a time (the sampler
                             * batches them, in AVX-512 lanes where the CPU has them). */
                            CHECK(px == jitter_rule(a, sampler_random(3, 0, x, y, (uint32_t)i, 0), kk));
                            CHECK(py == jitter_rule(b, sampler_random(3, 0, x, y, (uint32_t)i, 1), kk));
                        } else if (!strcmp(names[k], "nrooks")) {
                            CHECK(py >= (float)i / (float)n && py < (float)(i + 1) / (float)n);
                        }
                    }
                    if (!strcmp(names[k], "nrooks")) {
                        /* one sample in every column stratum */
                        int cols[64] = {0};
                        for (int i = 0; i < n; i++) {
                            int col = (int)(xy[2 * i] * (float)n);
                            col = col >= n ? n - 1 : col;
                            cols[col]++;
                        }
                        for (int i = 0; i < n; i++)
                            CHECK(cols[i] == 1 || n > 64);
                    }
                }
        }
}

/* Positions depend only on (pixel, index, seed): the same call twice gives the same
 * bits, another pixel or seed other positions; the mean of many draws is near 0.5. */
static void test_sampler_determinism(void)
{
    Sampler a, b;
    make_sampler(&a, "jittered", 16, 0);
    make_sampler(&b, "jittered", 16, 1);
    float x1[32], x2[32], x3[32], x4[32];
    sampler_pixel(&a, 10, 20, x1);
    sampler_pixel(&a, 11, 20, x3);
    sampler_pixel(&a, 10, 20, x2);
    sampler_pixel(&b, 10, 20, x4);
    CHECK(memcmp(x1, x2, sizeof x1) == 0);
    CHECK(memcmp(x1, x3, sizeof x1) != 0);
    CHECK(memcmp(x1, x4, sizeof x1) != 0);
    double sum = 0;
    for (int i = 0; i < 100000; i++)
        sum += (double)sampler_random(5, 0, i % 317, i / 317, (uint32_t)i, 0);
    CHECK_NEAR(sum / 100000, 0.5, 0.01);
}

/* Whole jittered pixels (sampler_pixel on each path the CPU has: jittered_pixel_avx512's
 * or jittered_pixel_avx2's draws and placement in one pass, the scalar draws and the
 * plain lanes) against the rule one coordinate at a time on sampler_random's draws, for
 * k = 1..32 (every tail of the 32 or 16 coordinates a step, and counts up to
 * SAMPLER_MAX_COUNT), both streams, a few seeds and pixels. Fails when a lane's hash counters (index, dimension, stream) or its
 * stratum are off on any path. */
static void test_jittered_pixels(void)
{
    static float xy[2 * SAMPLER_MAX_COUNT];
    for (int vec = 0; vec <= 2; vec++)
        for (int k = 1; k * k <= SAMPLER_MAX_COUNT; k++) {
            Sampler s;
            make_sampler(&s, "jittered", k * k, 77u + (uint64_t)k);
            if (vec > s.vec)
                continue; /* this CPU lacks the instruction set */
            s.vec = vec;
            int bad = 0;
            for (uint32_t stream = 0; stream < 2; stream++) {
                s.stream = stream;
                for (int px = 0; px < 3; px++) {
                    int x = px * 517 - 3, y = px * 91 + 2;
                    sampler_pixel(&s, x, y, xy);
                    for (int j = 0; j < 2 * k * k; j++) {
                        int i = j / 2, a = j % 2 ? i / k : i % k;
                        float u = sampler_random(s.seed, stream, x, y, (uint32_t)i,
                                                 (uint32_t)(j % 2));
                        bad += xy[j] != jitter_rule(a, u, k);
                    }
                }
            }
            CHECK_MSG(bad == 0, "k %d vec %d: %d coordinates off the rule", k, vec, bad);
        }
}

/* The jittered placement's lanes (sampler_jittered_place: the code of jittered_pixel's
 * placement, AVX-512 and AVX2 where the CPU has them, and the plain vectors) against the
 * rule one
 * coordinate at a time, with draws chosen to hit its edges: 0, the smallest draw, and
 * draws just below 1, where (a + xi) / k rounds up to the stratum's end (a >= 1) and
 * the rule takes the float below it. Counts 1..81 cover every tail of 16 lanes. Fails
 * when the end's fallback or a stratum is off in any lane. */
static void test_jittered_place(void)
{
    static const float special[] = {0.0f, 0x1p-24f, 0.5f, 1.0f - 0x1p-24f, 1.0f - 0x1p-23f,
                                    1.0f - 0x3p-24f, 0.999f};
    float u[2 * 81], xy[2 * 81];
    int rounded_up = 0;
    uint64_t r = 12345;
    for (int vec = 0; vec <= 2; vec++)
        for (int k = 1; k <= 9; k++) {
            Sampler s;
            make_sampler(&s, "jittered", k * k, 0);
            if (vec > s.vec)
                continue; /* this CPU lacks the instruction set */
            s.vec = vec;
            for (int round = 0; round < 20; round++) {
                int n2 = 2 * k * k;
                for (int j = 0; j < n2; j++) {
                    r = r * 6364136223846793005ULL + 1442695040888963407ULL;
                    int pick = (int)(r >> 33) % 10;
                    u[j] = pick < 7 ? special[pick] : (float)(r >> 40) * 0x1p-24f;
                }
                sampler_jittered_place(&s, u, xy);
                for (int j = 0; j < n2; j++) {
                    int i = j / 2, a = j % 2 ? i / k : i % k;
                    float want = jitter_rule(a, u[j], k);
                    CHECK_MSG(xy[j] == want, "k %d vec %d coordinate %d: %a, rule %a", k,
                              vec, j, (double)xy[j], (double)want);
                    rounded_up += want < ((float)a + u[j]) / (float)k;
                }
            }
        }
    CHECK(rounded_up > 0); /* the stratum-end fallback was exercised */
}

/* Smallest distance between two samples of a pixel. */
static float min_spacing(const float *xy, int n)
{
    float best = 2.0f;
    for (int i = 0; i < n; i++)
        for (int j = 0; j < i; j++) {
            float du = xy[2 * i] - xy[2 * j], dv = xy[2 * i + 1] - xy[2 * j + 1];
            float d = sqrtf(du * du + dv * dv);
            best = d < best ? d : best;
        }
    return best;
}

/* -poisson_samples: deterministic like the others, and its samples keep apart: the
 * closest pair of a pixel is on average far wider than random positions give, and
 * never closer than a small fraction of the grid spacing 1/sqrt(n) in any pixel
 * tried; counts above 256 are refused. */
static void test_poisson_sampler(void)
{
    static const int counts[] = {4, 16, 64};
    for (int c = 0; c < 3; c++) {
        int n = counts[c];
        Sampler p, r, p2;
        make_sampler(&p, "poisson", n, 4);
        make_sampler(&r, "random", n, 4);
        make_sampler(&p2, "poisson", n, 5);
        float xy[2 * 64], again[2 * 64], other[2 * 64];
        double sum_p = 0, sum_r = 0;
        float worst = 2.0f;
        int pixels = 0;
        for (int y = 0; y < 30; y++)
            for (int x = 0; x < 30; x++, pixels++) {
                sampler_pixel(&p, x, y, xy);
                sampler_pixel(&p, x, y, again);
                sampler_pixel(&p2, x, y, other);
                CHECK(memcmp(xy, again, (size_t)(2 * n) * sizeof *xy) == 0);
                CHECK(memcmp(xy, other, (size_t)(2 * n) * sizeof *xy) != 0);
                float d = min_spacing(xy, n);
                sum_p += (double)d;
                worst = d < worst ? d : worst;
                sampler_pixel(&r, x, y, xy);
                sum_r += (double)min_spacing(xy, n);
            }
        double mean_p = sum_p / pixels, mean_r = sum_r / pixels;
        printf("    poisson %d: closest pair %.3f on average (random %.3f), %.3f at worst "
               "(grid spacing %.3f)\n", n, mean_p, mean_r, (double)worst, 1.0 / sqrt(n));
        CHECK_MSG(mean_p > 2.0 * mean_r, "n %d: closest pairs %.4f, random %.4f", n, mean_p,
                  mean_r);
        CHECK_MSG(worst > 0.15f / sqrtf((float)n), "n %d: two samples %.4f apart", n,
                  (double)worst);
    }
    Sampler s;
    char why[160];
    CHECK(sampler_init(&s, sampler_find("poisson"), 256, 0, why, sizeof why));
    CHECK(!sampler_init(&s, sampler_find("poisson"), 257, 0, why, sizeof why));
}

static void test_filter_symmetry_and_support(void)
{
    static const float params[] = {0.5f, 1.5f, 1.7f, 2.3f, 0.4f, 1.0f};
    char why[160];
    /* Every filter of the table, a new one too. Only the Gaussian has weight beyond
     * its support (the course's pictures keep its small corner weights). */
    for (int k = 0; filter_registry[k]; k++)
        for (int p = 0; p < 6; p++) {
            Filter f;
            bool reaches = strcmp(filter_registry[k]->name, "gaussian") == 0;
            CHECK(filter_init(&f, filter_registry[k], params[p], why, sizeof why));
            for (float x = -3.0f; x <= 3.0f; x += 0.37f)
                for (float y = -3.0f; y <= 3.0f; y += 0.29f) {
                    float w = filter_weight(&f, x, y);
                    CHECK(w == filter_weight(&f, -x, y));
                    CHECK(w == filter_weight(&f, x, -y));
                    CHECK(w == filter_weight(&f, y, x));
                    /* nothing beyond the support: a sample of pixel i+R+1 lies at least
                     * R + 0.5 away */
                    if (fabsf(x) > (float)f.support + 0.5f && !reaches)
                        CHECK(w == 0.0f);
                }
            CHECK(filter_weight(&f, 0, 0) > 0.99f);
        }
    /* The support radii the course's filter pictures show. */
    static const struct { const char *n; float r; int R; } sup[] = {
        {"box", 0.5f, 0}, {"box", 1.5f, 1}, {"box", 1.7f, 2}, {"box", 2.3f, 2},
        {"tent", 1.5f, 1}, {"tent", 2.3f, 2}, {"gaussian", 0.5f, 1}, {"gaussian", 0.6f, 1},
        {"gaussian", 1.0f, 2}, {"gaussian", 1.7f, 3}, {"gaussian", 2.3f, 5},
        {"gaussian", 0.4f, 1}};
    for (size_t i = 0; i < sizeof sup / sizeof sup[0]; i++) {
        Filter f;
        CHECK(filter_init(&f, filter_find(sup[i].n), sup[i].r, why, sizeof why));
        CHECK_MSG(f.support == sup[i].R, "%s %g: R = %d, want %d", sup[i].n, (double)sup[i].r,
                  f.support, sup[i].R);
    }
    Filter f;
    CHECK(!filter_init(&f, filter_find("box"), 0.0f, why, sizeof why));
    CHECK(!filter_init(&f, filter_find("gaussian"), -1.0f, why, sizeof why));
    CHECK(!filter_init(&f, filter_find("tent"), 17.0f, why, sizeof why));
    /* Not a filter anyone would add (a real one's name, "lanczos", made this test fail
     * for whoever added that filter). */
    CHECK(filter_find("no such filter") == NULL);
    CHECK(filter_find("") == NULL);
}

/* Every filter of the registry says whether it has negative lobes, and says it right:
 * the film's guard for weight sums near zero (film_fix_lobes) is on exactly for those,
 * so a new filter with lobes (Lanczos) that left the flag false would go unguarded.
 * Its weights are probed over the support on a fine lattice at radii 0.5 to 3. */
static void test_filter_lobes_flag(void)
{
    static const float params[] = {0.5f, 1.0f, 1.5f, 2.0f, 3.0f};
    char why[160];
    int n = 0;
    for (size_t k = 0; filter_registry[k]; k++, n++) {
        const FilterOps *ops = filter_registry[k];
        CHECK(filter_find(ops->name) == ops);
        bool negative = false;
        for (size_t p = 0; p < sizeof params / sizeof params[0]; p++) {
            Filter f;
            CHECK(filter_init(&f, ops, params[p], why, sizeof why));
            float reach = (float)f.support + 0.5f;
            for (float x = -reach; x <= reach; x += 0.03125f)
                for (float y = -reach; y <= reach; y += 0.0625f)
                    negative |= filter_weight(&f, x, y) < 0.0f;
            CHECK(filter_has_negative_lobes(&f) == ops->negative_lobes);
        }
        CHECK_MSG(negative == ops->negative_lobes, "%s: negative weights %d, negative_lobes %d",
                  ops->name, negative, ops->negative_lobes);
    }
    CHECK(n >= 4); /* box, tent, gaussian, mitchell, and any added since */
    CHECK(filter_find("mitchell")->negative_lobes);
}

/* The separable Gaussian's own float exp against libm's, rounded to float: at most one
 * ulp apart (where the result is normal; at most one unit of the smallest subnormal
 * below 2^-126), equal nearly always, over every float t from 0 down past the
 * subnormals (a dense sample of them: every 397th float); exactly 1 at 0; 0 from -104 on
 * and for NaN and -infinity. Then the weights against the libm formula (within one ulp
 * plus the float exponent's rounding, |t| ulps) and batch against single, bit for bit,
 * whatever the batch length and the position in it. */
static void test_gaussian_fast_exp(void)
{
    long differ = 0, total = 0, worst = 0;
    float worst_t = 0.0f;
    for (uint32_t b = 0x80000000u; b <= 0xc2e00000u; b += 397) { /* -0 .. -112 */
        float t;
        memcpy(&t, &b, sizeof t);
        float g = filter_expf(t), e = (float)exp((double)t);
        total++;
        int32_t gi, ei;
        memcpy(&gi, &g, sizeof gi);
        memcpy(&ei, &e, sizeof ei);
        long d = labs((long)gi - (long)ei);
        if (d > worst) {
            worst = d;
            worst_t = t;
        }
        differ += d != 0;
    }
    CHECK_MSG(worst <= 1, "exp(%.9g): %ld ulps from libm's float", (double)worst_t, worst);
    CHECK_MSG(differ * 50 < total, "%ld of %ld floats differ from libm's", differ, total);
    CHECK(filter_expf(0.0f) == 1.0f && filter_expf(-0.0f) == 1.0f);
    CHECK(filter_expf(-104.0f) == 0.0f && filter_expf(-1e30f) == 0.0f);
    CHECK(filter_expf(-INFINITY) == 0.0f && filter_expf(NAN) == 0.0f);
    CHECK(filter_expf(-103.0f) > 0.0f); /* the subnormals are kept */
    char why[160];
    static const float sigmas[] = {0.26f, 0.4f, 0.6f, 1.0f, 2.3f, 16.0f};
    for (int k = 0; k < 6; k++) {
        Filter f;
        CHECK(filter_init(&f, filter_find("gaussian"), sigmas[k], why, sizeof why));
        float x[203], w[203];
        for (int i = 0; i < 203; i++)
            x[i] = (float)(i - 101) * (float)(f.support + 1) / 101.0f;
        for (int n = 1; n <= 203; n += 101) {
            filter_weights_1d(&f, x, w, n);
            for (int i = 0; i < n; i++) {
                CHECK(w[i] == f.ops->weight_1d(&f, x[i]));
                double s = (double)f.r, t = -(double)(x[i] * x[i]) / (2.0 * s * s);
                float ref = (float)exp(t);
                CHECK_MSG(fabsf(w[i] - ref) <= 1.2e-7f * (float)(2.0 - t) * ref,
                          "sigma %g x %g: %.9g vs %.9g", (double)f.r, (double)x[i],
                          (double)w[i], (double)ref);
            }
        }
    }
}

/* Every vector path of the separable Gaussian (plain, AVX2, AVX-512, as far as this CPU
 * has them) gives the plain build's bits: the images may not depend on the CPU.
 * Arguments across each support and beyond (through the subnormal weights and the exp's
 * clamp; huge ones, infinities and NaN), every batch length up to 40 (the partial
 * groups) and a long batch at odd offsets. */
static void test_gaussian_paths(void)
{
    char why[160];
    static const float sigmas[] = {0.26f, 0.4f, 0.6f, 1.0f, 2.3f, 16.0f};
    enum { N = 4099 };
    static float x[N], w0[N], w[N];
    for (int k = 0; k < 6; k++) {
        Filter f;
        CHECK(filter_init(&f, filter_find("gaussian"), sigmas[k], why, sizeof why));
        float span = (float)(f.support + 1) * 3.0f;
        for (int i = 0; i < N; i++)
            x[i] = ((float)i / (float)(N - 1) * 2.0f - 1.0f) * span + (float)(i % 7) * 1e-4f;
        /* far beyond the support, where the cheaper exps' scaling would leave the
         * exponent range (their t < -80 lanes must take the plain exp), and not numbers */
        static const float far[] = {40.0f, 1e3f, 3e5f, 1e19f, 3e38f, INFINITY, NAN};
        for (int j = 0; j < 7; j++) {
            x[40 + 3 * j] = far[j];
            x[41 + 3 * j] = -far[j] * (1.0f + 0x1p-20f);
        }
        filter_gaussian_path_set(0);
        filter_weights_1d(&f, x, w0, N);
        for (int cap = 1; cap <= 2; cap++) {
            filter_gaussian_path_set(cap);
            filter_weights_1d(&f, x, w, N);
            int bad = 0;
            for (int i = 0; i < N; i++)
                bad += memcmp(&w[i], &w0[i], sizeof w[i]) != 0;
            CHECK_MSG(bad == 0, "sigma %g path %d: %d of %d weights differ from the plain build",
                      (double)f.r, cap, bad, N);
            for (int n = 1; n <= 40; n++)
                for (int o = 0; o < 3; o++) {
                    filter_weights_1d(&f, x + 1000 + 37 * n + o, w, n);
                    CHECK_MSG(memcmp(w, w0 + 1000 + 37 * n + o, (size_t)n * sizeof w[0]) == 0,
                              "sigma %g path %d: batch of %d at %d differs", (double)f.r, cap,
                              n, 1000 + 37 * n + o);
                }
        }
        filter_gaussian_path_set(2);
    }
}

/* Distance of a from b in units in the last place of b (float), |b| >= 2^-126. */
static double ulps_from(double a, double b)
{
    int e;
    frexp(b, &e);
    return fabs(a - b) / ldexp(1.0, e - 24);
}

/* filter_weights_1d_offsets (the film's weights of a row of sample positions towards
 * the 2R+1 pixels around) against filter_weights_1d on the arguments made one by one
 * as its contract says, (position - 0.5) - R + k in double rounded to float once, bit
 * for bit: the separable filters at several radii, every vector path of the Gaussian,
 * every length up to 40 (partial vector groups) and a long row, positions with full
 * mantissas (a rounding of the argument in float, or of the difference before k is
 * added, gives other floats for many of them). The Gaussian at R = 1 and 2 makes the
 * weights of positions in [0, 1] by its steps (test_gaussian_steps, which measures
 * their accuracy): there the centre plane is the same bits (the same float argument and
 * exp) and the others the same weights to 1e-5 (each within a few ulps of the exact
 * ones, up to 28 for the arguments' exps at sigma 0.26: the right planes, in order);
 * positions outside (a few here, NaN and infinities too) take the arguments, bit for
 * bit. */
static void test_weights_offsets(void)
{
    char why[160];
    static const struct { const char *name; float r; } filters[] = {
        {"gaussian", 0.26f}, {"gaussian", 0.4f}, {"gaussian", 1.0f}, {"gaussian", 2.3f},
        {"box", 1.3f}, {"mitchell", 2.0f}, {"mitchell", 0.7f}};
    enum { N = 603, SIDE_MAX = 2 * 6 + 1 };
    static float pos[N], w[SIDE_MAX * N], ref[N], arg[N];
    uint64_t h = 0x9e3779b97f4a7c15u;
    for (int i = 0; i < N; i++) {
        h ^= h << 13, h ^= h >> 7, h ^= h << 17;
        pos[i] = (float)(h >> 40) * 0x1p-24f; /* [0, 1), 24 random bits */
    }
    pos[0] = 0.0f;
    pos[1] = nextafterf(1.0f, 0.0f);
    static const float outside[] = {-0.75f, 1.5f, -0x1p-20f, 1.0f + 0x1p-23f, 3e5f,
                                    -1e30f, INFINITY, -INFINITY, NAN};
    for (int j = 0; j < 9; j++)
        pos[7 + 5 * j] = outside[j];
    pos[60] = 1.0f; /* inside */
    for (size_t k = 0; k < sizeof filters / sizeof filters[0]; k++) {
        Filter f;
        CHECK(filter_init(&f, filter_find(filters[k].name), filters[k].r, why, sizeof why));
        int R = f.support, side = 2 * R + 1;
        bool steps = strcmp(filters[k].name, "gaussian") == 0 && (R == 1 || R == 2);
        CHECK(side <= SIDE_MAX);
        for (int cap = 0; cap <= 2; cap++) {
            filter_gaussian_path_set(cap);
            /* every length up to 40 at offsets 1, 2, 0, ... (odd starts), then a
             * long row */
            for (int n = 1; n <= N - 2; n = n < 40 ? n + 1 : N - 1) {
                int o = n % 3;
                memset(w, 0xff, sizeof w);
                filter_weights_1d_offsets(&f, pos + o, n, R, w, (size_t)n);
                int bad = 0;
                for (int t = 0; t < side; t++) {
                    for (int i = 0; i < n; i++)
                        arg[i] = (float)((double)pos[o + i] - 0.5 - (double)R + (double)t);
                    filter_weights_1d(&f, arg, ref, n);
                    const float *wt = w + (size_t)t * (size_t)n;
                    if (!steps) {
                        bad += memcmp(wt, ref, (size_t)n * sizeof ref[0]) != 0;
                        continue;
                    }
                    int off = 0;
                    for (int i = 0; i < n; i++) {
                        float p = pos[o + i];
                        if (t == R || !(p >= 0.0f && p <= 1.0f))
                            off += memcmp(&wt[i], &ref[i], sizeof ref[i]) != 0;
                        else /* the plane's offset, to the accuracy of either */
                            off += !(fabs((double)wt[i] - (double)ref[i]) <= 1e-5 * (double)ref[i]);
                    }
                    bad += off != 0;
                }
                CHECK_MSG(bad == 0, "%s %g path %d, %d positions: %d of %d planes differ",
                          filters[k].name, (double)f.r, cap, n, bad, side);
            }
        }
        filter_gaussian_path_set(2);
    }
}

/* The Gaussian's weights towards the 2R+1 pixels around at R = 1 and 2, made from the
 * position by steps (filter.c, FILTER_STEPS: exp(ni u^2) and E = exp(-2 ni u) with u =
 * p - 0.5 in float, the others by the factors exp(ni), exp(4 ni) and E^j), against
 * the exact exp(ni x^2) in double at the offsets x = u - R + k, ni the float factor
 * every path rounds -1/(2 sigma^2) to: over a dense scan of [0, 1] (every 2^-16, 1
 * included) and random full-mantissa positions below 1/4 (where p - 0.5 rounds), sigmas
 * from just above 1/4 (R = 1, the steepest) to 1.25 (R = 2), the worst error within 8
 * ulps, the mean within 0.9 and within 1.0 towards the pixels 2 away (measured
 * 2026-11-29: worst 7.7 at sigma 0.26, means at most 0.89 and 0.75; the exps of the
 * rounded arguments before, against the same exact weights at their arguments: up to
 * 28 ulps and a mean of 2.0 at sigma 0.26). Every vector path gives the plain build's
 * bits. Fails with exp(ni) or exp(4 ni) an ulp off either way (means 0.99 to 1.6). */
static void test_gaussian_steps(void)
{
    char why[160];
    static const float sigmas[] = {0.26f, 0.3f, 0.4f, 0.6f, 0.75f, 0.76f, 1.0f, 1.25f};
    enum { DENSE = (1 << 16) + 1, N = DENSE + 4096, SIDE = 5 };
    static float pos[N], w0[SIDE * N], w[SIDE * N];
    for (int i = 0; i < DENSE; i++)
        pos[i] = (float)i * 0x1p-16f;
    uint64_t h = 0x853c49e6748fea9bu;
    for (int i = DENSE; i < N; i++) {
        h ^= h << 13, h ^= h >> 7, h ^= h << 17;
        pos[i] = (float)(h >> 40) * 0x1p-26f; /* [0, 1/4), 24 random bits */
    }
    for (size_t q = 0; q < sizeof sigmas / sizeof sigmas[0]; q++) {
        Filter f;
        CHECK(filter_init(&f, filter_find("gaussian"), sigmas[q], why, sizeof why));
        int R = f.support;
        CHECK(R == 1 || R == 2);
        double s = (double)f.r, ni = (double)(float)(-1.0 / (2.0 * s * s));
        filter_gaussian_path_set(0);
        filter_weights_1d_offsets(&f, pos, N, R, w0, N);
        double worst = 0.0, sum = 0.0, outer = 0.0;
        for (int k = 0; k <= 2 * R; k++)
            for (int i = 0; i < N; i++) {
                double x = (double)(pos[i] - 0.5f) - R + k;
                double e = ulps_from((double)w0[(size_t)k * N + i], exp(ni * x * x));
                worst = e > worst ? e : worst;
                sum += e;
                outer += abs(k - R) == 2 ? e : 0.0;
            }
        double mean = sum / (double)((2 * R + 1) * N), mean2 = outer / (2.0 * N);
        CHECK_MSG(worst <= 8.0 && mean <= 0.9 && mean2 <= 1.0,
                  "sigma %g (R %d): worst %.2f ulps, mean %.3f, at +-2 pixels %.3f",
                  (double)f.r, R, worst, mean, mean2);
        for (int cap = 1; cap <= 2; cap++) {
            filter_gaussian_path_set(cap);
            filter_weights_1d_offsets(&f, pos, N, R, w, N);
            CHECK_MSG(memcmp(w, w0, (size_t)(2 * R + 1) * N * sizeof w[0]) == 0,
                      "sigma %g path %d: weights differ from the plain build's", (double)f.r,
                      cap);
        }
        filter_gaussian_path_set(2);
    }
}

/* filter_weights_1d_offsets on every vector path of the Gaussian against the plain
 * build's, bit for bit: tiny positions whose double steps round at R = 16 (2^-26 (1 +
 * k 2^-23); there a float argument differs by an ulp for two of them, though not their
 * weights), 0, the largest float below 1 and random ones; sigmas whose R takes the float
 * argument (R <= 2) and the double steps (R = 3, 5, 16); runs of 1..47 positions
 * (masked tails of 8 and 16; three planes a step, the last step partial). */
static void test_weights_offsets_boundaries(void)
{
    char why[160];
    static const float sigmas[] = {0.26f, 0.4f, 1.0f, 1.7f, 2.3f, 8.2f};
    enum { LEN = 47, SIDE_MAX = 33, POS = 1200 };
    static float pos[POS], w[SIDE_MAX * LEN], ref[SIDE_MAX * LEN];
    for (size_t q = 0; q < sizeof sigmas / sizeof sigmas[0]; q++) {
        Filter f;
        CHECK(filter_init(&f, filter_find("gaussian"), sigmas[q], why, sizeof why));
        int R = f.support, side = 2 * R + 1;
        CHECK(side <= SIDE_MAX);
        int np = 0;
        pos[np++] = 0.0f;
        pos[np++] = nextafterf(1.0f, 0.0f);
        for (int k = 0; k < 16; k++)
            pos[np++] = 0x1p-26f * (1.0f + (float)k * 0x1p-23f);
        uint64_t h = 0x2545f4914f6cdd1dULL ^ (uint64_t)q;
        while (np < POS) {
            h ^= h << 13, h ^= h >> 7, h ^= h << 17;
            pos[np++] = (float)(h >> 40) * 0x1p-24f;
        }
        int bad = 0;
        for (int start = 0; start + LEN <= np && !bad; start += LEN)
            for (int n = 1; n <= LEN && !bad; n += (n < 17 ? 1 : 10)) {
                filter_gaussian_path_set(0);
                filter_weights_1d_offsets(&f, pos + start, n, R, ref, (size_t)LEN);
                for (int cap = 1; cap <= 2; cap++) {
                    filter_gaussian_path_set(cap);
                    memset(w, 0xff, sizeof w);
                    filter_weights_1d_offsets(&f, pos + start, n, R, w, (size_t)LEN);
                    for (int k = 0; k < side; k++)
                        bad += memcmp(w + k * LEN, ref + k * LEN, (size_t)n * sizeof(float)) != 0;
                    CHECK_MSG(bad == 0, "sigma %g path %d, %d positions from %d: %d planes "
                              "differ", (double)f.r, cap, n, start, bad);
                    /* nothing written past the 2R+1 planes (the vector paths compute
                     * three planes a step) */
                    static const unsigned char ff[2 * LEN * sizeof(float)] = {0};
                    unsigned char past[2 * LEN * sizeof(float)];
                    size_t np_ = (size_t)(SIDE_MAX - side < 2 ? SIDE_MAX - side : 2) * LEN;
                    memcpy(past, w + side * LEN, np_ * sizeof(float));
                    for (size_t b = 0; b < np_ * sizeof(float); b++)
                        past[b] = (unsigned char)~past[b];
                    CHECK_MSG(memcmp(past, ff, np_ * sizeof(float)) == 0,
                              "sigma %g path %d: a plane past 2R was written", (double)f.r, cap);
                    bad += memcmp(past, ff, np_ * sizeof(float)) != 0;
                }
            }
        filter_gaussian_path_set(2);
    }
}

/* filter_weights_1d_blocks (the film's tile rows: groups of eight positions, each
 * group's weights in planes of its own) == filter_weights_1d_offsets on each group, bit
 * for bit, on every vector path of the Gaussian against the plain build's offsets: the
 * float-argument radii (R = 1, 2), the double steps (R = 3, 5), other separable filters
 * (a group at a time), 1..5 groups and 32 (the film's 16 samples), strides that are not
 * multiples of anything. Fails with the AVX2 loop's second vector or its k-th plane
 * put at the wrong stride. */
static void test_weights_blocks(void)
{
    char why[160];
    static const struct { const char *name; float r; } filters[] = {
        {"gaussian", 0.26f}, {"gaussian", 0.4f}, {"gaussian", 0.9f}, {"gaussian", 1.2f},
        {"gaussian", 2.3f}, {"box", 1.3f}, {"mitchell", 2.0f}};
    enum { GROUPS = 32, N = 8 * GROUPS, SIDE_MAX = 11, PLANE = 13, BSTRIDE = SIDE_MAX * PLANE + 5 };
    static float pos[N], w[GROUPS * BSTRIDE], ref[SIDE_MAX * 8];
    uint64_t h = 0x243f6a8885a308d3u;
    for (int i = 0; i < N; i++) {
        h ^= h << 13, h ^= h >> 7, h ^= h << 17;
        pos[i] = (float)(h >> 40) * 0x1p-24f;
    }
    pos[3] = 0.0f;
    pos[12] = nextafterf(1.0f, 0.0f);
    pos[20] = 0x1p-26f;
    for (size_t k = 0; k < sizeof filters / sizeof filters[0]; k++) {
        Filter f;
        CHECK(filter_init(&f, filter_find(filters[k].name), filters[k].r, why, sizeof why));
        int R = f.support, side = 2 * R + 1;
        CHECK(side <= SIDE_MAX);
        static const int groups[] = {1, 2, 3, 4, 5, GROUPS};
        for (int cap = 0; cap <= 2; cap++)
            for (size_t g = 0; g < sizeof groups / sizeof groups[0]; g++) {
                int nb = groups[g];
                filter_gaussian_path_set(cap);
                memset(w, 0xff, sizeof w);
                filter_weights_1d_blocks(&f, pos, nb, R, w, PLANE, BSTRIDE);
                filter_gaussian_path_set(0);
                int bad = 0;
                for (int v = 0; v < nb; v++) {
                    filter_weights_1d_offsets(&f, pos + 8 * v, 8, R, ref, 8);
                    for (int t = 0; t < side; t++)
                        bad += memcmp(w + (size_t)v * BSTRIDE + (size_t)t * PLANE, ref + 8 * t,
                                      8 * sizeof ref[0]) != 0;
                }
                CHECK_MSG(bad == 0, "%s %g path %d, %d groups: %d planes differ",
                          filters[k].name, (double)f.r, cap, nb, bad);
            }
        filter_gaussian_path_set(2);
    }
}

/* ---- the film on a course scene --------------------------------------------------- */

typedef struct Fixture {
    Scene *scene;
    PrimTable prims;
    Accel accel;
    RayTracer rt;
} Fixture;

static bool fixture_open(Fixture *fx, const char *name, bool grid)
{
    memset(fx, 0, sizeof *fx);
    const char *course = harness_course_dir();
    if (!course)
        harness_skip("course folder absent");
    char path[1024];
    snprintf(path, sizeof path, "%s/a7/%s", course, name);
    Diag d;
    diag_init(&d, NULL);
    fx->scene = scene_load(path, &d);
    CHECK_MSG(fx->scene != NULL, "%s", d.last);
    if (!fx->scene)
        return false;
    fx->rt.scene = fx->scene;
    fx->rt.shadows = true;
    fx->rt.bounces = 2;
    fx->rt.weight = 0.01f;
    fx->rt.shade_back = true;
    AccelConfig cfg = {.grid_n = {15, 30, 15}, .grid_auto = false, .no_marking = false, .visualize = false};
    CHECK(prim_table_build(&fx->prims, fx->scene));
    CHECK(accel_init(&fx->accel, grid ? accel_find("grid") : &accel_none_ops, &fx->prims,
                     &cfg, &d));
    fx->rt.accel = &fx->accel;
    return true;
}

static void fixture_close(Fixture *fx)
{
    accel_free(&fx->accel);
    prim_table_free(&fx->prims);
    scene_free(fx->scene);
}

static bool same_pixels(const Image *a, const Image *b, int ox, int oy)
{
    for (int y = 0; y < a->height; y++)
        for (int x = 0; x < a->width; x++) {
            Vec3 p = image_get(a, x, y), q = image_get(b, x + ox, y + oy);
            if (memcmp(&p, &q, sizeof p) != 0)
                return false;
        }
    return true;
}

static void render_rect(Fixture *fx, const Sampler *s, const Filter *f, const Sampler *refine,
                        int W, int H, int x0, int y0, int w, int h, size_t budget,
                        int threads, Image *color, Image *depth)
{
    CHECK(image_init(color, w, h));
    if (depth) /* NULL: colour only (the filter's vector path) */
        CHECK(image_init(depth, w, h));
    FilmConfig fc;
    memset(&fc, 0, sizeof fc);
    fc.sampler = s;
    fc.filter = f;
    fc.refine = refine;
    fc.threshold = 0.05f;
    fc.full_width = W;
    fc.full_height = H;
    fc.x0 = x0;
    fc.y0 = y0;
    fc.width = w;
    fc.height = h;
    fc.color = color;
    fc.depth = depth;
    fc.depth_min = 5;
    fc.depth_max = 15;
    fc.budget = budget;
    CHECK(film_render(&fx->rt, &fx->scene->camera, &fc, threads, NULL, NULL));
}

/* A rectangle (also at the borders, where the margin is cut) is exactly the crop of
 * the full render; so is the full render made strip by strip in a tiny budget. With
 * the depth image (the general loop), and colour only where the film keeps moments. */
static void test_film_region_and_budget(void)
{
    Fixture fx;
    if (!fixture_open(&fx, "scene7_03_marble_vase.txt", true))
        return;
    Sampler jit, rnd, ada;
    make_sampler(&jit, "jittered", 9, 0);
    make_sampler(&rnd, "random", 5, 2);
    make_sampler(&ada, "jittered", 16, 0);
    ada.stream = 1;
    Filter gauss, tent;
    char why[160];
    CHECK(filter_init(&gauss, filter_find("gaussian"), 0.9f, why, sizeof why));
    CHECK(filter_init(&tent, filter_find("tent"), 1.5f, why, sizeof why));
    const int W = 61, H = 47;
    struct { const Sampler *s; const Filter *f; const Sampler *refine; } cases[] = {
        {&jit, &gauss, NULL}, {&rnd, &tent, NULL}, {&jit, &tent, &ada}};
    for (int c = 0; c < 3; c++) {
        Image full, full_d;
        render_rect(&fx, cases[c].s, cases[c].f, cases[c].refine, W, H, 0, 0, W, H, 0, 2,
                    &full, &full_d);
        static const int rects[][4] = {{0, 0, 10, 7}, {20, 13, 17, 9}, {50, 40, 11, 7},
                                       {0, 30, 61, 1}, {60, 0, 1, 47}};
        for (int r = 0; r < 5; r++) {
            Image part, part_d;
            render_rect(&fx, cases[c].s, cases[c].f, cases[c].refine, W, H, rects[r][0],
                        rects[r][1], rects[r][2], rects[r][3], 0, 1, &part, &part_d);
            CHECK_MSG(same_pixels(&part, &full, rects[r][0], rects[r][1]) &&
                          same_pixels(&part_d, &full_d, rects[r][0], rects[r][1]),
                      "case %d: rectangle %d differs from the crop of the full render", c, r);
            image_free(&part);
            image_free(&part_d);
        }
        /* the smallest budget (2R + 1 rows held: a strip per output row) and one of a
         * few rows: many strips, the shared margin rows kept, not traced again */
        Image strip, strip_d;
        for (int b = 0; b < 2; b++) {
            render_rect(&fx, cases[c].s, cases[c].f, cases[c].refine, W, H, 0, 0, W, H,
                        b == 0 ? 1 : (size_t)W * 9 * 18 * 4 * 9, 2, &strip, &strip_d);
            CHECK_MSG(same_pixels(&strip, &full, 0, 0) && same_pixels(&strip_d, &full_d, 0, 0),
                      "case %d: the strip-by-strip render (budget %d) differs", c, b);
            image_free(&strip);
            image_free(&strip_d);
        }
        image_free(&full);
        image_free(&full_d);
    }
    /* Colour only, where the film keeps moments (jittered 16: the Gaussian 0.4, and the
     * box 0.5 summed from the packets): rectangles and tiny budgets as above. */
    Sampler jit16;
    make_sampler(&jit16, "jittered", 16, 3);
    Filter g4, box;
    CHECK(filter_init(&g4, filter_find("gaussian"), 0.4f, why, sizeof why));
    filter_init_default(&box);
    for (int c = 0; c < 2; c++) {
        const Filter *flt = c ? &box : &g4;
        Image full;
        render_rect(&fx, &jit16, flt, NULL, W, H, 0, 0, W, H, 0, 2, &full, NULL);
        static const int rects[][4] = {{0, 0, 10, 7}, {20, 13, 17, 9}, {50, 40, 11, 7},
                                       {0, 30, 61, 1}, {60, 0, 1, 47}};
        for (int r = 0; r < 5; r++) {
            Image part;
            render_rect(&fx, &jit16, flt, NULL, W, H, rects[r][0], rects[r][1], rects[r][2],
                        rects[r][3], 0, 1, &part, NULL);
            CHECK_MSG(same_pixels(&part, &full, rects[r][0], rects[r][1]),
                      "moments %d: rectangle %d differs from the crop of the full render", c, r);
            image_free(&part);
        }
        for (int b = 0; b < 2; b++) {
            Image strip;
            render_rect(&fx, &jit16, flt, NULL, W, H, 0, 0, W, H,
                        b == 0 ? 1 : (size_t)W * 40 * 4 * 9, 2, &strip, NULL);
            CHECK_MSG(same_pixels(&strip, &full, 0, 0),
                      "moments %d: the strip-by-strip render (budget %d) differs", c, b);
            image_free(&strip);
        }
        image_free(&full);
    }
    fixture_close(&fx);
}

/* Column chunks: a rectangle whose thinnest strip (2R + 1 rows of its whole width)
 * would hold more than strip_limit is rendered chunk after chunk. Without them the
 * film held 2R + 1 rows of the whole width whatever the budget (3840 wide, 256
 * samples, the Gaussian 1.0: 294 MB against a budget of 8). Here strip_limit 1 and
 * budget 1 force chunks of 16 columns (16 R, R = 1: the Gaussian 0.4) against 2R + 1
 * rows of the whole width: the bytes are those of the one-piece render
 * (colour and depth, and colour only where the film keeps moments: jittered 16; the
 * whole image and a rectangle, whose chunks land at their
 * column of the outputs), on 1 and 2 threads, adaptive too; the storage held is that
 * of a chunk's strip (under half the one piece's here); the rays are more by the chunks'
 * margins; the progress total (film_traced_pixels) is what was traced. */
static void test_film_column_chunks(void)
{
    Fixture fx;
    if (!fixture_open(&fx, "scene7_03_marble_vase.txt", true))
        return;
    Sampler jit, ada, jit16;
    make_sampler(&jit, "jittered", 9, 0);
    make_sampler(&jit16, "jittered", 16, 0);
    make_sampler(&ada, "jittered", 16, 0);
    ada.stream = 1;
    Filter gauss;
    char why[160];
    CHECK(filter_init(&gauss, filter_find("gaussian"), 0.4f, why, sizeof why));
    FILE *sink = fopen("/dev/null", "w");
    const int W = 61, H = 47;
    static const int rects[][4] = {{0, 0, 61, 47}, {13, 5, 40, 30}};
    for (int r = 0; r < 2 && sink; r++)
        for (int a = 0; a < 3; a++) /* 2: colour only, moments (jittered 16) */
            for (int threads = 1; threads <= 2; threads++) {
                Image img[2][2];
                RtStats st[2];
                size_t held[2];
                uint64_t traced[2];
                for (int chunked = 0; chunked < 2; chunked++) {
                    CHECK(image_init(&img[chunked][0], rects[r][2], rects[r][3]));
                    CHECK(image_init(&img[chunked][1], rects[r][2], rects[r][3]));
                    FilmConfig fc;
                    memset(&fc, 0, sizeof fc);
                    fc.sampler = a == 2 ? &jit16 : &jit;
                    fc.filter = &gauss;
                    fc.refine = a == 1 ? &ada : NULL;
                    fc.threshold = 0.05f;
                    fc.full_width = W;
                    fc.full_height = H;
                    fc.x0 = rects[r][0];
                    fc.y0 = rects[r][1];
                    fc.width = rects[r][2];
                    fc.height = rects[r][3];
                    fc.color = &img[chunked][0];
                    fc.depth = a == 2 ? NULL : &img[chunked][1];
                    fc.depth_min = 5;
                    fc.depth_max = 15;
                    /* the smallest strips both ways: 2R + 1 rows, of the whole width
                     * (no limit) or of a chunk */
                    fc.budget = 1;
                    fc.strip_limit = chunked ? 1 : SIZE_MAX;
                    traced[chunked] = film_traced_pixels(&fc);
                    fc.progress = progress_start(PROGRESS_ALWAYS, sink, "rendering",
                                                 traced[chunked]);
                    CHECK(film_render(&fx.rt, &fx.scene->camera, &fc, threads, &st[chunked],
                                      NULL));
                    CHECK_MSG(progress_done(fc.progress) == traced[chunked],
                              "rect %d adaptive %d chunked %d: progress %llu of %llu", r, a,
                              chunked, (unsigned long long)progress_done(fc.progress),
                              (unsigned long long)traced[chunked]);
                    progress_finish(fc.progress);
                    held[chunked] = fc.held;
                }
                CHECK_MSG(same_pixels(&img[1][0], &img[0][0], 0, 0) &&
                              (a == 2 || same_pixels(&img[1][1], &img[0][1], 0, 0)),
                          "rect %d adaptive %d threads %d: the chunked render differs", r, a,
                          threads);
                CHECK_MSG(held[1] > 0 && held[1] * 2 < held[0],
                          "rect %d adaptive %d threads %d: %zu bytes held in chunks, %zu in "
                          "one piece", r, a, threads, held[1], held[0]);
                CHECK_MSG(st[1].nonshadow_rays > st[0].nonshadow_rays &&
                              traced[1] > traced[0],
                          "rect %d adaptive %d: chunks traced no margin (%llu rays, %llu "
                          "pixels)", r, a, (unsigned long long)st[1].nonshadow_rays,
                          (unsigned long long)traced[1]);
                for (int k = 0; k < 2; k++) {
                    image_free(&img[k][0]);
                    image_free(&img[k][1]);
                }
            }
    if (sink)
        fclose(sink);
    fixture_close(&fx);
}

/* FilmConfig.rows: what a strip-by-strip render hands over. Its strips are copied into
 * byte images here, and every output pixel must come exactly once, strips of a column
 * chunk from the bottom up, all three outputs of a strip the same size. */
typedef struct RowsSink {
    Image out[3];              /* the rectangle's colour, depth, normals (bytes) */
    int *seen;                 /* per output pixel: strips that held it */
    int calls, last_x, last_y; /* the strip before: chunks left to right, rows upwards */
    bool ordered, sized;
} RowsSink;

static void rows_sink(void *user, const FilmRows *r)
{
    RowsSink *k = user;
    const Image *part[3] = {r->color, r->depth, r->normals};
    const Image *any = NULL;
    for (int i = 0; i < 3; i++) {
        if (!part[i])
            continue;
        if (any && (part[i]->width != any->width || part[i]->height != any->height))
            k->sized = false;
        any = part[i];
        for (int y = 0; y < part[i]->height; y++)
            memcpy(k->out[i].bytes + ((size_t)(r->y + y) * k->out[i].width + r->x) * 3,
                   part[i]->bytes + (size_t)y * part[i]->width * 3,
                   (size_t)part[i]->width * 3);
    }
    if (!any)
        return;
    if (k->calls > 0 && !(r->x > k->last_x || (r->x == k->last_x && r->y > k->last_y)))
        k->ordered = false;
    k->calls++;
    k->last_x = r->x;
    k->last_y = r->y;
    for (int y = 0; y < any->height; y++)
        for (int x = 0; x < any->width; x++)
            k->seen[(size_t)(r->y + y) * k->out[0].width + r->x + x]++;
}

/* Strip by strip (FilmConfig.rows, what a streamed output file is written from) gives
 * the bytes of the whole images: colour only (the planes and the vector filter), with
 * depth and normals (the general loop), adaptive; the whole image and a rectangle; the
 * default budget and the smallest (a strip per output row), column chunks
 * (strip_limit 1: chunks of 16 columns), 1 and 2 threads. Every pixel comes once. */
static void test_film_rows_strip_by_strip(void)
{
    Fixture fx;
    if (!fixture_open(&fx, "scene7_03_marble_vase.txt", true))
        return;
    Sampler jit, uni, ada;
    make_sampler(&jit, "jittered", 4, 3);
    make_sampler(&uni, "uniform", 4, 0);
    make_sampler(&ada, "jittered", 16, 3);
    Sampler jit16; /* colour only with 16 samples: the film keeps moments */
    make_sampler(&jit16, "jittered", 16, 3);
    ada.stream = 1;
    Filter gauss, tent;
    char why[160];
    CHECK(filter_init(&gauss, filter_find("gaussian"), 0.4f, why, sizeof why));
    CHECK(filter_init(&tent, filter_find("tent"), 1.5f, why, sizeof why));
    struct { const Sampler *s; const Filter *f; const Sampler *refine; unsigned want; }
        cases[] = {{&jit, &gauss, NULL, FILM_COLOR},
                   {&uni, &tent, NULL, FILM_COLOR | FILM_DEPTH | FILM_NORMALS},
                   {&jit, &tent, &ada, FILM_COLOR | FILM_NORMALS},
                   {&jit, &gauss, NULL, FILM_DEPTH}, {&jit16, &gauss, NULL, FILM_COLOR}};
    const int W = 61, H = 47;
    static const int rects[][4] = {{0, 0, 61, 47}, {13, 5, 40, 30}};
    for (int c = 0; c < (int)(sizeof cases / sizeof cases[0]); c++)
        for (int r = 0; r < 2; r++)
            for (int v = 0; v < 3; v++) {
                int x0 = rects[r][0], y0 = rects[r][1], w = rects[r][2], h = rects[r][3];
                int threads = v == 1 ? 1 : 2;
                FilmConfig fc;
                memset(&fc, 0, sizeof fc);
                fc.sampler = cases[c].s;
                fc.filter = cases[c].f;
                fc.refine = cases[c].refine;
                fc.threshold = 0.05f;
                fc.full_width = W;
                fc.full_height = H;
                fc.x0 = x0;
                fc.y0 = y0;
                fc.width = w;
                fc.height = h;
                fc.depth_min = 5;
                fc.depth_max = 15;
                fc.budget = v == 0 ? 0 : 1;
                fc.strip_limit = v == 2 ? 1 : 0;
                /* the whole images */
                Image whole[3];
                memset(whole, 0, sizeof whole);
                for (int i = 0; i < 3; i++)
                    if (cases[c].want & (1u << i))
                        CHECK(image_init_bytes(&whole[i], w, h));
                FilmConfig a = fc;
                a.color = whole[0].bytes ? &whole[0] : NULL;
                a.depth = whole[1].bytes ? &whole[1] : NULL;
                a.normals = whole[2].bytes ? &whole[2] : NULL;
                RtStats st_a, st_b;
                CHECK(film_render(&fx.rt, &fx.scene->camera, &a, threads, &st_a, NULL));
                /* strip by strip */
                RowsSink k;
                memset(&k, 0, sizeof k);
                k.ordered = k.sized = true;
                for (int i = 0; i < 3; i++)
                    CHECK(image_init_bytes(&k.out[i], w, h));
                k.seen = calloc((size_t)w * (size_t)h, sizeof *k.seen);
                CHECK(k.seen != NULL);
                FilmConfig b = fc;
                b.rows = rows_sink;
                b.rows_user = &k;
                b.rows_wanted = cases[c].want;
                if (k.seen)
                    CHECK(film_render(&fx.rt, &fx.scene->camera, &b, threads, &st_b, NULL));
                bool once = k.seen != NULL;
                for (size_t i = 0; once && i < (size_t)w * (size_t)h; i++)
                    once = k.seen[i] == 1;
                bool same = true;
                for (int i = 0; i < 3; i++)
                    if (whole[i].bytes)
                        same = same && memcmp(whole[i].bytes, k.out[i].bytes,
                                              (size_t)w * (size_t)h * 3) == 0;
                CHECK_MSG(same, "case %d rect %d variant %d: the strips differ from the whole "
                          "images", c, r, v);
                CHECK_MSG(once && k.ordered && k.sized && k.calls > (v == 0 ? 0 : 1),
                          "case %d rect %d variant %d: %d strips, every pixel once %d, in "
                          "order %d, of one size %d", c, r, v, k.calls, once, k.ordered,
                          k.sized);
                CHECK_MSG(st_a.nonshadow_rays == st_b.nonshadow_rays,
                          "case %d rect %d variant %d: %llu rays whole, %llu strip by strip",
                          c, r, v, (unsigned long long)st_a.nonshadow_rays,
                          (unsigned long long)st_b.nonshadow_rays);
                free(k.seen);
                for (int i = 0; i < 3; i++) {
                    image_free(&whole[i]);
                    image_free(&k.out[i]);
                }
            }
    /* rows with whole images too, or with nothing wanted: a bad configuration */
    Image one;
    CHECK(image_init_bytes(&one, 4, 4));
    RowsSink k;
    memset(&k, 0, sizeof k);
    FilmConfig bad;
    memset(&bad, 0, sizeof bad);
    bad.sampler = &jit;
    bad.filter = &gauss;
    bad.full_width = bad.full_height = bad.width = bad.height = 4;
    bad.rows = rows_sink;
    bad.rows_user = &k;
    bad.rows_wanted = FILM_COLOR;
    bad.color = &one;
    CHECK(!film_render(&fx.rt, &fx.scene->camera, &bad, 1, NULL, NULL));
    bad.color = NULL;
    bad.rows_wanted = 0;
    CHECK(!film_render(&fx.rt, &fx.scene->camera, &bad, 1, NULL, NULL));
    CHECK_INT(k.calls, 0);
    image_free(&one);
    fixture_close(&fx);
}

/* One worker and no shared rows (R = 0: the box 0.5 with any sampler): the film holds
 * one band of rows at a time, strip after strip; the bytes are those of the one strip
 * that two workers' default budget holds (the whole image here), with and without the
 * depth image (pixel by pixel, the general loop), fixed and random positions. */
static void test_film_band_strips(void)
{
    Fixture fx;
    if (!fixture_open(&fx, "scene7_03_marble_vase.txt", true))
        return;
    Sampler jit, uni, rnd;
    make_sampler(&jit, "jittered", 16, 0);
    make_sampler(&uni, "uniform", 9, 0);
    make_sampler(&rnd, "random", 4, 5);
    Filter box;
    filter_init_default(&box);
    CHECK(box.support == 0);
    const Sampler *ss[] = {&jit, &uni, &rnd};
    const int W = 61, H = 47; /* 47 rows: five whole bands and a partial one */
    for (int c = 0; c < 3; c++)
        for (int d = 0; d < 2; d++) {
            Image one, one_d, bands, bands_d;
            render_rect(&fx, ss[c], &box, NULL, W, H, 0, 0, W, H, 0, 2, &one,
                        d ? &one_d : NULL);
            render_rect(&fx, ss[c], &box, NULL, W, H, 0, 0, W, H, 0, 1, &bands,
                        d ? &bands_d : NULL);
            CHECK_MSG(same_pixels(&bands, &one, 0, 0) &&
                          (!d || same_pixels(&bands_d, &one_d, 0, 0)),
                      "sampler %d, depth %d: band by band differs from one strip", c, d);
            image_free(&one);
            image_free(&bands);
            if (d) {
                image_free(&one_d);
                image_free(&bands_d);
            }
        }
    fixture_close(&fx);
}

/* One centred sample with the default box filter: the image loop's bytes, with and
 * without the grid. */
static void test_film_default_is_image_loop(void)
{
    for (int g = 0; g < 2; g++) {
        Fixture fx;
        if (!fixture_open(&fx, "scene7_03_marble_vase.txt", g == 1))
            return;
        Sampler c;
        sampler_init_center(&c);
        Filter box;
        filter_init_default(&box);
        Image film, film_d, plain, plain_d;
        render_rect(&fx, &c, &box, NULL, 40, 30, 0, 0, 40, 30, 0, 2, &film, &film_d);
        CHECK(image_init(&plain, 40, 30) && image_init(&plain_d, 40, 30));
        RenderTarget t;
        memset(&t, 0, sizeof t);
        t.width = 40;
        t.height = 30;
        t.color = &plain;
        t.depth = &plain_d;
        t.depth_min = 5;
        t.depth_max = 15;
        CHECK(render_image(&fx.rt, &fx.scene->camera, &t, 2, NULL, NULL, NULL, NULL));
        CHECK(same_pixels(&film, &plain, 0, 0));
        CHECK(same_pixels(&film_d, &plain_d, 0, 0));
        image_free(&film);
        image_free(&film_d);
        image_free(&plain);
        image_free(&plain_d);
        fixture_close(&fx);
    }
}

/* The progress line counts every traced pixel once -- the rectangle and its filter
 * margin, strip after strip -- and ends at film_traced_pixels. */
static void test_film_progress(void)
{
    Fixture fx;
    if (!fixture_open(&fx, "scene7_03_marble_vase.txt", true))
        return;
    Sampler jit;
    make_sampler(&jit, "jittered", 4, 0);
    Filter gauss;
    char why[160];
    CHECK(filter_init(&gauss, filter_find("gaussian"), 0.9f, why, sizeof why)); /* R = 2 */
    FILE *sink = tmpfile();
    CHECK(sink != NULL);
    static const int rects[][4] = {{0, 0, 61, 47}, {20, 13, 17, 9}, {55, 0, 6, 5}};
    static const uint64_t traced[] = {61 * 47, 21 * 13, 8 * 7};
    for (int r = 0; r < 3 && sink; r++) {
        Image color;
        CHECK(image_init(&color, rects[r][2], rects[r][3]));
        FilmConfig fc;
        memset(&fc, 0, sizeof fc);
        fc.sampler = &jit;
        fc.filter = &gauss;
        fc.full_width = 61;
        fc.full_height = 47;
        fc.x0 = rects[r][0];
        fc.y0 = rects[r][1];
        fc.width = rects[r][2];
        fc.height = rects[r][3];
        fc.color = &color;
        fc.budget = 1; /* a strip per output row: many strips, margins shared */
        CHECK_MSG(film_traced_pixels(&fc) == traced[r], "rectangle %d: %llu traced pixels", r,
                  (unsigned long long)film_traced_pixels(&fc));
        fc.progress = progress_start(PROGRESS_ALWAYS, sink, "rendering", traced[r]);
        CHECK(fc.progress != NULL);
        CHECK(film_render(&fx.rt, &fx.scene->camera, &fc, 2, NULL, NULL));
        CHECK_MSG(progress_done(fc.progress) == traced[r], "rectangle %d: progress %llu of %llu",
                  r, (unsigned long long)progress_done(fc.progress),
                  (unsigned long long)traced[r]);
        progress_finish(fc.progress);
        image_free(&color);
    }
    if (sink)
        fclose(sink);
    fixture_close(&fx);
}

/* The colour-only filter sums four output pixels per vector (film_filter_quad) where
 * it can, the scalar loop elsewhere (border columns, a rectangle's last pixels); with a
 * depth image every pixel goes through the general loop. The colour must be the same
 * bytes either way, on every vector path of the film (film_path_set: the plain loops,
 * AVX2, AVX-512, as far as the CPU has them), and a rectangle at any column offset (which regroups the pixels of
 * a vector) the crop of the full render. Fixed weights (uniform: the table) and
 * separable ones (Gaussian: R = 1 and 2); R = 0: the table (uniform; box 0.5, box 0.3
 * and tent 0.5) and random positions with the box, eight pixels at a time with AVX2
 * (film_filter_own8; 9 and 5 samples: 45 and 25 floats a pixel, not whole 8 x 8
 * transposes), four without (film_filter_own), the scalar loop for the rest (box 0.3
 * also gives weights 0 and pixels with no weight at all). */
static void test_film_vector_filter(void)
{
    Fixture fx;
    if (!fixture_open(&fx, "scene7_03_marble_vase.txt", true))
        return;
    Sampler jit, uni, rnd, jit64;
    make_sampler(&jit, "jittered", 16, 3);
    /* 64 samples: more terms than the AVX-512 sums list at once (batches; two rows'
     * spans one at a time) */
    make_sampler(&jit64, "jittered", 64, 3);
    make_sampler(&uni, "uniform", 9, 0);
    make_sampler(&rnd, "random", 5, 1);
    Filter g4, g9, box, box3, tent5;
    char why[160];
    CHECK(filter_init(&g4, filter_find("gaussian"), 0.4f, why, sizeof why));
    CHECK(filter_init(&g9, filter_find("gaussian"), 0.9f, why, sizeof why));
    CHECK(filter_init(&box, filter_find("box"), 0.5f, why, sizeof why));
    CHECK(filter_init(&box3, filter_find("box"), 0.3f, why, sizeof why));
    /* R = 0 with the table's weights all different (tent 0.5), or 0 and 1 (box 0.3): the
     * table's sample order (film_filter_own8) */
    CHECK(filter_init(&tent5, filter_find("tent"), 0.5f, why, sizeof why));
    struct { const Sampler *s; const Filter *f; } cases[] = {
        {&jit, &g4}, {&jit, &box}, {&uni, &box}, {&uni, &g4}, {&rnd, &g9}, {&rnd, &box3},
        {&jit, &box3}, {&jit64, &g4}, {&uni, &tent5}, {&uni, &box3}};
    const int W = 37, H = 21;
    for (int c = 0; c < (int)(sizeof cases / sizeof cases[0]); c++) {
        Image plain, with_d, depth;
        render_rect(&fx, cases[c].s, cases[c].f, NULL, W, H, 0, 0, W, H, 0, 2, &plain, NULL);
        render_rect(&fx, cases[c].s, cases[c].f, NULL, W, H, 0, 0, W, H, 0, 1, &with_d, &depth);
        CHECK_MSG(same_pixels(&with_d, &plain, 0, 0),
                  "case %d: colour-only filtering differs from the general loop's", c);
        for (int cap = 0; cap <= 1; cap++) { /* the plain loops, AVX2 (as the CPU has it) */
            Image narrow;
            film_path_set(cap);
            render_rect(&fx, cases[c].s, cases[c].f, NULL, W, H, 0, 0, W, H, 0, 2, &narrow,
                        NULL);
            film_path_set(2);
            CHECK_MSG(same_pixels(&narrow, &plain, 0, 0),
                      "case %d: the film's path %d differs from its widest", c, cap);
            image_free(&narrow);
        }
        for (int x0 = 1; x0 <= 3; x0++) {
            Image part;
            render_rect(&fx, cases[c].s, cases[c].f, NULL, W, H, x0, 5, W - x0 - 2, 9, 0, 1,
                        &part, NULL);
            CHECK_MSG(same_pixels(&part, &plain, x0, 5),
                      "case %d: rectangle at column %d differs from the crop", c, x0);
            image_free(&part);
        }
        image_free(&plain);
        image_free(&with_d);
        image_free(&depth);
    }
    /* Rows of 1024 floats and more: the planes' rows padded apart (film_plane_width;
     * 1024 wide and R = 1 or 2: 1026 or 1028 floats, not the padded stride), read and
     * written at the padded stride everywhere. */
    for (int c = 0; c < (int)(sizeof cases / sizeof cases[0]); c++) {
        if (cases[c].f == &box || cases[c].f == &box3 || cases[c].f == &tent5)
            continue;
        const int WW = 1024, HH = 3;
        Image plain, with_d, depth, part;
        render_rect(&fx, cases[c].s, cases[c].f, NULL, WW, HH, 0, 0, WW, HH, 0, 1, &plain,
                    NULL);
        render_rect(&fx, cases[c].s, cases[c].f, NULL, WW, HH, 0, 0, WW, HH, 0, 2, &with_d,
                    &depth);
        CHECK_MSG(same_pixels(&with_d, &plain, 0, 0),
                  "case %d, %d wide: colour-only filtering differs from the general loop's", c,
                  WW);
        render_rect(&fx, cases[c].s, cases[c].f, NULL, WW, HH, 3, 1, WW - 5, 1, 0, 2, &part,
                    NULL);
        CHECK_MSG(same_pixels(&part, &plain, 3, 1),
                  "case %d, %d wide: a rectangle differs from the crop", c, WW);
        image_free(&plain);
        image_free(&with_d);
        image_free(&depth);
        image_free(&part);
    }
    fixture_close(&fx);
}

/* The samples picture of a film whose separable weights come from the tile's scratch
 * (the Gaussian: the positions then reach the planes only for this picture), or that
 * keeps moments instead of samples (the Gaussian with 16 samples, the box 0.5: the
 * samples then reach the film only for this picture), is the picture of the same
 * samples kept by the general loop (the box 0.5 with the depth image asked too: no
 * moments, every sample stored): same sampler, same positions and colours, on every
 * path of the film, 1 and 2 threads, a width that cuts the last tile (the per-pixel
 * weights and copies). Fails when the scratch or the moments drop the positions though
 * the picture is asked for. */
static void test_film_samples_with_weights(void)
{
    Fixture fx;
    if (!fixture_open(&fx, "scene7_03_marble_vase.txt", true))
        return;
    Sampler jit9, jit16;
    make_sampler(&jit9, "jittered", 9, 4);
    make_sampler(&jit16, "jittered", 16, 4);
    const Sampler *samplers[2] = {&jit9, &jit16};
    Filter g4, box;
    char why[160];
    CHECK(filter_init(&g4, filter_find("gaussian"), 0.4f, why, sizeof why));
    filter_init_default(&box);
    const int W = 21, H = 11, Z = 5;
    for (int k = 0; k < 2; k++) {
        Image ref, ref_color, ref_depth;
        CHECK(image_init(&ref, W * Z, H * Z) && image_init(&ref_color, W, H) &&
              image_init(&ref_depth, W, H));
        FilmConfig fc;
        memset(&fc, 0, sizeof fc);
        fc.sampler = samplers[k];
        fc.filter = &box;
        fc.full_width = W;
        fc.full_height = H;
        fc.width = W;
        fc.height = H;
        fc.color = &ref_color;
        fc.depth = &ref_depth;
        fc.depth_min = 5;
        fc.depth_max = 15;
        fc.samples = &ref;
        fc.samples_zoom = Z;
        CHECK(film_render(&fx.rt, &fx.scene->camera, &fc, 1, NULL, NULL));
        for (int c = 0; c < 2 * 2 * 3; c++) {
            const Filter *flt = c % 2 == 0 ? &box : &g4;
            int cap = c / 2 % 3, threads = 1 + c / 6;
            Image color, pic;
            CHECK(image_init(&color, W, H) && image_init(&pic, W * Z, H * Z));
            fc.filter = flt;
            fc.color = &color;
            fc.depth = NULL;
            fc.samples = &pic;
            film_path_set(cap);
            CHECK(film_render(&fx.rt, &fx.scene->camera, &fc, threads, NULL, NULL));
            film_path_set(2);
            CHECK_MSG(same_pixels(&pic, &ref, 0, 0),
                      "%d samples, %s, film path %d, %d threads: the samples picture differs "
                      "from the general loop's", samplers[k]->count, c % 2 ? "Gaussian" : "box",
                      cap, threads);
            if (c % 2 == 0)
                CHECK_MSG(same_pixels(&color, &ref_color, 0, 0),
                          "%d samples, box, film path %d, %d threads: the colour differs from "
                          "the general loop's", samplers[k]->count, cap, threads);
            image_free(&color);
            image_free(&pic);
        }
        image_free(&ref);
        image_free(&ref_color);
        image_free(&ref_depth);
    }
    fixture_close(&fx);
}

/* A scene given as text (no course folder needed), without a grid. */
static bool fixture_open_text(Fixture *fx, const char *text)
{
    memset(fx, 0, sizeof *fx);
    Diag d;
    diag_init(&d, NULL);
    fx->scene = scene_load_string(text, "<test>", NULL, &d);
    CHECK_MSG(fx->scene != NULL, "%s", d.last);
    if (!fx->scene)
        return false;
    fx->rt.scene = fx->scene;
    fx->rt.weight = 0.01f;
    AccelConfig cfg = {.grid_n = {1, 1, 1}};
    CHECK(prim_table_build(&fx->prims, fx->scene));
    CHECK(accel_init(&fx->accel, &accel_none_ops, &fx->prims, &cfg, &d));
    fx->rt.accel = &fx->accel;
    return true;
}

/* A sphere of 1 unit in a 5-unit orthographic view, on a bluish background; LIGHT and
 * AMBIENT are the light's and the ambient colour, DIFFUSE the sphere's. */
#define AA_SPHERE_SCENE(LIGHT, AMBIENT, DIFFUSE)                                          \
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"             \
    "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color " LIGHT " } }\n"       \
    "Background { color 0.2 0.6 1 ambientLight " AMBIENT " }\n"                            \
    "Materials { numMaterials 1 PhongMaterial { diffuseColor " DIFFUSE " } }\n"            \
    "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n"

/* Infinite and NaN sample colours through the filter. The first scene's sphere is
 * infinitely red (1e30 light times 1e30 diffuse overflows the float); the second's
 * is NaN red where its light falls (inf ambient plus -inf light). A filter reaching
 * past its support's zero weights (tent 1.5, box 1, Mitchell 2: inf times 0 is NaN)
 * must not turn the sphere or its surroundings into NaN, which the image writes as
 * black: no output channel may be NaN, and the first sphere's centre stays
 * saturated red (above 1), as its one-sample image has it. Every vector path of the
 * film (film_path_set), one and two threads. Fails without film_finite_colors. The
 * third scene's spheres, +inf and -inf red side by side, with films that keep
 * moments (random 20 + Gaussian 1.0, jittered 16 + Gaussian 0.4, random 20 + box 1):
 * a pixel's own sums overflow to +inf on one sphere and -inf on the other, and the
 * filter adding both made NaN pixels where they meet (26 of the 400 with random 20 and
 * the Gaussian 1.0); fails without film_finite_sum. */
static void test_film_nonfinite_samples(void)
{
    /* the third: a sphere of +inf red and one of -inf red side by side */
    static const char *const scenes[3] = {
        AA_SPHERE_SCENE("1e30 1e30 1e30", "0 0 0", "1e30 0 0"),
        AA_SPHERE_SCENE("-1e30 -1e30 -1e30", "1e30 1e30 1e30", "1e30 0 0"),
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1e30 1e30 1e30 } }\n"
        "Background { color 0.2 0.6 1 ambientLight 0 0 0 }\n"
        "Materials { numMaterials 2 PhongMaterial { diffuseColor 1e30 0 0 }\n"
        "    PhongMaterial { diffuseColor -1e30 0 0 } }\n"
        "Group { numObjects 2 MaterialIndex 0 Sphere { center -1 0 0 radius 1 }\n"
        "    MaterialIndex 1 Sphere { center 1 0 0 radius 1 } }\n"};
    Sampler uni, jit, rnd20, jit16;
    make_sampler(&uni, "uniform", 4, 0);
    make_sampler(&jit, "jittered", 4, 0);
    /* films that keep moments (test_film_moments): each pixel's own sums may overflow,
     * to +inf on one sphere and -inf on the other */
    make_sampler(&rnd20, "random", 20, 0);
    make_sampler(&jit16, "jittered", 16, 0);
    Filter tent, box, mitchell, gauss, gauss1, gauss4;
    char why[160];
    CHECK(filter_init(&tent, filter_find("tent"), 1.5f, why, sizeof why));
    CHECK(filter_init(&box, filter_find("box"), 1.0f, why, sizeof why));
    CHECK(filter_init(&mitchell, filter_find("mitchell"), 2.0f, why, sizeof why));
    CHECK(filter_init(&gauss, filter_find("gaussian"), 0.5f, why, sizeof why));
    CHECK(filter_init(&gauss1, filter_find("gaussian"), 1.0f, why, sizeof why));
    CHECK(filter_init(&gauss4, filter_find("gaussian"), 0.4f, why, sizeof why));
    struct { const Sampler *s; const Filter *f; } cases[] = {
        {&uni, &tent}, {&uni, &box}, {&jit, &mitchell}, {&jit, &tent}, {&uni, &gauss},
        {&rnd20, &gauss1}, {&jit16, &gauss4}, {&rnd20, &box}};
    const int W = 20, H = 20;
    for (int sc = 0; sc < 3; sc++) {
        Fixture fx;
        if (!fixture_open_text(&fx, scenes[sc]))
            return;
        for (int c = 0; c < (int)(sizeof cases / sizeof cases[0]); c++)
            for (int cap = 0; cap <= 2; cap++)
                for (int depth = 0; depth < 2; depth++) {
                    Image color, dimg;
                    film_path_set(cap);
                    render_rect(&fx, cases[c].s, cases[c].f, NULL, W, H, 0, 0, W, H, 0,
                                1 + depth, &color, depth ? &dimg : NULL);
                    film_path_set(2);
                    int nan = 0;
                    for (int y = 0; y < H; y++)
                        for (int x = 0; x < W; x++) {
                            Vec3 p = image_get(&color, x, y);
                            nan += isnan(p.x) || isnan(p.y) || isnan(p.z);
                        }
                    CHECK_MSG(nan == 0, "scene %d, case %d, path %d, depth %d: %d NaN pixels",
                              sc, c, cap, depth, nan);
                    if (sc == 0)
                        CHECK_MSG(image_get(&color, W / 2, H / 2).x > 1.0f,
                                  "case %d, path %d, depth %d: the infinite sphere's centre "
                                  "is %g red", c, cap, depth,
                                  (double)image_get(&color, W / 2, H / 2).x);
                    image_free(&color);
                    if (depth)
                        image_free(&dimg);
                }
        fixture_close(&fx);
    }
}

/* Filters narrower than the gaps between the samples: no sample of a pixel's support
 * has a non-zero weight (box 0.1 or Gaussian 0.02 with uniform 4: every pixel; box 0.2
 * with jittered 4, Mitchell 0.4 with random 3: about half; the tent 0.6, R = 1, with
 * random 2: the pixels whose samples and neighbours' all lie 0.6 or more from the
 * centre; tent 0.1 with adaptive refinement). (A separable filter with R >= 1 always
 * weighs its own pixel's samples: its reach is over 0.5.) Such a pixel takes its
 * support's nearest sample, never black
 * (the scene has no black: a lit red sphere on a light blue background); the same
 * bytes on every path of the film, with one or two threads, with a depth image (the
 * general loop) and in a rectangle. Fails with the old black pixels. */
static void test_film_unweighted_pixels(void)
{
    Fixture fx;
    if (!fixture_open_text(&fx, AA_SPHERE_SCENE("0.8 0.8 0.8", "0.2 0.2 0.2", "1 0 0")))
        return;
    Sampler uni4, uni16, jit4, rnd3, rnd2, ada;
    make_sampler(&uni4, "uniform", 4, 0);
    make_sampler(&uni16, "uniform", 16, 0);
    make_sampler(&jit4, "jittered", 4, 1);
    make_sampler(&rnd3, "random", 3, 2);
    make_sampler(&rnd2, "random", 2, 3);
    make_sampler(&ada, "jittered", 16, 1);
    ada.stream = 1;
    Filter box1, box2, g02, g03, m4, tent6, tent1;
    char why[160];
    CHECK(filter_init(&box1, filter_find("box"), 0.1f, why, sizeof why));
    CHECK(filter_init(&box2, filter_find("box"), 0.2f, why, sizeof why));
    CHECK(filter_init(&g02, filter_find("gaussian"), 0.02f, why, sizeof why));
    CHECK(filter_init(&g03, filter_find("gaussian"), 0.03f, why, sizeof why));
    CHECK(filter_init(&m4, filter_find("mitchell"), 0.4f, why, sizeof why));
    CHECK(filter_init(&tent6, filter_find("tent"), 0.6f, why, sizeof why));
    CHECK(filter_init(&tent1, filter_find("tent"), 0.1f, why, sizeof why));
    CHECK(tent6.support == 1);
    struct { const Sampler *s; const Filter *f; const Sampler *refine; } cases[] = {
        {&uni4, &box1, NULL}, {&uni4, &g02, NULL}, {&jit4, &box2, NULL},
        {&rnd3, &m4, NULL},   {&rnd2, &tent6, NULL},  {&jit4, &tent1, &ada},
        {&uni16, &g03, NULL}, {&jit4, &g03, NULL}};
    const int W = 23, H = 17;
    for (int c = 0; c < (int)(sizeof cases / sizeof cases[0]); c++) {
        Image ref, with_d, depth;
        render_rect(&fx, cases[c].s, cases[c].f, cases[c].refine, W, H, 0, 0, W, H, 0, 2,
                    &ref, NULL);
        int black = 0;
        for (int y = 0; y < H; y++)
            for (int x = 0; x < W; x++) {
                Vec3 p = image_get(&ref, x, y);
                black += p.x == 0.0f && p.y == 0.0f && p.z == 0.0f;
            }
        CHECK_MSG(black == 0, "case %d: %d black pixels", c, black);
        render_rect(&fx, cases[c].s, cases[c].f, cases[c].refine, W, H, 0, 0, W, H, 0, 1,
                    &with_d, &depth);
        CHECK_MSG(same_pixels(&with_d, &ref, 0, 0),
                  "case %d: with a depth image (the general loop) the colour differs", c);
        for (int cap = 0; cap <= 1; cap++) {
            Image narrow;
            film_path_set(cap);
            render_rect(&fx, cases[c].s, cases[c].f, cases[c].refine, W, H, 0, 0, W, H, 0, 1,
                        &narrow, NULL);
            film_path_set(2);
            CHECK_MSG(same_pixels(&narrow, &ref, 0, 0),
                      "case %d: the film's path %d differs from its widest", c, cap);
            image_free(&narrow);
        }
        Image part;
        render_rect(&fx, cases[c].s, cases[c].f, cases[c].refine, W, H, 3, 2, 15, 11, 1, 1,
                    &part, NULL);
        CHECK_MSG(same_pixels(&part, &ref, 3, 2), "case %d: a rectangle differs from the crop",
                  c);
        image_free(&part);
        image_free(&ref);
        image_free(&with_d);
        image_free(&depth);
    }
    fixture_close(&fx);
}

/* A film of random or jittered samples whose separable filter has no negative lobes
 * (the Gaussian, a box wider than a pixel), or of any samples with the box 0.5 (R = 0:
 * with 16 samples and AVX-512 summed as each packet is traced), keeps, per pixel, only
 * its weighted sums towards the (2R+1)^2 pixels around (red, green, blue, weight: 4
 * (2R+1)^2 floats), made as each tile is traced, instead of its samples and their
 * separable weights, where those sums are at most a third of the floats they replace:
 * a 40 x 20 render holds whole rows of 40 pixels of those floats (or of the samples and
 * weights) and a count, at least 2R + 1 rows. The colour is the same to the bit with
 * the depth image asked too (the general loop, which keeps the samples and adds each
 * pixel's own sums first where the moments do), on every path of the film and on 1 and
 * 2 threads. Fails when the film holds samples where it should hold moments (16 of 5
 * floats and 6 weights a pixel with the Gaussian 0.4: 176 floats) or the other way
 * round, or when the colour-only film and the general loop add in different orders. */
static void test_film_moments(void)
{
    Fixture fx;
    if (!fixture_open_text(&fx, AA_SPHERE_SCENE("0.9 0.9 0.9", "0.2 0.2 0.2", "1 0.5 0.1")))
        return;
    Sampler jit, rnd, uni, jit9, jit36, jit4;
    make_sampler(&jit, "jittered", 16, 5);
    make_sampler(&rnd, "random", 12, 6);
    make_sampler(&uni, "uniform", 16, 0);
    make_sampler(&jit9, "jittered", 9, 7);
    make_sampler(&jit36, "jittered", 36, 8);
    make_sampler(&jit4, "jittered", 4, 9);
    Filter g4, g9, box1, box5;
    char why[160];
    CHECK(filter_init(&g4, filter_find("gaussian"), 0.4f, why, sizeof why));
    CHECK(filter_init(&g9, filter_find("gaussian"), 0.9f, why, sizeof why));
    CHECK(filter_init(&box1, filter_find("box"), 1.0f, why, sizeof why));
    filter_init_default(&box5); /* the box 0.5 (R = 0): one moment, any sampler */
    /* moments: whether the film keeps them (film_moments_cfg: at most a third of the
     * floats of the samples and their weights; jittered 4 and 16 with the Gaussian 0.4
     * and 0.9 keep their samples) */
    struct { const Sampler *s; const Filter *f; int R; bool moments; } cases[] = {
        {&jit, &g4, 1, true}, {&jit36, &g9, 2, true}, {&rnd, &box1, 1, true},
        {&rnd, &g4, 1, true}, {&jit, &box5, 0, true}, {&uni, &box5, 0, true},
        {&jit9, &box5, 0, true}, {&jit4, &g4, 1, false}, {&jit, &g9, 2, false}};
    const int W = 40, H = 20;
    for (int c = 0; c < (int)(sizeof cases / sizeof cases[0]); c++) {
        int side = 2 * cases[c].R + 1;
        Image ref, depth;
        CHECK(image_init(&ref, W, H) && image_init(&depth, W, H));
        FilmConfig fc;
        memset(&fc, 0, sizeof fc);
        fc.sampler = cases[c].s;
        fc.filter = cases[c].f;
        fc.full_width = fc.width = W;
        fc.full_height = fc.height = H;
        fc.color = &ref;
        fc.depth = &depth;
        fc.depth_min = 5;
        fc.depth_max = 15;
        CHECK(film_render(&fx.rt, &fx.scene->camera, &fc, 1, NULL, NULL));
        for (int k = 0; k < 6; k++) {
            int cap = k % 3, threads = 1 + k / 3;
            Image img;
            CHECK(image_init(&img, W, H));
            fc.color = &img;
            fc.depth = NULL;
            film_path_set(cap);
            CHECK(film_render(&fx.rt, &fx.scene->camera, &fc, threads, NULL, NULL));
            film_path_set(2);
            int n = cases[c].s->count;
            size_t floats = cases[c].moments ? (size_t)(4 * side * side)
                                             : (size_t)n * (size_t)(5 + 2 * side);
            size_t row = (size_t)W * (floats * sizeof(float) + sizeof(int));
            size_t rows = fc.held / row;
            CHECK_MSG(fc.held % row == 0 && rows >= (size_t)side && rows <= (size_t)H,
                      "case %d, %d threads: the film held %zu bytes, not rows of 40 pixels of %zu "
                      "floats (%s) and a count (%zu bytes)", c, threads, fc.held, floats,
                      cases[c].moments ? "moments" : "samples and weights", row);
            CHECK_MSG(same_pixels(&img, &ref, 0, 0),
                      "case %d, path %d, %d threads: the colour-only film differs from the general "
                      "loop's", c, cap, threads);
            image_free(&img);
        }
        image_free(&ref);
        image_free(&depth);
    }
    fixture_close(&fx);
}


/* Filters reaching further than 16 pixels: the Gaussian's reach is 2 sigma, so sigma
 * 8.3 has R = 17 and sigma 16 (the largest) R = 32, though every radius is at most
 * FILTER_MAX_RADIUS. Weights made pixel by pixel (film_sample_weights: the general
 * loop with a depth image, a tile row cut by the image's or a rectangle's edge, the
 * plain build's copy) must be those of the whole tile rows (filter_weights_1d_blocks):
 * the colour the same bytes with the depth image, on every vector path, and a
 * rectangle cutting tile rows the crop of the full render. Fails when
 * film_sample_weights holds weights for R <= 16 only and leaves the others unwritten
 * (the pixels then had no weight and took their nearest sample). */
static void test_film_wide_support(void)
{
    Fixture fx;
    if (!fixture_open_text(&fx, AA_SPHERE_SCENE("0.9 0.9 0.9", "0.2 0.2 0.2", "1 0.5 0.1")))
        return;
    Sampler jit;
    make_sampler(&jit, "jittered", 4, 11);
    Filter g[2];
    char why[160];
    CHECK(filter_init(&g[0], filter_find("gaussian"), 8.3f, why, sizeof why));
    CHECK(filter_init(&g[1], filter_find("gaussian"), 16.0f, why, sizeof why));
    CHECK(g[0].support == 17 && g[1].support == 32);
    /* W = 40: whole tile rows; the rectangle cuts them (sigma 8.3: traced from column 4) */
    const int W = 40, H = 9;
    for (int c = 0; c < 2; c++) {
        Image plain, with_d, depth;
        render_rect(&fx, &jit, &g[c], NULL, W, H, 0, 0, W, H, 0, 2, &plain, NULL);
        render_rect(&fx, &jit, &g[c], NULL, W, H, 0, 0, W, H, 0, 1, &with_d, &depth);
        CHECK_MSG(same_pixels(&with_d, &plain, 0, 0),
                  "sigma %g: the colour with the depth image differs", (double)g[c].r);
        for (int cap = 0; cap <= 1; cap++) {
            Image narrow;
            film_path_set(cap);
            render_rect(&fx, &jit, &g[c], NULL, W, H, 0, 0, W, H, 0, 2, &narrow, NULL);
            film_path_set(2);
            CHECK_MSG(same_pixels(&narrow, &plain, 0, 0),
                      "sigma %g: the film's path %d differs from its widest", (double)g[c].r,
                      cap);
            image_free(&narrow);
        }
        Image part;
        render_rect(&fx, &jit, &g[c], NULL, W, H, 21, 2, 5, 5, 0, 1, &part, NULL);
        CHECK_MSG(same_pixels(&part, &plain, 21, 2),
                  "sigma %g: the rectangle differs from the crop", (double)g[c].r);
        image_free(&part);
        image_free(&plain);
        image_free(&with_d);
        image_free(&depth);
    }
    fixture_close(&fx);
}

static const TestCase tests[] = {
    {"filters: the negative-lobes flag matches each filter's weights", test_filter_lobes_flag},
    {"samplers: range, strata, lattice, n-rooks", test_sampler_ranges_and_strata},
    {"samplers: deterministic per pixel, index, seed", test_sampler_determinism},
    {"samplers: jittered placement's lanes == the rule at stratum edges", test_jittered_place},
    {"samplers: jittered pixels, each path, == the rule on sampler_random's draws",
     test_jittered_pixels},
    {"samplers: poisson (best candidate) keeps samples apart", test_poisson_sampler},
    {"filters: symmetric weights, support radii, bad radii", test_filter_symmetry_and_support},
    {"filters: the Gaussian's float exp within an ulp of libm's; batch == single", test_gaussian_fast_exp},
    {"filters: every vector path of the Gaussian gives the plain build's bits", test_gaussian_paths},
    {"filters: a row's weights towards 2R+1 pixels == one argument at a time",
     test_weights_offsets},
    {"filters: the Gaussian's steps (R = 1, 2) within 8 ulps of the exact weights",
     test_gaussian_steps},
    {"filters: a row's weights on every path: tiny positions, every run length",
     test_weights_offsets_boundaries},
    {"filters: groups of eight positions, weights in planes of their own == offsets",
     test_weights_blocks},
    {"film: rectangle == crop of the full render; tiny budget == one strip",
     test_film_region_and_budget},
    {"film: column chunks == one piece, holding a chunk's strips", test_film_column_chunks},
    {"film: strip by strip (FilmConfig.rows) == whole images, every pixel once",
     test_film_rows_strip_by_strip},
    {"film: colour-only vector filter == general loop; any column offset",
     test_film_vector_filter},
    {"film: one worker, R = 0: a strip per band == one strip", test_film_band_strips},
    {"film: one centred sample + box 0.5 == the image loop", test_film_default_is_image_loop},
    {"film: progress counts every traced pixel once", test_film_progress},
    {"film: samples picture with weights or moments from the scratch == the general loop's",
     test_film_samples_with_weights},
    {"film: infinite and NaN sample colours make no NaN pixels", test_film_nonfinite_samples},
    {"film: a pixel no weight reaches takes its nearest sample, on every path",
     test_film_unweighted_pixels},
    {"film: moments: (2R+1)^2 sums a pixel held, the general loop's bits", test_film_moments},
    {"film: filters reaching 17-32 pixels get their weights on every path", test_film_wide_support},
};

RT_TEST_MAIN(tests)
