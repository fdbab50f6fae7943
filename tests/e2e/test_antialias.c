/* Acceptance of antialiasing (A7): every line of the course's a7/commands.txt rendered
 * by the binary and compared with the course's official image. Deterministic lines
 * (plain renders, uniform sampling, filter pictures, uniform sample pictures) must
 * match pixel for pixel within 8/255; random and jittered lines cannot (the course's
 * random numbers), so their filtered images must be statistically close (mean absolute
 * difference within a bound, and README.txt's table of section 9 must show that
 * difference) and identical where the picture is smooth, and their sample pictures
 * must show the same number and layout of dots. Plus the properties:
 * default == one centred sample + box 0.5 == today's bytes, constant scenes stay
 * constant under every sampler and filter, 1 and N threads and grid or not give the
 * same bytes, the seed, -stats, and the usage errors. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>

#include "../harness.h"
#include "e2e_util.h"

#include "rt/image.h"
#include "rt/image_compare.h"

enum { THRESHOLD = 8 };

static const char *a7_dir(char *buf, size_t size)
{
    const char *course = e2e_course_or_skip();
    char rel[PATH_MAX];
    e2e_join(rel, sizeof rel, course, "a7");
    if (!e2e_exists(rel))
        harness_skip("course folder has no a7/ (antialiasing data)");
    CHECK(e2e_abspath(rel, buf, size));
    return buf;
}

/* Runs a course line with -input made absolute and every file argument (-output,
 * -render_samples, -render_filter) sent into dir; extra arguments appended. The output
 * file names are returned in names (up to 3). */
static bool run_line(const char *a7, const char *id, const char *dir, const char *const *extra,
                     char names[3][64], int *nnames, E2eRun *run)
{
    E2eCourseLine cl;
    CHECK_MSG(e2e_course_line(a7, id, &cl), "line %s not in a7/commands.txt", id);
    if (harness_failures)
        return false;
    static char paths[8][PATH_MAX];
    const char *args[96];
    int n = 0, np = 0;
    *nnames = 0;
    for (int i = 0; i < cl.argc && n < 80; i++) {
        const char *a = cl.argv[i];
        args[n++] = a;
        if (i + 1 >= cl.argc)
            continue;
        if (strcmp(a, "-input") == 0) {
            args[n++] = e2e_join(paths[np++], PATH_MAX, a7, cl.argv[++i]);
        } else if (strcmp(a, "-output") == 0 || strcmp(a, "-render_samples") == 0 ||
                   strcmp(a, "-render_filter") == 0) {
            snprintf(names[*nnames], 64, "%s", cl.argv[++i]);
            args[n++] = e2e_join(paths[np++], PATH_MAX, dir, names[(*nnames)++]);
        }
    }
    for (int i = 0; extra && extra[i] && n < 95; i++)
        args[n++] = extra[i];
    args[n] = NULL;
    CHECK(e2e_run_bin(harness_bin(), args, run));
    char why[512];
    CHECK_MSG(run->status == 0, "%s: %s", id, e2e_describe(run, why, sizeof why));
    return run->status == 0;
}

static bool load(const char *dir, const char *name, Image *img)
{
    char path[PATH_MAX];
    Diag d;
    diag_init(&d, NULL);
    bool ok = image_read(img, e2e_join(path, sizeof path, dir, name), &d);
    CHECK_MSG(ok, "%s", d.last);
    return ok;
}

/* ---- deterministic lines ---------------------------------------------------------- */

/* min_pct: share of pixels within 8/255 of the official image: 99.5 (100 for the filter
 * pictures, which hold no rendering). The grazing floor rows of 02d and 03a, where a
 * checker or the noise changes with the last bit of a ray's direction, match because
 * the camera rounds like the course's (docs/camera.md). */
typedef struct DetLine {
    const char *id;
    double min_pct;
} DetLine;

static void check_det(const DetLine *lines, int count)
{
    char a7[PATH_MAX], dir[PATH_MAX];
    a7_dir(a7, sizeof a7);
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7det") != NULL);
    for (int k = 0; k < count; k++) {
        char names[3][64];
        int nn = 0;
        E2eRun run;
        if (!run_line(a7, lines[k].id, dir, NULL, names, &nn, &run)) {
            e2e_run_free(&run);
            continue;
        }
        e2e_run_free(&run);
        for (int f = 0; f < nn; f++) {
            char off[PATH_MAX];
            Image mine, ref;
            if (!load(dir, names[f], &mine))
                continue;
            if (!load(e2e_join(off, sizeof off, a7, "official"), names[f], &ref)) {
                image_free(&mine);
                continue;
            }
            ImageDiff d = image_compare(&mine, &ref, THRESHOLD);
            CHECK_MSG(d.same_size, "%s: size %dx%d, official %dx%d", names[f], mine.width,
                      mine.height, ref.width, ref.height);
            if (d.same_size) {
                printf("\n    %-7s %-26s identical %7.3f%%, within 8/255 %7.3f%%, mad %.4f",
                       lines[k].id, names[f], 100.0 * (double)d.identical / (double)d.pixels,
                       d.pct_within_t, d.mean_abs);
                CHECK_MSG(d.pct_within_t >= lines[k].min_pct,
                          "%s: %.3f%% of pixels within 8/255 of the official image, need %.1f%%",
                          names[f], d.pct_within_t, lines[k].min_pct);
            }
            image_free(&mine);
            image_free(&ref);
        }
    }
    e2e_rmtree(dir);
}

static void test_plain_renders(void)
{
    static const DetLine lines[] = {{"01", 99.5}, {"01lr", 99.5}, {"02", 99.5},
                                    {"03a", 99.5}, {"04a", 99.5}, {"05a", 99.5},
                                    {"06a", 99.5}};
    check_det(lines, TEST_LIST_COUNT(lines));
}

static void test_filter_pictures(void)
{
    static const DetLine lines[] = {
        {"01f_a", 100}, {"01f_b", 100}, {"01f_c", 100}, {"01f_d", 100}, {"01f_e", 100},
        {"01f_f", 100}, {"01f_g", 100}, {"01f_h", 100}, {"01f_i", 100}, {"01lr_f_a", 100},
        {"01lr_f_b", 100}, {"01lr_f_c", 100}, {"02f_a", 100}, {"02f_b", 100}, {"02f_c", 100}};
    check_det(lines, TEST_LIST_COUNT(lines));
}

static void test_uniform_lines(void)
{
    static const DetLine lines[] = {{"01s_b", 99.5},  {"01s_e", 99.5},  {"01s_h", 99.5},
                                    {"01lr_s_b", 99.5}, {"02s_b", 99.5}, {"01lr_d", 99.5},
                                    {"01lr_e", 99.5}, {"01lr_f", 99.5}, {"02d", 99.5},
                                    {"02e", 99.5},    {"02f", 99.5}};
    check_det(lines, TEST_LIST_COUNT(lines));
}

/* ---- random and jittered lines ------------------------------------------------------ */

/* mad_ref: the mean absolute difference (1/255 units) a faithful seeded render shows
 * against the official image (reference oracle, seed 1); two seeds differ from each
 * other by as much. Bound: 1.5 x that + 0.5, which still rejects a render without
 * supersampling (e.g. 02a: 35 without, bound 15.95). */
typedef struct RandLine {
    const char *id;
    double mad_ref;
    int radius;        /* filter support R (smooth-area test window) */
} RandLine;

/* README.txt's table of section 9 ("line  sampler, filter  ours  a faithful seeded
 * render") gives, for some of these lines, the mean difference this test measures
 * ("ours") and the oracle's (mad_ref). A row names one line ("02h") or several of one
 * scene ("03b/c/d": 03b, 03c, 03d), and its two number columns hold as many values
 * separated by " / ". Columns are separated by two or more blanks. Finds id's two
 * values; false when no row names it. */
static bool readme_table_values(const char *readme, const char *id, double *ours,
                                double *oracle)
{
    const char *head = strstr(readme, "\n  line      sampler, filter");
    if (!head)
        return false;
    for (const char *line = strchr(head + 1, '\n'); line && line[1] == ' ';
         line = strchr(line + 1, '\n')) {
        const char *p = line + 1;
        while (*p == ' ')
            p++;
        char col[4][96];
        int ncol = 0;
        while (ncol < 4 && *p && *p != '\n') {
            size_t n = 0;
            /* a column ends at two blanks or the line's end */
            while (p[n] && p[n] != '\n' && !(p[n] == ' ' && p[n + 1] == ' '))
                n++;
            snprintf(col[ncol++], sizeof col[0], "%.*s", (int)n, p);
            p += n;
            while (*p == ' ')
                p++;
        }
        if (ncol < 4)
            continue;
        /* the row's ids: the first whole, then each "/x" replaces its last letter */
        char key[96];
        snprintf(key, sizeof key, "%s", col[0]);
        size_t base = strcspn(key, "/");
        int which = -1, k = 0;
        for (const char *q = key; which < 0 && *q; k++) {
            size_t n = strcspn(q, "/");
            char name[192];
            if (k == 0)
                snprintf(name, sizeof name, "%.*s", (int)n, q);
            else
                snprintf(name, sizeof name, "%.*s%.*s", (int)(base - n), key, (int)n, q);
            if (!strcmp(name, id))
                which = k;
            q += n + (q[n] == '/');
        }
        if (which < 0)
            continue;
        const char *a = col[2], *b = col[3];
        for (int s = 0; s < which && a && b; s++) {
            a = strchr(a, '/');
            b = strchr(b, '/');
            a = a ? a + 1 : NULL;
            b = b ? b + 1 : NULL;
        }
        if (!a || !b)
            return false;
        *ours = strtod(a, NULL);
        *oracle = strtod(b, NULL);
        return true;
    }
    return false;
}

/* The table must show what this test measures, to its two decimals (a value on the
 * rounding boundary may show either neighbour). */
static void check_readme_table(const RandLine *l, double mad)
{
    char path[PATH_MAX];
    e2e_join(path, sizeof path, harness_root(), "README.txt");
    char *readme = e2e_read_file(path, NULL);
    CHECK_MSG(readme != NULL, "cannot read %s", path);
    if (!readme)
        return;
    CHECK_MSG(strstr(readme, "\n  line      sampler, filter") != NULL,
              "README.txt has no table of the random and jittered lines' differences");
    double ours = 0, oracle = 0;
    if (readme_table_values(readme, l->id, &ours, &oracle)) {
        CHECK_MSG(fabs(ours - mad) <= 0.005 + 1e-9,
                  "README.txt's table says %s's mean difference is %.2f, this render's is "
                  "%.4f (write %.2f)", l->id, ours, mad, mad);
        CHECK_MSG(fabs(oracle - l->mad_ref) <= 0.005 + 1e-9,
                  "README.txt's table says %s's oracle is %.2f, this test's is %.2f", l->id,
                  oracle, l->mad_ref);
    }
    free(readme);
}

/* Smooth pixels: where the unantialiased official render is constant over the
 * (2R+5) x (2R+5) window (one pixel beyond every support pixel's neighbours), the
 * samples of the support all see the same flat surface, so the filtered pixel must
 * equal the official one: we demand 2/255 (shading varies slightly between samples
 * on curved surfaces), and allow 0.5% exceptions (a checkerboard finer than a pixel
 * can look constant at the pixel centres by coincidence: moire, 02a). */
static void check_random_line(const char *a7, const char *dir, const RandLine *l,
                              const char *plain_name)
{
    char names[3][64];
    int nn = 0;
    E2eRun run;
    bool ok = run_line(a7, l->id, dir, NULL, names, &nn, &run);
    e2e_run_free(&run);
    if (!ok)
        return;
    char off[PATH_MAX];
    e2e_join(off, sizeof off, a7, "official");
    Image mine, ref, plain;
    if (!load(dir, names[0], &mine))
        return;
    if (!load(off, names[0], &ref) || !load(off, plain_name, &plain)) {
        image_free(&mine);
        return;
    }
    ImageDiff d = image_compare(&mine, &ref, THRESHOLD);
    double bound = 1.5 * l->mad_ref + 0.5;
    long smooth = 0, smooth_bad = 0;
    int W = mine.width, H = mine.height, w = l->radius + 2;
    for (int y = 0; y < H && d.same_size; y++)
        for (int x = 0; x < W; x++) {
            bool flat = true;
            Vec3 c = image_get(&plain, x, y);
            for (int dy = -w; dy <= w && flat; dy++)
                for (int dx = -w; dx <= w && flat; dx++) {
                    int xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= W || yy >= H)
                        continue;
                    Vec3 o = image_get(&plain, xx, yy);
                    flat = image_color_to_byte(o.x) == image_color_to_byte(c.x) &&
                           image_color_to_byte(o.y) == image_color_to_byte(c.y) &&
                           image_color_to_byte(o.z) == image_color_to_byte(c.z);
                }
            if (!flat)
                continue;
            smooth++;
            Vec3 a = image_get(&mine, x, y), b = image_get(&ref, x, y);
            int dm = abs(image_color_to_byte(a.x) - image_color_to_byte(b.x));
            int dg = abs(image_color_to_byte(a.y) - image_color_to_byte(b.y));
            int db = abs(image_color_to_byte(a.z) - image_color_to_byte(b.z));
            if (dm > 2 || dg > 2 || db > 2)
                smooth_bad++;
        }
    printf("\n    %-7s %-26s mad %6.3f (bound %5.2f, oracle %5.2f); smooth pixels %5.1f%%, "
           "of them %ld off by > 2/255", l->id, names[0], d.mean_abs, bound, l->mad_ref,
           100.0 * (double)smooth / (double)(W * H), smooth_bad);
    CHECK_MSG(d.same_size, "%s: wrong size", names[0]);
    if (d.same_size)
        check_readme_table(l, d.mean_abs);
    CHECK_MSG(d.mean_abs <= bound, "%s: mean difference %.3f > %.2f", names[0], d.mean_abs,
              bound);
    /* A handful of "smooth" pixels may still hold a thin feature between the centres. */
    CHECK_MSG(smooth_bad <= smooth / 200, "%s: %ld of %ld smooth pixels differ by > 2/255",
              names[0], smooth_bad, smooth);
    image_free(&mine);
    image_free(&ref);
    image_free(&plain);
}

static void check_random(const RandLine *lines, int count, const char *plain_name)
{
    char a7[PATH_MAX], dir[PATH_MAX];
    a7_dir(a7, sizeof a7);
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7rnd") != NULL);
    for (int k = 0; k < count; k++)
        check_random_line(a7, dir, &lines[k], plain_name);
    e2e_rmtree(dir);
}

static void test_random_01_low_res(void)
{
    static const RandLine lines[] = {{"01lr_a", 8.3, 0}, {"01lr_b", 4.8, 1},
                                     {"01lr_c", 3.3, 2}, {"01lr_g", 4.6, 0},
                                     {"01lr_h", 3.7, 1}, {"01lr_i", 2.6, 2}};
    check_random(lines, TEST_LIST_COUNT(lines), "output7_01_low_res.tga");
}

static void test_random_02(void)
{
    static const RandLine lines[] = {{"02a", 10.3, 0}, {"02b", 5.5, 1}, {"02c", 5.7, 1},
                                     {"02g", 7.0, 0},  {"02h", 3.7, 1}, {"02i", 3.9, 1}};
    check_random(lines, TEST_LIST_COUNT(lines), "output7_02.tga");
}

static void test_random_03_04(void)
{
    static const RandLine a[] = {{"03b", 3.80, 1}, {"03c", 2.27, 1}, {"03d", 0.91, 1}};
    check_random(a, TEST_LIST_COUNT(a), "output7_03a.tga");
    static const RandLine b[] = {{"04b", 1.56, 1}};
    check_random(b, TEST_LIST_COUNT(b), "output7_04a.tga");
}

static void test_random_05_06(void)
{
    static const RandLine a[] = {{"05b", 2.47, 1}, {"05c", 0.98, 1}};
    check_random(a, TEST_LIST_COUNT(a), "output7_05a.tga");
    static const RandLine b[] = {{"06b", 0.32, 1}};
    check_random(b, TEST_LIST_COUNT(b), "output7_06a.tga");
}

/* ---- random and jittered sample pictures -------------------------------------------- */

/* Dots of a samples picture: pixels whose colour is not their block's background
 * (grey 51 for even i + j, black for odd). Counts per block and, for a k x k grid,
 * the largest number of dots in one sub-cell. */
typedef struct Dots {
    long total;
    int max_per_cell;
    long blocks_all_centred;   /* blocks whose dots all sit on the uniform cell centres */
} Dots;

static Dots count_dots(const Image *img, int zoom, int k)
{
    Dots d = {0, 0, 0};
    int W = img->width / zoom, H = img->height / zoom;
    for (int j = 0; j < H; j++)
        for (int i = 0; i < W; i++) {
            int bg = ((i + j) & 1) == 0 ? 51 : 0;
            int cells[36 * 36];
            memset(cells, 0, sizeof cells);
            int dots = 0, centred = 0;
            for (int y = 0; y < zoom; y++)
                for (int x = 0; x < zoom; x++) {
                    Vec3 c = image_get(img, i * zoom + x, j * zoom + y);
                    if (image_color_to_byte(c.x) == bg && image_color_to_byte(c.y) == bg &&
                        image_color_to_byte(c.z) == bg)
                        continue;
                    dots++;
                    int cx = x * k / zoom, cy = y * k / zoom;
                    if (k > 0 && k <= 36 && ++cells[cy * k + cx] > d.max_per_cell)
                        d.max_per_cell = cells[cy * k + cx];
                    /* the uniform position of this cell, zoomed; none for the random
                     * lines (k = 0), where the division would give an infinity, and
                     * converting that to int is undefined (clang's UBSan stops there) */
                    if (k <= 0)
                        continue;
                    int ux = (int)floorf((((float)cx + 0.5f) / (float)k) * (float)zoom);
                    int uy = (int)floorf((((float)cy + 0.5f) / (float)k) * (float)zoom);
                    if (x == ux && y == uy)
                        centred++;
                }
            d.total += dots;
            if (dots > 0 && centred == dots)
                d.blocks_all_centred++;
        }
    return d;
}

typedef struct SampleLine {
    const char *id;
    int zoom, k;       /* k: jittered grid side, 0 for random */
} SampleLine;

static void test_sample_pictures(void)
{
    static const SampleLine lines[] = {{"01s_a", 20, 0},    {"01s_c", 20, 2},
                                       {"01s_d", 20, 0},    {"01s_f", 20, 3},
                                       {"01s_g", 20, 0},    {"01s_i", 20, 6},
                                       {"01lr_s_a", 15, 0}, {"01lr_s_c", 15, 3},
                                       {"02s_a", 20, 0},    {"02s_c", 20, 4}};
    char a7[PATH_MAX], dir[PATH_MAX], off[PATH_MAX];
    a7_dir(a7, sizeof a7);
    e2e_join(off, sizeof off, a7, "official");
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7smp") != NULL);
    for (int n = 0; n < TEST_LIST_COUNT(lines); n++) {
        const SampleLine *l = &lines[n];
        char names[3][64];
        int nn = 0;
        E2eRun run;
        bool ok = run_line(a7, l->id, dir, NULL, names, &nn, &run);
        e2e_run_free(&run);
        Image mine, ref;
        if (!ok || !load(dir, names[0], &mine))
            continue;
        if (!load(off, names[0], &ref)) {
            image_free(&mine);
            continue;
        }
        CHECK(mine.width == ref.width && mine.height == ref.height);
        Dots a = count_dots(&mine, l->zoom, l->k), b = count_dots(&ref, l->zoom, l->k);
        printf("\n    %-8s dots %5ld (official %5ld), most per jitter cell %d (official %d)",
               l->id, a.total, b.total, a.max_per_cell, b.max_per_cell);
        /* Same count up to collisions and dots hidden on their background. */
        CHECK_MSG(labs(a.total - b.total) <= b.total / 20 + 2, "%s: %ld dots, official %ld",
                  l->id, a.total, b.total);
        if (l->k > 0) {
            /* Cells are whole zoomed pixels only when k divides the zoom. */
            if (l->zoom % l->k == 0)
                CHECK_MSG(a.max_per_cell <= 1, "%s: %d dots in one jitter cell", l->id,
                          a.max_per_cell);
            CHECK_MSG(a.blocks_all_centred == 0 || a.blocks_all_centred < (a.total / 50),
                      "%s: %ld blocks with every dot on the uniform centres", l->id,
                      a.blocks_all_centred);
        }
        image_free(&mine);
        image_free(&ref);
    }
    e2e_rmtree(dir);
}

/* ---- properties through the binary ------------------------------------------------- */

static bool render_args(const char *const *args, const char *out, E2eRun *run)
{
    const char *all[64];
    int n = 0;
    for (int i = 0; args[i] && n < 60; i++)
        all[n++] = args[i];
    all[n] = NULL;
    CHECK(e2e_run_bin(harness_bin(), all, run));
    char why[512];
    CHECK_MSG(run->status == 0, "%s", e2e_describe(run, why, sizeof why));
    CHECK_MSG(!out || e2e_exists(out), "no image at %s", out);
    return run->status == 0;
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

/* No option, one centred sample, a box of 0.5, both: the same bytes (the A6 image),
 * for the colour, depth and normal images, with a grid and shadows. */
static void test_default_is_a6(void)
{
    char a7[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX];
    a7_dir(a7, sizeof a7);
    e2e_join(scene, sizeof scene, a7, "scene7_03_marble_vase.txt");
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7def") != NULL);
    static const char *const variants[][5] = {
        {NULL}, {"-uniform_samples", "1", NULL}, {"-box_filter", "0.5", NULL},
        {"-uniform_samples", "1", "-box_filter", "0.5", NULL}};
    char first[3][PATH_MAX];
    for (int v = 0; v < 4; v++) {
        char out[3][PATH_MAX], name[32];
        const char *files[3] = {"c", "d", "n"};
        for (int f = 0; f < 3; f++) {
            snprintf(name, sizeof name, "%s%d.tga", files[f], v);
            e2e_join(out[f], PATH_MAX, dir, name);
        }
        const char *args[32] = {"-input", scene, "-size", "90", "70", "-grid", "15", "30",
                                "15", "-shadows", "-output", out[0], "-depth", "8", "14",
                                out[1], "-normals", out[2]};
        int n = 18;
        for (int k = 0; variants[v][k]; k++)
            args[n++] = variants[v][k];
        args[n] = NULL;
        E2eRun run;
        render_args(args, out[0], &run);
        e2e_run_free(&run);
        for (int f = 0; f < 3; f++) {
            if (v == 0)
                memcpy(first[f], out[f], PATH_MAX);
            else
                CHECK_MSG(same_file(first[f], out[f]), "variant %d: %s differs from the "
                          "default render", v, out[f]);
        }
    }
    e2e_rmtree(dir);
}

/* A scene of one colour everywhere (the sphere's flat colour is the background's):
 * every sampler and filter must give that colour (the filter is normalised by the
 * weights it used, also at the borders and with Mitchell's negative lobes). rgb is the
 * colour as the scene gives it, want its bytes. The weighted sum over the sum of the
 * weights may come out one float step below the colour, which the truncating writer
 * turns into one byte less where the colour is a whole byte exactly (0.2 = 51/255):
 * with one_below such pixels are allowed (and counted), never any other byte. */
static void constant_scene_check(const char *rgb, const int want[3], bool one_below)
{
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX], text[512];
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7const") != NULL);
    e2e_join(scene, sizeof scene, dir, "flat.txt");
    snprintf(text, sizeof text,
             "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 size 3 }\n"
             "Background { color %s ambientLight 1 1 1 }\n"
             "Materials { numMaterials 1 PhongMaterial { diffuseColor %s } }\n"
             "Group { numObjects 1 MaterialIndex 0 Sphere { center 0 0 0 radius 1 } }\n",
             rgb, rgb);
    CHECK(e2e_write_file(scene, text));
    e2e_join(out, sizeof out, dir, "o.tga");
    static const char *const samplers[][4] = {
        {NULL}, {"-uniform_samples", "9"}, {"-jittered_samples", "16"},
        {"-random_samples", "5"}, {"-nrooks_samples", "7"}, {"-poisson_samples", "6"},
        {"-adaptive_samples", "4", "16", "0.01"}};
    static const char *const filters[][2] = {{NULL}, {"-box_filter", "0.5"},
                                             {"-box_filter", "2.3"}, {"-tent_filter", "1.5"},
                                             {"-gaussian_filter", "1.7"},
                                             {"-mitchell_filter", "2"}};
    long below = 0, pixels = 0;
    for (int s = 0; s < TEST_LIST_COUNT(samplers); s++)
        for (int f = 0; f < TEST_LIST_COUNT(filters); f++) {
            const char *args[32] = {"-input", scene, "-size", "23", "17", "-output", out,
                                    "-threads", "2"};
            int n = 9;
            for (int k = 0; k < 4 && samplers[s][k]; k++)
                args[n++] = samplers[s][k];
            for (int k = 0; k < 2 && filters[f][k]; k++)
                args[n++] = filters[f][k];
            args[n] = NULL;
            E2eRun run;
            bool ok = render_args(args, out, &run);
            e2e_run_free(&run);
            Image img;
            if (!ok || !load(dir, "o.tga", &img))
                continue;
            long off = 0;
            for (int y = 0; y < img.height; y++)
                for (int x = 0; x < img.width; x++) {
                    Vec3 c = image_get(&img, x, y);
                    const int got[3] = {image_color_to_byte(c.x), image_color_to_byte(c.y),
                                        image_color_to_byte(c.z)};
                    bool exact = true, near = true;
                    for (int a = 0; a < 3; a++) {
                        exact &= got[a] == want[a];
                        near &= got[a] == want[a] || (one_below && got[a] == want[a] - 1);
                    }
                    off += !near;
                    below += near && !exact;
                    pixels++;
                }
            CHECK_MSG(off == 0, "colour %s, %s %s %s: %ld pixels not (%d, %d, %d)%s", rgb,
                      samplers[s][0] ? samplers[s][0] : "(default)",
                      filters[f][0] ? filters[f][0] : "(default)",
                      filters[f][0] ? filters[f][1] : "", off, want[0], want[1], want[2],
                      one_below ? " or one below" : "");
            image_free(&img);
        }
    if (one_below)
        printf("\n    colour %s: %ld of %ld pixels one byte below (float rounding, truncated) ",
               rgb, below, pixels);
    e2e_rmtree(dir);
}

static void test_constant_scene(void)
{
    /* 0.402 * 255 = 102.51: far from a byte boundary, so the rounding of the normalised
     * sum cannot move the byte: exactly the colour everywhere. */
    const int mid[3] = {102, 153, 51};
    constant_scene_check("0.402 0.602 0.202", mid, false);
    /* Whole bytes (README section 9): the colour or one below, nothing else. */
    const int whole[3] = {102, 51, 204};
    constant_scene_check("0.4 0.2 0.8", whole, true);
}

/* Mitchell's negative lobes with one or two samples per pixel (README section 9): a
 * checkerboard of greys 0.25 and 0.75 in squares of 3 pixels, radius 1. A pixel whose
 * few samples put much of the weight into the negative lobes had its colour blown up
 * or turned over (on 0816af8: 618 of 6912 channels at 1 sample, 306 at 2, beyond
 * 35..219, most at 0 or 255). Now such a pixel takes the positive lobe's average, and
 * a trusted one lies at most 21% of the samples' range (0.5) beyond them: every byte
 * in 35..219 (0.143..0.857, one byte of margin). The normals (all 0 0 1) go through
 * the fallback's general loop and stay blue. */
static void test_mitchell_few_samples(void)
{
    char dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX], nor[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7lobes") != NULL);
    e2e_join(scene, sizeof scene, dir, "checker.txt");
    CHECK(e2e_write_file(scene,
                         "OrthographicCamera { center 0 0 5 direction 0 0 -1 up 0 1 0 size 8 }\n"
                         "Lights { numLights 0 }\n"
                         "Background { color 0 0 0 ambientLight 1 1 1 }\n"
                         "Materials { numMaterials 3\n"
                         "  PhongMaterial { diffuseColor 0.25 0.25 0.25 }\n"
                         "  PhongMaterial { diffuseColor 0.75 0.75 0.75 }\n"
                         "  Checkerboard { Transform { UniformScale 2 } materialIndex 0 "
                         "materialIndex 1 } }\n"
                         "Group { numObjects 1 MaterialIndex 2 Plane { normal 0 0 1 offset -0.5 } }\n"));
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(nor, sizeof nor, dir, "n.tga");
    for (int n = 1; n <= 2; n++) {
        char count[16]; /* room for any int: gcc -O1 (make asan) cannot bound n */
        snprintf(count, sizeof count, "%d", n);
        const char *args[] = {"-input", scene, "-size", "48", "48", "-output", out,
                              "-random_samples", count, "-mitchell_filter", "1", "-normals",
                              nor, NULL};
        E2eRun run;
        bool ok = render_args(args, out, &run);
        e2e_run_free(&run);
        Image img, nimg;
        if (!ok || !load(dir, "o.tga", &img))
            continue;
        long beyond = 0, saturated = 0;
        for (int y = 0; y < img.height; y++)
            for (int x = 0; x < img.width; x++) {
                Vec3 c = image_get(&img, x, y);
                const int b[3] = {image_color_to_byte(c.x), image_color_to_byte(c.y),
                                  image_color_to_byte(c.z)};
                for (int k = 0; k < 3; k++) {
                    beyond += b[k] < 35 || b[k] > 219;
                    saturated += b[k] == 0 || b[k] == 255;
                }
            }
        CHECK_MSG(beyond == 0, "-random_samples %d -mitchell_filter 1: %ld channels beyond "
                  "35..219 (%ld at 0 or 255)", n, beyond, saturated);
        image_free(&img);
        if (!load(dir, "n.tga", &nimg))
            continue;
        long off = 0;
        for (int y = 0; y < nimg.height; y++)
            for (int x = 0; x < nimg.width; x++) {
                Vec3 c = image_get(&nimg, x, y);
                off += image_color_to_byte(c.x) != 0 || image_color_to_byte(c.y) != 0 ||
                       image_color_to_byte(c.z) != 255;
            }
        CHECK_MSG(off == 0, "-random_samples %d: %ld normal pixels not blue", n, off);
        image_free(&nimg);
    }
    e2e_rmtree(dir);
}

/* The same bytes and counters for 1 and 2 threads and with or without the grid; the
 * same bytes twice; another seed another image; -stats counts every sample's ray. */
static void test_deterministic(void)
{
    char a7[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX];
    a7_dir(a7, sizeof a7);
    e2e_join(scene, sizeof scene, a7, "scene7_03_marble_vase.txt");
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7thr") != NULL);
    char out[6][PATH_MAX];
    static const char *const extra[6][6] = {
        {"-threads", "1", "-grid", "15", "30", "15"},
        {"-threads", "2", "-grid", "15", "30", "15"},
        {"-threads", "2", NULL},
        {"-threads", "2", "-grid", "15", "30", "15"},
        {"-threads", "2", "-seed", "7", NULL},
        {"-threads", "2", "-no_packets", "-grid", "15", "30"}};
    unsigned long long rays[6] = {0};
    for (int v = 0; v < 6; v++) {
        char name[32];
        snprintf(name, sizeof name, "o%d.tga", v);
        e2e_join(out[v], PATH_MAX, dir, name);
        const char *args[40] = {"-input", scene, "-size", "48", "40", "-shadows", "-bounces",
                                "1", "-jittered_samples", "9", "-gaussian_filter", "0.7",
                                "-output", out[v], "-stats"};
        int n = 15;
        for (int k = 0; k < 6 && extra[v][k]; k++)
            args[n++] = extra[v][k];
        if (v == 5)
            args[n++] = "15";
        args[n] = NULL;
        E2eRun run;
        render_args(args, out[v], &run);
        E2eStats st;
        if (e2e_stats_parse(run.out, &st))
            rays[v] = st.nonshadow;
        e2e_run_free(&run);
    }
    CHECK_MSG(same_file(out[0], out[1]), "1 and 2 threads differ");
    CHECK_MSG(same_file(out[1], out[2]), "with and without -grid differ");
    CHECK_MSG(same_file(out[1], out[3]), "two runs of the same command differ");
    CHECK_MSG(!same_file(out[1], out[4]), "-seed 7 gives the default seed's image");
    CHECK_MSG(same_file(out[1], out[5]), "-no_packets differs from packets");
    CHECK_MSG(rays[0] == rays[1] && rays[1] == rays[2], "non-shadow rays %llu %llu %llu",
              rays[0], rays[1], rays[2]);
    /* every sample's primary ray, plus the reflections of one bounce */
    CHECK_MSG(rays[1] >= 48ULL * 40 * 9, "non-shadow rays %llu < 48*40*9", rays[1]);
    e2e_rmtree(dir);
}

/* Mean difference between horizontally neighbouring pixels (first channel, in bytes)
 * over rows y0..y1 and the columns inside [xa, xb) (inside) or outside it. */
static double neighbour_variation(const Image *img, int y0, int y1, int xa, int xb,
                                  bool inside)
{
    double sum = 0;
    long n = 0;
    for (int y = y0; y <= y1; y++)
        for (int x = 0; x + 1 < img->width; x++) {
            if ((x + 1 >= xa && x < xb) != inside)
                continue;
            float a = image_get(img, x, y).x, b = image_get(img, x + 1, y).x;
            sum += fabs((double)a - (double)b) * 255.0;
            n++;
        }
    return n ? sum / (double)n : 0.0;
}

/* -noise_cutoff: the distant part of the marble vase scene's Noise floor (the band of
 * rows below the horizon, beside the vase) varies much less from pixel to pixel, with
 * and without antialiasing; the same bytes for 1 and 2 threads and with and without
 * the grid; and a scene without noise (the checkerboard) keeps its bytes exactly. */
static void test_noise_cutoff(void)
{
    char a7[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX], checker[PATH_MAX];
    a7_dir(a7, sizeof a7);
    e2e_join(scene, sizeof scene, a7, "scene7_03_marble_vase.txt");
    e2e_join(checker, sizeof checker, a7, "scene7_02_checkerboard.txt");
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7cut") != NULL);
    static const char *const variants[][8] = {
        {NULL},
        {"-noise_cutoff", NULL},
        {"-uniform_samples", "4", NULL},
        {"-uniform_samples", "4", "-noise_cutoff", NULL},
        {"-uniform_samples", "4", "-noise_cutoff", "-threads", "1", "-grid", "15", NULL},
        {"-uniform_samples", "4", "-noise_cutoff", "-threads", "2", NULL}};
    char out[6][PATH_MAX];
    for (int v = 0; v < 6; v++) {
        char name[32];
        snprintf(name, sizeof name, "v%d.tga", v);
        e2e_join(out[v], PATH_MAX, dir, name);
        const char *args[32] = {"-input", scene, "-size", "100", "100", "-shadows",
                                "-output", out[v]};
        int n = 8;
        for (int k = 0; variants[v][k]; k++)
            args[n++] = variants[v][k];
        if (v == 4) {
            args[n++] = "30";
            args[n++] = "15";
        }
        args[n] = NULL;
        E2eRun run;
        render_args(args, out[v], &run);
        e2e_run_free(&run);
    }
    /* The horizon is at row 68 from the bottom; the vase covers columns 28..71 there. */
    for (int v = 0; v < 4; v += 2) {
        Image plain, cut;
        if (load(dir, v == 0 ? "v0.tga" : "v2.tga", &plain) &&
            load(dir, v == 0 ? "v1.tga" : "v3.tga", &cut)) {
            double far_plain = neighbour_variation(&plain, 58, 67, 25, 75, false);
            double far_cut = neighbour_variation(&cut, 58, 67, 25, 75, false);
            printf("    noise floor near the horizon, %s: neighbour difference %.1f -> %.1f "
                   "with -noise_cutoff\n", v == 0 ? "1 sample" : "4 samples", far_plain,
                   far_cut);
            CHECK_MSG(far_cut < 0.5 * far_plain, "%s: %.2f with the cut-off, %.2f without",
                      v == 0 ? "1 sample" : "4 samples", far_cut, far_plain);
            /* the vase itself (marble seen from nearby) keeps its veins */
            double vase_plain = neighbour_variation(&plain, 40, 60, 38, 58, true);
            double vase_cut = neighbour_variation(&cut, 40, 60, 38, 58, true);
            printf("    the vase: %.1f -> %.1f\n", vase_plain, vase_cut);
            CHECK_MSG(vase_cut > 0.5 * vase_plain, "vase: %.2f with the cut-off, %.2f without",
                      vase_cut, vase_plain);
            image_free(&plain);
            image_free(&cut);
        }
    }
    CHECK_MSG(same_file(out[3], out[4]) && same_file(out[3], out[5]),
              "-noise_cutoff: threads or grid change the bytes");
    /* No Noise, Marble or Wood in the scene: not one byte changes. */
    char c0[PATH_MAX], c1[PATH_MAX];
    e2e_join(c0, sizeof c0, dir, "c0.tga");
    e2e_join(c1, sizeof c1, dir, "c1.tga");
    for (int v = 0; v < 2; v++) {
        const char *args[] = {"-input", checker, "-size", "60", "60", "-uniform_samples", "4",
                              "-output", v ? c1 : c0, v ? "-noise_cutoff" : NULL, NULL};
        E2eRun run;
        render_args(args, v ? c1 : c0, &run);
        e2e_run_free(&run);
    }
    CHECK_MSG(same_file(c0, c1), "-noise_cutoff changed a scene without noise");
    e2e_rmtree(dir);
}

/* -stats of primary rays only: exactly W * H * n non-shadow rays. */
static void test_stats_counts(void)
{
    char a7[PATH_MAX], dir[PATH_MAX], scene[PATH_MAX], out[PATH_MAX];
    a7_dir(a7, sizeof a7);
    e2e_join(scene, sizeof scene, a7, "scene7_01_sphere_triangle.txt");
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7st") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    const char *args[] = {"-input", scene, "-size", "30", "20", "-output", out,
                          "-random_samples", "7", "-tent_filter", "1.5", "-stats", NULL};
    E2eRun run;
    render_args(args, out, &run);
    E2eStats st;
    CHECK(e2e_stats_parse(run.out, &st));
    CHECK_INT(st.nonshadow, 30 * 20 * 7);
    char why[256];
    CHECK_MSG(e2e_stats_layout_ok(&st, 30, 20, why, sizeof why), "%s", why);
    e2e_run_free(&run);
    e2e_rmtree(dir);
}

/* Bad values: one line on stderr, exit 2, nothing written, before the scene is read
 * (the scene named does not exist, so any work would fail with 1 instead). */
static void test_usage_errors(void)
{
    static const char *const bad[][4] = {
        {"-uniform_samples", "0"},        {"-uniform_samples", "10"},
        {"-jittered_samples", "8"},       {"-jittered_samples", "100000000"},
        {"-random_samples", "-3"},        {"-random_samples", "4096"},
        {"-nrooks_samples", "x"},         {"-poisson_samples", "257"},
        {"-box_filter", "-1"},
        {"-tent_filter", "0"},            {"-gaussian_filter", "-0.5"},
        {"-gaussian_filter", "nan"},      {"-mitchell_filter", "1000"},
        {"-render_samples", "s.tga", "0"}, {"-render_filter", "f.tga", "-2"},
        {"-adaptive_samples", "4", "2", "0.1"}, {"-adaptive_samples", "4", "15", "0.1"},
        {"-adaptive_samples", "4", "16", "-1"}, {"-seed", "-1"},
        /* one first sample has no spread: no pixel would ever be refined */
        {"-adaptive_samples", "1", "16", "0"},
        /* the filter picture's grid lines would cover every pixel */
        {"-render_filter", "f.tga", "1"},
        {"-render_samples", "s.tga", "100"}, {"-uniform_samples"}};
    char dir[PATH_MAX], out[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7bad") != NULL);
    e2e_join(out, sizeof out, dir, "o.tga");
    e2e_join(scene, sizeof scene, dir, "missing.txt");
    for (int b = 0; b < TEST_LIST_COUNT(bad); b++) {
        const char *args[16] = {"-input", scene, "-output", out, "-size", "500", "500"};
        int n = 7;
        for (int k = 0; k < 4 && bad[b][k]; k++)
            args[n++] = bad[b][k];
        args[n] = NULL;
        E2eRun run;
        CHECK(e2e_run_bin(harness_bin(), args, &run));
        const char *nl = strchr(run.err, '\n');
        CHECK_MSG(run.status == 2, "%s %s: exit %d (want 2); stderr: %s", bad[b][0],
                  bad[b][1] ? bad[b][1] : "", run.status, run.err);
        CHECK_MSG(nl && nl[1] == '\0', "%s: not one line on stderr: %s", bad[b][0], run.err);
        CHECK_MSG(e2e_count_entries(dir) == 0, "%s: something was written", bad[b][0]);
        e2e_run_free(&run);
    }
    e2e_rmtree(dir);
}

/* -tile and -region cut an image of the scene: with only the filter picture to write
 * (or with the samples picture, always whole) the part asked for cannot be made, and a
 * run that drew the whole picture anyway would ignore the option. A usage error: one
 * line, exit 2, nothing written. */
static void test_parts_of_pictures(void)
{
    char dir[PATH_MAX], pic[PATH_MAX], scene[PATH_MAX];
    CHECK(e2e_tmpdir(dir, sizeof dir, "a7part") != NULL);
    e2e_join(pic, sizeof pic, dir, "f.tga");
    e2e_join(scene, sizeof scene, dir, "missing.txt");
    static const char *const cut[][5] = {{"-tile", "0", "2"}, {"-region", "0", "0", "4", "4"}};
    for (int k = 0; k < TEST_LIST_COUNT(cut); k++)
        for (int which = 0; which < 2; which++) {
            const char *args[20] = {"-size", "9", "9", "-gaussian_filter", "0.4"};
            int n = 5;
            if (which == 0) {
                args[n++] = "-render_filter";
            } else {
                args[n++] = "-input";
                args[n++] = scene;
                args[n++] = "-render_samples";
            }
            args[n++] = pic;
            args[n++] = "20";
            for (int j = 0; j < 5 && cut[k][j]; j++)
                args[n++] = cut[k][j];
            args[n] = NULL;
            E2eRun run;
            CHECK(e2e_run_bin(harness_bin(), args, &run));
            const char *nl = strchr(run.err, '\n');
            CHECK_MSG(run.status == 2, "%s with %s: exit %d (want 2); stderr: %s",
                      which ? "-render_samples" : "-render_filter", cut[k][0], run.status,
                      run.err);
            CHECK_MSG(nl && nl[1] == '\0' && strstr(run.err, cut[k][0]),
                      "%s: not one line naming the option: %s", cut[k][0], run.err);
            CHECK_MSG(e2e_count_entries(dir) == 0, "%s: something was written", cut[k][0]);
            e2e_run_free(&run);
        }
    /* The same filter picture without a part is drawn (the refusal is the part's). */
    const char *ok[] = {"-size", "9", "9", "-gaussian_filter", "0.4", "-render_filter", pic,
                        "20", NULL};
    E2eRun run;
    CHECK(e2e_run_bin(harness_bin(), ok, &run));
    CHECK_MSG(run.status == 0, "whole filter picture: exit %d; stderr: %s", run.status,
              run.err);
    CHECK(e2e_count_entries(dir) == 1);
    e2e_run_free(&run);
    e2e_rmtree(dir);
}

static const TestCase tests[] = {
    {"a7 plain renders", test_plain_renders},
    {"-tile/-region with only the pictures: usage error", test_parts_of_pictures},
    {"-noise_cutoff: calmer distant noise, same bytes elsewhere", test_noise_cutoff},
    {"a7 filter pictures (bit-exact)", test_filter_pictures},
    {"a7 uniform samples: pictures and outputs", test_uniform_lines},
    {"a7 random/jittered 01 low res: close to official", test_random_01_low_res},
    {"a7 random/jittered 02: close to official", test_random_02},
    {"a7 jittered 03, 04: close to official", test_random_03_04},
    {"a7 jittered 05, 06: close to official", test_random_05_06},
    {"a7 random/jittered sample pictures: dots", test_sample_pictures},
    {"no option == one centred sample + box 0.5 (colour, depth, normals)", test_default_is_a6},
    {"constant scene stays constant under every sampler and filter", test_constant_scene},
    {"Mitchell with 1-2 samples: no blown-up or flipped pixels", test_mitchell_few_samples},
    {"threads, grid, packets, seed: deterministic bytes", test_deterministic},
    {"-stats counts every sample ray", test_stats_counts},
    {"bad sampler/filter values: usage error, exit 2", test_usage_errors},
};

RT_TEST_MAIN(tests)
