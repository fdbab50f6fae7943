/* Piping: -output - writes the image to standard output (TGA, or -format ppm|png), the
 * same bytes as the file and equal to it through build/tools/imgdiff reading "-";
 * -stats then goes to stderr; -format disagreeing with a file name or unknown is a usage
 * error; -input - reads the scene from standard input (obj_file names from the working
 * folder) into the same image as -input file, and its errors are located "<stdin>:L:C". */
#define _POSIX_C_SOURCE 200809L
#include "../harness.h"
#include "e2e_util.h"

#include "rt/image.h"

typedef struct Env {
    char dir[PATH_MAX];          /* a fresh folder */
    char bin[PATH_MAX];          /* absolute path of the binary under test */
    char imgdiff[PATH_MAX];
    char scenes[PATH_MAX];       /* the project's scenes/, absolute */
} Env;

static bool env_init(Env *e)
{
    char path[PATH_MAX];
    if (!e2e_tmpdir(e->dir, sizeof e->dir, "stdio"))
        return false;
    const char *tools = getenv("RT_TOOLS");
    char tools_buf[PATH_MAX];
    if (!tools || !*tools) {
        e2e_join(tools_buf, sizeof tools_buf, harness_root(), "build/tools");
        tools = tools_buf;
    }
    e2e_join(path, sizeof path, tools, "imgdiff");
    e2e_join(e->scenes, sizeof e->scenes, harness_root(), "scenes");
    char scenes[PATH_MAX];
    snprintf(scenes, sizeof scenes, "%s", e->scenes);
    return e2e_abspath(harness_bin(), e->bin, sizeof e->bin) &&
           e2e_abspath(path, e->imgdiff, sizeof e->imgdiff) &&
           e2e_abspath(scenes, e->scenes, sizeof e->scenes);
}

/* Runs a shell command line (built with printf-style arguments) in e->dir. */
static bool sh(const Env *e, E2eRun *r, const char *fmt, ...) __attribute__((format(printf, 3, 4)));
static bool sh(const Env *e, E2eRun *r, const char *fmt, ...)
{
    char cmd[8 * PATH_MAX];
    int n = snprintf(cmd, sizeof cmd, "cd '%s' && ", e->dir);
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(cmd + n, sizeof cmd - (size_t)n, fmt, ap);
    va_end(ap);
    char *argv[] = {(char *)"/bin/sh", (char *)"-c", cmd, NULL};
    return e2e_run(argv, r);
}

static bool same_file_bytes(const Env *e, const char *a, const char *b)
{
    char pa[PATH_MAX], pb[PATH_MAX];
    e2e_join(pa, sizeof pa, e->dir, a);
    e2e_join(pb, sizeof pb, e->dir, b);
    size_t la = 0, lb = 0;
    char *da = e2e_read_file(pa, &la), *db = e2e_read_file(pb, &lb);
    bool same = da && db && la == lb && la > 0 && memcmp(da, db, la) == 0;
    free(da);
    free(db);
    return same;
}

#define RENDER_ARGS "-input '%s/feat_ortho.txt' -size 64 48 -shadows"

static void check_format(const Env *e, const char *format, const char *ext)
{
    E2eRun r;
    char why[512];
    /* The file, then standard output redirected into a file: the same bytes. */
    CHECK(sh(e, &r, "'%s' " RENDER_ARGS " -output file.%s", e->bin, e->scenes, ext));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    char fmt_opt[32] = "";
    if (format)
        snprintf(fmt_opt, sizeof fmt_opt, "-format %s", format);
    CHECK(sh(e, &r, "'%s' " RENDER_ARGS " -output - %s > piped.%s", e->bin, e->scenes,
             fmt_opt, ext));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    CHECK_MSG(r.err_len == 0, "stderr: %s", r.err);
    e2e_run_free(&r);
    char a[32], b[32];
    snprintf(a, sizeof a, "file.%s", ext);
    snprintf(b, sizeof b, "piped.%s", ext);
    CHECK_MSG(same_file_bytes(e, a, b), "-output - %s differs from -output %s", fmt_opt, a);
    /* Through a pipe into imgdiff, which reads "-": equal to the file, every pixel. */
    CHECK(sh(e, &r, "'%s' " RENDER_ARGS " -output - %s | '%s' -t 0 -p 100 - file.%s",
             e->bin, e->scenes, fmt_opt, e->imgdiff, ext));
    CHECK_MSG(r.status == 0, "imgdiff: %s; stdout: %s", e2e_describe(&r, why, sizeof why),
              r.out);
    CHECK_CONTAINS(r.out, "identical       3072 (100.000%)");
    e2e_run_free(&r);
}

static void test_output_stdout_tga(void)
{
    Env e;
    CHECK(env_init(&e));
    check_format(&e, NULL, "tga");
    check_format(&e, "tga", "tga");
    e2e_rmtree(e.dir);
}

static void test_output_stdout_ppm_png(void)
{
    Env e;
    CHECK(env_init(&e));
    check_format(&e, "ppm", "ppm");
    /* a name in any case, as an extension is (-output X.PPM is a PPM) */
    check_format(&e, "PPM", "ppm");
    if (image_format_supported("png"))
        check_format(&e, "png", "png");
    else
        printf("   (PNG not built in: -format png not compared)\n");
    e2e_rmtree(e.dir);
}

/* The image owns standard output: -stats goes to stderr, stdout is the image alone. */
static void test_stats_on_stderr(void)
{
    Env e;
    CHECK(env_init(&e));
    E2eRun r;
    char why[512];
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -output file.tga", e.bin, e.scenes));
    CHECK_INT(r.status, 0);
    e2e_run_free(&r);
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -output - -stats > piped.tga", e.bin, e.scenes));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    CHECK_CONTAINS(r.err, "RAY TRACING STATISTICS");
    CHECK_CONTAINS(r.err, "num pixels                 3072 (64x48)");
    e2e_run_free(&r);
    CHECK_MSG(same_file_bytes(&e, "file.tga", "piped.tga"),
              "with -stats, standard output is not the image alone");
    e2e_rmtree(e.dir);
}

static void test_format_errors(void)
{
    Env e;
    CHECK(env_init(&e));
    E2eRun r;
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -output a.ppm -format tga", e.bin, e.scenes));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "-format tga, but -output a.ppm is ppm");
    e2e_run_free(&r);
    /* -format is the format of the image on standard output, here -normals': the
     * file keeps its extension's (this was refused as "-format ppm, but -output a.tga
     * is tga"). The piped normals are those written to a .ppm file. */
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -normals n.ppm", e.bin, e.scenes));
    CHECK_INT(r.status, 0);
    e2e_run_free(&r);
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -output a.tga -normals - -format ppm > np.ppm",
             e.bin, e.scenes));
    CHECK_INT(r.status, 0);
    e2e_run_free(&r);
    CHECK_MSG(same_file_bytes(&e, "n.ppm", "np.ppm"), "-normals - -format ppm: not the PPM");
    CHECK(sh(&e, &r, "head -c 2 a.tga | od -An -tx1"));
    CHECK_STR(r.out, " 00 00\n"); /* a TGA's empty ID and colour map, not "P6" */
    e2e_run_free(&r);
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -output - -format jpg > x", e.bin, e.scenes));
    CHECK_INT(r.status, 2);
    /* and it names the formats as -format takes them, without the extensions' dots */
    CHECK_CONTAINS(r.err, "option -format: unknown format 'jpg' (this build writes tga, ppm");
    e2e_run_free(&r);
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -output a.ppm -format TGA", e.bin, e.scenes));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "-format tga, but -output a.ppm is ppm");
    e2e_run_free(&r);
    /* A device or a pipe named for standard output: "-" is said, not "must end in .tga"
     * (which led to -output /dev/stdout.tga, a new file in /dev), whether /dev/stdout
     * leads to a file, as here, or a pipe */
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -output /dev/stdout > x", e.bin, e.scenes));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "option -output: unknown image format '/dev/stdout': a device or a "
                   "pipe has no extension to give one; for standard output give - as the "
                   "file name, and -format for its format (tga, ppm");
    e2e_run_free(&r);
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -normals /dev/fd/1 | cat", e.bin, e.scenes));
    CHECK_CONTAINS(r.err, "option -normals: unknown image format '/dev/fd/1': a device or a "
                   "pipe");
    CHECK_MSG(r.out_len == 0, "%zu bytes written into the pipe", r.out_len);
    e2e_run_free(&r);
    /* The preview prints on stdout (its c key): no image there too. */
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -gui -output - > x", e.bin, e.scenes));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "-gui prints on standard output");
    e2e_run_free(&r);
    /* A reader that goes away (head after 10 of 480,000 bytes): an output error, not a
     * silent death by SIGPIPE. */
    CHECK(sh(&e, &r, "{ '%s' -input '%s/feat_ortho.txt' -size 400 400 -output -; "
             "echo $? > status; } | head -c 10 > /dev/null; cat status", e.bin, e.scenes));
    CHECK_STR(r.out, "1\n");
    CHECK_CONTAINS(r.err, "<stdout>: error: cannot write image");
    e2e_run_free(&r);
    e2e_rmtree(e.dir);
}

/* -input - with a scene using OBJ files: run from scenes/, whose obj_file names
 * (../models/...) then resolve from the working folder, as from the scene's own. */
static void test_input_stdin(void)
{
    Env e;
    CHECK(env_init(&e));
    E2eRun r;
    char why[512];
    CHECK(sh(&e, &r, "cd '%s' && '%s' -input feat_mesh_transform.txt -size 60 40 -grid auto "
             "-output '%s/file.tga'", e.scenes, e.bin, e.dir));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    CHECK(sh(&e, &r, "cd '%s' && '%s' -input - -size 60 40 -grid auto -output '%s/stdin.tga' "
             "< feat_mesh_transform.txt", e.scenes, e.bin, e.dir));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    CHECK_MSG(same_file_bytes(&e, "file.tga", "stdin.tga"), "-input - differs from -input file");
    /* Through a pipe, and both ends at once: scene in, image out. */
    CHECK(sh(&e, &r, "cd '%s' && cat feat_ortho.txt | '%s' -input - -size 64 48 -shadows "
             "-output - > '%s/both.tga' && '%s' " RENDER_ARGS " -output '%s/file2.tga'",
             e.scenes, e.bin, e.dir, e.bin, e.scenes, e.dir));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    CHECK_MSG(same_file_bytes(&e, "both.tga", "file2.tga"), "-input - -output - differs");
    /* Errors name standard input with line and column. */
    CHECK(sh(&e, &r, "printf 'OrthographicCamera {\\n  center 0 0 x }\\n' | '%s' -input - "
             "-output x.tga", e.bin));
    CHECK_INT(r.status, 1);
    CHECK_CONTAINS(r.err, "<stdin>:2:");
    e2e_run_free(&r);
    /* The same scene piped in from another folder: its ../models/ names are not found
     * there, and the message says why (it named the path only, as if the scene's own
     * folder had been searched). */
    CHECK(sh(&e, &r, "cd '%s' && '%s' -input - -size 60 40 -output x.tga < "
             "'%s/feat_mesh_transform.txt'", e.dir, e.bin, e.scenes));
    CHECK_INT(r.status, 1);
    CHECK_CONTAINS(r.err, "in the working folder (a scene read from standard input has no "
                   "folder of its own)");
    e2e_run_free(&r);
    e2e_rmtree(e.dir);
}

/* imgdiff prints each "within N/255" line once, also for its default threshold 8. */
static void test_imgdiff_lines(void)
{
    Env e;
    CHECK(env_init(&e));
    E2eRun r;
    CHECK(sh(&e, &r, "'%s' " RENDER_ARGS " -output a.tga && '%s' a.tga a.tga && "
             "'%s' -t 20 a.tga a.tga", e.bin, e.scenes, e.imgdiff, e.imgdiff));
    CHECK_INT(r.status, 0);
    int eights = 0, twenties = 0;
    for (const char *p = strstr(r.out, "\nwithin 8/255"); p; p = strstr(p + 1, "\nwithin 8/255"))
        eights++;
    for (const char *p = strstr(r.out, "\nwithin 20/255"); p;
         p = strstr(p + 1, "\nwithin 20/255"))
        twenties++;
    CHECK_INT(eights, 2); /* once per run */
    CHECK_INT(twenties, 1);
    e2e_run_free(&r);
    e2e_rmtree(e.dir);
}

static const TestCase tests[] = {
    {"stdio_output_stdout_tga", test_output_stdout_tga},
    {"stdio_output_stdout_ppm_png", test_output_stdout_ppm_png},
    {"stdio_stats_on_stderr", test_stats_on_stderr},
    {"stdio_format_errors", test_format_errors},
    {"stdio_input_stdin", test_input_stdin},
    {"stdio_imgdiff_lines", test_imgdiff_lines},
};

RT_TEST_MAIN(tests)
