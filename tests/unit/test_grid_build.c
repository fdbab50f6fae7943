/* The grid build's triangle/cell overlap shortcut (a vertex well inside the cell
 * decides without the full separating-axis test) against the reference test, on random
 * and adversarial triangles: vertices on the faces, at the shortcut's threshold to the
 * ulp, degenerate and sliver triangles, at scales from 1e-6 to 1e6. */
#include <math.h>
#include <stdint.h>

#include "../harness.h"
#include "../../src/accel/grid_build.h"

static uint64_t g_rng = 0x9e3779b97f4a7c15ull;

static uint64_t rnd(void)
{
    g_rng ^= g_rng << 13;
    g_rng ^= g_rng >> 7;
    g_rng ^= g_rng << 17;
    return g_rng;
}

static double unit(void) { return (double)(rnd() >> 11) * 0x1p-53; }     /* [0, 1) */
static double sym(void) { return 2.0 * unit() - 1.0; }                     /* [-1, 1) */

/* A coordinate for axis half extent h, drawn from the spots where rounding decides. */
static double coord(double h)
{
    double sgn = (rnd() & 1) ? 1.0 : -1.0;
    double x;
    switch (rnd() % 8) {
    case 0: x = h; break;                               /* on the face */
    case 1: x = h * (1.0 - 0x1p-30); break;             /* the shortcut's bound */
    case 2: x = h * (1.0 - 0x1p-30) * (1.0 + 0x1p-52); break;
    case 3: x = h * (1.0 + 1e-12 * sym()); break;       /* ulps around the face */
    case 4: x = 0.0; break;
    default: x = 2.5 * h * unit(); break;               /* anywhere near the box */
    }
    int nudge = (int)(rnd() % 5) - 2;
    for (; nudge > 0; nudge--)
        x = nextafter(x, HUGE_VAL);
    for (; nudge < 0; nudge++)
        x = nextafter(x, -HUGE_VAL);
    return sgn * x;
}

static void make_case(double v[3][3], double h[3])
{
    double scale = pow(10.0, (double)((int)(rnd() % 13) - 6));
    for (int a = 0; a < 3; a++)
        h[a] = scale * (0.05 + unit());
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++)
            v[k][a] = coord(h[a]);
    switch (rnd() % 6) {
    case 0: /* a repeated vertex */
        for (int a = 0; a < 3; a++)
            v[2][a] = v[(int)(rnd() % 2)][a];
        break;
    case 1: { /* collinear */
        double t = sym() * 2.0;
        for (int a = 0; a < 3; a++)
            v[2][a] = v[0][a] + t * (v[1][a] - v[0][a]);
        break;
    }
    case 2: /* a sliver: the third vertex a hair off the first edge */
        for (int a = 0; a < 3; a++)
            v[2][a] = 0.5 * (v[0][a] + v[1][a]) + 1e-9 * scale * sym();
        break;
    default:
        break;
    }
}

static void test_shortcut_matches_sat(void)
{
    long cases = 0, overlaps = 0, inside = 0, mismatches = 0;
    for (int n = 0; n < 2000000; n++) {
        double v[3][3], h[3];
        make_case(v, h);
        double v1[3][3], v2[3][3];
        memcpy(v1, v, sizeof v);
        memcpy(v2, v, sizeof v);
        bool ref = grid_tri_box_overlap(v1, h);
        bool fast = grid_tri_cell_overlap(v2, h);
        cases++;
        overlaps += ref;
        for (int k = 0; k < 3; k++)
            if (fabs(v[k][0]) <= h[0] * (1.0 - 0x1p-30) && fabs(v[k][1]) <= h[1] * (1.0 - 0x1p-30) &&
                fabs(v[k][2]) <= h[2] * (1.0 - 0x1p-30)) {
                inside++;
                break;
            }
        if (ref != fast && mismatches++ < 5)
            CHECK_MSG(0, "case %d: SAT says %d, shortcut says %d: v = (%a %a %a) (%a %a %a) "
                         "(%a %a %a), h = (%a %a %a)",
                      n, ref, fast, v[0][0], v[0][1], v[0][2], v[1][0], v[1][1], v[1][2],
                      v[2][0], v[2][1], v[2][2], h[0], h[1], h[2]);
    }
    CHECK_INT(mismatches, 0);
    /* The draw must exercise both answers and the shortcut itself. */
    CHECK_MSG(overlaps > cases / 10 && overlaps < cases - cases / 10,
              "%ld overlaps of %ld cases", overlaps, cases);
    CHECK_MSG(inside > cases / 10, "only %ld of %ld cases had a vertex inside", inside, cases);
}

static const TestCase tests[] = {
    {"shortcut_matches_sat", test_shortcut_matches_sat},
};

RT_TEST_MAIN(tests)
