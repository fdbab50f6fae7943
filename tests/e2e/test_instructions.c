/* Instruction counts (valgrind's callgrind, which counts every instruction the process
 * executes: the same from run to run, unlike time on a shared machine) of two renders
 * by the same binary, where a past change made one of them far dearer than the other
 * without changing a byte (bench/instructions.sh compares two binaries line by line;
 * docs/benchmarks.md). Ratios, not counts, so that gcc, clang and their versions pass
 * alike. Skipped without valgrind and under the sanitizers (valgrind cannot run them). */
#define _POSIX_C_SOURCE 200809L
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../harness.h"
#include "e2e_util.h"

/* valgrind's path from PATH into buf; false when it is not installed. */
static bool find_valgrind(char *buf, size_t size)
{
    const char *path = getenv("PATH");
    while (path && *path) {
        const char *end = strchr(path, ':');
        size_t n = end ? (size_t)(end - path) : strlen(path);
        if (n > 0 && snprintf(buf, size, "%.*s/valgrind", (int)n, path) < (int)size &&
            access(buf, X_OK) == 0)
            return true;
        path = end ? end + 1 : NULL;
    }
    return false;
}

/* The instructions of the binary under test run with args (NULL-terminated) at
 * -threads 1, from callgrind's "totals:" line; 0 when the run failed. *unreadable: valgrind
 * could not read the binary's debug information (valgrind 3.19 and clang's DWARF 5:
 * "unhandled dwarf2 abbrev form", "I can't recover"), which is no failure of the
 * program's. */
static unsigned long long count(const char *valgrind, const char *dir, const char *tag,
                                const char *const *args, bool *unreadable)
{
    char out[PATH_MAX], opt[PATH_MAX + 32];
    e2e_join(out, sizeof out, dir, tag);
    snprintf(opt, sizeof opt, "--callgrind-out-file=%s", out);
    char *argv[64];
    int n = 0;
    argv[n++] = (char *)valgrind;
    argv[n++] = (char *)"--tool=callgrind";
    argv[n++] = opt;
    argv[n++] = (char *)harness_bin();
    for (int i = 0; args[i] && n < 60; i++)
        argv[n++] = (char *)args[i];
    argv[n++] = (char *)"-threads";
    argv[n++] = (char *)"1";
    argv[n] = NULL;
    E2eRun r;
    CHECK(e2e_run(argv, &r));
    *unreadable = strstr(r.err, "debuginfo reader") != NULL;
    if (*unreadable) {
        e2e_run_free(&r);
        return 0;
    }
    char why[512];
    CHECK_MSG(r.status == 0, "%s: %s", tag, e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    size_t len = 0;
    char *text = e2e_read_file(out, &len);
    unsigned long long total = 0;
    const char *at = text ? strstr(text, "\ntotals:") : NULL;
    if (at)
        total = strtoull(at + 8, NULL, 10);
    CHECK_MSG(total > 0, "%s: no totals line in %s", tag, out);
    free(text);
    return total;
}

/* valgrind's path and a fresh folder for a test, or a skip (nothing to clean up then). */
static void setup(char *valgrind, size_t vsize, char *dir, size_t dsize)
{
    if (E2E_SANITIZED)
        harness_skip("valgrind cannot run a sanitized binary");
    if (!find_valgrind(valgrind, vsize))
        harness_skip("valgrind is not installed");
    CHECK(e2e_tmpdir(dir, dsize, "instr"));
}

/* The ratio of the instructions of args_b to those of args_a (0 after a failure), or a
 * skip when valgrind cannot read the binary. */
static double ratio_of(const char *valgrind, const char *dir, const char *const *args_a,
                       const char *const *args_b, const char *what)
{
    bool unreadable = false;
    unsigned long long a = count(valgrind, dir, "a.cg", args_a, &unreadable);
    if (unreadable) {
        e2e_rmtree(dir);
        harness_skip("valgrind cannot read this binary's debug information (clang's DWARF 5)");
    }
    unsigned long long b = count(valgrind, dir, "b.cg", args_b, &unreadable);
    double ratio = a && b ? (double)b / (double)a : 0.0;
    printf("   %s: %llu and %llu instructions: %.3f\n", what, a, b, ratio);
    return ratio;
}

static const char *const k_scene_head =
    "PerspectiveCamera { center 0 2 10 direction 0 -0.2 -1 up 0 1 0 angle 30 }\n"
    "Lights { numLights 1 DirectionalLight { direction 0 -1 0 color 0.8 0.8 0.8 } }\n"
    "Background { color 0 0 1 ambientLight 0.2 0.2 0.2 }\n"
    "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n";

/* -visualize_grid's march (march_init with no padding) against the same grid's render:
 * 81c9a73 made march_init work out the band beyond the box (march_band_width, with
 * two libm calls per axis) on every axis of every ray, and a one-sphere scene's
 * -visualize_grid render went from 1.37 times the plain one's instructions to 2.31
 * times (course line 01c at 64 x 64: 2.68 M -> 4.54 M). */
static void test_visualize_grid_march(void)
{
    char valgrind[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX], img[PATH_MAX], text[1024];
    setup(valgrind, sizeof valgrind, dir, sizeof dir);
    e2e_join(scene, sizeof scene, dir, "sphere.txt");
    e2e_join(img, sizeof img, dir, "out.tga");
    snprintf(text, sizeof text, "%sGroup { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 "
                                "radius 1 } }\n", k_scene_head);
    CHECK(e2e_write_file(scene, text));
    const char *plain[] = {"-input", scene, "-output", img, "-size", "64", "64",
                           "-grid", "10", "10", "10", NULL};
    const char *vis[] = {"-input", scene, "-output", img, "-size", "64", "64",
                         "-grid", "10", "10", "10", "-visualize_grid", NULL};
    double ratio = ratio_of(valgrind, dir, plain, vis, "plain, -visualize_grid");
    /* 1.37 with the band made only where a pad needs it (gcc 12, -O2), 2.31 before. */
    CHECK_MSG(ratio > 0 && ratio < 1.7,
              "-visualize_grid costs %.2f times the plain render's instructions (at most "
              "1.7; about 1.4 expected)",
              ratio);
    e2e_rmtree(dir);
}

/* The scene reader's lexing, per byte of a token: 2,000 spheres whose coordinates are
 * written 0, against the same with each written in 42 characters (0.000...). c172987
 * (columns count characters) asked lex_char_bytes for every byte of every token, which
 * made the long scene's read 2.17 times the short one's instructions (1.90 before it;
 * 1.72 with printable ASCII bytes taken first). */
static void test_scene_lexing(void)
{
    char valgrind[PATH_MAX], dir[PATH_MAX], s_short[PATH_MAX], s_long[PATH_MAX], img[PATH_MAX];
    setup(valgrind, sizeof valgrind, dir, sizeof dir);
    e2e_join(s_short, sizeof s_short, dir, "short.txt");
    e2e_join(s_long, sizeof s_long, dir, "long.txt");
    e2e_join(img, sizeof img, dir, "out.tga");
    enum { SPHERES = 2000 };
    for (int pass = 0; pass < 2; pass++) {
        const char *num = pass ? "0.0000000000000000000000000000000000000000" : "0";
        size_t cap = (size_t)SPHERES * 200 + 1024, len = 0;
        char *text = malloc(cap);
        CHECK(text);
        if (!text)
            return;
        len += (size_t)snprintf(text + len, cap - len, "%sGroup { numObjects %d MaterialIndex 0\n",
                                k_scene_head, SPHERES);
        for (int i = 0; i < SPHERES; i++)
            len += (size_t)snprintf(text + len, cap - len,
                                    "Sphere { center %s %s %s radius 1 }\n", num, num, num);
        snprintf(text + len, cap - len, "}\n");
        CHECK(e2e_write_file(pass ? s_long : s_short, text));
        free(text);
    }
    const char *a[] = {"-input", s_short, "-output", img, "-size", "1", "1", NULL};
    const char *b[] = {"-input", s_long, "-output", img, "-size", "1", "1", NULL};
    double ratio = ratio_of(valgrind, dir, a, b, "short numbers, long numbers");
    CHECK_MSG(ratio > 0 && ratio < 2.0,
              "the scene with long numbers costs %.2f times the short one's instructions (at "
              "most 2.0; about 1.7 expected)",
              ratio);
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"visualize_grid_march", test_visualize_grid_march},
    {"scene_lexing", test_scene_lexing},
};

RT_TEST_MAIN(tests)
