/* The course's shading rules where no official picture decides them, each with the
 * smallest scene that shows it, rendered by the binary and checked against the formula
 * to the byte (one step of float rounding allowed): the -weight cutoff keeps a ray whose
 * weight equals it, along a path of products; the normal image takes |n| of every
 * component, also of back faces, which keep their depth; a reflected ray that meets a
 * back face brings black; a transparent object casts a whole shadow; a point light is
 * shadowed only by what lies before it; a ray leaving glass at a steep angle is totally
 * reflected and adds nothing; -visualize_grid with -shadows shades cells by cells.
 * Planar scenes, so the expected colours come straight from the formulas (README.txt,
 * 3 and 4). */
#define _POSIX_C_SOURCE 200809L
#include "../harness.h"
#include "e2e_util.h"

static char g_dir[PATH_MAX];

static void setup_dir(void)
{
    if (!e2e_tmpdir(g_dir, sizeof g_dir, "spec"))
        harness_fail(__FILE__, __LINE__, "cannot create a temporary folder");
}

/* Renders scene text at w x h with the given options (NULL-terminated) into
 * g_dir/NAME.tga; true when it ran with exit status 0. */
static bool render(const char *name, const char *scene, int w, int h, const char *const *opts)
{
    char scene_path[PATH_MAX], out[PATH_MAX], ws[16], hs[16];
    char file[64];
    snprintf(file, sizeof file, "%s.txt", name);
    e2e_join(scene_path, sizeof scene_path, g_dir, file);
    snprintf(file, sizeof file, "%s.tga", name);
    e2e_join(out, sizeof out, g_dir, file);
    if (!e2e_write_file(scene_path, scene))
        return false;
    snprintf(ws, sizeof ws, "%d", w);
    snprintf(hs, sizeof hs, "%d", h);
    const char *args[40] = {"-input", scene_path, "-output", out, "-size", ws, hs, "-quiet"};
    int n = 8;
    for (int i = 0; opts && opts[i] && n < 39; i++)
        args[n++] = opts[i];
    args[n] = NULL;
    E2eRun r;
    bool ok = e2e_run_bin(harness_bin(), args, &r) && r.status == 0;
    CHECK_MSG(ok, "%s: exit status %d: %s", name, r.status, r.err ? r.err : "");
    e2e_run_free(&r);
    return ok;
}

/* Pixel (i, j), j counted from the bottom, of g_dir/NAME.tga (the course's layout: 18
 * header bytes, rows from the top, B G R) into rgb; false when unreadable. */
static bool pixel(const char *name, int i, int j, int rgb[3])
{
    char file[64], path[PATH_MAX];
    snprintf(file, sizeof file, "%s.tga", name);
    size_t len;
    char *b = e2e_read_file(e2e_join(path, sizeof path, g_dir, file), &len);
    bool ok = b && len >= 18;
    if (ok) {
        const unsigned char *u = (const unsigned char *)b;
        int w = u[12] | u[13] << 8, h = u[14] | u[15] << 8;
        size_t at = 18 + u[0] + ((size_t)(h - 1 - j) * (size_t)w + (size_t)i) * 3;
        ok = i < w && j < h && at + 3 <= len;
        if (ok) {
            rgb[0] = u[at + 2];
            rgb[1] = u[at + 1];
            rgb[2] = u[at];
        }
    }
    free(b);
    CHECK_MSG(ok, "cannot read pixel (%d, %d) of %s.tga", i, j, name);
    return ok;
}

/* The writer's byte for a colour channel: truncated, clamped. */
static int to_byte(double c)
{
    double v = c * 255.0;
    return v <= 0.0 ? 0 : v >= 255.0 ? 255 : (int)v;
}

/* Pixel (i, j) of NAME is the colour c, within one byte (float against double). */
static void expect_color(const char *what, const char *name, int i, int j, double r, double g,
                         double b)
{
    int px[3];
    if (!pixel(name, i, j, px))
        return;
    int want[3] = {to_byte(r), to_byte(g), to_byte(b)};
    for (int k = 0; k < 3; k++)
        CHECK_MSG(abs(px[k] - want[k]) <= 1,
                  "%s: pixel (%d, %d) is %d %d %d, expected %d %d %d", what, i, j, px[0],
                  px[1], px[2], want[0], want[1], want[2]);
}

/* A mirror's reflected ray is traced when its weight equals -weight (at least, not
 * above: the product 1 x |kr| = 0.5 against -weight 0.5) and not when it is below, at
 * the first bounce and along a path (0.5 x 0.5 = 0.25 between two mirrors facing each
 * other); ray by ray and in the grid's packets (8 x 8 camera rays, their reflections
 * together), which decide the cutoff in code of their own. */
static void test_weight_cutoff_at_least(void)
{
    setup_dir();
    /* No lights: ambient 1 1 1, so a hit's own colour is its diffuse colour. A small
     * sphere far off gives the grid something to hold (a scene of planes has none). */
    static const char floor_scene[] =
        "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 2 }\n"
        "Background { color 0.1 0.2 0.3 }\n"
        "Materials { numMaterials 1\n"
        "  PhongMaterial { diffuseColor 0.6 0.5 0.4 reflectiveColor 0.5 0 0 } }\n"
        "Group { numObjects 2 MaterialIndex 0 Plane { normal 0 0 1 offset 0 }\n"
        "  Sphere { center 50 50 50 radius 1 } }\n";
    const char *grids[2][4] = {{NULL}, {"-grid", "2", "2", "2"}};
    for (int g = 0; g < 2; g++) {
        const char *at[] = {"-bounces", "1", "-weight", "0.5", grids[g][0], grids[g][1],
                            grids[g][2], grids[g][3], NULL};
        const char *above[] = {"-bounces", "1", "-weight", "0.5001", grids[g][0],
                               grids[g][1], grids[g][2], grids[g][3], NULL};
        if (render("at", floor_scene, 8, 8, at))
            expect_color(g ? "weight = cutoff, grid" : "weight = cutoff", "at", 3, 4,
                         0.6 + 0.5 * 0.1, 0.5, 0.4);
        if (render("above", floor_scene, 8, 8, above))
            expect_color(g ? "weight < cutoff, grid" : "weight < cutoff", "above", 3, 4, 0.6,
                         0.5, 0.4);
    }
    /* Floor mirror (z = 0, facing up) and ceiling mirror (z = 10, facing down), the eye
     * between them looking down; one light from above lights the floor only. The
     * centre pixel's path: floor (weight 1), ceiling (0.5), floor (0.25), ... */
    static const char two_mirrors[] =
        "PerspectiveCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 angle 30 }\n"
        "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.1 0.05 }\n"
        "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 0.5 0.5 0.5 } }\n"
        "Materials { numMaterials 2\n"
        "  PhongMaterial { diffuseColor 0.2 0.3 0.4 reflectiveColor 0.5 0 0 }\n"
        "  PhongMaterial { diffuseColor 0.3 0.2 0.1 reflectiveColor 0.5 0 0 } }\n"
        "Group { numObjects 2 MaterialIndex 0 Plane { normal 0 0 1 offset 0 }\n"
        "  MaterialIndex 1 Plane { normal 0 0 -1 offset -10 } }\n";
    /* floor: ambient + light; ceiling: ambient only (the light is behind it). */
    double fl = 0.2 * 0.2 + 0.5 * 0.2, ce = 0.2 * 0.3;
    double two = fl + 0.5 * ce, three = fl + 0.5 * (ce + 0.5 * fl);
    const char *w25[] = {"-bounces", "5", "-weight", "0.25", NULL};
    const char *w30[] = {"-bounces", "5", "-weight", "0.3", NULL};
    if (render("w25", two_mirrors, 1, 1, w25))
        expect_color("second bounce at weight 0.25 = cutoff", "w25", 0, 0, three,
                     0.1 * 0.3 + 0.5 * 0.3, 0.05 * 0.4 + 0.5 * 0.4);
    if (render("w30", two_mirrors, 1, 1, w30))
        expect_color("second bounce below cutoff 0.3", "w30", 0, 0, two,
                     0.1 * 0.3 + 0.5 * 0.3, 0.05 * 0.4 + 0.5 * 0.4);
    e2e_rmtree(g_dir);
}

/* -normals writes |nx| |ny| |nz|: the lower-left part of a sphere, whose normals point
 * to -x and -y, is as bright there as the upper right. A back face keeps its depth and
 * normal. */
static void test_normals_absolute(void)
{
    setup_dir();
    static const char sphere[] =
        "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 2.2 }\n"
        "Materials { numMaterials 1 PhongMaterial { } }\n"
        "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n";
    char nfile[PATH_MAX];
    const char *opts[] = {"-normals", e2e_join(nfile, sizeof nfile, g_dir, "n.tga"), NULL};
    if (render("o", sphere, 11, 11, opts)) {
        /* Pixel (2, 2): x = y = ((2.5 - 5.5) / 11) * 2.2 = -0.6. */
        double x = -0.6, y = -0.6, z = sqrt(1.0 - x * x - y * y);
        expect_color("normal to -x -y", "n", 2, 2, -x, -y, z);
        expect_color("normal to +x +y", "n", 8, 8, -x, -y, z);
    }
    /* A back face without -shade_back: black in the colour image, but its depth and
     * normal are written as any face's (docs/images.md). A clockwise triangle at z = 1:
     * t = 4, grey (5 - 4) / (5 - 3), normal -z. */
    static const char back[] =
        "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 2 }\n"
        "Materials { numMaterials 1 PhongMaterial { } }\n"
        "Group { numObjects 1 MaterialIndex 0\n"
        "  Triangle { vertex0 -5 -5 1 vertex1 -5 5 1 vertex2 5 -5 1 } }\n";
    char dfile[PATH_MAX];
    const char *opts2[] = {"-normals", nfile, "-depth", "3", "5",
                           e2e_join(dfile, sizeof dfile, g_dir, "d.tga"), NULL};
    if (render("b", back, 3, 3, opts2)) {
        expect_color("back face colour", "b", 1, 1, 0, 0, 0);
        expect_color("back face depth", "d", 1, 1, 0.5, 0.5, 0.5);
        expect_color("back face normal", "n", 1, 1, 0, 0, 1);
    }
    e2e_rmtree(g_dir);
}

/* A scene seen from (0 2 2) looking down at 45 degrees onto a mirror floor (y = 0):
 * the reflected ray rises away from the eye and meets a triangle at z = -10, whose
 * side towards it is its front or its back. */
static const char k_tilted_head[] =
    "OrthographicCamera { center 0 2 2 direction 0 -1 -1 up 0 1 -1 size 1 }\n"
    "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.1 0.05 }\n"
    "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 0.5 0.5 0.5 } }\n"
    "Materials { numMaterials 2\n"
    "  PhongMaterial { diffuseColor 0.6 0.5 0.4 reflectiveColor 0.5 0.4 0.3 }\n"
    "  PhongMaterial { diffuseColor 0.9 0.9 0.9 } }\n";

/* A back face met by a reflected ray is black, as for an eye ray (not the background,
 * not its ambient term); a front face there is shaded. */
static void test_reflected_back_face_black(void)
{
    setup_dir();
    char scene[2048];
    const char *opts[] = {"-bounces", "1", NULL};
    /* The floor's own colour: its normal +y is square to the light (0 0 1): ambient. */
    double base[3] = {0.2 * 0.6, 0.1 * 0.5, 0.05 * 0.4}, kr[3] = {0.5, 0.4, 0.3};
    for (int front = 0; front < 2; front++) {
        snprintf(scene, sizeof scene,
                 "%sGroup { numObjects 2 MaterialIndex 0 Plane { normal 0 1 0 offset 0 }\n"
                 "  MaterialIndex 1 Triangle { vertex0 -50 5 -10 vertex1 %s -10 "
                 "vertex2 %s -10 } }\n",
                 k_tilted_head, front ? "50 5" : "0 15", front ? "0 15" : "50 5");
        if (!render(front ? "front" : "back", scene, 3, 3, opts))
            continue;
        double seen[3];
        for (int k = 0; k < 3; k++) /* front: ambient + the light straight on */
            seen[k] = front ? (k == 0 ? 0.2 : k == 1 ? 0.1 : 0.05) * 0.9 + 0.5 * 0.9 : 0.0;
        expect_color(front ? "reflection of a front face" : "reflection of a back face",
                     front ? "front" : "back", 1, 1, base[0] + kr[0] * seen[0],
                     base[1] + kr[1] * seen[1], base[2] + kr[2] * seen[2]);
    }
    e2e_rmtree(g_dir);
}

/* Shadows are opaque whatever blocks them (the course's basic shadows): a transparent
 * sphere darkens the floor as an opaque one does. A point light's shadow ray stops at
 * the light: an object beyond it casts nothing. */
static void test_shadows_opaque_and_bounded(void)
{
    setup_dir();
    static const char head[] =
        "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 2 }\n"
        "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.1 0.05 }\n";
    static const char mats[] =
        "Materials { numMaterials 3 PhongMaterial { diffuseColor 0.6 0.5 0.4 }\n"
        "  PhongMaterial { diffuseColor 1 1 1 }\n"
        "  PhongMaterial { diffuseColor 0 0 0 transparentColor 1 1 1 } }\n";
    const double amb[3] = {0.2 * 0.6, 0.1 * 0.5, 0.05 * 0.4};
    char scene[2048];
    const char *shadows[] = {"-shadows", NULL};
    /* The light travels along (1 0 -1): the sphere at (2 0 2) stands between the
     * floor's centre and it, outside the eye's view. */
    for (int m = 1; m <= 2; m++) {
        snprintf(scene, sizeof scene,
                 "%sLights { numLights 1 DirectionalLight { direction -1 0 -1 color 0.5 0.5 "
                 "0.5 } }\n%sGroup { numObjects 2 MaterialIndex 0 Plane { normal 0 0 1 "
                 "offset 0 } MaterialIndex %d Sphere { center 2 0 2 radius 0.5 } }\n",
                 head, mats, m);
        if (render("occl", scene, 3, 3, shadows))
            expect_color(m == 1 ? "opaque occluder" : "transparent occluder", "occl", 1, 1,
                         amb[0], amb[1], amb[2]);
    }
    /* Point light at (0 0 2) over the floor, 9 x 9 pixels; pixel (0, 4) sees the floor
     * at x = -8/9. A sphere of radius 0.6 centred on the z axis at z = 1 stands
     * between them; at z = 3 it stands beyond the light, on the same line. */
    double x = -8.0 / 9.0, dist = sqrt(x * x + 4.0), nl = 2.0 / dist;
    for (int beyond = 0; beyond < 2; beyond++) {
        snprintf(scene, sizeof scene,
                 "%sLights { numLights 1 PointLight { position 0 0 2 color 0.5 0.5 0.5 } }\n"
                 "%sGroup { numObjects 2 MaterialIndex 0 Plane { normal 0 0 1 offset 0 }\n"
                 "  MaterialIndex 1 Sphere { center 0 0 %d radius 0.6 } }\n",
                 head, mats, beyond ? 3 : 1);
        if (!render("point", scene, 9, 9, shadows))
            continue;
        if (beyond)
            expect_color("occluder beyond the point light", "point", 0, 4,
                         amb[0] + 0.5 * 0.6 * nl, amb[1] + 0.5 * 0.5 * nl,
                         amb[2] + 0.5 * 0.4 * nl);
        else
            expect_color("occluder before the point light", "point", 0, 4, amb[0], amb[1],
                         amb[2]);
    }
    e2e_rmtree(g_dir);
}

/* Refraction at a flat surface seen at 60 degrees from its normal, index 1.5: entering
 * (the front face) the ray bends and goes on to the background; leaving (a back face,
 * shaded with -shade_back: index 1.5 to 1) sin 60 x 1.5 > 1, total internal reflection,
 * which adds nothing (no mirror term); index 1 passes straight through. */
static void test_refraction_enter_leave(void)
{
    setup_dir();
    /* Eye at 60 degrees: direction (0, -sin 60, -cos 60). */
    static const char cam[] =
        "OrthographicCamera { center 0 1.7320508 1 direction 0 -0.8660254 -0.5 "
        "up 0 0 1 size 1 }\n"
        "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.1 0.05 }\n"
        "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 0.5 0.5 0.5 } }\n";
    static const struct {
        const char *what;
        double ior;
        int nz;
        int tir;
    } cases[] = {{"entering at 60 degrees", 1.5, 1, 0},
                 {"leaving at 60 degrees: total internal reflection", 1.5, -1, 1},
                 {"leaving with index 1", 1.0, -1, 0}};
    const char *opts[] = {"-bounces", "1", "-shade_back", NULL};
    char scene[2048];
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        snprintf(scene, sizeof scene,
                 "%sMaterials { numMaterials 1 PhongMaterial { diffuseColor 0.1 0.1 0.1 "
                 "transparentColor 0.5 0.4 0.3 indexOfRefraction %g } }\n"
                 "Group { numObjects 1 MaterialIndex 0 Plane { normal 0 0 %d offset 0 } }\n",
                 cam, cases[c].ior, cases[c].nz);
        if (!render("glass", scene, 3, 3, opts))
            continue;
        /* The facing normal is +z either way: ambient + the light straight on. */
        double local[3] = {0.2 * 0.1 + 0.05, 0.1 * 0.1 + 0.05, 0.05 * 0.1 + 0.05};
        double kt_bg[3] = {0.5 * 0.1, 0.4 * 0.2, 0.3 * 0.3};
        int t = !cases[c].tir;
        expect_color(cases[c].what, "glass", 1, 1, local[0] + t * kt_bg[0],
                     local[1] + t * kt_bg[1], local[2] + t * kt_bg[2]);
    }
    e2e_rmtree(g_dir);
}

/* -visualize_grid with -shadows: the drawn cells cast the shadows (a shadow ray stops
 * at the first occupied cell towards the light), planes, not drawn, none. Two spheres
 * in a 6 x 1 x 2 grid: the cells of the upper-left one stand between the light and the
 * top of a lower cell of the other; a plane above everything shades nothing. */
static void test_visualize_grid_shadows(void)
{
    setup_dir();
    static const char scene[] =
        "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 6 }\n"
        "Background { ambientLight 0.2 0.2 0.2 }\n"
        "Lights { numLights 1 DirectionalLight { direction 0.3 0 -1 color 0.5 0.5 0.5 } }\n"
        "Materials { numMaterials 1 PhongMaterial { } }\n"
        "Group { numObjects 3 MaterialIndex 0 Sphere { center -2 0 1 radius 0.5 }\n"
        "  Sphere { center 1 0 -1 radius 0.5 } Plane { normal 0 0 -1 offset -4 } }\n";
    const char *plain[] = {"-grid", "6", "1", "2", "-visualize_grid", NULL};
    const char *shadows[] = {"-grid", "6", "1", "2", "-visualize_grid", "-shadows", NULL};
    /* A cell holding one object is white; its top face (normal +z) takes the light at
     * L = (-0.3, 0, 1) / |.|: cos = 1 / sqrt(1.09). */
    double lit = 0.2 + 0.5 / sqrt(1.09);
    /* Pixel (10, 12): x = -0.375, the top (z = 0) of a lower cell of the right sphere;
     * towards the light it passes x = -0.5 at z = 0.42, inside the left sphere's cells
     * (x < -0.5, 0 <= z <= 1.5). Pixel (14, 12): x = 0.625, nothing towards the light
     * but the plane. */
    if (render("viz", scene, 24, 24, plain)) {
        expect_color("cell lit without -shadows", "viz", 10, 12, lit, lit, lit);
        expect_color("cell lit without -shadows", "viz", 14, 12, lit, lit, lit);
    }
    if (render("vizsh", scene, 24, 24, shadows)) {
        expect_color("cell in the shadow of cells", "vizsh", 10, 12, 0.2, 0.2, 0.2);
        expect_color("planes cast no shadow on cells", "vizsh", 14, 12, lit, lit, lit);
    }
    e2e_rmtree(g_dir);
}

static const TestCase tests[] = {
    {"weight_cutoff_at_least", test_weight_cutoff_at_least},
    {"normals_absolute", test_normals_absolute},
    {"reflected_back_face_black", test_reflected_back_face_black},
    {"shadows_opaque_and_bounded", test_shadows_opaque_and_bounded},
    {"refraction_enter_leave", test_refraction_enter_leave},
    {"visualize_grid_shadows", test_visualize_grid_shadows},
};

RT_TEST_MAIN(tests)
