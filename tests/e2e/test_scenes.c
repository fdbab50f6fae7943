/* The project's own scenes and models never rot: every .txt in scenes/ parses and
 * renders (exit 0), the grid and a second thread change no byte, every .obj in models/
 * loads with outward faces, and `make models` reproduces the committed models exactly. */
#include "../harness.h"
#include "e2e_util.h"

#include "rt/geom.h"
#include "rt/scene.h"

enum { MAX_FILES = 256, SIZE = 64 };

typedef struct FileList {
    int n;
    char name[MAX_FILES][256];
} FileList;

static int cmp_names(const void *a, const void *b) { return strcmp(a, b); }

/* Sorted names in dir ending in suffix (e.g. ".txt"). */
static void list_files(const char *dir, const char *suffix, FileList *fl)
{
    fl->n = 0;
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    size_t ls = strlen(suffix);
    while ((e = readdir(d)) != NULL && fl->n < MAX_FILES) {
        size_t l = strlen(e->d_name);
        if (l > ls && l < sizeof fl->name[0] && strcmp(e->d_name + l - ls, suffix) == 0)
            strcpy(fl->name[fl->n++], e->d_name);
    }
    closedir(d);
    qsort(fl->name, (size_t)fl->n, sizeof fl->name[0], cmp_names);
}

static const char *scenes_dir(char *buf, size_t size)
{
    return e2e_join(buf, size, harness_root(), "scenes");
}

static const char *models_dir(char *buf, size_t size)
{
    return e2e_join(buf, size, harness_root(), "models");
}

static bool same_file(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *x = e2e_read_file(a, &la), *y = e2e_read_file(b, &lb);
    bool same = x && y && la == lb && memcmp(x, y, la) == 0;
    free(x);
    free(y);
    return same;
}

/* Renders scene into dir/tag.tga (+ tag_d.tga depth, tag_n.tga normals) at SIZE x SIZE
 * with every shading feature on, plus the extra arguments (NULL-terminated). */
static bool render(const char *scene, const char *dir, const char *tag, const char *const *extra)
{
    char out[PATH_MAX], dep[PATH_MAX], nor[PATH_MAX], name[64], why[512];
    char sz[16];
    snprintf(sz, sizeof sz, "%d", SIZE);
    snprintf(name, sizeof name, "%s.tga", tag);
    e2e_join(out, sizeof out, dir, name);
    snprintf(name, sizeof name, "%s_d.tga", tag);
    e2e_join(dep, sizeof dep, dir, name);
    snprintf(name, sizeof name, "%s_n.tga", tag);
    e2e_join(nor, sizeof nor, dir, name);
    const char *args[64] = {"-input", scene, "-output", out, "-size", sz, sz, "-shadows",
                            "-shade_back", "-bounces", "3", "-weight", "0.01",
                            "-depth", "0", "20", dep, "-normals", nor};
    int n = 19;
    for (int i = 0; extra[i] && n < 62; i++)
        args[n++] = extra[i];
    args[n] = NULL;
    E2eRun r;
    if (!e2e_run_bin(harness_bin(), args, &r)) {
        CHECK_MSG(false, "%s: could not run %s", scene, harness_bin());
        return false;
    }
    bool ok = r.status == 0 && !r.timed_out && e2e_exists(out);
    CHECK_MSG(ok, "%s (%s): %s", scene, tag, e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    return ok;
}

/* Compares the three images of two renders. */
static void check_same_images(const char *dir, const char *scene, const char *ta, const char *tb)
{
    static const char *const sfx[] = {".tga", "_d.tga", "_n.tga"};
    for (int i = 0; i < 3; i++) {
        char a[PATH_MAX], b[PATH_MAX], na[64], nb[64];
        snprintf(na, sizeof na, "%s%s", ta, sfx[i]);
        snprintf(nb, sizeof nb, "%s%s", tb, sfx[i]);
        e2e_join(a, sizeof a, dir, na);
        e2e_join(b, sizeof b, dir, nb);
        CHECK_MSG(same_file(a, b), "%s: %s differs from %s", scene, nb, na);
    }
}

static void test_scene_folder_has_showcase_and_features(void)
{
    char dir[PATH_MAX], p[PATH_MAX];
    FileList fl;
    list_files(scenes_dir(dir, sizeof dir), ".txt", &fl);
    CHECK_MSG(fl.n >= 6, "only %d scenes in %s", fl.n, dir);
    CHECK(e2e_exists(e2e_join(p, sizeof p, dir, "showcase.txt")));
    CHECK(e2e_exists(e2e_join(p, sizeof p, dir, "demo.sh")));
    int feats = 0;
    for (int i = 0; i < fl.n; i++)
        feats += strncmp(fl.name[i], "feat_", 5) == 0;
    CHECK_MSG(feats >= 5, "only %d feat_*.txt scenes", feats);
}

/* In-process: the parser accepts every scene with no error and finds a camera, a group
 * and (for the showcase) every kind of object and material. */
static void test_every_scene_parses(void)
{
    char dir[PATH_MAX], p[PATH_MAX];
    FileList fl;
    list_files(scenes_dir(dir, sizeof dir), ".txt", &fl);
    for (int i = 0; i < fl.n; i++) {
        Diag d;
        diag_init(&d, NULL);
        Scene *s = scene_load(e2e_join(p, sizeof p, dir, fl.name[i]), &d);
        CHECK_MSG(s != NULL, "%s: %s", fl.name[i], d.last);
        if (!s)
            continue;
        CHECK_MSG(d.errors == 0, "%s: %s", fl.name[i], d.last);
        CHECK_MSG(s->has_camera, "%s has no camera", fl.name[i]);
        CHECK_MSG(s->root != NULL, "%s has no group", fl.name[i]);
        CHECK_MSG(s->num_primitives > 0, "%s has no primitives", fl.name[i]);
        scene_free(s);
    }
}

/* Every scene renders with exit 0; -grid auto gives the same bytes as brute force
 * (colour, depth and normals), and so does a lopsided fixed grid. */
static void test_every_scene_renders_same_with_grid(void)
{
    char dir[PATH_MAX], tmp[PATH_MAX], p[PATH_MAX];
    FileList fl;
    list_files(scenes_dir(dir, sizeof dir), ".txt", &fl);
    CHECK(e2e_tmpdir(tmp, sizeof tmp, "scenes") != NULL);
    for (int i = 0; i < fl.n; i++) {
        e2e_join(p, sizeof p, dir, fl.name[i]);
        const char *none[] = {"-threads", "1", NULL};
        const char *gauto[] = {"-threads", "1", "-grid", "auto", NULL};
        const char *gfix[] = {"-threads", "1", "-grid", "7", "3", "5", NULL};
        if (!render(p, tmp, "brute", none))
            continue;
        if (render(p, tmp, "gauto", gauto))
            check_same_images(tmp, fl.name[i], "brute", "gauto");
        if (render(p, tmp, "gfix", gfix))
            check_same_images(tmp, fl.name[i], "brute", "gfix");
    }
    e2e_rmtree(tmp);
}

/* Rendering is deterministic per pixel: two threads give the bytes of one. */
static void test_every_scene_same_with_two_threads(void)
{
    char dir[PATH_MAX], tmp[PATH_MAX], p[PATH_MAX];
    FileList fl;
    list_files(scenes_dir(dir, sizeof dir), ".txt", &fl);
    CHECK(e2e_tmpdir(tmp, sizeof tmp, "scenes") != NULL);
    for (int i = 0; i < fl.n; i++) {
        e2e_join(p, sizeof p, dir, fl.name[i]);
        const char *one[] = {"-threads", "1", "-grid", "auto", NULL};
        const char *two[] = {"-threads", "2", "-grid", "auto", NULL};
        if (render(p, tmp, "t1", one) && render(p, tmp, "t2", two))
            check_same_images(tmp, fl.name[i], "t1", "t2");
    }
    e2e_rmtree(tmp);
}

/* Signed volume of every triangle below o (divergence theorem): > 0 when a closed
 * mesh's faces are counter-clockwise seen from outside. */
static void mesh_walk(const Object3D *o, double *vol, long *tris)
{
    if (obj_kind(o) == OBJ_GROUP) {
        for (int i = 0; i < group_count(o); i++)
            mesh_walk(group_child(o, i), vol, tris);
    } else if (obj_kind(o) == OBJ_TRIANGLE) {
        Vec3 v[3];
        triangle_vertices(o, v);
        Vec3 c = v3_cross(v[1], v[2]);
        *vol += ((double)v[0].x * (double)c.x + (double)v[0].y * (double)c.y +
                 (double)v[0].z * (double)c.z) / 6.0;
        (*tris)++;
    }
}

static void test_every_model_loads(void)
{
    char dir[PATH_MAX];
    FileList fl;
    list_files(models_dir(dir, sizeof dir), ".obj", &fl);
    CHECK_MSG(fl.n >= 4, "only %d models in %s", fl.n, dir);
    for (int i = 0; i < fl.n; i++) {
        char text[512];
        snprintf(text, sizeof text,
                 "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 4 }\n"
                 "Materials { numMaterials 1 PhongMaterial { } }\n"
                 "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file %s } }\n",
                 fl.name[i]);
        Diag d;
        diag_init(&d, NULL);
        Scene *s = scene_load_string(text, "model-test.txt", dir, &d);
        CHECK_MSG(s != NULL, "%s: %s", fl.name[i], d.last);
        if (!s)
            continue;
        double vol = 0.0;
        long tris = 0;
        mesh_walk(s->root, &vol, &tris);
        CHECK_MSG(tris > 0, "%s has no triangles", fl.name[i]);
        /* the closed solids of modelgen must face outward */
        static const char *const closed[] = {"icosahedron.obj", "icosphere.obj", "torus.obj",
                                             "vase.obj"};
        for (size_t k = 0; k < sizeof closed / sizeof closed[0]; k++)
            if (strcmp(fl.name[i], closed[k]) == 0)
                CHECK_MSG(vol > 0.0, "%s: signed volume %g (inward faces?)", fl.name[i], vol);
        if (strcmp(fl.name[i], "icosphere.obj") == 0) /* unit sphere, level 3 */
            CHECK_MSG(fabs(vol - 4.18879) < 0.1, "icosphere volume %g", vol);
        scene_free(s);
    }
}

/* `make models` (its command lines read from mk/bench.mk) reproduces every committed
 * model byte for byte: the generator is deterministic and the files are not stale. */
static void test_make_models_reproduces_committed_models(void)
{
    const char *tools = getenv("RT_TOOLS");
    char gen[PATH_MAX], mk[PATH_MAX], tmp[PATH_MAX], dir[PATH_MAX];
    if (!tools || !*tools)
        tools = "build/tools";
    e2e_join(gen, sizeof gen, tools, "modelgen");
    if (!e2e_exists(gen))
        harness_skip("build/tools/modelgen not built (run make tools)");
    char *text = e2e_read_file(e2e_join(mk, sizeof mk, harness_root(), "mk/bench.mk"), NULL);
    CHECK_MSG(text != NULL, "cannot read %s", mk);
    if (!text)
        return;
    CHECK(e2e_tmpdir(tmp, sizeof tmp, "models") != NULL);
    models_dir(dir, sizeof dir);
    int checked = 0;
    const char *key = "tools/modelgen -o models/";
    for (char *line = strtok(text, "\n"); line; line = strtok(NULL, "\n")) {
        char *at = strstr(line, key);
        if (!at)
            continue;
        /* "<name>.obj ARGS..." */
        char *rest = at + strlen(key);
        char name[128], *args[16];
        int na = 0;
        if (sscanf(rest, "%127s", name) != 1)
            continue;
        char out[PATH_MAX], committed[PATH_MAX];
        e2e_join(out, sizeof out, tmp, name);
        e2e_join(committed, sizeof committed, dir, name);
        args[na++] = gen;
        args[na++] = (char *)"-q";
        args[na++] = (char *)"-o";
        args[na++] = out;
        char *save = NULL;
        for (char *w = strtok_r(rest + strlen(name), " \t", &save); w && na < 15;
             w = strtok_r(NULL, " \t", &save))
            args[na++] = w;
        args[na] = NULL;
        E2eRun r;
        char why[512];
        CHECK(e2e_run(args, &r));
        CHECK_MSG(r.status == 0, "modelgen %s: %s", name, e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
        CHECK_MSG(same_file(out, committed), "models/%s differs from what `make models` makes",
                  name);
        checked++;
    }
    free(text);
    CHECK_MSG(checked >= 4, "only %d modelgen lines found in mk/bench.mk", checked);
    e2e_rmtree(tmp);
}

/* The generator's command line: help, bad input, and a deterministic seeded blob. */
static void test_modelgen_cli(void)
{
    const char *tools = getenv("RT_TOOLS");
    char gen[PATH_MAX], tmp[PATH_MAX], a[PATH_MAX], b[PATH_MAX], why[512];
    if (!tools || !*tools)
        tools = "build/tools";
    e2e_join(gen, sizeof gen, tools, "modelgen");
    if (!e2e_exists(gen))
        harness_skip("build/tools/modelgen not built (run make tools)");
    E2eRun r;
    char *help[] = {gen, (char *)"-h", NULL};
    CHECK(e2e_run(help, &r));
    CHECK_INT(r.status, 0);
    CHECK_CONTAINS(r.out, "icosphere");
    e2e_run_free(&r);
    char *bad[][5] = {{gen, (char *)"teapot", NULL},
                      {gen, (char *)"icosphere", (char *)"x", NULL},
                      {gen, (char *)"icosphere", (char *)"99", NULL},
                      {gen, (char *)"torus", (char *)"1", (char *)"2", NULL},
                      {gen, (char *)"-z", NULL}};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        CHECK(e2e_run(bad[i], &r));
        CHECK_MSG(r.status == 2 && r.out_len == 0, "modelgen %s %s: %s", bad[i][1],
                  bad[i][2] ? bad[i][2] : "", e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
    }
    CHECK(e2e_tmpdir(tmp, sizeof tmp, "blob") != NULL);
    e2e_join(a, sizeof a, tmp, "a.obj");
    e2e_join(b, sizeof b, tmp, "b.obj");
    char *ga[] = {gen, (char *)"-o", a, (char *)"blob", (char *)"2", (char *)"7", NULL};
    char *gb[] = {gen, (char *)"-o", b, (char *)"blob", (char *)"2", (char *)"7", NULL};
    CHECK(e2e_run(ga, &r));
    CHECK_INT(r.status, 0);
    CHECK_CONTAINS(r.err, "320 triangles");
    e2e_run_free(&r);
    CHECK(e2e_run(gb, &r));
    CHECK_INT(r.status, 0);
    e2e_run_free(&r);
    CHECK_MSG(same_file(a, b), "blob 2 7 is not deterministic");
    e2e_rmtree(tmp);
}

static const TestCase tests[] = {
    {"scenes: showcase and feature scenes present", test_scene_folder_has_showcase_and_features},
    {"scenes: every scene parses", test_every_scene_parses},
    {"scenes: render, -grid identical to brute force", test_every_scene_renders_same_with_grid},
    {"scenes: -threads 2 identical to -threads 1", test_every_scene_same_with_two_threads},
    {"models: every model loads, closed ones face out", test_every_model_loads},
    {"models: make models reproduces models/", test_make_models_reproduces_committed_models},
    {"modelgen: help, bad arguments, determinism", test_modelgen_cli},
};

RT_TEST_MAIN(tests)
