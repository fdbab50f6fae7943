/* The byte rule, checked on random scenes: build/tools/diffcheck (tools/diffcheck.c)
 * with a fixed seed, small images and few variants (-quick, -sets 2), so the suite runs
 * about 100 renders of scenes no one wrote: every image identical between brute force,
 * -grid auto, -grid nx ny nz, -accel twolevel, packets or not, 1, 2 or 3 threads, parts
 * merged, and the -stats blocks of 1 and 3 threads the same. The checker's own failure paths are
 * tested through a wrapper around the binary that changes what one variant writes. */
#include "../harness.h"
#include "e2e_util.h"

/* The fixed run: 8 scenes of seed 11, two option sets each (about 100 renders, half a
 * second on an idle machine). Seed 11 was chosen because its 8 scenes reach every
 * keyword and kind of variant diffcheck counts (its "covered:" line, checked below);
 * under the sanitizers, whose renders are several times slower, the first 3 only. */
enum { SCENES = 8, SANITIZED_SCENES = 3, SEED = 11 };

static bool diffcheck_path(char *buf, size_t size)
{
    const char *tools = getenv("RT_TOOLS");
    snprintf(buf, size, "%s/diffcheck", tools && *tools ? tools : "build/tools");
    return access(buf, X_OK) == 0;
}

/* Runs diffcheck with -bin bin, -dir dir/work and the extra arguments. */
static bool run_diffcheck(const char *bin, const char *dir, const char *const *extra, E2eRun *r)
{
    char tool[PATH_MAX], work[PATH_MAX];
    if (!diffcheck_path(tool, sizeof tool))
        return false;
    e2e_join(work, sizeof work, dir, "work");
    const char *argv[32] = {tool, "-bin", bin, "-dir", work};
    int n = 5;
    for (int i = 0; extra[i] && n < 31; i++)
        argv[n++] = extra[i];
    argv[n] = NULL;
    return e2e_run((char *const *)argv, r);
}

static void test_fixed_seed_agrees(void)
{
    char tool[PATH_MAX], dir[PATH_MAX], seed[32], count[32];
    CHECK_MSG(diffcheck_path(tool, sizeof tool), "%s not found (make builds it)", tool);
    CHECK(e2e_tmpdir(dir, sizeof dir, "diffcheck") != NULL);
    int scenes = E2E_SANITIZED ? SANITIZED_SCENES : SCENES;
    snprintf(seed, sizeof seed, "%d", SEED);
    snprintf(count, sizeof count, "%d", scenes);
    const char *extra[] = {"-quick", "-sets", "2", "-seed", seed, "-n", count, NULL};
    E2eRun r;
    CHECK(run_diffcheck(harness_bin(), dir, extra, &r));
    CHECK_MSG(r.status == 0, "diffcheck found a difference (status %d):\n%s%s", r.status,
              r.out, r.err);
    char want[128];
    snprintf(want, sizeof want, "diffcheck: %d scenes (seed %d, from 0)", scenes, SEED);
    CHECK_CONTAINS(r.out, want);
    CHECK_CONTAINS(r.out, " 0 failures in 0 scenes");
    /* Every feature counted was reached (name=0 nowhere), so a change to the generator
     * that loses one shows here. */
    const char *cov = strstr(r.out, "diffcheck: covered:");
    CHECK_MSG(cov != NULL, "no covered: line in\n%s", r.out);
    if (cov && !E2E_SANITIZED) {
        size_t len = strcspn(cov, "\n");
        char line[4096];
        snprintf(line, sizeof line, "%.*s ", (int)len, cov);
        CHECK_MSG(strstr(line, "=0 ") == NULL, "a feature not covered: %s", line);
    }
    /* Agreeing scenes are removed: the folder is left empty. */
    char work[PATH_MAX];
    CHECK_INT(e2e_count_entries(e2e_join(work, sizeof work, dir, "work")), 0);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* A wrapper around the binary under test: runs it, then, when the arguments contain
 * the words `when`, does `what` (a shell command with $out the -output file and $in
 * the -input file). */
static bool write_wrapper(const char *path, const char *when, const char *what)
{
    char text[4096];
    snprintf(text, sizeof text,
             "#!/bin/sh\n"
             "out=\n"
             "in=\n"
             "prev=\n"
             "hit=0\n"
             "for a in \"$@\"; do\n"
             "  [ \"$prev\" = -output ] && out=$a\n"
             "  [ \"$prev\" = -input ] && in=$a\n"
             "  [ \"$prev $a\" = \"%s\" ] && hit=1\n"
             "  prev=$a\n"
             "done\n"
             "\"%s\" \"$@\" || exit $?\n"
             "[ $hit = 1 ] && { %s; }\n"
             "exit 0\n",
             when, harness_bin(), what);
    return e2e_write_file(path, text) && chmod(path, 0755) == 0;
}

/* Each way diffcheck reports a failure: a wrapper spoils one variant's output, and the
 * run must end with status 1, name the difference and keep the scene. */
static void expect_failure(const char *tag, const char *when, const char *what,
                           const char *start, const char *message)
{
    char tool[PATH_MAX], dir[PATH_MAX], wrapper[PATH_MAX], seed[32];
    CHECK_MSG(diffcheck_path(tool, sizeof tool), "%s not found (make builds it)", tool);
    CHECK(e2e_tmpdir(dir, sizeof dir, tag) != NULL);
    CHECK(write_wrapper(e2e_join(wrapper, sizeof wrapper, dir, "rt.sh"), when, what));
    snprintf(seed, sizeof seed, "%d", SEED);
    const char *extra[] = {"-quick", "-sets", "2", "-seed", seed, "-start", start, "-n", "1",
                           NULL};
    E2eRun r;
    CHECK(run_diffcheck(wrapper, dir, extra, &r));
    CHECK_MSG(r.status == 1, "status %d, expected 1:\n%s%s", r.status, r.out, r.err);
    CHECK_CONTAINS(r.out, message);
    CHECK_CONTAINS(r.out, "diffcheck: the differing scenes are kept in");
    char work[PATH_MAX];
    CHECK_MSG(e2e_count_entries(e2e_join(work, sizeof work, dir, "work")) >= 1,
              "no scene kept in %s", work);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

static void test_detects_an_image_difference(void)
{
    /* The first option set of every scene renders -grid auto at 2 threads. */
    expect_failure("diffcheck_img", "-threads 2", "printf x >> \"$out\"", "0",
                   "bytes differ, the first at offset");
}

static void test_detects_a_failed_render(void)
{
    expect_failure("diffcheck_fail", "-threads 3", "exit 3", "0",
                   "render failed with status 3");
}

static void test_detects_a_stats_difference(void)
{
    /* Only -stats variants print to stdout; scene 1 of the fixed run has them at 1 and
     * 3 threads. */
    expect_failure("diffcheck_stats", "-threads 3", "echo '  num shadow rays 1'", "1",
                   "-stats blocks");
}

/* -crowded: one scene with a dense cluster, checked like the others; -grid auto must
 * build the two-level grid on it (-timings names it), which random scenes alone almost
 * never make it do. */
static void test_crowded_scene(void)
{
    char tool[PATH_MAX], dir[PATH_MAX], seed[32], scene[PATH_MAX + 64], img[PATH_MAX];
    CHECK_MSG(diffcheck_path(tool, sizeof tool), "%s not found (make builds it)", tool);
    CHECK(e2e_tmpdir(dir, sizeof dir, "diffcheck_crowded") != NULL);
    snprintf(seed, sizeof seed, "%d", SEED);
    const char *extra[] = {"-quick", "-sets", "1", "-crowded", "100", "-seed", seed, "-n", "1",
                           "-keep", NULL};
    E2eRun r;
    CHECK(run_diffcheck(harness_bin(), dir, extra, &r));
    CHECK_MSG(r.status == 0, "diffcheck found a difference (status %d):\n%s%s", r.status,
              r.out, r.err);
    CHECK_CONTAINS(r.out, "diffcheck: 1 scenes with a dense cluster (-crowded)");
    e2e_run_free(&r);
    snprintf(scene, sizeof scene, "%s/work/scene_%d_0/scene.txt", dir, SEED);
    e2e_join(img, sizeof img, dir, "auto.ppm");
    const char *args[] = {"-input", scene, "-size", "4", "4", "-output", img, "-grid", "auto",
                          "-timings", "-quiet", NULL};
    char why[512];
    CHECK_MSG(e2e_run_bin(harness_bin(), args, &r) && r.status == 0, "-grid auto: %s",
              e2e_describe(&r, why, sizeof why));
    CHECK_CONTAINS(r.err, "grid auto: two-level");
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* A difference is shrunk: the wrapper spoils the 2-thread image of any scene with a
 * sphere, so the reducer must end with one root object (the one holding the sphere)
 * and no light, written as reduced.txt beside the scene. */
static void test_reduces_a_difference(void)
{
    char tool[PATH_MAX], dir[PATH_MAX], wrapper[PATH_MAX], seed[32], path[PATH_MAX + 64];
    CHECK_MSG(diffcheck_path(tool, sizeof tool), "%s not found (make builds it)", tool);
    CHECK(e2e_tmpdir(dir, sizeof dir, "diffcheck_reduce") != NULL);
    CHECK(write_wrapper(e2e_join(wrapper, sizeof wrapper, dir, "rt.sh"), "-threads 2",
                        "grep -q Sphere \"$in\" && printf x >> \"$out\""));
    snprintf(seed, sizeof seed, "%d", SEED);
    /* Scene 0 of the fixed run: 3 root objects, one of them a sphere, and 3 lights. */
    const char *extra[] = {"-quick", "-sets", "2", "-seed", seed, "-n", "1", NULL};
    E2eRun r;
    CHECK(run_diffcheck(wrapper, dir, extra, &r));
    CHECK_MSG(r.status == 1, "status %d, expected 1:\n%s%s", r.status, r.out, r.err);
    CHECK_CONTAINS(r.out, "reduced to 1 of 3 root objects and 0 of 3 lights");
    snprintf(path, sizeof path, "%s/work/scene_%d_0/reduced.txt", dir, SEED);
    char *text = e2e_read_file(path, NULL);
    CHECK_MSG(text != NULL, "no %s", path);
    if (text) {
        const char *root = strstr(text, "Group {\n  numObjects 1\n");
        CHECK_MSG(root && strstr(root, "Sphere {"), "the reduced scene:\n%s", text);
        CHECK_CONTAINS(text, "numLights 0");
    }
    free(text);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* diffcheck's first finding (seed 3000, scene 329; docs/grid.md, Exactness), reduced by
 * hand: the eye in the plane z = 0 of a face of the scene's box, a ray leaving that face
 * by 1e-5 per unit and hitting the first triangle 8e-6 outside its edge at z = 0, which
 * the triangle test's edge tolerance accepts. The single-ray march ended where the ray
 * crossed the face, before the cell holding the triangle; it now goes on in the padded
 * band. Both grid paths must give the plain loop's bytes. */
static void test_march_band_beyond_the_box(void)
{
    static const char scene[] =
        "PerspectiveCamera { center 0 0.62 0 direction 0 -1 -0.00001 up 1 0 0 angle 30 }\n"
        "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 1 1 } }\n"
        "Group { numObjects 2 MaterialIndex 0\n"
        "  Triangle { vertex0 -0.136 -0.158 0 vertex1 0.914 -0.158 0 vertex2 0.914 -0.158 1.385 }\n"
        "  Triangle { vertex0 -0.136 -0.158 1.385 vertex1 0.914 0.791 1.385 "
        "vertex2 -0.136 0.791 1.385 } }\n";
    char dir[PATH_MAX], path[PATH_MAX], out[3][PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "diffcheck_band") != NULL);
    CHECK(e2e_write_file(e2e_join(path, sizeof path, dir, "gap.txt"), scene));
    const char *extra[3][6] = {{NULL}, {"-grid", "1", "2", "1", "-no_packets", NULL},
                               {"-grid", "1", "2", "1", NULL}};
    char *img[3] = {NULL, NULL, NULL};
    size_t len[3] = {0, 0, 0};
    for (int k = 0; k < 3; k++) {
        char name[32];
        snprintf(name, sizeof name, "%d.ppm", k);
        e2e_join(out[k], sizeof out[k], dir, name);
        const char *args[16] = {"-input", path, "-size", "3", "3", "-output", out[k], "-quiet"};
        int n = 8;
        for (int i = 0; extra[k][i]; i++)
            args[n++] = extra[k][i];
        args[n] = NULL;
        E2eRun r;
        char why[512];
        CHECK_MSG(e2e_run_bin(harness_bin(), args, &r) && r.status == 0, "render %d: %s", k,
                  e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
        img[k] = e2e_read_file(out[k], &len[k]);
        CHECK(img[k] != NULL);
    }
    for (int k = 1; k < 3; k++)
        CHECK_MSG(img[0] && img[k] && len[0] == len[k] && memcmp(img[0], img[k], len[0]) == 0,
                  "render %d (%s) differs from the plain loop's", k, extra[k][4] ? "single rays"
                                                                                : "packets");
    /* The plain loop hits the triangle's back face in the centre pixel: black (the
     * missed hit showed the grey background), so the scene still meets the case. */
    CHECK(img[0] && len[0] > 3 && img[0][len[0] - 15] == 0);
    for (int k = 0; k < 3; k++)
        free(img[k]);
    e2e_rmtree(dir);
}

/* The same eye and two triangles for the two-level grid (-accel twolevel, and -grid auto
 * where the scene is crowded enough to get it), which ended its walks at the box's faces
 * the same way. Small triangles behind the eye (y = 0.7..0.78, out of view) make the
 * levels: 12 of them (14 entries in all) give one top cell holding a leaf grid, whose box
 * is clipped at the face z = 0 and whose march ended there; 126 give 2 x 2 x 2 top cells,
 * the small ones in a leaf grid of their own, and the top walk ended at the face in the
 * eye's cell, before the one holding the first triangle. Every render must give the
 * plain loop's bytes. */
static void test_twolevel_band_beyond_the_box(void)
{
    static const struct {
        int small;
        const char *what, *args[3];
    } cases[] = {
        {12, "one top cell, leaf grid (-accel twolevel)", {"-accel", "twolevel", NULL}},
        {126, "2x2x2 top cells (-accel twolevel)", {"-accel", "twolevel", NULL}},
        {126, "2x2x2 top cells (-grid auto)", {"-grid", "auto", NULL}},
    };
    char dir[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "diffcheck_twolevel_band") != NULL);
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        /* The scene: the band reproducer's camera and triangles, then the small ones. */
        static char scene[32768];
        int len = snprintf(scene, sizeof scene,
                           "PerspectiveCamera { center 0 0.62 0 direction 0 -1 -0.00001 "
                           "up 1 0 0 angle 30 }\n"
                           "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 1 1 } }\n"
                           "Group { numObjects %d MaterialIndex 0\n"
                           "  Triangle { vertex0 -0.136 -0.158 0 vertex1 0.914 -0.158 0 "
                           "vertex2 0.914 -0.158 1.385 }\n"
                           "  Triangle { vertex0 -0.136 -0.158 1.385 vertex1 0.914 0.791 1.385 "
                           "vertex2 -0.136 0.791 1.385 }\n",
                           2 + cases[c].small);
        for (int i = 0; i < cases[c].small && len > 0 && (size_t)len < sizeof scene; i++) {
            double x = 0.5 + 0.003 * (i % 100), y = 0.70 + 0.0005 * i, z = 0.9 + 0.003 * i;
            len += snprintf(scene + len, sizeof scene - (size_t)len,
                            "  Triangle { vertex0 %.4f %.4f %.3f vertex1 %.4f %.4f %.3f "
                            "vertex2 %.4f %.4f %.3f }\n",
                            x, y, z, x + 0.002, y, z, x, y, z + 0.002);
        }
        CHECK(len > 0 && (size_t)len + 3 < sizeof scene);
        if (!(len > 0 && (size_t)len + 3 < sizeof scene))
            break;
        memcpy(scene + len, "}\n", 3);
        char path[PATH_MAX], out[2][PATH_MAX];
        CHECK(e2e_write_file(e2e_join(path, sizeof path, dir, "scene.txt"), scene));
        char *img[2] = {NULL, NULL};
        size_t n[2] = {0, 0};
        for (int k = 0; k < 2; k++) {
            e2e_join(out[k], sizeof out[k], dir, k ? "accel.ppm" : "plain.ppm");
            const char *args[16] = {"-input", path, "-size", "3", "3", "-output", out[k],
                                    "-quiet"};
            int na = 8;
            for (int i = 0; k && cases[c].args[i]; i++)
                args[na++] = cases[c].args[i];
            args[na] = NULL;
            E2eRun r;
            char why[512];
            CHECK_MSG(e2e_run_bin(harness_bin(), args, &r) && r.status == 0, "%s, render %d: %s",
                      cases[c].what, k, e2e_describe(&r, why, sizeof why));
            e2e_run_free(&r);
            img[k] = e2e_read_file(out[k], &n[k]);
            CHECK(img[k] != NULL);
        }
        CHECK_MSG(img[0] && img[1] && n[0] == n[1] && memcmp(img[0], img[1], n[0]) == 0,
                  "%s differs from the plain loop's", cases[c].what);
        /* The plain loop's centre pixel is the first triangle's back face (black). */
        CHECK(img[0] && n[0] > 15 && img[0][n[0] - 15] == 0);
        free(img[0]);
        free(img[1]);
    }
    e2e_rmtree(dir);

}

static const TestCase tests[] = {
    {"random scenes render the same bytes with every accelerator, thread count, packets",
     test_fixed_seed_agrees},
    {"diffcheck reports an image that differs", test_detects_an_image_difference},
    {"diffcheck reports a render that fails", test_detects_a_failed_render},
    {"diffcheck reports -stats blocks that differ", test_detects_a_stats_difference},
    {"diffcheck shrinks a scene that differs", test_reduces_a_difference},
    {"diffcheck -crowded adds a cluster that -grid auto gives the two-level grid",
     test_crowded_scene},
    {"the grid march goes on beyond a face of its box (diffcheck's finding)",
     test_march_band_beyond_the_box},
    {"the two-level grid's walks go on beyond a face of its box (diffcheck's finding)",
     test_twolevel_band_beyond_the_box},
};
RT_TEST_MAIN(tests)
