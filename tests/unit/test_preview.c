/* The OpenGL preview: key-script parsing and camera controls (no GL needed), then
 * OSMesa snapshots through the binary compared with the ray-traced image of the same
 * view (background in the corners, colour at projected centres, silhouettes, ray tree).
 * The snapshot tests are skipped when the binary was built without OSMesa. */
#include "../harness.h"
#include "../e2e/e2e_util.h"

#include "../../src/preview/view.h"
#include "rt/image.h"
#include "rt/preview.h"
#include "rt/raytracer.h"
#include "rt/scene.h"

/* ---- key scripts ---- */

static void test_keys_parse_all_commands(void)
{
    Diag d;
    diag_init(&d, NULL);
    KeyScript s;
    /* "shot:/x/y" ends at the blank; "z.tga" is then a bad command. */
    CHECK(!preview_keys_parse("  r T t:10,20 g c rot:1.5,-2 truck:3,4\tdolly:-5 "
                              "shot:/x/y z.tga q ", &s, &d));
    CHECK_CONTAINS(d.last, "'z.tga'");
    CHECK(preview_keys_parse("r T t:10,20 g c rot:1.5,-2 truck:3,4 dolly:-5 shot:/x/y.tga Q",
                             &s, &d));
    CHECK_INT(s.count, 10);
    if (s.count == 10) {
        CHECK_INT(s.cmds[0].kind, KEYCMD_RENDER);
        CHECK_INT(s.cmds[1].kind, KEYCMD_TRACE);
        CHECK(!s.cmds[1].has_pixel);
        CHECK_INT(s.cmds[2].kind, KEYCMD_TRACE);
        CHECK(s.cmds[2].has_pixel);
        CHECK_INT(s.cmds[2].i, 10);
        CHECK_INT(s.cmds[2].j, 20);
        CHECK_INT(s.cmds[3].kind, KEYCMD_GRID);
        CHECK_INT(s.cmds[4].kind, KEYCMD_CAMERA);
        CHECK_INT(s.cmds[5].kind, KEYCMD_ROTATE);
        CHECK_NEAR(s.cmds[5].a, 1.5, 0);
        CHECK_NEAR(s.cmds[5].b, -2.0, 0);
        CHECK_INT(s.cmds[6].kind, KEYCMD_TRUCK);
        CHECK_NEAR(s.cmds[6].b, 4.0, 0);
        CHECK_INT(s.cmds[7].kind, KEYCMD_DOLLY);
        CHECK_NEAR(s.cmds[7].a, -5.0, 0);
        CHECK_INT(s.cmds[8].kind, KEYCMD_SHOT);
        CHECK_STR(s.cmds[8].path, "/x/y.tga");
        CHECK_INT(s.cmds[9].kind, KEYCMD_QUIT);
    }
    preview_keys_free(&s);
    CHECK(preview_keys_parse(NULL, &s, &d));
    CHECK_INT(s.count, 0);
    CHECK(preview_keys_parse("   ", &s, &d));
    CHECK_INT(s.count, 0);
    CHECK_INT(d.errors, 1); /* only the "z.tga" word of the first script */
}

static void test_keys_parse_rejects_bad_words(void)
{
    const char *bad[] = {"x", "t:1", "t:1,", "t:-1,2", "t:1,2,3", "rot:1", "rot:a,b",
                         "rot:1,2x", "dolly:1,2", "dolly:", "shot:", "truck:1,nan",
                         "r rr", "rot:1e99999,0", "qq", "dolly:1e300", "truck:0,-3.5e38"};
    for (int k = 0; k < TEST_LIST_COUNT(bad); k++) {
        Diag d;
        diag_init(&d, NULL);
        KeyScript s;
        bool ok = preview_keys_parse(bad[k], &s, &d);
        CHECK_MSG(!ok, "script \"%s\" was accepted", bad[k]);
        if (ok)
            preview_keys_free(&s);
        CHECK_INT(d.errors, 1);
        CHECK_CONTAINS(d.last, "-gui_keys");
    }
}

/* t:I,J must name a pixel of the image: the last column and row are the bounds. */
static void test_keys_check_pixel_in_image(void)
{
    static const struct {
        const char *script;
        bool ok;
    } cases[] = {{"t:19,9", true}, {"t t:0,0 r", true}, {"t:20,9", false},
                 {"r t:19,10", false}, {"t:500,500", false}, {"rot:500,500", true}};
    for (int k = 0; k < TEST_LIST_COUNT(cases); k++) {
        Diag d;
        diag_init(&d, NULL);
        KeyScript s;
        CHECK(preview_keys_parse(cases[k].script, &s, &d));
        bool ok = preview_keys_check(&s, 20, 10, "image", &d);
        CHECK_MSG(ok == cases[k].ok, "script \"%s\" on 20x10: %s", cases[k].script,
                  ok ? "accepted" : "refused");
        CHECK_INT(d.errors, cases[k].ok ? 0 : 1);
        if (!cases[k].ok)
            CHECK_CONTAINS(d.last, "is outside the 20x10 image");
        preview_keys_free(&s);
    }
}

/* ---- camera controls and the ray tree, on a parsed scene ---- */

static const char *ORTHO_SPHERE =
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 6 }\n"
    "Lights { numLights 1 DirectionalLight { direction -1 0 0 color 1 1 1 } }\n"
    "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }\n"
    "Materials { numMaterials 1 PhongMaterial { diffuseColor 0.8 0.2 0.2 } }\n"
    "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1.5 } }\n";

typedef struct Fixture {
    Scene *scene;
    PrimTable prims;
    Accel accel;
    RayTracer rt;
    PreviewConfig cfg;
    PreviewView view;
} Fixture;

static bool fixture_init(Fixture *f, const char *text)
{
    memset(f, 0, sizeof *f);
    Diag d;
    diag_init(&d, stderr);
    f->scene = scene_load_string(text, "fixture.txt", NULL, &d);
    if (!f->scene)
        return false;
    if (!prim_table_build(&f->prims, f->scene) ||
        !accel_init(&f->accel, &accel_none_ops, &f->prims, NULL, &d))
        return false;
    f->rt.scene = f->scene;
    f->rt.accel = &f->accel;
    f->rt.shadows = true;
    f->cfg.scene = f->scene;
    f->cfg.tracer = &f->rt;
    f->cfg.width = f->cfg.height = 200;
    return preview_view_init(&f->view, &f->cfg, &d);
}

static void fixture_free(Fixture *f)
{
    preview_view_free(&f->view);
    accel_free(&f->accel);
    prim_table_free(&f->prims);
    scene_free(f->scene);
}

static void test_rotate_keeps_distance_and_aim(void)
{
    Fixture f;
    CHECK(fixture_init(&f, ORTHO_SPHERE));
    if (!f.scene)
        return;
    /* 0.005 rad per pixel: 314.159 pixels are a quarter turn about world up. */
    preview_view_rotate(&f.view, 314.159265f, 0.0f);
    const Camera *c = &f.view.camera;
    CHECK_NEAR(v3_length(c->center), 10.0, 1e-3);
    CHECK_NEAR(fabsf(c->direction.x), 1.0, 1e-4);
    CHECK_NEAR(c->direction.z, 0.0, 1e-4);
    /* Still looking at the pivot (the sphere's centre). */
    CHECK_NEAR(v3_dot(v3_normalize(v3_neg(c->center)), c->direction), 1.0, 1e-4);
    CHECK_NEAR(v3_dot(c->up, c->direction), 0.0, 1e-5);
    CHECK_NEAR(v3_length(c->horizontal), 1.0, 1e-5);
    /* A huge tilt stops short of the pole. */
    preview_view_rotate(&f.view, 0.0f, -100000.0f);
    float cos_tilt = v3_dot(f.view.world_up, f.view.camera.direction);
    CHECK(fabsf(cos_tilt) <= cosf(0.0099f));
    CHECK(fabsf(cos_tilt) > cosf(0.02f));
    CHECK_NEAR(v3_length(f.view.camera.center), 10.0, 1e-3);
    fixture_free(&f);
}

static void test_truck_and_dolly_units(void)
{
    Fixture f;
    CHECK(fixture_init(&f, ORTHO_SPHERE));
    if (!f.scene)
        return;
    preview_view_dolly(&f.view, 20.0f); /* 0.05 per pixel along the view */
    CHECK_NEAR(f.view.camera.center.z, 9.0, 1e-5);
    preview_view_truck(&f.view, 10.0f, 20.0f); /* the scene follows the mouse */
    CHECK_NEAR(f.view.camera.center.x, -0.5, 1e-5);
    CHECK_NEAR(f.view.camera.center.y, 1.0, 1e-5);
    fixture_free(&f);
}

/* A perspective camera straight down -z: its basis is exact, so a moved camera can be
 * compared with one made afresh at the moved centre to the bit. */
static const char *PERSP_SPHERES =
    "PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }\n"
    "Lights { numLights 1 DirectionalLight { direction -1 -1 -1 color 1 1 1 } }\n"
    "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }\n"
    "Materials { numMaterials 2 PhongMaterial { diffuseColor 0.8 0.2 0.2 }\n"
    "    PhongMaterial { diffuseColor 0.2 0.8 0.2 } }\n"
    "Group { numObjects 2 MaterialIndex 0 Sphere { center 0 0 0 radius 1.5 }\n"
    "    MaterialIndex 1 Sphere { center 2 1 -1 radius 0.7 } }\n";

static bool v3_same(Vec3 a, Vec3 b)
{
    return a.x == b.x && a.y == b.y && a.z == b.z;
}

/* truck and dolly move the perspective screen with the eye: before, only the centre
 * moved, and every ray of r and t aimed from the new eye at the old screen (after
 * dolly 20 the eye lay in the old screen's plane and the centre ray ran sideways). */
static void test_truck_and_dolly_move_the_screen(void)
{
    Fixture f;
    CHECK(fixture_init(&f, PERSP_SPHERES));
    if (!f.scene)
        return;
    preview_view_dolly(&f.view, 20.0f);
    preview_view_truck(&f.view, 20.0f, -10.0f);
    const Camera *c = &f.view.camera;
    Camera want;
    CHECK(camera_init_perspective(&want, v3(-1.0f, -0.5f, 9.0f), v3(0, 0, -1), v3(0, 1, 0),
                                  f.scene->camera.angle));
    CHECK(v3_same(c->center, want.center));
    CHECK_MSG(v3_same(c->lower_left, want.lower_left),
              "screen corner %g %g %g, wanted %g %g %g", (double)c->lower_left.x,
              (double)c->lower_left.y, (double)c->lower_left.z, (double)want.lower_left.x,
              (double)want.lower_left.y, (double)want.lower_left.z);
    Ray r = camera_generate_ray(c, 0.5f, 0.5f);
    CHECK_MSG(v3_same(r.dir, v3(0, 0, -1)), "centre ray %g %g %g", (double)r.dir.x,
              (double)r.dir.y, (double)r.dir.z);
    /* A move out of float range leaves the camera where it was (finite), as a rotation
     * that would make the basis degenerate does. */
    Camera before = f.view.camera;
    for (int k = 0; k < 40; k++)
        preview_view_dolly(&f.view, 3.0e38f);
    CHECK(v3_isfinite(f.view.camera.center) && v3_isfinite(f.view.camera.lower_left));
    CHECK(f.view.camera.center.z < before.center.z);
    fixture_free(&f);
}

static void test_trace_records_main_and_shadow(void)
{
    Fixture f;
    CHECK(fixture_init(&f, ORTHO_SPHERE));
    if (!f.scene)
        return;
    CHECK(preview_view_trace(&f.view, 100, 100, 200, 200));
    CHECK(f.view.has_tree);
    const RayTree *t = f.view.tree;
    CHECK(t->num_segments >= 2);
    if (t->num_segments >= 2) {
        CHECK_INT(t->segments[0].kind, RAYSEG_MAIN);
        /* Main ray from the image plane (z = 10) to the front of the sphere. */
        CHECK_NEAR(t->segments[0].a.z, 10.0, 1e-3);
        CHECK_NEAR(t->segments[0].b.z, 1.5, 1e-2);
        CHECK_INT(t->segments[1].kind, RAYSEG_SHADOW);
        CHECK(t->segments[1].b.x > t->segments[1].a.x); /* toward the light at +x */
    }
    /* No grid: `g` keeps the object view. */
    preview_view_cycle_grid(&f.view, NULL);
    CHECK_INT(f.view.mode, PREVIEW_OBJECTS);
    fixture_free(&f);
}

/* Inside three nested glass spheres (tests/repro/deep_ray_tree.txt) with -bounces 60
 * -weight 0 the centre pixel's tree has some 10^15 rays: `t` must stop at the
 * recording's limit instead of tracing them all (it hung the preview). The alarm is
 * only a guard against that hang. */
static const char *DEEP_TREE =
    "PerspectiveCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 angle 30 }\n"
    "Lights { numLights 1 PointLight { position 0 0 0 color 1 1 1 } }\n"
    "Materials { numMaterials 1 PhongMaterial { diffuseColor 0.1 0.1 0.1\n"
    "  reflectiveColor 0.5 0.5 0.5 transparentColor 0.5 0.5 0.5 indexOfRefraction 1 } }\n"
    "Group { numObjects 3 MaterialIndex 0 Sphere { center 0 0 0 radius 1 }\n"
    "  Sphere { center 0 0 0 radius 2 } Sphere { center 0 0 0 radius 3 } }\n";

static void test_trace_deep_tree_is_cut(void)
{
    Fixture f;
    CHECK(fixture_init(&f, DEEP_TREE));
    if (!f.scene)
        return;
    f.rt.bounces = 60;
    f.rt.weight = 0.0f;
    f.rt.shade_back = true;
    alarm(120);
    CHECK(preview_view_trace(&f.view, 100, 100, 200, 200));
    alarm(0);
    CHECK(ray_tree_full(f.view.tree));
    CHECK_INT(f.view.tree->num_segments, RT_RAYTREE_MAX_SEGMENTS);
    fixture_free(&f);
}

/* ---- snapshots through the binary ---- */

static void need_snapshot(void)
{
    if (!preview_snapshot_built())
        harness_skip("built without OSMesa (apt-get install libosmesa6-dev, rebuild)");
}

static const char *course_file(char *buf, size_t size, const char *name)
{
    const char *dir = harness_course_dir();
    if (!dir)
        harness_skip("course folder absent (set RT_COURSE)");
    return e2e_join(buf, size, dir, name);
}

/* Runs the binary with args; checks exit 0. */
static bool run_ok(const char *const *args)
{
    E2eRun r;
    char why[512];
    if (!e2e_run_bin(harness_bin(), args, &r)) {
        CHECK_MSG(false, "cannot run %s", harness_bin());
        return false;
    }
    bool ok = r.status == 0;
    CHECK_MSG(ok, "%s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    return ok;
}

static bool load(Image *img, const char *path)
{
    Diag d;
    diag_init(&d, stderr);
    return image_read(img, path, &d);
}

static float max_diff(Vec3 a, Vec3 b)
{
    return fmaxf(fabsf(a.x - b.x), fmaxf(fabsf(a.y - b.y), fabsf(a.z - b.z)));
}

/* Pixel of world point p in a w x h view (inverse of camera_pixel_to_screen). */
static void project(const Camera *c, Vec3 p, int w, int h, int *i, int *j)
{
    Vec3 q = v3_sub(p, c->center);
    float x, y;
    if (c->kind == CAMERA_ORTHOGRAPHIC) {
        x = v3_dot(q, c->horizontal) / c->size;
        y = v3_dot(q, c->up) / c->size;
    } else {
        float z = v3_dot(q, c->direction), t = tanf(0.5f * c->angle);
        x = v3_dot(q, c->horizontal) / z / (2.0f * t);
        y = v3_dot(q, c->up) / z / (2.0f * t);
    }
    float s = (float)(w > h ? w : h);
    *i = (int)floorf(x * s + 0.5f * (float)w);
    *j = (int)floorf(y * s + 0.5f * (float)h);
}

typedef struct Expect {
    Vec3 point;          /* world point whose pixel is checked */
    bool bounds_centre;  /* use the centre of the scene's bounding box instead */
    bool has_color;
    Vec3 color;          /* expected preview colour there (else: the ray-traced one) */
    float tol;
} Expect;

/* Snapshot and ray trace of scene (with extra preview args), then the checks. */
static void compare_views(const char *scene_path, const char *const *pv_args, int npv,
                          const Expect *ex, int nex, int ncorners)
{
    char dir[PATH_MAX], snap[PATH_MAX], ray[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "preview") != NULL);
    e2e_join(snap, sizeof snap, dir, "snap.tga");
    e2e_join(ray, sizeof ray, dir, "ray.tga");
    const char *a1[32] = {"-input", scene_path, "-size", "200", "200", "-gui_snapshot", snap};
    int n = 7;
    for (int k = 0; k < npv && n < 31; k++)
        a1[n++] = pv_args[k];
    a1[n] = NULL;
    const char *a2[] = {"-input", scene_path, "-size", "200", "200", "-output", ray, NULL};
    Image s = {0}, r = {0};
    Diag d;
    diag_init(&d, stderr);
    Scene *scene = scene_load(scene_path, &d);
    if (run_ok(a1) && run_ok(a2) && load(&s, snap) && load(&r, ray) && scene) {
        CHECK_INT(s.width, 200);
        CHECK_INT(s.height, 200);
        Vec3 bg = scene->background;
        /* The background colour in the corners (top ones first: a floor may fill the
         * bottom ones). */
        int cx[4] = {0, 199, 0, 199}, cy[4] = {199, 199, 0, 0};
        for (int k = 0; k < ncorners; k++) {
            Vec3 p = image_get(&s, cx[k], cy[k]);
            CHECK_MSG(max_diff(p, bg) < 0.01f, "corner (%d,%d) = %.3f %.3f %.3f, background "
                      "%.3f %.3f %.3f", cx[k], cy[k], (double)p.x, (double)p.y, (double)p.z,
                      (double)bg.x, (double)bg.y, (double)bg.z);
        }
        /* The object's colour at its projected centre. */
        for (int k = 0; k < nex; k++) {
            int i, j;
            Vec3 at = ex[k].point;
            if (ex[k].bounds_centre)
                at = v3_scale(v3_add(scene->bounds.min, scene->bounds.max), 0.5f);
            project(&scene->camera, at, 200, 200, &i, &j);
            CHECK(i >= 0 && i < 200 && j >= 0 && j < 200);
            if (i < 0 || i >= 200 || j < 0 || j >= 200)
                continue;
            Vec3 p = image_get(&s, i, j);
            Vec3 want = ex[k].has_color ? ex[k].color : image_get(&r, i, j);
            printf("  pixel (%d,%d): preview %.3f %.3f %.3f, expected %.3f %.3f %.3f\n", i, j,
                   (double)p.x, (double)p.y, (double)p.z, (double)want.x, (double)want.y,
                   (double)want.z);
            CHECK_MSG(max_diff(p, want) <= ex[k].tol,
                      "pixel (%d,%d): preview %.3f %.3f %.3f, expected %.3f %.3f %.3f", i, j,
                      (double)p.x, (double)p.y, (double)p.z, (double)want.x, (double)want.y,
                      (double)want.z);
            CHECK(max_diff(p, bg) > 0.05f);
        }
        /* Silhouettes: of the pixels either image shows as object, >= 90% agree. */
        long either = 0, agree = 0;
        for (int y = 0; y < 200; y++)
            for (int x = 0; x < 200; x++) {
                bool so = max_diff(image_get(&s, x, y), bg) > 0.02f;
                bool ro = max_diff(image_get(&r, x, y), bg) > 0.02f;
                either += so || ro;
                agree += so && ro;
            }
        CHECK(either > 400);
        double frac = either ? (double)agree / (double)either : 0.0;
        printf("  silhouette agreement %.4f of %ld object pixels\n", frac, either);
        CHECK_MSG(frac >= 0.90, "silhouette agreement %.4f < 0.90", frac);
    }
    image_free(&s);
    image_free(&r);
    if (scene)
        scene_free(scene);
    e2e_rmtree(dir);
}

static void test_snapshot_course_01(void)
{
    need_snapshot();
    char path[PATH_MAX];
    course_file(path, sizeof path, "scene6_01_sphere.txt");
    /* A lit point on the upper front of the sphere: GL's per-vertex lighting of a fine
     * tessellation agrees with the ray tracer's per-pixel shading to a few per cent. */
    Expect ex[] = {{v3(0, 0.7071f, 0.7071f), false, false, v3(0, 0, 0), 0.06f}};
    const char *args[] = {"-tessellation", "60", "30", "-gouraud"};
    compare_views(path, args, 4, ex, 1, 4);
}

static void test_snapshot_course_04(void)
{
    need_snapshot();
    char path[PATH_MAX];
    course_file(path, sizeof path, "scene6_04_bunny_mesh_200.txt");
    /* The bunny's centre (flat triangles in both; GL's specular is per vertex) and a
     * point of the green floor, diffuse only; the floor fills the bottom corners. */
    Expect ex[] = {{v3(0, 0, 0), true, false, v3(0, 0, 0), 0.08f},
                   {v3(-0.2f, 0.06f, 0.1f), false, false, v3(0, 0, 0), 0.03f}};
    compare_views(path, NULL, 0, ex, 2, 2);
}

/* The project's own scene: orthographic, a checkerboard sphere (the preview shows the
 * FIRST material, as the course's) and a transformed triangle, light from the viewer. */
static const char *CHECKER_SCENE =
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 6 }\n"
    "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }\n"
    "Background { color 0.1 0.2 0.3 ambientLight 0 0 0 }\n"
    "Materials { numMaterials 4\n"
    "  PhongMaterial { diffuseColor 0.8 0.1 0.1 }\n"
    "  PhongMaterial { diffuseColor 0.9 0.9 0.9 }\n"
    "  Checkerboard { Transform { UniformScale 2 } materialIndex 0 materialIndex 1 }\n"
    "  PhongMaterial { diffuseColor 0.1 0.1 0.8 }\n"
    "}\n"
    "Group { numObjects 2\n"
    "  MaterialIndex 2 Sphere { center 0 0.5 0 radius 1.5 }\n"
    "  MaterialIndex 3 Transform { Translate 1.5 -2 0 Scale 1 0.5 1\n"
    "    Triangle { vertex0 -1 -1 0 vertex1 1 -1 0 vertex2 0 1 0 } }\n"
    "}\n";

static void test_snapshot_own_checkerboard(void)
{
    need_snapshot();
    char dir[PATH_MAX], path[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvscene") != NULL);
    e2e_join(path, sizeof path, dir, "checker.txt");
    CHECK(e2e_write_file(path, CHECKER_SCENE));
    Expect ex[] = {
        /* Sphere front: first material, n.L = 1 at the exact vertex of -gouraud. */
        {v3(0, 0.5f, 1.5f), false, true, v3(0.8f, 0.1f, 0.1f), 0.02f},
        /* Triangle centroid through the Transform (non-uniform scale: GL_NORMALIZE). */
        {v3(1.5f, -2.0f - 1.0f / 6.0f, 0), false, true, v3(0.1f, 0.1f, 0.8f), 0.02f},
    };
    const char *args[] = {"-tessellation", "40", "20", "-gouraud"};
    compare_views(path, args, 4, ex, 2, 4);
    e2e_rmtree(dir);
}

static bool is_green(Vec3 p) { return p.y > 0.5f && p.y > p.x + 0.3f && p.y > p.z + 0.3f; }
static bool is_gray(Vec3 p)
{
    return p.x > 0.55f && p.x < 0.85f && max_diff(p, v3(p.x, p.x, p.x)) < 0.05f;
}

/* Count of pixels of row y +- 1, columns x0..x1, that pass pred. */
static int count_row(const Image *img, int y, int x0, int x1, bool (*pred)(Vec3))
{
    int n = 0;
    for (int x = x0; x <= x1; x++) {
        bool hit = false;
        for (int dy = -1; dy <= 1; dy++)
            hit = hit || pred(image_get(img, x, y + dy));
        n += hit;
    }
    return n;
}

static void test_snapshot_ray_tree(void)
{
    need_snapshot();
    char dir[PATH_MAX], scene[PATH_MAX], a[PATH_MAX], b[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvtree") != NULL);
    e2e_join(scene, sizeof scene, dir, "sphere.txt");
    e2e_join(a, sizeof a, dir, "front.tga");
    e2e_join(b, sizeof b, dir, "side.tga");
    CHECK(e2e_write_file(scene, ORTHO_SPHERE));
    /* Front view: the main ray is seen end-on; the shadow ray toward the light at +x
     * runs from the hit point (pixel 100,100) to the right edge along row 100. */
    const char *a1[] = {"-input", scene, "-size", "200", "200", "-shadows",
                        "-gui_snapshot", a, "-gui_keys", "t:100,100", NULL};
    /* A quarter turn (314.16 pixels of rotation): now the main ray, from the image
     * plane (z = 10) to the sphere's front (z = 1.5), lies across the view. */
    const char *a2[] = {"-input", scene, "-size", "200", "200", "-shadows",
                        "-gui_snapshot", b, "-gui_keys", "t:100,100 rot:314.159265,0", NULL};
    Image fa = {0}, fb = {0};
    if (run_ok(a1) && run_ok(a2) && load(&fa, a) && load(&fb, b)) {
        int green = count_row(&fa, 100, 110, 195, is_green);
        CHECK_MSG(green >= 80, "shadow ray: %d of 86 pixels green along row 100", green);
        CHECK_INT(count_row(&fa, 100, 5, 45, is_green), 0);      /* not to the left */
        CHECK_INT(count_row(&fa, 160, 110, 195, is_green), 0);   /* only on its row */
        /* Side view: screen x of a point at depth z is 100 + z/6*200 or 100 - that,
         * depending on the turn's sense; the ray covers z in [1.5, 3] inside the view. */
        int right = count_row(&fb, 100, 155, 195, is_gray);
        int left = count_row(&fb, 100, 5, 45, is_gray);
        CHECK_MSG((right >= 38 && left == 0) || (left >= 38 && right == 0),
                  "main ray: %d gray pixels right, %d left of the sphere", right, left);
    }
    image_free(&fa);
    image_free(&fb);
    e2e_rmtree(dir);
}

/* What `t` prints: the counts with their singular ("1 segment", "0 grid cells"), and
 * for a tree cut at the recording's limit a warning on stderr. */
static void test_snapshot_ray_tree_lines(void)
{
    need_snapshot();
    char dir[PATH_MAX], scene[PATH_MAX], deep[PATH_MAX], a[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvtreeline") != NULL);
    e2e_join(scene, sizeof scene, dir, "sphere.txt");
    e2e_join(deep, sizeof deep, dir, "deep.txt");
    e2e_join(a, sizeof a, dir, "a.tga");
    CHECK(e2e_write_file(scene, ORTHO_SPHERE));
    CHECK(e2e_write_file(deep, DEEP_TREE));
    /* pixel (0, 0) misses the sphere: the main ray alone */
    const char *a1[] = {"-input", scene, "-size", "200", "200", "-shadows",
                        "-gui_snapshot", a, "-gui_keys", "t:0,0 t:100,100", NULL};
    E2eRun r;
    char why[512];
    CHECK(e2e_run_bin(harness_bin(), a1, &r));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    CHECK_CONTAINS(r.out, "ray tree of pixel (0, 0): 1 segment, 0 grid cells\n");
    CHECK_CONTAINS(r.out, "ray tree of pixel (100, 100): 2 segments, 0 grid cells\n");
    CHECK(strstr(r.err, "warning") == NULL);
    e2e_run_free(&r);
    const char *a2[] = {"-input", deep, "-size", "20", "20", "-shade_back", "-bounces", "60",
                        "-weight", "0", "-gui_snapshot", a, "-gui_keys", "t", NULL};
    CHECK(e2e_run_bin(harness_bin(), a2, &r));
    CHECK_MSG(r.status == 0 && !r.timed_out, "%s", e2e_describe(&r, why, sizeof why));
    CHECK_CONTAINS(r.out, "ray tree of pixel (10, 10): 1024 segments, 0 grid cells\n");
    CHECK_CONTAINS(r.err, "raytracer: warning: the ray tree of pixel (10, 10) is cut at 1024 "
                          "segments (the most kept): its deeper reflected and refracted rays "
                          "were not traced");
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

static void test_snapshot_bad_script_writes_nothing(void)
{
    need_snapshot();
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvbad") != NULL);
    e2e_join(scene, sizeof scene, dir, "sphere.txt");
    e2e_join(out, sizeof out, dir, "x.tga");
    CHECK(e2e_write_file(scene, ORTHO_SPHERE));
    const char *args[] = {"-input", scene, "-gui_snapshot", out, "-gui_keys", "t:1 q", NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "-gui_keys: bad command 't:1'");
    CHECK(!e2e_exists(out));
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

static void test_grid_view_snapshot(void)
{
    need_snapshot();
    char path[PATH_MAX], dir[PATH_MAX], a[PATH_MAX];
    course_file(path, sizeof path, "scene6_01_sphere.txt");
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvgrid") != NULL);
    e2e_join(a, sizeof a, dir, "grid.tga");
    /* One cell holding the sphere: a white cube (palette count 1) at the centre and
     * the white wireframe; the ray-traced -visualize_grid image has the same cube. */
    const char *args[] = {"-input", path, "-size", "200", "200", "-grid", "1", "1", "1",
                          "-visualize_grid", "-gui_snapshot", a, NULL};
    Image g = {0};
    if (run_ok(args) && load(&g, a)) {
        Vec3 c = image_get(&g, 100, 100);
        /* White, lit from above: grey levels, clearly not the blue background. */
        CHECK_MSG(max_diff(c, v3(c.x, c.x, c.x)) < 0.02f && c.x > 0.15f,
                  "centre %.3f %.3f %.3f", (double)c.x, (double)c.y, (double)c.z);
        Vec3 corner = image_get(&g, 0, 0);
        CHECK(max_diff(corner, v3(0, 0, 1)) < 0.01f);
    }
    image_free(&g);
    e2e_rmtree(dir);
}

/* r after truck and dolly renders what the command line renders from the moved camera
 * (the scene with that centre): the same bytes. Before, the screen stayed behind and the
 * moved render was mostly background. */
static void test_snapshot_render_after_truck_dolly(void)
{
    need_snapshot();
    char dir[PATH_MAX], scene[PATH_MAX], moved[PATH_MAX], snap[PATH_MAX], a[PATH_MAX],
        b[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvmove") != NULL);
    e2e_join(scene, sizeof scene, dir, "s.txt");
    e2e_join(moved, sizeof moved, dir, "moved.txt");
    e2e_join(snap, sizeof snap, dir, "snap.tga");
    e2e_join(a, sizeof a, dir, "r.tga");
    e2e_join(b, sizeof b, dir, "cli.tga");
    char text[1024];
    snprintf(text, sizeof text, "%s", PERSP_SPHERES);
    CHECK(e2e_write_file(scene, text));
    /* dolly 20 = 1 unit along -z, truck 20,-10 = 1 unit left and 0.5 down. */
    char *at = strstr(text, "center 0 0 10");
    CHECK(at != NULL);
    if (at) {
        char rest[1024];
        snprintf(rest, sizeof rest, "%s", at + strlen("center 0 0 10"));
        snprintf(at, sizeof text - (size_t)(at - text), "center -1 -0.5 9%s", rest);
    }
    CHECK(e2e_write_file(moved, text));
    const char *a1[] = {"-input", scene, "-size", "40", "40", "-shadows", "-output", a,
                        "-gui_snapshot", snap, "-gui_keys", "dolly:20 truck:20,-10 r", NULL};
    const char *a2[] = {"-input", moved, "-size", "40", "40", "-shadows", "-output", b, NULL};
    if (run_ok(a1) && run_ok(a2)) {
        size_t na = 0, nb = 0;
        char *da = e2e_read_file(a, &na), *db = e2e_read_file(b, &nb);
        CHECK(da && db);
        CHECK_MSG(da && db && na == nb && memcmp(da, db, na) == 0,
                  "r after the moves differs from the render of the moved camera");
        free(da);
        free(db);
    }
    e2e_rmtree(dir);
}

/* -grid auto builds the two-level grid for the showcase (a dense part in a big box):
 * its top level is the grid -visualize_grid and g show. Before, the preview looked for a
 * uniform grid only: -visualize_grid started in the object view and g said "no grid to
 * show: run with -grid nx ny nz". */
static void test_snapshot_grid_view_of_twolevel(void)
{
    need_snapshot();
    char dir[PATH_MAX], shot[PATH_MAX], rel[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvtl") != NULL);
    e2e_join(shot, sizeof shot, dir, "shot.tga");
    e2e_join(rel, sizeof rel, harness_root(), "scenes/showcase.txt");
    CHECK(e2e_abspath(rel, scene, sizeof scene));
    const char *args[] = {"-input", scene, "-size", "40", "30", "-grid", "auto",
                          "-visualize_grid", "-timings", "-gui_snapshot", shot,
                          "-gui_keys", "t g", NULL};
    E2eRun r;
    char why[512];
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    CHECK_CONTAINS(r.err, "grid auto: two-level"); /* the premise: the two-level grid */
    /* Started in the grid view: the first g goes on to the ray's cells. */
    CHECK_CONTAINS(r.out, "grid view: the cells the last traced ray visited");
    CHECK_MSG(strstr(r.out, "no grid to show") == NULL, "stdout '%s'", r.out);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* -noise_cutoff in the picture r draws: the first r's snapshot frame is the second's
 * (before, the pixel cone was set only when the files were rendered, after the first
 * picture: it showed the noise uncut, 17.7 dB from -output on the course's vase). */
static void test_snapshot_first_r_noise_cutoff(void)
{
    need_snapshot();
    char dir[PATH_MAX], rel[PATH_MAX], scene[PATH_MAX], s1[PATH_MAX], s2[PATH_MAX],
        out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvcut") != NULL);
    e2e_join(rel, sizeof rel, harness_root(), "scenes/tex_marble.txt");
    CHECK(e2e_abspath(rel, scene, sizeof scene));
    e2e_join(s1, sizeof s1, dir, "one.tga");
    e2e_join(s2, sizeof s2, dir, "two.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    const char *a1[] = {"-input", scene, "-size", "48", "32", "-noise_cutoff", "-output", out,
                        "-gui_snapshot", s1, "-gui_keys", "r", NULL};
    const char *a2[] = {"-input", scene, "-size", "48", "32", "-noise_cutoff", "-output", out,
                        "-gui_snapshot", s2, "-gui_keys", "r r", NULL};
    if (run_ok(a1) && run_ok(a2)) {
        size_t n1 = 0, n2 = 0;
        char *d1 = e2e_read_file(s1, &n1), *d2 = e2e_read_file(s2, &n2);
        CHECK(d1 && d2);
        CHECK_MSG(d1 && d2 && n1 == n2 && memcmp(d1, d2, n1) == 0,
                  "the first r's picture differs from the second's");
        free(d1);
        free(d2);
    }
    e2e_rmtree(dir);
}

/* An image on standard output (-gui_snapshot -, shot:-) is all that goes there: the
 * lines of c, t, g (and the -stats block of r) go to stderr. Before, c's camera block,
 * t's and g's lines were printed into the image's bytes. */
static void test_snapshot_to_stdout_alone(void)
{
    need_snapshot();
    char dir[PATH_MAX], scene[PATH_MAX], file[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "pvout") != NULL);
    e2e_join(scene, sizeof scene, dir, "s.txt");
    e2e_join(file, sizeof file, dir, "shot.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    CHECK(e2e_write_file(scene, PERSP_SPHERES));
    for (int k = 0; k < 2; k++) {
        /* k 0: the snapshot itself to stdout; k 1: shot:- beside a shot of the same
         * frame into a file. */
        const char *a0[] = {"-input", scene, "-size", "20", "16", "-output", out, "-stats",
                            "-gui_snapshot", "-", "-gui_keys", "c t g r", NULL};
        const char *a1[] = {"-input", scene, "-size", "20", "16", "-gui_snapshot", out,
                            "-gui_keys", "c t:3,4 shot:- g", NULL};
        E2eRun r;
        char why[512];
        CHECK(e2e_run_bin(harness_bin(), k ? a1 : a0, &r));
        CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
        CHECK_CONTAINS(r.err, "PerspectiveCamera {");
        CHECK_CONTAINS(r.err, "ray tree of pixel");
        /* g without a grid, and the two ways to one (-grid with -accel none is refused) */
        CHECK_CONTAINS(r.err, "no grid to show: run with -grid nx ny nz or -grid auto (and "
                              "without -accel none)");
        if (!k)
            CHECK_CONTAINS(r.err, "RAY TRACING STATISTICS");
        /* The frame alone: the bytes of the same frame written to a file. */
        const char *b0[] = {"-input", scene, "-size", "20", "16", "-gui_snapshot", file,
                            "-gui_keys", "c t g r", NULL};
        const char *b1[] = {"-input", scene, "-size", "20", "16", "-gui_snapshot", out,
                            "-gui_keys", "c t:3,4 shot:", NULL};
        char shot_word[PATH_MAX + 32];
        snprintf(shot_word, sizeof shot_word, "c t:3,4 shot:%s", file);
        b1[8] = shot_word;
        if (run_ok(k ? b1 : b0)) {
            size_t n = 0;
            char *want = e2e_read_file(file, &n);
            CHECK(want != NULL);
            CHECK_MSG(want && r.out_len == n && memcmp(r.out, want, n) == 0,
                      "case %d: stdout holds %zu bytes, the frame %zu", k, r.out_len, n);
            free(want);
        }
        e2e_run_free(&r);
    }
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"keys_parse_all_commands", test_keys_parse_all_commands},
    {"keys_parse_rejects_bad_words", test_keys_parse_rejects_bad_words},
    {"keys_check_pixel_in_image", test_keys_check_pixel_in_image},
    {"rotate_keeps_distance_and_aim", test_rotate_keeps_distance_and_aim},
    {"truck_and_dolly_units", test_truck_and_dolly_units},
    {"truck_and_dolly_move_the_screen", test_truck_and_dolly_move_the_screen},
    {"trace_records_main_and_shadow", test_trace_records_main_and_shadow},
    {"trace_deep_tree_is_cut", test_trace_deep_tree_is_cut},
    {"snapshot_course_01", test_snapshot_course_01},
    {"snapshot_course_04", test_snapshot_course_04},
    {"snapshot_own_checkerboard", test_snapshot_own_checkerboard},
    {"snapshot_ray_tree", test_snapshot_ray_tree},
    {"snapshot_ray_tree_lines", test_snapshot_ray_tree_lines},
    {"snapshot_bad_script_writes_nothing", test_snapshot_bad_script_writes_nothing},
    {"grid_view_snapshot", test_grid_view_snapshot},
    {"snapshot_render_after_truck_dolly", test_snapshot_render_after_truck_dolly},
    {"snapshot_grid_view_of_twolevel", test_snapshot_grid_view_of_twolevel},
    {"snapshot_first_r_noise_cutoff", test_snapshot_first_r_noise_cutoff},
    {"snapshot_to_stdout_alone", test_snapshot_to_stdout_alone},
};

RT_TEST_MAIN(tests)
