/* -grid auto: a grid resolution chosen from the scene. The rule (docs/grid.md): about
 * GRID_AUTO_LAMBDA cells per bounded primitive, with cells as close to cubes as the
 * box allows (resolution proportional to the box's sides). */
#include <math.h>

#include "rt/geom.h"
#include "rt/grid.h"
#include "rt/scene.h"

/* Cells per primitive. Measured on the course scenes (docs/grid.md). */
#define GRID_AUTO_LAMBDA 4.0
#define GRID_AUTO_MAX_AXIS 512
#define GRID_AUTO_MAX_CELLS (1 << 22)

/* Leaves that go into cells (everything but planes). */
static uint64_t count_bounded(const Object3D *o, int depth)
{
    if (!o || depth > RT_MAX_NESTING)
        return 0;
    switch (obj_kind(o)) {
    case OBJ_GROUP: {
        uint64_t n = 0;
        for (int i = 0; i < group_count(o); i++)
            n += count_bounded(group_child(o, i), depth + 1);
        return n;
    }
    case OBJ_TRANSFORM:
        return count_bounded(transform_child(o), depth + 1);
    case OBJ_PLANE:
        return 0;
    default:
        return 1;
    }
}

void grid_choose_auto(const Scene *scene, int n[3])
{
    n[0] = n[1] = n[2] = 1;
    if (!scene || !scene->root || bbox_is_empty(&scene->bounds))
        return;
    double prims = (double)count_bounded(scene->root, 0);
    if (prims < 1.0)
        prims = 1.0;
    double e[3], emax = 0.0;
    for (int a = 0; a < 3; a++) {
        e[a] = (double)v3_comp(scene->bounds.max, a) - (double)v3_comp(scene->bounds.min, a);
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
}
