/* -isa: the images do not depend on the instruction set the program may use. Every
 * render below (packets, secondary rays, point lights, textures, the film's samplers and
 * filters, depth and normal images) is made with -isa base (the portable code a CPU
 * without AVX2 runs) and again with each wider set this CPU has, and the files must be
 * the same bytes: what two machines of different generations must write. Without
 * -stats, which turns the packets off. Then the option's bad values. */
#include <stdio.h>
#include <string.h>

#include "../harness.h"
#include "e2e_util.h"

static const char *const isas[] = {"base", "avx2", "avx512"};
enum { NUM_ISA = 3 };

/* Whether this CPU runs isa: -isa accepts it, or refuses it with the usage error that
 * names the CPU's lack (any other outcome fails the test). */
static bool cpu_runs_isa(const char *isa, const char *scene, const char *out)
{
    const char *args[] = {"-isa", isa, "-input", scene, "-size", "8", "8", "-output", out, NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    bool runs = r.status == 0;
    if (!runs) {
        char why[512];
        CHECK_MSG(r.status == 2, "-isa %s: %s", isa, e2e_describe(&r, why, sizeof why));
        char want[64];
        snprintf(want, sizeof want, "option -isa: this CPU has no %s", isa);
        CHECK_CONTAINS(r.err, want);
    }
    e2e_run_free(&r);
    return runs;
}

static bool same_file(const char *a, const char *b)
{
    size_t na = 0, nb = 0;
    char *x = e2e_read_file(a, &na), *y = e2e_read_file(b, &nb);
    bool same = x && y && na == nb && memcmp(x, y, na) == 0;
    free(x);
    free(y);
    return same;
}

typedef struct Case {
    const char *scene;   /* under scenes/ */
    const char *opts[16];
    bool maps;           /* also -depth and -normals */
} Case;

static const Case cases[] = {
    {"showcase.txt", {"-grid", "auto", "-shadows", "-bounces", "3", NULL}, true},
    {"feat_attenuation.txt", {"-grid", "auto", "-shadows", NULL}, false},
    {"feat_mirrors.txt",
     {"-grid", "auto", "-bounces", "4", "-uniform_samples", "4", "-tent_filter", "1.5", NULL},
     false},
    {"feat_refraction.txt",
     {"-grid", "auto", "-shadows", "-shade_back", "-bounces", "5", "-adaptive_samples", "4",
      "16", "0.1", "-mitchell_filter", "2", NULL},
     true},
    {"tex_marble.txt",
     {"-grid", "auto", "-shadows", "-jittered_samples", "9", "-gaussian_filter", "0.4", NULL},
     false},
    {"tex_wood.txt", {"-noise_cutoff", "-random_samples", "4", "-box_filter", "1", NULL}, false},
    /* 16 samples: with AVX-512 the film makes the rays of a packet's four pixels in one
     * call (film_tile), from the positions of the whole tile asked first; the image's
     * last tile row is cut (54 rows), so packets there start mid-tile. Planes and the
     * scratch (the Gaussian), and pixel by pixel with fixed positions (uniform, box). */
    {"tex_marble.txt",
     {"-grid", "auto", "-shadows", "-jittered_samples", "16", "-gaussian_filter", "0.4", NULL},
     false},
    {"feat_mirrors.txt", {"-grid", "auto", "-bounces", "2", "-uniform_samples", "16", NULL},
     false},
    {"tex_nested.txt", {"-grid", "8", "8", "8", "-shadows", "-threads", "2", NULL}, false},
};

static void test_same_bytes(void)
{
    char dir[256], scene0[PATH_MAX], probe[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "isa"));
    snprintf(scene0, sizeof scene0, "%s/scenes/showcase.txt", harness_root());
    e2e_join(probe, sizeof probe, dir, "probe.tga");
    bool runs[NUM_ISA];
    int wider = 0;
    for (int i = 0; i < NUM_ISA; i++) {
        runs[i] = cpu_runs_isa(isas[i], scene0, probe);
        wider += i > 0 && runs[i];
    }
    CHECK_MSG(runs[0], "-isa base must run everywhere");
    if (!wider)
        printf("    (this CPU has neither AVX2 nor AVX-512: only -isa base's refusals tested)\n");
    static const char *const kinds[] = {"color", "depth", "normals"};
    for (size_t c = 0; c < sizeof cases / sizeof cases[0]; c++) {
        const Case *k = &cases[c];
        char scene[PATH_MAX];
        snprintf(scene, sizeof scene, "%s/scenes/%s", harness_root(), k->scene);
        for (int i = 0; i < NUM_ISA; i++) {
            if (!runs[i])
                continue;
            char out[3][PATH_MAX], name[64];
            for (int m = 0; m < 3; m++) {
                snprintf(name, sizeof name, "%zu_%s_%s.tga", c, isas[i], kinds[m]);
                e2e_join(out[m], sizeof out[m], dir, name);
            }
            const char *args[40];
            int n = 0;
            args[n++] = "-isa";
            args[n++] = isas[i];
            args[n++] = "-input";
            args[n++] = scene;
            args[n++] = "-size";
            args[n++] = "72";
            args[n++] = "54";
            args[n++] = "-output";
            args[n++] = out[0];
            if (k->maps) {
                args[n++] = "-depth";
                args[n++] = "9";
                args[n++] = "14";
                args[n++] = out[1];
                args[n++] = "-normals";
                args[n++] = out[2];
            }
            for (int j = 0; k->opts[j]; j++)
                args[n++] = k->opts[j];
            args[n] = NULL;
            E2eRun r;
            CHECK(e2e_run_bin(harness_bin(), args, &r));
            char why[512];
            CHECK_MSG(r.status == 0, "%s -isa %s: %s", k->scene, isas[i],
                      e2e_describe(&r, why, sizeof why));
            e2e_run_free(&r);
            if (i == 0)
                continue;
            for (int m = 0; m < (k->maps ? 3 : 1); m++) {
                char base[PATH_MAX];
                snprintf(name, sizeof name, "%zu_base_%s.tga", c, kinds[m]);
                e2e_join(base, sizeof base, dir, name);
                CHECK_MSG(same_file(base, out[m]), "%s: the %s image of -isa %s differs from "
                          "-isa base's", k->scene, kinds[m], isas[i]);
            }
        }
    }
    e2e_rmtree(dir);
}

static void test_bad_values(void)
{
    char dir[256], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "isa_bad"));
    snprintf(scene, sizeof scene, "%s/scenes/showcase.txt", harness_root());
    e2e_join(out, sizeof out, dir, "out.tga");
    const char *a1[] = {"-isa", "sse9", "-input", scene, "-output", out, NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), a1, &r));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "option -isa: unknown instruction set 'sse9' (known: base, avx2, avx512)");
    CHECK_MSG(strchr(r.err, '\n') == r.err + strlen(r.err) - 1, "one line: %s", r.err);
    e2e_run_free(&r);
    const char *a2[] = {"-input", scene, "-output", out, "-isa", NULL};
    CHECK(e2e_run_bin(harness_bin(), a2, &r));
    CHECK_INT(r.status, 2);
    CHECK_CONTAINS(r.err, "-isa");
    e2e_run_free(&r);
    CHECK(!e2e_exists(out));
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"isa: the same bytes with every instruction set this CPU runs", test_same_bytes},
    {"isa: bad values are usage errors", test_bad_values},
};
RT_TEST_MAIN(tests)
