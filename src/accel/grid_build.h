/* Private to src/accel and its tests: the triangle/cell overlap of the grid build
 * (grid.c), exported so a test can hold the fast path to the reference test. */
#ifndef RT_ACCEL_GRID_BUILD_H
#define RT_ACCEL_GRID_BUILD_H

#include <stdbool.h>

/* The reference: separating-axis test of the triangle v (relative to the box centre)
 * against the box of half extents h (Akenine-Moller 2001). */
bool grid_tri_box_overlap(double v[3][3], const double h[3]);
/* What the build uses: the same answer by a shortcut when a vertex is well inside. */
bool grid_tri_cell_overlap(double v[3][3], const double h[3]);

#endif
