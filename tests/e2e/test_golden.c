/* Golden images of the project's own scenes (tests/golden/LIST): each is rendered again
 * through the binary and compared with build/tools/imgdiff at a strict tolerance
 * (every pixel within 1/255). They need no course data, so a clone alone still
 * compares pictures. */
#define _POSIX_C_SOURCE 200809L
#include "../harness.h"
#include "e2e_util.h"

static void test_golden_images(void)
{
    char list[PATH_MAX], dir[PATH_MAX], imgdiff[PATH_MAX];
    snprintf(list, sizeof list, "%s/tests/golden/LIST", harness_root());
    const char *tools = getenv("RT_TOOLS");
    snprintf(imgdiff, sizeof imgdiff, "%s/imgdiff", tools && *tools ? tools : "build/tools");
    CHECK_MSG(access(imgdiff, X_OK) == 0, "%s not found (make builds it)", imgdiff);
    FILE *f = fopen(list, "r");
    CHECK_MSG(f != NULL, "cannot open %s", list);
    if (!f)
        return;
    CHECK(e2e_tmpdir(dir, sizeof dir, "golden") != NULL);
    char line[1024];
    int compared = 0;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\r\n")] = '\0';
        if (line[0] == '#' || line[0] == '\0')
            continue;
        char *words[40];
        int n = 0;
        for (char *w = strtok(line, " "); w && n < 36; w = strtok(NULL, " "))
            words[n++] = w;
        if (n < 2)
            continue;
        char scene[PATH_MAX], golden[PATH_MAX], out[PATH_MAX], name[300];
        snprintf(name, sizeof name, "%s.tga", words[0]);
        snprintf(scene, sizeof scene, "%s/%s", harness_root(), words[1]);
        snprintf(golden, sizeof golden, "%s/tests/golden/%s", harness_root(), name);
        e2e_join(out, sizeof out, dir, name);
        const char *args[48] = {"-input", scene, "-output", out};
        int k = 4;
        for (int i = 2; i < n; i++)
            args[k++] = words[i];
        args[k] = NULL;
        E2eRun r;
        char why[512];
        bool ran = e2e_run_bin(harness_bin(), args, &r);
        CHECK_MSG(ran && r.status == 0, "%s: %s", words[0], e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
        char *diff_argv[] = {imgdiff, "-t", "1", "-p", "100", golden, out, NULL};
        ran = e2e_run(diff_argv, &r);
        CHECK_MSG(ran && r.status == 0, "%s differs from tests/golden/%s: %s%s", words[0], name,
                  r.out ? r.out : "", r.err ? r.err : "");
        e2e_run_free(&r);
        compared++;
    }
    fclose(f);
    CHECK_MSG(compared >= 10, "only %d golden images listed", compared);
    e2e_rmtree(dir);
}

/* The comparison can fail: a golden image against another scene's render. */
static void test_golden_detects_a_difference(void)
{
    char dir[PATH_MAX], out[PATH_MAX], imgdiff[PATH_MAX], golden[PATH_MAX], scene[PATH_MAX];
    const char *tools = getenv("RT_TOOLS");
    snprintf(imgdiff, sizeof imgdiff, "%s/imgdiff", tools && *tools ? tools : "build/tools");
    snprintf(golden, sizeof golden, "%s/tests/golden/tex_wood.tga", harness_root());
    snprintf(scene, sizeof scene, "%s/scenes/tex_marble.txt", harness_root());
    CHECK(e2e_tmpdir(dir, sizeof dir, "golden_neg") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    const char *args[] = {"-input", scene, "-output", out, "-size", "48", "48", NULL};
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r) && r.status == 0);
    e2e_run_free(&r);
    char *diff_argv[] = {imgdiff, "-q", "-t", "1", "-p", "100", golden, out, NULL};
    CHECK(e2e_run(diff_argv, &r));
    CHECK_INT(r.status, 1);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"golden images of scenes/ (imgdiff -t 1 -p 100)", test_golden_images},
    {"golden comparison detects a different picture", test_golden_detects_a_difference},
};
RT_TEST_MAIN(tests)
