/* End-to-end tests of the set-up cache (-cache FILE): a process that writes the cache
 * and every process that maps it render exactly the bytes (and -stats) of a process
 * without it, for every accelerator, threads, tiles, regions and antialiasing; a
 * truncated, damaged, foreign or stale cache is never used and never breaks a render;
 * a cache that cannot be written is a warning; racing writers leave one valid file;
 * ./raytracer-static, when built, renders the same bytes; an OBJ file known by its
 * settled identity is not read (and a part image rendered so carries the render
 * identity of one whose process read it), and a changed one is. */
#define _GNU_SOURCE /* memmem */
#include "../harness.h"
#include "e2e_util.h"

#include <fcntl.h>
#include <sys/stat.h>

#include "rt/file.h"

/* A course line's arguments, -input made absolute and -output dropped, plus extras. */
typedef struct Cmd {
    const char *v[96];
    int n;
    char input[PATH_MAX];
    E2eCourseLine cl;
} Cmd;

static bool cmd_line(Cmd *c, const char *course, const char *id, const char *const *extra)
{
    memset(c, 0, sizeof *c);
    if (!e2e_course_line(course, id, &c->cl))
        return false;
    /* An -accel in extra replaces the line's -grid. */
    bool accel = false;
    for (int i = 0; extra && extra[i]; i++)
        accel = accel || strcmp(extra[i], "-accel") == 0;
    for (int i = 0; i < c->cl.argc; i++) {
        const char *t = c->cl.argv[i];
        if (strcmp(t, "-output") == 0 && i + 1 < c->cl.argc) {
            i++;
        } else if (accel && strcmp(t, "-grid") == 0) {
            i += i + 1 < c->cl.argc && strcmp(c->cl.argv[i + 1], "auto") == 0 ? 1 : 3;
        } else if (strcmp(t, "-input") == 0 && i + 1 < c->cl.argc) {
            e2e_join(c->input, sizeof c->input, course, c->cl.argv[++i]);
            c->v[c->n++] = "-input";
            c->v[c->n++] = c->input;
        } else {
            c->v[c->n++] = t;
        }
    }
    for (int i = 0; extra && extra[i] && c->n < 80; i++)
        c->v[c->n++] = extra[i];
    return true;
}

/* Runs c with -output out (and -cache cache, -timings when cache is given); the run in
 * *r. */
static bool cmd_run(const Cmd *c, const char *out, const char *cache, E2eRun *r)
{
    const char *argv[100];
    int n = 0;
    for (int i = 0; i < c->n; i++)
        argv[n++] = c->v[i];
    argv[n++] = "-output";
    argv[n++] = out;
    if (cache) {
        argv[n++] = "-cache";
        argv[n++] = cache;
        argv[n++] = "-timings";
    }
    argv[n] = NULL;
    return e2e_run_bin(harness_bin(), argv, r);
}

/* stdout without the lines that vary from run to run (times, rates), malloc'd. */
static char *steady(const char *out)
{
    char *s = strdup(out), *w = s;
    for (const char *l = out; s && *l;) {
        const char *nl = strchr(l, '\n');
        size_t n = nl ? (size_t)(nl + 1 - l) : strlen(l);
        if (!memmem(l, n, "total time", 10) && !memmem(l, n, "rays per second", 15)) {
            memmove(w, l, n);
            w += n;
        }
        l += n;
    }
    if (s)
        *w = '\0';
    return s;
}

static bool same_file(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *x = e2e_read_file(a, &la), *y = e2e_read_file(b, &lb);
    bool same = x && y && la == lb && memcmp(x, y, la) == 0;
    free(x);
    free(y);
    return same;
}

/* The line rendered without a cache, then with a fresh cache (built and written), then
 * with the written one (used): three identical images and -stats blocks. */
static void check_line(const char *id, const char *const *extra)
{
    const char *course = e2e_course_or_skip();
    Cmd c;
    CHECK_MSG(cmd_line(&c, course, id, extra), "line %s", id);
    if (harness_failures)
        return;
    char dir[PATH_MAX], ref[PATH_MAX], out[PATH_MAX], cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cache"));
    if (harness_failures)
        return;
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    E2eRun r0, r;
    char why[512];
    CHECK_MSG(cmd_run(&c, ref, NULL, &r0) && r0.status == 0, "%s: %s", id,
              e2e_describe(&r0, why, sizeof why));
    static const char *const want[] = {"built and written", "used", "used"};
    for (int k = 0; k < 3 && !harness_failures; k++) {
        char name[32];
        snprintf(name, sizeof name, "out%d.tga", k);
        e2e_join(out, sizeof out, dir, name);
        CHECK(cmd_run(&c, out, cache, &r));
        CHECK_MSG(r.status == 0, "%s run %d: %s", id, k, e2e_describe(&r, why, sizeof why));
        CHECK_MSG(strstr(r.err, want[k]) != NULL, "%s run %d: no '%s' in: %s", id, k, want[k],
                  r.err);
        CHECK_MSG(same_file(ref, out), "%s run %d: image differs from the render without "
                  "-cache", id, k);
        /* Every message of the run without a cache (warnings) is said with it too. */
        char *lines = strdup(r0.err);
        for (char *l = lines ? strtok(lines, "\n") : NULL; l; l = strtok(NULL, "\n"))
            CHECK_MSG(strstr(r.err, l) != NULL, "%s run %d: '%s' not said with -cache", id,
                      k, l);
        free(lines);
        char *o1 = steady(r.out), *o0 = steady(r0.out);
        CHECK_MSG(o1 && o0 && strcmp(o1, o0) == 0,
                  "%s run %d: stdout (-stats) differs:\n%s\nwithout -cache:\n%s", id, k,
                  r.out, r0.out);
        free(o1);
        free(o0);
        e2e_run_free(&r);
    }
    e2e_run_free(&r0);
    e2e_rmtree(dir);
}

static void test_cache_07(void) { check_line("07", NULL); }
static void test_cache_07_threads1(void)
{
    static const char *const x[] = {"-threads", "1", NULL};
    check_line("07", x);
}
static void test_cache_07_region(void)
{
    static const char *const x[] = {"-region", "13", "57", "101", "77", NULL};
    check_line("07", x);
}
static void test_cache_07_aa_tile(void)
{
    static const char *const x[] = {"-jittered_samples", "4", "-gaussian_filter", "0.6",
                                    "-tile", "3", "7", NULL};
    check_line("07", x);
}
static void test_cache_07_visualize(void)
{
    static const char *const x[] = {"-visualize_grid", NULL};
    check_line("07", x);
}
static void test_cache_07_auto(void)
{
    static const char *const x[] = {"-grid", "auto", NULL};
    check_line("07", x);
}
static void test_cache_07_twolevel(void)
{
    static const char *const x[] = {"-accel", "twolevel", NULL};
    check_line("07", x);
}
static void test_cache_07_nogrid(void)
{
    static const char *const x[] = {"-accel", "none", "-size", "12", "12", NULL};
    check_line("07", x);
}
/* Nothing to cache (no OBJ file, no grid): said so, same image. */
static void test_cache_nothing(void)
{
    const char *course = e2e_course_or_skip();
    Cmd c;
    CHECK(cmd_line(&c, course, "13", NULL));
    char dir[PATH_MAX], ref[PATH_MAX], out[PATH_MAX], cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cachenone"));
    if (harness_failures)
        return;
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    E2eRun r;
    CHECK(cmd_run(&c, ref, NULL, &r) && r.status == 0);
    e2e_run_free(&r);
    CHECK(cmd_run(&c, out, cache, &r));
    CHECK_MSG(r.status == 0 && strstr(r.err, "nothing to cache"), "%s", r.err);
    CHECK(same_file(ref, out));
    CHECK(!e2e_exists(cache));
    e2e_run_free(&r);
    e2e_rmtree(dir);
}
static void test_cache_10b(void) { check_line("10b", NULL); }
static void test_cache_11b(void) { check_line("11b", NULL); }
static void test_cache_12c(void) { check_line("12c", NULL); }
static void test_cache_17a(void) { check_line("17a", NULL); }
static void test_cache_18a_uniform(void)
{
    static const char *const x[] = {"-uniform_samples", "4", "-tile", "1", "3", NULL};
    check_line("18a", x);
}
/* The cap on cell references makes this grid coarser: the warning comes from the cache
 * too. */
static void test_cache_refit_warning(void)
{
    static const char *const x[] = {"-grid", "2048", "2048", "3", NULL};
    check_line("12b", x);
}

/* Writes len bytes to path. */
static bool put_file(const char *path, const char *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return false;
    bool ok = fwrite(data, 1, len, f) == len;
    return fclose(f) == 0 && ok;
}

/* Damaged caches: each is reported as not used (with -timings), the scene is built and
 * the image is the render's without a cache; the file is then rewritten valid. */
static void test_cache_damaged(void)
{
    const char *course = e2e_course_or_skip();
    Cmd c;
    CHECK(cmd_line(&c, course, "06", NULL));
    char dir[PATH_MAX], ref[PATH_MAX], out[PATH_MAX], cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cachebad"));
    if (harness_failures)
        return;
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    E2eRun r;
    char why[512];
    CHECK(cmd_run(&c, ref, cache, &r) && r.status == 0);
    e2e_run_free(&r);
    size_t len = 0;
    char *good = e2e_read_file(cache, &len);
    CHECK(good && len > 4096);
    if (harness_failures)
        return;
    char *bad = malloc(len);
    CHECK(bad != NULL);
    if (!bad)
        return;
    /* Every kind of damage, each alone. */
    for (int k = 0; k < 7 && !harness_failures; k++) {
        size_t n = len;
        memcpy(bad, good, len);
        const char *what;
        switch (k) {
        case 0: what = "truncated to half"; n = len / 2; break;
        case 1: what = "last byte cut"; n = len - 1; break;
        case 2: what = "a byte flipped in the body"; bad[len / 2 + 7] ^= 0x10; break;
        case 3: what = "a byte flipped in the header"; bad[20] ^= 0x01; break;
        case 4: what = "empty"; n = 0; break;
        case 5: what = "header only"; n = 128; break;
        default: what = "a byte flipped in the section table"; bad[140] ^= 0x40; break;
        }
        CHECK(put_file(cache, bad, n));
        CHECK(cmd_run(&c, out, cache, &r));
        CHECK_MSG(r.status == 0, "%s: %s", what, e2e_describe(&r, why, sizeof why));
        CHECK_MSG(strstr(r.err, "not used") != NULL, "%s: no 'not used' note in: %s", what,
                  r.err);
        CHECK_MSG(strstr(r.err, "built and written") != NULL, "%s: not rewritten: %s", what,
                  r.err);
        CHECK_MSG(same_file(ref, out), "%s: image differs", what);
        e2e_run_free(&r);
        /* Rewritten whole: the next run uses it. */
        CHECK(cmd_run(&c, out, cache, &r));
        CHECK_MSG(r.status == 0 && strstr(r.err, ": used") != NULL, "%s, rewritten: %s", what,
                  r.err);
        CHECK_MSG(same_file(ref, out), "%s, rewritten: image differs", what);
        e2e_run_free(&r);
    }
    /* A file that is no cache at all (the scene or an image named by mistake, short or
     * as long as a cache) is not used and left as it is: a warning, the same image.
     * It was replaced by the cache (a scene file given as -cache was lost). */
    for (int k = 0; k < 2 && !harness_failures; k++) {
        size_t n = k ? len : 20;
        memset(bad, 'x', len);
        memcpy(bad, "not a cache at all\n\n", 20);
        CHECK(put_file(cache, bad, n));
        CHECK(cmd_run(&c, out, cache, &r));
        CHECK_MSG(r.status == 0, "foreign %zu bytes: %s", n, e2e_describe(&r, why, sizeof why));
        CHECK_CONTAINS(r.err, "not used (not a set-up cache)");
        CHECK_CONTAINS(r.err, "is not a set-up cache: left as it is");
        CHECK_MSG(same_file(ref, out), "foreign %zu bytes: image differs", n);
        size_t back_len = 0;
        char *back = e2e_read_file(cache, &back_len);
        CHECK_MSG(back && back_len == n && memcmp(back, bad, n) == 0,
                  "foreign %zu bytes: the file was changed", n);
        free(back);
        e2e_run_free(&r);
    }
    free(bad);
    free(good);
    e2e_rmtree(dir);
}

/* A cache written for another scene or other options is valid but holds nothing this
 * render needs: built, rewritten, same image; and the render it was written for, run
 * again with the rewritten file, builds again (one scene per file) with its own image. */
static void test_cache_stale(void)
{
    const char *course = e2e_course_or_skip();
    Cmd a, b, g;
    static const char *const other_grid[] = {"-grid", "21", "20", "15", NULL};
    CHECK(cmd_line(&a, course, "05", NULL));
    CHECK(cmd_line(&b, course, "06", NULL));
    CHECK(cmd_line(&g, course, "06", other_grid));
    char dir[PATH_MAX], refa[PATH_MAX], refb[PATH_MAX], refg[PATH_MAX], out[PATH_MAX],
        cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cachestale"));
    if (harness_failures)
        return;
    e2e_join(refa, sizeof refa, dir, "a.tga");
    e2e_join(refb, sizeof refb, dir, "b.tga");
    e2e_join(refg, sizeof refg, dir, "g.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    E2eRun r;
    CHECK(cmd_run(&a, refa, NULL, &r) && r.status == 0);
    e2e_run_free(&r);
    CHECK(cmd_run(&b, refb, NULL, &r) && r.status == 0);
    e2e_run_free(&r);
    CHECK(cmd_run(&g, refg, NULL, &r) && r.status == 0);
    e2e_run_free(&r);
    const Cmd *seq[] = {&a, &b, &b, &g, &g, &b, &a};
    const char *refs[] = {refa, refb, refb, refg, refg, refb, refa};
    const char *want[] = {"built", "built", "used", "built", "used", "built", "built"};
    for (int k = 0; k < 7 && !harness_failures; k++) {
        CHECK(cmd_run(seq[k], out, cache, &r));
        CHECK_MSG(r.status == 0 && strstr(r.err, want[k]) != NULL, "step %d: want '%s': %s",
                  k, want[k], r.err);
        CHECK_MSG(same_file(refs[k], out), "step %d: image differs", k);
        e2e_run_free(&r);
    }
    e2e_rmtree(dir);
}

/* A cache that cannot be written (its folder is missing; it is a folder) is a warning
 * and the render goes on. */
static void test_cache_unwritable(void)
{
    const char *course = e2e_course_or_skip();
    Cmd c;
    CHECK(cmd_line(&c, course, "05", NULL));
    char dir[PATH_MAX], ref[PATH_MAX], out[PATH_MAX], cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cachero"));
    if (harness_failures)
        return;
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    E2eRun r;
    CHECK(cmd_run(&c, ref, NULL, &r) && r.status == 0);
    e2e_run_free(&r);
    e2e_join(cache, sizeof cache, dir, "no/such/folder/setup.cache");
    CHECK(cmd_run(&c, out, cache, &r));
    CHECK_MSG(r.status == 0, "missing folder: status %d: %s", r.status, r.err);
    CHECK_CONTAINS(r.err, "warning: set-up cache not written");
    CHECK(same_file(ref, out));
    e2e_run_free(&r);
    CHECK(cmd_run(&c, out, dir, &r)); /* the cache path is a folder */
    CHECK_MSG(r.status == 0, "folder: status %d: %s", r.status, r.err);
    CHECK_CONTAINS(r.err, "not used (not a regular file)");
    CHECK_CONTAINS(r.err, "warning: set-up cache not written");
    CHECK(same_file(ref, out));
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* -cache through a symbolic link: the cache is written to the link's target and the
 * link stays a link, as an image output does (930e55b). The link was replaced by a
 * regular file, both when dangling (its target made nowhere) and when its target
 * existed (the target left as it was). The next run through the link uses the cache. */
static void test_cache_through_links(void)
{
    const char *course = e2e_course_or_skip();
    Cmd c;
    CHECK(cmd_line(&c, course, "05", NULL));
    char dir[PATH_MAX], a[PATH_MAX], b[PATH_MAX], out[PATH_MAX];
    char dangling[PATH_MAX], existing[PATH_MAX], target1[PATH_MAX], target2[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cachelink"));
    if (harness_failures)
        return;
    e2e_join(a, sizeof a, dir, "a");
    e2e_join(b, sizeof b, dir, "b");
    CHECK(mkdir(a, 0755) == 0 && mkdir(b, 0755) == 0);
    e2e_join(out, sizeof out, dir, "out.tga");
    e2e_join(dangling, sizeof dangling, a, "dangling.cache");
    e2e_join(existing, sizeof existing, a, "existing.cache");
    e2e_join(target1, sizeof target1, b, "one.cache");
    e2e_join(target2, sizeof target2, b, "two.cache");
    CHECK(symlink("../b/one.cache", dangling) == 0);
    CHECK(put_file(target2, "", 0)); /* empty: nothing to lose, so it may be replaced */
    CHECK(symlink("../b/two.cache", existing) == 0);
    const char *links[2] = {dangling, existing}, *targets[2] = {target1, target2};
    for (int i = 0; i < 2 && !harness_failures; i++) {
        E2eRun r;
        CHECK(cmd_run(&c, out, links[i], &r));
        CHECK_MSG(r.status == 0, "%s: status %d: %s", links[i], r.status, r.err);
        CHECK_CONTAINS(r.err, "built and written");
        e2e_run_free(&r);
        struct stat st;
        CHECK_MSG(lstat(links[i], &st) == 0 && S_ISLNK(st.st_mode),
                  "%s is no longer a symbolic link", links[i]);
        CHECK_MSG(lstat(targets[i], &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0,
                  "%s was not written", targets[i]);
        CHECK(cmd_run(&c, out, links[i], &r));
        CHECK_MSG(r.status == 0, "%s again: status %d: %s", links[i], r.status, r.err);
        CHECK_CONTAINS(r.err, "set-up cache");
        CHECK_CONTAINS(r.err, ": used");
        e2e_run_free(&r);
    }
    /* no temporary file left beside either */
    CHECK_INT(e2e_count_entries(a), 2);
    CHECK_INT(e2e_count_entries(b), 2);
    e2e_rmtree(dir);
}

/* Eight processes start together on a fresh cache path: every one renders the same
 * image; the file left is valid (the next run uses it) and no temporary file stays. */
static void test_cache_racing_writers(void)
{
    const char *course = e2e_course_or_skip();
    Cmd c;
    CHECK(cmd_line(&c, course, "06", NULL));
    char dir[PATH_MAX], ref[PATH_MAX], out[PATH_MAX], cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cacherace"));
    if (harness_failures)
        return;
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    E2eRun r;
    CHECK(cmd_run(&c, ref, NULL, &r) && r.status == 0);
    e2e_run_free(&r);
    enum { N = 8 };
    pid_t pid[N];
    for (int k = 0; k < N; k++) {
        char name[32];
        snprintf(name, sizeof name, "race%d.tga", k);
        e2e_join(out, sizeof out, dir, name);
        pid[k] = fork();
        if (pid[k] == 0) {
            E2eRun rr;
            bool ok = cmd_run(&c, out, cache, &rr) && rr.status == 0;
            _exit(ok ? 0 : 1);
        }
        CHECK(pid[k] > 0);
    }
    for (int k = 0; k < N; k++) {
        int st = 0;
        if (pid[k] > 0) {
            CHECK(waitpid(pid[k], &st, 0) == pid[k]);
            CHECK_MSG(WIFEXITED(st) && WEXITSTATUS(st) == 0, "writer %d failed", k);
        }
        char name[32];
        snprintf(name, sizeof name, "race%d.tga", k);
        e2e_join(out, sizeof out, dir, name);
        CHECK_MSG(same_file(ref, out), "writer %d: image differs", k);
    }
    e2e_join(out, sizeof out, dir, "after.tga");
    CHECK(cmd_run(&c, out, cache, &r));
    CHECK_MSG(r.status == 0 && strstr(r.err, ": used") != NULL, "after the race: %s", r.err);
    CHECK(same_file(ref, out));
    e2e_run_free(&r);
    /* ref.tga, the N images, after.tga and the cache: nothing else. */
    CHECK_INT(e2e_count_entries(dir), N + 3);
    e2e_rmtree(dir);
}

/* ./raytracer-static (make static: the same program linked statically, for split
 * renders of many small parts) when it was built, else skipped: line 07 with the
 * Gaussian (whose margin crosses the parts) as 4 -tile parts with -cache, merged, is
 * ./raytracer's whole render byte for byte; its cache is its own (another binary's file
 * is not used). */
static void test_cache_static_binary(void)
{
    const char *bin = getenv("RT_STATIC_BIN");
    if (!bin || !*bin || access(bin, X_OK) != 0) {
        /* CI builds it (RT_REQUIRE_TOOLS=1): there a missing binary is a failure. */
        const char *req = getenv("RT_REQUIRE_TOOLS");
        if (req && strcmp(req, "1") == 0) {
            harness_fail(__FILE__, __LINE__, "RT_REQUIRE_TOOLS=1 but ./raytracer-static is "
                         "not built (make static)");
            return;
        }
        harness_skip("./raytracer-static not built (make static)");
    }
    const char *course = e2e_course_or_skip();
    static const char *const x[] = {"-size", "96", "64", "-jittered_samples", "4",
                                    "-gaussian_filter", "0.6", NULL};
    Cmd c;
    CHECK(cmd_line(&c, course, "07", x));
    char dir[PATH_MAX], ref[PATH_MAX], merged[PATH_MAX], cache[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cache_static"));
    if (harness_failures)
        return;
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    e2e_join(merged, sizeof merged, dir, "merged.tga");
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    E2eRun r;
    char why[512];
    CHECK_MSG(cmd_run(&c, ref, cache, &r) && r.status == 0, "%s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    char parts[4][PATH_MAX], kbuf[4][12];
    const char *margv[8] = {"-merge", merged};
    for (int k = 0; k < 4 && !harness_failures; k++) {
        snprintf(kbuf[k], sizeof kbuf[k], "%d", k);
        char name[32];
        snprintf(name, sizeof name, "part%d.tga", k);
        e2e_join(parts[k], sizeof parts[k], dir, name);
        const char *argv[110];
        int n = 0;
        for (int i = 0; i < c.n; i++)
            argv[n++] = c.v[i];
        const char *tail[] = {"-tile", kbuf[k], "4", "-cache", cache, "-timings",
                              "-output", parts[k], NULL};
        for (int i = 0; tail[i]; i++)
            argv[n++] = tail[i];
        argv[n] = NULL;
        CHECK(e2e_run_bin(bin, argv, &r));
        CHECK_MSG(r.status == 0, "part %d: %s", k, e2e_describe(&r, why, sizeof why));
        /* The first part finds ./raytracer's file (another build) and writes its own. */
        const char *want = k == 0 ? "another build" : ": used";
        CHECK_MSG(strstr(r.err, want) != NULL, "part %d: no '%s' in: %s", k, want, r.err);
        e2e_run_free(&r);
        margv[2 + k] = parts[k];
    }
    margv[6] = NULL;
    CHECK(e2e_run_bin(bin, margv, &r));
    CHECK_MSG(r.status == 0, "merge: %s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    CHECK_MSG(same_file(ref, merged), "the merged parts differ from ./raytracer's render");
    /* It has no preview on purpose: its answers say so and name the binary that has one,
     * rather than packages to install (they may well be installed). */
    const char *vargv[] = {"--version", NULL};
    CHECK(e2e_run_bin(bin, vargv, &r));
    CHECK_MSG(r.status == 0 && r.out && strstr(r.out, "gui window no (this build leaves it out "
                                                       "on purpose") &&
                  !strstr(r.out, "apt-get install libglut"),
              "--version: %s", r.out ? r.out : "");
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* Runs raytracer on scene with -cache cache (and -timings) into out; true when it
 * exited 0, with its stderr in err (malloc'd). */
/* The mesh scene at 48x48 with -timings (its cache line in *err, malloc'd); tile: band
 * tile of 2 (-tile), NULL: the whole image; cache NULL: none. */
static bool run_scene_tile(const char *scene, const char *out, const char *cache,
                           const char *tile, char **err)
{
    const char *argv[20] = {"-input", scene, "-size", "48", "48", "-grid", "10", "10", "7",
                            "-shadows", "-output", out, "-timings"};
    int n = 13;
    if (tile) {
        argv[n++] = "-tile";
        argv[n++] = tile;
        argv[n++] = "2";
    }
    if (cache) {
        argv[n++] = "-cache";
        argv[n++] = cache;
    }
    argv[n] = NULL;
    E2eRun r;
    bool ok = e2e_run_bin(harness_bin(), argv, &r) && r.status == 0;
    *err = strdup(r.err ? r.err : "");
    e2e_run_free(&r);
    return ok;
}

static bool run_scene(const char *scene, const char *out, const char *cache, char **err)
{
    return run_scene_tile(scene, out, cache, NULL, err);
}

/* An OBJ file whose settled identity (rt/file.h: device, inode, size, mtime, ctime,
 * older than RT_FILE_SETTLED_SECONDS) the cache knows is not read; a fresh one always
 * is; and one changed since, even with its size and mtime put back and settled again,
 * is read again and rendered as it now is. */
static void test_cache_obj_identity(void)
{
    const char *course = e2e_course_or_skip();
    char dir[PATH_MAX], src[PATH_MAX], scene[PATH_MAX], obj[PATH_MAX], cache[PATH_MAX];
    char ref[PATH_MAX], ref2[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "cache_id"));
    if (harness_failures)
        return;
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(obj, sizeof obj, dir, "bunny_200.obj");
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    e2e_join(ref, sizeof ref, dir, "ref.tga");
    e2e_join(ref2, sizeof ref2, dir, "ref2.tga");
    e2e_join(out, sizeof out, dir, "out.tga");
    e2e_join(src, sizeof src, course, "scene6_04_bunny_mesh_200.txt");
    char *text = e2e_read_file(src, NULL);
    e2e_join(src, sizeof src, course, "bunny_200.obj");
    size_t olen = 0;
    char *objtext = e2e_read_file(src, &olen);
    CHECK(text && objtext && e2e_write_file(scene, text) && e2e_write_file(obj, objtext));
    char *err = NULL;
    /* Fresh files: read every time. */
    static const char *const fresh[] = {"built and written", "used"};
    for (int k = 0; k < 2 && !harness_failures; k++) {
        CHECK(run_scene(scene, out, cache, &err));
        CHECK_MSG(strstr(err, fresh[k]) && strstr(err, "not read: 0)"), "fresh run %d: %s", k,
                  err);
        free(err);
    }
    CHECK(run_scene(scene, ref, NULL, &err));
    free(err);
    /* Settled: the first run records the identity, the next one does not read the file. */
    sleep(RT_FILE_SETTLED_SECONDS + 1);
    static const char *const settled[] = {"built and written (OBJ files known by their "
                                          "identity, not read: 0)",
                                          "used (OBJ files known by their identity, not "
                                          "read: 1)"};
    for (int k = 0; k < 2 && !harness_failures; k++) {
        CHECK(run_scene(scene, out, cache, &err));
        CHECK_MSG(strstr(err, settled[k]) != NULL, "settled run %d: %s", k, err);
        CHECK_MSG(same_file(ref, out), "settled run %d: image differs", k);
        free(err);
    }
    /* A part image's render identity keys the OBJ file's bytes (rt/image.h) also when
     * the cache knew the file by its identity and did not read it: such a part merges
     * with one whose process read the file, into the whole render. */
    char top[PATH_MAX], bottom[PATH_MAX];
    e2e_join(top, sizeof top, dir, "top.tga");
    e2e_join(bottom, sizeof bottom, dir, "bottom.tga");
    CHECK(run_scene_tile(scene, top, cache, "0", &err));
    CHECK_MSG(strstr(err, settled[1]) != NULL, "settled part: %s", err);
    free(err);
    CHECK(run_scene_tile(scene, bottom, NULL, "1", &err));
    free(err);
    E2eRun mr;
    CHECK(e2e_run_bin(harness_bin(), (const char *[]){"-merge", out, top, bottom, NULL}, &mr));
    CHECK_MSG(mr.status == 0, "a part of the mesh known by its identity and one of the mesh "
              "read do not merge: %s", mr.err ? mr.err : "");
    e2e_run_free(&mr);
    CHECK_MSG(same_file(ref, out), "the merged parts differ from the whole render");
    /* Changed in place, same size, mtime put back: ctime moved, so it is read again. */
    struct stat st;
    CHECK(stat(obj, &st) == 0);
    for (char *c = objtext; (c = strstr(c, "0.2")) != NULL; c += 3)
        c[2] = '3';
    FILE *f = fopen(obj, "r+b");
    CHECK(f && fwrite(objtext, 1, olen, f) == olen);
    if (f)
        fclose(f);
    struct timespec times[2] = {st.st_atim, st.st_mtim};
    CHECK(utimensat(AT_FDCWD, obj, times, 0) == 0);
    struct stat now;
    CHECK(stat(obj, &now) == 0 && now.st_size == st.st_size &&
          now.st_mtim.tv_sec == st.st_mtim.tv_sec && now.st_mtim.tv_nsec == st.st_mtim.tv_nsec);
    CHECK(run_scene(scene, ref2, NULL, &err));
    free(err);
    CHECK_MSG(!same_file(ref, ref2), "the changed OBJ file renders the same image");
    /* Settled again (so only its new ctime tells it from the recorded identity). */
    sleep(RT_FILE_SETTLED_SECONDS + 1);
    CHECK(run_scene(scene, out, cache, &err));
    CHECK_MSG(strstr(err, "built and written") && strstr(err, "not read: 0)"), "changed: %s",
              err);
    CHECK_MSG(same_file(ref2, out), "the changed OBJ file was rendered from the stale cache");
    free(err);
    free(text);
    free(objtext);
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"cache_07", test_cache_07},
    {"cache_07_threads1", test_cache_07_threads1},
    {"cache_07_region", test_cache_07_region},
    {"cache_07_aa_tile", test_cache_07_aa_tile},
    {"cache_07_visualize", test_cache_07_visualize},
    {"cache_07_auto", test_cache_07_auto},
    {"cache_07_twolevel", test_cache_07_twolevel},
    {"cache_07_nogrid", test_cache_07_nogrid},
    {"cache_nothing", test_cache_nothing},
    {"cache_10b", test_cache_10b},
    {"cache_11b", test_cache_11b},
    {"cache_12c", test_cache_12c},
    {"cache_17a", test_cache_17a},
    {"cache_18a_uniform", test_cache_18a_uniform},
    {"cache_refit_warning", test_cache_refit_warning},
    {"cache_damaged", test_cache_damaged},
    {"cache_stale", test_cache_stale},
    {"cache_unwritable", test_cache_unwritable},
    {"cache_through_links", test_cache_through_links},
    {"cache_racing_writers", test_cache_racing_writers},
    {"cache_static_binary", test_cache_static_binary},
    {"cache_obj_identity", test_cache_obj_identity},
};
RT_TEST_MAIN(tests)
