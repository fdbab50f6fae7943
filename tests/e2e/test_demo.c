/* make demo (scenes/demo.sh) with a stand-in for the renderer (a shell script that
 * answers --version as told and writes each -output, -depth and -normals file), so the
 * script's own rules are checked in a second: PNG images when the binary has PNG, TGA
 * otherwise; the log of a quiet render is deleted, a log with text kept; the table's
 * time column lines up on every row. */
#define _POSIX_C_SOURCE 200809L
#include "../harness.h"
#include "e2e_util.h"

/* The stand-in: prints the features line with PNG_ANSWER, writes "x" into every file
 * named by -output, -depth (third value) and -normals, prints a warning for the
 * scene feat_nolights.txt (as the real one does), and for -stats a warning and a
 * statistics block framed by lines of asterisks. */
#define STARS "********************************************"
static const char k_stub[] =
    "#!/bin/sh\n"
    "if [ \"$1\" = --version ]; then echo 'features: png PNG_ANSWER, gui window no'; exit 0; fi\n"
    "while [ $# -gt 0 ]; do\n"
    "  case $1 in\n"
    "  -output|-normals) echo x > \"$2\"; shift 2 ;;\n"
    "  -depth) echo x > \"$4\"; shift 4 ;;\n"
    "  -input) case $2 in *feat_nolights.txt) echo 'warning: no lights' >&2 ;; esac; shift 2 ;;\n"
    "  -stats) echo 'warning: before the block' >&2; echo '" STARS "'; echo 'RAY TRACING "
    "STATISTICS'; echo '  num pixels 1'; echo '" STARS "'; shift ;;\n"
    "  *) shift ;;\n"
    "  esac\n"
    "done\n";

static void run_demo(const char *png_answer, const char *ext)
{
    char dir[PATH_MAX], stub[PATH_MAX], out[PATH_MAX], script[PATH_MAX], path[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "demo") != NULL);
    e2e_join(stub, sizeof stub, dir, "stub.sh");
    e2e_join(out, sizeof out, dir, "out");
    char text[sizeof k_stub + 128];
    const char *at = strstr(k_stub, "PNG_ANSWER");
    snprintf(text, sizeof text, "%.*s%s%s", (int)(at - k_stub), k_stub, png_answer,
             at + strlen("PNG_ANSWER"));
    CHECK(e2e_write_file(stub, text));
    CHECK(chmod(stub, 0755) == 0);
    e2e_join(path, sizeof path, harness_root(), "scenes/demo.sh");
    CHECK(e2e_abspath(path, script, sizeof script));
    char *argv[] = {(char *)"/bin/sh", script, stub, out, NULL};
    E2eRun r;
    char why[512];
    CHECK(e2e_run(argv, &r));
    CHECK_MSG(r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    /* The images in the right format. */
    static const char *const names[] = {"showcase", "feat_ortho", "feat_ortho_depth",
                                        "feat_ortho_normals", "feat_nolights", "tex_wood"};
    for (size_t i = 0; i < sizeof names / sizeof names[0]; i++) {
        char file[64];
        snprintf(file, sizeof file, "%s.%s", names[i], ext);
        e2e_join(path, sizeof path, out, file);
        CHECK_MSG(e2e_exists(path), "demo did not write %s", file);
    }
    /* Logs: only the one with text is left. */
    e2e_join(path, sizeof path, out, "feat_nolights.log");
    CHECK_MSG(e2e_exists(path), "the log holding a warning was deleted");
    e2e_join(path, sizeof path, out, "feat_ortho.log");
    CHECK_MSG(!e2e_exists(path), "an empty log was left");
    /* The table: every row's " s " (after the seconds) at the same column. */
    int rows = 0, column = -1;
    bool aligned = true;
    const char *table = r.out ? r.out : "";
    for (const char *line = table; *line;) {
        const char *eol = strchr(line, '\n');
        size_t len = eol ? (size_t)(eol - line) : strlen(line);
        char suffix[8];
        snprintf(suffix, sizeof suffix, ".%s ", ext);
        const char *name_end = NULL;
        for (const char *p = line; p + strlen(suffix) <= line + len; p++)
            if (!strncmp(p, suffix, strlen(suffix))) {
                name_end = p;
                break;
            }
        const char *secs = NULL;
        for (const char *p = line; p + 3 <= line + len; p++)
            if (!strncmp(p, " s  ", 4)) {
                secs = p;
                break;
            }
        if (name_end && secs && !strncmp(line, "  ", 2)) {
            int col = (int)(secs - line);
            if (column < 0)
                column = col;
            aligned = aligned && col == column;
            rows++;
        }
        line = eol ? eol + 1 : line + len;
    }
    CHECK_MSG(rows >= 15, "only %d table rows in: %s", rows, table);
    CHECK_MSG(aligned, "the time column is not aligned:\n%s", table);
    /* The showcase's statistics block, whole: both lines of asterisks, no warning. */
    CHECK_MSG(strstr(table, "\n" STARS "\nRAY TRACING STATISTICS\n  num pixels 1\n" STARS
                            "\n") != NULL && !strstr(table, "before the block"),
              "the statistics block is not shown whole:\n%s", table);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

static void test_demo_png(void) { run_demo("yes", "png"); }
static void test_demo_tga(void) { run_demo("no (install libpng-dev and rebuild (make PNG=1))", "tga"); }

static const TestCase tests[] = {
    {"demo: PNG when built with libpng, logs, table", test_demo_png},
    {"demo: TGA without libpng", test_demo_tga},
};

RT_TEST_MAIN(tests)
