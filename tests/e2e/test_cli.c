/* End-to-end tests of the command line: exit statuses (0 written, 1 input/output error,
 * 2 usage error; README.txt), help and version output, and that a failed run leaves
 * no output file. Scenes are written by the tests into a temporary folder. */
#define _POSIX_C_SOURCE 200809L
#include <signal.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>
#include "../harness.h"
#include <dirent.h>
#include "e2e_util.h"

#include <ctype.h>

#include "rt/image.h"

static const char SCENE[] =
    "OrthographicCamera {\n"
    "    center 0 0 10\n"
    "    direction 0 0 -1\n"
    "    up 0 1 0\n"
    "    size 5\n"
    "}\n"
    "Lights {\n"
    "    numLights 1\n"
    "    DirectionalLight {\n"
    "        direction -0.5 -0.5 -1\n"
    "        color 1 1 1\n"
    "    }\n"
    "}\n"
    "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }\n"
    "Materials {\n"
    "    numMaterials 1\n"
    "    PhongMaterial { diffuseColor 1 0 0 }\n"
    "}\n"
    "Group {\n"
    "    numObjects 1\n"
    "    MaterialIndex 0\n"
    "    Sphere { center 0 0 0 radius 1 }\n"
    "}\n";

/* A scene with a syntax error near the end, so parsing gets some way first. */
static const char BAD_SCENE[] =
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
    "Group {\n"
    "    numObjects 1\n"
    "    Sphere { center 0 0 0 radius oops }\n"
    "}\n";

typedef struct Fixture {
    char dir[PATH_MAX];
    char scene[PATH_MAX];
    char bad_scene[PATH_MAX];
    char out[PATH_MAX];
} Fixture;

static void fixture_init(Fixture *f)
{
    CHECK(e2e_tmpdir(f->dir, sizeof f->dir, "cli") != NULL);
    e2e_join(f->scene, sizeof f->scene, f->dir, "scene.txt");
    e2e_join(f->bad_scene, sizeof f->bad_scene, f->dir, "bad.txt");
    e2e_join(f->out, sizeof f->out, f->dir, "out.tga");
    CHECK(e2e_write_file(f->scene, SCENE));
    CHECK(e2e_write_file(f->bad_scene, BAD_SCENE));
    if (access(harness_bin(), X_OK) != 0) {
        harness_fail(__FILE__, __LINE__, "binary under test %s not found (run make first)",
                     harness_bin());
        e2e_rmtree(f->dir);
        fflush(stdout);
        _exit(1);
    }
}

/* Runs the binary with args; returns the exit status and keeps the run in *r. */
static int run(const char *const *args, E2eRun *r)
{
    if (!e2e_run_bin(harness_bin(), args, r))
        return -1;
    return r->status;
}

static void expect_status(const char *const *args, int want, const char *what, E2eRun *r)
{
    int got = run(args, r);
    char why[512];
    CHECK_MSG(got == want, "%s: exit %d, expected %d (%s)", what, got, want,
              e2e_describe(r, why, sizeof why));
}

static bool ci_contains(const char *hay, const char *needle)
{
    size_t n = strlen(needle);
    for (; *hay; hay++) {
        size_t i = 0;
        while (i < n && hay[i] && tolower((unsigned char)hay[i]) == tolower((unsigned char)needle[i]))
            i++;
        if (i == n)
            return true;
    }
    return false;
}

static void test_good_render(void)
{
    Fixture f;
    fixture_init(&f);
    E2eRun r;
    const char *args[] = {"-input", f.scene, "-output", f.out, "-size", "12", "10", NULL};
    expect_status(args, 0, "good render", &r);
    CHECK_MSG(r.err_len == 0, "good render printed on stderr: %s", r.err);
    Image img;
    Diag diag;
    diag_init(&diag, NULL);
    CHECK_MSG(image_read(&img, f.out, &diag), "%s", diag.last);
    CHECK_INT(img.width, 12);
    CHECK_INT(img.height, 10);
    if (img.pixels) {
        /* corner: background (0.1 0.2 0.3); centre: the lit red sphere */
        CHECK_INT(image_color_to_byte(image_get(&img, 0, 0).z), image_color_to_byte(0.3f));
        CHECK_INT(image_color_to_byte(image_get(&img, 0, 0).x), image_color_to_byte(0.1f));
        Vec3 c = image_get(&img, 6, 5);
        CHECK(c.x > 0.2f && c.y == 0.0f && c.z == 0.0f);
    }
    image_free(&img);
    size_t len = 0;
    char *bytes = e2e_read_file(f.out, &len);
    CHECK_INT(len, 18 + 12 * 10 * 3);
    free(bytes);
    /* scene, image and nothing else (no leftover temporary file) */
    CHECK_INT(e2e_count_entries(f.dir), 3);
    e2e_run_free(&r);
    e2e_rmtree(f.dir);
}

static void test_all_three_images_and_ppm(void)
{
    Fixture f;
    fixture_init(&f);
    char depth[PATH_MAX], normals[PATH_MAX], ppm[PATH_MAX];
    e2e_join(depth, sizeof depth, f.dir, "depth.tga");
    e2e_join(normals, sizeof normals, f.dir, "normals.tga");
    e2e_join(ppm, sizeof ppm, f.dir, "out.ppm");
    E2eRun r;
    const char *args[] = {"-input", f.scene, "-size", "8", "8", "-output", ppm, "-depth", "9",
                          "11", depth, "-normals", normals, NULL};
    expect_status(args, 0, "three images", &r);
    CHECK(e2e_exists(ppm));
    CHECK(e2e_exists(depth));
    CHECK(e2e_exists(normals));
    size_t len = 0;
    char *bytes = e2e_read_file(ppm, &len);
    CHECK(bytes && len > 2 && bytes[0] == 'P' && bytes[1] == '6');
    free(bytes);
    e2e_run_free(&r);
    e2e_rmtree(f.dir);
}

/* Each usage error: exit 2, a message on stderr, and no image. */
static void check_usage_error(Fixture *f, const char *const *args, const char *what)
{
    E2eRun r;
    expect_status(args, 2, what, &r);
    CHECK_MSG(r.err_len > 0, "%s: nothing on stderr", what);
    CHECK_MSG(!e2e_exists(f->out), "%s: an image was written", what);
    e2e_run_free(&r);
}

static void test_usage_errors(void)
{
    Fixture f;
    fixture_init(&f);
    const char *unknown[] = {"-input", f.scene, "-output", f.out, "-bogus", NULL};
    check_usage_error(&f, unknown, "unknown option");
    const char *missing_value[] = {"-input", f.scene, "-output", f.out, "-size", "10", NULL};
    check_usage_error(&f, missing_value, "-size with one value");
    const char *missing_input_value[] = {"-output", f.out, "-input", NULL};
    check_usage_error(&f, missing_input_value, "-input without a value");
    const char *negative[] = {"-input", f.scene, "-output", f.out, "-size", "-5", "10", NULL};
    check_usage_error(&f, negative, "negative size");
    const char *zero[] = {"-input", f.scene, "-output", f.out, "-size", "0", "10", NULL};
    check_usage_error(&f, zero, "zero size");
    const char *not_number[] = {"-input", f.scene, "-output", f.out, "-size", "10", "x", NULL};
    check_usage_error(&f, not_number, "-size 10 x");
    const char *trailing[] = {"-input", f.scene, "-output", f.out, "-size", "10", "10x", NULL};
    check_usage_error(&f, trailing, "-size 10 10x");
    const char *bad_float[] = {"-input", f.scene, "-output", f.out, "-weight", "abc", NULL};
    check_usage_error(&f, bad_float, "-weight abc");
    const char *no_input[] = {"-output", f.out, "-size", "10", "10", NULL};
    check_usage_error(&f, no_input, "no -input");
    const char *positional[] = {"-input", f.scene, "-output", f.out, "stray", NULL};
    check_usage_error(&f, positional, "stray positional argument");
    e2e_rmtree(f.dir);
}

static void check_help(const char *flag)
{
    E2eRun r;
    const char *args[] = {flag, NULL};
    expect_status(args, 0, flag, &r);
    CHECK_MSG(ci_contains(r.out, "usage"), "%s: no usage on stdout: %.200s", flag, r.out);
    CHECK_CONTAINS(r.out, "-input");
    CHECK_CONTAINS(r.out, "-output");
    CHECK_CONTAINS(r.out, "-size");
    /* Both forms, as the man page's SYNOPSIS: the merge one was only an option among
     * the others, 70 lines further down */
    static const char synopsis[] = "usage: raytracer -input scene.txt [options]\n"
                                   "       raytracer -merge out part...\n\n";
    CHECK_MSG(strncmp(r.out, synopsis, sizeof synopsis - 1) == 0,
              "%s: the synopsis is not both forms: %.200s", flag, r.out);
    CHECK_MSG(r.err_len == 0, "%s printed on stderr: %s", flag, r.err);
    e2e_run_free(&r);
}

static void test_help(void)
{
    check_help("-h");
    check_help("--help");
}

static void test_version(void)
{
    E2eRun r;
    const char *args[] = {"--version", NULL};
    expect_status(args, 0, "--version", &r);
    CHECK_CONTAINS(r.out, "raytracer");
    /* the optional features are listed; this test binary is built with the same
     * feature flags as the raytracer */
    CHECK_MSG(ci_contains(r.out, "png"), "--version does not list the png feature: %s",
              r.out);
    if (image_format_supported("png"))
        CHECK_MSG(ci_contains(r.out, "png yes") || ci_contains(r.out, "+png") ||
                  ci_contains(r.out, "png: yes"),
                  "--version does not say png is built in: %s", r.out);
    /* ./raytracer has no MPI: said as a sentence, with where to get it */
    CHECK_CONTAINS(r.out, "\nmpi: not in this binary (make mpi builds ./raytracer-mpi, which "
                          "has it)\n");
    e2e_run_free(&r);
}

static void test_missing_scene(void)
{
    Fixture f;
    fixture_init(&f);
    char missing[PATH_MAX];
    e2e_join(missing, sizeof missing, f.dir, "nothere.txt");
    E2eRun r;
    const char *args[] = {"-input", missing, "-output", f.out, "-size", "8", "8", NULL};
    expect_status(args, 1, "missing scene file", &r);
    CHECK_CONTAINS(r.err, "nothere.txt");
    CHECK_CONTAINS(r.err, "error");
    CHECK(!e2e_exists(f.out));
    e2e_run_free(&r);
    e2e_rmtree(f.dir);
}

/* Ctrl-C: exit status 130, no image and no temporary file. No sleeping: the scene is a
 * FIFO, so the test's open() returns only once the program is reading it (its signal
 * handlers are installed before); the signal then comes while the scene is parsed or
 * the 6000x6000 image (36M pixels, seconds of work) is rendered, and either way the
 * run must stop with nothing written. */
static void test_interrupt(void)
{
    Fixture f;
    fixture_init(&f);
    char fifo[PATH_MAX];
    e2e_join(fifo, sizeof fifo, f.dir, "scene.fifo");
    CHECK(mkfifo(fifo, 0600) == 0);
    int before = e2e_count_entries(f.dir);
    const char *args[] = {harness_bin(), "-input", fifo, "-output", f.out, "-size", "6000",
                          "6000", "-threads", "1", NULL};
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        int null = open("/dev/null", O_WRONLY);
        if (null >= 0) {
            dup2(null, 1);
            dup2(null, 2);
        }
        execv(args[0], (char *const *)args);
        _exit(127);
    }
    CHECK(pid > 0);
    if (pid <= 0)
        return;
    int fd = open(fifo, O_WRONLY); /* blocks until the program opens its scene */
    CHECK(fd >= 0);
    if (fd >= 0) {
        size_t len = strlen(SCENE);
        CHECK(write(fd, SCENE, len) == (ssize_t)len);
        close(fd);
    }
    kill(pid, SIGINT);
    int status = 0;
    while (waitpid(pid, &status, 0) < 0) {
    }
    CHECK_MSG(WIFEXITED(status) && WEXITSTATUS(status) == 130, "status %d, expected exit 130",
              status);
    CHECK(!e2e_exists(f.out));
    CHECK_INT(e2e_count_entries(f.dir), before);
    e2e_rmtree(f.dir);
}

/* -timings: one line of phase times on stderr, nothing added to stdout. */
static void test_timings(void)
{
    Fixture f;
    fixture_init(&f);
    E2eRun r;
    const char *args[] = {"-input", f.scene, "-output", f.out, "-size", "8", "8", "-timings",
                          NULL};
    expect_status(args, 0, "-timings", &r);
    CHECK_CONTAINS(r.err, "timings: parse ");
    CHECK_CONTAINS(r.err, " ms, render ");
    CHECK_CONTAINS(r.err, " ms, write ");
    /* no accelerator: no build phase (it was called "grid" with none built) */
    CHECK(strstr(r.err, " grid ") == NULL);
    CHECK(r.out == NULL || strstr(r.out, "timings") == NULL);
    e2e_run_free(&r);
    /* the build phase is named after the accelerator */
    static const char *const accels[][2] = {{"none", NULL}, {"grid", " ms, grid "},
                                            {"twolevel", " ms, twolevel "}};
    for (int i = 0; i < 3; i++) {
        const char *a2[] = {"-input", f.scene, "-output", f.out, "-size", "8", "8", "-timings",
                            "-accel", accels[i][0], NULL};
        expect_status(a2, 0, "-timings -accel", &r);
        CHECK_CONTAINS(r.err, "timings: parse ");
        if (accels[i][1])
            CHECK_CONTAINS(r.err, accels[i][1]);
        else
            CHECK_MSG(strstr(r.err, " grid ") == NULL && strstr(r.err, " none ") == NULL,
                      "-accel none: %s", r.err);
        e2e_run_free(&r);
    }
    e2e_rmtree(f.dir);
}

static void test_bad_scene_leaves_no_output(void)
{
    Fixture f;
    fixture_init(&f);
    E2eRun r;
    const char *args[] = {"-input", f.bad_scene, "-output", f.out, "-size", "8", "8", NULL};
    expect_status(args, 1, "scene with a syntax error", &r);
    /* located message: bad.txt:4:<col>: error: ... */
    CHECK_CONTAINS(r.err, "bad.txt:4:");
    CHECK_CONTAINS(r.err, "error");
    CHECK(!e2e_exists(f.out));
    CHECK_INT(e2e_count_entries(f.dir), 2); /* only the two scenes */
    e2e_run_free(&r);
    e2e_rmtree(f.dir);
}

static void test_unwritable_output(void)
{
    Fixture f;
    fixture_init(&f);
    char out[PATH_MAX];
    e2e_join(out, sizeof out, f.dir, "missing/out.tga");
    E2eRun r;
    const char *args[] = {"-input", f.scene, "-output", out, "-size", "8", "8", NULL};
    expect_status(args, 1, "output into a missing folder", &r);
    CHECK_CONTAINS(r.err, "missing/out.tga");
    CHECK_CONTAINS(r.err, "cannot write image");
    CHECK(!e2e_exists(out));
    CHECK_INT(e2e_count_entries(f.dir), 2);
    e2e_run_free(&r);

    /* An unknown image extension is a usage error and writes nothing. */
    char bmp[PATH_MAX];
    e2e_join(bmp, sizeof bmp, f.dir, "out.bmp");
    const char *args2[] = {"-input", f.scene, "-output", bmp, "-size", "8", "8", NULL};
    int st = run(args2, &r);
    CHECK_MSG(st == 2, "unknown extension: exit %d, expected 2", st);
    CHECK_CONTAINS(r.err, ".tga");
    CHECK(!e2e_exists(bmp));
    CHECK_INT(e2e_count_entries(f.dir), 2);
    e2e_run_free(&r);
    e2e_rmtree(f.dir);
}

static void test_failed_second_image_leaves_no_first(void)
{
    /* -output fine, -normals into a missing folder: the run fails with 1. Whatever was
     * written, no temporary file stays behind. */
    Fixture f;
    fixture_init(&f);
    char normals[PATH_MAX];
    e2e_join(normals, sizeof normals, f.dir, "missing/n.tga");
    E2eRun r;
    const char *args[] = {"-input", f.scene, "-output", f.out, "-normals", normals, "-size",
                          "8", "8", NULL};
    expect_status(args, 1, "unwritable -normals", &r);
    CHECK(!e2e_exists(normals));
    int n = e2e_count_entries(f.dir);
    CHECK_MSG(n == 2 || n == 3, "%d entries in the folder (temporary file left?)", n);
    e2e_run_free(&r);
    e2e_rmtree(f.dir);
}

static void test_stats_on_stdout(void)
{
    Fixture f;
    fixture_init(&f);
    E2eRun r;
    const char *args[] = {"-input", f.scene, "-output", f.out, "-size", "20", "10", "-stats",
                          NULL};
    expect_status(args, 0, "-stats", &r);
    E2eStats s;
    CHECK_MSG(e2e_stats_parse(r.out, &s), "no statistics block on stdout: %.300s", r.out);
    char why[512] = "";
    CHECK_MSG(e2e_stats_layout_ok(&s, 20, 10, why, sizeof why), "%s", why);
    /* one sphere, no shadows, no bounces: one ray and one test per pixel */
    CHECK_INT(s.nonshadow, 200);
    CHECK_INT(s.shadow, 0);
    CHECK_INT(s.intersections, 200);
    CHECK_STR(s.values[2], "-1.000000 -1.000000 -1.000000  -> 1.000000 1.000000 1.000000");
    e2e_run_free(&r);
    e2e_rmtree(f.dir);
}

/* The image comparison tool (docs/images.md): figures and exit statuses. */
static void test_imgdiff_tool(void)
{
    const char *tools = getenv("RT_TOOLS");
    char bin[PATH_MAX];
    if (!tools || !*tools)
        tools = "build/tools";
    e2e_join(bin, sizeof bin, tools, "imgdiff");
    if (access(bin, X_OK) != 0) {
        harness_fail(__FILE__, __LINE__, "%s not found (make builds it)", bin);
        return;
    }
    char dir[PATH_MAX], a[PATH_MAX], b[PATH_MAX], c[PATH_MAX], d[PATH_MAX], missing[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "imgdiff") != NULL);
    e2e_join(a, sizeof a, dir, "a.tga");
    e2e_join(b, sizeof b, dir, "b.ppm");
    e2e_join(c, sizeof c, dir, "c.tga");
    e2e_join(d, sizeof d, dir, "diff.tga");
    e2e_join(missing, sizeof missing, dir, "nothere.tga");
    /* 10x10: b equals a; c differs by 20/255 in one channel of 2 pixels (98% within 8) */
    Image img;
    Diag diag;
    diag_init(&diag, NULL);
    CHECK(image_init(&img, 10, 10));
    image_fill(&img, v3(0.5f, 0.25f, 0.75f));
    CHECK(image_write(&img, a, &diag));
    CHECK(image_write(&img, b, &diag));
    image_set(&img, 3, 4, v3(0.5f + 20.0f / 255.0f, 0.25f, 0.75f));
    image_set(&img, 7, 1, v3(0.5f, 0.25f, 0.75f - 20.0f / 255.0f));
    CHECK(image_write(&img, c, &diag));
    image_free(&img);

    E2eRun r;
    char *same[] = {bin, a, b, NULL};
    CHECK(e2e_run(same, &r));
    CHECK_INT(r.status, 0);
    CHECK_CONTAINS(r.out, "PASS");
    CHECK_CONTAINS(r.out, "100.000%");
    e2e_run_free(&r);

    char *differ[] = {bin, a, c, "-o", d, NULL};
    CHECK(e2e_run(differ, &r));
    CHECK_INT(r.status, 1);
    CHECK_CONTAINS(r.out, "FAIL");
    CHECK_CONTAINS(r.out, "98.000%");
    CHECK_CONTAINS(r.out, "max diff        20");
    e2e_run_free(&r);
    CHECK(image_read(&img, d, &diag));
    if (img.pixels) {
        CHECK_INT(image_color_to_byte(image_get(&img, 3, 4).x), 160); /* 20 x 8 */
        CHECK_INT(image_color_to_byte(image_get(&img, 0, 0).x), 0);
    }
    image_free(&img);

    char *loose[] = {bin, "-t", "20", "-q", a, c, NULL};
    CHECK(e2e_run(loose, &r));
    CHECK_INT(r.status, 0);
    CHECK_INT(r.out_len, 0);
    e2e_run_free(&r);
    char *low_bar[] = {bin, "-p", "97.5", a, c, NULL};
    CHECK(e2e_run(low_bar, &r));
    CHECK_INT(r.status, 0);
    e2e_run_free(&r);

    /* different sizes: a difference (1), not an error */
    char small[PATH_MAX];
    e2e_join(small, sizeof small, dir, "small.tga");
    CHECK(image_init(&img, 4, 3));
    CHECK(image_write(&img, small, &diag));
    image_free(&img);
    char *sizes[] = {bin, a, small, NULL};
    CHECK(e2e_run(sizes, &r));
    CHECK_INT(r.status, 1);
    CHECK_CONTAINS(r.out, "size differs: 10x10 vs 4x3");
    e2e_run_free(&r);

    char *unreadable[] = {bin, a, missing, NULL};
    CHECK(e2e_run(unreadable, &r));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "nothere.tga");
    e2e_run_free(&r);
    char *bad_opt[] = {bin, "-x", a, b, NULL};
    CHECK(e2e_run(bad_opt, &r));
    CHECK_INT(r.status, 2);
    e2e_run_free(&r);
    char *one_file[] = {bin, a, NULL};
    CHECK(e2e_run(one_file, &r));
    CHECK_INT(r.status, 2);
    e2e_run_free(&r);
    char *bad_t[] = {bin, "-t", "abc", a, b, NULL};
    CHECK(e2e_run(bad_t, &r));
    CHECK_INT(r.status, 2);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* No temporary file of ours (".null.XXXXXX") in /dev. */
static int dev_temporaries(void)
{
    DIR *d = opendir("/dev");
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)) != NULL)
        n += strncmp(e->d_name, ".null.", 6) == 0;
    if (d)
        closedir(d);
    return n;
}

/* -output /dev/null (and the other images, and a link to it, and -merge's output) is
 * accepted though it has no extension: the render runs, TGA bytes go into the device in
 * place (no temporary file in /dev), exit 0. It was "unknown image format". Another
 * device without an extension stays a usage error. */
static void test_null_device(void)
{
    Fixture f;
    fixture_init(&f);
    E2eRun r;
    int before = dev_temporaries();
    const char *a1[] = {"-input", f.scene, "-output", "/dev/null", "-depth", "9", "11",
                        "/dev/null", "-normals", "/dev/null", "-size", "16", "16", NULL};
    CHECK_INT(run(a1, &r), 0);
    CHECK_MSG(r.err_len == 0 && r.out_len == 0, "stdout '%s', stderr '%s'", r.out, r.err);
    e2e_run_free(&r);
    const char *a2[] = {"-input", f.scene, "-output", "/dev/null", "-size", "16", "16",
                        "-jittered_samples", "4", "-gaussian_filter", "1", NULL};
    CHECK_INT(run(a2, &r), 0);
    CHECK_MSG(r.err_len == 0, "stderr '%s'", r.err);
    e2e_run_free(&r);
    char link[PATH_MAX];
    e2e_join(link, sizeof link, f.dir, "discard");
    CHECK(symlink("/dev/null", link) == 0);
    const char *a3[] = {"-input", f.scene, "-output", link, "-size", "16", "16", NULL};
    CHECK_INT(run(a3, &r), 0);
    e2e_run_free(&r);
    struct stat st;
    CHECK(lstat(link, &st) == 0 && S_ISLNK(st.st_mode));
    CHECK(stat("/dev/null", &st) == 0 && S_ISCHR(st.st_mode));
    /* -merge into it: two halves rendered as parts */
    char p1[PATH_MAX], p2[PATH_MAX];
    e2e_join(p1, sizeof p1, f.dir, "p1.tga");
    e2e_join(p2, sizeof p2, f.dir, "p2.tga");
    const char *a4[] = {"-input", f.scene, "-size", "16", "16", "-tile", "0", "2", "-output",
                        p1, NULL};
    const char *a5[] = {"-input", f.scene, "-size", "16", "16", "-tile", "1", "2", "-output",
                        p2, NULL};
    CHECK_INT(run(a4, &r), 0);
    e2e_run_free(&r);
    CHECK_INT(run(a5, &r), 0);
    e2e_run_free(&r);
    const char *a6[] = {"-merge", "/dev/null", p1, p2, NULL};
    CHECK_INT(run(a6, &r), 0);
    CHECK_MSG(r.err_len == 0, "stderr '%s'", r.err);
    e2e_run_free(&r);
    CHECK_INT(e2e_count_entries(f.dir), 5); /* scene, bad scene, link, two parts */
    CHECK_INT(dev_temporaries(), before);
    const char *a7[] = {"-input", f.scene, "-output", "/dev/zero", NULL};
    CHECK_INT(run(a7, &r), 2);
    CHECK_CONTAINS(r.err, "unknown image format '/dev/zero'");
    e2e_run_free(&r);
    e2e_rmtree(f.dir);
}

/* -render_filter alone draws the filter from its options, -size and the zoom: the
 * picture is the same whether the scene is good, missing, broken or not given at all
 * (before, the scene was read: no -input was a usage error, exit 2, and a missing or
 * broken scene exit 1). Anything that shows the scene still needs it: -output with no
 * -input stays a usage error, and a broken scene with -stats an input error. */
static void test_filter_picture_without_scene(void)
{
    Fixture f;
    fixture_init(&f);
    char ref[PATH_MAX], pic[PATH_MAX], missing[PATH_MAX], why[512];
    e2e_join(ref, sizeof ref, f.dir, "ref.tga");
    e2e_join(pic, sizeof pic, f.dir, "pic.tga");
    e2e_join(missing, sizeof missing, f.dir, "nothere.txt");
    E2eRun r;
    const char *good[] = {"-input", f.scene, "-size", "5", "4", "-render_filter", ref, "3",
                          "-tent_filter", "1.2", NULL};
    expect_status(good, 0, "filter picture with a good scene", &r);
    e2e_run_free(&r);
    size_t ref_len = 0;
    char *want = e2e_read_file(ref, &ref_len);
    CHECK_MSG(want && ref_len == 18 + 16 * 13 * 3, "the picture has %zu bytes", ref_len);
    const char *scenes[] = {NULL, missing, f.bad_scene};
    const char *what[] = {"no -input", "a missing scene", "a broken scene"};
    for (int i = 0; i < 3; i++) {
        const char *args[] = {"-size", "5", "4", "-render_filter", pic, "3", "-tent_filter",
                              "1.2", "-input", scenes[i], NULL};
        if (!scenes[i])
            args[8] = NULL; /* no -input at all */
        CHECK_MSG(run(args, &r) == 0 && r.err_len == 0, "filter picture with %s: %s",
                  what[i], e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
        size_t len = 0;
        char *got = e2e_read_file(pic, &len);
        CHECK_MSG(got && want && len == ref_len && memcmp(got, want, len) == 0,
                  "filter picture with %s differs from the one with the scene", what[i]);
        free(got);
        unlink(pic);
    }
    free(want);
    const char *with_output[] = {"-size", "5", "4", "-render_filter", pic, "3", "-output",
                                 f.out, NULL};
    expect_status(with_output, 2, "-render_filter and -output without -input", &r);
    CHECK_CONTAINS(r.err, "-input scene.txt is required");
    e2e_run_free(&r);
    const char *with_stats[] = {"-input", f.bad_scene, "-size", "5", "4", "-render_filter",
                                pic, "3", "-stats", NULL};
    expect_status(with_stats, 1, "-render_filter -stats with a broken scene", &r);
    e2e_run_free(&r);
    CHECK(!e2e_exists(pic) && !e2e_exists(f.out));
    e2e_rmtree(f.dir);
}

static const TestCase tests[] = {
    {"cli: -timings prints phase times on stderr", test_timings},
    {"cli: Ctrl-C exits 130 and writes nothing", test_interrupt},
    {"cli: good render exits 0, image correct", test_good_render},
    {"cli: -output .ppm, -depth, -normals together", test_all_three_images_and_ppm},
    {"cli: usage errors exit 2, write nothing", test_usage_errors},
    {"cli: -h and --help", test_help},
    {"cli: --version lists features", test_version},
    {"cli: missing scene exits 1", test_missing_scene},
    {"cli: bad scene exits 1, located, no output", test_bad_scene_leaves_no_output},
    {"cli: unwritable output exits 1, no file", test_unwritable_output},
    {"cli: failed second image leaves no temp file", test_failed_second_image_leaves_no_first},
    {"cli: -stats block on stdout", test_stats_on_stdout},
    {"cli: -output /dev/null renders and discards", test_null_device},
    {"cli: -render_filter alone needs no scene", test_filter_picture_without_scene},
    {"imgdiff: figures, exit statuses, -o", test_imgdiff_tool},
};

RT_TEST_MAIN(tests)
