/* The real -gui window, run under xvfb-run (no shell: fork/exec): it opens, runs a
 * -gui_keys script (screenshot, `r` progressive trace, `t` ray tree, `q`), writes the
 * screenshots and the requested -output, and exits 0. Skipped when the window is not
 * built or xvfb-run is absent (Debian: apt-get install xvfb xauth). */
#define _POSIX_C_SOURCE 200809L
#include <dlfcn.h>

#include "../harness.h"
#include "e2e_util.h"

#include "rt/image.h"
#include "rt/preview.h"

/* Perspective view of a checkerboard sphere: the preview shows the first material
 * (red) only, the ray-traced picture both squares (red and white). */
static const char *SCENE =
    "PerspectiveCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 angle 30 }\n"
    "Lights { numLights 1 DirectionalLight { direction -1 -0.2 -0.3 color 0.9 0.9 0.9 } }\n"
    "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }\n"
    "Materials { numMaterials 3\n"
    "  PhongMaterial { diffuseColor 1 0 0 }\n"
    "  PhongMaterial { diffuseColor 1 1 1 }\n"
    "  Checkerboard { Transform { UniformScale 2 } materialIndex 0 materialIndex 1 }\n"
    "}\n"
    "Group { numObjects 1 MaterialIndex 2 Sphere { center 0 0 0 radius 1.5 } }\n";

/* xvfb-run's full path from PATH, or NULL. */
static const char *find_xvfb_run(char *buf, size_t size)
{
    const char *path = getenv("PATH");
    if (!path)
        path = "/usr/bin:/bin";
    while (*path) {
        const char *end = strchr(path, ':');
        size_t n = end ? (size_t)(end - path) : strlen(path);
        if (n > 0 && snprintf(buf, size, "%.*s/xvfb-run", (int)n, path) < (int)size &&
            access(buf, X_OK) == 0)
            return buf;
        path += n + (end ? 1 : 0);
    }
    return NULL;
}

static float max_diff(Vec3 a, Vec3 b)
{
    return fmaxf(fabsf(a.x - b.x), fmaxf(fabsf(a.y - b.y), fabsf(a.z - b.z)));
}

static bool load(Image *img, const char *path)
{
    Diag d;
    diag_init(&d, stderr);
    return image_read(img, path, &d);
}

/* Pixels that look like the white checker square (lit, all channels alike, bright). */
static int count_whitish(const Image *img)
{
    int n = 0;
    for (long p = 0; p < (long)img->width * img->height; p++) {
        Vec3 c = img->pixels[p];
        n += c.x > 0.5f && c.y > 0.5f && c.z > 0.5f && max_diff(c, v3(c.x, c.x, c.x)) < 0.05f;
    }
    return n;
}

static int count_green(const Image *img)
{
    int n = 0;
    for (long p = 0; p < (long)img->width * img->height; p++) {
        Vec3 c = img->pixels[p];
        n += c.y > 0.5f && c.y > c.x + 0.3f && c.y > c.z + 0.3f;
    }
    return n;
}

/* Skips the calling test unless the window is built in and xvfb-run is found (its
 * path into xvfb). */
static void need_window_and_xvfb(char *xvfb, size_t size)
{
    if (!preview_window_built())
        harness_skip("built without freeglut (apt-get install libglut-dev, rebuild)");
    if (!find_xvfb_run(xvfb, size))
        harness_skip("xvfb-run not found (apt-get install xvfb xauth)");
}

static void test_window_script_under_xvfb(void)
{
    char xvfb[PATH_MAX];
    need_window_and_xvfb(xvfb, sizeof xvfb);
    char dir[PATH_MAX], scene[PATH_MAX], a[PATH_MAX], b[PATH_MAX], c[PATH_MAX],
        out[PATH_MAX], keys[4 * PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "gui") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(a, sizeof a, dir, "preview.tga");
    e2e_join(b, sizeof b, dir, "traced.tga");
    e2e_join(c, sizeof c, dir, "tree.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    CHECK(e2e_write_file(scene, SCENE));
    snprintf(keys, sizeof keys, "shot:%s r shot:%s t:200,200 shot:%s q", a, b, c);
    /* -a finds a free display number starting at -n; a start of our own makes a clash
     * with another xvfb-run started at the same moment (parallel test runs) unlikely,
     * and such a clash ("cannot open the X display") is retried below. */
    char servernum[32];
    snprintf(servernum, sizeof servernum, "%d", 100 + (int)(getpid() % 800));
    char *argv[] = {xvfb, "-a", "-n", servernum, "-s", "-screen 0 640x480x24",
                    (char *)harness_bin(),
                    "-input", scene, "-size", "200", "200", "-shadows", "-gui", "-stats",
                    "-output", out, "-gui_keys", keys, NULL};
    /* Under `make asan`: Mesa's X driver keeps allocations and is unloaded before the
     * leak check runs, so LeakSanitizer cannot name (or suppress) them; leaks are not
     * checked for this run. The same drawing code is leak-checked through OSMesa
     * (tests/unit/test_preview.c). No effect on builds without sanitizers. */
    char asan[1024];
    const char *prev = getenv("ASAN_OPTIONS");
    snprintf(asan, sizeof asan, "%s%sdetect_leaks=0", prev ? prev : "",
             prev && *prev ? ":" : "");
    setenv("ASAN_OPTIONS", asan, 1);
    E2eRun r;
    char why[512];
    CHECK(e2e_run(argv, &r));
    for (int k = 0; k < 3 && r.status != 0 && strstr(r.err, "X display"); k++) {
        e2e_run_free(&r);
        snprintf(servernum, sizeof servernum, "%d", 100 + (int)((getpid() + 97 * k + 31) % 800));
        CHECK(e2e_run(argv, &r));
    }
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    /* The statistics of the `r` render start on a line of their own. */
    CHECK_CONTAINS(r.out, "Rendering scene...\n********************************************\n"
                          "RAY TRACING STATISTICS");
    CHECK_CONTAINS(r.out, "Rendering done.");
    CHECK_CONTAINS(r.out, "ray tree of pixel (200, 200)");
    Image ia = {0}, ib = {0}, ic = {0}, io = {0};
    if (r.status == 0 && load(&ia, a) && load(&ib, b) && load(&ic, c) && load(&io, out)) {
        /* The window is the course's 400 x 400 for -size 200 200. */
        CHECK_INT(ia.width, 400);
        CHECK_INT(ia.height, 400);
        CHECK_INT(io.width, 200);
        Vec3 bg = v3(0.1f, 0.2f, 0.3f);
        CHECK(max_diff(image_get(&ia, 0, 0), bg) < 0.01f);
        CHECK(max_diff(image_get(&ia, 399, 399), bg) < 0.01f);
        Vec3 mid = image_get(&ia, 200, 200);
        CHECK_MSG(mid.x > 0.3f && mid.y < 0.05f && mid.z < 0.05f,
                  "preview centre %.3f %.3f %.3f", (double)mid.x, (double)mid.y, (double)mid.z);
        /* The GL preview shows only the first (red) material; the traced one both. */
        CHECK_INT(count_whitish(&ia), 0);
        CHECK(count_whitish(&ib) > 1000);
        /* The traced window agrees with the 200 x 200 -output written by the same `r`. */
        int close = 0;
        for (int y = 0; y < 200; y++)
            for (int x = 0; x < 200; x++)
                close += max_diff(image_get(&ib, 2 * x, 2 * y), image_get(&io, x, y)) < 0.1f;
        CHECK_MSG(close >= 200 * 200 * 95 / 100, "%d of 40000 pixels agree", close);
        /* After `t` the preview is back, with the green shadow ray drawn. */
        CHECK_INT(count_whitish(&ic), 0);
        CHECK(count_green(&ic) > 50);
    }
    image_free(&ia);
    image_free(&ib);
    image_free(&ic);
    image_free(&io);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

static void test_window_without_display(void)
{
    char dir[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "guinodisp") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    CHECK(e2e_write_file(scene, SCENE));
    unsetenv("DISPLAY"); /* this test runs in its own forked child */
    const char *args[] = {"-input", scene, "-gui", NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    if (preview_window_built()) {
        /* Reported, not freeglut's exit: status 1 and a pointer to -gui_snapshot. */
        CHECK_INT(r.status, 1);
        CHECK_CONTAINS(r.err, "X display");
    } else {
        /* The remedy the build's own: a PREVIEW=0 build (mk/preview.mk defines
         * RT_PREVIEW_LEFT_OUT for it and its tests) says it leaves the window out on
         * purpose; one that found no GLUT says what to install. */
        CHECK_INT(r.status, 2);
#ifdef RT_PREVIEW_LEFT_OUT
        CHECK_CONTAINS(r.err, "this build leaves it out on purpose, PREVIEW=0");
#else
        CHECK_CONTAINS(r.err, "apt-get install libglut-dev");
#endif
    }
    CHECK_INT(e2e_count_entries(dir), 1);
    e2e_run_free(&r);
    if (preview_window_built()) {
        /* t:I,J counts the window's pixels (-size 200 100: 400 x 200), checked before the
         * display is looked at: the last pixel passes on to the display's error. */
        const char *out_args[] = {"-input", scene, "-size", "200", "100", "-gui",
                                  "-gui_keys", "t:0,200", NULL};
        CHECK(e2e_run_bin(harness_bin(), out_args, &r));
        CHECK_INT(r.status, 2);
        CHECK_CONTAINS(r.err, "t:0,200 is outside the 400x200 window");
        e2e_run_free(&r);
        const char *in_args[] = {"-input", scene, "-size", "200", "100", "-gui",
                                 "-gui_keys", "t:399,199", NULL};
        CHECK(e2e_run_bin(harness_bin(), in_args, &r));
        CHECK_INT(r.status, 1);
        CHECK_CONTAINS(r.err, "X display");
        e2e_run_free(&r);
    }
    e2e_rmtree(dir);
}

/* ---- a window destroyed by another X client ------------------------------------- */

/* `test_gui_xvfb --destroy-window`, run inside the same xvfb-run: destroys the window
 * titled "OpenGL Viewer" through libX11 (opened at run time: the tests do not link X).
 * Exit 0 when done, 1 when no such window showed up within 30 s. */
static int destroy_window(void)
{
    typedef void Dpy;
    typedef unsigned long XWin;
    void *x11 = dlopen("libX11.so.6", RTLD_NOW);
    if (!x11)
        return 1;
    Dpy *(*open_display)(const char *) = (Dpy * (*)(const char *))dlsym(x11, "XOpenDisplay");
    XWin (*root_of)(Dpy *) = (XWin(*)(Dpy *))dlsym(x11, "XDefaultRootWindow");
    int (*query_tree)(Dpy *, XWin, XWin *, XWin *, XWin **, unsigned *) =
        (int (*)(Dpy *, XWin, XWin *, XWin *, XWin **, unsigned *))dlsym(x11, "XQueryTree");
    int (*fetch_name)(Dpy *, XWin, char **) =
        (int (*)(Dpy *, XWin, char **))dlsym(x11, "XFetchName");
    int (*destroy)(Dpy *, XWin) = (int (*)(Dpy *, XWin))dlsym(x11, "XDestroyWindow");
    int (*sync)(Dpy *, int) = (int (*)(Dpy *, int))dlsym(x11, "XSync");
    int (*xfree)(void *) = (int (*)(void *))dlsym(x11, "XFree");
    if (!open_display || !root_of || !query_tree || !fetch_name || !destroy || !sync || !xfree)
        return 1;
    Dpy *dpy = open_display(NULL);
    if (!dpy)
        return 1;
    for (int tries = 0; tries < 1500; tries++) {
        XWin root, parent, *kids = NULL;
        unsigned n = 0;
        if (query_tree(dpy, root_of(dpy), &root, &parent, &kids, &n)) {
            for (unsigned i = 0; i < n; i++) {
                char *name = NULL;
                if (fetch_name(dpy, kids[i], &name) && name &&
                    strcmp(name, "OpenGL Viewer") == 0) {
                    xfree(name);
                    destroy(dpy, kids[i]);
                    sync(dpy, 0);
                    xfree(kids);
                    return 0;
                }
                if (name)
                    xfree(name);
            }
            if (kids)
                xfree(kids);
        }
        struct timespec ts = {0, 20 * 1000 * 1000};
        nanosleep(&ts, NULL);
    }
    return 1;
}

/* Runs the shell command cmd under xvfb-run (its own display number, from the process
 * id and salt, so parallel suites do not meet), without ASan's leak check (the X and
 * GL libraries' own allocations) and with a two-minute limit: a hang fails in two
 * minutes, not ten. */
static bool xvfb_sh(char *xvfb, char *cmd, int salt, E2eRun *r)
{
    char servernum[32];
    snprintf(servernum, sizeof servernum, "%d", 100 + (int)((getpid() + salt) % 800));
    char *argv[] = {xvfb, "-a", "-n", servernum, "-s", "-screen 0 640x480x24",
                    "/bin/sh", "-c", cmd, NULL};
    char asan[1024];
    const char *prev = getenv("ASAN_OPTIONS");
    snprintf(asan, sizeof asan, "%s%sdetect_leaks=0", prev ? prev : "",
             prev && *prev ? ":" : "");
    setenv("ASAN_OPTIONS", asan, 1);
    setenv("RT_E2E_TIMEOUT", "120", 1);
    return e2e_run(argv, r);
}

/* The window destroyed from outside (not closed through the window manager): the
 * program notices, says so and exits 0 instead of running on without a window. The
 * destroyer starts once the window is up and running its key script (the c key has
 * printed the camera). */
static void test_window_destroyed_from_outside(void)
{
    char xvfb[PATH_MAX];
    need_window_and_xvfb(xvfb, sizeof xvfb);
    char dir[PATH_MAX], scene[PATH_MAX], self[PATH_MAX], cmd[8 * PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "guidestroy") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    CHECK(e2e_write_file(scene, SCENE));
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    CHECK(n > 0);
    self[n > 0 ? n : 0] = '\0';
    snprintf(cmd, sizeof cmd,
             "cd '%s' && { '%s' -input scene.txt -gui -gui_keys c > out.txt 2> err.txt & "
             "pid=$!; i=0; while ! grep -q Camera out.txt && [ $i -lt 3000 ]; do "
             "sleep 0.02; i=$((i+1)); done; '%s' --destroy-window; echo \"destroyer $?\"; "
             "wait $pid; echo \"raytracer $?\"; cat err.txt; }",
             dir, harness_bin(), self);
    E2eRun r;
    char why[512];
    CHECK(xvfb_sh(xvfb, cmd, 401, &r));
    CHECK_MSG(r.status == 0 && !r.timed_out, "%s; stdout: %.500s",
              e2e_describe(&r, why, sizeof why), r.out);
    CHECK_CONTAINS(r.out, "destroyer 0");
    CHECK_CONTAINS(r.out, "raytracer 0");
    CHECK_CONTAINS(r.out, "the preview window was destroyed");
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* Ctrl-C in the terminal (SIGINT) while the window is up: the window closes, the
 * program says so and exits 130, as a render does. It ignored SIGINT, SIGTERM and
 * SIGHUP (GLUT's loop never looked at the stop flag): only SIGKILL ended it. The
 * signal is sent once the window is up and running its key script; a run still there
 * 60 s later is killed (status 137: the test fails, nothing is left running). The
 * program runs in the foreground of its shell and the signalling loop in the
 * background: a shell starts its background jobs with SIGINT ignored, and a signal
 * ignored at the start stays ignored (README section 5). */
static void test_window_stopped_by_signal(void)
{
    char xvfb[PATH_MAX];
    need_window_and_xvfb(xvfb, sizeof xvfb);
    char dir[PATH_MAX], scene[PATH_MAX], cmd[8 * PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "guisignal") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    CHECK(e2e_write_file(scene, SCENE));
    snprintf(cmd, sizeof cmd,
             "cd '%s' && { (i=0; while ! grep -q Camera out.txt 2> /dev/null && "
             "[ $i -lt 3000 ]; do sleep 0.02; i=$((i+1)); done; kill -INT $(cat pid); "
             "sleep 60; kill -KILL $(cat pid)) > /dev/null 2>&1 & k=$!; "
             "sh -c 'echo $$ > pid; exec \"$0\" -input scene.txt -gui -gui_keys c "
             "> out.txt 2> err.txt' '%s'; echo \"raytracer $?\"; kill $k; cat err.txt; }",
             dir, harness_bin());
    E2eRun r;
    char why[512];
    CHECK(xvfb_sh(xvfb, cmd, 613, &r));
    CHECK_MSG(r.status == 0 && !r.timed_out, "%s; stdout: %.500s",
              e2e_describe(&r, why, sizeof why), r.out);
    CHECK_CONTAINS(r.out, "raytracer 130");
    CHECK_CONTAINS(r.out, "interrupted; the preview closed");
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"window_script_under_xvfb", test_window_script_under_xvfb},
    {"window_without_display", test_window_without_display},
    {"window_destroyed_from_outside", test_window_destroyed_from_outside},
    {"window_stopped_by_signal", test_window_stopped_by_signal},
};

int main(int argc, char **argv)
{
    if (argc > 1 && strcmp(argv[1], "--destroy-window") == 0)
        return destroy_window();
    return harness_main(argc, argv, tests, TEST_LIST_COUNT(tests));
}
