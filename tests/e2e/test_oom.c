/* End-to-end tests of the program when memory runs out. A preloaded injector
 * (tests/support/oom_shim.c) makes one allocation of a command fail -- malloc, calloc,
 * realloc, the aligned forms or mmap -- and the test does so for every allocation the
 * command makes, one run each. Every run must end by itself, either
 *   - with status 0 and exactly the bytes of the normal run (an allocation the program
 *     can do without: a helper thread's memory, a cache, a faster path), or
 *   - with status 1, a message on stderr that says memory ran out, no image written and
 *     no temporary file left behind;
 * never with a crash, an abort, a hang or a half-written image. And one where every
 * big allocation fails (OOM_MAX_BYTES): an antialiased render written into its files
 * while it is made must not need one. */
#define _POSIX_C_SOURCE 200809L
#include <dirent.h>
#include <limits.h>
#include <unistd.h>

#include "../harness.h"
#include "e2e_util.h"

#include "rt/image.h"

/* The injector: RT_OOM_SHIM (the test command sets it), else the library beside the
 * test binaries of this build (build/tests/liboom_shim.so for build/tests/e2e/test_oom). */
static bool shim_path(char *buf, size_t size)
{
    const char *env = getenv("RT_OOM_SHIM");
    if (env && *env) {
        snprintf(buf, size, "%s", env);
        return access(buf, R_OK) == 0;
    }
    char self[PATH_MAX];
    ssize_t n = readlink("/proc/self/exe", self, sizeof self - 1);
    if (n <= 0)
        return false;
    self[n] = '\0';
    char *slash = strrchr(self, '/');
    if (!slash)
        return false;
    *slash = '\0';
    int len = snprintf(buf, size, "%s/../liboom_shim.so", self);
    return len > 0 && (size_t)len < size && access(buf, R_OK) == 0;
}

enum { MAX_OUTS = 4 };

/* A file in dir that is none of the command's outputs nor its scratch file: a
 * temporary file left behind (an image's ".name.XXXXXX", the set-up cache's
 * "cache.tmp.PID.N", or any other). Its name goes to stray. */
static bool has_stray_file(const char *dir, const char *const *outs, const char *scratch,
                           char *stray, size_t size)
{
    DIR *d = opendir(dir);
    if (!d)
        return false;
    bool found = false;
    struct dirent *e;
    while (!found && (e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, ".."))
            continue;
        char path[PATH_MAX];
        e2e_join(path, sizeof path, dir, e->d_name);
        bool known = scratch && !strcmp(path, scratch);
        for (int k = 0; k < MAX_OUTS && outs[k] && !known; k++)
            known = !strcmp(path, outs[k]);
        if (!known) {
            snprintf(stray, size, "%s", e->d_name);
            found = true;
        }
    }
    closedir(d);
    return found;
}

typedef struct Sweep {
    const char *shim;
    const char *dir;
    const char *const *args;   /* the command's arguments, NULL-terminated */
    const char *outs[MAX_OUTS]; /* the files it writes (NULL-terminated) */
    const char *scratch;       /* a file removed before every run (NULL: none) */
} Sweep;

/* Runs the command under the injector with OOM_FAIL_AT = fail_at (0: no failure) and,
 * when count_file is given, the injector's count of allocations written there. */
static bool run_injected(const Sweep *s, long fail_at, const char *count_file, E2eRun *r)
{
    for (int k = 0; k < MAX_OUTS && s->outs[k]; k++)
        remove(s->outs[k]);
    if (s->scratch)
        remove(s->scratch);
    char at[32];
    snprintf(at, sizeof at, "%ld", fail_at);
    /* The child inherits these; this process was loaded long before, without them. */
    setenv("LD_PRELOAD", s->shim, 1);
    setenv("OOM_FAIL_AT", at, 1);
    if (count_file)
        setenv("OOM_COUNT_FILE", count_file, 1);
    bool started = e2e_run_bin(harness_bin(), s->args, r);
    unsetenv("LD_PRELOAD");
    unsetenv("OOM_FAIL_AT");
    unsetenv("OOM_COUNT_FILE");
    return started;
}

static void sweep(const Sweep *s)
{
    char count_file[PATH_MAX], why[512];
    e2e_join(count_file, sizeof count_file, s->dir, "count.txt");
    E2eRun r;
    CHECK(run_injected(s, 0, count_file, &r));
    CHECK_MSG(r.status == 0, "the run without a failure: %s", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    char *ref[MAX_OUTS] = {NULL};
    size_t ref_len[MAX_OUTS] = {0};
    int nouts = 0;
    for (; nouts < MAX_OUTS && s->outs[nouts]; nouts++) {
        ref[nouts] = e2e_read_file(s->outs[nouts], &ref_len[nouts]);
        CHECK_MSG(ref[nouts] != NULL, "the run without a failure wrote no %s", s->outs[nouts]);
    }
    char *text = e2e_read_file(count_file, NULL);
    long calls = text ? atol(text) : 0;
    free(text);
    remove(count_file);
    /* The injector counts this process's own allocations only if it was preloaded: a
     * command with none would mean it was not, and the sweep would prove nothing. */
    CHECK_MSG(calls > 0, "the injector saw no allocation: not preloaded?");
    if (harness_failures)
        goto done;
    int absorbed = 0, refused = 0;
    /* With threads the order of allocations may vary a little between runs: a few
     * failure points past the count of the first run are tried too. */
    for (long at = 1; at <= calls + 4 && !harness_failures; at++) {
        CHECK(run_injected(s, at, NULL, &r));
        if (r.status == 0) {
            absorbed++;
            for (int k = 0; k < nouts; k++) {
                size_t len = 0;
                char *got = e2e_read_file(s->outs[k], &len);
                CHECK_MSG(got && len == ref_len[k] && memcmp(got, ref[k], len) == 0,
                          "allocation %ld failed, status 0, but %s differs from the normal "
                          "run's", at, s->outs[k]);
                free(got);
            }
        } else if (r.status == 1) {
            refused++;
            CHECK_MSG(strstr(r.err, "error: ") && strstr(r.err, "memory"),
                      "allocation %ld failed: status 1 without a message about memory: %s", at,
                      r.err);
            for (int k = 0; k < nouts; k++)
                CHECK_MSG(!e2e_exists(s->outs[k]), "allocation %ld failed: status 1 but %s "
                          "was written", at, s->outs[k]);
        } else {
            CHECK_MSG(false, "allocation %ld failed: %s", at, e2e_describe(&r, why, sizeof why));
        }
        char stray[256] = "";
        CHECK_MSG(!has_stray_file(s->dir, s->outs, s->scratch, stray, sizeof stray),
                  "allocation %ld failed: a temporary file %s was left in %s", at, stray,
                  s->dir);
        e2e_run_free(&r);
    }
    CHECK_MSG(refused > 0, "no failure was refused (%d absorbed): the injector did nothing?",
              absorbed);
    printf("(%d failure points: %d absorbed, %d refused) ", absorbed + refused, absorbed,
           refused);
    fflush(stdout);
done:
    for (int k = 0; k < nouts; k++)
        free(ref[k]);
}

static bool setup(char *shim, size_t shim_size, char *dir, size_t dir_size, const char *name,
                  char *scene, size_t scene_size)
{
    if (E2E_SANITIZED)
        harness_skip("the sanitizers' runtime must be the first library loaded: no injector");
    CHECK_MSG(shim_path(shim, shim_size), "no allocation injector (build/tests/liboom_shim.so; "
              "make test builds it)");
    if (harness_failures)
        return false;
    e2e_join(scene, scene_size, harness_root(), "scenes/feat_mesh_transform.txt");
    CHECK_MSG(e2e_exists(scene), "missing %s", scene);
    CHECK(e2e_tmpdir(dir, dir_size, name) != NULL);
    return !harness_failures;
}

/* A render with everything that allocates: OBJ meshes, the two-level grid, shadow rays,
 * the film's strips and weights, two render threads. */
static void test_oom_render(void)
{
    char shim[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    if (!setup(shim, sizeof shim, dir, sizeof dir, "oom_render", scene, sizeof scene))
        return;
    e2e_join(out, sizeof out, dir, "a.tga");
    const char *args[] = {"-input", scene, "-size", "64", "48", "-grid", "auto", "-shadows",
                          "-jittered_samples", "4", "-gaussian_filter", "0.4", "-threads", "2",
                          "-output", out, NULL};
    Sweep s = {shim, dir, args, {out, NULL}, NULL};
    sweep(&s);
    e2e_rmtree(dir);
}

/* A part image with all three kinds of image, the counters, a uniform grid. */
static void test_oom_part(void)
{
    char shim[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX], col[PATH_MAX], nor[PATH_MAX],
        dep[PATH_MAX];
    if (!setup(shim, sizeof shim, dir, sizeof dir, "oom_part", scene, sizeof scene))
        return;
    e2e_join(col, sizeof col, dir, image_format_supported("png") ? "b.png" : "b.tga");
    e2e_join(nor, sizeof nor, dir, "n.ppm");
    e2e_join(dep, sizeof dep, dir, "d.tga");
    const char *args[] = {"-input", scene, "-size", "48", "32", "-tile", "1", "2",
                          "-output", col, "-normals", nor, "-depth", "5", "15", dep,
                          "-stats", "-grid", "6", "6", "6", "-threads", "2", NULL};
    Sweep s = {shim, dir, args, {col, nor, dep, NULL}, NULL};
    sweep(&s);
    e2e_rmtree(dir);
}

/* The set-up cache written from scratch by every run, with uniform samples. */
static void test_oom_cache(void)
{
    char shim[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX], cache[PATH_MAX];
    if (!setup(shim, sizeof shim, dir, sizeof dir, "oom_cache", scene, sizeof scene))
        return;
    e2e_join(out, sizeof out, dir, "c.tga");
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    const char *args[] = {"-input", scene, "-size", "40", "30", "-grid", "8", "8", "8",
                          "-uniform_samples", "4", "-cache", cache, "-output", out, NULL};
    Sweep s = {shim, dir, args, {out, NULL}, cache};
    sweep(&s);
    e2e_rmtree(dir);
}

/* -merge of two parts rendered beforehand (outside the swept folder). */
static void test_oom_merge(void)
{
    char shim[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX], parts[PATH_MAX], p0[PATH_MAX],
        p1[PATH_MAX], out[PATH_MAX];
    if (!setup(shim, sizeof shim, dir, sizeof dir, "oom_merge", scene, sizeof scene))
        return;
    CHECK(e2e_tmpdir(parts, sizeof parts, "oom_parts") != NULL);
    e2e_join(p0, sizeof p0, parts, "p0.tga");
    e2e_join(p1, sizeof p1, parts, "p1.tga");
    e2e_join(out, sizeof out, dir, "m.tga");
    for (int k = 0; k < 2; k++) {
        E2eRun r;
        CHECK_INT(e2e_run_bin(harness_bin(),
                              (const char *[]){"-input", scene, "-size", "48", "32", "-tile",
                                               k ? "1" : "0", "2", "-output", k ? p1 : p0, NULL},
                              &r),
                  true);
        CHECK_INT(r.status, 0);
        e2e_run_free(&r);
    }
    const char *args[] = {"-merge", out, p1, p0, NULL};
    Sweep s = {shim, dir, args, {out, NULL}, NULL};
    if (!harness_failures)
        sweep(&s);
    e2e_rmtree(parts);
    e2e_rmtree(dir);
}

/* An antialiased render into files holds no whole image (main.c stream_film: the film
 * hands its rows strip by strip to the files, rt/film.h FilmConfig.rows): under the
 * injector every allocation of more than 1.5 MB fails (OOM_MAX_BYTES), less than one
 * whole 1000 x 700 image (2.1 MB, and as much again for its file's bytes), yet the
 * colour (TGA) and normal (PPM) images are written, with the bytes of the same render to
 * standard output, which is rendered whole (not under the injector). One thread: with
 * two the film's strips take its 8 MB budget. Before, the render allocated the whole
 * images and stopped with "out of memory for a 1000x700 image". */
static void test_oom_streamed_film(void)
{
    char shim[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX], nor[PATH_MAX],
        ref_nor[PATH_MAX], why[512];
    if (!setup(shim, sizeof shim, dir, sizeof dir, "oom_stream", scene, sizeof scene))
        return;
    char planes[PATH_MAX];
    snprintf(planes, sizeof planes, "%s/tests/repro/planes_only.txt", harness_root());
    e2e_join(out, sizeof out, dir, "s.tga");
    e2e_join(nor, sizeof nor, dir, "n.ppm");
    e2e_join(ref_nor, sizeof ref_nor, dir, "ref_n.ppm");
    const char *args[] = {"-input", planes, "-size", "1000", "700", "-jittered_samples", "1",
                          "-tent_filter", "1", "-threads", "1", "-output", out, "-normals",
                          nor, NULL};
    setenv("LD_PRELOAD", shim, 1);
    setenv("OOM_MAX_BYTES", "1500000", 1);
    E2eRun r;
    CHECK(e2e_run_bin(harness_bin(), args, &r));
    unsetenv("LD_PRELOAD");
    unsetenv("OOM_MAX_BYTES");
    CHECK_MSG(r.status == 0, "the streamed render under a 1.5 MB cap: %s",
              e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    const char *ref_args[] = {"-input", planes, "-size", "1000", "700", "-jittered_samples",
                              "1", "-tent_filter", "1", "-threads", "1", "-output", "-",
                              "-normals", ref_nor, NULL};
    CHECK(e2e_run_bin(harness_bin(), ref_args, &r));
    CHECK_MSG(r.status == 0, "the render to standard output: %s",
              e2e_describe(&r, why, sizeof why));
    size_t len = 0, nlen = 0, rnlen = 0;
    char *got = e2e_read_file(out, &len);
    char *got_n = e2e_read_file(nor, &nlen), *ref_n = e2e_read_file(ref_nor, &rnlen);
    CHECK_MSG(got && len == r.out_len && len == 18 + 1000 * 700 * 3 &&
                  memcmp(got, r.out, len) == 0,
              "the streamed colour image (%zu bytes) differs from the whole one (%zu)", len,
              r.out_len);
    CHECK_MSG(got_n && ref_n && nlen == rnlen && memcmp(got_n, ref_n, nlen) == 0,
              "the streamed normal image (%zu bytes) differs from the whole one (%zu)", nlen,
              rnlen);
    free(got);
    free(got_n);
    free(ref_n);
    e2e_run_free(&r);
    e2e_rmtree(dir);
}

/* Whether every pixel of the file at path (len bytes, the pixels from byte `top` on)
 * is the three bytes px. */
static bool all_pixels(const unsigned char *img, size_t len, size_t top, const unsigned char *px)
{
    for (size_t i = top; i + 3 <= len; i += 3)
        if (memcmp(img + i, px, 3) != 0)
            return false;
    return true;
}

/* The file at path: 2000 x 2000 pixels after a header of `top` bytes, each px. */
static void check_flat_image(const char *path, size_t top, const unsigned char *px)
{
    size_t len = 0;
    unsigned char *img = (unsigned char *)e2e_read_file(path, &len);
    CHECK_MSG(img && len == top + (size_t)2000 * 2000 * 3, "%s has %zu bytes", path, len);
    if (img && len == top + (size_t)2000 * 2000 * 3)
        CHECK_MSG(all_pixels(img, len, top, px), "%s: a pixel is not %u %u %u", path, px[0],
                  px[1], px[2]);
    free(img);
}

/* A plain render into TGA and PPM files reserves no whole image (main.c stream_plain:
 * each image goes band by band into its file, which is begun as its header only):
 * under an address-space limit (ulimit -v 30000, about 29 MB) a 2000 x 2000 render
 * (12 MB per image and as much again for its file's bytes, never touched but reserved
 * before) is written whole, every pixel the plane's colour; with aux, its -depth (t = 11
 * between 9 and 13: grey 127) and -normals (0 0 1: blue) too. The limit is set in a
 * shell that then runs the program. Before, the colour alone needed 48-56 MB of address
 * space (measured) and stopped with "cannot write image: Cannot allocate memory", exit
 * 1; it now needs about 5. With the depth and normal images, which were held whole until
 * polish31, 85-90 MB at -threads 2 (exit 1, "out of memory for a 2000x2000 image"); now
 * about 18. Not under the sanitizers, whose shadow memory no such limit admits. */
static void plain_stream_address_limit(bool aux)
{
    if (E2E_SANITIZED)
        harness_skip("the sanitizers' shadow memory does not fit under ulimit -v");
    char dir[PATH_MAX], out[PATH_MAX], dep[PATH_MAX], nor[PATH_MAX], planes[PATH_MAX],
        why[512];
    snprintf(planes, sizeof planes, "%s/tests/repro/planes_only.txt", harness_root());
    CHECK(e2e_tmpdir(dir, sizeof dir, "aslimit") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(dep, sizeof dep, dir, "d.tga");
    e2e_join(nor, sizeof nor, dir, "n.ppm");
    char *args[] = {"/bin/sh", "-c", "ulimit -v 30000 && exec \"$0\" \"$@\"",
                    (char *)harness_bin(), "-input", planes, "-output", out, "-size", "2000",
                    "2000", "-threads", "2", "-depth", "9", "13", dep, "-normals", nor, NULL};
    if (!aux)
        args[13] = NULL; /* the colour alone */
    E2eRun r;
    CHECK(e2e_run(args, &r));
    CHECK_MSG(r.status == 0, "a plain 2000x2000 render%s under ulimit -v 30000: %s",
              aux ? " with -depth and -normals" : "", e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    /* The plane fills the view: red (B G R in the TGA). */
    static const unsigned char red_bgr[3] = {0, 0, 255}, grey[3] = {127, 127, 127},
                               blue[3] = {0, 0, 255};
    check_flat_image(out, 18, red_bgr);
    if (aux) {
        check_flat_image(dep, 18, grey);
        check_flat_image(nor, 17, blue); /* "P6\n2000 2000\n255\n" */
    }
    CHECK_INT(e2e_count_entries(dir), aux ? 3 : 1);
    e2e_rmtree(dir);
}

static void test_plain_stream_address_limit(void) { plain_stream_address_limit(false); }

/* The same with -depth and -normals: on 0816af8 exit 1 under the limit (fails). */
static void test_plain_stream_aux_address_limit(void) { plain_stream_address_limit(true); }

/* The widest film README promises an answer for: the Gaussian 16 (R = 32) with 1024
 * jittered samples and a depth image keeps each sample's eight floats and 130 weights for
 * strips of 72 rows of at least 576 columns (about 23 GB at 600 wide). Under an address
 * limit of about 2 GB (ulimit -v 2000000) the render must stop before tracing with
 * README's message, exit status 1, and write no image: neither a crash nor a half-written
 * file. Not under the sanitizers (their shadow memory does not fit the limit). */
static void test_wide_film_address_limit(void)
{
    if (E2E_SANITIZED)
        harness_skip("the sanitizers' shadow memory does not fit under ulimit -v");
    char dir[PATH_MAX], out[PATH_MAX], dep[PATH_MAX], planes[PATH_MAX], why[512];
    snprintf(planes, sizeof planes, "%s/tests/repro/planes_only.txt", harness_root());
    CHECK(e2e_tmpdir(dir, sizeof dir, "widefilm") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(dep, sizeof dep, dir, "d.tga");
    char *args[] = {"/bin/sh", "-c", "ulimit -v 2000000 && exec \"$0\" \"$@\"",
                    (char *)harness_bin(), "-input", planes, "-output", out, "-size", "600",
                    "100", "-jittered_samples", "1024", "-gaussian_filter", "16", "-depth", "9",
                    "13", dep, "-threads", "2", NULL};
    E2eRun r;
    CHECK(e2e_run(args, &r));
    CHECK_MSG(r.status == 1 && strstr(r.err, "could not start the render (out of memory?)"),
              "the Gaussian 16 with 1024 samples under ulimit -v 2000000: %s",
              e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
    CHECK_INT(e2e_count_entries(dir), 0);
    e2e_rmtree(dir);
}

/* Whether the files at a and b hold the same bytes (both readable). */
static bool same_bytes(const char *a, const char *b)
{
    size_t la = 0, lb = 0;
    char *da = e2e_read_file(a, &la), *db = e2e_read_file(b, &lb);
    bool same = da && db && la == lb && memcmp(da, db, la) == 0;
    free(da);
    free(db);
    return same;
}

/* -merge reads its parts row by row and writes the output strip by strip (src/io/merge.c,
 * rows.c), so its memory does not grow with the image: under ulimit -v 20000 (about
 * 19.5 MB of address space) four 1000 x 1000 tiles of a 2000 x 2000 image, one each as
 * TGA, PNG and PPM, merge into TGA and PNG files that are the whole render's bytes. It
 * needs about 10 MB; before, the merge held the whole output (12 MB) and each part as
 * floats (12 MB) and stopped with "cannot read image: out of memory for a 1000x1000
 * image" (exit 1) below about 35 MB. Under the sanitizers, whose shadow memory no such
 * limit admits, the merges run without the limit (the bytes are still checked). */
static void test_merge_address_limit(void)
{
    char dir[PATH_MAX], scene[PATH_MAX], why[512];
    CHECK(e2e_tmpdir(dir, sizeof dir, "mergelimit") != NULL);
    e2e_join(scene, sizeof scene, dir, "spheres.txt");
    /* Two spheres under a slanted light: every row differs, so a row out of place shows. */
    CHECK(e2e_write_file(scene,
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
        "Lights { numLights 1 DirectionalLight { direction -0.3 -0.5 -1 color 1 1 1 } }\n"
        "Materials { numMaterials 2 PhongMaterial { diffuseColor 1 0 0 }\n"
        "  PhongMaterial { diffuseColor 0 1 0 } }\n"
        "Background { color 0 0 0.5 ambientLight 0.1 0.1 0.1 }\n"
        "Group { numObjects 2 MaterialIndex 0 Sphere { center -1 0 0 radius 2 }\n"
        "  MaterialIndex 1 Sphere { center 1.5 1 0 radius 1.5 } }\n"));
    static const char *const names[] = {"whole.tga", "whole.png", "t0.tga", "t1.png",
                                        "t2.ppm", "t3.tga"};
    char paths[6][PATH_MAX];
    for (int i = 0; i < 6; i++) {
        e2e_join(paths[i], sizeof paths[i], dir, names[i]);
        char k[4];
        snprintf(k, sizeof k, "%d", i - 2);
        const char *args[] = {"-input", scene, "-size", "2000", "2000", "-output", paths[i],
                              i >= 2 ? "-tile" : NULL, k, "2x2", NULL};
        E2eRun r;
        CHECK(e2e_run_bin(harness_bin(), args, &r));
        CHECK_MSG(r.status == 0, "render of %s: %s", names[i], e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
    }
    for (int i = 0; i < 2; i++) {
        char out[PATH_MAX];
        e2e_join(out, sizeof out, dir, i == 0 ? "merged.tga" : "merged.png");
        char *limited[] = {"/bin/sh", "-c", "ulimit -v 20000 && exec \"$0\" \"$@\"",
                           (char *)harness_bin(), "-merge", out, paths[5], paths[4],
                           paths[3], paths[2], NULL};
        E2eRun r;
        CHECK(e2e_run(E2E_SANITIZED ? limited + 3 : limited, &r));
        CHECK_MSG(r.status == 0, "-merge %s under ulimit -v 20000: %s", out,
                  e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
        CHECK_MSG(same_bytes(out, paths[i]), "%s differs from the whole render %s", out,
                  paths[i]);
    }
    CHECK_INT(e2e_count_entries(dir), 9); /* the scene, 6 renders, 2 merges: no leftovers */
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"oom_render", test_oom_render},
    {"oom_part", test_oom_part},
    {"oom_cache", test_oom_cache},
    {"oom_merge", test_oom_merge},
    {"oom_streamed_film", test_oom_streamed_film},
    {"plain_stream_address_limit", test_plain_stream_address_limit},
    {"plain_stream_aux_address_limit", test_plain_stream_aux_address_limit},
    {"merge_address_limit", test_merge_address_limit},
    {"wide_film_address_limit", test_wide_film_address_limit},
};
RT_TEST_MAIN(tests)
