/* TwoLevelGrid: an accelerator for scenes of uneven density (Kalojanov, Billeter,
 * Slusallek, "Two-Level Grids for Ray Tracing on GPUs", 2011). A coarse uniform grid
 * (the course Grid, rt/grid.h) whose crowded cells each hold a grid of their own, sized
 * from that cell's own primitive count and fitted to the box its primitives occupy in
 * the cell. Answers are exactly the brute-force loop's (same t, normal, material, id).
 * Built once, then read-only (shared by threads). docs/twolevel.md explains the choices. */
#ifndef RT_TWOLEVEL_H
#define RT_TWOLEVEL_H

#include <stdbool.h>
#include <stdint.h>
#include "rt/accel.h"
#include "rt/diag.h"
#include "rt/grid.h"
#include "rt/prim.h"

typedef struct TwoLevelGrid TwoLevelGrid;

/* Builds the two levels over the table's bounded primitives (t borrowed: it must
 * outlive the grid) in bounded time and memory (entries capped by a multiple of the
 * primitive count, whatever the input). NULL with an error in diag when out of memory;
 * NULL WITHOUT an error when nothing is bounded (as grid_build_table). */
TwoLevelGrid *twolevel_build(const PrimTable *t, Diag *diag);
void twolevel_free(TwoLevelGrid *t);

/* How crowded the scene is at the top level's resolution: the mean, over bounded
 * primitives, of how many primitives have their box centre in the same top cell. About
 * the top cells' average for even scenes; the size of the dense part for a dense mesh
 * in a big sparse scene. 0 without bounded primitives. */
double twolevel_crowding(const PrimTable *t);
/* Whether -grid auto should build the two-level grid: the crowding is far above what
 * a surface spread over the whole scene gives (docs/twolevel.md). */
bool twolevel_preferred(const PrimTable *t);

/* The accelerator "twolevel" (registered in accel.c), and the grid behind an Accel
 * built with it (NULL for any other). */
extern const AccelOps accel_twolevel_ops;
const TwoLevelGrid *twolevel_of_accel(const Accel *a);

/* The top level: a course Grid (bounds, resolution, marking, mailbox size, packets and
 * -visualize_grid all come from it). Owned by t. */
Grid *twolevel_top(const TwoLevelGrid *t);
/* Number of top cells with a grid of their own, and the cells of all those grids. */
void twolevel_counts(const TwoLevelGrid *t, uint32_t *subgrids, uint64_t *leaf_cells);

/* Nearest hit with t > tmin (as grid_intersect); counts every top cell and every leaf
 * cell visited in cells_traversed and every primitive test in intersections. */
bool twolevel_intersect(const TwoLevelGrid *t, const Ray *ray, Hit *hit, float tmin,
                        RenderCtx *ctx);
/* Is anything hit with tmin < t < tmax? (as grid_occluded) */
bool twolevel_occluded(const TwoLevelGrid *t, const Ray *ray, float tmin, float tmax,
                       RenderCtx *ctx);

#endif
