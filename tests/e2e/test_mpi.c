/* End-to-end tests of ./raytracer-mpi (make mpi) under mpirun --oversubscribe: the same
 * bytes and -stats counters as ./raytracer for 1, 2 and 3 ranks on course lines, one
 * message and exit 1 on a scene error, a clean abort with no image when a rank dies.
 * They run when RT_MPI_BIN names a built binary and mpirun is on PATH; otherwise they
 * are skipped, unless RT_REQUIRE_MPI=1 (CI), which makes a missing build a failure. */
#define _XOPEN_SOURCE 600
#include "../harness.h"
#include <ctype.h>
#include <fcntl.h>
#include <sys/wait.h>
#include "e2e_util.h"

static char g_mpirun[PATH_MAX];

/* The MPI binary and mpirun, or a skip (a failure under RT_REQUIRE_MPI=1). */
static const char *mpi_or_skip(void)
{
    const char *bin = getenv("RT_MPI_BIN");
    bool have_bin = bin && *bin && access(bin, X_OK) == 0;
    bool have_run = false;
    const char *path = getenv("PATH");
    char copy[4096];
    snprintf(copy, sizeof copy, "%s", path ? path : "/usr/bin:/bin");
    for (char *d = strtok(copy, ":"); d && !have_run; d = strtok(NULL, ":")) {
        e2e_join(g_mpirun, sizeof g_mpirun, d, "mpirun");
        have_run = access(g_mpirun, X_OK) == 0;
    }
    const char *req = getenv("RT_REQUIRE_MPI");
    bool required = req && strcmp(req, "1") == 0;
    if (!have_bin || !have_run) {
        const char *why = !have_bin ? "raytracer-mpi not built (make mpi)"
                                    : "mpirun not found (apt-get install openmpi-bin)";
        if (required) {
            harness_fail(__FILE__, __LINE__, "RT_REQUIRE_MPI=1 but %s", why);
            fflush(stdout);
            _exit(1);
        }
        harness_skip(why);
    }
    /* CI runs as root; OpenMPI refuses that unless told. */
    setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
    setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
    return bin;
}

typedef struct Cmd {
    const char *v[128];
    int n;
} Cmd;

static void add(Cmd *c, const char *s)
{
    if (c->n < 126)
        c->v[c->n++] = s;
}

static void mpirun_prefix(Cmd *c, const char *np)
{
    c->n = 0;
    add(c, g_mpirun);
    add(c, "--oversubscribe");
    add(c, "-np");
    add(c, np);
}

static int run(Cmd *c, E2eRun *r)
{
    c->v[c->n] = NULL;
    if (!e2e_run((char *const *)c->v, r))
        return -1;
    return r->status;
}

static bool same_file(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *da = e2e_read_file(a, &la), *db = e2e_read_file(b, &lb);
    bool same = da && db && la == lb && memcmp(da, db, la) == 0;
    free(da);
    free(db);
    return same;
}

/* The -stats lines that depend on time are left out. */
static void stats_counts(const char *out, char *buf, size_t size)
{
    E2eStats s;
    buf[0] = '\0';
    if (!e2e_stats_parse(out, &s))
        return;
    for (int k = 0; k < E2E_STATS_LABELS; k++)
        if (k != 0 && k != 8) {
            size_t len = strlen(buf);
            snprintf(buf + len, size - len, "%s=%s;", e2e_stats_labels[k], s.values[k]);
        }
}

/* Course line id with -output, -depth and -normals: raytracer-mpi on 1, 2 and 3 ranks
 * against ./raytracer, file by file, and the -stats counters. extra: more arguments. */
static void check_line(const char *id, const char *const *extra)
{
    const char *mpi = mpi_or_skip();
    const char *course = e2e_course_or_skip();
    E2eCourseLine cl;
    CHECK_MSG(e2e_course_line(course, id, &cl), "line %s not found", id);
    if (harness_failures)
        return;
    char dir[PATH_MAX], input[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpi") != NULL);
    static const char *const kinds[3] = {"color", "depth", "normals"};
    char ref[3][PATH_MAX];
    for (int np = 0; np <= 3; np++) { /* 0: ./raytracer itself */
        Cmd c;
        char nps[16];
        snprintf(nps, sizeof nps, "%d", np);
        if (np == 0) {
            c.n = 0;
            add(&c, harness_bin());
        } else {
            mpirun_prefix(&c, nps);
            add(&c, mpi);
        }
        for (int i = 0; i < cl.argc; i++) {
            if (strcmp(cl.argv[i], "-output") == 0) {
                i++;
            } else if (strcmp(cl.argv[i], "-input") == 0 && i + 1 < cl.argc) {
                add(&c, "-input");
                add(&c, e2e_join(input, sizeof input, course, cl.argv[++i]));
            } else {
                add(&c, cl.argv[i]);
            }
        }
        for (int i = 0; extra && extra[i]; i++)
            add(&c, extra[i]);
        char out[3][PATH_MAX];
        for (int k = 0; k < 3; k++) {
            char name[64];
            snprintf(name, sizeof name, "np%d_%s.tga", np, kinds[k]);
            e2e_join(out[k], sizeof out[k], dir, name);
        }
        add(&c, "-stats");
        add(&c, "-output");
        add(&c, out[0]);
        add(&c, "-depth");
        add(&c, "3");
        add(&c, "20");
        add(&c, out[1]);
        add(&c, "-normals");
        add(&c, out[2]);
        E2eRun r;
        int st = run(&c, &r);
        char why[512];
        CHECK_MSG(st == 0, "%s, %d rank(s): %s", id, np, e2e_describe(&r, why, sizeof why));
        static char ref_stats[2048];
        char stats[2048];
        stats_counts(r.out, stats, sizeof stats);
        /* exactly one block, whatever the number of ranks */
        const char *first = strstr(r.out, "RAY TRACING STATISTICS");
        CHECK_MSG(first && !strstr(first + 1, "RAY TRACING STATISTICS"),
                  "%s, %d rank(s): %s statistics blocks", id, np, first ? "several" : "no");
        if (np == 0) {
            memcpy(ref, out, sizeof ref);
            snprintf(ref_stats, sizeof ref_stats, "%s", stats);
        } else {
            for (int k = 0; k < 3; k++)
                CHECK_MSG(same_file(out[k], ref[k]), "%s, %d rank(s): %s image differs from "
                          "./raytracer's", id, np, kinds[k]);
            CHECK_MSG(strcmp(stats, ref_stats) == 0, "%s, %d rank(s): statistics differ:\n"
                      "      mpi:  %s\n      alone: %s", id, np, stats, ref_stats);
        }
        e2e_run_free(&r);
        if (harness_failures)
            break;
    }
    e2e_rmtree(dir);
}

static void test_mpi_03d(void) { check_line("03d", NULL); }
static void test_mpi_11b(void) { check_line("11b", NULL); }
static void test_mpi_12a(void) { check_line("12a", (const char *const[]){"-threads", "1", NULL}); }
static void test_mpi_17a(void) { check_line("17a", NULL); }
static void test_mpi_18a_region(void)
{
    check_line("18a", (const char *const[]){"-region", "13", "37", "301", "121", NULL});
}

static const char BAD_SCENE[] =
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
    "Group {\n"
    "    numObjects 1\n"
    "    Sphere { center 0 0 0 radius oops }\n"
    "}\n";

static const char SCENE[] =
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
    "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
    "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n";

static int count(const char *hay, const char *needle)
{
    int n = 0;
    for (const char *p = strstr(hay, needle); p; p = strstr(p + 1, needle))
        n++;
    return n;
}

static void test_mpi_scene_error(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpibad") != NULL);
    e2e_join(scene, sizeof scene, dir, "bad.txt");
    e2e_join(out, sizeof out, dir, "out.tga");
    CHECK(e2e_write_file(scene, BAD_SCENE));
    Cmd c;
    mpirun_prefix(&c, "3");
    add(&c, mpi);
    add(&c, "-input");
    add(&c, scene);
    add(&c, "-output");
    add(&c, out);
    E2eRun r;
    int st = run(&c, &r);
    CHECK_MSG(st == 1, "exit %d, expected 1", st);
    CHECK_MSG(count(r.err, "bad.txt:4:") == 1, "the located message appears %d times, "
              "expected once:\n%s", count(r.err, "bad.txt:4:"), r.err);
    CHECK(!e2e_exists(out));
    e2e_run_free(&r);
    /* Every rank ends through MPI_Finalize with status 1, so none is terminated by
     * mpirun: the message is not followed by raytracer-mpi's "the job was aborted"
     * (it was, about one run in ten at -np 4, when mpirun's SIGTERM reached rank 0
     * still finalizing). Ten runs at -np 4. */
    for (int i = 0; i < 10 && !harness_failures; i++) {
        mpirun_prefix(&c, "4");
        add(&c, mpi);
        add(&c, "-input");
        add(&c, scene);
        add(&c, "-output");
        add(&c, out);
        st = run(&c, &r);
        CHECK_MSG(st == 1, "run %d at -np 4: exit %d, expected 1", i, st);
        CHECK_MSG(count(r.err, "bad.txt:4:") == 1 &&
                  !strstr(r.err, "raytracer-mpi: the job was aborted"),
                  "run %d at -np 4: stderr:\n%s", i, r.err);
        e2e_run_free(&r);
    }
    /* a usage error, once */
    mpirun_prefix(&c, "2");
    add(&c, mpi);
    add(&c, "-input");
    add(&c, scene);
    add(&c, "-bogus");
    st = run(&c, &r);
    CHECK_MSG(st == 2, "usage error: exit %d, expected 2", st);
    CHECK_INT(count(r.err, "unknown option '-bogus'"), 1);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* Rank 1 dies (SIGKILL) on rank 0's first answer (RT_MPI_TEST_KILL_RANK), before
 * the counters are gathered, however the tiles were shared out: the job
 * ends non-zero, rank 0 says why, and no image (nor a temporary file) is left. */
static void test_mpi_killed_rank(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpikill") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "out.tga");
    CHECK(e2e_write_file(scene, SCENE));
    setenv("RT_MPI_TEST_KILL_RANK", "1", 1);
    Cmd c;
    mpirun_prefix(&c, "3");
    /* mpirun ends the other ranks with SIGTERM and, odls_base_sigkill_timeout seconds
     * later (1 by default), SIGKILL. On a loaded machine rank 0's line was sometimes
     * cut off by that SIGKILL or lost with mpirun's forwarding of its stderr (2 of 12
     * runs with four busy loops on the 2-core host; 0 of 8 with 3 s, ~3 s longer). */
    add(&c, "--mca");
    add(&c, "odls_base_sigkill_timeout");
    add(&c, "3");
    add(&c, "-x");
    add(&c, "RT_MPI_TEST_KILL_RANK");
    add(&c, mpi);
    add(&c, "-input");
    add(&c, scene);
    add(&c, "-size");
    add(&c, "64");
    add(&c, "640");
    add(&c, "-threads");
    add(&c, "1");
    add(&c, "-output");
    add(&c, out);
    E2eRun r;
    int st = run(&c, &r);
    unsetenv("RT_MPI_TEST_KILL_RANK");
    CHECK_MSG(st != 0 && !r.timed_out, "exit %d%s, expected a failure", st,
              r.timed_out ? " (timed out)" : "");
    CHECK_CONTAINS(r.err, "raytracer-mpi: the job was aborted");
    CHECK_MSG(!e2e_exists(out), "an image was written");
    CHECK_MSG(e2e_count_entries(dir) == 1, "files left behind in %s", dir);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* -timings prints one line (the maximum over the ranks), --version names MPI. */
static void test_mpi_timings_version(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpitime") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "out.tga");
    CHECK(e2e_write_file(scene, SCENE));
    Cmd c;
    mpirun_prefix(&c, "2");
    add(&c, mpi);
    add(&c, "-input");
    add(&c, scene);
    add(&c, "-timings");
    add(&c, "-output");
    add(&c, out);
    E2eRun r;
    CHECK_INT(run(&c, &r), 0);
    CHECK_INT(count(r.err, "timings: parse"), 1);
    e2e_run_free(&r);
    /* Under mpirun rank 0 started MPI beside its set-up (OMPI_COMM_WORLD_RANK/SIZE),
     * and the per-rank tile counts add up to the tiles cut. */
    mpirun_prefix(&c, "3");
    add(&c, mpi);
    add(&c, "-input");
    add(&c, scene);
    add(&c, "-size");
    add(&c, "64");
    add(&c, "640");
    add(&c, "-threads");
    add(&c, "1");
    add(&c, "-timings");
    add(&c, "-output");
    add(&c, out);
    CHECK_INT(run(&c, &r), 0);
    CHECK_INT(count(r.err, "timings: mpi: MPI_Init "), 1);
    CHECK_CONTAINS(r.err, " ms beside rank 0's set-up and render; ");
    const char *line = strstr(r.err, "timings: mpi: ");
    const char *tiles = line ? strstr(line, " render; ") : NULL;
    int total = -1, sum = 0, ranks = 0;
    if (tiles) {
        tiles += strlen(" render; ");
        total = atoi(tiles);
        CHECK_CONTAINS(tiles, " tiles handed out to 3 ranks, the first rank done ");
        const char *p = strstr(tiles, "last tile placed):");
        for (int rank = 0; p && rank < 3; rank++) {
            char key[16];
            snprintf(key, sizeof key, " %d: ", rank);
            if (!(p = strstr(p, key)))
                break;
            p += strlen(key);
            sum += atoi(p);
            ranks++;
        }
    }
    CHECK_MSG(total > 0 && ranks == 3 && sum == total, "per-rank tiles %d over %d ranks, "
              "%d cut:\n%s", sum, ranks, total, r.err);
    e2e_run_free(&r);
    /* An 8x8 image is one tile: one of the two ranks places none, and its entry has no
     * last time ("-"; it said 0.0, as if a tile had been placed at the start). One tile
     * is "1 tile", in all and in the rank that rendered it (it said "1 tiles"). */
    mpirun_prefix(&c, "2");
    add(&c, mpi);
    add(&c, "-input");
    add(&c, scene);
    add(&c, "-size");
    add(&c, "8");
    add(&c, "8");
    add(&c, "-timings");
    add(&c, "-output");
    add(&c, out);
    CHECK_INT(run(&c, &r), 0);
    const char *none = strstr(r.err, ": 0 tiles ");
    double first = -1.0;
    char last = 0;
    CHECK_MSG(none && sscanf(none, ": 0 tiles %lf %c", &first, &last) == 2 && last == '-',
              "the rank with no tile:\n%s", r.err);
    CHECK_CONTAINS(r.err, " render; 1 tile handed out to 2 ranks, the first rank done ");
    CHECK_MSG(strstr(r.err, ": 1 tile ") != NULL && strstr(r.err, "1 tiles") == NULL,
              "one tile, as \"1 tile\" in all and in its rank:\n%s", r.err);
    e2e_run_free(&r);
    mpirun_prefix(&c, "2");
    add(&c, mpi);
    add(&c, "--version");
    CHECK_INT(run(&c, &r), 0);
    CHECK_INT(count(r.out, "mpi: yes, this run has 2 ranks ("), 1);
    e2e_run_free(&r);
    mpirun_prefix(&c, "1");
    add(&c, mpi);
    add(&c, "--version");
    CHECK_INT(run(&c, &r), 0);
    CHECK_INT(count(r.out, "mpi: yes, this run has 1 rank ("), 1);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* Rank 0's "rows done" line: OpenMPI's mpirun gives the ranks a pipe for stderr, so
 * rank 0 never sees a terminal, and the line came with neither -progress nor a
 * terminal: -progress must draw it under mpirun, and without it (stderr a pipe here)
 * there is none. */
static void test_mpi_progress(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpiprog") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "out.tga");
    CHECK(e2e_write_file(scene, SCENE));
    for (int with = 0; with < 2; with++) {
        Cmd c;
        mpirun_prefix(&c, "2");
        add(&c, mpi);
        add(&c, "-input");
        add(&c, scene);
        add(&c, "-size");
        add(&c, "64");
        add(&c, "256");
        if (with)
            add(&c, "-progress");
        add(&c, "-output");
        add(&c, out);
        E2eRun r;
        CHECK_INT(run(&c, &r), 0);
        /* Into mpirun's pipe the line comes as whole lines, not redrawn with carriage
         * returns (every tile's update piled up on one line of a batch job's log):
         * in a render this short (under 30 s) only the final one. */
        CHECK_MSG(with ? strstr(r.err, "raytracer-mpi: 256/256 rows on 2 ranks\n") != NULL &&
                             count(r.err, "rows on") == 1 && !strchr(r.err, '\r')
                       : strstr(r.err, "rows on") == NULL,
                  "%s -progress: stderr:\n%s", with ? "with" : "without", r.err);
        e2e_run_free(&r);
    }
    e2e_rmtree(dir);
}

/* Ctrl-C at any moment of a run started without mpirun (a singleton: MPI_Init starts
 * an orted and takes a while): a signal during MPI_Init was lost, and the render of
 * tests/repro/deep_ray_tree.txt (endless) ran on. Signals at 0.1 .. 0.9 s; each run
 * must exit 130 by itself (not be killed by the signal: the handler is installed
 * first); the 60 s limit is only a guard against the hang. */
static void test_mpi_singleton_early_signal(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], out[PATH_MAX], scene[PATH_MAX], repro[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpisig") != NULL);
    e2e_join(out, sizeof out, dir, "out.tga");
    snprintf(repro, sizeof repro, "%s/tests/repro", harness_root());
    e2e_join(scene, sizeof scene, repro, "deep_ray_tree.txt");
    const char *args[] = {mpi, "-input", scene, "-output", out, "-size", "4", "4",
                          "-shade_back", "-bounces", "60", "-weight", "0", NULL};
    for (int ms = 100; ms < 1000 && !harness_failures; ms += 200) {
        pid_t pid = e2e_spawn(args, NULL);
        CHECK(pid > 0);
        if (pid <= 0)
            break;
        struct timespec pause = {0, (long)ms * 1000 * 1000};
        nanosleep(&pause, NULL);
        kill(pid, SIGINT);
        int st = 0;
        bool hung = !e2e_wait_or_kill(pid, 60, &st);
        CHECK_MSG(!hung, "Ctrl-C after %d ms: still running after 60 s", ms);
        CHECK_MSG(!hung && WIFEXITED(st) && WEXITSTATUS(st) == 130,
                  "Ctrl-C after %d ms: %s %d, expected exit 130", ms,
                  WIFEXITED(st) ? "exit" : "killed by",
                  WIFEXITED(st) ? WEXITSTATUS(st) : WTERMSIG(st));
        CHECK(!e2e_exists(out));
    }
    e2e_rmtree(dir);
}

/* Ctrl-C to mpirun (it forwards SIGINT, then ends the ranks with SIGTERM) while MPI is
 * starting beside rank 0's set-up and later, during the render of
 * tests/repro/deep_ray_tree.txt (endless): the job fails, no image nor temporary file
 * is left. The 60 s limit is only a guard against a hang. */
static void test_mpi_sigint_to_mpirun(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], out[PATH_MAX], scene[PATH_MAX], repro[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpiint") != NULL);
    e2e_join(out, sizeof out, dir, "out.tga");
    snprintf(repro, sizeof repro, "%s/tests/repro", harness_root());
    e2e_join(scene, sizeof scene, repro, "deep_ray_tree.txt");
    const char *args[] = {g_mpirun, "--oversubscribe", "-np", "2", mpi, "-input", scene,
                          "-output", out, "-size", "4", "4", "-shade_back", "-bounces",
                          "60", "-weight", "0", NULL};
    for (int ms = 50; ms < 2000 && !harness_failures; ms *= 3) {
        pid_t pid = e2e_spawn(args, NULL);
        CHECK(pid > 0);
        if (pid <= 0)
            break;
        struct timespec pause = {ms / 1000, (long)(ms % 1000) * 1000 * 1000};
        nanosleep(&pause, NULL);
        kill(pid, SIGINT);
        int st = 0;
        bool hung = !e2e_wait_or_kill(pid, 60, &st);
        CHECK_MSG(!hung, "SIGINT to mpirun after %d ms: still running after 60 s", ms);
        CHECK_MSG(!hung && !(WIFEXITED(st) && WEXITSTATUS(st) == 0),
                  "SIGINT to mpirun after %d ms: exit 0", ms);
        CHECK_MSG(e2e_count_entries(dir) == 0, "SIGINT to mpirun after %d ms: files left "
                  "in %s", ms, dir);
    }
    e2e_rmtree(dir);
}

/* A launcher environment that disagrees with MPI (rank 0 of 2 by OMPI_COMM_WORLD_RANK
 * and OMPI_COMM_WORLD_SIZE, a singleton to MPI): rank 0 must not serve tiles to a rank
 * that never comes; it says so and fails, with no image. */
static void test_mpi_env_mismatch(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpienv") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "out.tga");
    CHECK(e2e_write_file(scene, SCENE));
    setenv("OMPI_COMM_WORLD_RANK", "0", 1);
    setenv("OMPI_COMM_WORLD_SIZE", "2", 1);
    Cmd c;
    c.n = 0;
    add(&c, mpi);
    add(&c, "-input");
    add(&c, scene);
    add(&c, "-output");
    add(&c, out);
    E2eRun r;
    int st = run(&c, &r);
    unsetenv("OMPI_COMM_WORLD_RANK");
    unsetenv("OMPI_COMM_WORLD_SIZE");
    CHECK_MSG(st == 1 && !r.timed_out, "exit %d%s, expected 1", st,
              r.timed_out ? " (timed out)" : "");
    CHECK_INT(count(r.err, "MPI's rank and size differ from the launcher's"), 1);
    CHECK_MSG(!e2e_exists(out), "an image was written");
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* raytracer-mpi names itself, not ./raytracer: --version's first line, -h's synopsis,
 * a usage error and its hint, and -merge's usage (checked before MPI starts). The name
 * is the binary's own (dist_program_name), so a path in argv[0] changes nothing. */
static void test_mpi_names_itself(void)
{
    const char *mpi = mpi_or_skip();
    Cmd c;
    E2eRun r;
    mpirun_prefix(&c, "1");
    add(&c, mpi);
    add(&c, "--version");
    CHECK_INT(run(&c, &r), 0);
    CHECK_MSG(strncmp(r.out, "raytracer-mpi ", 14) == 0 && isdigit((unsigned char)r.out[14]),
              "--version:\n%s", r.out);
    e2e_run_free(&r);
    mpirun_prefix(&c, "1");
    add(&c, mpi);
    add(&c, "-h");
    CHECK_INT(run(&c, &r), 0);
    static const char synopsis[] = "usage: raytracer-mpi -input scene.txt [options]\n"
                                   "       raytracer-mpi -merge out part...\n";
    CHECK_MSG(strncmp(r.out, synopsis, sizeof synopsis - 1) == 0,
              "-h:\n%.200s", r.out);
    e2e_run_free(&r);
    mpirun_prefix(&c, "2");
    add(&c, mpi);
    add(&c, "-bogus");
    CHECK_INT(run(&c, &r), 2);
    /* its first line (mpirun adds its own about the non-zero exit) */
    static const char usage[] = "raytracer-mpi: unknown option '-bogus' (raytracer-mpi -h "
                                "for help)\n";
    CHECK_MSG(strncmp(r.err, usage, sizeof usage - 1) == 0, "usage error:\n%s", r.err);
    e2e_run_free(&r);
    c.n = 0;
    add(&c, mpi);
    add(&c, "-merge");
    add(&c, "out.tga");
    CHECK_INT(run(&c, &r), 2);
    static const char merge[] = "raytracer-mpi: usage: raytracer-mpi -merge ";
    CHECK_MSG(strncmp(r.err, merge, sizeof merge - 1) == 0,
              "-merge usage:\n%s", r.err);
    e2e_run_free(&r);
}

/* -output - under mpirun (into mpirun's standard output, here a pipe): the image's
 * bytes, the same as ./raytracer's, on 1 and 2 ranks. OpenMPI gives every rank a
 * pseudo-terminal as standard output, and the check that refuses to write an image to a
 * terminal refused it ("standard output is a terminal", exit 1, nothing written). */
static void test_mpi_output_stdout(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], scene[PATH_MAX], ref[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpiout") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    CHECK(e2e_write_file(scene, SCENE));
    const char *const opts[] = {"-input", scene, "-size", "40", "30", "-jittered_samples",
                                "4", "-gaussian_filter", "1", "-output", NULL};
    Cmd c;
    c.n = 0;
    add(&c, harness_bin());
    for (int i = 0; opts[i]; i++)
        add(&c, opts[i]);
    add(&c, ref);
    E2eRun r;
    CHECK_INT(run(&c, &r), 0);
    e2e_run_free(&r);
    size_t ref_len = 0;
    char *want = e2e_read_file(ref, &ref_len);
    CHECK(want != NULL && ref_len > 0);
    for (int np = 1; np <= 2 && want && !harness_failures; np++) {
        mpirun_prefix(&c, np == 1 ? "1" : "2");
        add(&c, mpi);
        for (int i = 0; opts[i]; i++)
            add(&c, opts[i]);
        add(&c, "-");
        int st = run(&c, &r);
        char why[512];
        CHECK_MSG(st == 0, "-np %d -output -: %s", np, e2e_describe(&r, why, sizeof why));
        CHECK_MSG(r.out_len == ref_len && memcmp(r.out, want, ref_len) == 0,
                  "-np %d -output -: %zu bytes on stdout, not ./raytracer's %zu", np,
                  r.out_len, ref_len);
        e2e_run_free(&r);
    }
    free(want);
    /* Started without mpirun (a singleton, whose MPI_Init sets OpenMPI's variables in
     * the process) onto a terminal, the image is still refused: the terminal is the
     * user's. Its standard output and error on a new pseudo-terminal. */
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    CHECK(master >= 0 && grantpt(master) == 0 && unlockpt(master) == 0);
    const char *slave_name = master >= 0 ? ptsname(master) : NULL;
    CHECK(slave_name != NULL);
    if (slave_name && !harness_failures) {
        c.n = 0;
        add(&c, mpi);
        for (int i = 0; opts[i]; i++)
            add(&c, opts[i]);
        add(&c, "-");
        c.v[c.n] = NULL;
        fflush(stdout);
        fflush(stderr);
        pid_t pid = fork();
        if (pid == 0) {
            setsid();
            int slave = open(slave_name, O_RDWR);
            int devnull = open("/dev/null", O_RDONLY);
            if (slave < 0 || devnull < 0)
                _exit(126);
            dup2(devnull, 0);
            dup2(slave, 1);
            dup2(slave, 2);
            close(master);
            execv(c.v[0], (char *const *)c.v);
            _exit(127);
        }
        size_t len = 0, cap = 0;
        char *text = NULL, buf[4096];
        e2e_append(&text, &len, &cap, "", 0);
        for (;;) {
            ssize_t got = read(master, buf, sizeof buf);
            if (got > 0)
                e2e_append(&text, &len, &cap, buf, (size_t)got);
            else if (!(got < 0 && errno == EINTR))
                break; /* EIO: the terminal's other side has gone */
        }
        int st = 0;
        while (waitpid(pid, &st, 0) < 0 && errno == EINTR) {
        }
        CHECK_MSG(WIFEXITED(st) && WEXITSTATUS(st) == 1 &&
                      strstr(text, "standard output is a terminal") && len < 1000,
                  "singleton -output - onto a terminal: status %d, %zu bytes:\n%.300s", st,
                  len, text);
        free(text);
    }
    if (master >= 0)
        close(master);
    e2e_rmtree(dir);
}

/* raytracer-mpi names itself when a stop signal ends -merge (it runs before MPI) or
 * the set-up of a singleton run (no mpirun: one process, which stops after the parse):
 * both said "raytracer: interrupted; no image written" from a fixed string. The input
 * that is read when the signal comes is a FIFO: the part image, the scene's OBJ file. */
static void test_mpi_interrupted_names_itself(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], fifo[PATH_MAX], out[PATH_MAX], scene[PATH_MAX], mesh[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpiname") != NULL);
    e2e_join(fifo, sizeof fifo, dir, "part.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(mesh, sizeof mesh, dir, "mesh.obj");
    CHECK(mkfifo(fifo, 0600) == 0 && mkfifo(mesh, 0600) == 0);
    CHECK(e2e_write_file(scene,
                         "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
                         "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
                         "Group { numObjects 1 MaterialIndex 0 TriangleMesh { obj_file mesh.obj } }\n"));
    if (harness_failures)
        return;
    int st = 0;
    char err[4096];
    const char *merge[] = {mpi, "-merge", out, fifo, NULL};
    CHECK_MSG(e2e_signal_while_reading(merge, fifo, SIGTERM, "", 0, &st, err, sizeof err) &&
                  WIFEXITED(st) && WEXITSTATUS(st) == 128 + SIGTERM,
              "-merge: status %#x, expected exit %d: %s", st, 128 + SIGTERM, err);
    CHECK_CONTAINS(err, "raytracer-mpi: interrupted; no image written\n");
    CHECK_MSG(!strstr(err, "raytracer: "), "-merge: another name: %s", err);
    const char *setup[] = {mpi, "-input", scene, "-size", "8", "8", "-output", out, NULL};
    static const char obj[] = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    CHECK_MSG(e2e_signal_while_reading(setup, mesh, SIGTERM, obj, sizeof obj - 1, &st, err,
                                       sizeof err) &&
                  WIFEXITED(st) && WEXITSTATUS(st) == 128 + SIGTERM,
              "set-up: status %#x, expected exit %d: %s", st, 128 + SIGTERM, err);
    CHECK_CONTAINS(err, "raytracer-mpi: interrupted; no image written\n");
    CHECK_MSG(!strstr(err, "raytracer: "), "set-up: another name: %s", err);
    CHECK(!e2e_exists(out));
    e2e_rmtree(dir);
}

/* A warning (an option without effect, two samplers) comes once, from rank 0: every
 * rank printed it (two ranks: twice). */
static void test_mpi_warnings_once(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpiwarn") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(out, sizeof out, dir, "out.tga");
    CHECK(e2e_write_file(scene, SCENE));
    Cmd c;
    mpirun_prefix(&c, "2");
    add(&c, mpi);
    add(&c, "-input");
    add(&c, scene);
    add(&c, "-size");
    add(&c, "16");
    add(&c, "16");
    add(&c, "-seed");
    add(&c, "3");
    add(&c, "-jittered_samples");
    add(&c, "4");
    add(&c, "-uniform_samples");
    add(&c, "4");
    add(&c, "-output");
    add(&c, out);
    E2eRun r;
    CHECK_INT(run(&c, &r), 0);
    CHECK_INT(count(r.err, "raytracer-mpi: warning: -seed has no effect"), 1);
    CHECK_INT(count(r.err, "raytracer-mpi: warning: -jittered_samples and -uniform_samples "
                           "both choose the sampler"), 1);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* -merge under mpirun: every rank ran it, each writing the output and printing every
 * message (a missing part was named three times at -np 3), and -merge - was refused on
 * every rank ("standard output is a terminal": OpenMPI gives each rank a
 * pseudo-terminal). Now rank 0 merges and the others leave with status 0: one image on
 * mpirun's standard output, the same bytes as the whole render, one message. */
static void test_mpi_merge_once(void)
{
    const char *mpi = mpi_or_skip();
    char dir[PATH_MAX], scene[PATH_MAX], whole[PATH_MAX], t0[PATH_MAX], t1[PATH_MAX],
        out[PATH_MAX], missing[PATH_MAX], why[512];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mpimerge") != NULL);
    e2e_join(scene, sizeof scene, dir, "s.txt");
    e2e_join(whole, sizeof whole, dir, "whole.tga");
    e2e_join(t0, sizeof t0, dir, "t0.tga");
    e2e_join(t1, sizeof t1, dir, "t1.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    e2e_join(missing, sizeof missing, dir, "missing.tga");
    CHECK(e2e_write_file(scene, SCENE));
    const char *outs[3] = {whole, t0, t1};
    for (int i = 0; i < 3; i++) {
        char k[4];
        snprintf(k, sizeof k, "%d", i - 1);
        const char *args[] = {"-input", scene, "-size", "40", "30", "-output", outs[i],
                              i ? "-tile" : NULL, k, "2", NULL};
        E2eRun r;
        CHECK(e2e_run_bin(harness_bin(), args, &r));
        CHECK_MSG(r.status == 0, "render: %s", e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
    }
    size_t want_len = 0;
    char *want = e2e_read_file(whole, &want_len);
    CHECK(want != NULL);
    Cmd c;
    E2eRun r;
    mpirun_prefix(&c, "3");
    add(&c, mpi);
    add(&c, "-merge");
    add(&c, "-");
    add(&c, t1);
    add(&c, t0);
    int st = run(&c, &r);
    CHECK_MSG(st == 0, "-merge - at -np 3: %s", e2e_describe(&r, why, sizeof why));
    CHECK_MSG(want && r.out_len == want_len && memcmp(r.out, want, want_len) == 0,
              "-merge - at -np 3: %zu bytes on stdout, not the whole render's %zu", r.out_len,
              want_len);
    e2e_run_free(&r);
    mpirun_prefix(&c, "3");
    add(&c, mpi);
    add(&c, "-merge");
    add(&c, out);
    add(&c, t0);
    add(&c, t1);
    st = run(&c, &r);
    CHECK_MSG(st == 0, "-merge at -np 3: %s", e2e_describe(&r, why, sizeof why));
    CHECK_MSG(same_file(out, whole), "-merge at -np 3: not the whole render's bytes");
    e2e_run_free(&r);
    /* A missing part: named once, status 1, nothing written. */
    unlink(out);
    mpirun_prefix(&c, "3");
    add(&c, mpi);
    add(&c, "-merge");
    add(&c, out);
    add(&c, t0);
    add(&c, missing);
    st = run(&c, &r);
    CHECK_MSG(st == 1, "-merge of a missing part at -np 3: exit %d, expected 1", st);
    CHECK_MSG(count(r.err, "missing.tga: error: ") == 1, "the missing part is named %d "
              "times, expected once:\n%s", count(r.err, "missing.tga: error: "), r.err);
    CHECK(!e2e_exists(out));
    e2e_run_free(&r);
    free(want);
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"mpi_03d", test_mpi_03d},
    {"mpi_11b", test_mpi_11b},
    {"mpi_12a_one_thread", test_mpi_12a},
    {"mpi_17a", test_mpi_17a},
    {"mpi_18a_region", test_mpi_18a_region},
    {"mpi_scene_error", test_mpi_scene_error},
    {"mpi_killed_rank", test_mpi_killed_rank},
    {"mpi_timings_version", test_mpi_timings_version},
    {"mpi_progress", test_mpi_progress},
    {"mpi_singleton_early_signal", test_mpi_singleton_early_signal},
    {"mpi_sigint_to_mpirun", test_mpi_sigint_to_mpirun},
    {"mpi_env_mismatch", test_mpi_env_mismatch},
    {"mpi_names_itself", test_mpi_names_itself},
    {"mpi_output_stdout", test_mpi_output_stdout},
    {"mpi_warnings_once", test_mpi_warnings_once},
    {"mpi_interrupted_names_itself", test_mpi_interrupted_names_itself},
    {"mpi_merge_once", test_mpi_merge_once},
};
RT_TEST_MAIN(tests)
