/* The grid's cell-reference cap (rt/grid.h, src/accel/grid_budget.c): a requested
 * resolution whose references would pass the cap is built coarser, with a warning, and
 * stays under the cap; -grid auto chooses from the primitives' sizes (co-located
 * spheres, large overlapping triangles) and keeps to its own budget; a scene under the
 * cap is built exactly as requested, silently; the estimate bounds what the build stores;
 * and the coarser grid still finds exactly the hits of "none". */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../harness.h"
#include "rt/accel.h"
#include "rt/grid.h"
#include "rt/prim.h"
#include "rt/render_ctx.h"
#include "rt/scene.h"

static uint64_t g_rng = 0x2545f4914f6cdd1dull;

static float rnd(void)
{
    g_rng ^= g_rng << 13;
    g_rng ^= g_rng >> 7;
    g_rng ^= g_rng << 17;
    return (float)((g_rng >> 40) * 0x1p-24);
}

static float sym(void) { return 2.0f * rnd() - 1.0f; }

/* A scene text with a camera, one material and the given objects. */
static char *scene_text(int n, const char *(*object)(int i, char *buf, size_t len))
{
    size_t cap = (size_t)n * 160 + 512, len = 0;
    char *s = malloc(cap);
    if (!s)
        return NULL;
    len += (size_t)snprintf(s + len, cap - len,
                            "OrthographicCamera { center 0 0 10 direction 0 0 -1 up 0 1 0 "
                            "size 5 }\nLights { numLights 0 }\nMaterials { numMaterials 1 "
                            "PhongMaterial { diffuseColor 1 0 0 } }\nGroup { numObjects %d "
                            "MaterialIndex 0\n", n);
    char buf[160];
    for (int i = 0; i < n; i++)
        len += (size_t)snprintf(s + len, cap - len, "%s\n", object(i, buf, sizeof buf));
    snprintf(s + len, cap - len, "}\n");
    return s;
}

static const char *colocated_sphere(int i, char *buf, size_t len)
{
    (void)i;
    snprintf(buf, len, "Sphere { center 0.5 0.25 0.125 radius 0.001 }");
    return buf;
}

/* Triangles with vertices anywhere in [-2, 2]^3: each spans about half the box. */
static const char *large_triangle(int i, char *buf, size_t len)
{
    (void)i;
    float v[9];
    for (int k = 0; k < 9; k++)
        v[k] = 2.0f * sym();
    snprintf(buf, len, "Triangle { vertex0 %g %g %g vertex1 %g %g %g vertex2 %g %g %g }",
             (double)v[0], (double)v[1], (double)v[2], (double)v[3], (double)v[4],
             (double)v[5], (double)v[6], (double)v[7], (double)v[8]);
    return buf;
}

/* Small spheres spread over [-2, 2]^3 (a course-like scene). */
static const char *small_sphere(int i, char *buf, size_t len)
{
    (void)i;
    snprintf(buf, len, "Sphere { center %g %g %g radius 0.05 }", (double)(2.0f * sym()),
             (double)(2.0f * sym()), (double)(2.0f * sym()));
    return buf;
}

typedef struct Loaded {
    Scene *s;
    PrimTable t;
} Loaded;

static bool load(Loaded *l, int n, const char *(*object)(int, char *, size_t))
{
    char *text = scene_text(n, object);
    Diag d;
    diag_init(&d, stderr);
    l->s = text ? scene_load_string(text, "budget.txt", NULL, &d) : NULL;
    free(text);
    if (!l->s || !prim_table_build(&l->t, l->s)) {
        scene_free(l->s);
        return false;
    }
    return true;
}

static void unload(Loaded *l)
{
    prim_table_free(&l->t);
    scene_free(l->s);
}

/* The grid's hits equal "none"'s on random rays through the scene (t bits and id). */
static void check_same_hits(const PrimTable *t, Grid *g, int rays)
{
    Accel none, grid = grid_as_accel(g);
    Diag d;
    diag_init(&d, NULL);
    CHECK(accel_init(&none, &accel_none_ops, t, NULL, &d));
    RenderCtx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.num_mailbox = accel_scratch_size(&grid);
    ctx.mailbox = calloc(ctx.num_mailbox ? ctx.num_mailbox : 1, sizeof *ctx.mailbox);
    CHECK(ctx.mailbox != NULL);
    int hits = 0;
    for (int i = 0; i < rays && ctx.mailbox; i++) {
        Ray r;
        r.origin = v3(3.0f * sym(), 3.0f * sym(), 6.0f);
        r.dir = v3_normalize(v3(0.3f * sym(), 0.3f * sym(), -1.0f));
        if (i % 2) { /* at a primitive's box centre */
            const Prim *p = &t->prims[(uint32_t)(rnd() * (float)t->num_prims) % t->num_prims];
            Vec3 c = v3_scale(v3_add(p->bounds.min, p->bounds.max), 0.5f);
            r.dir = v3_normalize(v3_sub(c, r.origin));
        }
        Hit a = hit_none(), b = hit_none();
        bool ha = accel_intersect(&none, &r, &a, 0.0f, &ctx);
        bool hb = accel_intersect(&grid, &r, &b, 0.0f, &ctx);
        CHECK_MSG(ha == hb && memcmp(&a.t, &b.t, sizeof a.t) == 0 && a.id == b.id,
                  "ray %d: none %d t=%g id=%u, grid %d t=%g id=%u", i, ha, (double)a.t,
                  a.id, hb, (double)b.t, b.id);
        hits += ha;
    }
    CHECK(hits > 0);
    free(ctx.mailbox);
    accel_free(&none);
}

/* Asking for far too many cells: a coarser grid, a warning, under the cap. */
static void check_capped(const char *what, int n, const char *(*object)(int, char *, size_t))
{
    Loaded l;
    CHECK(load(&l, n, object));
    if (harness_failures)
        return;
    int req[3] = {64, 64, 64};
    uint64_t cap = grid_ref_cap(l.t.num_bounded);
    CHECK_MSG(grid_ref_estimate(&l.t, req) > cap, "%s: the request should pass the cap", what);
    Diag d;
    diag_init(&d, NULL);
    Grid *g = grid_build_table(&l.t, req[0], req[1], req[2], &d);
    CHECK(g != NULL);
    if (g) {
        CHECK_INT(d.errors, 0);
        CHECK_INT(d.warnings, 1);
        CHECK_CONTAINS(d.last, "cell references");
        CHECK_CONTAINS(d.last, "a 64x64x64 grid would exceed");
        int dims[3];
        grid_dims(g, dims);
        CHECK_MSG(dims[0] < 64 && dims[1] < 64 && dims[2] < 64, "%s: %dx%dx%d", what,
                  dims[0], dims[1], dims[2]);
        uint64_t course, marching, est = grid_ref_estimate(&l.t, dims);
        grid_entry_totals(g, &course, &marching);
        CHECK_MSG(course <= est && marching <= est && est <= cap,
                  "%s: course %llu, marching %llu, estimate %llu, cap %llu", what,
                  (unsigned long long)course, (unsigned long long)marching,
                  (unsigned long long)est, (unsigned long long)cap);
        check_same_hits(&l.t, g, 300);
        grid_free(g);
    }
    /* -grid auto: from the sizes, within its own (smaller) budget, no warning. */
    int a[3];
    grid_choose_auto(&l.t, a);
    uint64_t est = grid_ref_estimate(&l.t, a);
    CHECK_MSG(est <= grid_ref_cap_auto(l.t.num_bounded), "%s: auto %dx%dx%d makes %llu", what,
              a[0], a[1], a[2], (unsigned long long)est);
    diag_init(&d, NULL);
    g = grid_build_table(&l.t, a[0], a[1], a[2], &d);
    CHECK(g != NULL);
    CHECK_INT(d.warnings, 0);
    grid_free(g);
    unload(&l);
}

static void test_colocated_spheres_capped(void)
{
    check_capped("co-located spheres", 3000, colocated_sphere);
}

static void test_large_triangles_capped(void)
{
    check_capped("large triangles", 3000, large_triangle);
}

/* Under the cap nothing changes: the requested resolution, no warning. */
static void test_under_cap_unchanged(void)
{
    Loaded l;
    CHECK(load(&l, 500, small_sphere));
    if (harness_failures)
        return;
    Diag d;
    diag_init(&d, NULL);
    Grid *g = grid_build_table(&l.t, 30, 20, 10, &d);
    CHECK(g != NULL);
    if (g) {
        int dims[3];
        grid_dims(g, dims);
        CHECK_INT(dims[0], 30);
        CHECK_INT(dims[1], 20);
        CHECK_INT(dims[2], 10);
        CHECK_INT(d.warnings, 0);
        uint64_t course, marching, est = grid_ref_estimate(&l.t, dims);
        grid_entry_totals(g, &course, &marching);
        CHECK(course <= est && marching <= est);
        grid_free(g);
    }
    /* Count-based choice kept: small spread-out spheres are well under the budget. */
    int a[3];
    grid_choose_auto(&l.t, a);
    CHECK_MSG((long)a[0] * a[1] * a[2] >= 1000, "auto chose %dx%dx%d", a[0], a[1], a[2]);
    unload(&l);
}

/* The cap's formula and the fitting loop's end: one cell is always within the cap. */
static void test_cap_formula(void)
{
    CHECK(grid_ref_cap(0) == GRID_REFS_FLOOR);
    CHECK(grid_ref_cap(1000) == (uint64_t)GRID_REFS_PER_PRIM * 1000 + GRID_REFS_FLOOR);
    CHECK(grid_ref_cap_auto(1000) < grid_ref_cap(1000));
    Loaded l;
    CHECK(load(&l, 200, large_triangle));
    if (harness_failures)
        return;
    int n[3] = {100, 100, 100};
    uint64_t est = 0;
    CHECK(grid_fit_refs(&l.t, n, 200, &est)); /* 1 per primitive: only one cell fits */
    CHECK_INT(n[0] * n[1] * n[2], 1);
    CHECK(est == 200);
    unload(&l);
}

/* Small triangles of a mesh-like cloud: each about a cell or two of the grids below. */
static const char *small_triangle(int i, char *buf, size_t len)
{
    (void)i;
    float c[3] = {2.0f * sym(), 2.0f * sym(), 2.0f * sym()}, v[9];
    for (int k = 0; k < 9; k++)
        v[k] = c[k % 3] + 0.15f * sym();
    snprintf(buf, len, "Triangle { vertex0 %g %g %g vertex1 %g %g %g vertex2 %g %g %g }",
             (double)v[0], (double)v[1], (double)v[2], (double)v[3], (double)v[4],
             (double)v[5], (double)v[6], (double)v[7], (double)v[8]);
    return buf;
}

/* The fit keeps a resolution exactly when its estimate is within the cap: with the cap
 * at the estimate, and one below it. The quick bound on triangles (grid_budget.c,
 * tri_refs_bound) decides whether the exact sum is taken at all, so a bound below some
 * triangle's exact references lets the second fit keep a resolution over its cap. */
static void test_fit_at_cap_edge(void)
{
    static const char *(*const kinds[])(int, char *, size_t) = {small_triangle,
                                                                 large_triangle};
    static const int res[][3] = {{7, 5, 3}, {20, 20, 20}, {33, 9, 17}, {64, 64, 64}};
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; k++) {
        Loaded l;
        CHECK(load(&l, 400, kinds[k]));
        if (harness_failures)
            return;
        for (size_t r = 0; r < sizeof res / sizeof res[0]; r++) {
            int n[3] = {res[r][0], res[r][1], res[r][2]};
            uint64_t est = grid_ref_estimate(&l.t, n);
            CHECK_MSG(!grid_fit_refs(&l.t, n, est, NULL), "kind %zu, %dx%dx%d: cap %llu",
                      k, res[r][0], res[r][1], res[r][2], (unsigned long long)est);
            CHECK(memcmp(n, res[r], sizeof n) == 0);
            CHECK_MSG(grid_fit_refs(&l.t, n, est - 1, NULL),
                      "kind %zu, %dx%dx%d kept with the cap one below its estimate %llu", k,
                      res[r][0], res[r][1], res[r][2], (unsigned long long)est);
        }
        unload(&l);
    }
}

static const TestCase tests[] = {
    {"colocated_spheres_capped", test_colocated_spheres_capped},
    {"large_triangles_capped", test_large_triangles_capped},
    {"under_cap_unchanged", test_under_cap_unchanged},
    {"cap_formula", test_cap_formula},
    {"fit_at_cap_edge", test_fit_at_cap_edge},
};
RT_TEST_MAIN(tests)
