/* The user's side of the command line: the progress line (under a pseudo-terminal it
 * appears and is erased at the end; into a pipe it is absent unless -progress, and then
 * comes as whole lines), hints, warnings, "did you mean" suggestions and the usage
 * error for a run with nothing to write. */
#define _XOPEN_SOURCE 600
#include <fcntl.h>
#include <poll.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include "../harness.h"
#include "e2e_util.h"

#include "rt/diag.h"
#include "rt/image.h"
#include "rt/preview.h"
#include "rt/progress.h"
#include "rt/suggest.h"

/* Runs the binary with args, its stderr on a new pseudo-terminal (stdout to /dev/null),
 * and returns what the terminal received (malloc'd) and the exit status. */
static char *run_on_pty(const char *const *args, int *status)
{
    *status = -1;
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0)
        return NULL;
    const char *slave_name = ptsname(master);
    if (!slave_name)
        return NULL;
    char *argv[64];
    int n = 0;
    argv[n++] = (char *)harness_bin();
    for (int i = 0; args[i] && n < 63; i++)
        argv[n++] = (char *)args[i];
    argv[n] = NULL;
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        setsid();
        int slave = open(slave_name, O_RDWR);
        int devnull = open("/dev/null", O_RDWR);
        if (slave < 0 || devnull < 0)
            _exit(126);
        /* Raw output: the bytes arrive as written (no \n -> \r\n). */
        struct termios tio;
        if (tcgetattr(slave, &tio) == 0) {
            tio.c_oflag &= ~(tcflag_t)OPOST;
            tcsetattr(slave, TCSANOW, &tio);
        }
        dup2(devnull, 0);
        dup2(devnull, 1);
        dup2(slave, 2);
        close(master);
        execv(argv[0], argv);
        _exit(127);
    }
    size_t len = 0, cap = 0;
    char *text = NULL;
    e2e_append(&text, &len, &cap, "", 0);
    char buf[4096];
    for (;;) {
        ssize_t got = read(master, buf, sizeof buf);
        if (got > 0)
            e2e_append(&text, &len, &cap, buf, (size_t)got);
        else if (got < 0 && errno == EINTR)
            continue;
        else
            break; /* EIO: the last holder of the terminal's other side has gone */
    }
    close(master);
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
    *status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    return text;
}

typedef struct Paths {
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
} Paths;

static void paths_init(Paths *p)
{
    CHECK(e2e_tmpdir(p->dir, sizeof p->dir, "ux") != NULL);
    char rel[PATH_MAX];
    e2e_join(rel, sizeof rel, harness_root(), "scenes/showcase.txt");
    CHECK(e2e_abspath(rel, p->scene, sizeof p->scene));
    e2e_join(p->out, sizeof p->out, p->dir, "out.tga");
}

/* The text left on the terminal's line: what follows the last carriage return. */
static const char *last_segment(const char *text)
{
    const char *cr = strrchr(text, '\r');
    return cr ? cr + 1 : text;
}

static void check_progress_on_terminal(bool antialiased)
{
    Paths p;
    paths_init(&p);
    const char *args[] = {"-input", p.scene, "-output", p.out, "-size", "160", "120",
                          "-shadows", "-grid", "auto",
                          antialiased ? "-jittered_samples" : NULL, "4", "-gaussian_filter",
                          "0.6", NULL};
    int status;
    char *text = run_on_pty(args, &status);
    CHECK(text != NULL);
    CHECK_INT(status, 0);
    if (text) {
        CHECK_CONTAINS(text, "\rrendering ");
        CHECK_CONTAINS(text, "% ");
        CHECK_CONTAINS(text, "elapsed");
        /* Ends cleanly: the last redraw is blanks over the longest line, then a carriage
         * return, and nothing is printed after it. */
        size_t n = strlen(text);
        CHECK_MSG(n >= 2 && text[n - 1] == '\r', "the line is not erased at the end: '%s'",
                  text);
        if (n >= 2 && text[n - 1] == '\r') {
            text[n - 1] = '\0';
            const char *blank = last_segment(text);
            CHECK_MSG(strspn(blank, " ") == strlen(blank) && strlen(blank) >= 20,
                      "the last segment is not the erasing blanks: '%s'", blank);
        }
    }
    free(text);
    CHECK(e2e_exists(p.out));
    e2e_rmtree(p.dir);
}

static void test_progress_on_terminal(void) { check_progress_on_terminal(false); }

/* The film counts its traced pixels: the same line while antialiasing. */
static void test_progress_antialiased(void) { check_progress_on_terminal(true); }

static void test_quiet_on_terminal(void)
{
    Paths p;
    paths_init(&p);
    const char *args[] = {"-input", p.scene, "-output", p.out, "-size", "40", "30", "-quiet",
                          NULL};
    int status;
    char *text = run_on_pty(args, &status);
    CHECK_INT(status, 0);
    CHECK_MSG(text && text[0] == '\0', "-quiet printed '%s'", text ? text : "(null)");
    free(text);
    e2e_rmtree(p.dir);
}

static void test_no_progress_into_pipe(void)
{
    Paths p;
    paths_init(&p);
    const char *args[] = {"-input", p.scene, "-output", p.out, "-size", "40", "30", "-grid",
                          "auto", NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(r.err_len == 0, "stderr into a pipe: '%s'", r.err);
    e2e_run_free(&r);
    /* -progress forces it; into a pipe (a batch job's log) as whole lines, not as a
     * line redrawn with carriage returns ten times a second (~2 MB of log an hour):
     * one each 5% and 30 s at most (none in so short a run) and the final one. */
    const char *forced[] = {"-input", p.scene, "-output", p.out, "-size", "160", "120",
                            "-grid", "auto", "-progress", NULL};
    CHECK(e2e_run_bin(harness_bin(), forced, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(memchr(r.err, '\r', r.err_len) == NULL, "a carriage return into a pipe: '%s'",
              r.err);
    CHECK_MSG(r.err_len > 0 && r.err[r.err_len - 1] == '\n', "not whole lines: '%s'", r.err);
    /* Every line is the progress line's text; the last is the render's end. A slow
     * machine (valgrind) may pass 30 s and 5%: bounded, not exactly one. */
    int lines = 0;
    const char *last = r.err;
    for (const char *l = r.err; *l; l = strchr(l, '\n') + 1) {
        if (!strchr(l, '\n'))
            break;
        CHECK_MSG(strncmp(l, "rendering ", 10) == 0, "not a progress line: '%s'", l);
        last = l;
        lines++;
    }
    CHECK_MSG(lines >= 1 && lines <= 20, "%d lines into a pipe: '%s'", lines, r.err);
    CHECK_MSG(strncmp(last, "rendering 100%  ", 16) == 0 && strstr(last, " elapsed\n"),
              "the final line: '%s'", last);
    e2e_run_free(&r);
    /* Of -progress and -quiet the later decides the line (README 3); -quiet's "no
     * hints" stays either way (the showcase without a grid would get one). */
    const char *quiet_then[] = {"-input", p.scene, "-output", p.out, "-size", "8", "6",
                                "-quiet", "-progress", NULL};
    CHECK(e2e_run_bin(harness_bin(), quiet_then, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(strncmp(r.err, "rendering 100%  ", 16) == 0 && !strstr(r.err, "hint"),
              "-quiet -progress: '%s'", r.err);
    e2e_run_free(&r);
    const char *progress_then[] = {"-input", p.scene, "-output", p.out, "-size", "8", "6",
                                   "-progress", "-quiet", NULL};
    CHECK(e2e_run_bin(harness_bin(), progress_then, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(r.err_len == 0, "-progress -quiet: '%s'", r.err);
    e2e_run_free(&r);
    e2e_rmtree(p.dir);
}

static void test_progress_format(void)
{
    char buf[160];
    progress_format(buf, sizeof buf, "rendering", 25, 100, 3000000, 2.0);
    CHECK_STR(buf, "rendering  25%  1.50 Mrays/s  0:02 elapsed, 0:06 left");
    progress_format(buf, sizeof buf, "tiles", 0, 8, 0, 0.0);
    CHECK_STR(buf, "tiles   0%  0:00 elapsed");
    progress_format(buf, sizeof buf, "rendering", 100, 100, 5000, 3725.0);
    CHECK_STR(buf, "rendering 100%  1 rays/s  1:02:05 elapsed");
    progress_format(buf, sizeof buf, "rendering", 3, 4, 45000, 1.0);
    CHECK_STR(buf, "rendering  75%  45 krays/s  0:01 elapsed, 0:00 left");
    /* Nothing is drawn where nothing is wanted, and NULL is accepted everywhere. */
    CHECK(progress_start(PROGRESS_NEVER, stderr, "x", 10) == NULL);
    CHECK(progress_start(PROGRESS_ALWAYS, stderr, "x", 0) == NULL);
    progress_add(NULL, 1, 1);
    progress_finish(NULL);
}

static void test_suggestions(void)
{
    static const char *const names[] = {"-shadows", "-shade_back", "-size", "-grid", "-gui",
                                        "-h", "--help"};
    const size_t n = sizeof names / sizeof names[0];
    char buf[200];
    suggest_format(buf, sizeof buf, "-shadow", names, n);
    CHECK_STR(buf, " (did you mean -shadows?)");
    suggest_format(buf, sizeof buf, "-sha", names, n);
    CHECK_STR(buf, " (did you mean -shadows or -shade_back?)");
    suggest_format(buf, sizeof buf, "-gird", names, n);
    CHECK_STR(buf, " (did you mean -grid?)");
    suggest_format(buf, sizeof buf, "-zzzzzz", names, n);
    CHECK_STR(buf, "");
    CHECK_INT(suggest_distance("Phongmaterial", "PhongMaterial"), 0);
    CHECK_INT(suggest_distance("Sphre", "Sphere"), 1);
    CHECK_INT(suggest_distance("-sahdows", "-shadows"), 1);
    CHECK_INT(suggest_distance("", "abc"), 3);
}

/* Runs with args and expects status and a message containing want. */
static void expect_run(const char *const *args, int status, const char *want)
{
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    char why[512];
    CHECK_MSG(r.status == status, "%s: %s", args[0], e2e_describe(&r, why, sizeof why));
    CHECK_CONTAINS(r.err, want);
    e2e_run_free(&r);
}

static void test_usage_suggestions(void)
{
    Paths p;
    paths_init(&p);
    const char *a1[] = {"-input", p.scene, "-output", p.out, "-shadow", NULL};
    expect_run(a1, 2, "unknown option '-shadow' (did you mean -shadows?)");
    const char *a2[] = {p.scene, "-output", p.out, NULL};
    char want[PATH_MAX + 64];
    snprintf(want, sizeof want, "(did you mean -input %s?)", p.scene);
    expect_run(a2, 2, want);
    const char *a3[] = {"-input", p.scene, "-output", p.out, "-size", "200", "200", "300", NULL};
    expect_run(a3, 2, "extra value '300' after '-size 200 200': -size takes 2 values");
    const char *a4[] = {"-input", p.scene, NULL};
    expect_run(a4, 2, "nothing to write: give -output FILE");
    const char *a5[] = {"-input", p.scene, "-output", p.out, "-sha", NULL};
    expect_run(a5, 2, "(did you mean -shadows or -shade_back?)");
    /* A size written as one argument, as it often is elsewhere: the message shows the
     * values apart (it only said "w expects an integer"); only when the numbers are as
     * many as the option's values. */
    const char *a6[] = {"-input", p.scene, "-output", p.out, "-size", "200x150", NULL};
    expect_run(a6, 2, "option -size: w expects an integer, got '200x150' (the 2 values are "
               "separate arguments: -size 200 150)\n");
    const char *a7[] = {"-input", p.scene, "-output", p.out, "-grid", "10,10,10", NULL};
    expect_run(a7, 2, "(the 3 values are separate arguments: -grid 10 10 10)\n");
    const char *a8[] = {"-input", p.scene, "-output", p.out, "-grid", "10x10", NULL};
    expect_run(a8, 2, "got '10x10' (raytracer -h for help)\n");
    CHECK(!e2e_exists(p.out));
    e2e_rmtree(p.dir);
}

static void test_warnings_and_hint(void)
{
    Paths p;
    paths_init(&p);
    const char *a1[] = {"-input", p.scene, "-output", p.out, "-size", "8", "8", "-gouraud",
                        "-tessellation", "8", "4", "-gui_keys", "r", "-threads", "1000", NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), a1, &r));
    CHECK_INT(r.status, 0);
    CHECK_CONTAINS(r.err, "warning: -gouraud has no effect without -gui");
    CHECK_CONTAINS(r.err, "warning: -tessellation has no effect");
    CHECK_CONTAINS(r.err, "warning: -gui_keys has no effect");
    CHECK_CONTAINS(r.err, "warning: -threads 1000 on ");
    e2e_run_free(&r);

    /* Options this run does not use: -seed without a random sampler, -no_packets and
     * -no_marking without a grid, -weight without -bounces; each once. With what they
     * act on, none of them. */
    const char *u1[] = {"-input", p.scene, "-output", p.out, "-size", "8", "8",
                        "-uniform_samples", "4", "-seed", "7", "-no_packets", "-no_marking",
                        "-weight", "0.01", NULL};
    CHECK(e2e_run_bin(harness_bin(), u1, &r));
    CHECK_INT(r.status, 0);
    CHECK_CONTAINS(r.err, "warning: -seed has no effect without a random sampler");
    CHECK_CONTAINS(r.err, "warning: -no_packets has no effect without -grid");
    CHECK_CONTAINS(r.err, "warning: -no_marking has no effect without a grid");
    CHECK_CONTAINS(r.err, "warning: -weight has no effect without -bounces");
    e2e_run_free(&r);
    const char *u2[] = {"-input", p.scene, "-output", p.out, "-size", "8", "8",
                        "-jittered_samples", "4", "-seed", "7", "-grid", "2", "2", "2",
                        "-no_packets", "-no_marking", "-bounces", "1", "-weight", "0.01",
                        NULL};
    CHECK(e2e_run_bin(harness_bin(), u2, &r));
    CHECK_INT(r.status, 0);
    CHECK(strstr(r.err, "warning") == NULL);
    e2e_run_free(&r);
    const char *u3[] = {"-input", p.scene, "-output", p.out, "-size", "8", "8",
                        "-adaptive_samples", "4", "16", "0.1", "-seed", "7", "-accel",
                        "twolevel", "-no_marking", NULL};
    CHECK(e2e_run_bin(harness_bin(), u3, &r));
    CHECK_INT(r.status, 0);
    CHECK(strstr(r.err, "warning") == NULL);
    e2e_run_free(&r);

    /* Two samplers and two filters: the later of each wins (the same image as with it
     * alone) and one warning each names both (they passed silently); the same option
     * twice is the plain repeat rule, no warning. */
    char alone[PATH_MAX];
    e2e_join(alone, sizeof alone, p.dir, "alone.tga");
    const char *t1[] = {"-input", p.scene, "-output", p.out, "-size", "8", "8", "-grid", "auto",
                        "-uniform_samples", "4", "-jittered_samples", "9", "-box_filter", "1",
                        "-gaussian_filter", "0.5", NULL};
    CHECK(e2e_run_bin(harness_bin(), t1, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(strcmp(r.err, "raytracer: warning: -uniform_samples and -jittered_samples both "
                            "choose the sampler: the later, -jittered_samples, is used\n"
                            "raytracer: warning: -box_filter and -gaussian_filter both "
                            "choose the filter: the later, -gaussian_filter, is used\n") == 0,
              "stderr:\n%s", r.err);
    e2e_run_free(&r);
    const char *t2[] = {"-input", p.scene, "-output", alone, "-size", "8", "8",
                        "-jittered_samples", "9", "-gaussian_filter", "0.5", NULL};
    CHECK(e2e_run_bin(harness_bin(), t2, &r));
    CHECK_INT(r.status, 0);
    e2e_run_free(&r);
    size_t la = 0, lb = 0;
    char *da = e2e_read_file(p.out, &la), *db = e2e_read_file(alone, &lb);
    CHECK_MSG(da && db && la == lb && memcmp(da, db, la) == 0, "the later sampler and filter "
              "are not the ones used");
    free(da);
    free(db);
    const char *t3[] = {"-input", p.scene, "-output", p.out, "-size", "8", "8", "-grid", "auto",
                        "-adaptive_samples", "4", "16", "0.1", "-uniform_samples", "4",
                        "-jittered_samples", "4", "-jittered_samples", "9", "-tent_filter",
                        "1", "-tent_filter", "2", NULL};
    CHECK(e2e_run_bin(harness_bin(), t3, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(strcmp(r.err, "raytracer: warning: -uniform_samples and -jittered_samples both "
                            "choose the sampler: the later, -jittered_samples, is used\n") == 0,
              "stderr:\n%s", r.err);
    e2e_run_free(&r);

    /* A mesh of 1280 triangles without -grid: one hint; with -grid or -quiet none. */
    char scene[PATH_MAX], model[PATH_MAX], text[PATH_MAX + 512];
    e2e_join(model, sizeof model, harness_root(), "models/icosphere.obj");
    char abs_model[PATH_MAX];
    CHECK(e2e_abspath(model, abs_model, sizeof abs_model));
    snprintf(text, sizeof text,
             "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }\n"
             "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }\n"
             "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
             "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file %s } }\n",
             abs_model);
    e2e_join(scene, sizeof scene, p.dir, "mesh.txt");
    CHECK(e2e_write_file(scene, text));
    const char *a2[] = {"-input", scene, "-output", p.out, "-size", "8", "8", NULL};
    CHECK(e2e_run_bin(harness_bin(), a2, &r));
    CHECK_INT(r.status, 0);
    CHECK_CONTAINS(r.err, "hint: 1280 primitives and no -grid: add -grid auto");
    e2e_run_free(&r);
    const char *a3[] = {"-input", scene, "-output", p.out, "-size", "8", "8", "-grid", "auto",
                        NULL};
    CHECK(e2e_run_bin(harness_bin(), a3, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(r.err_len == 0, "stderr: %s", r.err);
    e2e_run_free(&r);
    const char *a4[] = {"-input", scene, "-output", p.out, "-size", "8", "8", "-quiet", NULL};
    CHECK(e2e_run_bin(harness_bin(), a4, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(r.err_len == 0, "stderr: %s", r.err);
    e2e_run_free(&r);
    /* A filter picture alone traces no ray (README, 9): no hint to speed up tracing,
     * which it gave. With the scene's image as well, the hint again. */
    char fpic[PATH_MAX];
    e2e_join(fpic, sizeof fpic, p.dir, "filter.tga");
    const char *a5[] = {"-input", scene, "-size", "8", "8", "-gaussian_filter", "1",
                        "-render_filter", fpic, "2", NULL};
    CHECK(e2e_run_bin(harness_bin(), a5, &r));
    CHECK_INT(r.status, 0);
    CHECK_MSG(r.err_len == 0, "stderr: %s", r.err);
    CHECK(e2e_exists(fpic));
    e2e_run_free(&r);
    const char *a6[] = {"-input", scene, "-output", p.out, "-size", "8", "8",
                        "-gaussian_filter", "1", "-render_filter", fpic, "2", NULL};
    CHECK(e2e_run_bin(harness_bin(), a6, &r));
    CHECK_INT(r.status, 0);
    CHECK_CONTAINS(r.err, "hint: 1280 primitives and no -grid: add -grid auto");
    e2e_run_free(&r);
    e2e_rmtree(p.dir);
}

/* Output problems are found before the scene is opened: with a scene file that does
 * not exist, the only message is the output's (opening the scene first would report
 * the scene). A name without an image extension is a usage error (2: it was 1, an
 * input/output error, for a problem found in the command line alone), the others are
 * output errors (1). */
static void test_outputs_checked_first(void)
{
    Paths p;
    paths_init(&p);
    char missing_scene[PATH_MAX], in_missing_dir[PATH_MAX], jpg[PATH_MAX];
    e2e_join(missing_scene, sizeof missing_scene, p.dir, "no_such_scene.txt");
    e2e_join(in_missing_dir, sizeof in_missing_dir, p.dir, "nodir/a.tga");
    e2e_join(jpg, sizeof jpg, p.dir, "a.jpg");
    struct {
        const char *flag, *path, *want;
        int status;
    } cases[] = {
        {"-output", jpg, "unknown image format", 2},
        {"-output", in_missing_dir, "No such file or directory", 1},
        {"-output", p.dir, "it is a folder", 1},
        {"-depth", in_missing_dir, "No such file or directory", 1},
        {"-depth", jpg, "unknown image format", 2},
        {"-normals", jpg, "unknown image format", 2},
        {"-gui_snapshot", jpg, "unknown image format", 2},
        {"-render_filter", jpg, "unknown image format", 2},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const char *args[10];
        int n = 0;
        args[n++] = "-input";
        args[n++] = missing_scene;
        args[n++] = cases[i].flag;
        if (!strcmp(cases[i].flag, "-depth")) {
            args[n++] = "1";
            args[n++] = "2";
        }
        args[n++] = cases[i].path;
        if (!strcmp(cases[i].flag, "-render_filter"))
            args[n++] = "2";
        args[n] = NULL;
        E2eRun r;
        CHECK(e2e_run_bin(harness_bin(), args, &r));
        CHECK_MSG(r.status == cases[i].status, "%s %s: exit %d, expected %d", cases[i].flag,
                  cases[i].path, r.status, cases[i].status);
        CHECK_CONTAINS(r.err, cases[i].want);
        CHECK_MSG(!strstr(r.err, "scene"), "%s %s: the scene was opened: %s", cases[i].flag,
                  cases[i].path, r.err);
        e2e_run_free(&r);
    }
    /* With a real scene, the same: one line, nothing written. */
    const char *args[] = {"-input", p.scene, "-output", p.out, "-normals", jpg, NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "raytracer: option -normals: unknown image format '");
    CHECK_CONTAINS(r.err, "a.jpg': the file name must end in one of .tga, .ppm");
    CHECK_MSG(strchr(r.err, '\n') == r.err + r.err_len - 1, "more than one line: %s", r.err);
    e2e_run_free(&r);
    CHECK_INT(e2e_count_entries(p.dir), 0);
    /* -merge's output likewise (the parts are read by their contents, not named). */
    const char *merge[] = {"-merge", jpg, p.scene, NULL};
    CHECK(e2e_run_bin(harness_bin(), merge, &r));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "raytracer: option -merge: unknown image format '");
    CHECK_MSG(strchr(r.err, '\n') == r.err + r.err_len - 1, "more than one line: %s", r.err);
    e2e_run_free(&r);
    CHECK_INT(e2e_count_entries(p.dir), 0);
    e2e_rmtree(p.dir);
}

/* The preview's options are checked before the scene is read, as the outputs are: a
 * bad -gui_keys command and a shot:FILE without an image extension are usage errors
 * (2; shot:a.jpg was 1), a shot:FILE in a missing folder an output error (1), and a
 * build without the preview says so (2); all of them, before, came only after the
 * scene's parse and grid build (here: "cannot open scene file"). Nothing is written. */
static void test_preview_checked_first(void)
{
    Paths p;
    paths_init(&p);
    char missing_scene[PATH_MAX], snap[PATH_MAX], jpg[PATH_MAX], in_missing_dir[PATH_MAX];
    e2e_join(missing_scene, sizeof missing_scene, p.dir, "no_such_scene.txt");
    e2e_join(snap, sizeof snap, p.dir, "snap.tga");
    e2e_join(jpg, sizeof jpg, p.dir, "a.jpg");
    e2e_join(in_missing_dir, sizeof in_missing_dir, p.dir, "nodir/a.tga");
    char shot_jpg[PATH_MAX + 8], shot_missing[PATH_MAX + 8];
    snprintf(shot_jpg, sizeof shot_jpg, "r shot:%s", jpg);
    snprintf(shot_missing, sizeof shot_missing, "shot:%s q", in_missing_dir);
    struct {
        bool window;
        const char *keys, *want;
        int status;
    } cases[] = {
        {false, "r x", "-gui_keys: bad command 'x' at character 3", 2},
        {false, shot_jpg, "unknown image format", 2},
        {false, shot_missing, "No such file or directory", 1},
        {true, "rot:1", "-gui_keys: bad command 'rot:1'", 2},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        bool built = cases[i].window ? preview_window_built() : preview_snapshot_built();
        const char *args[10];
        int n = 0;
        args[n++] = "-input";
        args[n++] = missing_scene;
        if (cases[i].window) {
            args[n++] = "-gui";
        } else {
            args[n++] = "-gui_snapshot";
            args[n++] = snap;
        }
        args[n++] = "-gui_keys";
        args[n++] = cases[i].keys;
        args[n] = NULL;
        E2eRun r;
        CHECK(e2e_run_bin(harness_bin(), args, &r));
        int status = built ? cases[i].status : 2;
        CHECK_MSG(r.status == status, "-gui_keys '%s': exit %d, expected %d: %s",
                  cases[i].keys, r.status, status, r.err);
        CHECK_CONTAINS(r.err, built ? cases[i].want : "is not built in");
        CHECK_MSG(!strstr(r.err, "scene"), "-gui_keys '%s': the scene was opened: %s",
                  cases[i].keys, r.err);
        e2e_run_free(&r);
    }
    /* shot:- is standard output (here a pipe), not a name without an extension: the
     * script passes, and the scene's error is the one reported. */
    if (preview_snapshot_built()) {
        const char *args[] = {"-input", missing_scene, "-gui_snapshot", snap, "-gui_keys",
                              "shot:-", NULL};
        E2eRun r;
        CHECK(e2e_run_bin(harness_bin(), args, &r));
        CHECK_INT(r.status, 1);
        CHECK_CONTAINS(r.err, "cannot open scene file");
        e2e_run_free(&r);
    }
    CHECK_INT(e2e_count_entries(p.dir), 0);
    e2e_rmtree(p.dir);
}

/* A -gui_snapshot wider than GL's largest viewport (16384 in Mesa): refused with the
 * limit named (exit 2, no file). It was drawn squeezed into the first 16384 columns and
 * written with the rest background (feat_ortho's shapes ended at 0.67 of the width
 * instead of 0.81). Where GL draws wider, the frame must then be whole. */
static void test_snapshot_wider_than_gl(void)
{
    if (!preview_snapshot_built())
        harness_skip("-gui_snapshot not built (apt-get install libosmesa6-dev; rebuild)");
    Paths p;
    paths_init(&p);
    char snap[PATH_MAX], scene[PATH_MAX];
    e2e_join(snap, sizeof snap, p.dir, "wide.tga");
    e2e_join(scene, sizeof scene, harness_root(), "scenes/feat_ortho.txt");
    const char *args[] = {"-input", scene, "-size", "20000", "2", "-gui_snapshot", snap, NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    if (r.status == 2) {
        CHECK_CONTAINS(r.err, "is larger than OpenGL can draw here (at most ");
        CHECK_INT(e2e_count_entries(p.dir), 0);
    } else {
        CHECK_INT(r.status, 0);
        Image img;
        Diag diag;
        diag_init(&diag, NULL);
        CHECK_MSG(image_read(&img, snap, &diag), "%s", diag.last);
        int last = -1;
        for (int x = 0; img.pixels && x < img.width; x++) {
            Vec3 px = image_get(&img, x, 0), bg = image_get(&img, 0, 0);
            if (px.x != bg.x || px.y != bg.y || px.z != bg.z)
                last = x;
        }
        CHECK_MSG(last > img.width * 3 / 4, "the frame ends at column %d of %d", last,
                  img.width);
        image_free(&img);
    }
    e2e_run_free(&r);
    e2e_rmtree(p.dir);
}

/* The preview's g key says on the terminal which view it switched to, like t and c
 * (headless: -gui_snapshot through OSMesa); r's statistics start on a line of their
 * own. */
static void test_preview_keys_print(void)
{
    if (!preview_snapshot_built())
        harness_skip("-gui_snapshot not built (apt-get install libosmesa6-dev; rebuild)");
    Paths p;
    paths_init(&p);
    char shot[PATH_MAX];
    e2e_join(shot, sizeof shot, p.dir, "shot.tga");
    const char *args[] = {"-input", p.scene, "-size", "40", "30", "-grid", "4", "4", "4",
                          "-gui_snapshot", shot, "-gui_keys", "g g g", NULL};
    E2eRun r;
    char why[512];
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    const char *a = strstr(r.out, "grid view: occupied cells");
    const char *b = a ? strstr(a, "grid view: the cells the last traced ray visited") : NULL;
    const char *c = b ? strstr(b, "grid view: objects") : NULL;
    CHECK_MSG(a && b && c, "g did not print its three views in order: '%s'", r.out);
    e2e_run_free(&r);
    e2e_rmtree(p.dir);
}

/* -gui_snapshot renders the images and statistics asked for only through an r in
 * -gui_keys: without one it now says so (before, -output, -stats and the others were
 * left out in silence, exit 0); with r nothing is said and the image is written. */
static void test_snapshot_without_r_warns(void)
{
    if (!preview_snapshot_built())
        harness_skip("-gui_snapshot not built (apt-get install libosmesa6-dev; rebuild)");
    Paths p;
    paths_init(&p);
    char shot[PATH_MAX];
    e2e_join(shot, sizeof shot, p.dir, "shot.tga");
    /* "q r": nothing runs after q. */
    static const char *const keys[] = {NULL, "rot:10,0 t", "q r", "rot:10,0 r"};
    for (int k = 0; k < 4; k++) {
        const char *args[] = {"-input", p.scene, "-size", "16", "12", "-output", p.out,
                              "-stats", "-gui_snapshot", shot,
                              keys[k] ? "-gui_keys" : NULL, keys[k], NULL};
        E2eRun r;
        char why[512];
        CHECK(e2e_run_bin(harness_bin(), args, &r));
        CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
        const char *warning = "warning: nothing is rendered for -output, -stats: with "
                              "-gui_snapshot only an r in -gui_keys renders (-gui_keys r)";
        if (k < 3) {
            CHECK_MSG(strstr(r.err, warning) != NULL, "keys %s: stderr '%s'",
                      keys[k] ? keys[k] : "(none)", r.err);
            CHECK(!e2e_exists(p.out));
        } else {
            CHECK_MSG(strstr(r.err, "warning") == NULL, "with r: stderr '%s'", r.err);
            CHECK(e2e_exists(p.out));
            CHECK_CONTAINS(r.out, "RAY TRACING STATISTICS");
        }
        e2e_run_free(&r);
    }
    e2e_rmtree(p.dir);
}

/* Runs the binary with args, its standard input and standard error on a new
 * pseudo-terminal (stdout to /dev/null), types feed into the terminal followed by the
 * end-of-file character (Ctrl-D), and returns what the terminal showed (malloc'd: the
 * program's stderr and the echo of what was typed) and the exit status. */
static char *run_stdin_on_pty(const char *const *args, const char *feed, int *status)
{
    *status = -1;
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || grantpt(master) != 0 || unlockpt(master) != 0)
        return NULL;
    const char *slave_name = ptsname(master);
    if (!slave_name)
        return NULL;
    char *argv[64];
    int n = 0;
    argv[n++] = (char *)harness_bin();
    for (int i = 0; args[i] && n < 63; i++)
        argv[n++] = (char *)args[i];
    argv[n] = NULL;
    /* The terminal keeps typed lines until the program reads them (canonical mode),
     * once its other side is open: opened here, before the typing below. */
    int slave = open(slave_name, O_RDWR | O_NOCTTY);
    if (slave < 0) {
        close(master);
        return NULL;
    }
    fflush(stdout);
    fflush(stderr);
    pid_t pid = fork();
    if (pid == 0) {
        setsid();
        int devnull = open("/dev/null", O_RDWR);
        if (devnull < 0)
            _exit(126);
        dup2(slave, 0);
        dup2(devnull, 1);
        dup2(slave, 2);
        close(slave);
        close(master);
        execv(argv[0], argv);
        _exit(127);
    }
    close(slave);
    /* The text goes in at once; a Ctrl-D at the start of a line ends it. */
    char eof = 4;
    size_t flen = strlen(feed);
    bool typed = write(master, feed, flen) == (ssize_t)flen && write(master, &eof, 1) == 1;
    size_t len = 0, cap = 0;
    char *text = NULL;
    e2e_append(&text, &len, &cap, "", 0);
    char buf[4096];
    /* A program that waits for more than the one Ctrl-D would hang the test: after 60 s
     * it is killed and the run fails (status -1). */
    double t0 = e2e_now();
    bool hung = false;
    for (;;) {
        double left = 60.0 - (e2e_now() - t0);
        struct pollfd pfd = {master, POLLIN, 0};
        if (left <= 0.0 || poll(&pfd, 1, (int)(left * 1000.0) + 1) == 0) {
            hung = true;
            kill(pid, SIGKILL);
            break;
        }
        ssize_t got = read(master, buf, sizeof buf);
        if (got > 0)
            e2e_append(&text, &len, &cap, buf, (size_t)got);
        else if (got < 0 && errno == EINTR)
            continue;
        else
            break; /* EIO: the last holder of the terminal's other side has gone */
    }
    close(master);
    int st = 0;
    while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
    }
    *status = hung ? -1 : WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
    if (!typed) {
        free(text);
        return NULL;
    }
    return text;
}

/* -input - with a terminal as standard input said nothing and waited: a new user saw a
 * hang. It now says what it waits for (not with -quiet, not from a pipe), and one
 * Ctrl-D ends the scene (it took two: the read went on after the first). */
static void test_stdin_terminal_hint(void)
{
    Paths p;
    paths_init(&p);
    static const char scene[] =
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
        "Group { numObjects 1 MaterialIndex 0\n"
        "Sphere { center 0 0 0 radius 1 } }\n";
    static const char hint[] = "reading the scene from the terminal (-input -)";
    const char *args[] = {"-input", "-", "-output", p.out, "-size", "8", "8", NULL};
    int status;
    char *text = run_stdin_on_pty(args, scene, &status);
    CHECK(text != NULL);
    CHECK_INT(status, 0);
    if (text)
        CHECK_CONTAINS(text, hint);
    free(text);
    CHECK(e2e_exists(p.out));
    const char *quiet[] = {"-input", "-", "-output", p.out, "-size", "8", "8", "-quiet", NULL};
    text = run_stdin_on_pty(quiet, scene, &status);
    CHECK_INT(status, 0);
    CHECK_MSG(text && !strstr(text, hint), "-quiet printed the hint: '%s'",
              text ? text : "(null)");
    free(text);
    /* Standard input that is no terminal (/dev/null here, a pipe alike): no hint, only
     * the empty scene's error. */
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    CHECK_INT(r.status, 1);
    CHECK_MSG(!strstr(r.err, hint), "the hint without a terminal: '%s'", r.err);
    e2e_run_free(&r);
    e2e_rmtree(p.dir);
}

/* The course's zero-lights rule warns where the lights would go: at the Lights block
 * that declares none, or without one at the end of the text (like the errors, a
 * file:line:col a user can jump to). */
static void test_no_lights_warning_located(void)
{
    char dir[PATH_MAX], zero[PATH_MAX], none[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "uxlights") != NULL);
    e2e_join(zero, sizeof zero, dir, "zero.txt");
    e2e_join(none, sizeof none, dir, "none.txt");
    e2e_join(out, sizeof out, dir, "o.tga");
    static const char cam[] =
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }\n";
    static const char rest[] =
        "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 1 1 } }\n"
        "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n";
    char text[1024];
    snprintf(text, sizeof text, "%s\n  Lights {\n    numLights 0\n  }\n%s", cam, rest);
    CHECK(e2e_write_file(zero, text));
    snprintf(text, sizeof text, "%s%s\n", cam, rest);
    CHECK(e2e_write_file(none, text));
    const char *want[2] = {"zero.txt:3:3: warning: no lights specified",
                           "none.txt:5:1: warning: no lights specified"};
    const char *scene[2] = {zero, none};
    for (int k = 0; k < 2; k++) {
        const char *args[] = {"-input", scene[k], "-size", "8", "8", "-output", out, NULL};
        expect_run(args, 0, want[k]);
    }
    e2e_rmtree(dir);
}

/* A Sphere of radius 0 (typed, or under the float range) is read but warned about at
 * its radius: no ray hits a point, so it silently drew nothing. A small radius draws and
 * says nothing. */
static void test_zero_radius_warning(void)
{
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "uxradius") != NULL);
    e2e_join(scene, sizeof scene, dir, "s.txt");
    e2e_join(out, sizeof out, dir, "o.tga");
    const char *radius[3] = {"0", "1e-50", "1e-30"};
    for (int k = 0; k < 3; k++) {
        char text[1024];
        snprintf(text, sizeof text,
                 "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }\n"
                 "Lights { numLights 1 DirectionalLight { direction 0 0 -1 color 1 1 1 } }\n"
                 "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 1 1 } }\n"
                 "Group { numObjects 1 MaterialIndex 0\n"
                 "  Sphere { center 0 0 0 radius %s } }\n",
                 radius[k]);
        CHECK(e2e_write_file(scene, text));
        const char *args[] = {"-input", scene, "-size", "8", "8", "-output", out, NULL};
        if (k < 2) {
            expect_run(args, 0, "s.txt:5:25: warning: this Sphere's radius is 0");
            continue;
        }
        E2eRun r;
        CHECK(e2e_run_bin(harness_bin(), args, &r));
        CHECK_INT(r.status, 0);
        CHECK_MSG(r.err[0] == '\0', "radius %s: stderr '%s'", radius[k], r.err);
        e2e_run_free(&r);
    }
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"ux: a Sphere of radius 0 is warned about", test_zero_radius_warning},
    {"ux: the no-lights warning is located", test_no_lights_warning_located},
    {"ux: the preview's g prints its view", test_preview_keys_print},
    {"ux: the preview's options are checked before the scene is read",
     test_preview_checked_first},
    {"ux: a -gui_snapshot wider than OpenGL draws is refused", test_snapshot_wider_than_gl},
    {"ux: -gui_snapshot without r in -gui_keys warns that nothing is rendered",
     test_snapshot_without_r_warns},
    {"ux: outputs are checked before the scene is read", test_outputs_checked_first},
    {"ux: progress line on a terminal, erased at the end", test_progress_on_terminal},
    {"ux: progress line while antialiasing", test_progress_antialiased},
    {"ux: -quiet on a terminal prints nothing", test_quiet_on_terminal},
    {"ux: no progress into a pipe; -progress forces it, as whole lines",
     test_no_progress_into_pipe},
    {"ux: progress line text", test_progress_format},
    {"ux: edit distance and suggestions", test_suggestions},
    {"ux: usage errors suggest the fix", test_usage_suggestions},
    {"ux: warnings for options without effect, the grid hint", test_warnings_and_hint},
    {"ux: -input - on a terminal says what it waits for", test_stdin_terminal_hint},
};
RT_TEST_MAIN(tests)
