/* -grid auto: a grid resolution chosen from the scene. The rule (docs/grid.md): about
 * GRID_AUTO_LAMBDA cells per bounded primitive, with cells as close to cubes as the
 * box allows (resolution proportional to the box's sides); then the primitives' sizes:
 * coarser until their cell references fit the auto budget (grid_ref_cap_auto), so
 * large or piled-up primitives do not multiply the build's time and memory. */
#include <math.h>

#include "rt/grid.h"
#include "rt/prim.h"

/* Cells per primitive. Measured on the course scenes (docs/grid.md). */
#define GRID_AUTO_LAMBDA 4.0
#define GRID_AUTO_MAX_AXIS 512
/* At most about a million cells: on the 1.3M-triangle blob of bench/blob.txt (a surface
 * in a box mostly empty) the packet walk traced 1080p 12% faster for camera rays and 9%
 * faster for shadow rays on 103x106x96 (1.05M cells) than on the 164x168x153 (4.2M) the
 * count gives, and no slower on the 3.3M-triangle row of bench/bigmesh.txt (2M cells
 * before); the cells a ray crosses cost more there than the tests they save. Only
 * scenes of more than 262,144 bounded primitives reach the cap. */
#define GRID_AUTO_MAX_CELLS (1 << 20)

void grid_choose_auto(const PrimTable *t, int n[3])
{
    n[0] = n[1] = n[2] = 1;
    if (!t || bbox_is_empty(&t->scene_bounds))
        return;
    /* The leaves that go into cells (everything but planes). */
    double prims = (double)t->num_bounded;
    if (prims < 1.0)
        prims = 1.0;
    double e[3], emax = 0.0;
    for (int a = 0; a < 3; a++) {
        e[a] = (double)v3_comp(t->scene_bounds.max, a) - (double)v3_comp(t->scene_bounds.min, a);
        if (!isfinite(e[a]) || e[a] < 0.0)
            return;
        emax = fmax(emax, e[a]);
    }
    if (!(emax > 0.0))
        return;
    /* Axes thinner than 1/1000 of the largest get one cell; the others share the
     * cell budget so that cells are near-cubes: n_a = e_a * k, prod n_a = lambda * N. */
    double vol = 1.0;
    int dims = 0;
    for (int a = 0; a < 3; a++)
        if (e[a] > 1e-3 * emax) {
            vol *= e[a];
            dims++;
        }
    double target = fmin(GRID_AUTO_LAMBDA * prims, (double)GRID_AUTO_MAX_CELLS);
    double k = pow(target / vol, 1.0 / dims);
    for (int a = 0; a < 3; a++) {
        if (!(e[a] > 1e-3 * emax))
            continue;
        double v = floor(e[a] * k + 0.5);
        n[a] = v < 1.0 ? 1 : v > GRID_AUTO_MAX_AXIS ? GRID_AUTO_MAX_AXIS : (int)v;
    }
    grid_fit_refs(t, n, grid_ref_cap_auto(t->num_bounded), NULL);
}
