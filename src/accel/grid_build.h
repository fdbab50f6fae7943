/* Private to src/accel: the grid build's parts (grid.c lifecycle, grid_bin.c the
 * parallel binning, grid_course.c the course's occupancy counts, grid_cells.c the
 * marching sets) and, for its tests, the triangle/cell overlap of the marching sets. */
#ifndef RT_ACCEL_GRID_BUILD_H
#define RT_ACCEL_GRID_BUILD_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "grid_internal.h"

/* Primitives per chunk of the binning passes: enough to make handing out a chunk cheap,
 * few enough that the threads finish close together (40 chunks on the 40k bunny). */
enum { BIN_CHUNK = 1024 };

/* How a primitive is binned. The course's occupancy rules: an untransformed sphere
 * occupies the cells whose centre lies within r + half a cell diagonal of its centre
 * (REC_SPHERE); anything else the cells its world box touches (a triangle: of its world
 * vertices, REC_TRIANGLE; any other leaf: its bounds op, REC_BOX). The marching sets:
 * triangles by the fast path of grid_cells.c, anything else by its cell_bounds and
 * overlaps_box ops. A new primitive needs no code here. */
typedef enum RecKind { REC_SPHERE, REC_TRIANGLE, REC_BOX } RecKind;

/* A primitive with what its insertion needs in world space, made by the binning pass
 * (bin_part) from the walk's GridPrim and kept on its stack. */
struct GridBuildRec {
    const Object3D *obj;
    const PrimXform *gp;  /* NULL: no Transform above it */
    RecKind kind;
    Vec3 v[3];            /* sphere: v[0] = centre; triangle: world vertices; box:
                             v[0], v[1] = world box min, max */
    float r;              /* sphere radius */
};

/* One binning worker's scratch (rt/par.h): its own counts and cell list, so workers
 * share nothing they write (worker 0 writes the grid's arrays). Each on a cache line of
 * its own: push_pair writes num_pairs for every entry, and with two workers' parts on
 * one line that line went back and forth between the cores (2 threads, 40k bunny: the
 * binning's CPU 6.7 -> 5.7 ms, wall 3.5 -> 3.0 ms). Which worker bins which
 * primitives varies from run to run; the result does not: the counts are sums, and the
 * fill pass reads the chunks' cell lists in primitive order. */
typedef struct BinPart {
    _Alignas(64) const Grid *g;
    const double *cell_axis; /* GridBuild.cell_axis */
    uint32_t *count;      /* per cell: marching entries (worker 0: g->cell_start + 1) */
    uint32_t *pairs;      /* cells of each binned primitive's marching set, in order */
    size_t num_pairs, cap_pairs;
    bool oom, too_many, stopped;
} BinPart;

typedef struct CellRange {
    int lo[3], hi[3];
} CellRange;

/* The cell ranges below are ceil(y) - 1 and floor(z), clamped to [0, n-1], where NaN
 * and everything below 0 give 0. Written with compares and one conversion instead of
 * ceil/floor (libm calls without SSE4.1), with the same result for every input:
 * ceil(y) - 1 >= 0 iff y > 0, ceil(y) - 1 >= n - 1 iff y > n - 1, floor(z) >= 0 iff
 * z >= 0, floor(z) >= n - 1 iff z >= n - 1; in between, y and z are small positive
 * numbers whose conversion truncates exactly. n <= 2^24, so n - 1 is exact. The course's
 * float rule passes its floats widened: the same compares, the same answers. */
static inline int grid_range_lo(double y, int n)
{
    if (!(y > 0.0))
        return 0;
    if (y > (double)(n - 1))
        return n - 1;
    int i = (int)y;
    return (double)i < y ? i : i - 1;
}

static inline int grid_range_hi(double z, int n)
{
    if (!(z >= 0.0))
        return 0;
    if (z >= (double)(n - 1))
        return n - 1;
    return (int)z;
}

/* The build-time state of one grid (grid.c keeps it on its stack while it builds; the
 * Grid holds only what the queries read). */
typedef struct GridBuild {
    Grid *g;
    uint32_t *prim_ncells;  /* per prim: its RecKind until binned, then the number of
                               cells of its marching set */
    double *cell_axis;      /* per axis and cell: padded bounds, centre, half sizes */
    bool too_many;          /* more marching entries than a uint32_t index can hold */
    bool stopped;           /* cut short: a stop was requested (rt/par.h) */
} GridBuild;

/* A binning chunk's cells: its run in the pairs of the worker that binned it. */
typedef struct BinChunk {
    size_t off, len;
    int worker;
} BinChunk;

/* grid_bin.c: the CSR fill, on one thread: primitive p (of n, in chunks of BIN_CHUNK)
 * goes into each of its ncells[p] cells, listed in order in part[chunk[k].worker].pairs
 * from chunk[k].off for its chunk k: items[cursor[cell]++] = p. False, the items cut
 * short, when a stop was requested (rt/par.h: looked at every FILL_STOP_CHUNKS chunks,
 * from the last of the first FILL_STOP_CHUNKS on). */
enum { FILL_STOP_CHUNKS = 64 };
bool grid_fill_items(uint32_t *items, uint32_t *cursor, const uint32_t *ncells, uint32_t n,
                     const BinChunk *chunk, const BinPart *part);

/* grid_cache.c: a table primitive by its leaf and Transforms, and its index in the
 * table; sorted by (obj, xf) to find each grid primitive's index. */
typedef struct PrimRef {
    const Object3D *obj;
    const PrimXform *xf;
    uint32_t index;
} PrimRef;
/* Sorts refs[0..n) by (obj, xf) as addresses, stably, with tmp (n refs) as scratch.
 * False, refs left in some order, when a stop was requested (rt/par.h: looked at every
 * SORT_STOP refs moved). */
enum { SORT_STOP = 65536 };
bool grid_cache_sort_refs(PrimRef *refs, uint32_t n, PrimRef *tmp);

/* grid_bin.c: the marching sets, the CSR arrays and grid_pack, on the set-up threads. False when out of memory, with b->too_many when the entries
 * overflow a uint32_t, or with b->stopped when a stop was requested (the binning and
 * the pack look before each chunk: a stop ends the build within a chunk's time). */
bool grid_bin_fill_pack(GridBuild *b);
/* Frees the build-time arrays (prim_ncells, cell_axis). */
void grid_free_build_state(GridBuild *b);

/* grid_course.c: adds rec's cells by the course's rules to course[] (per-cell counts). */
void grid_course_insert(const Grid *g, uint32_t *course, const GridBuildRec *rec);
/* The number of cells grid_course_insert visits for rec (its box range). */
uint64_t grid_course_box_cells(const Grid *g, const GridBuildRec *rec);

/* grid.c: the cells' geometry (box, sizes, pads) of g from g->bounds and g->n. */
void grid_setup_geometry(Grid *g);
/* grid_bin.c: how a bounded primitive of the table is binned, and its record. */
RecKind grid_rec_kind(const Prim *p);
/* The same from a grid's primitive (its leaf and Transforms). */
RecKind grid_prim_rec_kind(const GridPrim *gp);
void grid_make_rec(const GridPrim *gp, RecKind kind, GridBuildRec *rec);
/* grid_cells.c: the number of cells grid_tight_insert visits for rec (its padded box
 * range): an upper bound on its marching entries. */
uint64_t grid_tight_box_cells(const Grid *g, const GridBuildRec *rec);

/* grid_cells.c: the per-axis cell tables of the triangle fast path (false: out of
 * memory), and the marching set of rec: its cells counted into bp->count and listed in
 * bp->pairs (false when out of memory or out of entries). */
bool grid_setup_cell_axis(GridBuild *b);
bool grid_tight_insert(BinPart *bp, const GridBuildRec *rec, uint32_t *ncells);

/* The reference: separating-axis test of the triangle v (relative to the box centre)
 * against the box of half extents h (Akenine-Moller 2001). */
bool grid_tri_box_overlap(double v[3][3], const double h[3]);
/* What the build uses: the same answer by a shortcut when a vertex is well inside. */
bool grid_tri_cell_overlap(double v[3][3], const double h[3]);
/* grid_tri_cell_overlap with its vertex flags given: in[k] must be (|v[k][a]| <=
 * h[a] * GRID_INSIDE_SHRINK on every axis a), as it computes them (the leaf builds of
 * twolevel.c compute them per axis, once per row of cells). */
#define GRID_INSIDE_SHRINK (1.0 - 0x1p-30)
bool grid_tri_cell_overlap_in(double v[3][3], const double h[3], const bool in[3]);

#endif
