/* MarchingInfo (3D-DDA) against hand-computed cell sequences: entry through each of the
 * six faces, axis-parallel and diagonal rays, starts inside, grazing edges and corners,
 * misses, negative directions, padding and the cells-traversed counter. */
#include "rt/marching_info.h"

#include <stdlib.h>
#include <string.h>

#include "../harness.h"

typedef struct Seq {
    int n;
    int c[64][3];
    float t[64];
    Vec3 normal[64];
} Seq;

/* Marches ray over box [0,4]^3 split into 4x4x4 unit cells unless box/n are given. */
static bool run(const BBox *box, const int n[3], float pad, Vec3 o, Vec3 d, float tmin,
                Seq *s, RenderCtx *ctx)
{
    memset(s, 0, sizeof *s);
    MarchingInfo mi;
    float p[3] = {pad, pad, pad};
    Ray r = {o, d};
    if (!march_init(&mi, box, n, p, &r, tmin, ctx))
        return false;
    do {
        if (s->n >= 64)
            break;
        memcpy(s->c[s->n], mi.cell, sizeof mi.cell);
        s->t[s->n] = mi.t;
        s->normal[s->n] = mi.normal;
        s->n++;
    } while (march_next(&mi, ctx));
    return true;
}

static const BBox unit_box = {{0, 0, 0}, {4, 4, 4}};
static const int four[3] = {4, 4, 4};

static bool march4(Vec3 o, Vec3 d, float tmin, Seq *s)
{
    return run(&unit_box, four, 0.0f, o, d, tmin, s, NULL);
}

#define CHECK_CELLS(s, expected, count)                                                   \
    do {                                                                                  \
        CHECK_INT((s).n, count);                                                          \
        for (int q_ = 0; q_ < (count) && q_ < (s).n; q_++)                                \
            CHECK_MSG((s).c[q_][0] == (expected)[q_][0] && (s).c[q_][1] == (expected)[q_][1] && \
                          (s).c[q_][2] == (expected)[q_][2],                              \
                      "cell %d is (%d,%d,%d), expected (%d,%d,%d)", q_, (s).c[q_][0],     \
                      (s).c[q_][1], (s).c[q_][2], (expected)[q_][0], (expected)[q_][1],   \
                      (expected)[q_][2]);                                                 \
    } while (0)

static void check_normal(Vec3 n, float x, float y, float z)
{
    CHECK_MSG(n.x == x && n.y == y && n.z == z, "normal (%g,%g,%g), expected (%g,%g,%g)",
              (double)n.x, (double)n.y, (double)n.z, (double)x, (double)y, (double)z);
}

static void test_enter_from_minus_x(void)
{
    Seq s;
    CHECK(march4(v3(-1, 0.5f, 0.5f), v3(1, 0, 0), 0.0f, &s));
    int e[4][3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
    CHECK_CELLS(s, e, 4);
    CHECK_NEAR(s.t[0], 1.0, 0);
    CHECK_NEAR(s.t[3], 4.0, 0);
    check_normal(s.normal[0], -1, 0, 0);
    check_normal(s.normal[2], -1, 0, 0);
}

static void test_enter_from_plus_x(void)
{
    Seq s;
    CHECK(march4(v3(5, 1.5f, 2.5f), v3(-1, 0, 0), 0.0f, &s));
    int e[4][3] = {{3, 1, 2}, {2, 1, 2}, {1, 1, 2}, {0, 1, 2}};
    CHECK_CELLS(s, e, 4);
    CHECK_NEAR(s.t[0], 1.0, 0);
    check_normal(s.normal[0], 1, 0, 0);
    check_normal(s.normal[1], 1, 0, 0);
}

static void test_enter_from_minus_y(void)
{
    Seq s;
    CHECK(march4(v3(0.5f, -2, 3.5f), v3(0, 1, 0), 0.0f, &s));
    int e[4][3] = {{0, 0, 3}, {0, 1, 3}, {0, 2, 3}, {0, 3, 3}};
    CHECK_CELLS(s, e, 4);
    CHECK_NEAR(s.t[0], 2.0, 0);
    check_normal(s.normal[0], 0, -1, 0);
}

static void test_enter_from_plus_y(void)
{
    Seq s;
    CHECK(march4(v3(3.5f, 7, 0.5f), v3(0, -2, 0), 0.0f, &s));
    int e[4][3] = {{3, 3, 0}, {3, 2, 0}, {3, 1, 0}, {3, 0, 0}};
    CHECK_CELLS(s, e, 4);
    CHECK_NEAR(s.t[0], 1.5, 0);
    CHECK_NEAR(s.t[1], 2.0, 0); /* cells are half a unit of t apart at |d| = 2 */
    check_normal(s.normal[0], 0, 1, 0);
}

static void test_enter_from_minus_z(void)
{
    Seq s;
    CHECK(march4(v3(2.5f, 1.5f, -1), v3(0, 0, 0.5f), 0.0f, &s));
    int e[4][3] = {{2, 1, 0}, {2, 1, 1}, {2, 1, 2}, {2, 1, 3}};
    CHECK_CELLS(s, e, 4);
    CHECK_NEAR(s.t[0], 2.0, 0);
    CHECK_NEAR(s.t[3], 8.0, 0);
    check_normal(s.normal[0], 0, 0, -1);
}

static void test_enter_from_plus_z(void)
{
    Seq s;
    CHECK(march4(v3(0.5f, 0.5f, 10), v3(0, 0, -2), 0.0f, &s));
    int e[4][3] = {{0, 0, 3}, {0, 0, 2}, {0, 0, 1}, {0, 0, 0}};
    CHECK_CELLS(s, e, 4);
    CHECK_NEAR(s.t[0], 3.0, 0);
    CHECK_NEAR(s.t[1], 3.5, 0);
    CHECK_NEAR(s.t[3], 4.5, 0);
    check_normal(s.normal[3], 0, 0, 1);
}

/* x crosses at t = 2,3,4,5 and y (from 0.75) at t = 1.5, 3.5, 5.5. */
static void test_diagonal_xy(void)
{
    Seq s;
    CHECK(march4(v3(-1, 0.25f, 0.5f), v3(1, 0.5f, 0), 0.0f, &s));
    int e[6][3] = {{0, 0, 0}, {0, 1, 0}, {1, 1, 0}, {2, 1, 0}, {2, 2, 0}, {3, 2, 0}};
    CHECK_CELLS(s, e, 6);
    float t[6] = {1, 1.5f, 2, 3, 3.5f, 4};
    for (int i = 0; i < 6 && i < s.n; i++)
        CHECK_NEAR(s.t[i], t[i], 1e-6);
    check_normal(s.normal[0], -1, 0, 0);
    check_normal(s.normal[1], 0, -1, 0);
    check_normal(s.normal[2], -1, 0, 0);
}

static void test_diagonal_negative(void)
{
    Seq s;
    CHECK(march4(v3(5, 3.75f, 0.5f), v3(-1, -0.5f, 0), 0.0f, &s));
    int e[7][3] = {{3, 3, 0}, {3, 2, 0}, {2, 2, 0}, {1, 2, 0}, {1, 1, 0}, {0, 1, 0}};
    CHECK_CELLS(s, e, 6);
    check_normal(s.normal[0], 1, 0, 0);
    check_normal(s.normal[1], 0, 1, 0);
    CHECK_NEAR(s.t[4], 3.5, 1e-6);
}

static void test_start_inside(void)
{
    Seq s;
    CHECK(march4(v3(1.5f, 1.5f, 1.5f), v3(0, 0, 1), 0.0f, &s));
    int e[3][3] = {{1, 1, 1}, {1, 1, 2}, {1, 1, 3}};
    CHECK_CELLS(s, e, 3);
    CHECK_NEAR(s.t[0], 0.0, 0);
    CHECK_NEAR(s.t[1], 0.5, 0);
    /* Started inside at tmin = 12, exactly on the z = 2 boundary: cell 2. */
    CHECK(march4(v3(1.5f, 1.5f, -10), v3(0, 0, 1), 12.0f, &s));
    int f[2][3] = {{1, 1, 2}, {1, 1, 3}};
    CHECK_CELLS(s, f, 2);
    CHECK_NEAR(s.t[0], 12.0, 0);
    /* Backwards from inside. */
    CHECK(march4(v3(3.2f, 0.5f, 2.5f), v3(-1, 0, 0), 0.0f, &s));
    int g[4][3] = {{3, 0, 2}, {2, 0, 2}, {1, 0, 2}, {0, 0, 2}};
    CHECK_CELLS(s, g, 4);
    CHECK_NEAR(s.t[1], 0.2, 1e-6);
}

static void test_axis_parallel_never_steps_other_axes(void)
{
    MarchingInfo mi;
    float p[3] = {0, 0, 0};
    Ray r = {v3(1.5f, -1, 2.5f), v3(0, 1, 0)};
    CHECK(march_init(&mi, &unit_box, four, p, &r, 0.0f, NULL));
    CHECK(isinf(mi.t_next[0]) && mi.t_next[0] > 0);
    CHECK(isinf(mi.t_next[2]) && mi.t_next[2] > 0);
    CHECK_NEAR(mi.t_next[1], 2.0, 0);
}

/* Through the corner (0,0) of cells diagonally: ties step x before y. */
static void test_grazing_inner_edges(void)
{
    Seq s;
    CHECK(march4(v3(-1, -1, 0.5f), v3(1, 1, 0), 0.0f, &s));
    int e[7][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {2, 1, 0}, {2, 2, 0}, {3, 2, 0}, {3, 3, 0}};
    CHECK_CELLS(s, e, 7);
    check_normal(s.normal[0], -1, 0, 0); /* tie at entry: the x face */
}

static void test_through_corners_3d(void)
{
    Seq s;
    CHECK(march4(v3(-1, -1, -1), v3(1, 1, 1), 0.0f, &s));
    int e[10][3] = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {1, 1, 1}, {2, 1, 1},
                    {2, 2, 1}, {2, 2, 2}, {3, 2, 2}, {3, 3, 2}, {3, 3, 3}};
    CHECK_CELLS(s, e, 10);
}

/* Touches the box only along its edge x = 0, y = 4: the closed slab test accepts the
 * single touching cell. */
static void test_grazing_outer_edge(void)
{
    Seq s;
    CHECK(march4(v3(-1, 3, 2.5f), v3(1, 1, 0), 0.0f, &s));
    int e[1][3] = {{0, 3, 2}};
    CHECK_CELLS(s, e, 1);
    /* Running along a face of the box (y = 0): the border cells. */
    CHECK(march4(v3(-1, 0, 0.5f), v3(1, 0, 0), 0.0f, &s));
    int f[4][3] = {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}};
    CHECK_CELLS(s, f, 4);
}

static void test_misses(void)
{
    Seq s;
    CHECK(!march4(v3(-1, 5, 0.5f), v3(1, 0, 0), 0.0f, &s));        /* passes above */
    CHECK(!march4(v3(-1, 3.5f, 0.5f), v3(1, 1, 0), 0.0f, &s));     /* clips past the corner */
    CHECK(!march4(v3(10, 1, 1), v3(1, 0, 0), 0.0f, &s));           /* box behind */
    CHECK(!march4(v3(-1, 1, 1), v3(1, 0, 0), 5.5f, &s));            /* box before tmin */
    CHECK(!march4(v3(1, 1, 1), v3(0, 0, 0), 0.0f, &s));             /* no direction */
    /* Orthographic rays (tmin = -inf) see the box behind the origin. */
    CHECK(march4(v3(10, 1.5f, 1.5f), v3(1, 0, 0), -INFINITY, &s));
    int e[4][3] = {{0, 1, 1}, {1, 1, 1}, {2, 1, 1}, {3, 1, 1}};
    CHECK_CELLS(s, e, 4);
    CHECK_NEAR(s.t[0], -10.0, 0);
}

static void test_padding_widens_only_the_slab(void)
{
    Seq s;
    CHECK(!run(&unit_box, four, 0.0f, v3(-1, 4.0005f, 0.5f), v3(1, 0, 0), 0.0f, &s, NULL));
    CHECK(run(&unit_box, four, 0.001f, v3(-1, 4.0005f, 0.5f), v3(1, 0, 0), 0.0f, &s, NULL));
    int e[4][3] = {{0, 3, 0}, {1, 3, 0}, {2, 3, 0}, {3, 3, 0}};
    CHECK_CELLS(s, e, 4);
}

static void test_non_cubic_cells(void)
{
    /* Box [-1,1] x [0,3] x [2,2.5] with 2 x 3 x 1 cells: cells 1 x 1 x 0.5. */
    BBox b = {{-1, 0, 2}, {1, 3, 2.5f}};
    int n[3] = {2, 3, 1};
    Seq s;
    CHECK(run(&b, n, 0.0f, v3(-2, 0.5f, 2.25f), v3(1, 0.5f, 0), 0.0f, &s, NULL));
    /* x crosses -1 at t=1 (y=1.0 there), x=0 at t=2 (y=1.5), y=2 at t=4 (x=2: out). */
    int e[3][3] = {{0, 1, 0}, {1, 1, 0}};
    CHECK_CELLS(s, e, 2);
    CHECK(run(&b, n, 0.0f, v3(0.5f, 5, 2.25f), v3(0, -1, 0), 0.0f, &s, NULL));
    int f[3][3] = {{1, 2, 0}, {1, 1, 0}, {1, 0, 0}};
    CHECK_CELLS(s, f, 3);
}

static void test_counts_every_visited_cell(void)
{
    RenderCtx ctx;
    memset(&ctx, 0, sizeof ctx);
    Seq s;
    CHECK(run(&unit_box, four, 0.0f, v3(-1, 0.25f, 0.5f), v3(1, 0.5f, 0), 0.0f, &s, &ctx));
    CHECK_INT(ctx.stats.cells_traversed, 6);
    CHECK(run(&unit_box, four, 0.0f, v3(1.5f, 1.5f, 1.5f), v3(0, 0, 1), 0.0f, &s, &ctx));
    CHECK_INT(ctx.stats.cells_traversed, 9);
    CHECK(!run(&unit_box, four, 0.0f, v3(-1, 5, 0.5f), v3(1, 0, 0), 0.0f, &s, &ctx));
    CHECK_INT(ctx.stats.cells_traversed, 9);
}

/* With a ray tree attached, every visited cell is recorded with its entered face; a
 * march starting inside records no face for its first cell (the GUI's `g` modes). */
static void test_records_cells_in_ray_tree(void)
{
    RenderCtx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.tree = calloc(1, sizeof *ctx.tree);
    CHECK(ctx.tree != NULL);
    if (!ctx.tree)
        return;
    ray_tree_clear(ctx.tree);
    Seq s;
    CHECK(run(&unit_box, four, 0.0f, v3(-1, 0.25f, 0.5f), v3(1, 0.5f, 0), 0.0f, &s, &ctx));
    CHECK_INT(ctx.tree->num_cells, 6);
    CHECK(ctx.tree->cells[1].i == 0 && ctx.tree->cells[1].j == 1 && ctx.tree->cells[1].k == 0);
    check_normal(ctx.tree->cells[0].entered_normal, -1, 0, 0);
    check_normal(ctx.tree->cells[1].entered_normal, 0, -1, 0);
    ray_tree_clear(ctx.tree);
    CHECK(run(&unit_box, four, 0.0f, v3(1.5f, 1.5f, 1.5f), v3(0, 0, 1), 0.0f, &s, &ctx));
    CHECK_INT(ctx.tree->num_cells, 3);
    check_normal(ctx.tree->cells[0].entered_normal, 0, 0, 0);
    check_normal(ctx.tree->cells[1].entered_normal, 0, 0, -1);
    free(ctx.tree);
}

/* The recomputed boundaries stay exact over a long march (no accumulated drift). */
static void test_long_march_boundaries(void)
{
    BBox b = {{0, 0, 0}, {1000, 1, 1}};
    int n[3] = {1000, 1, 1};
    MarchingInfo mi;
    float p[3] = {0, 0, 0};
    Ray r = {v3(-0.5f, 0.5f, 0.5f), v3(1, 0, 0)};
    CHECK(march_init(&mi, &b, n, p, &r, 0.0f, NULL));
    int steps = 1;
    while (march_next(&mi, NULL))
        steps++;
    CHECK_INT(steps, 1000);
    CHECK_INT(mi.cell[0], 999);
    CHECK_NEAR(mi.t, 999.5, 0);
}

static const TestCase tests[] = {
    {"enter_from_minus_x", test_enter_from_minus_x},
    {"enter_from_plus_x", test_enter_from_plus_x},
    {"enter_from_minus_y", test_enter_from_minus_y},
    {"enter_from_plus_y", test_enter_from_plus_y},
    {"enter_from_minus_z", test_enter_from_minus_z},
    {"enter_from_plus_z", test_enter_from_plus_z},
    {"diagonal_xy", test_diagonal_xy},
    {"diagonal_negative", test_diagonal_negative},
    {"start_inside", test_start_inside},
    {"axis_parallel_never_steps_other_axes", test_axis_parallel_never_steps_other_axes},
    {"grazing_inner_edges", test_grazing_inner_edges},
    {"through_corners_3d", test_through_corners_3d},
    {"grazing_outer_edge", test_grazing_outer_edge},
    {"misses", test_misses},
    {"padding_widens_only_the_slab", test_padding_widens_only_the_slab},
    {"non_cubic_cells", test_non_cubic_cells},
    {"counts_every_visited_cell", test_counts_every_visited_cell},
    {"long_march_boundaries", test_long_march_boundaries},
    {"records_cells_in_ray_tree", test_records_cells_in_ray_tree},
};

RT_TEST_MAIN(tests)
