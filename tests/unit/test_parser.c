/* Scene parser tests: official scenes, values, defaults, composition order, the
 * MaterialIndex state, obj_file resolution, located errors, and no crash on truncated
 * or mutated input. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../harness.h"
#include "rt/geom.h"
#include "rt/scene.h"

/* Under ASan, LeakSanitizer checks explicitly: the harness ends children with _exit(),
 * which skips the automatic check at exit. */
#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#define CHECK_NO_LEAKS() CHECK_MSG(__lsan_do_recoverable_leak_check() == 0, "memory leaked")
#else
#define CHECK_NO_LEAKS() ((void)0)
#endif

static Diag g_diag;

static Scene *load(const char *text)
{
    diag_init(&g_diag, NULL);
    return scene_load_string(text, "t.txt", NULL, &g_diag);
}

/* Parses text as "t.txt" with its messages captured in out (size bytes, kept
 * NUL-terminated) and counted in *d. */
static Scene *load_capture(const char *text, Diag *d, char *out, size_t size)
{
    out[0] = '\0';
    FILE *f = fmemopen(out, size - 1, "w");
    CHECK(f != NULL);
    diag_init(d, f);
    if (!f)
        return NULL;
    Scene *s = scene_load_string(text, "t.txt", NULL, d);
    fclose(f);
    return s;
}

/* The text must fail with a message containing msg (location included). */
#define EXPECT_ERROR(text, msg) \
    do { \
        Scene *s_ = load(text); \
        CHECK_MSG(s_ == NULL, "parsed, expected error \"%s\"", (msg)); \
        scene_free(s_); \
        CHECK_CONTAINS(g_diag.last, (msg)); \
        CHECK_INT(g_diag.errors, 1); \
    } while (0)

static char *read_text(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    fseek(f, 0, SEEK_END);
    long n = ftell(f);
    fseek(f, 0, SEEK_SET);
    char *b = malloc((size_t)n + 1);
    if (b && fread(b, 1, (size_t)n, f) != (size_t)n) {
        free(b);
        b = NULL;
    }
    if (b)
        b[n] = '\0';
    fclose(f);
    return b;
}

static const char *course_or_skip(void)
{
    const char *c = harness_course_dir();
    if (!c)
        harness_skip("course data folder absent (set RT_COURSE)");
    return c;
}

/* ---- official scenes ------------------------------------------------------------- */

typedef struct Official {
    const char *file;
    int lights, materials;
    unsigned prims;
    bool perspective;
} Official;

/* Counts taken independently from the files (grep of Sphere/Plane/Triangle plus the
 * 'f' lines of each obj_file). */
static const Official k_official[] = {
    {"scene6_01_sphere.txt", 1, 2, 1, true},
    {"scene6_02_sphere_triangles.txt", 1, 2, 3, true},
    {"scene6_03_sphere_plane.txt", 1, 2, 2, true},
    {"scene6_04_bunny_mesh_200.txt", 2, 2, 201, true},
    {"scene6_05_bunny_mesh_1k.txt", 2, 2, 1001, true},
    {"scene6_06_bunny_mesh_5k.txt", 2, 2, 5001, true},
    {"scene6_07_bunny_mesh_40k.txt", 2, 2, 40001, true},
    {"scene6_08_scale_translate.txt", 1, 6, 6, false},
    {"scene6_09_rotated_triangles.txt", 1, 3, 4, false},
    {"scene6_10_nested_transformations.txt", 1, 3, 36, false},
    {"scene6_11_mirrored_floor.txt", 2, 4, 38, true},
    {"scene6_12_faceted_gem.txt", 3, 2, 111, true},
    {"scene6_13_checkerboard.txt", 2, 6, 2, true},
    {"scene6_14_glass_sphere.txt", 2, 7, 38, true},
    {"scene6_15_marble_cubes.txt", 1, 12, 48, false},
    {"scene6_16_wood_cubes.txt", 1, 12, 48, false},
    {"scene6_17_marble_vase.txt", 2, 6, 3841, true},
    {"scene6_18_6.837_logo.txt", 2, 8, 13853, true},
};

static void test_official_scenes_parse(void)
{
    const char *dir = course_or_skip();
    for (size_t i = 0; i < sizeof k_official / sizeof k_official[0]; i++) {
        const Official *o = &k_official[i];
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, o->file);
        Diag d;
        diag_init(&d, NULL);
        Scene *s = scene_load(path, &d);
        CHECK_MSG(s != NULL, "%s: %s", o->file, d.last);
        if (!s)
            continue;
        CHECK_MSG(s->has_camera && s->root, "%s: camera/root missing", o->file);
        CHECK_MSG(s->num_lights == o->lights, "%s: %d lights, expected %d", o->file,
                  s->num_lights, o->lights);
        CHECK_MSG(s->num_materials == o->materials, "%s: %d materials, expected %d", o->file,
                  s->num_materials, o->materials);
        CHECK_MSG(s->num_primitives == o->prims, "%s: %u primitives, expected %u", o->file,
                  (unsigned)s->num_primitives, o->prims);
        CHECK_MSG(s->camera.kind == (o->perspective ? CAMERA_PERSPECTIVE : CAMERA_ORTHOGRAPHIC),
                  "%s: camera kind", o->file);
        CHECK_MSG(!s->no_lights, "%s: no_lights set", o->file);
        CHECK_INT(d.errors, 0);
        scene_free(s);
    }
}

static void test_official_values(void)
{
    const char *dir = course_or_skip();
    char path[4096];
    Diag d;
    diag_init(&d, NULL);
    snprintf(path, sizeof path, "%s/scene6_07_bunny_mesh_40k.txt", dir);
    Scene *s = scene_load(path, &d);
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->camera.kind == CAMERA_PERSPECTIVE);
    CHECK_NEAR(s->camera.center.x, -0.084519, 1e-7);
    CHECK_NEAR(s->camera.center.y, 0.313242, 1e-7);
    CHECK_NEAR(s->camera.center.z, 0.855356, 1e-7);
    CHECK_NEAR(s->camera.angle, 26.0 * M_PI / 180.0, 1e-6);
    CHECK_NEAR(v3_length(s->camera.direction), 1.0, 1e-6);
    CHECK_NEAR(s->background.x, 0.2, 1e-7);
    CHECK_NEAR(s->background.z, 0.6, 1e-7);
    CHECK_NEAR(s->ambient.y, 0.2, 1e-7);
    CHECK(s->lights[0].kind == LIGHT_DIRECTIONAL);
    /* Directional light direction normalised: (0.4 -0.8 -0.3) / |..| */
    double l = sqrt(0.16 + 0.64 + 0.09);
    CHECK_NEAR(s->lights[0].direction.x, 0.4 / l, 1e-6);
    CHECK_NEAR(s->lights[0].direction.y, -0.8 / l, 1e-6);
    CHECK_NEAR(s->lights[1].color.x, 0.5, 1e-7);
    PhongParams pp;
    CHECK(phong_params(s->materials[1], &pp));
    CHECK_NEAR(pp.diffuse.y, 0.9, 1e-7);
    CHECK_NEAR(pp.exponent, 100, 0);
    /* Root: mesh group (40000 triangles) then the plane, both bounded or not as they are. */
    CHECK_INT(group_count(s->root), 2);
    const Object3D *mesh = group_child(s->root, 0);
    CHECK(obj_kind(mesh) == OBJ_GROUP);
    CHECK_INT(group_count(mesh), 40000);
    CHECK(group_child(mesh, 0)->material == s->materials[0]);
    CHECK(group_child(mesh, 39999)->material == s->materials[0]);
    CHECK(obj_kind(group_child(s->root, 1)) == OBJ_PLANE);
    CHECK(group_child(s->root, 1)->material == s->materials[1]);
    CHECK_NEAR(plane_offset(group_child(s->root, 1)), 0.06, 1e-7);
    CHECK(!bbox_is_empty(&s->bounds));
    scene_free(s);

    diag_init(&d, NULL);
    snprintf(path, sizeof path, "%s/scene6_18_6.837_logo.txt", dir);
    s = scene_load(path, &d);
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(phong_params(s->materials[0], &pp));
    CHECK_NEAR(pp.diffuse.x, 0.1, 1e-7);
    CHECK_NEAR(pp.specular.x, 0.5, 1e-7);
    CHECK_NEAR(pp.exponent, 64, 0);
    CHECK_NEAR(pp.transparent.x, 0.7, 1e-7);
    CHECK_NEAR(pp.reflective.x, 0.3, 1e-7);
    CHECK_NEAR(pp.ior, 2.0, 0);
    CHECK_STR(s->materials[3]->ops->type_name, "Wood");
    CHECK_STR(s->materials[6]->ops->type_name, "Wood");
    CHECK_STR(s->materials[7]->ops->type_name, "Checkerboard");
    CHECK(!phong_params(s->materials[7], &pp));
    CHECK(s->lights[0].kind == LIGHT_POINT);
    CHECK_NEAR(s->lights[0].attenuation[0], 0, 0);
    CHECK_NEAR(s->lights[0].attenuation[1], 0.2, 1e-7);
    CHECK_NEAR(s->lights[1].position.z, 1, 0);
    scene_free(s);
}

/* ---- values, defaults, rules ------------------------------------------------------ */

static const char *k_cam =
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n";

static void test_defaults_and_zero_lights(void)
{
    Scene *s = load("");
    CHECK(s != NULL);
    if (s) {
        CHECK(!s->has_camera);
        CHECK(s->root == NULL);
        CHECK_NEAR(s->background.x, 0.5, 0);
        CHECK_NEAR(s->background.z, 0.5, 0);
        CHECK(s->no_lights);
        CHECK_NEAR(s->ambient.x, 1, 0);
        CHECK(bbox_is_empty(&s->bounds));
        CHECK_INT(s->num_primitives, 0);
        scene_free(s);
    }
    /* Whitespace only, CRLF, tabs: still an empty scene. */
    s = load(" \r\n\t\r\n");
    CHECK(s != NULL);
    scene_free(s);
    /* The rule overrides Background's ambientLight, also for numLights 0. */
    s = load("Background { ambientLight 0.2 0.3 0.4 color 0 0 0 }\nLights { numLights 0 }");
    CHECK(s != NULL);
    if (s) {
        CHECK(s->no_lights);
        CHECK_NEAR(s->ambient.y, 1, 0);
        CHECK_NEAR(s->background.x, 0, 0);
        scene_free(s);
    }
    /* With a light the ambient default is 0 and a PointLight defaults to 1 0 0. */
    s = load("Lights { numLights 2 PointLight { position 1 2 3 color 1 1 1 }\n"
             "DirectionalLight { direction 0 0 -2 color 1 1 1 } }");
    CHECK(s != NULL);
    if (s) {
        CHECK(!s->no_lights);
        CHECK_NEAR(s->ambient.x, 0, 0);
        CHECK_NEAR(s->lights[0].attenuation[0], 1, 0);
        CHECK_NEAR(s->lights[0].attenuation[1], 0, 0);
        CHECK_NEAR(s->lights[0].attenuation[2], 0, 0);
        CHECK_NEAR(s->lights[0].position.y, 2, 0);
        CHECK_NEAR(s->lights[1].direction.z, -1, 0);
        scene_free(s);
    }
    /* Phong defaults; Material is a synonym; last repeat wins. */
    s = load("Materials { numMaterials 2 PhongMaterial { }\n"
             "Material { diffuseColor 1 0 0 diffuseColor 0 1 0 exponent 5 } }");
    CHECK(s != NULL);
    if (s) {
        PhongParams pp;
        CHECK(phong_params(s->materials[0], &pp));
        CHECK_NEAR(pp.diffuse.x, 1, 0);
        CHECK_NEAR(pp.diffuse.z, 1, 0);
        CHECK_NEAR(pp.specular.x, 0, 0);
        CHECK_NEAR(pp.exponent, 1, 0);
        CHECK_NEAR(pp.reflective.y, 0, 0);
        CHECK_NEAR(pp.transparent.z, 0, 0);
        CHECK_NEAR(pp.ior, 1, 0);
        CHECK(phong_params(s->materials[1], &pp));
        CHECK_NEAR(pp.diffuse.x, 0, 0);
        CHECK_NEAR(pp.diffuse.y, 1, 0);
        CHECK_NEAR(pp.exponent, 5, 0);
        scene_free(s);
    }
}

static void test_number_forms(void)
{
    /* C float syntax as fscanf("%f") reads it: 0. .4 -.3 1e-3 +2 */
    Scene *s = load("Background { color 0. .4 -.3 ambientLight 1e-3 +2 0x1p-2 }");
    CHECK(s != NULL);
    if (s) {
        CHECK_NEAR(s->background.x, 0, 0);
        CHECK_NEAR(s->background.y, 0.4f, 0);
        CHECK_NEAR(s->background.z, -0.3f, 0);
        scene_free(s);
    }
    /* Lights make the ambient survive (no zero-lights rule). */
    s = load("Lights { numLights 1 DirectionalLight { direction 0 -1 0 color 1 1 1 } }\n"
             "Background { ambientLight 1e-3 +2 0x1p-2 }");
    CHECK(s != NULL);
    if (s) {
        CHECK_NEAR(s->ambient.x, 1e-3f, 0);
        CHECK_NEAR(s->ambient.y, 2, 0);
        CHECK_NEAR(s->ambient.z, 0.25, 0);
        scene_free(s);
    }
}

static void test_camera_values(void)
{
    Scene *s = load("PerspectiveCamera { center 1 2 3 direction 0 0 -5 up 0 2 0 angle 90 }");
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK(s->has_camera);
    CHECK(s->camera.kind == CAMERA_PERSPECTIVE);
    CHECK_NEAR(s->camera.angle, M_PI / 2, 1e-6);
    CHECK_NEAR(s->camera.direction.z, -1, 1e-7);
    CHECK_NEAR(s->camera.up.y, 1, 1e-7);
    CHECK_NEAR(s->camera.center.z, 3, 0);
    scene_free(s);
    /* A second camera replaces the first. */
    char buf[1024];
    snprintf(buf, sizeof buf,
             "PerspectiveCamera { center 1 2 3 direction 0 0 -5 up 0 2 0 angle 90 }\n%s", k_cam);
    s = load(buf);
    CHECK(s != NULL);
    if (s) {
        CHECK(s->camera.kind == CAMERA_ORTHOGRAPHIC);
        CHECK_NEAR(s->camera.size, 5, 0);
        scene_free(s);
    }
}

static const Mat4 *first_xf(const Scene *s)
{
    const Object3D *o = group_child(s->root, 0);
    return obj_kind(o) == OBJ_TRANSFORM ? transform_matrix(o) : NULL;
}

static void test_transform_order(void)
{
    const char *mats = "Materials { numMaterials 1 PhongMaterial { } }\n";
    char buf[2048];
    /* Transforms apply last-written first: Translate then Scale = scale about the origin,
     * then move +1 x. */
    snprintf(buf, sizeof buf,
             "%sGroup { numObjects 1 MaterialIndex 0 Transform { Translate 1 0 0 Scale 2 2 2 "
             "Sphere { center 0 0 0 radius 1 } } }", mats);
    Scene *s = load(buf);
    CHECK(s != NULL);
    if (s) {
        const Mat4 *m = first_xf(s);
        CHECK(m != NULL);
        if (m) {
            Vec3 p = mat4_point(m, v3(1, 0, 0));
            CHECK_NEAR(p.x, 3, 1e-6);
            CHECK_NEAR(m->m[0][0], 2, 0);
            CHECK_NEAR(m->m[0][3], 1, 0);
        }
        /* The object's box in world space: x in [-1, 3]. */
        CHECK_NEAR(s->bounds.min.x, -1, 1e-5);
        CHECK_NEAR(s->bounds.max.x, 3, 1e-5);
        scene_free(s);
    }
    /* Matrix left-multiplies: Translate 1, then Matrix(scale 2) gives S * T. */
    snprintf(buf, sizeof buf,
             "%sGroup { numObjects 1 MaterialIndex 0 Transform { Translate 1 0 0 "
             "Matrix { 2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1 } Sphere { center 0 0 0 radius 1 } } }",
             mats);
    s = load(buf);
    CHECK(s != NULL);
    if (s) {
        const Mat4 *m = first_xf(s);
        if (m) {
            CHECK_NEAR(m->m[0][3], 2, 0);
            CHECK_NEAR(m->m[0][0], 2, 0);
        }
        scene_free(s);
    }
    /* Matrix first (row by row: translation in numbers 4, 8, 12), then Scale on the right. */
    snprintf(buf, sizeof buf,
             "%sGroup { numObjects 1 MaterialIndex 0 Transform { "
             "Matrix { 1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1 } Scale 2 3 4 "
             "Sphere { center 0 0 0 radius 1 } } }", mats);
    s = load(buf);
    CHECK(s != NULL);
    if (s) {
        const Mat4 *m = first_xf(s);
        if (m) {
            Vec3 p = mat4_point(m, v3(1, 1, 1));
            CHECK_NEAR(p.x, 7, 1e-6);
            CHECK_NEAR(p.y, 9, 1e-6);
            CHECK_NEAR(p.z, 11, 1e-6);
        }
        scene_free(s);
    }
    /* Rotations in degrees, right-handed; Rotate { axis angle }; UniformScale; empty list. */
    snprintf(buf, sizeof buf,
             "%sGroup { numObjects 4 MaterialIndex 0 "
             "Transform { XRotate 90 Sphere { center 0 0 0 radius 1 } }\n"
             "Transform { Rotate { 0 0 1 90 } Sphere { center 0 0 0 radius 1 } }\n"
             "Transform { UniformScale 3 YRotate 90 Sphere { center 0 0 0 radius 1 } }\n"
             "Transform { Sphere { center 0 0 0 radius 1 } } }", mats);
    s = load(buf);
    CHECK(s != NULL);
    if (s) {
        const Mat4 *m = transform_matrix(group_child(s->root, 0));
        Vec3 p = mat4_point(m, v3(0, 1, 0));
        CHECK_NEAR(p.z, 1, 1e-6);
        CHECK_NEAR(p.y, 0, 1e-6);
        m = transform_matrix(group_child(s->root, 1));
        p = mat4_point(m, v3(1, 0, 0));
        CHECK_NEAR(p.y, 1, 1e-6);
        m = transform_matrix(group_child(s->root, 2));
        p = mat4_point(m, v3(0, 0, 1));
        CHECK_NEAR(p.x, 3, 1e-6);
        m = transform_matrix(group_child(s->root, 3));
        CHECK_NEAR(m->m[0][0], 1, 0);
        CHECK_NEAR(m->m[1][3], 0, 0);
        scene_free(s);
    }
}

static void test_material_index_state(void)
{
    const char *text =
        "Materials { numMaterials 3 PhongMaterial { } PhongMaterial { } PhongMaterial { } }\n"
        "Group { numObjects 3 MaterialIndex 1\n"
        "  Group { numObjects 1 MaterialIndex 2 Sphere { center 0 0 0 radius 1 } }\n"
        "  Sphere { center 0 0 0 radius 1 }\n"          /* not restored: still 2 */
        "  Transform { Translate 1 0 0 Sphere { center 0 0 0 radius 1 } } }\n"
        "Group { numObjects 1 Sphere { center 5 0 0 radius 1 } }\n"; /* carries over */
    Scene *s = load(text);
    CHECK(s != NULL);
    if (!s)
        return;
    /* The second Group replaced the first as root, its sphere still uses material 2. */
    CHECK_INT(group_count(s->root), 1);
    CHECK(group_child(s->root, 0)->material == s->materials[2]);
    CHECK_INT(s->num_primitives, 1);
    CHECK_NEAR(s->bounds.min.x, 4, 0);
    scene_free(s);

    s = load("Materials { numMaterials 3 PhongMaterial { } PhongMaterial { } PhongMaterial { } }\n"
             "Group { numObjects 3 MaterialIndex 1\n"
             "  Group { numObjects 1 MaterialIndex 2 Sphere { center 0 0 0 radius 1 } }\n"
             "  Sphere { center 0 0 0 radius 1 }\n"
             "  Transform { Translate 1 0 0 Sphere { center 0 0 0 radius 1 } } }\n");
    CHECK(s != NULL);
    if (!s)
        return;
    const Object3D *inner = group_child(s->root, 0);
    CHECK(group_child(inner, 0)->material == s->materials[2]);
    CHECK(group_child(s->root, 1)->material == s->materials[2]);
    CHECK(transform_child(group_child(s->root, 2))->material == s->materials[2]);
    /* Depth-first ids 0..2. */
    CHECK_INT(s->num_primitives, 3);
    CHECK_INT(group_child(inner, 0)->id, 0);
    CHECK_INT(group_child(s->root, 1)->id, 1);
    CHECK_INT(transform_child(group_child(s->root, 2))->id, 2);
    scene_free(s);
}

static void test_procedural_materials(void)
{
    Scene *s = load("Materials { numMaterials 6\n"
                    "PhongMaterial { diffuseColor 1 0 0 }\n"
                    "PhongMaterial { diffuseColor 0 0 1 }\n"
                    "Checkerboard { Transform { UniformScale 2 } materialIndex 0 materialIndex 1 }\n"
                    "Noise { materialIndex 2 materialIndex 0 octaves 0 }\n"
                    "Marble { Transform { } materialIndex 0 materialIndex 3 octaves 4 frequency 5 amplitude 3 }\n"
                    "Wood { materialIndex 4 materialIndex 1 octaves 3 frequency 6 amplitude 2 } }");
    CHECK_MSG(s != NULL, "%s", g_diag.last);
    if (!s)
        return;
    CHECK_STR(s->materials[2]->ops->type_name, "Checkerboard");
    CHECK_STR(s->materials[3]->ops->type_name, "Noise");
    CHECK_STR(s->materials[4]->ops->type_name, "Marble");
    CHECK_STR(s->materials[5]->ops->type_name, "Wood");
    /* Checkerboard with UniformScale 2: texture point = 2 * world point; cells of size 1
     * in texture space. diffuse_at picks one of the two children's colours. */
    Vec3 a = mat_diffuse_at(s->materials[2], v3(0.1f, 0.1f, 0.1f));
    Vec3 b = mat_diffuse_at(s->materials[2], v3(0.6f, 0.1f, 0.1f));
    CHECK(a.x != b.x);
    scene_free(s);
}

static void test_repeated_blocks_replace(void)
{
    Scene *s = load("Lights { numLights 1 DirectionalLight { direction 0 -1 0 color 1 1 1 } }\n"
                    "Lights { numLights 2 DirectionalLight { direction 0 -1 0 color 1 0 0 }\n"
                    "  DirectionalLight { direction 0 -1 0 color 0 1 0 } }\n"
                    "Materials { numMaterials 1 PhongMaterial { } }\n"
                    "Materials { numMaterials 2 PhongMaterial { } PhongMaterial { exponent 3 } }\n"
                    "Background { color 1 1 1 } Background { ambientLight 0.5 0.5 0.5 }");
    CHECK(s != NULL);
    if (!s)
        return;
    CHECK_INT(s->num_lights, 2);
    CHECK_NEAR(s->lights[1].color.y, 1, 0);
    CHECK_INT(s->num_materials, 2);
    CHECK_NEAR(s->background.x, 1, 0); /* Background entries update, not reset */
    CHECK_NEAR(s->ambient.x, 0.5, 0);
    scene_free(s);
}

/* A second top-level block of a kind replaces the first (above) and gets a located
 * warning naming the line of the first; a single block of each kind gets none. */
static void test_repeated_blocks_warn(void)
{
    static const char text[] =
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Background { color 1 1 1 }\n"
        "Lights { numLights 0 }\n"
        "Materials { numMaterials 1 PhongMaterial { } }\n"
        "Group { numObjects 0 }\n"
        "  PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }\n"
        "Background { ambientLight 0.5 0.5 0.5 }\n"
        "Lights { numLights 0 }\n"
        "Materials { numMaterials 1 PhongMaterial { } }\n"
        "Group { numObjects 0 } Group { numObjects 0 }\n";
    char out[2048];
    Diag d;
    Scene *sc = load_capture(text, &d, out, sizeof out);
    CHECK(sc != NULL);
    CHECK(sc && sc->camera.kind == CAMERA_PERSPECTIVE);
    scene_free(sc);
    CHECK_INT(d.errors, 0);
    CHECK_INT(d.warnings, 6);
    CHECK_CONTAINS(out, "t.txt:6:3: warning: a second camera (PerspectiveCamera): it overrides "
                        "the OrthographicCamera at line 1\n");
    CHECK_CONTAINS(out, "t.txt:7:1: warning: a second Background block: it overrides the one "
                        "at line 2");
    CHECK_CONTAINS(out, "t.txt:8:1: warning: a second Lights block: it overrides the one at "
                        "line 3\n");
    CHECK_CONTAINS(out, "t.txt:9:1: warning: a second Materials block: it overrides the one "
                        "at line 4 for Groups after it (the Group at line 5 keeps its "
                        "materials)\n");
    CHECK_CONTAINS(out, "t.txt:10:1: warning: a second Group block: it overrides the one at "
                        "line 5\n");
    CHECK_CONTAINS(out, "t.txt:10:24: warning: a second Group block: it overrides the one at "
                        "line 5\n");
    /* one block of each kind: no warning */
    Scene *one = load("OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
                      "Background { color 1 1 1 } Lights { numLights 0 }\n"
                      "Materials { numMaterials 1 PhongMaterial { } } Group { numObjects 0 }\n");
    CHECK(one != NULL);
    scene_free(one);
    CHECK_INT(g_diag.warnings, 0);
}

/* Rotate's axis is used as written, like the course's Rodrigues matrix (an axis of
 * length 2 doubles the object along it: not normalised), and an axis that is not of
 * length 1 (beyond 1e-3) gets a located warning naming the unit axis, in an object's
 * Transform and in a texture's alike; unit axes, written to 6 digits or exactly, get
 * none. */
static void test_rotate_axis_as_given(void)
{
    static const char text[] =
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Materials { numMaterials 3 PhongMaterial { } PhongMaterial { }\n"
        "  Checkerboard { Transform { Rotate { 3 0 0 10 } } materialIndex 0 materialIndex 1 } }\n"
        "Group { numObjects 3 MaterialIndex 0\n"
        "  Transform { Rotate { 0 0 2 90 } Sphere { center 0 0 0 radius 1 } }\n"
        "  Transform { Rotate { 0.707107 0.707107 0 35 } Sphere { center 0 0 0 radius 1 } }\n"
        "  Transform { Rotate { 0 1 0 30 } Sphere { center 0 0 0 radius 1 } } }\n";
    char out[2048];
    Diag d;
    Scene *s = load_capture(text, &d, out, sizeof out);
    CHECK(s != NULL);
    if (s) {
        /* cos 90 = 0, sin 90 = 1: (1 0 0) -> (0 2 0), and the axis (0 0 1) -> (0 0 4). */
        const Mat4 *m = transform_matrix(group_child(s->root, 0));
        Vec3 x = mat4_point(m, v3(1, 0, 0)), z = mat4_point(m, v3(0, 0, 1));
        CHECK_NEAR(x.x, 0, 1e-6);
        CHECK_NEAR(x.y, 2, 1e-6);
        CHECK_NEAR(z.z, 4, 1e-6);
    }
    scene_free(s);
    CHECK_INT(d.errors, 0);
    CHECK_INT(d.warnings, 2);
    CHECK_CONTAINS(out, "t.txt:3:39: warning: Rotate axis 3 0 0 has length 3, not 1: it is "
                        "used as given (the course's rule), which stretches the object as "
                        "well as turning it; for a pure rotation write the unit axis 1 0 0\n");
    CHECK_CONTAINS(out, "t.txt:5:24: warning: Rotate axis 0 0 2 has length 2, not 1");
}

static void test_primitives_values(void)
{
    Scene *s = load("Materials { numMaterials 1 PhongMaterial { } }\n"
                    "Group { numObjects 3 MaterialIndex 0\n"
                    "Sphere { center 1 2 3 radius 0.5 }\n"
                    "Plane { normal 0 1 0 offset -2 }\n"
                    "Triangle { vertex0 0 0 0 vertex1 1 0 0 vertex2 0 1 0 } }");
    CHECK(s != NULL);
    if (!s)
        return;
    const Object3D *sp = group_child(s->root, 0);
    CHECK(obj_kind(sp) == OBJ_SPHERE);
    CHECK_NEAR(sphere_center(sp).z, 3, 0);
    CHECK_NEAR(sphere_radius(sp), 0.5, 0);
    CHECK_NEAR(plane_normal(group_child(s->root, 1)).y, 1, 0);
    CHECK_NEAR(plane_offset(group_child(s->root, 1)), -2, 0);
    Vec3 v[3];
    triangle_vertices(group_child(s->root, 2), v);
    CHECK_NEAR(v[1].x, 1, 0);
    CHECK_NEAR(v[2].y, 1, 0);
    CHECK_INT(s->num_primitives, 3);
    CHECK_NEAR(s->bounds.min.x, 0, 0);
    CHECK_NEAR(s->bounds.max.z, 3.5, 0);
    scene_free(s);
    /* Only planes: no bounds. */
    s = load("Materials { numMaterials 1 PhongMaterial { } }\n"
             "Group { numObjects 1 MaterialIndex 0 Plane { normal 0 1 0 offset 0 } }");
    CHECK(s != NULL);
    if (s) {
        CHECK(bbox_is_empty(&s->bounds));
        scene_free(s);
    }
    /* numObjects 0 is an empty group. */
    s = load("Group { numObjects 0 }");
    CHECK(s != NULL);
    if (s) {
        CHECK(s->root != NULL);
        CHECK_INT(s->num_primitives, 0);
        scene_free(s);
    }
}

/* ---- obj_file resolution ------------------------------------------------------------ */

static char g_tmp[256];

static void make_tmp(void)
{
    snprintf(g_tmp, sizeof g_tmp, "/tmp/rt_parser_XXXXXX");
    CHECK(mkdtemp(g_tmp) != NULL);
}

static void write_file(const char *path, const char *text)
{
    FILE *f = fopen(path, "wb");
    CHECK(f != NULL);
    if (f) {
        fputs(text, f);
        fclose(f);
    }
}

static void test_obj_file_resolution(void)
{
    make_tmp();
    char sub[512], obj[600], scene[600];
    snprintf(sub, sizeof sub, "%s/sc", g_tmp);
    mkdir(sub, 0700);
    snprintf(obj, sizeof obj, "%s/quad.obj", sub);
    write_file(obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n");
    snprintf(scene, sizeof scene, "%s/s.txt", sub);
    write_file(scene, "Materials { numMaterials 2 PhongMaterial { } PhongMaterial { } }\n"
                      "Group { numObjects 2 MaterialIndex 1 TriangleMesh { obj_file quad.obj }\n"
                      "Sphere { center 0 0 0 radius 1 } }\n");
    /* Run from elsewhere: the scene's folder is searched first. */
    Diag d;
    diag_init(&d, NULL);
    Scene *s = scene_load(scene, &d);
    CHECK_MSG(s != NULL, "%s", d.last);
    if (s) {
        const Object3D *mesh = group_child(s->root, 0);
        CHECK_INT(group_count(mesh), 2); /* quad fanned into 2 triangles */
        CHECK(group_child(mesh, 0)->material == s->materials[1]);
        CHECK(group_child(mesh, 1)->material == s->materials[1]);
        CHECK_INT(s->num_primitives, 3);
        scene_free(s);
    }
    /* Any file name is accepted for obj_file (not only *.obj); the content decides. */
    char dat[700];
    snprintf(dat, sizeof dat, "%s/quad.dat", sub);
    write_file(dat, "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file quad.dat } }",
                          "str", sub, &d);
    CHECK_MSG(s != NULL, "%s", d.last);
    if (s)
        CHECK_INT(s->num_primitives, 1);
    scene_free(s);
    /* scene_load_string: base_dir, then the working directory. */
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file quad.obj } }",
                          "str.txt", sub, &d);
    CHECK_MSG(s != NULL, "%s", d.last);
    scene_free(s);
    char cwd[4096];
    CHECK(getcwd(cwd, sizeof cwd) != NULL);
    CHECK(chdir(sub) == 0);
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file quad.obj } }",
                          "str.txt", "/nonexistent-dir", &d);
    CHECK_MSG(s != NULL, "%s", d.last);
    scene_free(s);
    CHECK(chdir(cwd) == 0);
    /* Not found: every tried path named. */
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0\n  TriangleMesh { obj_file nope.obj } }",
                          "str.txt", "some/dir", &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "str.txt:3:27: error: cannot open OBJ file 'nope.obj' "
                           "(tried 'some/dir/nope.obj', 'nope.obj')");
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file nope.obj } }",
                          "str.txt", NULL, &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "cannot open OBJ file 'nope.obj' (tried 'nope.obj')");
    CHECK(strstr(d.last, "quotes") == NULL);
    /* A quoted name (other formats quote them) and a name with a space (cut at it):
     * each message says what to write instead. */
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file \"a.obj\" } }",
                          "str.txt", "some/dir", &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "str.txt:2:62: error: cannot open OBJ file '\"a.obj\"' (tried "
                           "'some/dir/\"a.obj\"', '\"a.obj\"'): No such file or directory (file "
                           "names are written without quotes)");
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file my model.obj } }",
                          "str.txt", NULL, &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "str.txt:2:65: error: expected '}', found 'model.obj' (an OBJ file "
                           "name is one word: it cannot contain white space)");
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file a.obj #c } }",
                          "str.txt", NULL, &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "str.txt:2:68: error: expected '}', found '#c' (scene files have no "
                           "comments)");
    /* Errors inside the OBJ file are located in it. */
    snprintf(obj, sizeof obj, "%s/bad.obj", sub);
    write_file(obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\nf 1 2 7\n");
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file bad.obj } }",
                          "str.txt", sub, &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "/sc/bad.obj:5:7: error: vertex index 7 out of range (3 vertices)");
    /* A file of lone CRs (classic Mac OS line ends) that begins with a comment, as
     * exporters begin theirs, is that one comment to the OBJ reader: 'has no faces'
     * says why. A file of LF lines with a CR at its very end gets no such word. */
    snprintf(obj, sizeof obj, "%s/mac.obj", sub);
    write_file(obj, "# exported\rv 0 0 0\rv 1 0 0\rv 1 1 0\rf 1 2 3\r");
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file mac.obj } }",
                          "str.txt", sub, &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "str.txt:2:62: error: OBJ file 'mac.obj' has no faces (a lone CR ends "
                           "no line: give the file LF or CR LF line ends)");
    write_file(obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\n# no face\r");
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file mac.obj } }",
                          "str.txt", sub, &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "str.txt:2:62: error: OBJ file 'mac.obj' has no faces");
    CHECK(strstr(d.last, "lone CR") == NULL);
    /* Columns count characters: a file name of 2-, 3- and 4-byte characters (6 bytes
     * more than characters) before the error's token on its line shifts it by none. */
    snprintf(obj, sizeof obj, "%s/caf\xC3\xA9\xE2\x86\x92\xF0\x9F\x98\x80.obj", sub);
    write_file(obj, "v 0 0 0\nv 1 0 0\nv 1 1 0\nf 1 2 3\n");
    diag_init(&d, NULL);
    s = scene_load_string("Materials { numMaterials 1 PhongMaterial { } }\n"
                          "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file "
                          "caf\xC3\xA9\xE2\x86\x92\xF0\x9F\x98\x80.obj } Sphere { } }",
                          "str.txt", sub, &d);
    CHECK(s == NULL);
    CHECK_CONTAINS(d.last, "str.txt:2:75: error: ");
    /* A missing scene file. */
    char missing[600];
    snprintf(missing, sizeof missing, "%s/none.txt", g_tmp);
    diag_init(&d, NULL);
    CHECK(scene_load(missing, &d) == NULL);
    CHECK_CONTAINS(d.last, "none.txt: error: cannot open scene file: No such file or directory");
    diag_init(&d, NULL);
    CHECK(scene_load(g_tmp, &d) == NULL); /* a directory */
    CHECK_CONTAINS(d.last, "error: cannot open scene file: Is a directory");
    /* An endless input is refused, not read until memory runs out. */
    diag_init(&d, NULL);
    CHECK(scene_load("/dev/zero", &d) == NULL);
    CHECK_CONTAINS(d.last, "/dev/zero: error: cannot open scene file: File too large");
    char cmd[700];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", g_tmp);
    CHECK(system(cmd) == 0);
    CHECK_NO_LEAKS();
}

/* ---- located errors ----------------------------------------------------------------- */

static void test_errors_located(void)
{
    EXPECT_ERROR("Sphre", "t.txt:1:1: error: unknown top-level block 'Sphre'");
    EXPECT_ERROR("\n\n  Foo {", "t.txt:3:3: error: unknown top-level block 'Foo'");
    EXPECT_ERROR("# comment", "t.txt:1:1: error: unknown top-level block '#'");
    EXPECT_ERROR("Background {\n color 1 1 1\n", "t.txt:3:1: error: unexpected end of file, expected '}'");
    /* Line ends as an editor counts them: LF, CR LF, and a lone CR (classic Mac OS),
     * which was a column, so such a file was line 1 in every message. */
    EXPECT_ERROR("Background {\r\n color 1 1 1\r\n colour", "t.txt:3:2: error: unknown Background field");
    EXPECT_ERROR("Background {\r color 1 1 1\r colour", "t.txt:3:2: error: unknown Background field");
    EXPECT_ERROR("Background {\r\r\n\n colour", "t.txt:4:2: error: unknown Background field");
    EXPECT_ERROR("Background {\r color 1 1 1\r", "t.txt:3:1: error: unexpected end of file, expected '}'");
    EXPECT_ERROR("Background {\tcolour 1 1 1 }", "t.txt:1:14: error: unknown Background field 'colour'");
    EXPECT_ERROR("Background { color 1 1 }", "t.txt:1:24: error: expected a number, found '}'");
    EXPECT_ERROR("Background { color 1 1 nan }", "t.txt:1:24: error: number out of range: 'nan'");
    EXPECT_ERROR("Background { color 1 1 -inf }", "number out of range: '-inf'");
    EXPECT_ERROR("Background { color 1 1 1e999 }", "t.txt:1:24: error: number out of range: '1e999'");
    EXPECT_ERROR("Background { color 1 1 1,5 }", "expected a number, found '1,5'");
    EXPECT_ERROR("Background{ color 1 1 1 }", "unknown top-level block 'Background{'");
    EXPECT_ERROR("OrthographicCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 siz 1 }",
                 "t.txt:1:61: error: expected 'size', found 'siz'");
    EXPECT_ERROR("OrthographicCamera { center 0 0 0 up 0 1 0 direction 0 0 -1 size 1 }",
                 "t.txt:1:35: error: expected 'direction', found 'up'");
    EXPECT_ERROR("OrthographicCamera { center 0 0 0 direction 0 0 0 up 0 1 0 size 1 }",
                 "t.txt:1:35: error: camera direction is zero");
    EXPECT_ERROR("OrthographicCamera { center 0 0 0 direction 0 0 -1 up 0 0 1 size 1 }",
                 "t.txt:1:52: error: degenerate camera: up is zero or parallel to direction");
    EXPECT_ERROR("OrthographicCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 size 0 }",
                 "t.txt:1:61: error: size must be positive, found 0");
    EXPECT_ERROR("PerspectiveCamera { center 0 0 0 direction 0 0 -1 up 0 1 0 angle 180 }",
                 "t.txt:1:60: error: angle must be more than 0 and less than 180 degrees, found 180");
    EXPECT_ERROR("Lights { numLights 2.0 }", "t.txt:1:20: error: expected an integer, found '2.0'");
    EXPECT_ERROR("Lights { numLights -1 }", "t.txt:1:20: error: numLights must be between 0 and 10000000, found -1");
    EXPECT_ERROR("Lights { numLights 99999999999 }", "number out of range: '99999999999'");
    EXPECT_ERROR("Lights { numLights 20000000 }", "numLights must be between 0 and 10000000, found 20000000");
    EXPECT_ERROR("Lights { numLights 2 DirectionalLight { direction 0 -1 0 color 1 1 1 } }",
                 "t.txt:1:72: error: numLights is 2 but the Lights block ends after 1 light");
    EXPECT_ERROR("Lights { numLights 1 DirectionalLight { direction 0 -1 0 color 1 1 1 }\n"
                 "PointLight { position 0 0 0 color 1 1 1 } }",
                 "t.txt:2:1: error: numLights is 1 but more lights follow");
    EXPECT_ERROR("Lights { numLights 1 SpotLight { } }", "t.txt:1:22: error: unknown light 'SpotLight'");
    EXPECT_ERROR("Lights { numLights 1 DirectionalLight { direction 0 0 0 color 1 1 1 } }",
                 "t.txt:1:41: error: light direction is zero");
    EXPECT_ERROR("Lights { numLights 1 PointLight { position 0 0 0 color 1 1 1 attenuation 1 0 } }",
                 "expected a number, found '}'");
    EXPECT_ERROR("Lights { numLights 1 PointLight { position 0 0 0 color 1 1 1 falloff 1 } }",
                 "t.txt:1:62: error: expected 'attenuation' or '}', found 'falloff'");
    EXPECT_ERROR("Materials { numMaterials 1 Phong { } }", "t.txt:1:28: error: unknown material 'Phong'");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { shininess 3 } }",
                 "t.txt:1:44: error: unknown PhongMaterial field 'shininess'");
    EXPECT_ERROR("Materials { numMaterials 1 Checkerboard { materialIndex 0 materialIndex 0 } }",
                 "t.txt:1:57: error: materialIndex 0 out of range");
    EXPECT_ERROR("Materials { numMaterials 3 PhongMaterial { } PhongMaterial { }\n"
                 "Checkerboard { materialIndex 0 materialIndex 2 } }",
                 "t.txt:2:46: error: materialIndex 2 out of range (only earlier materials 0..1 may be used)");
    EXPECT_ERROR("Materials { numMaterials 2 PhongMaterial { }\n"
                 "Noise { materialIndex 0 materialIndex 0 octaves 1.5 } }",
                 "t.txt:2:49: error: expected an integer, found '1.5'");
    EXPECT_ERROR("Materials { numMaterials 2 PhongMaterial { }\n"
                 "Noise { materialIndex 0 materialIndex 0 octaves 1000 } }",
                 "octaves must be between 0 and 32, found 1000");
    EXPECT_ERROR("Materials { numMaterials 2 PhongMaterial { }\n"
                 "Marble { materialIndex 0 materialIndex 0 octaves 1 amplitude 1 frequency 1 } }",
                 "t.txt:2:52: error: expected 'frequency', found 'amplitude'");
    EXPECT_ERROR("Materials { numMaterials 2 PhongMaterial { }\n"
                 "Wood { Transform { Scale 1 1 1 Sphere } materialIndex 0 materialIndex 0 octaves 1 frequency 1 amplitude 1 } }",
                 "t.txt:2:32: error: expected a transformation or '}', found 'Sphere'");
    EXPECT_ERROR("Group { numObjects 1 Sphere { center 0 0 0 radius 1 } }",
                 "t.txt:1:22: error: no material selected for Sphere (MaterialIndex missing)");
    EXPECT_ERROR("Materials { numMaterials 3 PhongMaterial { } PhongMaterial { } PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 5 }",
                 "t.txt:2:36: error: MaterialIndex 5 out of range (3 materials)");
    EXPECT_ERROR("Group { numObjects 1 MaterialIndex 0 }", "MaterialIndex 0 out of range (0 materials: "
                 "a Materials block must come before the Group)");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 3 MaterialIndex 0\nSphere { center 0 0 0 radius 1 }\n"
                 "Sphere { center 0 0 0 radius 1 }\n}",
                 "t.txt:5:1: error: numObjects is 3 but the group ends after 2 objects");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\nSphere { center 0 0 0 radius 1 }\n"
                 "Sphere { center 0 0 0 radius 1 }\n}",
                 "t.txt:4:1: error: numObjects is 1 but the group has more objects");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0 Sphre { center 0 0 0 radius 1 } }",
                 "t.txt:2:38: error: unknown object 'Sphre'");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radus 1 } }",
                 "t.txt:2:60: error: expected 'radius', found 'radus'");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius -1 } }",
                 "t.txt:2:60: error: Sphere radius must not be negative, found -1");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0 Plane { normal 0 0 0 offset 1 } }",
                 "t.txt:2:46: error: Plane normal is zero");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { Scale 0 0 0 Sphere { center 0 0 0 radius 1 } } }",
                 "t.txt:3:1: error: singular transformation (the matrix has no inverse)");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { Scale 1 1 1 } }",
                 "t.txt:3:25: error: Transform has no object");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { Sphere { center 0 0 0 radius 1 } Sphere { center 0 0 0 radius 1 } } }",
                 "t.txt:3:46: error: a Transform holds exactly one object");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { Rotate 0 0 1 90 Sphere { center 0 0 0 radius 1 } } }",
                 "t.txt:3:20: error: expected '{', found '0'");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { Matrix { 1 0 0 0 0 1 0 0 0 0 1 0 0 0 1 1 } Sphere { center 0 0 0 radius 1 } } }",
                 "t.txt:3:13: error: Matrix must be affine");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { UniformScale 1e30 UniformScale 1e30 Sphere { center 0 0 0 radius 1 } } }",
                 "t.txt:3:31: error: transformation overflows");
    EXPECT_ERROR("Group { numObjects 1 MaterialIndex 0 ", "MaterialIndex 0 out of range");
    EXPECT_ERROR("Group { numObjects 1 ", "t.txt:1:22: error: unexpected end of file, expected '}'");
    EXPECT_ERROR("Group {", "t.txt:1:8: error: unexpected end of file, expected 'numObjects'");
    EXPECT_ERROR("Group { numObjects", "t.txt:1:19: error: unexpected end of file, expected an integer");
    EXPECT_ERROR("Group { numObjects 1 MaterialIndex", "unexpected end of file, expected an integer");
    CHECK_NO_LEAKS();
}

/* Transforms at the parser's limits. A translation never makes a matrix singular: it
 * used to count in mat4_inverse's relative pivot test, so "Translate 2e12 0 0" was
 * refused ("too extreme to invert: its scale factors span 1..1", while a Sphere at
 * x = 2e12 is fine); now it parses and the sphere is there. Scale factors too far
 * apart, or too large, are still refused with a message that says the rule (1e-7
 * and 1e6 were both "within 1e-12..1e12" of the old message), and an inverse whose
 * translation overflows float says so. */
static void test_transform_limits(void)
{
    static const char *const far[] = {"Translate 2e12 0 0", "Translate 1e13 0 0 UniformScale 1e3",
                                      "YRotate 30 Translate 0 0 -1e15"};
    for (int i = 0; i < 3; i++) {
        char text[512];
        snprintf(text, sizeof text,
                 "Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { %s Sphere { center 0 0 0 radius 1 } } }", far[i]);
        Scene *s = load(text);
        CHECK_MSG(s != NULL, "'%s': %s", far[i], g_diag.last);
        CHECK(!s || s->root != NULL);
        scene_free(s);
    }
    Scene *s = load("Materials { numMaterials 1 PhongMaterial { } }\n"
                    "Group { numObjects 1 MaterialIndex 0\n"
                    "Transform { Translate 2e12 0 0 Sphere { center 0 0 0 radius 1 } } }");
    CHECK(s && fabsf(s->root->bbox.min.x - 2e12f) <= 2e12f * 1e-6f);
    scene_free(s);
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { Scale 1e-7 1e6 1 Sphere { center 0 0 0 radius 1 } } }",
                 "t.txt:3:1: error: transformation too extreme to invert in float precision: "
                 "its scale factors span 1e-07..1e+06 (keep them within 1e-12..1e12, the "
                 "smallest more than 1e-12 times the largest)");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { UniformScale 2e12 Sphere { center 0 0 0 radius 1 } } }",
                 "t.txt:3:1: error: transformation too extreme to invert in float precision: "
                 "its scale factors span 2e+12..2e+12");
    EXPECT_ERROR("Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "Transform { Translate 3e38 0 0 UniformScale 0.5 Sphere { center 0 0 0 radius 1 } } }",
                 "t.txt:3:1: error: transformation too extreme to invert in float precision: "
                 "undoing its translation overflows float (scale factors 0.5..0.5)");
    CHECK_NO_LEAKS();
}

static void test_errors_limits(void)
{
    /* Nesting: RT_MAX_NESTING groups are fine, one more is not. */
    size_t cap = 64 * 1024;
    char *buf = malloc(cap);
    for (int depth = RT_MAX_NESTING; depth <= RT_MAX_NESTING + 1; depth++) {
        size_t o = (size_t)snprintf(buf, cap, "Materials { numMaterials 1 PhongMaterial { } }\n");
        for (int i = 0; i < depth; i++)
            o += (size_t)snprintf(buf + o, cap - o, "Group { numObjects 1 %s\n",
                                  i == 0 ? "MaterialIndex 0" : "");
        o += (size_t)snprintf(buf + o, cap - o, "Sphere { center 0 0 0 radius 1 }\n");
        for (int i = 0; i < depth; i++)
            o += (size_t)snprintf(buf + o, cap - o, "}\n");
        Scene *s = load(buf);
        if (depth == RT_MAX_NESTING) {
            CHECK_MSG(s != NULL, "%s", g_diag.last);
            if (s)
                CHECK_INT(s->num_primitives, 1);
        } else {
            CHECK(s == NULL);
            CHECK_CONTAINS(g_diag.last, "t.txt:66:1: error: objects nested deeper than 64 levels");
        }
        scene_free(s);
    }
    /* 10000 nested groups: an error, not a stack overflow. */
    cap = 25 * 10000 + 1000;
    buf = realloc(buf, cap);
    size_t o = 0;
    for (int i = 0; i < 10000; i++)
        o += (size_t)snprintf(buf + o, cap - o, "Group { numObjects 1 ");
    EXPECT_ERROR(buf, "objects nested deeper than 64 levels");
    /* A long chain of procedural materials. */
    cap = 200000;
    buf = realloc(buf, cap);
    o = (size_t)snprintf(buf, cap, "Materials { numMaterials 101 PhongMaterial { }\n");
    for (int i = 1; i <= 100; i++)
        o += (size_t)snprintf(buf + o, cap - o,
                              "Checkerboard { materialIndex %d materialIndex 0 }\n", i - 1);
    snprintf(buf + o, cap - o, "}");
    EXPECT_ERROR(buf, "t.txt:65:1: error: procedural materials nested deeper than 64 levels");
    /* Token length limit. */
    memset(buf, 'x', 5000);
    buf[5000] = '\0';
    EXPECT_ERROR(buf, "t.txt:1:1: error: token too long (5000 characters, the limit is 4096)");
    /* Long but legal number tokens are still numbers. */
    o = (size_t)snprintf(buf, cap, "Background { color 0.");
    memset(buf + o, '0', 3000);
    o += 3000;
    snprintf(buf + o, cap - o, "5 0 0 }");
    Scene *s = load(buf);
    CHECK_MSG(s != NULL, "%s", g_diag.last);
    scene_free(s);
    /* Control bytes are refused where they are; other bytes are shown escaped. */
    EXPECT_ERROR("\x01\x02\xff", "t.txt:1:1: error: control byte \\x01 in the scene");
    EXPECT_ERROR("Group\x7f {", "t.txt:1:6: error: control byte \\x7f in the scene");
    EXPECT_ERROR("\xfe\xff", "t.txt:1:1: error: unknown top-level block '\\xfe\\xff'");
    /* Columns count characters (gcc's and an editor's column), not bytes: after "Gruß"
     * (5 bytes) the control byte is at column 5; a byte that begins no character (a
     * stray continuation byte, a sequence cut short) is one. */
    EXPECT_ERROR("Gru\xC3\x9F\x01", "t.txt:1:5: error: control byte \\x01 in the scene");
    EXPECT_ERROR("\x80\xC3\xE2\x86\xF0\x9F\x98\x80\x01",
                 "t.txt:1:6: error: control byte \\x01 in the scene");
    EXPECT_ERROR("Background { color 0 0 \xE2\x86\x92\x01",
                 "t.txt:1:25: error: control byte \\x01 in the scene");
    /* A UTF-8 byte-order mark at the start is skipped (columns from the character
     * after it); anywhere else it is an unknown word like any other. */
    EXPECT_ERROR("\xEF\xBB\xBF" "Foo {", "t.txt:1:1: error: unknown top-level block 'Foo'");
    EXPECT_ERROR("\xEF\xBB\xBF" "Background { colour",
                 "t.txt:1:14: error: unknown Background field 'colour'");
    EXPECT_ERROR("\xEF\xBB\xBF" "\xC3\xA9\x01", "t.txt:1:2: error: control byte \\x01");
    EXPECT_ERROR("\xEF\xBB\xBF" "Background { color 0 0 0 }\n\xEF\xBB\xBF",
                 "t.txt:2:1: error: unknown top-level block '\\xef\\xbb\\xbf'");
    s = load("\xEF\xBB\xBF" "Background { color 0.25 0.5 1 }");
    CHECK_MSG(s != NULL, "%s", g_diag.last);
    if (s)
        CHECK(s->background.x == 0.25f && s->background.z == 1.0f);
    scene_free(s);
    free(buf);
    CHECK_NO_LEAKS();
}

/* ---- robustness: every truncation, seeded random mutations -------------------------- */

static void fuzz_one(const char *text, size_t len)
{
    char *copy = malloc(len + 1);
    memcpy(copy, text, len);
    copy[len] = '\0';
    Diag d;
    diag_init(&d, NULL);
    Scene *s = scene_load_string(copy, "f.txt", NULL, &d);
    /* Either a scene or exactly one located error. */
    if (s)
        CHECK_INT(d.errors, 0);
    else
        CHECK_MSG(d.errors == 1 && strstr(d.last, "f.txt:") == d.last, "bad report: %s", d.last);
    scene_free(s);
    free(copy);
}

static void test_truncations_never_crash(void)
{
    const char *dir = course_or_skip();
    static const char *files[] = {"scene6_13_checkerboard.txt", "scene6_18_6.837_logo.txt",
                                  "scene6_10_nested_transformations.txt",
                                  "scene6_14_glass_sphere.txt", "scene6_08_scale_translate.txt"};
    for (size_t f = 0; f < sizeof files / sizeof files[0]; f++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, files[f]);
        char *text = read_text(path);
        CHECK(text != NULL);
        if (!text)
            continue;
        /* obj_file names resolve against the course folder only through base_dir, which
         * is NULL here: meshes fail to open, which is fine (an error, not a crash). */
        size_t len = strlen(text);
        for (size_t cut = 0; cut <= len; cut++)
            fuzz_one(text, cut);
        free(text);
    }
    CHECK_NO_LEAKS();
}

static void test_mutations_never_crash(void)
{
    static const char *seed_text =
        "PerspectiveCamera { center 0 1 6 direction 0 -0.15 -1 up 0 1 0 angle 35 }\n"
        "Background { color 0.1 0.1 0.2 ambientLight 0.2 0.2 0.2 }\n"
        "Lights { numLights 2\n DirectionalLight { direction -1 -1 -1 color 0.7 0.7 0.7 }\n"
        " PointLight { position 0 4 2 color 1 1 1 attenuation 0 0.5 0 } }\n"
        "Materials { numMaterials 4\n PhongMaterial { diffuseColor 0.9 0.9 0.9 }\n"
        " PhongMaterial { diffuseColor 0.1 0.1 0.1 specularColor 0.5 0.5 0.5 exponent 20 }\n"
        " Checkerboard { Transform { UniformScale 2 } materialIndex 0 materialIndex 1 }\n"
        " Marble { materialIndex 0 materialIndex 1 octaves 4 frequency 5 amplitude 3 } }\n"
        "Group { numObjects 3\n MaterialIndex 2\n Plane { normal 0 1 0 offset -1 }\n"
        " MaterialIndex 3\n Transform { Translate 0 0 -1 UniformScale 1.5 Sphere { center 0 0 0 radius 0.6 } }\n"
        " Group { numObjects 1 Triangle { vertex0 0 0 0 vertex1 1 0 0 vertex2 0 1 0 } } }\n";
    size_t len = strlen(seed_text);
    Scene *ok = load(seed_text);
    CHECK_MSG(ok != NULL, "seed scene: %s", g_diag.last);
    scene_free(ok);
    uint32_t rng = 12345u;
    char *buf = malloc(len + 64);
    static const char pool[] = "{}0123456789.-e+ \n\tXGroup";
    for (int iter = 0; iter < 4000; iter++) {
        memcpy(buf, seed_text, len + 1);
        size_t n = len;
        int edits = 1 + (int)((rng >> 8) % 4);
        for (int e = 0; e < edits; e++) {
            rng = rng * 1664525u + 1013904223u;
            size_t at = (rng >> 4) % n;
            rng = rng * 1664525u + 1013904223u;
            switch ((rng >> 12) % 3) {
            case 0: /* replace a byte */
                buf[at] = pool[(rng >> 16) % (sizeof pool - 1)];
                break;
            case 1: /* delete a byte */
                memmove(buf + at, buf + at + 1, n - at);
                n--;
                break;
            default: /* duplicate a byte */
                if (n + 1 < len + 60) {
                    memmove(buf + at + 1, buf + at, n - at + 1);
                    n++;
                }
                break;
            }
        }
        fuzz_one(buf, n);
    }
    free(buf);
    CHECK_NO_LEAKS();
}

static const TestCase tests[] = {
    {"official_scenes_parse", test_official_scenes_parse},
    {"official_values", test_official_values},
    {"defaults_and_zero_lights", test_defaults_and_zero_lights},
    {"number_forms", test_number_forms},
    {"camera_values", test_camera_values},
    {"transform_order", test_transform_order},
    {"material_index_state", test_material_index_state},
    {"procedural_materials", test_procedural_materials},
    {"repeated_blocks_replace", test_repeated_blocks_replace},
    {"repeated_blocks_warn", test_repeated_blocks_warn},
    {"rotate_axis_as_given", test_rotate_axis_as_given},
    {"primitives_values", test_primitives_values},
    {"obj_file_resolution", test_obj_file_resolution},
    {"errors_located", test_errors_located},
    {"errors_limits", test_errors_limits},
    {"transform_limits", test_transform_limits},
    {"truncations_never_crash", test_truncations_never_crash},
    {"mutations_never_crash", test_mutations_never_crash},
};

RT_TEST_MAIN(tests)
