/* End-to-end tests of split renders: -region and -tile give exactly the pixels of the
 * whole render (colour, -depth, -normals) and record where they sit; -merge assembles
 * parts in any order into the whole render's bytes and refuses every bad set of parts
 * with a message naming the file, writing nothing. */
#define _POSIX_C_SOURCE 200809L
#include "../harness.h"
#include "e2e_util.h"

#include "rt/bigmem.h"
#include "rt/image.h"
#include "rt/options.h"

/* The arguments of a course line with -input made absolute (so the test runs from any
 * folder) and -output taken out: the tests choose their own outputs. */
typedef struct Args {
    const char *v[128];
    int n;
    char input[PATH_MAX];
    E2eCourseLine cl;
} Args;

static bool course_args(const char *course, const char *id, Args *a)
{
    memset(a, 0, sizeof *a);
    if (!e2e_course_line(course, id, &a->cl))
        return false;
    for (int i = 0; i < a->cl.argc; i++) {
        const char *t = a->cl.argv[i];
        if (strcmp(t, "-output") == 0 && i + 1 < a->cl.argc) {
            i++;
            continue;
        }
        if (strcmp(t, "-input") == 0 && i + 1 < a->cl.argc) {
            e2e_join(a->input, sizeof a->input, course, a->cl.argv[++i]);
            a->v[a->n++] = "-input";
            a->v[a->n++] = a->input;
            continue;
        }
        a->v[a->n++] = t;
    }
    return true;
}

static void add(Args *a, const char *s)
{
    if (a->n < 126)
        a->v[a->n++] = s;
}

static int int_after(const Args *a, const char *flag, int k, int dflt)
{
    for (int i = 0; i + 1 + k < a->n; i++)
        if (strcmp(a->v[i], flag) == 0)
            return atoi(a->v[i + 1 + k]);
    return dflt;
}

/* Runs the binary; the run is kept in *r (the caller frees it). */
static bool run_ok(const Args *a, E2eRun *r, const char *what)
{
    const char *argv[130];
    memcpy(argv, a->v, (size_t)a->n * sizeof *argv);
    argv[a->n] = NULL;
    if (!e2e_run_bin(harness_bin(), argv, r)) {
        CHECK_MSG(false, "%s: cannot start %s", what, harness_bin());
        return false;
    }
    char why[512];
    CHECK_MSG(r->status == 0, "%s: %s", what, e2e_describe(r, why, sizeof why));
    return r->status == 0;
}

static int run_status(const char *const *args, E2eRun *r)
{
    if (!e2e_run_bin(harness_bin(), args, r))
        return -1;
    return r->status;
}

/* Reads an image and checks it; false (with a failure) when unreadable. */
static bool read_image(const char *path, Image *img)
{
    Diag d;
    diag_init(&d, NULL);
    bool ok = image_read(img, path, &d);
    CHECK_MSG(ok, "%s", d.last);
    return ok;
}

/* True when part holds exactly the bytes of full's rectangle at (x, y) (top-left). */
static bool same_as_crop(const Image *full, const Image *part, int x, int y, char *why,
                         size_t size)
{
    for (int py = 0; py < part->height; py++) {
        int fy = full->height - 1 - (y + (part->height - 1 - py));
        for (int px = 0; px < part->width; px++) {
            Vec3 a = image_get(part, px, py), b = image_get(full, x + px, fy);
            if (image_color_to_byte(a.x) != image_color_to_byte(b.x) ||
                image_color_to_byte(a.y) != image_color_to_byte(b.y) ||
                image_color_to_byte(a.z) != image_color_to_byte(b.z)) {
                snprintf(why, size, "pixel (%d, %d) of the part differs from the full image",
                         px, part->height - 1 - py);
                return false;
            }
        }
    }
    return true;
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

static const char *const OUTPUTS[3] = {"color", "depth", "normals"};

/* Adds -output/-depth/-normals writing dir/<prefix>_<kind>.<ext>. */
static void add_outputs(Args *a, char paths[3][PATH_MAX], const char *dir, const char *prefix,
                        const char *ext)
{
    for (int k = 0; k < 3; k++) {
        char name[128];
        snprintf(name, sizeof name, "%s_%s.%s", prefix, OUTPUTS[k], ext);
        e2e_join(paths[k], PATH_MAX, dir, name);
    }
    add(a, "-output");
    add(a, paths[0]);
    add(a, "-depth");
    add(a, "2");
    add(a, "25");
    add(a, paths[1]);
    add(a, "-normals");
    add(a, paths[2]);
}

/* ---- -region ------------------------------------------------------------------- */

/* Appends a NULL-terminated list of extra arguments (antialiasing options). */
static void add_all(Args *a, const char *const *extra)
{
    for (int i = 0; extra && extra[i]; i++)
        add(a, extra[i]);
}

static void check_regions_with(const char *id, const char *const *extra)
{
    const char *course = e2e_course_or_skip();
    Args base;
    CHECK_MSG(course_args(course, id, &base), "line %s not found", id);
    if (harness_failures)
        return;
    add_all(&base, extra);
    int w = int_after(&base, "-size", 0, 100), h = int_after(&base, "-size", 1, 100);
    char dir[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "region") != NULL);

    Args a = base;
    char full[3][PATH_MAX];
    add_outputs(&a, full, dir, "full", "tga");
    E2eRun r;
    bool ok = run_ok(&a, &r, id);
    e2e_run_free(&r);
    Image fimg[3];
    for (int k = 0; k < 3 && ok; k++)
        ok = read_image(full[k], &fimg[k]) || (k = 3, false);
    if (!ok) {
        e2e_rmtree(dir);
        return;
    }
    /* An odd rectangle off the 8x8 packet grid, one at the bottom-right corner, a single
     * pixel, and a full-width band. */
    int rects[4][4] = {{w / 5 + 3, h / 3 + 1, w / 2 - 1, h / 4 + 5},
                       {w - 13, h - 9, 13, 9},
                       {w / 2, h / 2, 1, 1},
                       {0, 5, w, 11}};
    for (int q = 0; q < 4; q++) {
        Args b = base;
        char rx[4][16];
        add(&b, "-region");
        for (int c = 0; c < 4; c++) {
            snprintf(rx[c], sizeof rx[c], "%d", rects[q][c]);
            add(&b, rx[c]);
        }
        char part[3][PATH_MAX], prefix[32];
        snprintf(prefix, sizeof prefix, "part%d", q);
        add_outputs(&b, part, dir, prefix, "tga");
        if (!run_ok(&b, &r, id)) {
            e2e_run_free(&r);
            continue;
        }
        e2e_run_free(&r);
        for (int k = 0; k < 3; k++) {
            Image p;
            if (!read_image(part[k], &p))
                continue;
            char why[160] = "";
            CHECK_MSG(p.width == rects[q][2] && p.height == rects[q][3], "%s %s: %dx%d part",
                      id, OUTPUTS[k], p.width, p.height);
            CHECK_MSG(p.has_region && p.region.x == rects[q][0] && p.region.y == rects[q][1] &&
                          p.region.full_width == w && p.region.full_height == h,
                      "%s %s: region record missing or wrong", id, OUTPUTS[k]);
            if (p.width == rects[q][2] && p.height == rects[q][3])
                CHECK_MSG(same_as_crop(&fimg[k], &p, rects[q][0], rects[q][1], why, sizeof why),
                          "%s %s, region %d %d %d %d: %s", id, OUTPUTS[k], rects[q][0],
                          rects[q][1], rects[q][2], rects[q][3], why);
            image_free(&p);
        }
    }
    for (int k = 0; k < 3; k++)
        image_free(&fimg[k]);
    e2e_rmtree(dir);
}

static void check_regions(const char *id) { check_regions_with(id, NULL); }

static void test_region_03d(void) { check_regions("03d"); }
static void test_region_11b(void) { check_regions("11b"); }
static void test_region_14(void) { check_regions("14"); }
static void test_region_17a(void) { check_regions("17a"); }
static void test_region_18a(void) { check_regions("18a"); }

/* ---- -tile and -merge ------------------------------------------------------------ */

/* Renders line id whole and as n tiles (in ext), merges the parts in a shuffled order
 * and compares the merged files with the whole render's, byte for byte. */
static void check_tiles_of(const char *id, const char *count, int n, const char *ext,
                           const char *const *extra)
{
    const char *course = e2e_course_or_skip();
    Args base;
    CHECK_MSG(course_args(course, id, &base), "line %s not found", id);
    if (harness_failures)
        return;
    add_all(&base, extra);
    char dir[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "tiles") != NULL);
    Args a = base;
    char full[3][PATH_MAX];
    add_outputs(&a, full, dir, "full", "tga");
    E2eRun r;
    bool ok = run_ok(&a, &r, id);
    e2e_run_free(&r);

    enum { MAX_TILES = 64 };
    static char parts[MAX_TILES][3][PATH_MAX];
    for (int k = 0; k < n && ok; k++) {
        Args b = base;
        char ks[16], ns[16], prefix[32];
        snprintf(ks, sizeof ks, "%d", k);
        snprintf(ns, sizeof ns, "%s", count);
        snprintf(prefix, sizeof prefix, "tile%02d", k);
        add(&b, "-tile");
        add(&b, ks);
        add(&b, ns);
        add_outputs(&b, parts[k], dir, prefix, ext);
        ok = run_ok(&b, &r, id);
        e2e_run_free(&r);
    }
    /* A fixed shuffle: alternately from the bottom and the top band (n-1, 0, n-2, 1...). */
    for (int kind = 0; kind < 3 && ok; kind++) {
        char merged[PATH_MAX], name[64];
        snprintf(name, sizeof name, "merged_%s.tga", OUTPUTS[kind]);
        e2e_join(merged, sizeof merged, dir, name);
        const char *args[MAX_TILES + 4];
        int m = 0;
        args[m++] = "-merge";
        args[m++] = merged;
        for (int i = 0; i < n; i++)
            args[m++] = parts[i % 2 == 0 ? n - 1 - i / 2 : i / 2][kind];
        args[m] = NULL;
        int st = run_status(args, &r);
        char why[512];
        CHECK_MSG(st == 0, "%s merge of %d %s parts: %s", id, n, OUTPUTS[kind],
                  e2e_describe(&r, why, sizeof why));
        e2e_run_free(&r);
        CHECK_MSG(same_file(merged, full[kind]), "%s: %d merged %s tiles (%s) differ from "
                  "the whole render", id, n, OUTPUTS[kind], ext);
    }
    e2e_rmtree(dir);
}

/* n bands (-tile k n). */
static void check_tiles_with(const char *id, int n, const char *ext, const char *const *extra)
{
    char count[16];
    snprintf(count, sizeof count, "%d", n);
    check_tiles_of(id, count, n, ext, extra);
}

static void check_tiles(const char *id, int n, const char *ext)
{
    check_tiles_with(id, n, ext, NULL);
}

static void test_tiles_1(void) { check_tiles("17a", 1, "tga"); }
static void test_tiles_7(void) { check_tiles("18a", 7, "tga"); }
/* 64 bands of a 300-row image are thinner than the 8-row packet bands: rows split. */
static void test_tiles_64(void) { check_tiles("17a", 64, "tga"); }
static void test_tiles_ppm(void) { check_tiles("11b", 5, "ppm"); }
/* A grid of tiles (-tile k CxR): columns on the 8-column packet grid, and (8x8 of a
 * 300x300 image) rows and columns thinner than a packet. */
static void test_tiles_grid(void) { check_tiles_of("18a", "3x2", 6, "tga", NULL); }
static void test_tiles_grid_64(void) { check_tiles_of("17a", "8x8", 64, "tga", NULL); }
static void test_tiles_png(void)
{
    if (!image_format_supported("png"))
        harness_skip("built without libpng");
    check_tiles("03d", 4, "png");
}

/* Antialiased parts: a filter wider than a pixel reaches across the part's edge, so a
 * part must render the margin its filter needs and keep only its own pixels. Each
 * sampler and filter below is checked on rectangles off the packet grid, at the image
 * corner, a single pixel and a band, and as merged tiles. */
static const char *const AA_JITTER_GAUSS[] = {"-jittered_samples", "9", "-gaussian_filter",
                                              "0.8", NULL};
static const char *const AA_UNIFORM_TENT[] = {"-uniform_samples", "4", "-tent_filter", "1.5",
                                              NULL};
static const char *const AA_ADAPTIVE_MITCHELL[] = {"-adaptive_samples", "4", "16", "0.05",
                                                   "-mitchell_filter", "2", NULL};
static const char *const AA_RANDOM_BOX[] = {"-random_samples", "5", "-box_filter", "1.3",
                                            "-seed", "7", NULL};
static void test_region_aa_17a(void) { check_regions_with("17a", AA_JITTER_GAUSS); }
static void test_region_aa_11b(void) { check_regions_with("11b", AA_UNIFORM_TENT); }
static void test_region_aa_03d(void) { check_regions_with("03d", AA_ADAPTIVE_MITCHELL); }
static void test_region_aa_14(void) { check_regions_with("14", AA_RANDOM_BOX); }
static void test_tiles_aa_18a(void) { check_tiles_with("18a", 5, "tga", AA_JITTER_GAUSS); }
static void test_tiles_aa_11b(void) { check_tiles_with("11b", 9, "tga", AA_ADAPTIVE_MITCHELL); }
/* The Gaussian's margin crosses the tiles' left and right edges too. */
static void test_tiles_grid_aa(void) { check_tiles_of("18a", "4x3", 12, "tga", AA_JITTER_GAUSS); }

/* Bands on the packet grid trace the whole render's packets: the -stats counters of
 * the tiles add up to the whole render's exactly. */
static void test_tile_stats_add_up(void)
{
    const char *course = e2e_course_or_skip();
    Args base;
    CHECK(course_args(course, "17a", &base));
    if (harness_failures)
        return;
    add(&base, "-stats");
    char dir[PATH_MAX], out[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "tstats") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    add(&base, "-output");
    add(&base, out);
    E2eRun r;
    E2eStats whole, part;
    Args a = base;
    if (!run_ok(&a, &r, "whole")) {
        e2e_run_free(&r);
        e2e_rmtree(dir);
        return;
    }
    e2e_stats_parse(r.out, &whole);
    e2e_run_free(&r);
    CHECK(whole.found);
    unsigned long long sum[4] = {0, 0, 0, 0};
    for (int k = 0; k < 5; k++) {
        Args b = base;
        char ks[16];
        snprintf(ks, sizeof ks, "%d", k);
        add(&b, "-tile");
        add(&b, ks);
        add(&b, "5");
        if (run_ok(&b, &r, "tile") && e2e_stats_parse(r.out, &part)) {
            sum[0] += part.nonshadow;
            sum[1] += part.shadow;
            sum[2] += part.intersections;
            sum[3] += part.cells;
        }
        e2e_run_free(&r);
    }
    CHECK_INT(sum[0], whole.nonshadow);
    CHECK_INT(sum[1], whole.shadow);
    CHECK_INT(sum[2], whole.intersections);
    CHECK_INT(sum[3], whole.cells);
    e2e_rmtree(dir);
}

/* ---- refused merges --------------------------------------------------------------- */

static const char SCENE[] =
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
    "Background { color 0.1 0.2 0.3 }\n"
    "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
    "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n";

static void render_part(const char *scene, const char *size_w, const char *size_h,
                        const char *const *region, const char *out)
{
    const char *args[16] = {"-input", scene, "-size", size_w, size_h, "-output", out};
    int n = 7;
    for (int i = 0; region[i]; i++)
        args[n++] = region[i];
    args[n] = NULL;
    E2eRun r;
    char why[512];
    CHECK_MSG(run_status(args, &r) == 0, "part %s: %s", out, e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
}

static void expect_refused(const char *dir, const char *const *parts, const char *names_file,
                           const char *says)
{
    char out[PATH_MAX];
    e2e_join(out, sizeof out, dir, "merged.tga");
    const char *args[16] = {"-merge", out};
    int n = 2;
    for (int i = 0; parts[i]; i++)
        args[n++] = parts[i];
    args[n] = NULL;
    E2eRun r;
    int st = run_status(args, &r);
    CHECK_MSG(st == 1, "merge exit %d, expected 1 (%s)", st, says);
    CHECK_CONTAINS(r.err, names_file);
    CHECK_CONTAINS(r.err, says);
    CHECK_MSG(!e2e_exists(out), "a refused merge wrote %s", out);
    CHECK_MSG(e2e_count_entries(dir) == 7, "a refused merge left a file behind");
    e2e_run_free(&r);
}

static void test_bad_merges(void)
{
    char dir[PATH_MAX], scene[PATH_MAX], top[PATH_MAX], bottom[PATH_MAX], mid[PATH_MAX],
        other[PATH_MAX], whole[PATH_MAX], junk[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "badmerge") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(top, sizeof top, dir, "top.tga");
    e2e_join(bottom, sizeof bottom, dir, "bottom.tga");
    e2e_join(mid, sizeof mid, dir, "mid.tga");
    e2e_join(other, sizeof other, dir, "other.tga");
    e2e_join(whole, sizeof whole, dir, "whole.tga");
    e2e_join(junk, sizeof junk, dir, "junk.tga");
    CHECK(e2e_write_file(scene, SCENE));
    CHECK(e2e_write_file(junk, "not an image"));
    render_part(scene, "40", "30", (const char *[]){"-tile", "0", "2", NULL}, top);
    render_part(scene, "40", "30", (const char *[]){"-tile", "1", "2", NULL}, bottom);
    render_part(scene, "40", "30", (const char *[]){"-region", "0", "10", "40", "10", NULL}, mid);
    render_part(scene, "40", "32", (const char *[]){"-tile", "1", "2", NULL}, other);
    render_part(scene, "40", "30", (const char *[]){NULL}, whole);
    if (harness_failures) {
        e2e_rmtree(dir);
        return;
    }
    /* 7 entries: the scene, junk and the five images. */
    expect_refused(dir, (const char *[]){top, other, NULL}, other, "40x32");
    expect_refused(dir, (const char *[]){top, mid, bottom, NULL}, mid, "overlaps");
    /* The top band holds rows 0..13 (bands are cut on whole 8-row packet blocks where
     * they can be, and 30 rows split 14 + 16): the message names the first row missing. */
    expect_refused(dir, (const char *[]){top, NULL}, "merged.tga",
                   "the 1 part does not cover the 40x30 image: no part has pixel (0, 14)");
    expect_refused(dir, (const char *[]){top, bottom, whole, NULL}, whole, "no region record");
    expect_refused(dir, (const char *[]){top, junk, NULL}, junk, "cannot read image");
    expect_refused(dir, (const char *[]){top, junk, NULL}, junk, "not a TGA image");
    char missing[PATH_MAX];
    e2e_join(missing, sizeof missing, dir, "missing.tga");
    expect_refused(dir, (const char *[]){missing, top, NULL}, missing, "cannot read image");
    /* an output in a missing folder is refused with the words a render uses, naming the
     * folder, before any part is read (the junk part would be named otherwise) */
    {
        char nodir[PATH_MAX], into[PATH_MAX];
        e2e_join(nodir, sizeof nodir, dir, "nodir");
        e2e_join(into, sizeof into, nodir, "merged.tga");
        E2eRun rr;
        CHECK_INT(run_status((const char *[]){"-merge", into, junk, top, NULL}, &rr), 1);
        CHECK_CONTAINS(rr.err, "merged.tga: error: cannot write image: folder '");
        CHECK_CONTAINS(rr.err, "nodir': No such file or directory");
        CHECK_MSG(strstr(rr.err, "junk.tga") == NULL, "the part was read first: %s", rr.err);
        CHECK(e2e_count_entries(dir) == 7);
        e2e_run_free(&rr);
    }
    /* and the good pair merges */
    char out[PATH_MAX];
    e2e_join(out, sizeof out, dir, "merged.tga");
    E2eRun r;
    CHECK_INT(run_status((const char *[]){"-merge", out, bottom, top, NULL}, &r), 0);
    e2e_run_free(&r);
    CHECK(same_file(out, whole));
    /* usage errors: too few arguments, -merge not first */
    CHECK_INT(run_status((const char *[]){"-merge", out, NULL}, &r), 2);
    e2e_run_free(&r);
    CHECK_INT(run_status((const char *[]){"-input", scene, "-merge", out, top, NULL}, &r), 2);
    CHECK_CONTAINS(r.err, "-merge must come first");
    e2e_run_free(&r);
    /* usage errors that write nothing: the output among the parts (it would be read
     * and then replaced), a part twice (the same text, or another path to the same
     * file: device and inode), render options after -merge */
    char again[PATH_MAX + 16], merged2[PATH_MAX];
    CHECK(snprintf(again, sizeof again, "%s/./top.tga", dir) < (int)sizeof again);
    e2e_join(merged2, sizeof merged2, dir, "merged2.tga");
    int before = e2e_count_entries(dir);
    const char *const *usage[] = {
        (const char *[]){"-merge", top, top, bottom, NULL},
        (const char *[]){"-merge", merged2, top, bottom, top, NULL},
        (const char *[]){"-merge", merged2, top, bottom, again, NULL},
        (const char *[]){"-merge", merged2, top, bottom, "-size", "40", "30", NULL},
        (const char *[]){"-merge", merged2, "-output", top, bottom, NULL},
    };
    const char *says[] = {"is also listed as a part", "is listed twice",
                          "is listed twice (also as", "not -size", "not -output"};
    for (size_t i = 0; i < sizeof usage / sizeof usage[0]; i++) {
        char why[512];
        CHECK_MSG(run_status(usage[i], &r) == 2, "merge usage case %zu: %s", i,
                  e2e_describe(&r, why, sizeof why));
        CHECK_CONTAINS(r.err, says[i]);
        CHECK_MSG(strchr(r.err, '\n') == r.err + strlen(r.err) - 1, "case %zu: not one line: %s",
                  i, r.err);
        e2e_run_free(&r);
    }
    CHECK_INT(e2e_count_entries(dir), before);
    CHECK(!e2e_exists(merged2));
    /* the parts were left alone: they still merge into the whole render */
    CHECK_INT(run_status((const char *[]){"-merge", merged2, bottom, top, NULL}, &r), 0);
    e2e_run_free(&r);
    CHECK(same_file(merged2, whole));
    e2e_rmtree(dir);
}

/* ---- render identities ------------------------------------------------------------ */

/* A scene whose triangle comes from an OBJ file (its bytes are part of the identity). */
static const char MESH_SCENE[] =
    "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 5 }\n"
    "Lights { numLights 1 DirectionalLight { direction 0.3 -0.5 -1 color 1 1 1 } }\n"
    "Background { color 0.1 0.2 0.3 ambientLight 0.2 0.2 0.2 }\n"
    "Materials { numMaterials 1 PhongMaterial { diffuseColor 1 0 0 } }\n"
    "Group { numObjects 2 MaterialIndex 0 Sphere { center 0.5 0.5 1 radius 0.7 }\n"
    "  TriangleMesh { obj_file tri.obj } }\n";
static const char TRI_OBJ[] = "v -2 -2 0\nv 2 -2 0\nv 0 2 0\nf 1 2 3\n";
/* The same triangle and one comment more: other bytes, the same pixels. */
static const char TRI_OBJ_COMMENTED[] = "# edited\nv -2 -2 0\nv 2 -2 0\nv 0 2 0\nf 1 2 3\n";

/* Renders band k of 2 of the 40x30 mesh scene with extra options into out. */
static void identity_part(const char *scene, int k, const char *const *extra, const char *out)
{
    const char *args[32] = {"-input", scene, "-size", "40", "30", "-output", out,
                            "-tile",  k ? "1" : "0", "2"};
    int n = 10;
    for (int i = 0; extra[i] && n < 31; i++)
        args[n++] = extra[i];
    args[n] = NULL;
    E2eRun r;
    char why[512];
    CHECK_MSG(run_status(args, &r) == 0, "part %s: %s", out, e2e_describe(&r, why, sizeof why));
    e2e_run_free(&r);
}

static void expect_merge(const char *dir, const char *a, const char *b, int status,
                         const char *says)
{
    char out[PATH_MAX];
    e2e_join(out, sizeof out, dir, "merged.tga");
    remove(out);
    E2eRun r;
    char why[512];
    CHECK_MSG(run_status((const char *[]){"-merge", out, a, b, NULL}, &r) == status,
              "merge %s %s: expected %d: %s", a, b, status, e2e_describe(&r, why, sizeof why));
    if (says)
        CHECK_CONTAINS(r.err, says);
    CHECK_MSG(e2e_exists(out) == (status == 0), "merge %s %s: output %s", a, b,
              e2e_exists(out) ? "written" : "missing");
    e2e_run_free(&r);
}

/* A part as an earlier version wrote it: the same pixels and place, no identity. */
static bool strip_identity(const char *from, const char *to)
{
    Image img;
    Diag d;
    diag_init(&d, NULL);
    if (!image_read(&img, from, &d))
        return false;
    bool ok = img.has_region && img.region.has_id;
    img.region.has_id = false;
    ok = ok && image_write(&img, to, &d);
    image_free(&img);
    return ok;
}

static void test_render_identity(void)
{
    char dir[PATH_MAX], scene[PATH_MAX], obj[PATH_MAX], whole[PATH_MAX], merged[PATH_MAX];
    char top[PATH_MAX], bottom[PATH_MAX], p[17][PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "identity") != NULL);
    e2e_join(scene, sizeof scene, dir, "scene.txt");
    e2e_join(obj, sizeof obj, dir, "tri.obj");
    e2e_join(whole, sizeof whole, dir, "whole.tga");
    e2e_join(merged, sizeof merged, dir, "merged.tga");
    e2e_join(top, sizeof top, dir, "top.tga");
    e2e_join(bottom, sizeof bottom, dir, "bottom.tga");
    for (int i = 0; i < 17; i++) {
        char name[32];
        snprintf(name, sizeof name, "p%d.%s", i, i == 3 ? "png" : i == 4 ? "ppm" : "tga");
        e2e_join(p[i], sizeof p[i], dir, name);
    }
    CHECK(e2e_write_file(scene, MESH_SCENE));
    CHECK(e2e_write_file(obj, TRI_OBJ));
    render_part(scene, "40", "30", (const char *[]){NULL}, whole);
    identity_part(scene, 0, (const char *[]){NULL}, top);
    identity_part(scene, 1, (const char *[]){NULL}, bottom);
    /* Options no pixel depends on: the parts still merge, into the whole render. */
    identity_part(scene, 1, (const char *[]){"-threads", "3", "-grid", "4", "4", "4", NULL}, p[0]);
    identity_part(scene, 1, (const char *[]){"-accel", "none", "-no_packets", "-stats", NULL},
                  p[1]);
    char cache[PATH_MAX];
    e2e_join(cache, sizeof cache, dir, "setup.cache");
    identity_part(scene, 1, (const char *[]){"-cache", cache, "-grid", "auto", NULL}, p[2]);
    if (image_format_supported("png"))
        identity_part(scene, 1, (const char *[]){"-quiet", NULL}, p[3]);
    identity_part(scene, 1, (const char *[]){"-timings", NULL}, p[4]);
    /* Options that change pixels, another image kind, another OBJ file's bytes. */
    identity_part(scene, 1, (const char *[]){"-shadows", NULL}, p[5]);
    identity_part(scene, 1, (const char *[]){"-jittered_samples", "4", NULL}, p[6]);
    identity_part(scene, 1, (const char *[]){"-jittered_samples", "4", "-seed", "1", NULL}, p[7]);
    char normals[PATH_MAX];
    e2e_join(normals, sizeof normals, dir, "normals.tga");
    identity_part(scene, 1, (const char *[]){"-normals", normals, NULL}, p[8]);
    /* Options as the renderer uses them: the default filter is the box 0.5, -weight
     * needs -bounces, -seed only moves random samples. */
    identity_part(scene, 1, (const char *[]){"-box_filter", "0.5", "-weight", "0.3", "-seed",
                                             "5", NULL}, p[12]);
    identity_part(scene, 0, (const char *[]){"-uniform_samples", "4", "-seed", "1", NULL}, p[13]);
    identity_part(scene, 1, (const char *[]){"-uniform_samples", "4", "-seed", "2", NULL}, p[14]);
    identity_part(scene, 1, (const char *[]){"-bounces", "1", "-weight", "0.3", NULL}, p[15]);
    /* one uniform sample is the default's centre sample (the same pixels) */
    identity_part(scene, 1, (const char *[]){"-uniform_samples", "1", NULL}, p[16]);
    char j0[PATH_MAX], b0[PATH_MAX];
    e2e_join(j0, sizeof j0, dir, "j0.tga");
    identity_part(scene, 0, (const char *[]){"-jittered_samples", "4", NULL}, j0);
    e2e_join(b0, sizeof b0, dir, "b0.tga");
    identity_part(scene, 0, (const char *[]){"-bounces", "1", NULL}, b0);
    if (harness_failures) {
        e2e_rmtree(dir);
        return;
    }
    CHECK(e2e_write_file(obj, TRI_OBJ_COMMENTED));
    identity_part(scene, 1, (const char *[]){NULL}, p[9]);
    /* ... twice with the cache, which then maps the mesh instead of parsing it: the
     * identity keys the file's bytes either way */
    identity_part(scene, 0, (const char *[]){"-cache", cache, NULL}, p[10]);
    identity_part(scene, 0, (const char *[]){"-cache", cache, NULL}, p[11]);
    if (harness_failures) {
        e2e_rmtree(dir);
        return;
    }
    /* p8's colour image is the plain render's; its normal image is another kind. */
    for (int i = 0; i < 9; i++) {
        if ((i == 3 && !image_format_supported("png")) || (i >= 5 && i < 8))
            continue;
        expect_merge(dir, top, p[i], 0, NULL);
        CHECK_MSG(same_file(merged, whole), "parts with %s merged into other bytes", p[i]);
    }
    for (int i = 5; i < 8; i++)
        expect_merge(dir, top, p[i], 1, "part of another render than");
    expect_merge(dir, top, p[12], 0, NULL);
    CHECK(same_file(merged, whole));
    expect_merge(dir, top, p[16], 0, NULL);
    CHECK(same_file(merged, whole));
    expect_merge(dir, p[13], p[14], 0, NULL);
    expect_merge(dir, p[13], p[6], 1, "part of another render than"); /* uniform, jittered */
    /* with -bounces, -weight counts (this scene reflects nothing, but in general it
     * decides which secondary rays are traced) */
    expect_merge(dir, b0, p[15], 1, "part of another render than");
    /* the same jittered count with another seed: other samples */
    expect_merge(dir, j0, p[6], 0, NULL);
    expect_merge(dir, j0, p[7], 1, "part of another render than");
    expect_merge(dir, top, normals, 1, "part of another render than");
    /* The edited OBJ's pixels are the same, its bytes are not: refused, and its own
     * parts merge (with and without the cache) into the same image. */
    expect_merge(dir, p[9], top, 1, "part of another render than");
    expect_merge(dir, p[10], p[9], 0, NULL);
    CHECK(same_file(merged, whole));
    expect_merge(dir, p[11], p[9], 0, NULL);
    CHECK(same_file(merged, whole));
    /* Parts without an identity (an earlier version's) merge only among themselves. */
    char old_top[PATH_MAX], old_bottom[PATH_MAX];
    e2e_join(old_top, sizeof old_top, dir, "old_top.tga");
    e2e_join(old_bottom, sizeof old_bottom, dir, "old_bottom.tga");
    CHECK(strip_identity(top, old_top));
    CHECK(strip_identity(bottom, old_bottom));
    expect_merge(dir, old_top, old_bottom, 0, NULL);
    CHECK(same_file(merged, whole));
    expect_merge(dir, old_top, bottom, 1, "has a render identity but");
    expect_merge(dir, top, old_bottom, 1, "has no render identity (written by an earlier");
    e2e_rmtree(dir);
}

static void test_region_usage_errors(void)
{
    static const char *const bad[][10] = {
        {"-size", "40", "30", "-region", "30", "0", "11", "5", NULL},
        {"-size", "40", "30", "-region", "0", "26", "40", "5", NULL},
        {"-size", "40", "30", "-region", "0", "0", "0", "5", NULL},
        {"-size", "40", "30", "-tile", "2", "2", NULL},
        {"-size", "40", "30", "-tile", "0", "31", NULL},
        {"-size", "40", "30", "-tile", "-1", "3", NULL},
        {"-size", "40", "30", "-tile", "12", "4x3", NULL},
        {"-size", "40", "30", "-tile", "0", "41x1", NULL},
        {"-size", "40", "30", "-tile", "0", "1x31", NULL},
        {"-size", "40", "30", "-tile", "0", "0x3", NULL},
        {"-size", "40", "30", "-tile", "0", "4x", NULL},
        {"-size", "40", "30", "-tile", "0", "4x3x2", NULL},
        {"-size", "40", "30", "-tile", "0", "x3", NULL},
        {"-size", "40", "30", "-tile", "0", "4x-3", NULL},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        const char *args[16] = {"-input", "scene.txt"};
        int n = 2;
        for (int k = 0; bad[i][k]; k++)
            args[n++] = bad[i][k];
        args[n] = NULL;
        E2eRun r;
        int st = run_status(args, &r);
        CHECK_MSG(st == 2, "case %zu: exit %d, expected 2", i, st);
        CHECK_CONTAINS(r.err, "raytracer: option -");
        e2e_run_free(&r);
    }
}

/* Bands cover the image top to bottom without overlap, and on the 8-row packet bands
 * (counted from the bottom) whenever there are enough of those. */
static void test_tile_rows_cover(void)
{
    for (int height = 1; height <= 70; height++) {
        for (int n = 1; n <= height; n++) {
            int next = 0;
            for (int k = 0; k < n; k++) {
                int y, h;
                options_tile_rows(k, n, height, &y, &h);
                CHECK_MSG(y == next && h >= 1, "height %d, %d bands: band %d at %d+%d, "
                          "expected to start at %d", height, n, k, y, h, next);
                if (n <= (height + 7) / 8)
                    CHECK_MSG((height - y - h) % 8 == 0, "height %d, %d bands: band %d "
                              "off the packet grid", height, n, k);
                next = y + h;
            }
            CHECK_INT(next, height);
            if (harness_failures)
                return;
        }
    }
}

/* Columns of tiles cover the image left to right without overlap, and on the 8-column
 * packet grid (counted from the left) whenever there are enough of those. */
static void test_tile_cols_cover(void)
{
    for (int width = 1; width <= 70; width++) {
        for (int n = 1; n <= width; n++) {
            int next = 0;
            for (int k = 0; k < n; k++) {
                int x, w;
                options_tile_cols(k, n, width, &x, &w);
                CHECK_MSG(x == next && w >= 1, "width %d, %d columns: column %d at %d+%d, "
                          "expected to start at %d", width, n, k, x, w, next);
                if (n <= (width + 7) / 8)
                    CHECK_MSG(x % 8 == 0, "width %d, %d columns: column %d off the packet "
                              "grid", width, n, k);
                next = x + w;
            }
            CHECK_INT(next, width);
            if (harness_failures)
                return;
        }
    }
}

/* ---- the record in each format ------------------------------------------------------ */

static void test_region_record_formats(void)
{
    Image img;
    CHECK(image_init(&img, 3, 2));
    img.has_region = true;
    img.region = (ImageRegion){5, 7, 20, 10, false, 0};
    image_set(&img, 1, 0, v3(1.0f, 0.5f, 0.25f));
    const ImageCodec *tga = image_codec_find("tga"), *ppm = image_codec_find("ppm");
    static const char *const names[3] = {"tga", "ppm", "png"};
    for (int f = 0; f < 3; f++) {
        if (!image_format_supported(names[f]))
            continue;
        const ImageCodec *codec = image_codec_find(names[f]);
        uint8_t *buf = NULL;
        size_t len = 0;
        CHECK(codec->encode(&img, &buf, &len));
        Image back;
        char err[200] = "";
        CHECK_MSG(codec->decode(buf, len, &back, err, sizeof err), "%s: %s", names[f], err);
        CHECK(back.has_region);
        CHECK_INT(back.region.x, 5);
        CHECK_INT(back.region.y, 7);
        CHECK_INT(back.region.full_width, 20);
        CHECK_INT(back.region.full_height, 10);
        CHECK_INT(image_color_to_byte(image_get(&back, 1, 0).y), 127);
        image_free(&back);
        bigmem_free(buf);
    }
    /* A damaged record is refused; a record that leaves the full image too. */
    uint8_t *buf = NULL;
    size_t len = 0;
    CHECK(tga->encode(&img, &buf, &len));
    char *rec = memchr(buf, '5', 40);
    CHECK(rec != NULL);
    if (rec) {
        *rec = 'x';
        Image back;
        char err[200] = "";
        CHECK(!tga->decode(buf, len, &back, err, sizeof err));
        CHECK_CONTAINS(err, "malformed region record");
        *rec = '9'; /* x = 9: still inside the 20-wide image */
        CHECK(tga->decode(buf, len, &back, err, sizeof err));
        image_free(&back);
    }
    bigmem_free(buf);
    img.region = (ImageRegion){18, 0, 20, 10, false, 0};
    CHECK(ppm->encode(&img, &buf, &len));
    Image back;
    char err[200] = "";
    CHECK(!ppm->decode(buf, len, &back, err, sizeof err));
    CHECK_CONTAINS(err, "does not lie inside");
    bigmem_free(buf);
    /* The render identity: 16 lowercase hex digits after " render=", or nothing. */
    img.region = (ImageRegion){5, 7, 20, 10, true, 0x0123456789abcdefull};
    for (int f = 0; f < 3; f++) {
        if (!image_format_supported(names[f]))
            continue;
        const ImageCodec *codec = image_codec_find(names[f]);
        CHECK(codec->encode(&img, &buf, &len));
        char err2[200] = "";
        CHECK_MSG(codec->decode(buf, len, &back, err2, sizeof err2), "%s: %s", names[f], err2);
        CHECK(back.has_region && back.region.has_id);
        CHECK(back.region.id == 0x0123456789abcdefull);
        CHECK_INT(back.region.x, 5);
        image_free(&back);
        bigmem_free(buf);
    }
    CHECK(tga->encode(&img, &buf, &len));
    char *hex = memchr(buf, '=', len);
    CHECK(hex != NULL && buf[0] > 16 && hex - (char *)buf == 18 + buf[0] - 17);
    if (hex) {
        static const char bad[] = {'A', 'g', ' ', '-'};
        for (size_t i = 0; i < sizeof bad; i++) {
            char keep = hex[5];
            hex[5] = bad[i];
            CHECK_MSG(!tga->decode(buf, len, &back, err, sizeof err), "id digit '%c'", bad[i]);
            CHECK_CONTAINS(err, "malformed region record");
            hex[5] = keep;
        }
        hex[-1] = 'x'; /* " rendex=" */
        CHECK(!tga->decode(buf, len, &back, err, sizeof err));
        hex[-1] = 'r';
        CHECK(tga->decode(buf, len, &back, err, sizeof err));
        image_free(&back);
    }
    bigmem_free(buf);
    /* Whole images carry no record. */
    img.has_region = false;
    CHECK(tga->encode(&img, &buf, &len));
    CHECK_INT(buf[0], 0);
    CHECK_INT(len, 18 + 3 * 2 * 3);
    bigmem_free(buf);
    image_free(&img);
}

static const TestCase tests[] = {
    {"region_record_formats", test_region_record_formats},
    {"region_usage_errors", test_region_usage_errors},
    {"tile_rows_cover", test_tile_rows_cover},
    {"tile_cols_cover", test_tile_cols_cover},
    {"region_03d", test_region_03d},
    {"region_11b", test_region_11b},
    {"region_14", test_region_14},
    {"region_17a", test_region_17a},
    {"region_18a", test_region_18a},
    {"tiles_1", test_tiles_1},
    {"tiles_7", test_tiles_7},
    {"tiles_64", test_tiles_64},
    {"tiles_ppm", test_tiles_ppm},
    {"tiles_grid", test_tiles_grid},
    {"tiles_grid_64", test_tiles_grid_64},
    {"tiles_png", test_tiles_png},
    {"region_aa_17a", test_region_aa_17a},
    {"region_aa_11b", test_region_aa_11b},
    {"region_aa_03d", test_region_aa_03d},
    {"region_aa_14", test_region_aa_14},
    {"tiles_aa_18a", test_tiles_aa_18a},
    {"tiles_aa_11b", test_tiles_aa_11b},
    {"tiles_grid_aa", test_tiles_grid_aa},
    {"tile_stats_add_up", test_tile_stats_add_up},
    {"bad_merges", test_bad_merges},
    {"render_identity", test_render_identity},
};
RT_TEST_MAIN(tests)
