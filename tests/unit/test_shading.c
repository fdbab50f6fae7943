/* Unit tests: cameras and pixel mapping, lights, Phong, and the tracer's rules
 * (back faces, shadows, reflection, refraction, TIR, cutoff, counters). */
#include "harness.h"
#include "rt/arena.h"
#include "rt/geom.h"
#include "rt/raytracer.h"
#include "rt/render.h"

#include <float.h>
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
    RenderTarget target = {8, 8, NULL, &depth, 9.0f, 11.0f, &normals, 0, 0, 0, 0, NULL};
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
    RenderTarget target = {64, 32, &color, NULL, 0, 1, NULL, 0, 0, 0, 0, NULL};
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

static const TestCase tests[] = {
    {"render: stops at the cancel flag", test_render_cancel},
    {"render: -depth and -normals images", test_depth_and_normals_images},
    {"shading: pixel centres and cropping", test_pixel_mapping},
    {"shading: camera bases and rays", test_cameras},
    {"shading: lights and attenuation", test_lights},
    {"shading: Phong with the n.L step", test_phong},
    {"tracer: back faces black / -shade_back", test_backface_rules},
    {"tracer: shadows and counters", test_shadows_and_counts},
    {"tracer: reflection, bounces, weight cutoff", test_reflection_and_cutoff},
    {"tracer: refraction and total internal reflection", test_refraction_and_tir},
};
RT_TEST_MAIN(tests)
