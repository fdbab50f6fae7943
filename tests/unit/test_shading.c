/* Unit tests: cameras and pixel mapping, lights, Phong, and the tracer's rules
 * (back faces, shadows, reflection, refraction, TIR, cutoff, counters). */
#include "harness.h"
#include "rt/arena.h"
#include "rt/cpu.h"
#include "rt/geom.h"
#include "rt/raytracer.h"
#include "rt/perlin.h"
#include "rt/render.h"
#include "../../src/render/phong_packet.h"

#include <float.h>
#include <math.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>

static void test_pixel_mapping(void)
{
    float u, v;
    camera_pixel_to_screen(0, 0, 200, 200, &u, &v);
    CHECK_NEAR(u, 0.5 / 200, 1e-7);
    CHECK_NEAR(v, 0.5 / 200, 1e-7);
    /* 400x200: the square screen covers the width, v is cropped to (0.25, 0.75). */
    camera_pixel_to_screen(399, 0, 400, 200, &u, &v);
    CHECK_NEAR(u, 399.5 / 400, 1e-6);
    CHECK_NEAR(v, 0.25 + 0.5 / 400, 1e-6);
    camera_pixel_to_screen(0, 199, 400, 200, &u, &v);
    CHECK_NEAR(v, 0.75 - 0.5 / 400, 1e-6);
}

static void test_cameras(void)
{
    Camera c;
    CHECK(camera_init_orthographic(&c, v3(0, 0, 10), v3(0, 0, -2), v3(0, 3, 0.5f), 4));
    CHECK_NEAR(c.horizontal.x, 1, 1e-6);
    CHECK_NEAR(v3_dot(c.up, c.direction), 0, 1e-6);
    Ray r = camera_generate_ray(&c, 1, 0.5f);
    CHECK_NEAR(r.origin.x, 2, 1e-6);
    CHECK_NEAR(r.dir.z, -1, 1e-6);
    CHECK(camera_tmin(&c) == -FLT_MAX);
    CHECK(camera_init_perspective(&c, v3(0, 0, 0), v3(0, 0, -1), v3(0, 1, 0), 3.14159265f / 2));
    r = camera_generate_ray(&c, 1, 0.5f); /* right edge: 45 degrees */
    CHECK_NEAR(r.dir.x, sqrt(0.5), 1e-6);
    CHECK_NEAR(r.dir.z, -sqrt(0.5), 1e-6);
    CHECK(camera_tmin(&c) == 0);
    CHECK(!camera_init_perspective(&c, v3(0, 0, 0), v3(0, 0, 0), v3(0, 1, 0), 1));
    CHECK(!camera_init_perspective(&c, v3(0, 0, 0), v3(0, 1, 0), v3(0, 2, 0), 1));
    CHECK(!camera_init_orthographic(&c, v3(0, 0, 0), v3(0, 0, 1), v3(0, 1, 0), 0));
}

/* A perspective eye far from the origin aims as precisely as a near one. The screen
 * point in world space was rounded to ulp(|eye|): at 1e5 every ray of a 30-degree view
 * was off by up to 0.005 radians (the image came out blocky at 200 x 200), and from 2^24
 * on (3e7 here) the rays went sideways and the image was empty. Each ray of a 4096-wide
 * image (pixels 1.3e-4 radians apart) against the textbook direction
 * normalize(d + (2u - 1) t h + (2v - 1) t up) in double, from the camera's own basis:
 * within 1e-6 radians, and neighbouring pixels' rays distinct; eyes at 200 (just past
 * CAMERA_FAR_EYE), 1e5 and 3e7, and one at 20 (the course's range, aiming in world
 * space: within 1e-5) for comparison. */
static void test_far_eye_rays(void)
{
    static const float eyes[4] = {20.0f, 200.0f, 1e5f, 3e7f};
    for (int e = 0; e < 4; e++) {
        Camera c;
        float k = eyes[e];
        CHECK(camera_init_perspective(&c, v3(k, -0.7f * k, 0.4f * k), v3(-1, 0.7f, -0.4f),
                                      v3(0, 0, 1), 30.0f * 3.14159265f / 180.0f));
        double worst = 0.0;
        int same = 0;
        Ray prev = {{0, 0, 0}, {0, 0, 0}};
        for (int j = 0; j < 4096; j += 273)
            for (int i = 0; i < 4096; i += (i % 2 ? 511 : 1)) {
                float u, v;
                camera_pixel_to_screen(i, j, 4096, 4096, &u, &v);
                Ray r = camera_generate_ray(&c, u, v);
                double a = 2.0 * (double)u - 1.0, b = 2.0 * (double)v - 1.0;
                double t = (double)c.tan_half;
                const float *d = &c.direction.x, *h = &c.horizontal.x, *up = &c.up.x;
                const float *got = &r.dir.x;
                double w[3], n = 0.0, err = 0.0;
                for (int q = 0; q < 3; q++) {
                    w[q] = (double)d[q] + a * t * (double)h[q] + b * t * (double)up[q];
                    n += w[q] * w[q];
                }
                for (int q = 0; q < 3; q++) {
                    double diff = (double)got[q] - w[q] / sqrt(n);
                    err += diff * diff;
                }
                err = sqrt(err);
                worst = err > worst ? err : worst;
                if (i % 2 == 1 && memcmp(&prev.dir, &r.dir, sizeof r.dir) == 0)
                    same++;
                prev = r;
            }
        /* The world-space form at 20: about 2e-6 (ulp(20) = 2e-6), the course's rounding. */
        double bound = k >= CAMERA_FAR_EYE ? 1e-6 : 1e-5;
        if (worst > bound || same)
            fprintf(stderr, "  eye at %g: rays off by up to %g radians, %d pixels share their "
                            "neighbour's ray\n", (double)k, worst, same);
        CHECK(worst <= bound);
        CHECK_INT(same, 0);
        CHECK(c.far_eye == (k >= CAMERA_FAR_EYE));
    }
}

/* The depth grey of a range wider than the largest float: -depth -3e38 3e38 divided by
 * dmax - dmin = inf and drew every hit black; a hit in the middle is mid grey, the ends
 * white and black, and a finite range gives the plain ratio to the bit. */
static void test_depth_color_huge_range(void)
{
    Arena a;
    arena_init(&a);
    PhongParams pp = phong_defaults();
    Hit h = hit_none();
    h.material = phong_new(&a, &pp);
    h.t = 9.0f;
    CHECK_NEAR(render_depth_color(&h, -3e38f, 3e38f).x, 0.5, 1e-6);
    CHECK_NEAR(render_depth_color(&h, -FLT_MAX, FLT_MAX).y, 0.5, 1e-6);
    h.t = -FLT_MAX;
    CHECK(render_depth_color(&h, -3e38f, 3e38f).z == 1.0f);
    h.t = FLT_MAX;
    CHECK(render_depth_color(&h, -3e38f, 3e38f).x == 0.0f);
    h.t = 9.5f;
    float g = render_depth_color(&h, 8.0f, 12.0f).x;
    CHECK(g == (12.0f - 9.5f) / (12.0f - 8.0f));
    arena_free(&a);
}

/* dmin above dmax (-depth 12 8): the same line read the other way, dmin white and dmax
 * black with a gradient between, as the formula g = (dmax - t) / (dmax - dmin) gives;
 * t was clamped to dmin, then to dmax, which made a hard step at dmin (every nearer
 * hit white, every farther one black). */
static void test_depth_color_reversed_range(void)
{
    Arena a;
    arena_init(&a);
    PhongParams pp = phong_defaults();
    Hit h = hit_none();
    h.material = phong_new(&a, &pp);
    const float ts[] = {5.0f, 8.0f, 9.0f, 10.0f, 11.5f, 12.0f, 20.0f};
    const float want[] = {0.0f, 0.0f, 0.25f, 0.5f, 0.875f, 1.0f, 1.0f};
    for (int k = 0; k < (int)(sizeof ts / sizeof ts[0]); k++) {
        h.t = ts[k];
        float g = render_depth_color(&h, 12.0f, 8.0f).x;
        CHECK_MSG(g == want[k], "t %g: grey %g, want %g", (double)ts[k], (double)g,
                  (double)want[k]);
        /* the ordinary range, mirrored: 1 - g to the bit at these values */
        CHECK(render_depth_color(&h, 8.0f, 12.0f).x == 1.0f - want[k]);
    }
    arena_free(&a);
}

/* The cameras and image sizes the ray-generation tests compare over: course line 07's
 * perspective view, an oblique perspective with a tilted up vector, an orthographic
 * camera looking slightly sideways and a perspective eye far from the origin (aiming
 * relative to the eye, rt/camera.h); a square, a wide and an odd-sized cropped image. */
enum { RAY_TEST_CAMERAS = 4 };
static const int ray_test_sizes[3][2] = {{200, 200}, {1920, 1080}, {333, 517}};

/* n floats in [0, 1) from the LCG state *st (24-bit steps): sample positions. */
static void ray_test_unit_floats(uint32_t *st, float *out, int n)
{
    for (int k = 0; k < n; k++) {
        *st = *st * 1664525u + 1013904223u;
        out[k] = (float)(*st >> 8) / 16777216.0f;
    }
}

static void ray_test_cameras(Camera cams[RAY_TEST_CAMERAS])
{
    CHECK(camera_init_perspective(&cams[0], v3(-0.084519f, 0.313242f, 0.855356f),
                                  v3(0.049361f, -0.139598f, -0.988977f), v3(0, 1, 0),
                                  26.0f * 3.14159265f / 180.0f));
    CHECK(camera_init_perspective(&cams[1], v3(1, 2, 3), v3(-1, -0.5f, -2), v3(0.1f, 1, 0), 1.9f));
    CHECK(camera_init_orthographic(&cams[2], v3(0, 0, 10), v3(0.2f, 0.1f, -2), v3(0, 3, 0.5f), 4));
    CHECK(camera_init_perspective(&cams[3], v3(3e5f, -2e5f, 1e5f), v3(-3, 2, -1.1f), v3(0, 0, 1), 0.6f));
    CHECK(cams[3].far_eye && !cams[0].far_eye && !cams[1].far_eye && !cams[2].far_eye);
}

/* camera_pixel_rays gives each pixel camera_generate_ray(camera_pixel_to_screen) to
 * the bit: perspective and orthographic, square and cropped images, blocks at odd
 * places and of every size up to the maximum. */
static void test_pixel_rays_block(void)
{
    Camera cams[RAY_TEST_CAMERAS];
    ray_test_cameras(cams);
    const int (*sizes)[2] = ray_test_sizes;
    int differ = 0, checked = 0;
    for (int c = 0; c < RAY_TEST_CAMERAS; c++)
        for (int s = 0; s < 3; s++)
            for (int b = 0; b < 6; b++) {
                int W = sizes[s][0], H = sizes[s][1];
                int nx = 1 + (b * 5 + c) % CAMERA_BLOCK_MAX, ny = 1 + (b * 3 + s) % CAMERA_BLOCK_MAX;
                int x0 = (b * 37 + c * 11) % (W - nx + 1), y0 = (b * 53 + s * 7) % (H - ny + 1);
                Ray rays[CAMERA_BLOCK_MAX * CAMERA_BLOCK_MAX], placed[CAMERA_BLOCK_MAX * CAMERA_BLOCK_MAX];
                camera_pixel_rays(&cams[c], x0, y0, nx, ny, W, H, NULL, rays);
                /* With slots: pixel p to place n - 1 - p. */
                uint8_t slot[CAMERA_BLOCK_MAX * CAMERA_BLOCK_MAX];
                for (int p = 0; p < nx * ny; p++)
                    slot[p] = (uint8_t)(nx * ny - 1 - p);
                camera_pixel_rays(&cams[c], x0, y0, nx, ny, W, H, slot, placed);
                for (int j = 0; j < ny; j++)
                    for (int i = 0; i < nx; i++) {
                        float u, v;
                        camera_pixel_to_screen(x0 + i, y0 + j, W, H, &u, &v);
                        Ray r = camera_generate_ray(&cams[c], u, v);
                        checked++;
                        if (memcmp(&r, &rays[j * nx + i], sizeof r) != 0 ||
                            memcmp(&r, &placed[nx * ny - 1 - (j * nx + i)], sizeof r) != 0)
                            differ++;
                    }
            }
    CHECK_INT(differ, 0);
    CHECK(checked > 500);
}

/* camera_block8_rays gives lane k the ray of pixel lane[k] (8 j + i) of its 8 x 8 block,
 * camera_generate_ray(camera_pixel_to_screen) to the bit: the renderer's tile order and
 * shuffled orders (every lane group mixing columns and rows), perspective and
 * orthographic, blocks at odd places of square and cropped images; the lane-order AVX2
 * path where this CPU has it and the plain one (camera_pixel_rays through the inverse
 * table) each. */
static void test_block8_rays(void)
{
    Camera cams[RAY_TEST_CAMERAS];
    ray_test_cameras(cams);
    const int (*sizes)[2] = ray_test_sizes;
    uint32_t st = 2024;
    int differ = 0, checked = 0;
    for (int plain = 0; plain < 2; plain++) {
        camera_block8_rays_plain(plain != 0);
        for (int c = 0; c < RAY_TEST_CAMERAS; c++)
            for (int s = 0; s < 3; s++)
                for (int b = 0; b < 4; b++) {
                    int W = sizes[s][0], H = sizes[s][1];
                    int x0 = (b * 37 + c * 11) % (W - 7), y0 = (b * 53 + s * 7) % (H - 7);
                    uint8_t lane[64];
                    for (int k = 0; k < 64; k++) {
                        int dx, dy;
                        render_tile_order(k, &dx, &dy);
                        lane[k] = (uint8_t)(dy * 8 + dx);
                    }
                    for (int k = 63; b > 0 && k > 0; k--) { /* a shuffle (Fisher-Yates) */
                        st = st * 1664525u + 1013904223u;
                        int r = (int)((st >> 8) % (uint32_t)(k + 1));
                        uint8_t tmp = lane[k];
                        lane[k] = lane[r];
                        lane[r] = tmp;
                    }
                    Ray rays[64];
                    camera_block8_rays(&cams[c], x0, y0, W, H, lane, rays);
                    for (int k = 0; k < 64; k++) {
                        float u, v;
                        camera_pixel_to_screen(x0 + lane[k] % 8, y0 + lane[k] / 8, W, H, &u, &v);
                        Ray r = camera_generate_ray(&cams[c], u, v);
                        checked++;
                        differ += memcmp(&r, &rays[k], sizeof r) != 0;
                    }
                }
    }
    camera_block8_rays_plain(false);
    CHECK_INT(differ, 0);
    CHECK_INT(checked, 2 * RAY_TEST_CAMERAS * 3 * 4 * 64);
}

/* camera_sample_rays gives each sample camera_generate_ray(camera_sample_to_screen) to
 * the bit, for sample counts 1 to 37: with and without a partial group of four, and with
 * one or two groups of sixteen (the AVX-512 lanes) or of eight (AVX2) before them; with
 * each copy of the lanes this CPU runs. */
static void test_sample_rays_with(const char *isa)
{
    Camera cams[RAY_TEST_CAMERAS];
    ray_test_cameras(cams);
    const int (*sizes)[2] = ray_test_sizes;
    uint32_t st = 12345;
    int differ = 0, checked = 0;
    for (int c = 0; c < RAY_TEST_CAMERAS; c++)
        for (int s = 0; s < 3; s++)
            for (int n = 1; n <= 37; n += 4) {
                int W = sizes[s][0], H = sizes[s][1];
                float xy[2 * 40];
                ray_test_unit_floats(&st, xy, 2 * n);
                int x = (n * 37 + c) % W, y = (n * 53 + s) % H;
                Ray rays[40];
                camera_sample_rays(&cams[c], x, y, xy, n, W, H, rays);
                for (int k = 0; k < n; k++) {
                    float u, v;
                    camera_sample_to_screen(x, y, xy[2 * k], xy[2 * k + 1], W, H, &u, &v);
                    Ray r = camera_generate_ray(&cams[c], u, v);
                    checked++;
                    if (memcmp(&r, &rays[k], sizeof r) != 0)
                        differ++;
                }
            }
    if (differ)
        fprintf(stderr, "  camera_sample_rays, %s lanes: %d of %d rays differ\n", isa, differ,
                checked);
    CHECK_INT(differ, 0);
    CHECK(checked > 500);
}

/* camera_sample_rays_put: camera_sample_rays' rays to the bit, each position pair at
 * pos + k * stride, its address in dest[k], and every other float of the scratch as it
 * was (the film keeps a sample's colour there); counts 1 to 37 (groups of eight with and
 * without a remainder), strides 5 (the film's) and 7, each copy of the lanes this CPU
 * runs. */
static void test_sample_rays_put_with(const char *isa)
{
    Camera cams[RAY_TEST_CAMERAS];
    ray_test_cameras(cams);
    const int (*sizes)[2] = ray_test_sizes;
    uint32_t st = 54321;
    int differ = 0, checked = 0;
    for (int c = 0; c < RAY_TEST_CAMERAS; c++)
        for (int s = 0; s < 3; s++)
            for (int n = 1; n <= 37; n += 4)
                for (size_t stride = 5; stride <= 7; stride += 2) {
                    int W = sizes[s][0], H = sizes[s][1];
                    float xy[2 * 40], scratch[7 * 40 + 1];
                    ray_test_unit_floats(&st, xy, 2 * n);
                    for (size_t k = 0; k < sizeof scratch / sizeof scratch[0]; k++)
                        scratch[k] = -7.0f - (float)k;
                    int x = (n * 31 + c) % W, y = (n * 17 + s) % H;
                    Ray rays[40], want[40];
                    float *dest[40];
                    camera_sample_rays(&cams[c], x, y, xy, n, W, H, want);
                    camera_sample_rays_put(&cams[c], x, y, xy, n, W, H, rays, scratch, stride,
                                           dest);
                    for (int k = 0; k < n; k++) {
                        float *p = scratch + (size_t)k * stride;
                        checked++;
                        if (memcmp(&want[k], &rays[k], sizeof rays[k]) != 0 || dest[k] != p ||
                            memcmp(p, xy + 2 * k, 2 * sizeof(float)) != 0)
                            differ++;
                        for (size_t j = 2; j < stride; j++)
                            if (p[j] != -7.0f - (float)((size_t)k * stride + j))
                                differ++;
                    }
                    for (size_t j = (size_t)n * stride; j < sizeof scratch / sizeof scratch[0];
                         j++)
                        if (scratch[j] != -7.0f - (float)j)
                            differ++;
                }
    if (differ)
        fprintf(stderr, "  camera_sample_rays_put, %s lanes: %d differences in %d samples\n",
                isa, differ, checked);
    CHECK_INT(differ, 0);
    CHECK(checked > 1000);
}

/* camera_sample_rays_pixels: for 1 to 5 pixels (whole pairs and a pixel left over,
 * the AVX-512 lanes' two interleaved chains), each pixel's 16 rays are
 * camera_generate_ray(camera_sample_to_screen) of its own position and positions, to
 * the bit, in its own 16 slots; with each copy of the lanes this CPU runs. */
static void test_sample_rays_pixels_with(const char *isa)
{
    Camera cams[RAY_TEST_CAMERAS];
    ray_test_cameras(cams);
    const int (*sizes)[2] = ray_test_sizes;
    uint32_t st = 777;
    int differ = 0, checked = 0;
    for (int c = 0; c < RAY_TEST_CAMERAS; c++)
        for (int s = 0; s < 3; s++)
            for (int npx = 1; npx <= 5; npx++) {
                int W = sizes[s][0], H = sizes[s][1];
                float xy[5][32];
                const float *p[5];
                int x[5], y[5];
                for (int i = 0; i < npx; i++) {
                    ray_test_unit_floats(&st, xy[i], 32);
                    p[i] = xy[i];
                    x[i] = (npx * 29 + 7 * i + c) % W;
                    y[i] = (npx * 13 + 5 * i + s) % H;
                }
                Ray rays[5 * 16];
                camera_sample_rays_pixels(&cams[c], npx, x, y, p, W, H, rays);
                for (int i = 0; i < npx; i++)
                    for (int k = 0; k < 16; k++) {
                        float u, v;
                        camera_sample_to_screen(x[i], y[i], xy[i][2 * k], xy[i][2 * k + 1], W,
                                                H, &u, &v);
                        Ray r = camera_generate_ray(&cams[c], u, v);
                        checked++;
                        if (memcmp(&r, &rays[16 * i + k], sizeof r) != 0)
                            differ++;
                    }
            }
    if (differ)
        fprintf(stderr, "  camera_sample_rays_pixels, %s lanes: %d of %d rays differ\n", isa,
                differ, checked);
    CHECK_INT(differ, 0);
    CHECK_INT(checked, RAY_TEST_CAMERAS * 3 * 15 * 16);
}

static void test_sample_rays(void)
{
    const char *isas[] = {"base", "avx2", "avx512"};
    int ran = 0;
    for (int i = 0; i < 3; i++)
        if (camera_sample_rays_use_kernel(isas[i])) {
            test_sample_rays_with(isas[i]);
            test_sample_rays_put_with(isas[i]);
            test_sample_rays_pixels_with(isas[i]);
            ran++;
        }
    CHECK(ran >= 1);
    /* Back to the widest. */
    if (!camera_sample_rays_use_kernel("avx512"))
        camera_sample_rays_use_kernel("avx2");
}

static void test_lights(void)
{
    Light d = {LIGHT_DIRECTIONAL, v3(0, -1, 0), v3(0, 0, 0), v3(1, 1, 1), {1, 0, 0}};
    Vec3 l, c;
    float dist;
    light_illuminate(&d, v3(0, 0, 0), &l, &c, &dist);
    CHECK_NEAR(l.y, 1, 0);
    CHECK(isinf(dist));
    Light p = {LIGHT_POINT, v3(0, 0, 0), v3(0, 4, 0), v3(1, 1, 1), {0, 0, 0.25f}};
    light_illuminate(&p, v3(0, 0, 0), &l, &c, &dist);
    CHECK_NEAR(dist, 4, 0);
    CHECK_NEAR(c.x, 1.0 / 4.0, 1e-7); /* 1 / (0.25 * 16) */
    Light neg = p;
    neg.attenuation[0] = -10; /* negative factor clamps to 0 */
    light_illuminate(&neg, v3(0, 0, 0), &l, &c, &dist);
    CHECK_NEAR(c.x, 0, 0);
}

static void test_phong(void)
{
    Arena a;
    arena_init(&a);
    PhongParams pp = phong_defaults();
    pp.diffuse = v3(0.5f, 0.5f, 0.5f);
    pp.specular = v3(1, 1, 1);
    pp.exponent = 10;
    Material *m = phong_new(&a, &pp);
    Hit h = hit_none();
    h.normal = v3(0, 0, 1);
    Ray r = {v3(0, 0, 5), v3(0, 0, -1)};
    /* Light straight above: diffuse 1, half vector = n, specular 1. */
    Vec3 c = mat_shade(m, &r, &h, v3(0, 0, 1), v3(1, 1, 1));
    CHECK_NEAR(c.x, 1.5, 1e-6);
    /* Light below the surface: no diffuse and, by the course's step, no specular. */
    c = mat_shade(m, &r, &h, v3_normalize(v3(1, 0, -0.01f)), v3(1, 1, 1));
    CHECK_NEAR(c.x, 0, 0);
    PhongParams back;
    CHECK(phong_params(m, &back));
    CHECK_NEAR(back.exponent, 10, 0);
    CHECK(mat_preview(m) == m);
    arena_free(&a);
}

/* phong_term skips powf when the specular colour is zero: the result must be the bits
 * of the full formula (specular * powf(...)) for every input, including exponents and
 * normals outside the range where the skip applies (powf then runs: a NaN or an
 * infinity from it must come through as before). */
static Vec3 phong_reference(const PhongParams *p, Vec3 n, Vec3 v, Vec3 l, Vec3 lc)
{
    Vec3 h = v3_normalize(v3_add(l, v));
    float nl = v3_dot(n, l);
    float diffuse = nl > 0.0f ? nl : 0.0f;
    float specular = 0.0f;
    if (nl > 0.0f) {
        float nh = v3_dot(n, h);
        specular = powf(nh > 0.0f ? nh : 0.0f, p->exponent);
    }
    Vec3 c = v3_add(v3_scale(p->diffuse, diffuse), v3_scale(p->specular, specular));
    return v3_mul(lc, c);
}

static void test_phong_zero_specular(void)
{
    const float exps[] = {0, 1, 10, 100, 1000, 1001, 1e6f, -1, -0.5f};
    const Vec3 specs[] = {{0, 0, 0}, {-0.0f, 0, -0.0f}, {0.4f, 0.4f, 0.4f}, {0, 0, 1e-30f}};
    const Vec3 diffs[] = {{0.79f, 0.66f, 0.44f}, {-0.5f, 0, 2}};
    uint32_t seed = 12345;
    int checked = 0, bad = 0;
    for (int k = 0; k < 20000 && bad < 3; k++) {
        float r[10];
        for (int j = 0; j < 10; j++) {
            seed = seed * 1664525u + 1013904223u;
            r[j] = (float)(seed >> 8) / 8388608.0f - 1.0f; /* [-1, 1) */
        }
        /* Normals of length ~1 mostly, some longer (up to 2.4: beyond the skip's bound),
         * some zero; the light towards the normal's side half of the time. */
        float len = k % 7 == 0 ? 1.0f + 1.4f * (r[9] + 1.0f) / 2.0f : 1.0f;
        Vec3 n = k % 97 == 0 ? v3(0, 0, 0) : v3_scale(v3_normalize(v3(r[0], r[1], r[2])), len);
        Vec3 v = v3_normalize(v3(r[3], r[4], r[5]));
        Vec3 l = v3_normalize(v3(r[6], r[7], r[8]));
        if (k % 2 == 0 && v3_dot(n, l) < 0.0f)
            l = v3_neg(l);
        if (k % 5 == 0)
            v = v3_neg(l); /* l + v = 0: h is the zero vector */
        PhongParams p = phong_defaults();
        p.diffuse = diffs[k % 2];
        p.specular = specs[(k / 2) % 4];
        p.exponent = exps[(k / 8) % 9];
        Vec3 lc = v3(0.3f, 0.5f, 1.0f);
        Vec3 a = phong_term(&p, n, v, l, lc), b = phong_reference(&p, n, v, l, lc);
        checked++;
        if (memcmp(&a, &b, sizeof a) != 0) {
            bad++;
            CHECK_MSG(false, "phong_term differs from powf's formula at k=%d", k);
        }
    }
    CHECK_INT(bad, 0);
    CHECK(checked > 10000);
    /* A NaN from powf (0^-1 = inf, times 0) must survive: the skip is not taken. */
    PhongParams p = phong_defaults();
    p.specular = v3(0, 0, 0);
    p.exponent = -1;
    Vec3 c = phong_term(&p, v3(0, 0, 1), v3(0, 0, -1), v3(0.6f, 0, 0.8f), v3(1, 1, 1));
    CHECK(isnan(c.x));
}

/* A one-object scene in front of a perspective camera looking down -z. */
typedef struct Mini {
    Scene s;
    Light lights[2];
    Material *mats[4];
} Mini;

static void mini_init(Mini *m)
{
    memset(m, 0, sizeof *m);
    arena_init(&m->s.arena);
    m->s.has_camera = camera_init_perspective(&m->s.camera, v3(0, 0, 5), v3(0, 0, -1),
                                              v3(0, 1, 0), 0.5f);
    m->s.background = v3(0.5f, 0.5f, 0.5f);
    m->s.ambient = v3(0.1f, 0.1f, 0.1f);
    m->s.lights = m->lights;
    m->lights[0] = (Light){LIGHT_DIRECTIONAL, v3(0, 0, -1), v3(0, 0, 0), v3(1, 1, 1), {1, 0, 0}};
    m->s.num_lights = 1;
}

static void mini_set_root(Mini *m, Object3D *root)
{
    m->s.root = root;
    m->s.num_primitives = group_assign_ids(root);
    m->s.bounds = root->bbox;
}

/* The tracer of a finished scene, brute force ("none"); one per test (each test runs
 * in its own process), reachable until it exits. */
static PrimTable tracer_prims;
static Accel tracer_accel;

static RayTracer tracer(const Scene *s)
{
    RayTracer rt;
    memset(&rt, 0, sizeof rt);
    rt.scene = s;
    CHECK(prim_table_build(&tracer_prims, s));
    CHECK(accel_init(&tracer_accel, &accel_none_ops, &tracer_prims, NULL, NULL));
    rt.accel = &tracer_accel;
    return rt;
}

static void test_backface_rules(void)
{
    Mini m;
    mini_init(&m);
    PhongParams pp = phong_defaults();
    pp.diffuse = v3(1, 0, 0);
    Material *red = phong_new(&m.s.arena, &pp);
    /* Triangle facing away from the camera (clockwise seen from +z). */
    Object3D *t = triangle_new(&m.s.arena, v3(-1, -1, 0), v3(0, 1, 0), v3(1, -1, 0), red);
    mini_set_root(&m, t);
    RayTracer rt = tracer(&m.s);
    RenderCtx ctx = {0};
    Ray r = {v3(0, 0, 5), v3(0, 0, -1)};
    Hit h;
    Vec3 c = raytracer_trace(&rt, &ctx, &r, 0, 0, 1, 1, &h);
    CHECK_NEAR(c.x, 0, 0); /* black, not background, not ambient */
    CHECK_NEAR(h.normal.z, -1, 0);
    rt.shade_back = true;
    m.lights[0].direction = v3(0, 0, -1); /* light travels -z: lights the +z side */
    c = raytracer_trace(&rt, &ctx, &r, 0, 0, 1, 1, &h);
    CHECK_NEAR(c.x, 0.1 + 1.0, 1e-6); /* ambient + full diffuse with flipped normal */
    CHECK_INT(ctx.stats.nonshadow_rays, 2);
    arena_free(&m.s.arena);
}

static void test_shadows_and_counts(void)
{
    Mini m;
    mini_init(&m);
    PhongParams pp = phong_defaults();
    Material *white = phong_new(&m.s.arena, &pp);
    Object3D *g = group_new(&m.s.arena, 2);
    group_set_child(g, 0, plane_new(&m.s.arena, v3(0, 0, 1), -1, white)); /* z = -1 */
    group_set_child(g, 1, sphere_new(&m.s.arena, v3(0, 0, 1), 0.5f, white));
    group_finish(g);
    mini_set_root(&m, g);
    RayTracer rt = tracer(&m.s);
    rt.shadows = true;
    RenderCtx ctx = {0};
    /* A ray that misses the sphere and hits the plane at (0.8, 0, -1), in the shadow
     * of the sphere for a light travelling from the sphere's centre to that point. */
    m.lights[0].direction = v3_normalize(v3(0.8f, 0, -2));
    Ray r = {v3(0.8f, 0, 5), v3(0, 0, -1)};
    Vec3 c = raytracer_trace(&rt, &ctx, &r, 0, 0, 1, 1, NULL);
    CHECK_NEAR(c.x, 0.1, 1e-6); /* ambient only */
    CHECK_INT(ctx.stats.shadow_rays, 1);
    /* One primary + one shadow ray, each testing both primitives (no early exit in
     * the brute-force loop, like the course). */
    CHECK_INT(ctx.stats.intersections, 4);
    rt.shadows = false;
    c = raytracer_trace(&rt, &ctx, &r, 0, 0, 1, 1, NULL);
    CHECK_NEAR(c.x, 0.1 + 2.0 / sqrt(4.64), 1e-6);
    arena_free(&m.s.arena);
}

static void test_reflection_and_cutoff(void)
{
    Mini m;
    mini_init(&m);
    m.s.num_lights = 0;
    m.s.ambient = v3(1, 1, 1);
    m.s.background = v3(0.2f, 0.4f, 0.6f);
    PhongParams pp = phong_defaults();
    pp.diffuse = v3(0, 0, 0);
    pp.reflective = v3(0.5f, 0.5f, 0.5f);
    Material *mirror = phong_new(&m.s.arena, &pp);
    Object3D *p = plane_new(&m.s.arena, v3(0, 0, 1), 0, mirror);
    mini_set_root(&m, p);
    RayTracer rt = tracer(&m.s);
    RenderCtx ctx = {0};
    Ray r = {v3(0, 0, 5), v3(0, 0, -1)};
    Vec3 c = raytracer_trace(&rt, &ctx, &r, 0, 0, 1, 1, NULL);
    CHECK_NEAR(c.z, 0, 0); /* -bounces 0: no secondary rays */
    rt.bounces = 3;
    c = raytracer_trace(&rt, &ctx, &r, 0, 0, 1, 1, NULL);
    CHECK_NEAR(c.z, 0.3, 1e-6); /* 0.5 * background */
    /* weight 1 * |kr| = 0.866 < cutoff 0.9: not traced, and not counted. */
    RenderCtx c2 = {0};
    rt.weight = 0.9f;
    c = raytracer_trace(&rt, &c2, &r, 0, 0, 1, 1, NULL);
    CHECK_NEAR(c.z, 0, 0);
    CHECK_INT(c2.stats.nonshadow_rays, 1);
    arena_free(&m.s.arena);
}

static void test_refraction_and_tir(void)
{
    Mini m;
    mini_init(&m);
    m.s.num_lights = 0;
    m.s.ambient = v3(0, 0, 0);
    m.s.background = v3(1, 1, 1);
    PhongParams pp = phong_defaults();
    pp.diffuse = v3(0, 0, 0);
    pp.transparent = v3(1, 1, 1);
    pp.ior = 1.5f;
    Material *glass = phong_new(&m.s.arena, &pp);
    Object3D *s = sphere_new(&m.s.arena, v3(0, 0, 0), 1, glass);
    mini_set_root(&m, s);
    RayTracer rt = tracer(&m.s);
    rt.bounces = 5;
    rt.shade_back = true;
    RenderCtx ctx = {0};
    /* Through the centre: straight through two interfaces, out to the background. */
    Ray r = {v3(0, 0, 5), v3(0, 0, -1)};
    Vec3 c = raytracer_trace(&rt, &ctx, &r, 0, 0, 1, 1, NULL);
    CHECK_NEAR(c.x, 1, 1e-6);
    CHECK_INT(ctx.stats.nonshadow_rays, 3);
    /* From inside at a grazing angle: total internal reflection adds nothing. */
    RenderCtx c2 = {0};
    Ray in = {v3(0, 0.9f, 0), v3(1, 0, 0)};
    c = raytracer_trace(&rt, &c2, &in, 0, 1, 1, 1.5f, NULL);
    CHECK_NEAR(c.x, 0, 0);
    CHECK_INT(c2.stats.nonshadow_rays, 1);
    arena_free(&m.s.arena);
}

/* Packets shade procedural hits inline too (raytracer_trace_packet: Checkerboard lanes
 * as the Phong child they pick, Noise/Marble/Wood lanes of two PhongMaterials with
 * their weights a material's lanes at once); every colour must be the bits
 * raytracer_trace gives ray by ray through the ops, with every noise lane kernel this
 * CPU runs: Marble with a texture matrix, Noise (clamped weights at 0 and 1), Wood, a
 * blend with a specular child (powf: not the quick lanes), a blend with a mirror child
 * (shade_finish: through the ops when there are bounces), a checker of a checker, a
 * checker over a Marble and a Noise over a Marble (through the ops); shadows,
 * -shade_back, bounces and a point light (everything through the ops) vary. */
static void test_packet_procedural_same_bits(void)
{
    enum { NM = 16 };
    Mini m;
    mini_init(&m);
    Material *mats[NM];
    m.s.ambient = v3(0.3f, 0.2f, 0.25f);
    m.lights[0] = (Light){LIGHT_DIRECTIONAL, v3_normalize(v3(0.4f, -0.8f, -0.3f)), v3(0, 0, 0),
                          v3(0.6f, 0.5f, 0.4f), {1, 0, 0}};
    m.lights[1] = (Light){LIGHT_DIRECTIONAL, v3_normalize(v3(-0.3f, -1, -0.5f)), v3(0, 0, 0),
                          v3(0.5f, 0.5f, 0.5f), {1, 0, 0}};
    m.s.num_lights = 2;
    PhongParams a = phong_defaults(), b = phong_defaults(), shiny = phong_defaults(),
                mirror = phong_defaults();
    a.diffuse = v3(0.5f, 0.2f, 0.1f);
    b.diffuse = v3(1, 0.8f, 0.8f);
    b.specular = v3(0, -0.0f, 0); /* zero: the quick lanes, a -0 kept */
    shiny.diffuse = v3(0.2f, 0.6f, 0.9f);
    shiny.specular = v3(0.5f, 0.5f, 0.5f);
    shiny.exponent = 12;
    mirror.diffuse = v3(0.1f, 0.1f, 0.1f);
    mirror.reflective = v3(0.5f, 0.5f, 0.5f);
    mats[0] = phong_new(&m.s.arena, &a);
    mats[1] = phong_new(&m.s.arena, &b);
    mats[2] = phong_new(&m.s.arena, &shiny);
    mats[3] = phong_new(&m.s.arena, &mirror);
    Mat4 sc = mat4_scale(v3(2.5f, 2.5f, 2.5f)), ro = mat4_rotate_y(30);
    Mat4 xf = mat4_mul(&sc, &ro);
    mats[4] = marble_new(&m.s.arena, &xf, mats[0], mats[1], 5, 8, 4);
    mats[5] = noise_new(&m.s.arena, NULL, mats[1], mats[0], 4);
    Mat4 wxf = mat4_scale(v3(3, 3, 3));
    mats[6] = wood_new(&m.s.arena, &wxf, mats[0], mats[1], 3, 10, 2);
    mats[7] = marble_new(&m.s.arena, NULL, mats[2], mats[0], 3, 6, 3);  /* specular child */
    mats[8] = noise_new(&m.s.arena, &xf, mats[3], mats[1], 3);          /* mirror child */
    Mat4 cxf = mat4_scale(v3(4, 4, 4));
    mats[9] = checkerboard_new(&m.s.arena, &cxf, mats[0], mats[2]);
    mats[10] = checkerboard_new(&m.s.arena, NULL, mats[9], mats[1]);    /* nested */
    mats[11] = checkerboard_new(&m.s.arena, &cxf, mats[4], mats[1]);    /* over a Marble */
    mats[12] = noise_new(&m.s.arena, NULL, mats[4], mats[1], 2);        /* of a Marble */
    mats[13] = marble_new(&m.s.arena, &xf, mats[0], mats[1], 0, 8, 4);  /* no octaves */
    mats[14] = checkerboard_new(&m.s.arena, &cxf, mats[4], mats[6]);    /* no Phong pick */
    mats[15] = checkerboard_new(&m.s.arena, NULL, mats[14], mats[5]);   /* nor nested */
    /* Which checkers' lanes may be Phong lanes (the others go through the ops). */
    CHECK(mat_checker_reaches_phong(mats[9]) && mat_checker_reaches_phong(mats[10]) &&
          mat_checker_reaches_phong(mats[11]));
    CHECK(!mat_checker_reaches_phong(mats[14]) && !mat_checker_reaches_phong(mats[15]) &&
          !mat_checker_reaches_phong(mats[0]) && !mat_checker_reaches_phong(mats[4]));
    Object3D *g = group_new(&m.s.arena, 13);
    group_set_child(g, 0, plane_new(&m.s.arena, v3(0, 1, 0), -1, mats[5]));
    group_set_child(g, 1, sphere_new(&m.s.arena, v3(-0.6f, 0, 0), 0.45f, mats[4]));
    group_set_child(g, 2, sphere_new(&m.s.arena, v3(0.5f, 0.1f, -0.5f), 0.4f, mats[6]));
    group_set_child(g, 3, sphere_new(&m.s.arena, v3(0.1f, -0.6f, 0.6f), 0.3f, mats[7]));
    group_set_child(g, 4, sphere_new(&m.s.arena, v3(0.2f, 0.6f, 0.1f), 0.3f, mats[8]));
    group_set_child(g, 5, sphere_new(&m.s.arena, v3(-0.5f, 0.7f, -0.3f), 0.3f, mats[10]));
    group_set_child(g, 6, sphere_new(&m.s.arena, v3(0.8f, -0.4f, 0.2f), 0.25f, mats[11]));
    group_set_child(g, 7, sphere_new(&m.s.arena, v3(-0.9f, -0.6f, 0.3f), 0.25f, mats[12]));
    group_set_child(g, 8, sphere_new(&m.s.arena, v3(0.9f, 0.6f, -0.2f), 0.25f, mats[13]));
    /* Seen from behind: back faces of a blend and of a checker. */
    group_set_child(g, 9, triangle_new(&m.s.arena, v3(-1, 0.3f, 0.5f), v3(-0.4f, 1, 0.5f),
                                       v3(-0.5f, 0.2f, 0.5f), mats[4]));
    group_set_child(g, 10, triangle_new(&m.s.arena, v3(0.3f, -0.3f, 0.9f), v3(1, -0.2f, 0.9f),
                                        v3(0.6f, 0.4f, 0.9f), mats[9]));
    group_set_child(g, 11, sphere_new(&m.s.arena, v3(-0.1f, 0.25f, 0.4f), 0.2f, mats[14]));
    group_set_child(g, 12, sphere_new(&m.s.arena, v3(0.45f, -0.15f, 0.55f), 0.15f, mats[15]));
    group_finish(g);
    mini_set_root(&m, g);
    PrimTable prims;
    CHECK(prim_table_build(&prims, &m.s));
    Accel grid;
    AccelConfig cfg = {.grid_n = {6, 6, 6}, .grid_auto = false, .no_marking = false, .visualize = false};
    Diag d;
    diag_init(&d, NULL);
    CHECK(accel_init(&grid, accel_find("grid"), &prims, &cfg, &d));
    int differ = 0, kernels_run = 0, lanes = 0;
    const char *default_kernel = perlin_lanes_kernel();
    const char *kernels[] = {"scalar", "avx2", "avx512", "avx512vbmi"};
    /* ... and with each the quick blend lanes' copy of that width (raytracer.c). */
    const char *blends[] = {"base", "avx2", "avx512", "avx512"};
    int blends_run = 0;
    for (int kn = 0; kn < 4; kn++) {
        if (!perlin_use_lanes_kernel(kernels[kn]))
            continue;
        kernels_run++;
        blends_run += raytracer_blend_use_kernel(blends[kn]);
        for (int variant = 0; variant < 6; variant++) {
            RayTracer rt;
            memset(&rt, 0, sizeof rt);
            rt.scene = &m.s;
            rt.accel = &grid;
            rt.shadows = variant % 2 == 0;
            rt.shade_back = variant % 3 == 1;
            rt.bounces = variant >= 2 ? 2 : 0;
            rt.weight = 0.01f;
            /* The last two: a point light whose colour falls off with distance, with
             * and without shadows (each lane its own direction and colour). */
            m.lights[1].kind = variant >= 4 ? LIGHT_POINT : LIGHT_DIRECTIONAL;
            m.lights[1].position = v3(0.5f, 3, 2);
            m.lights[1].attenuation[1] = variant >= 4 ? 0.25f : 0.0f;
            m.lights[1].attenuation[2] = variant >= 4 ? 0.125f : 0.0f;
            m.lights[1].color = variant >= 4 ? v3(0.7f, 0.5f, 0.35f) : v3(0.5f, 0.5f, 0.5f);
            RenderCtx pctx, sctx;
            CHECK(raytracer_ctx_init(&pctx, &rt));
            CHECK(raytracer_ctx_init(&sctx, &rt));
            for (int ty = 0; ty < 64; ty += 8)
                for (int tx = 0; tx < 64; tx += 8) {
                    Ray rays[64];
                    Vec3 colors[64];
                    Hit hits[64];
                    for (int k = 0; k < 64; k++) {
                        float u, v;
                        camera_pixel_to_screen(tx + k % 8, ty + k / 8, 64, 64, &u, &v);
                        rays[k] = camera_generate_ray(&m.s.camera, u, v);
                    }
                    int n = (tx + ty) % 16 == 8 ? 29 : 64; /* partial packets too */
                    raytracer_trace_packet(&rt, &pctx, rays, n, 0, colors, hits);
                    for (int k = 0; k < n; k++) {
                        Hit h;
                        Vec3 c = raytracer_trace(&rt, &sctx, &rays[k], 0, 0, 1, 1, &h);
                        differ += memcmp(&c, &colors[k], sizeof c) != 0 ||
                                  memcmp(&h.t, &hits[k].t, sizeof h.t) != 0 ||
                                  h.material != hits[k].material;
                        lanes++;
                    }
                }
            CHECK_INT(pctx.stats.shadow_rays, sctx.stats.shadow_rays);
            raytracer_ctx_free(&pctx);
            raytracer_ctx_free(&sctx);
        }
    }
    m.lights[1].kind = LIGHT_DIRECTIONAL;
    CHECK(perlin_use_lanes_kernel(default_kernel));
    CHECK(blends_run >= 1);
    CHECK(raytracer_blend_use_kernel("avx512") || raytracer_blend_use_kernel("avx2") ||
          raytracer_blend_use_kernel("base"));
    CHECK_MSG(differ == 0, "%d of %d lanes differ from the single rays' bits", differ, lanes);
    CHECK(kernels_run >= 1);
    accel_free(&grid);
    prim_table_free(&prims);
    arena_free(&m.s.arena);
}

/* Packets shade their plain Phong hits inline (raytracer_trace_packet); every colour
 * and hit must be the bits raytracer_trace gives ray by ray through the materials' ops:
 * Phong with and without specular colour, a mirror and glass (bounces: their secondary
 * rays as packets), a checkerboard, back faces with and without -shade_back,
 * directional and point lights. */
static void test_packet_shading_same_bits(void)
{
    Mini m;
    mini_init(&m);
    m.s.ambient = v3(0.2f, 0.1f, 0.3f);
    m.lights[0] = (Light){LIGHT_DIRECTIONAL, v3_normalize(v3(0.4f, -0.8f, -0.3f)), v3(0, 0, 0),
                          v3(0.3f, 0.3f, 0.3f), {1, 0, 0}};
    m.lights[1] = (Light){LIGHT_DIRECTIONAL, v3_normalize(v3(-0.3f, -1, -0.5f)), v3(0, 0, 0),
                          v3(0.5f, 0.5f, 0.5f), {1, 0, 0}};
    m.s.num_lights = 2;
    PhongParams shiny = phong_defaults(), matte = phong_defaults(), mirror = phong_defaults();
    shiny.diffuse = v3(0.79f, 0.66f, 0.44f);
    shiny.specular = v3(0.4f, 0.4f, 0.4f);
    shiny.exponent = 10;
    matte.diffuse = v3(0.15f, 0.9f, 0.3f);
    matte.exponent = 100;
    mirror.diffuse = v3(0.1f, 0.1f, 0.1f);
    mirror.reflective = v3(0.6f, 0.6f, 0.6f);
    mirror.specular = v3(1, 1, 1);
    mirror.exponent = 20;
    m.mats[0] = phong_new(&m.s.arena, &shiny);
    m.mats[1] = phong_new(&m.s.arena, &matte);
    m.mats[2] = phong_new(&m.s.arena, &mirror);
    m.mats[3] = checkerboard_new(&m.s.arena, NULL, m.mats[0], m.mats[1]);
    /* Glass: refracted rays in and out (total internal reflection on the way out) and
     * reflected ones, traced as packets of secondary rays where they stay close. */
    PhongParams glass = phong_defaults();
    glass.diffuse = v3(0.05f, 0.08f, 0.05f);
    glass.specular = v3(0.5f, 0.5f, 0.5f);
    glass.exponent = 30;
    glass.reflective = v3(0.15f, 0.2f, 0.15f);
    glass.transparent = v3(0.8f, 0.75f, 0.8f);
    glass.ior = 1.5f;
    Material *glass_m = phong_new(&m.s.arena, &glass);
    Object3D *g = group_new(&m.s.arena, 8);
    group_set_child(g, 0, plane_new(&m.s.arena, v3(0, 1, 0), -1, m.mats[1]));
    group_set_child(g, 1, sphere_new(&m.s.arena, v3(-0.4f, 0, 0), 0.5f, m.mats[0]));
    group_set_child(g, 2, sphere_new(&m.s.arena, v3(0.5f, 0.1f, -0.5f), 0.4f, m.mats[2]));
    group_set_child(g, 3, sphere_new(&m.s.arena, v3(0.1f, -0.6f, 0.6f), 0.3f, m.mats[3]));
    /* Seen from behind (its normal points away from the camera): a back face. */
    group_set_child(g, 4, triangle_new(&m.s.arena, v3(-1, 0.3f, 0.5f), v3(-0.4f, 1, 0.5f),
                                       v3(-0.5f, 0.2f, 0.5f), m.mats[0]));
    group_set_child(g, 5, triangle_new(&m.s.arena, v3(0.3f, 0.3f, 0.2f), v3(1, 0.4f, 0.2f),
                                       v3(0.6f, 1, 0.2f), m.mats[2]));
    group_set_child(g, 6, sphere_new(&m.s.arena, v3(0.45f, -0.3f, 1.2f), 0.45f, glass_m));
    /* A glass slab (one triangle) in front of the mirror: coherent refracted rays. */
    group_set_child(g, 7, triangle_new(&m.s.arena, v3(-1.2f, -0.9f, 1.5f), v3(0.2f, -0.9f, 1.5f),
                                       v3(-1.2f, 0.2f, 1.7f), glass_m));
    group_finish(g);
    mini_set_root(&m, g);
    PrimTable prims;
    CHECK(prim_table_build(&prims, &m.s));
    Accel grid;
    AccelConfig cfg = {.grid_n = {6, 6, 6}, .grid_auto = false, .no_marking = false, .visualize = false};
    Diag d;
    diag_init(&d, NULL);
    CHECK(accel_init(&grid, accel_find("grid"), &prims, &cfg, &d));
    CHECK(accel_has_packets(&grid));
    int differ = 0, packets = 0, kernels_run = 0, puts_run = 0;
    /* Every Phong kernel this CPU runs (phong_packet.c's choice), the default last; each
     * with the lane-by-lane put of a tile of one material and with the widest eight-lane
     * put this CPU has (raytracer.c's phong_put_run8, chosen with the blend kernels). */
    const char *default_kernel = phong_packet_kernel();
    const char *kernels[] = {"generic", "sse2", "avx2", "avx512"};
    for (int kp = 0; kp <= 9; kp++) {
        int kn = kp / 2;
        if (kn < 4 && (!strcmp(kernels[kn], default_kernel) || !phong_packet_use_kernel(kernels[kn])))
            continue;
        if (kn == 4)
            CHECK(phong_packet_use_kernel(default_kernel));
        if (kp % 2 == 0) {
            CHECK(raytracer_blend_use_kernel("base"));
        } else {
            bool wide = raytracer_blend_use_kernel("avx512") || raytracer_blend_use_kernel("avx2");
            puts_run += wide;
            if (!wide)
                continue; /* no eight-lane put here: the base put ran already */
        }
        kernels_run++;
        for (int variant = 0; variant < 6; variant++) {
            RayTracer rt;
            memset(&rt, 0, sizeof rt);
            rt.scene = &m.s;
            rt.accel = &grid;
            rt.shadows = variant % 2 == 0;
            rt.shade_back = variant % 3 == 1;
            rt.bounces = variant >= 2 ? 3 : 0;
            rt.weight = 0.01f;
            /* The last two variants: a point light whose colour falls off with distance
             * (each lane its own direction and colour). */
            m.lights[1].kind = variant >= 4 ? LIGHT_POINT : LIGHT_DIRECTIONAL;
            m.lights[1].position = v3(0.5f, 3, 2);
            m.lights[1].attenuation[1] = variant >= 4 ? 0.25f : 0.0f;
            m.lights[1].attenuation[2] = variant >= 4 ? 0.125f : 0.0f;
            m.lights[1].color = variant >= 4 ? v3(0.7f, 0.5f, 0.35f) : v3(0.5f, 0.5f, 0.5f);
            RenderCtx pctx, sctx, bctx;
            CHECK(raytracer_ctx_init(&pctx, &rt));
            CHECK(raytracer_ctx_init(&bctx, &rt));
            CHECK(raytracer_ctx_init(&sctx, &rt));
            CHECK(pctx.packet_rays != NULL);
            for (int ty = 0; ty < 48; ty += 8)
                for (int tx = 0; tx < 48; tx += 8) {
                    Ray rays[64];
                    Vec3 colors[64];
                    Hit hits[64];
                    for (int k = 0; k < 64; k++) {
                        float u, v;
                        camera_pixel_to_screen(tx + k % 8, ty + k / 8, 48, 48, &u, &v);
                        rays[k] = camera_generate_ray(&m.s.camera, u, v);
                    }
                    raytracer_trace_packet(&rt, &pctx, rays, 64, 0, colors, hits);
                    packets++;
                    Vec3 bcolors[64];
                    Hit bhits[64];
                    raytracer_trace_packet_bytes(&rt, &bctx, rays, 64, 0, bcolors, bhits);
                    for (int k = 0; k < 64; k++) {
                        Hit h;
                        Vec3 c = raytracer_trace(&rt, &sctx, &rays[k], 0, 0, 1, 1, &h);
                        if (memcmp(&c, &colors[k], sizeof c) != 0 || memcmp(&h.t, &hits[k].t, sizeof h.t) ||
                            h.material != hits[k].material)
                            differ++;
                        /* The bytes variant: powf's bytes, the same hits. */
                        if (image_color_to_byte(c.x) != image_color_to_byte(bcolors[k].x) ||
                            image_color_to_byte(c.y) != image_color_to_byte(bcolors[k].y) ||
                            image_color_to_byte(c.z) != image_color_to_byte(bcolors[k].z) ||
                            memcmp(&h.t, &bhits[k].t, sizeof h.t) || h.material != bhits[k].material)
                            differ++;
                    }
                    /* A packet of a part of a tile (lanes past n in a kernel's group). */
                    raytracer_trace_packet(&rt, &pctx, rays + 3, 13, 0, colors, hits);
                    raytracer_trace_packet_bytes(&rt, &bctx, rays + 3, 13, 0, bcolors, bhits);
                    for (int k = 0; k < 13; k++) {
                        Hit h;
                        Vec3 c = raytracer_trace(&rt, &sctx, &rays[3 + k], 0, 0, 1, 1, &h);
                        if (memcmp(&c, &colors[k], sizeof c) != 0 || memcmp(&h.t, &hits[k].t, sizeof h.t) ||
                            h.material != hits[k].material)
                            differ++;
                        if (image_color_to_byte(c.x) != image_color_to_byte(bcolors[k].x) ||
                            image_color_to_byte(c.y) != image_color_to_byte(bcolors[k].y) ||
                            image_color_to_byte(c.z) != image_color_to_byte(bcolors[k].z))
                            differ++;
                    }
                }
            CHECK_INT(pctx.stats.nonshadow_rays, sctx.stats.nonshadow_rays);
            CHECK_INT(pctx.stats.shadow_rays, sctx.stats.shadow_rays);
            CHECK_INT(bctx.stats.nonshadow_rays, sctx.stats.nonshadow_rays);
            CHECK_INT(bctx.stats.shadow_rays, sctx.stats.shadow_rays);
            raytracer_ctx_free(&pctx);
            raytracer_ctx_free(&sctx);
            raytracer_ctx_free(&bctx);
        }
    }
    m.lights[1].kind = LIGHT_DIRECTIONAL;
    CHECK_INT(differ, 0);
    CHECK(kernels_run >= 2); /* SSE2 or plain C at least, and the default again */
    CHECK_INT(packets, kernels_run * 6 * 36);
    if (cpu_runs("avx2"))
        CHECK(puts_run >= 2); /* the eight-lane put ran with two Phong kernels at least */
    accel_free(&grid);
    prim_table_free(&prims);
    arena_free(&m.s.arena);
}

/* The assumption the power bracket rests on (src/render/phong_packet.h): the C
 * library's powf(x, e) lies in [lo, hi] as each kernel computes them, for every integer
 * exponent 0 .. PHONG_BRACKET_EXP_MAX and x in [0, 1.0625]: random x, and every float
 * of dense ranges near 1, near 0 (denormals), at 2^-20, and where x^e crosses into
 * float's denormals and underflows to 0. A libm whose powf strays further than the
 * bracket's margin fails here. */
static uint64_t bracket_rng(uint64_t *s)
{
    uint64_t z = (*s += 0x9e3779b97f4a7c15ull);
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

static float float_of_bits(uint32_t b)
{
    float f;
    memcpy(&f, &b, sizeof f);
    return f;
}

static uint32_t bits_of_float(float f)
{
    uint32_t b;
    memcpy(&b, &f, sizeof b);
    return b;
}

static void test_pow_bracket_holds_powf(void)
{
    enum { CHUNK = 4096, RANDOM = 256 * 1024 };
    static float xs[CHUNK], es[CHUNK], want[CHUNK], lo[3][CHUNK], hi[3][CHUNK];
    const char *default_kernel = phong_packet_kernel();
    const char *names[] = {"generic", "sse2", "avx2", "avx512"};
    int usable[4], nk = 0;
    for (int k = 0; k < 4; k++)
        if (phong_packet_use_kernel(names[k]))
            usable[nk++] = k;
    CHECK(phong_packet_use_kernel(default_kernel));
    CHECK(nk >= 1 && nk <= 3);
    uint64_t seed = 42, checked = 0, bad = 0;
    for (int e = 0; e <= PHONG_BRACKET_EXP_MAX; e++) {
        /* Starting bits of the dense runs: below 1 and from 1, from +0, at 2^-20,
         * where x^e is 2^-126 (float's smallest normal) and 2^-150 (rounds to 0). */
        uint32_t runs[6] = {bits_of_float(1.0f) - CHUNK / 2, bits_of_float(1.0f), 0,
                            bits_of_float(0x1p-20f), 0, 0};
        if (e > 0) {
            runs[4] = bits_of_float(exp2f(-126.0f / (float)e)) - CHUNK / 2;
            runs[5] = bits_of_float(exp2f(-150.0f / (float)e)) - CHUNK / 2;
        }
        for (int chunk = 0; chunk < 6 + RANDOM / CHUNK; chunk++) {
            for (int i = 0; i < CHUNK; i++) {
                float x;
                if (chunk < 6) {
                    x = float_of_bits(runs[chunk] + (uint32_t)i);
                } else {
                    x = (float)(bracket_rng(&seed) >> 40) * 0x1p-24f * 1.0625f;
                }
                if (!(x >= 0.0f && x <= 1.0625f))
                    x = 1.0625f;
                xs[i] = x;
                es[i] = (float)e;
                want[i] = powf(x, (float)e);
            }
            for (int k = 0; k < nk; k++) {
                CHECK(phong_packet_use_kernel(names[usable[k]]));
                phong_packet_bracket(xs, es, CHUNK, lo[k], hi[k]);
            }
            for (int i = 0; i < CHUNK; i++)
                for (int k = 0; k < nk; k++) {
                    checked++;
                    if (!(lo[k][i] >= 0.0f && lo[k][i] <= want[i] && want[i] <= hi[k][i] &&
                          isfinite(hi[k][i]))) {
                        if (bad++ < 5)
                            CHECK_MSG(false, "%s: powf(%a, %d) = %a outside [%a, %a]",
                                      names[usable[k]], (double)xs[i], e, (double)want[i],
                                      (double)lo[k][i], (double)hi[k][i]);
                    }
                }
        }
    }
    CHECK(phong_packet_use_kernel(default_kernel));
    CHECK_INT(bad, 0);
    CHECK(checked >= (uint64_t)nk * 129 * (6 * CHUNK + RANDOM));
}

/* The kernels with the bracket against themselves without it (which the test below
 * holds to the materials' ops): random hits under two lights, materials with integer
 * exponents (bracket) and others (a fraction, a negative specular channel, no
 * specular), a light with a negative channel. A lane phong_packet_settle leaves alone
 * must quantise to powf's bytes; a lane without the bracket must be powf's bits. */
static void test_packet_bracket_bytes(void)
{
    PhongParams mats[6];
    const float exps[6] = {10, 128, 1, 20.5f, 64, 0};
    for (int k = 0; k < 6; k++) {
        mats[k] = phong_defaults();
        mats[k].diffuse = v3(0.79f, 0.66f, 0.44f);
        mats[k].specular = v3(0.9f, 0.5f, 0.25f);
        mats[k].exponent = exps[k];
    }
    mats[4].specular.y = -0.5f;
    mats[5].specular = v3(0.0f, 2.0f, 0.0f);
    const Vec3 ldir[2] = {v3_normalize(v3(0.4f, 0.8f, 0.3f)), v3_normalize(v3(-0.3f, 1, 0.5f))};
    const Vec3 lcol[3] = {v3(0.3f, 0.3f, 0.3f), v3(0.5f, 0.6f, 0.7f), v3(0.5f, -0.1f, 0.5f)};
    const char *default_kernel = phong_packet_kernel();
    const char *names[] = {"generic", "sse2", "avx2", "avx512"};
    uint64_t seed = 7;
    long lanes = 0, bracketed = 0, settled = 0, bad = 0;
    for (int kn = 0; kn < 4; kn++) {
        if (!phong_packet_use_kernel(names[kn]))
            continue;
        for (int round = 0; round < 3000; round++) {
            PhongPacket ref, br;
            const PhongParams *lp[ACCEL_PACKET_MAX];
            for (int i = 0; i < ACCEL_PACKET_MAX; i++) {
                float r[6];
                for (int j = 0; j < 6; j++)
                    r[j] = (float)(bracket_rng(&seed) >> 40) * 0x1p-23f - 1.0f;
                /* Normals mostly of unit length, towards the lights (a bright lobe). */
                Vec3 n = v3_normalize(v3(r[0] * 0.3f, 1.0f, r[1] * 0.3f));
                if (i % 9 == 0)
                    n = v3_scale(n, 1.03f);
                Vec3 d = v3_normalize(v3(r[2] * 0.5f, -1.0f + r[3] * 0.2f, r[4] * 0.5f));
                ref.nx[i] = n.x, ref.ny[i] = n.y, ref.nz[i] = n.z;
                ref.vx[i] = d.x, ref.vy[i] = d.y, ref.vz[i] = d.z;
                lp[i] = &mats[(i + round) % 6];
                if (i % 17 == 5)
                    lp[i] = &mats[round % 6]; /* groups of one material and mixed */
            }
            ref.same = NULL; /* lp says each lane's material */
            br = ref;
            uint64_t ent;
            ref.brk = 0;
            br.brk = ~(uint64_t)0;
            uint64_t sh_ref = phong_packet_begin(&ref, ACCEL_PACKET_MAX, ~(uint64_t)0, lp, true,
                                                 v3(0.2f, 0.1f, 0.3f), &ent);
            uint64_t sh_br = phong_packet_begin(&br, ACCEL_PACKET_MAX, ~(uint64_t)0, lp, true,
                                                v3(0.2f, 0.1f, 0.3f), &ent);
            CHECK(sh_ref == sh_br);
            for (int li = 0; li < 2; li++) {
                Vec3 lc = lcol[(round + li) % 3];
                uint64_t mask = bracket_rng(&seed) | bracket_rng(&seed); /* some in shadow */
                phong_packet_light(&ref, ACCEL_PACKET_MAX, mask & sh_ref, ldir[li], lc);
                phong_packet_light(&br, ACCEL_PACKET_MAX, mask & sh_br, ldir[li], lc);
            }
            uint64_t open = phong_packet_settle(&br, ACCEL_PACKET_MAX, sh_br);
            CHECK((open & ~br.brk) == 0);
            for (int i = 0; i < ACCEL_PACKET_MAX; i++) {
                uint64_t bit = (uint64_t)1 << i;
                if (!(sh_br & bit))
                    continue;
                lanes++;
                bracketed += (br.brk & bit) != 0;
                settled += (open & bit) != 0;
                if (open & bit)
                    continue;
                const float a[3] = {br.cr[i], br.cg[i], br.cb[i]};
                const float b[3] = {ref.cr[i], ref.cg[i], ref.cb[i]};
                for (int c = 0; c < 3; c++) {
                    bool same = br.brk & bit ? image_color_to_byte(a[c]) == image_color_to_byte(b[c])
                                             : memcmp(&a[c], &b[c], sizeof a[c]) == 0;
                    if (!same && bad++ < 5)
                        CHECK_MSG(false, "%s: lane %d channel %d: %a against powf's %a",
                                  names[kn], i, c, (double)a[c], (double)b[c]);
                }
            }
        }
    }
    CHECK(phong_packet_use_kernel(default_kernel));
    CHECK_INT(bad, 0);
    /* The bracket was taken by most lanes, and left their bytes open for very few. */
    CHECK(bracketed > lanes / 3);
    CHECK(settled < bracketed / 100);
}

/* The fallback: a plane lit so that its bytes sit on a boundary inside the bracket
 * (the low power's byte is not powf's), found by search; the packet path must still
 * give powf's bytes, with every kernel. */
static void test_packet_bracket_fallback(void)
{
    Mini m;
    mini_init(&m);
    CHECK(camera_init_orthographic(&m.s.camera, v3(0, 0, 5), v3(0, 0, -1), v3(0, 1, 0), 2));
    m.s.ambient = v3(0, 0, 0);
    m.lights[0] = (Light){LIGHT_DIRECTIONAL, v3_normalize(v3(-0.3f, 0.2f, -1)), v3(0, 0, 0),
                          v3(1, 1, 1), {1, 0, 0}};
    m.s.num_lights = 1;
    /* x = n.h as the shading makes it (v = -normalize(d), h = normalize(l + v)). */
    Vec3 l, lc;
    float dist;
    light_illuminate(&m.lights[0], v3(0, 0, 0), &l, &lc, &dist);
    Vec3 n = v3(0, 0, 1), v = v3_neg(v3_normalize(v3(0, 0, -1)));
    float x = v3_dot(n, v3_normalize(v3_add(l, v)));
    CHECK(x > 0.9f && x < 1.0f);
    float xs[PHONG_PACKET_GROUP], es[PHONG_PACKET_GROUP], plo[PHONG_PACKET_GROUP],
        phi[PHONG_PACKET_GROUP];
    for (int i = 0; i < PHONG_PACKET_GROUP; i++)
        xs[i] = x, es[i] = 10;
    phong_packet_bracket(xs, es, PHONG_PACKET_GROUP, plo, phi);
    volatile float pw = powf(x, 10), lo = plo[0];
    /* The colour is 0 + 1 * (0 * n.l + s * p) = s * p: the specular colour s whose
     * byte with powf's power is 128 and with the low power 127. */
    float s = 128.0f / 255.0f / pw, found = 0;
    for (int j = 0; j < 4096 && !found; j++) {
        float c = s * pw, c_lo = s * lo;
        if (image_color_to_byte(c) == 128 && image_color_to_byte(c_lo) == 127)
            found = s;
        s = nextafterf(s, image_color_to_byte(c) >= 128 ? 0.0f : 2.0f);
    }
    CHECK(found > 0);
    PhongParams pp = phong_defaults();
    pp.diffuse = v3(0, 0, 0);
    pp.specular = v3(found, found, found);
    pp.exponent = 10;
    Material *mat = phong_new(&m.s.arena, &pp);
    /* A plane and a small sphere off to the side: the grid needs a bounded object. */
    Object3D *g = group_new(&m.s.arena, 2);
    group_set_child(g, 0, plane_new(&m.s.arena, v3(0, 0, 1), 0, mat));
    group_set_child(g, 1, sphere_new(&m.s.arena, v3(30, 30, 1), 0.5f, mat));
    group_finish(g);
    mini_set_root(&m, g);
    PrimTable prims;
    CHECK(prim_table_build(&prims, &m.s));
    Accel grid;
    AccelConfig cfg = {.grid_n = {4, 4, 4}, .grid_auto = false, .no_marking = false, .visualize = false};
    Diag d;
    diag_init(&d, NULL);
    CHECK(accel_init(&grid, accel_find("grid"), &prims, &cfg, &d));
    CHECK(accel_has_packets(&grid)); /* else the rays go one by one, with powf */
    RayTracer rt;
    memset(&rt, 0, sizeof rt);
    rt.scene = &m.s;
    rt.accel = &grid;
    const char *default_kernel = phong_packet_kernel();
    const char *names[] = {"generic", "sse2", "avx2", "avx512"};
    int kernels_run = 0, bad = 0;
    for (int kn = 0; kn < 4; kn++) {
        if (!phong_packet_use_kernel(names[kn]))
            continue;
        kernels_run++;
        RenderCtx ctx;
        CHECK(raytracer_ctx_init(&ctx, &rt));
        CHECK(ctx.packet_rays != NULL);
        Ray rays[64];
        Vec3 colors[64], ref[64];
        Hit hits[64];
        for (int k = 0; k < 64; k++) {
            float u, w;
            camera_pixel_to_screen(k % 8, k / 8, 8, 8, &u, &w);
            rays[k] = camera_generate_ray(&m.s.camera, u, w);
        }
        raytracer_trace_packet(&rt, &ctx, rays, 64, 0, ref, hits);
        raytracer_trace_packet_bytes(&rt, &ctx, rays, 64, 0, colors, hits);
        for (int k = 0; k < 64; k++) {
            const float *a = &colors[k].x, *b = &ref[k].x;
            for (int c = 0; c < 3; c++)
                if (image_color_to_byte(a[c]) != image_color_to_byte(b[c]) ||
                    image_color_to_byte(b[c]) != 128)
                    bad++;
        }
        raytracer_ctx_free(&ctx);
    }
    CHECK(phong_packet_use_kernel(default_kernel));
    CHECK(kernels_run >= 1);
    CHECK_INT(bad, 0);
    accel_free(&grid);
    prim_table_free(&prims);
    arena_free(&m.s.arena);
}

/* -depth and -normals (A1, A2): a tilted plane seen by an orthographic camera; the
 * left half of the image sees it, the right half sees nothing. */
static void test_depth_and_normals_images(void)
{
    Mini m;
    mini_init(&m);
    CHECK(camera_init_orthographic(&m.s.camera, v3(0, 0, 10), v3(0, 0, -1), v3(0, 1, 0), 4));
    PhongParams pp = phong_defaults();
    Material *white = phong_new(&m.s.arena, &pp);
    /* A big triangle covering the left half (x < 0), in the plane z = -x/2. */
    Object3D *t = triangle_new(&m.s.arena, v3(0, -10, 0), v3(0, 10, 0), v3(-10, 0, 5), white);
    mini_set_root(&m, t);
    RayTracer rt = tracer(&m.s);
    Image depth, normals;
    CHECK(image_init(&depth, 8, 8));
    CHECK(image_init(&normals, 8, 8));
    RenderTarget target = {8, 8, NULL, &depth, 9.0f, 11.0f, &normals, 0, 0, 0, 0, NULL,
                           NULL, false, NULL, NULL, NULL, false};
    CHECK(render_image(&rt, &m.s.camera, &target, 2, NULL, NULL, NULL, NULL));
    Vec3 n = v3_normalize(v3(0.5f, 0, 1)); /* the triangle's plane: z = -x/2 */
    for (int x = 0; x < 8; x++) {
        float u, v;
        camera_pixel_to_screen(x, 4, 8, 8, &u, &v);
        float wx = (u - 0.5f) * 4.0f; /* world x of the pixel's ray */
        Vec3 d = image_get(&depth, x, 4), nn = image_get(&normals, x, 4);
        if (wx < 0.0f) {
            float tt = 10.0f - (-0.5f * wx); /* ray from z = 10 down to z = -x/2 */
            float g = (11.0f - (tt < 9 ? 9 : tt > 11 ? 11 : tt)) / 2.0f;
            CHECK_NEAR(d.x, g, 1e-5);
            CHECK_NEAR(nn.x, fabsf(n.x), 1e-5);
            CHECK_NEAR(nn.z, fabsf(n.z), 1e-5);
        } else {
            CHECK_NEAR(d.x, 0, 0); /* background: black in both */
            CHECK_NEAR(nn.z, 0, 0);
        }
    }
    image_free(&depth);
    image_free(&normals);
    arena_free(&m.s.arena);
}

/* The stop flag (the preview's q, signals): raised as the first band finishes, the
 * render stops there, returns false, reports no further rows and leaves the other
 * rows untouched. */
static int g_rows_reported;
static volatile int g_stop;
static void stop_after_first_row(void *user, int y)
{
    (void)user;
    (void)y;
    g_rows_reported++;
    g_stop = 1;
}

static void test_render_cancel(void)
{
    Mini m;
    mini_init(&m);
    CHECK(camera_init_orthographic(&m.s.camera, v3(0, 0, 10), v3(0, 0, -1), v3(0, 1, 0), 4));
    PhongParams pp = phong_defaults();
    Material *white = phong_new(&m.s.arena, &pp);
    mini_set_root(&m, sphere_new(&m.s.arena, v3(0, 0, 0), 1.0f, white));
    RayTracer rt = tracer(&m.s);
    Image color;
    CHECK(image_init(&color, 64, 32));
    image_fill(&color, v3(-1, -1, -1)); /* "never written" */
    RenderTarget target = {64, 32, &color, NULL, 0, 1, NULL, 0, 0, 0, 0, NULL, NULL, false,
                           NULL, NULL, NULL, false};
    g_rows_reported = 0;
    g_stop = 0;
    CHECK(!render_image(&rt, &m.s.camera, &target, 1, NULL, stop_after_first_row, NULL,
                        &g_stop));
    CHECK_INT(g_rows_reported, 8); /* the band that raised the flag; none after it */
    int written = 0;
    for (int y = 0; y < 32; y++)
        for (int x = 0; x < 64; x++)
            written += image_get(&color, x, y).x >= 0.0f;
    CHECK_INT(written, 64 * 8); /* exactly the first band of 8 rows */
    /* Raised before the start: nothing at all. */
    image_fill(&color, v3(-1, -1, -1));
    CHECK(!render_image(&rt, &m.s.camera, &target, 2, NULL, NULL, NULL, &g_stop));
    CHECK(image_get(&color, 0, 0).x < 0.0f && image_get(&color, 63, 31).x < 0.0f);
    image_free(&color);
    arena_free(&m.s.arena);
}

/* The last bands of a render with several threads come in parts (render.c): every
 * pixel and counter is the one thread's, and each row of the rectangle is reported
 * exactly once, when all of its pixels are there (also with a rectangle off the tile
 * grid and a cut top band). */
typedef struct RowCheck {
    const Image *img;
    int x0, y0, w, h;
    atomic_int reported[64];
    atomic_int early; /* rows reported before all their pixels were written */
} RowCheck;

static void check_row(void *user, int y)
{
    RowCheck *rc = user;
    int r = y - rc->y0;
    if (r < 0 || r >= rc->h || r >= 64)
        return;
    atomic_fetch_add(&rc->reported[r], 1);
    for (int x = 0; x < rc->w; x++)
        if (image_get(rc->img, x, r).x < 0.0f)
            atomic_fetch_add(&rc->early, 1);
}

static void test_render_split_bands(void)
{
    Mini m;
    mini_init(&m);
    CHECK(camera_init_orthographic(&m.s.camera, v3(0, 0, 10), v3(0, 0, -1), v3(0, 1, 0), 4));
    PhongParams pp = phong_defaults();
    Material *white = phong_new(&m.s.arena, &pp);
    mini_set_root(&m, sphere_new(&m.s.arena, v3(0.3f, -0.2f, 0), 1.5f, white));
    RayTracer rt = tracer(&m.s);
    /* The whole 70 x 45 image (45 rows: a cut top band), then a rectangle of it. */
    const int rects[2][4] = {{0, 0, 70, 45}, {5, 3, 50, 30}};
    for (int c = 0; c < 2; c++) {
        int x0 = rects[c][0], y0 = rects[c][1], w = rects[c][2], h = rects[c][3];
        Image ref;
        CHECK(image_init(&ref, w, h));
        RtStats ref_st;
        for (int threads = 1; threads <= 4; threads++) {
            Image img;
            CHECK(image_init(&img, w, h));
            image_fill(&img, v3(-1, -1, -1)); /* "never written" */
            static RowCheck rc;
            memset(&rc, 0, sizeof rc);
            rc.img = &img;
            rc.x0 = x0;
            rc.y0 = y0;
            rc.w = w;
            rc.h = h;
            RenderTarget t = {70, 45, &img, NULL, 0, 1, NULL, x0, y0, w, h, NULL, NULL, false,
                              NULL, NULL, NULL, false};
            RtStats st;
            CHECK(render_image(&rt, &m.s.camera, &t, threads, &st, check_row, &rc, NULL));
            CHECK_INT(atomic_load(&rc.early), 0);
            for (int r = 0; r < h; r++)
                CHECK_MSG(atomic_load(&rc.reported[r]) == 1, "%d threads: row %d reported %d times",
                          threads, r, atomic_load(&rc.reported[r]));
            if (threads == 1) {
                memcpy(ref.pixels, img.pixels, (size_t)w * (size_t)h * sizeof *img.pixels);
                ref_st = st;
            } else {
                CHECK_MSG(memcmp(ref.pixels, img.pixels, (size_t)w * (size_t)h *
                                 sizeof *img.pixels) == 0, "%d threads: pixels differ", threads);
                CHECK(memcmp(&ref_st, &st, sizeof st) == 0);
            }
            image_free(&img);
        }
        image_free(&ref);
    }
    accel_free(&tracer_accel);
    prim_table_free(&tracer_prims);
    arena_free(&m.s.arena);
}

/* The file of RenderTarget.color_rows: the rows as they come, each once, before
 * row_done reports them. */
typedef struct StagedFile {
    uint8_t *file;
    int y0, w, h;
    atomic_int got[64];  /* deliveries per row of the rectangle */
    atomic_int bad;      /* rows out of range, or reported before they were delivered */
} StagedFile;

static void staged_rows(void *user, int y_lo, int y_hi, const uint8_t *rows)
{
    StagedFile *sf = user;
    int lo = y_lo - sf->y0, hi = y_hi - sf->y0;
    if (lo < 0 || hi >= sf->h || lo > hi || hi - lo >= 8) {
        atomic_fetch_add(&sf->bad, 1);
        return;
    }
    size_t row = 3 * (size_t)sf->w;
    memcpy(sf->file + (size_t)(sf->h - 1 - hi) * row, rows, (size_t)(hi - lo + 1) * row);
    for (int r = lo; r <= hi; r++)
        atomic_fetch_add(&sf->got[r], 1);
}

static void staged_row_done(void *user, int y)
{
    StagedFile *sf = user;
    int r = y - sf->y0;
    if (r >= 0 && r < sf->h && atomic_load(&sf->got[r]) != 1)
        atomic_fetch_add(&sf->bad, 1);
}

/* render_image's whole tiles of one Phong material as planes (raytracer_trace_tile_bytes,
 * stored by render.c's AVX2 store_tile_planes): the same bytes as with every tile's
 * colours as Vec3s (render_use_tile_planes(false)), into a byte image (R G B) and into a
 * file's rows (B G R and R G B), at 1 and 2 threads; a sphere in front of a plane, so
 * tiles of one material (planes) and tiles of two or of the background (Vec3s). */
static void test_render_tile_planes(void)
{
    if (!render_use_tile_planes(true)) {
        CHECK_MSG(!cpu_has_avx2(), "the plane store is off on a CPU with AVX2");
        return; /* no AVX2: every tile takes the Vec3s (the other tests) */
    }
    Mini m;
    mini_init(&m);
    m.lights[0] = (Light){LIGHT_DIRECTIONAL, v3_normalize(v3(0.4f, -0.8f, -0.3f)), v3(0, 0, 0),
                          v3(0.3f, 0.3f, 0.3f), {1, 0, 0}};
    m.lights[1] = (Light){LIGHT_DIRECTIONAL, v3_normalize(v3(-0.3f, -1, -0.5f)), v3(0, 0, 0),
                          v3(0.5f, 0.6f, 0.7f), {1, 0, 0}};
    m.s.num_lights = 2;
    PhongParams shiny = phong_defaults(), matte = phong_defaults();
    shiny.diffuse = v3(0.79f, 0.66f, 0.44f); /* three different bytes: a swap shows */
    shiny.specular = v3(0.4f, 0.5f, 0.6f);
    shiny.exponent = 10;
    matte.diffuse = v3(0.15f, 0.9f, 0.3f);
    Object3D *g = group_new(&m.s.arena, 2);
    group_set_child(g, 0, sphere_new(&m.s.arena, v3(0.2f, 0.1f, 0), 0.8f,
                                     phong_new(&m.s.arena, &shiny)));
    group_set_child(g, 1, plane_new(&m.s.arena, v3(0, 0, 1), -1, phong_new(&m.s.arena, &matte)));
    group_finish(g);
    mini_set_root(&m, g);
    PrimTable prims;
    CHECK(prim_table_build(&prims, &m.s));
    Accel grid;
    AccelConfig cfg = {.grid_n = {4, 4, 4}, .grid_auto = false, .no_marking = false, .visualize = false};
    Diag d;
    diag_init(&d, NULL);
    CHECK(accel_init(&grid, accel_find("grid"), &prims, &cfg, &d));
    RayTracer rt;
    memset(&rt, 0, sizeof rt);
    rt.scene = &m.s;
    rt.accel = &grid;
    rt.shadows = true;
    enum { W = 70, H = 45 }; /* cut tiles at the right and the top */
    size_t len = (size_t)W * H * 3;
    int differ = 0, lit = 0;
    for (int v = 0; v < 6; v++) {
        int threads = v & 1 ? 2 : 1, out = v / 2; /* 0: image, 1: file B G R, 2: file R G B */
        uint8_t *got[2];
        for (int on = 0; on < 2; on++) {
            CHECK(render_use_tile_planes(on) == (on == 1));
            Image img;
            CHECK(image_init_bytes(&img, W, H));
            uint8_t *file = malloc(len);
            CHECK(file != NULL);
            memset(file, 0xcd, len);
            RenderTarget t = {W, H, &img, NULL, 0, 1, NULL, 0, 0, W, H, NULL,
                              out ? file : NULL, out == 1, NULL, NULL, NULL, false};
            CHECK(render_image(&rt, &m.s.camera, &t, threads, NULL, NULL, NULL, NULL));
            if (!out)
                memcpy(file, img.bytes, len);
            got[on] = file;
            image_free(&img);
        }
        differ += memcmp(got[0], got[1], len) != 0;
        for (size_t i = 0; i < len; i += 3)
            lit += got[1][i] != got[1][i + 1] && got[1][i + 1] != got[1][i + 2];
        free(got[0]);
        free(got[1]);
    }
    CHECK(render_use_tile_planes(true));
    CHECK(lit > 6 * 500); /* the sphere and the plane are there, in colour */
    CHECK_INT(differ, 0);
    accel_free(&grid);
    prim_table_free(&prims);
    arena_free(&m.s.arena);
}

/* RenderTarget.color_file (the colour bytes straight into a file's rows, as main.c
 * does when the file is made during the render) and color_rows (band by band through
 * small buffers, as main.c does when that file is written while it is made): the same
 * bytes as the byte image, row y at file row h - 1 - y, R G B or B G R, for a whole
 * image with a cut top band and for a rectangle off the tile grid (whole tiles and cut
 * ones), with and without a depth image beside it (then every pixel goes through
 * store_pixel), at 1 and 3 threads (split bands); the byte image itself stays
 * untouched, and so does color_file with color_rows; each row comes once, before
 * row_done. */
static void test_render_color_into_file(void)
{
    Mini m;
    mini_init(&m);
    CHECK(camera_init_orthographic(&m.s.camera, v3(0, 0, 10), v3(0, 0, -1), v3(0, 1, 0), 4));
    PhongParams pp = phong_defaults();
    pp.diffuse = v3(0.9f, 0.4f, 0.1f); /* three different bytes: a swap shows */
    pp.specular = v3(0.3f, 0.5f, 0.7f);
    pp.exponent = 12.0f;
    Material *mat = phong_new(&m.s.arena, &pp);
    mini_set_root(&m, sphere_new(&m.s.arena, v3(0.3f, -0.2f, 0), 1.5f, mat));
    RayTracer rt = tracer(&m.s);
    const int rects[2][4] = {{0, 0, 70, 45}, {5, 3, 50, 30}};
    int compared = 0, differ = 0, touched = 0, lit = 0;
    for (int c = 0; c < 2; c++) {
        int x0 = rects[c][0], y0 = rects[c][1], w = rects[c][2], h = rects[c][3];
        size_t len = (size_t)w * (size_t)h * 3;
        Image ref, depth;
        CHECK(image_init_bytes(&ref, w, h));
        CHECK(image_init(&depth, w, h));
        RenderTarget rt_ref = {70, 45, &ref, NULL, 0, 1, NULL, x0, y0, w, h, NULL, NULL, false,
                               NULL, NULL, NULL, false};
        CHECK(render_image(&rt, &m.s.camera, &rt_ref, 1, NULL, NULL, NULL, NULL));
        for (size_t i = 0; i < len; i += 3)
            lit += ref.bytes[i] != ref.bytes[i + 2];
        for (int v = 0; v < 16; v++) {
            bool bgr = v & 1, with_depth = v & 2, staged = v & 8;
            int threads = v & 4 ? 3 : 1;
            Image img;
            CHECK(image_init_bytes(&img, w, h));
            memset(img.bytes, 0xab, len);
            uint8_t *file = malloc(len), *unused = malloc(len);
            CHECK(file != NULL && unused != NULL);
            memset(file, 0xcd, len);
            memset(unused, 0xcd, len);
            static StagedFile sf;
            memset(&sf, 0, sizeof sf);
            sf.file = file;
            sf.y0 = y0;
            sf.w = w;
            sf.h = h;
            RenderTarget t = {70, 45, &img, with_depth ? &depth : NULL, 0, 1, NULL,
                              x0, y0, w, h, NULL, staged ? unused : file, bgr,
                              staged ? staged_rows : NULL, NULL, NULL, false};
            CHECK(render_image(&rt, &m.s.camera, &t, threads, NULL,
                               staged ? staged_row_done : NULL, &sf, NULL));
            if (staged) {
                CHECK_INT(atomic_load(&sf.bad), 0);
                for (int r = 0; r < h; r++)
                    differ += atomic_load(&sf.got[r]) != 1;
                for (size_t i = 0; i < len; i++)
                    touched += unused[i] != 0xcd;
            }
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++) {
                    const uint8_t *a = ref.bytes + 3 * ((size_t)y * (size_t)w + (size_t)x);
                    const uint8_t *b = file + 3 * ((size_t)(h - 1 - y) * (size_t)w + (size_t)x);
                    compared++;
                    differ += bgr ? a[0] != b[2] || a[1] != b[1] || a[2] != b[0]
                                  : memcmp(a, b, 3) != 0;
                }
            for (size_t i = 0; i < len; i++)
                touched += img.bytes[i] != 0xab;
            free(unused);
            free(file);
            image_free(&img);
        }
        image_free(&depth);
        image_free(&ref);
    }
    CHECK(lit > 100); /* the sphere is there, in colour */
    CHECK_INT(compared, 16 * (70 * 45 + 50 * 30));
    CHECK_INT(differ, 0);
    CHECK_INT(touched, 0);
    accel_free(&tracer_accel);
    prim_table_free(&tracer_prims);
    arena_free(&m.s.arena);
}

static const TestCase tests[] = {
    {"render: the last bands in parts: same pixels, each row once, complete", test_render_split_bands},
    {"render: colour bytes straight into a file's rows, or band by band",
     test_render_color_into_file},
    {"render: whole tiles of one Phong material as planes, the same bytes",
     test_render_tile_planes},
    {"render: stops at the cancel flag", test_render_cancel},
    {"render: -depth and -normals images", test_depth_and_normals_images},
    {"shading: pixel centres and cropping", test_pixel_mapping},
    {"shading: camera bases and rays", test_cameras},
    {"shading: a far perspective eye aims as precisely as a near one", test_far_eye_rays},
    {"shading: the depth grey of a range wider than the largest float", test_depth_color_huge_range},
    {"shading: the depth grey with dmin above dmax is a reversed gradient",
     test_depth_color_reversed_range},
    {"shading: a block of pixel rays, to the bit", test_pixel_rays_block},
    {"shading: an 8 x 8 block of pixel rays in lane order, to the bit", test_block8_rays},
    {"shading: a pixel's sample rays, to the bit", test_sample_rays},
    {"shading: lights and attenuation", test_lights},
    {"shading: Phong with the n.L step", test_phong},
    {"shading: Phong without specular colour skips powf, same bits", test_phong_zero_specular},
    {"tracer: back faces black / -shade_back", test_backface_rules},
    {"tracer: shadows and counters", test_shadows_and_counts},
    {"tracer: reflection, bounces, weight cutoff", test_reflection_and_cutoff},
    {"tracer: refraction and total internal reflection", test_refraction_and_tir},
    {"tracer: packets shade like single rays, to the bit", test_packet_shading_same_bits},
    {"tracer: procedural packet lanes shade like single rays, to the bit",
     test_packet_procedural_same_bits},
    {"shading: powf lies in the power bracket of every kernel", test_pow_bracket_holds_powf},
    {"shading: the bracket's settled lanes have powf's bytes", test_packet_bracket_bytes},
    {"tracer: lanes the bracket leaves open get powf's bytes", test_packet_bracket_fallback},
};
RT_TEST_MAIN(tests)
