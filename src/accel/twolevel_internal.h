/* Private layout of the TwoLevelGrid (rt/twolevel.h), shared by its build (twolevel.c)
 * and its walk, which lives beside the uniform grid's cast (grid_cast.c) so that it
 * inlines the same march and cell loop instead of calling them per cell. */
#ifndef RT_ACCEL_TWOLEVEL_INTERNAL_H
#define RT_ACCEL_TWOLEVEL_INTERNAL_H

#include <stdint.h>
#include "grid_internal.h"
#include "rt/twolevel.h"

#define TWOLEVEL_NO_SUB UINT32_MAX

/* One top cell's leaf grid: it tiles box (the cell's primitives clipped to the cell,
 * thin axes widened) with n cells; its cells are base.. in TwoLevelGrid.start. */
typedef struct SubGrid {
    BBox box;
    int n[3];
    float pad[3];   /* rounding margin per axis, as the course Grid's (grid.c) */
    float min_pad;
    /* march_init's per-grid constants for (box, n, pad), computed once by its own float
     * expressions, as the course Grid keeps them (Grid.inv_size, slab_lo, slab_hi): the
     * walk's march then takes the same cells and t's without four divisions per leaf
     * grid a ray enters. */
    float size[3], inv_size[3], slab_lo[3], slab_hi[3];
    uint32_t base;
    uint32_t big_start, big_count; /* the cell's large entries, in items: tested for
                                      every ray entering the cell, kept out of the leaf
                                      grid so it fits the small ones tightly */
} SubGrid;

struct TwoLevelGrid {
    Grid *top;
    uint32_t *sub_of;      /* per top cell: index into subs, or TWOLEVEL_NO_SUB (its own list) */
    SubGrid *subs;
    uint32_t num_subs, cap_subs;
    uint32_t *start;       /* leaf cells + 1 offsets into items (CSR) */
    uint32_t *items;       /* entries, in the top grid's cell_items format */
    size_t num_cells, cap_cells, num_items, cap_items;
};

#endif
