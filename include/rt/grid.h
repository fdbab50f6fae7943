/* Uniform grid over the scene's bounded primitives (A5/A6), stored flat (CSR: per-cell
 * offsets + one entry array). Planes and other unbounded primitives are kept in a
 * separate list tested for every ray. Built once, then read-only (shared by threads). */
#ifndef RT_GRID_H
#define RT_GRID_H

#include <stdbool.h>
#include <stdint.h>
#include "rt/diag.h"
#include "rt/accel.h"
#include "rt/object3d.h"

typedef struct Scene Scene;
typedef struct PrimTable PrimTable;
typedef struct Grid Grid;

/* Builds an nx*ny*nz grid over the table's scene box with the table's bounded
 * primitives in its cells (t is borrowed: it must outlive the grid). Returns NULL and
 * reports to diag on failure (out of memory, absurd resolution). Returns NULL WITHOUT
 * an error when the table has no bounded primitive (only planes): then there is simply
 * no grid. */
Grid *grid_build_table(const PrimTable *t, int nx, int ny, int nz, Diag *diag);
/* The same over a primitive table of scene's that the grid builds and owns. */
Grid *grid_build(const Scene *scene, int nx, int ny, int nz, Diag *diag);
void grid_free(Grid *g);

BBox grid_bounds(const Grid *g);
void grid_dims(const Grid *g, int n[3]);
/* Number of entries in cell (i, j, k) (the visualisation "count"). */
int grid_cell_count(const Grid *g, int i, int j, int k);
/* Number of primitives the march would test in cell (i, j, k): the tighter, padded
 * marching set (exact sphere-surface / triangle-box tests), never smaller than needed. */
int grid_cell_marching_count(const Grid *g, int i, int j, int k);
/* Sum over all cells of the course counts and of the marching-set sizes. */
void grid_entry_totals(const Grid *g, uint64_t *course, uint64_t *marching);
/* Size the per-thread mailbox (RenderCtx.mailbox) must have. */
uint32_t grid_mailbox_size(const Grid *g);

/* Marking (mailboxing): on by default; main turns it off for the hidden option
 * -no_marking (the with/without analysis). Call before rendering only: the grid is shared read-only while rendering.
 * With marking off and a mailbox present, RtStats.repeat_tests counts the repeated
 * primitive tests marking would have avoided. */
void grid_set_marking(Grid *g, bool on);
bool grid_marking(const Grid *g);

/* RayCastFast: nearest hit with t > tmin, exactly the one the brute-force loop over
 * the scene finds (same t, normal, material, id). Counts cells and intersections. */
bool grid_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin, RenderCtx *ctx);
/* Shadow query: is anything hit with tmin < t < tmax? Stops at the first occluder. */
bool grid_occluded(const Grid *g, const Ray *ray, float tmin, float tmax, RenderCtx *ctx);
/* Ray packets: up to GRID_PACKET_MAX coherent rays (a tile of primary rays, or their
 * shadow rays) walked through the grid together, slice by slice along the packet's main
 * axis, with each cell's triangles tested against all rays at once in SIMD (coherent
 * grid traversal, Wald et al., SIGGRAPH 2006). Every answer is exactly the one the
 * single-ray query gives (same t, normal, material, id); only the counters differ: a
 * cell counts once per packet visit, a test once per ray it is run for. Rays that do
 * not fit the packet (other direction, grazing, far origin) go through the single-ray
 * march. Without ctx->packet_rays every ray goes through it. */
#define GRID_PACKET_MAX ACCEL_PACKET_MAX
/* Nearest hits: for every i < n, like grid_intersect(g, &rays[i], &hits[i], tmin, ctx)
 * (hits are in/out, as there). Returns the mask of rays that found a hit (bit i). */
uint64_t grid_intersect_packet(const Grid *g, const Ray *rays, int n, Hit *hits, float tmin,
                               RenderCtx *ctx);
/* Shadow queries for the rays in mask: bit i of the result is
 * grid_occluded(g, &rays[i], tmin, tmax[i], ctx). */
uint64_t grid_occluded_packet(const Grid *g, const Ray *rays, uint64_t mask, float tmin,
                              const float *tmax, RenderCtx *ctx);
/* Shadow rays towards a directional light: bit i of the result is grid_occluded(g,
 * ray, tmin, tmax, ctx) for the ray from rays[i].origin in direction dir (the rays'
 * own directions are not read). The same answers and counters; the packet's set-up
 * reads no direction and divides once. */
uint64_t grid_occluded_packet_dir(const Grid *g, const Ray *rays, uint64_t mask, float tmin,
                                  float tmax, Vec3 dir, RenderCtx *ctx);
/* Which SIMD kernel the packets use: "avx2" or "generic" (the CPU is asked once), or
 * "avx512" when asked for below. */
const char *grid_packet_kernel(void);
/* Tests and benchmarks: makes every packet use kernel `name` ("generic", or "avx2" or
 * "avx512" when the CPU has it); false when it cannot. Not while rendering. */
bool grid_packet_use_kernel(const char *name);

/* -visualize_grid: the first non-empty cell along the ray, as a hit (t = cell entry,
 * normal = entered face, material = palette colour of its count). Planes not drawn. */
bool grid_visualize_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin,
                              RenderCtx *ctx);
/* Shadow rays in that mode: the drawn cells are the scene, so they cast the shadows
 * (an occupied cell entered with tmin < t < tmax). */
bool grid_visualize_occluded(const Grid *g, const Ray *ray, float tmin, float tmax,
                             RenderCtx *ctx);
/* The ops of an accelerator's -visualize_grid mode (its AccelOps.visualize): the same
 * state as the accelerator (create, destroy, scratch, report), queries that hit the
 * drawn cells instead of the scene; no packets. */
#define GRID_CELLS_OPS(name_, summary_, create_, destroy_, cells_intersect, cells_occluded,  \
                       scratch_, report_)                                                    \
    {                                                                                        \
        .name = name_, .summary = summary_, .create = create_, .destroy = destroy_,          \
        .intersect = cells_intersect, .occluded = cells_occluded, .scratch_size = scratch_,  \
        .report = report_                                                                    \
    }

/* The palette of -visualize_grid: a diffuse, non-specular material per entry count,
 * 1 white, then magenta, blue, cyan, green, yellow, orange towards red at 17 and more
 * (count 0 and below take count 1's). Built once, shared, freed at exit. */
const Material *grid_palette_material(int count);

/* Packed triangles (on by default): untransformed triangles are intersected inline from
 * a packed copy instead of through their ops. Same hits either way; tests that count
 * calls of the ops turn it off. */
void grid_set_packing(Grid *g, bool on);
bool grid_packing(const Grid *g);

/* Cell references: the entries a grid stores and the cells its build visits, summed
 * over the bounded primitives (each counts the cells of its box range in the marching
 * sets and in the course's counts, whichever is more). Unbounded by the primitive count
 * alone (a big primitive covers many cells), so every build is held to a cap:
 * GRID_REFS_PER_PRIM per bounded primitive plus GRID_REFS_FLOOR. A requested resolution
 * over the cap is built coarser (same proportions), with a warning. -grid auto keeps
 * to a tighter budget of its own. The course's lines and the project's scenes stay far
 * below both (docs/grid.md). A primitive smaller than a cell costs at most 27 (its
 * course box: the sphere rule reaches half a cell diagonal around it), so only
 * primitives larger than a few cells can reach 32 per primitive. */
#define GRID_REFS_PER_PRIM 32
#define GRID_REFS_FLOOR (1u << 20)
#define GRID_AUTO_REFS_PER_PRIM 32
#define GRID_AUTO_REFS_FLOOR (1u << 16)
uint64_t grid_ref_cap(uint32_t num_bounded);
uint64_t grid_ref_cap_auto(uint32_t num_bounded);
/* The cell references an n[0] x n[1] x n[2] grid over t would make (an upper bound on
 * grid_entry_totals' two sums, each). O(primitives), nothing allocated. */
uint64_t grid_ref_estimate(const PrimTable *t, const int n[3]);
/* Shrinks n (every axis by the same factor, at least 1 cell) until the estimate is at
 * most cap (always reached: one cell makes one reference per primitive). True when n
 * changed; *est (may be NULL) gets the estimate of the final n. */
bool grid_fit_refs(const PrimTable *t, int n[3], uint64_t cap, uint64_t *est);

/* -grid auto: a resolution chosen from the table's scene box, number of bounded
 * primitives and their sizes (docs/grid.md explains the rule): about GRID_AUTO_LAMBDA
 * cells per primitive, then coarser until the references fit grid_ref_cap_auto. */
void grid_choose_auto(const PrimTable *t, int n[3]);
/* The grid behind an accelerator built by "grid" (for drawing its cells); NULL for any
 * other accelerator. */
const Grid *grid_of_accel(const Accel *a);
/* The accelerator "grid" over a grid built by the caller (tests, tools), who keeps
 * owning it: free the grid, never this Accel. */
Accel grid_as_accel(Grid *g);


#endif
