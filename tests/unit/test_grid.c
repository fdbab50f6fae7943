/* Grid construction on small hand-made scenes: the course occupancy rules
 * (sphere distance rule, touching boxes, transformed triangles and
 * spheres), the tighter marching sets, planes, degenerate boxes, the palette, the
 * visualisation hit, -grid auto and a stop request during the build. */
#include <stdlib.h>
#include <string.h>

#include "../harness.h"
#include "rt/arena.h"
#include "rt/geom.h"
#include "rt/grid.h"
#include "rt/material.h"
#include "rt/scene.h"
#include "rt/par.h"
#include "rt/prim.h"
#include "rt/twolevel.h"
#include "../../src/accel/grid_build.h"
#include "../../src/accel/grid_internal.h"

/* A scene assembled by hand from the geometry constructors. */
typedef struct TestScene {
    Scene s;
    Material *mat;
    Object3D *kids[16];
    int n;
} TestScene;

static void ts_init(TestScene *t)
{
    memset(t, 0, sizeof *t);
    arena_init(&t->s.arena);
    PhongParams p = phong_defaults();
    t->mat = phong_new(&t->s.arena, &p);
}

static void ts_add(TestScene *t, Object3D *o)
{
    CHECK(o != NULL);
    if (o && t->n < 16)
        t->kids[t->n++] = o;
}

static void ts_finish(TestScene *t)
{
    Object3D *root = group_new(&t->s.arena, t->n);
    for (int i = 0; i < t->n; i++)
        group_set_child(root, i, t->kids[i]);
    group_finish(root);
    t->s.root = root;
    t->s.num_primitives = group_assign_ids(root);
    t->s.bounds = root->bounded ? root->bbox : bbox_empty();
}

static void ts_free(TestScene *t) { arena_free(&t->s.arena); }

static Grid *build(const TestScene *t, int nx, int ny, int nz)
{
    Diag d;
    diag_init(&d, stderr);
    Grid *g = grid_build(&t->s, nx, ny, nz, &d);
    CHECK(g != NULL);
    CHECK_INT(d.errors, 0);
    return g;
}

/* Unit sphere, 5^3 cells of 0.4: reach = 1 + 0.2*sqrt(3) = 1.3464. Every cell centre
 * lies within it except the 8 corner cells (centre distance 0.8*sqrt(3) = 1.386). */
static void test_sphere_distance_rule(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, sphere_new(&t.s.arena, v3(0, 0, 0), 1.0f, t.mat));
    ts_finish(&t);
    Grid *g = build(&t, 5, 5, 5);
    if (!g)
        return;
    int occupied = 0;
    for (int k = 0; k < 5; k++)
        for (int j = 0; j < 5; j++)
            for (int i = 0; i < 5; i++) {
                int c = grid_cell_count(g, i, j, k);
                CHECK(c == 0 || c == 1);
                bool corner = (i == 0 || i == 4) && (j == 0 || j == 4) && (k == 0 || k == 4);
                CHECK_MSG(c == (corner ? 0 : 1), "cell (%d,%d,%d) count %d", i, j, k, c);
                occupied += c;
            }
    CHECK_INT(occupied, 117);
    /* Marching set: only cells the surface crosses. The centre cell [-0.2,0.2]^3 lies
     * inside the sphere, the corner cells outside it. */
    CHECK_INT(grid_cell_marching_count(g, 2, 2, 2), 0);
    CHECK_INT(grid_cell_marching_count(g, 0, 0, 0), 0);
    CHECK_INT(grid_cell_marching_count(g, 4, 2, 2), 1);
    CHECK_INT(grid_cell_marching_count(g, 0, 0, 2), 1);
    CHECK_INT(grid_cell_count(g, 5, 0, 0), 0); /* out of range */
    CHECK_INT(grid_cell_count(g, -1, 0, 0), 0);
    CHECK_INT(grid_mailbox_size(g), 1);
    uint64_t course, marching;
    grid_entry_totals(g, &course, &marching);
    CHECK_INT(course, 117);
    CHECK(marching < course);
    grid_free(g);
    ts_free(&t);
}

/* Box [0,4]^3 of unit cells (a sphere at (2,2,2) of radius 2 occupies every cell by the
 * distance rule: corner centre distance 2.598 <= 2 + 0.866), plus triangles whose boxes
 * touch cell borders. */
static void test_touching_boxes(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, sphere_new(&t.s.arena, v3(2, 2, 2), 2.0f, t.mat));
    /* AABB [0.5,1] x [0.5,1] x {0.5}: max touches x = 1 and y = 1. */
    ts_add(&t, triangle_new(&t.s.arena, v3(0.5f, 0.5f, 0.5f), v3(1, 0.5f, 0.5f),
                            v3(0.5f, 1, 0.5f), t.mat));
    /* AABB [1,1.5] x [2.5,3] x {0.5}: min touches x = 1, max touches y = 3. */
    ts_add(&t, triangle_new(&t.s.arena, v3(1, 2.5f, 0.5f), v3(1.5f, 2.5f, 0.5f),
                            v3(1, 3, 0.5f), t.mat));
    ts_finish(&t);
    Grid *g = build(&t, 4, 4, 4);
    if (!g)
        return;
    int expect[4][4] = {{0}}; /* [j][i] in layer k = 0: extra entries */
    expect[0][0] = expect[0][1] = expect[1][0] = expect[1][1] = 1;
    expect[2][0] = expect[2][1] = expect[3][0] = expect[3][1] = 1;
    for (int k = 0; k < 4; k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++) {
                int want = 1 + (k == 0 ? expect[j][i] : 0);
                CHECK_MSG(grid_cell_count(g, i, j, k) == want, "cell (%d,%d,%d): %d, want %d",
                          i, j, k, grid_cell_count(g, i, j, k), want);
            }
    /* Marching set of the first triangle: its hypotenuse x + y = 1.5 stays out of
     * cell (1,1,0) (x + y >= 2 there); the exact test drops the cell the box rule adds. */
    CHECK_INT(grid_cell_count(g, 1, 1, 0), 2);
    CHECK_INT(grid_cell_marching_count(g, 1, 1, 0), 1); /* the sphere's surface only */
    CHECK_INT(grid_cell_marching_count(g, 0, 0, 0), 2);
    grid_free(g);
    ts_free(&t);
}

/* The course's transformed-triangle rule: the box of the three TRANSFORMED vertices. */
static void test_transformed_triangle(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, sphere_new(&t.s.arena, v3(2, 2, 2), 2.0f, t.mat));
    Object3D *tri = triangle_new(&t.s.arena, v3(0.25f, 0.25f, 1.5f), v3(0.75f, 0.25f, 1.5f),
                                 v3(0.25f, 0.75f, 1.5f), t.mat);
    Mat4 tr = mat4_translate(v3(2, 0, 0)), sc = mat4_scale(v3(1, 2, 1));
    Mat4 m = mat4_mul(&tr, &sc);
    /* Two nested transforms to exercise path composition: translate(2,0,0)(scale(1,2,1)). */
    Object3D *inner = transform_new(&t.s.arena, &sc, tri);
    ts_add(&t, transform_new(&t.s.arena, &tr, inner));
    (void)m;
    ts_finish(&t);
    Grid *g = build(&t, 4, 4, 4);
    if (!g)
        return;
    /* World vertices (2.25,0.5,1.5) (2.75,0.5,1.5) (2.25,1.5,1.5): cells x 2, y 0..1, z 1. */
    for (int k = 0; k < 4; k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++) {
                int want = 1 + (i == 2 && j <= 1 && k == 1);
                CHECK_MSG(grid_cell_count(g, i, j, k) == want, "cell (%d,%d,%d): %d, want %d",
                          i, j, k, grid_cell_count(g, i, j, k), want);
            }
    grid_free(g);
    ts_free(&t);
}

/* A sphere through a Transform uses the box rule on its transformed local box:
 * translate(2,2,2) scale(2,1,1), r = 0.5 -> [1,3] x [1.5,2.5]^2, touching x = 1 and 3:
 * cells x 0..3, y 1..2, z 1..2 (16 cells). */
static void test_transformed_sphere(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, sphere_new(&t.s.arena, v3(2, 2, 2), 2.0f, t.mat));
    Mat4 tr = mat4_translate(v3(2, 2, 2)), sc = mat4_scale(v3(2, 1, 1));
    Mat4 m = mat4_mul(&tr, &sc);
    ts_add(&t, transform_new(&t.s.arena, &m, sphere_new(&t.s.arena, v3(0, 0, 0), 0.5f, t.mat)));
    ts_finish(&t);
    Grid *g = build(&t, 4, 4, 4);
    if (!g)
        return;
    int extra = 0;
    for (int k = 0; k < 4; k++)
        for (int j = 0; j < 4; j++)
            for (int i = 0; i < 4; i++) {
                int want = 1 + (j >= 1 && j <= 2 && k >= 1 && k <= 2);
                CHECK_MSG(grid_cell_count(g, i, j, k) == want, "cell (%d,%d,%d): %d, want %d",
                          i, j, k, grid_cell_count(g, i, j, k), want);
                extra += grid_cell_count(g, i, j, k) - 1;
            }
    CHECK_INT(extra, 16);
    /* Marching: the ellipsoid's surface crosses these cells, so it must be there. */
    CHECK(grid_cell_marching_count(g, 1, 1, 1) >= 1);
    CHECK(grid_cell_marching_count(g, 2, 2, 2) >= 1);
    grid_free(g);
    ts_free(&t);
}

/* An identity Transform still switches a sphere to the box rule (the course
 * tests a transformed sphere by its transformed box). */
static void test_identity_transform_sphere_uses_box_rule(void)
{
    TestScene t;
    ts_init(&t);
    Mat4 id = mat4_identity();
    ts_add(&t, transform_new(&t.s.arena, &id, sphere_new(&t.s.arena, v3(0, 0, 0), 1.0f, t.mat)));
    ts_finish(&t);
    Grid *g = build(&t, 5, 5, 5);
    if (!g)
        return;
    CHECK_INT(grid_cell_count(g, 0, 0, 0), 1); /* the corner the distance rule leaves out */
    CHECK_INT(grid_cell_count(g, 4, 4, 4), 1);
    grid_free(g);
    ts_free(&t);
}

static void test_planes_are_not_in_cells(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, plane_new(&t.s.arena, v3(0, 1, 0), -1.0f, t.mat));
    ts_add(&t, sphere_new(&t.s.arena, v3(0, 0, 0), 1.0f, t.mat));
    ts_finish(&t);
    Grid *g = build(&t, 5, 5, 5);
    if (!g)
        return;
    CHECK_INT(grid_cell_count(g, 2, 0, 2), 1);
    CHECK_INT(grid_mailbox_size(g), 1);
    /* A ray from above hits the sphere; one from below the plane (y = -1) hits the plane
     * first, although the plane is in no cell. */
    RenderCtx ctx;
    memset(&ctx, 0, sizeof ctx);
    Hit h = hit_none();
    Ray down = {v3(0, 5, 0), v3(0, -1, 0)};
    CHECK(grid_intersect(g, &down, &h, 0.0f, &ctx));
    CHECK_NEAR(h.t, 4.0, 1e-6);
    h = hit_none();
    Ray up = {v3(0, -5, 0), v3(0, 1, 0)};
    CHECK(grid_intersect(g, &up, &h, 0.0f, &ctx));
    CHECK_NEAR(h.t, 4.0, 1e-6);
    CHECK_INT(h.id, 0); /* the plane (first child) */
    /* Shadow query between y = -5 and y = -3: nothing; up to y = 0: the plane. */
    CHECK(!grid_occluded(g, &up, 0.0f, 2.0f, &ctx));
    CHECK(grid_occluded(g, &up, 0.0f, 5.0f, &ctx));
    grid_free(g);
    ts_free(&t);
}

static void test_only_planes_gives_no_grid(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, plane_new(&t.s.arena, v3(0, 1, 0), 0.0f, t.mat));
    ts_finish(&t);
    Diag d;
    diag_init(&d, NULL);
    CHECK(grid_build(&t.s, 4, 4, 4, &d) == NULL);
    CHECK_INT(d.errors, 0);
    ts_free(&t);
}

static void test_bad_resolutions(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, sphere_new(&t.s.arena, v3(0, 0, 0), 1.0f, t.mat));
    ts_finish(&t);
    Diag d;
    diag_init(&d, NULL);
    CHECK(grid_build(&t.s, 0, 4, 4, &d) == NULL);
    CHECK_INT(d.errors, 1);
    CHECK(grid_build(&t.s, 100000, 100000, 100000, &d) == NULL);
    CHECK_INT(d.errors, 2);
    CHECK_CONTAINS(d.last, "too large");
    ts_free(&t);

    /* A box whose size overflows a float: its objects are kept out of the cells
     * (rt/prim.h), so nothing is left to put in a grid: no grid, no error. With an
     * ordinary object beside them, the grid covers that object alone. */
    TestScene h;
    ts_init(&h);
    ts_add(&h, sphere_new(&h.s.arena, v3(3e38f, 0, 0), 1.0f, h.mat));
    ts_add(&h, sphere_new(&h.s.arena, v3(-3e38f, 0, 0), 1.0f, h.mat));
    ts_finish(&h);
    diag_init(&d, NULL);
    CHECK(grid_build(&h.s, 4, 4, 4, &d) == NULL);
    CHECK_INT(d.errors, 0);
    ts_free(&h);
    ts_init(&h);
    ts_add(&h, sphere_new(&h.s.arena, v3(3e38f, 0, 0), 1.0f, h.mat));
    ts_add(&h, sphere_new(&h.s.arena, v3(1, 2, 3), 1.0f, h.mat));
    ts_finish(&h);
    Grid *g = grid_build(&h.s, 4, 4, 4, &d);
    CHECK(g != NULL);
    CHECK_INT(d.errors, 0);
    if (g) {
        BBox b = grid_bounds(g);
        CHECK(b.min.x == 0.0f && b.max.x == 2.0f && b.min.z == 2.0f && b.max.z == 4.0f);
        CHECK_INT(grid_mailbox_size(g), 1);
        grid_free(g);
    }
    ts_free(&h);
}

/* A flat scene (one triangle in z = 0) has a zero-thickness box: the grid still works. */
static void test_zero_thickness_box(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, triangle_new(&t.s.arena, v3(0, 0, 0), v3(1, 0, 0), v3(0, 1, 0), t.mat));
    ts_finish(&t);
    Grid *g = build(&t, 4, 4, 4);
    if (!g)
        return;
    BBox b = grid_bounds(g);
    CHECK(b.min.z == 0.0f && b.max.z == 0.0f); /* the printed box is the scene's */
    RenderCtx ctx;
    memset(&ctx, 0, sizeof ctx);
    Hit h = hit_none();
    Ray r = {v3(0.2f, 0.3f, 5), v3(0, 0, -1)};
    CHECK(grid_intersect(g, &r, &h, 0.0f, &ctx));
    CHECK_NEAR(h.t, 5.0, 0);
    h = hit_none();
    Ray miss = {v3(0.8f, 0.8f, 5), v3(0, 0, -1)};
    CHECK(!grid_intersect(g, &miss, &h, 0.0f, &ctx));
    /* Grazing within the plane of the triangle: no hit, no crash. */
    h = hit_none();
    Ray along = {v3(-1, 0.25f, 0), v3(1, 0, 0)};
    (void)grid_intersect(g, &along, &h, 0.0f, &ctx);
    grid_free(g);
    ts_free(&t);
}

static void check_rgb(const Material *m, float r, float gg, float b)
{
    PhongParams p;
    CHECK(m != NULL);
    if (!m)
        return;
    CHECK(phong_params(m, &p));
    CHECK_MSG(p.diffuse.x == r && p.diffuse.y == gg && p.diffuse.z == b,
              "diffuse (%g,%g,%g), want (%g,%g,%g)", (double)p.diffuse.x, (double)p.diffuse.y,
              (double)p.diffuse.z, (double)r, (double)gg, (double)b);
    CHECK(v3_is_zero(p.specular));
}

static void test_palette(void)
{
    check_rgb(grid_palette_material(1), 1, 1, 1);
    check_rgb(grid_palette_material(2), 1, 0, 1);
    check_rgb(grid_palette_material(3), 0.7f, 0, 1);
    check_rgb(grid_palette_material(5), 0, 0, 1);
    check_rgb(grid_palette_material(8), 0, 1, 1);
    check_rgb(grid_palette_material(11), 0, 1, 0);
    check_rgb(grid_palette_material(14), 1, 1, 0);
    check_rgb(grid_palette_material(16), 1, 0.3f, 0);
    check_rgb(grid_palette_material(17), 1, 0, 0);
    check_rgb(grid_palette_material(1000), 1, 0, 0);
    /* One material per colour, made once: counts past 17 share the last one, and
     * neighbouring counts are different materials. */
    CHECK(grid_palette_material(17) == grid_palette_material(1000));
    CHECK(grid_palette_material(0) == grid_palette_material(1));
    for (int c = 1; c < 17; c++)
        CHECK_MSG(grid_palette_material(c) != grid_palette_material(c + 1),
                  "counts %d and %d share a material", c, c + 1);
}

/* The visualisation hit: first non-empty course cell, t = its entry, entered face. */
static void test_visualize_hit(void)
{
    TestScene t;
    ts_init(&t);
    ts_add(&t, sphere_new(&t.s.arena, v3(0, 0, 0), 1.0f, t.mat));
    ts_finish(&t);
    Grid *g = build(&t, 5, 5, 5);
    if (!g)
        return;
    RenderCtx ctx;
    memset(&ctx, 0, sizeof ctx);
    /* Along the diagonal corner cell (4,4,4) is empty, (3,4,4)... the march from the
     * +x side through row y = 0.9, z = 0.9 meets corner cell (4,4,4) first (empty),
     * then (3,4,4) at x = 0.6 (count 1). */
    Hit h = hit_none();
    Ray r = {v3(3, 0.9f, 0.9f), v3(-1, 0, 0)};
    CHECK(grid_visualize_intersect(g, &r, &h, 0.0f, &ctx));
    CHECK_NEAR(h.t, 2.4, 1e-5);
    CHECK(h.normal.x == 1.0f && h.normal.y == 0.0f && h.normal.z == 0.0f);
    CHECK(h.material == grid_palette_material(1));
    CHECK_INT(ctx.stats.cells_traversed, 2);
    /* A ray in front of the box entering a full cell: t = box entry, face -z. */
    h = hit_none();
    Ray f = {v3(0, 0, -3), v3(0, 0, 1)};
    CHECK(grid_visualize_intersect(g, &f, &h, 0.0f, &ctx));
    CHECK_NEAR(h.t, 2.0, 1e-6);
    CHECK(h.normal.z == -1.0f);
    /* Missing the box. */
    h = hit_none();
    Ray m = {v3(0, 3, -3), v3(0, 0, 1)};
    CHECK(!grid_visualize_intersect(g, &m, &h, 0.0f, &ctx));
    grid_free(g);
    ts_free(&t);
}

static void test_auto_resolution(void)
{
    TestScene t;
    ts_init(&t);
    /* 16 spheres of radius 0.5 filling a 4.75 x 2 x 1 box. */
    for (int i = 0; i < 16; i++)
        ts_add(&t, sphere_new(&t.s.arena, v3(0.25f * (float)i, (float)(i % 2), 0), 0.5f, t.mat));
    ts_finish(&t);
    int n[3];
    PrimTable pt;
    CHECK(prim_table_build(&pt, &t.s));
    grid_choose_auto(&pt, n);
    prim_table_free(&pt);
    for (int a = 0; a < 3; a++)
        CHECK(n[a] >= 1);
    /* The rule of docs/grid.md: 4 cells per primitive (64), near-cubic cells:
     * k = (64 / (4.75 * 2 * 1))^(1/3) = 1.889, n = round(side * k) = 9, 4, 2. */
    CHECK_MSG(n[0] == 9 && n[1] == 4 && n[2] == 2, "%dx%dx%d, expected 9x4x2", n[0], n[1],
              n[2]);
    ts_free(&t);

    TestScene f;
    ts_init(&f);
    ts_add(&f, triangle_new(&f.s.arena, v3(0, 0, 0), v3(10, 0, 0), v3(0, 10, 0), f.mat));
    ts_finish(&f);
    CHECK(prim_table_build(&pt, &f.s));
    grid_choose_auto(&pt, n);
    prim_table_free(&pt);
    CHECK_INT(n[2], 1); /* flat axis: one cell */
    /* A 10 x 10 square, one primitive: 4 cells as 2 x 2 (k = sqrt(4 / 100) = 0.2). */
    CHECK_MSG(n[0] == 2 && n[1] == 2, "%dx%d, expected 2x2", n[0], n[1]);
    ts_free(&f);
}

/* The packed triangles and their hit records share one block, as do the primitive list
 * and its renumbered copy (grid_pack.c, grid.c): each pair used to be two mappings, the
 * second with a fresh 2 MB page of its own. The blocks' layout, and the grid's contents
 * in them: the hit records of the packed triangles, the sphere unpacked. */
static void test_pack_blocks(void)
{
    TestScene t;
    ts_init(&t);
    for (int i = 0; i < 15; i++) {
        float x = 0.25f * (float)i;
        ts_add(&t, triangle_new(&t.s.arena, v3(x, 0, 0), v3(x + 0.5f, 0, 1), v3(x, 1, 0.5f),
                                t.mat));
    }
    ts_add(&t, sphere_new(&t.s.arena, v3(2, 2, 2), 0.5f, t.mat));
    ts_finish(&t);
    /* With a set-up helper the second primitive array is always made (on one thread,
     * only where the first one's mapping has room: not for 16 primitives). */
    par_set_helpers(1);
    Grid *g = build(&t, 4, 3, 2);
    par_set_helpers(-1);
    if (!g)
        return;
    uint32_t n = g->num_prims;
    CHECK_INT(n, 16);
    CHECK(g->hit_in_tri && (char *)g->tri_hit == (char *)(g->tri + n));
    CHECK(g->prims_block != NULL &&
          ((g->prims == g->prims_block && g->prims_spare == g->prims_block + n) ||
           (g->prims_spare == g->prims_block && g->prims == g->prims_block + n)));
    int packed = 0;
    for (uint32_t p = 0; p < n; p++) {
        bool tri = obj_kind(g->prims[p].obj) == OBJ_TRIANGLE;
        CHECK(tri == (g->tri[p].id != RT_NO_ID));
        if (tri) {
            Vec3 nrm = triangle_normal(g->prims[p].obj);
            CHECK(memcmp(&g->tri_hit[p].normal, &nrm, sizeof nrm) == 0);
            CHECK(g->tri_hit[p].material == t.mat);
            packed++;
        }
    }
    CHECK_INT(packed, 15);
    grid_free(g);
    ts_free(&t);
}

/* A stop request (rt/par.h: main's stop-signal flag) ends the set-up's long loops: the
 * grid's binning and pack, the two-level grid's top grid and leaves, the flattening of
 * a big group. Each then fails quietly (NULL / false, no error reported: main says
 * "interrupted"), on one thread and with a helper; with the flag clear the same calls
 * succeed. Before, the build ran to its end whatever the flag (a Ctrl-C during a 1M
 * triangle mesh's grid build waited 0.2-0.6 s for it). */
static void test_stop_request(void)
{
    TestScene t;
    ts_init(&t);
    enum { N = 3 * 4096 }; /* three flattening chunks, twelve binning chunks */
    Object3D *mesh = group_new(&t.s.arena, N);
    CHECK(mesh != NULL);
    if (!mesh)
        return;
    for (int i = 0; i < N; i++) {
        float x = (float)(i % 128), y = (float)(i / 128);
        group_set_child(mesh, i, triangle_new(&t.s.arena, v3(x, y, 0), v3(x + 1, y, 0),
                                              v3(x, y + 1, 0.5f), t.mat));
    }
    group_finish(mesh);
    ts_add(&t, mesh);
    ts_finish(&t);
    volatile int stop = 0;
    par_set_stop_flag(&stop);
    for (int helpers = 0; helpers < 2; helpers++) {
        par_set_helpers(helpers);
        Diag d;
        diag_init(&d, NULL);
        PrimTable table;
        stop = 0;
        CHECK(prim_table_build(&table, &t.s));
        Grid *g = grid_build_table(&table, 16, 16, 2, &d);
        CHECK_MSG(g != NULL, "helpers %d: no grid without a stop", helpers);
        grid_free(g);
        TwoLevelGrid *tl = twolevel_build(&table, &d);
        CHECK_MSG(tl != NULL, "helpers %d: no two-level grid without a stop", helpers);
        twolevel_free(tl);
        stop = 2; /* SIGINT's number, as the handler stores it */
        CHECK_MSG(grid_build_table(&table, 16, 16, 2, &d) == NULL,
                  "helpers %d: the grid was built after the stop", helpers);
        CHECK_MSG(twolevel_build(&table, &d) == NULL,
                  "helpers %d: the two-level grid was built after the stop", helpers);
        CHECK_INT(d.errors, 0);
        prim_table_free(&table);
        /* The flattening looks in its chunks, which it uses with helpers only. */
        PrimTable cut;
        if (helpers > 0)
            CHECK_MSG(!prim_table_build(&cut, &t.s), "the scene was flattened after the stop");
        else if (prim_table_build(&cut, &t.s))
            prim_table_free(&cut);
    }
    par_set_stop_flag(NULL);
    par_set_helpers(-1);
    ts_free(&t);
}

/* The grid's CSR fill (grid_fill_items: one thread writes every entry, tens of ms at
 * 1.3M triangles) looks at the stop request every FILL_STOP_CHUNKS chunks: with the flag
 * set it gives up (false); clear, it writes every primitive into its cells in order. n
 * primitives of one cell each (p % 7), their cells listed by two "workers" in turn.
 * Before, the fill ran to its end whatever the flag (the API is new: this does not
 * build on 1f2bcd1). */
static void test_fill_stop_request(void)
{
    enum { CELLS = 7 };
    uint32_t n = FILL_STOP_CHUNKS * BIN_CHUNK + 5, nchunks = n / BIN_CHUNK + 1;
    uint32_t *ncells = malloc(n * sizeof *ncells), *items = malloc(n * sizeof *items);
    uint32_t *pairs[2] = {malloc(n * sizeof(uint32_t)), malloc(n * sizeof(uint32_t))};
    BinChunk *chunk = calloc(nchunks, sizeof *chunk);
    BinPart *part = calloc(PAR_MAX_WORKERS, sizeof *part);
    CHECK(ncells && items && pairs[0] && pairs[1] && chunk && part);
    if (harness_failures)
        goto done;
    size_t used[2] = {0, 0};
    for (uint32_t k = 0; k < nchunks; k++) {
        int w = (int)(k % 2);
        chunk[k].worker = w;
        chunk[k].off = used[w];
        for (uint32_t p = k * BIN_CHUNK; p < n && p < (k + 1) * BIN_CHUNK; p++) {
            ncells[p] = 1;
            pairs[w][used[w]++] = p % CELLS;
        }
    }
    part[0].pairs = pairs[0];
    part[1].pairs = pairs[1];
    volatile int stop = 0;
    par_set_stop_flag(&stop);
    for (int round = 0; round < 2; round++) {
        stop = round == 0 ? 2 : 0;
        uint32_t cursor[CELLS], start[CELLS];
        for (uint32_t c = 0, at = 0; c < CELLS; c++) {
            start[c] = cursor[c] = at;
            at += n / CELLS + (c < n % CELLS);
        }
        memset(items, 0xFF, n * sizeof *items);
        bool done = grid_fill_items(items, cursor, ncells, n, chunk, part);
        if (round == 0) {
            CHECK_MSG(!done, "the entries were filled after the stop");
            continue;
        }
        CHECK(done);
        uint32_t bad = 0;
        for (uint32_t c = 0; c < CELLS; c++)
            for (uint32_t i = start[c], p = c; p < n; i++, p += CELLS)
                bad += items[i] != p;
        CHECK_INT((int)bad, 0);
    }
    par_set_stop_flag(NULL);
done:
    free(ncells);
    free(items);
    free(pairs[0]);
    free(pairs[1]);
    free(chunk);
    free(part);
}

static int ref_order(const void *pa, const void *pb)
{
    const PrimRef *a = pa, *b = pb;
    if (a->obj != b->obj)
        return (uintptr_t)a->obj < (uintptr_t)b->obj ? -1 : 1;
    if (a->xf != b->xf)
        return (uintptr_t)a->xf < (uintptr_t)b->xf ? -1 : 1;
    return 0;
}

/* The -cache store's sort of the table's primitives (grid_cache_sort_refs, our merge
 * sort in place of qsort, which cannot be stopped inside: a quarter of a second at 1.3M
 * triangles) gives qsort's order (unique keys, in shuffled order, for sizes around its
 * runs and a few SORT_STOP passes), and with the stop flag set gives up (false). The
 * pointers are only compared, never followed. (The API is new: this does not build on
 * 1f2bcd1.) */
static void test_cache_sort_stop_request(void)
{
    static const uint32_t sizes[] = {0, 1, 2, 15, 16, 17, 33, 1000, 3 * SORT_STOP + 7};
    uint32_t most = sizes[sizeof sizes / sizeof *sizes - 1];
    PrimRef *refs = malloc(most * sizeof *refs), *want = malloc(most * sizeof *want);
    PrimRef *tmp = malloc(most * sizeof *tmp);
    CHECK(refs && want && tmp);
    if (harness_failures)
        goto done;
    volatile int stop = 0;
    par_set_stop_flag(&stop);
    uint64_t state = 12345;
    for (size_t s = 0; s < sizeof sizes / sizeof *sizes; s++) {
        uint32_t n = sizes[s];
        for (uint32_t i = 0; i < n; i++) {
            /* Keys (obj, xf) unique: obj of 1..n/3 + 1, xf of 3 values. */
            refs[i].obj = (const Object3D *)(uintptr_t)(64 * (1 + i / 3));
            refs[i].xf = (const PrimXform *)(uintptr_t)(64 * (i % 3));
            refs[i].index = i;
        }
        for (uint32_t i = n; i > 1; i--) { /* shuffle */
            state = state * 6364136223846793005ull + 1442695040888963407ull;
            uint32_t j = (uint32_t)((state >> 33) % i);
            PrimRef t = refs[i - 1];
            refs[i - 1] = refs[j];
            refs[j] = t;
        }
        memcpy(want, refs, n * sizeof *refs);
        qsort(want, n, sizeof *want, ref_order);
        stop = 0;
        CHECK(grid_cache_sort_refs(refs, n, tmp));
        CHECK_MSG(n == 0 || memcmp(refs, want, n * sizeof *refs) == 0,
                  "%u refs: not qsort's order", n);
        if (n > 0) {
            stop = 15;
            CHECK_MSG(!grid_cache_sort_refs(refs, n, tmp), "%u refs sorted after the stop", n);
        }
    }
    par_set_stop_flag(NULL);
done:
    free(refs);
    free(want);
    free(tmp);
}

static const TestCase tests[] = {
    {"sphere_distance_rule", test_sphere_distance_rule},
    {"stop_request", test_stop_request},
    {"fill_stop_request", test_fill_stop_request},
    {"cache_sort_stop_request", test_cache_sort_stop_request},
    {"touching_boxes", test_touching_boxes},
    {"transformed_triangle", test_transformed_triangle},
    {"pack_blocks", test_pack_blocks},
    {"transformed_sphere", test_transformed_sphere},
    {"identity_transform_sphere_uses_box_rule", test_identity_transform_sphere_uses_box_rule},
    {"planes_are_not_in_cells", test_planes_are_not_in_cells},
    {"only_planes_gives_no_grid", test_only_planes_gives_no_grid},
    {"bad_resolutions", test_bad_resolutions},
    {"zero_thickness_box", test_zero_thickness_box},
    {"palette", test_palette},
    {"visualize_hit", test_visualize_hit},
    {"auto_resolution", test_auto_resolution},
};

RT_TEST_MAIN(tests)
