/* Private layout of the uniform Grid, shared by the files of src/accel/ (build, casting,
 * visualisation). Nothing outside src/accel/ sees it. */
#ifndef RT_ACCEL_GRID_INTERNAL_H
#define RT_ACCEL_GRID_INTERNAL_H

#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdint.h>
#include <string.h>
#include "rt/grid.h"
#include "rt/marching_info.h"
#include "rt/geom.h"
#include "rt/prim.h"

/* fminf and fmaxf without the libm call (at -O2 for plain x86-64 they are calls: 240,000
 * of them per 40k triangles in the packing, two per ray leaving the box in the march's
 * band_needed): a NaN operand yields the other one, as with fminf. */
static inline float min_nan_last(float a, float b) { return (a < b || b != b) ? a : b; }
static inline float max_nan_last(float a, float b) { return (a > b || b != b) ? a : b; }

/* One primitive of the table as the march reads it: the leaf and the Transforms above it
 * (NULL: none). Its index in Grid.prims is its mailbox slot. */
typedef struct GridPrim {
    const Object3D *obj;
    const PrimXform *xf;
} GridPrim;

typedef struct GridBuildRec GridBuildRec;

/* The box of a packed triangle, widened by the grid's rounding pad on each axis (the
 * packet walk's cull, grid_packet_kernel.h): lo[a] <= every vertex's a - pad[a], and
 * hi[a] >= + pad[a]. Unused for primitives that are not packed. */
typedef struct TriBox {
    float lo[3], hi[3];
} TriBox;

/* An untransformed triangle as the hot loop reads it (grid_pack.c): 64 bytes, one
 * cache line in an aligned array, so the packet walk's cull and the test that may
 * follow it read one line. The first 48 are three 4-float rows for SIMD loads (v0, e1,
 * e2, then the id and two floats of the box, which those loads carry unused). */
typedef struct PackedTri {
    _Alignas(16) Vec3 v0;
    Vec3 e1, e2;
    uint32_t id;            /* depth-first id; RT_NO_ID: this primitive is not packed */
    TriBox box;
} PackedTri;
_Static_assert(sizeof(PackedTri) == 64, "a packed triangle is one cache line");

/* What a hit on a packed triangle records, read only at hits: the Triangle's normal
 * (triangle_normal's bits) and material, without reading the Triangle. */
typedef struct TriHit {
    Vec3 normal;
    const Material *material;
} TriHit;

struct Grid {
    BBox bounds;            /* the scene box as given (printed by -stats) */
    BBox box;               /* the box the cells tile: bounds, zero-thickness axes widened */
    int n[3];
    float size[3];          /* cell size per axis */
    float pad[3];           /* rounding margin (world units): cells are padded by it when
                               inserting for marching, and the march's slab test too */
    float min_pad;          /* smallest pad[a] */
    float band[3];          /* march_band_width of box and pad[a]: how far beyond the box's
                               faces the single-ray march goes on (lean_next_band) */
    /* march_init's per-grid constants, computed once by the same float expressions
     * (grid_setup_geometry) for the cast's own march (grid_cast.c): n[a] / extent,
     * and the padded slab's sides box.min - pad and box.max + pad. */
    float inv_size[3];
    float slab_lo[3], slab_hi[3];
    float box_mag;          /* largest |coordinate| of the box (march rounding bound) */
    uint32_t num_cells;
    uint32_t *cell_start;   /* num_cells + 1 offsets into cell_items (CSR) */
    uint32_t *cell_items;   /* indices into prims: the marching sets (tight insertion) */
    /* Bit c (word c / 64, bit c % 64) set when cell c has entries, or NULL: the
     * packet walk reads it before cell_start, so the empty cells it crosses (most of
     * them) cost a bit in an array 32 times smaller than cell_start (grid_pack.c,
     * grid_occupancy_make). The grid's own memory, also with a set-up cache. */
    uint64_t *occupied;
    /* The packet walk starts the loads of a cell's packed triangles together before
     * testing them: set by grid_occupancy_make only where tri is too big to stay in
     * the cache (a 1.3M-triangle mesh's 84 MB); on a 40k mesh (2.5 MB) the extra pass
     * over the entries cost 2.6% of the walk's instructions for misses it rarely has. */
    bool prefetch_tri;
    /* Per cell: entries by the course rules (grid_course.c), the -visualize_grid count.
     * Only -visualize_grid, the preview and -timings read them, so they are made on
     * first use (grid_course_counts) instead of by every build: a split render's
     * processes would each pay ~12% of their set-up for nothing. */
    uint32_t *_Atomic course_count;
    pthread_mutex_t course_lock;
    GridPrim *prims;        /* bounded primitives, depth-first order */
    uint32_t num_prims;
    /* NULL, or num_prims more: grid_pack writes the renumbered order into it on the
     * set-up threads, then the two swap (the old order is kept until grid_free: an
     * munmap during the set-up would cost about what the serial move it spares did). */
    GridPrim *prims_spare;
    /* Non-NULL: prims and prims_spare are the two halves of this one block (grid.c's
     * build makes them so), freed as one. */
    GridPrim *prims_block;
    GridPrim *unbounded;    /* planes: tested for every ray */
    uint32_t num_unbounded;
    bool marking;           /* mailboxing on (default; grid_set_marking) */
    float march_tmin_scale; /* (0, 1]: the march starts at tmin times this (tmin > 0),
                               as a leaf under a shrinking Transform accepts hits below
                               a positive world tmin (transform_path_tmin_scale) */

    /* Hot-loop layout (grid_pack.c): cell_items entries with GRID_ITEM_TRI set are
     * untransformed triangles whose edges are copied, packed, into tri[prim]. */
    PackedTri *tri;
    TriHit *tri_hit;        /* per packed triangle */
    /* tri_hit lies in tri's block, right behind its num_prims entries (grid_pack.c,
     * pack_arrays), and goes with it: one mapping for the two. */
    bool hit_in_tri;
    bool packing_off;       /* grid_set_packing(g, false): every entry via its ops */
    /* Every entry of cell_items (and of a two-level grid's lists over this grid) is
     * tagged GRID_ITEM_TRI: the single-ray cell loop then tests entries in groups of
     * four as they stand (grid_cast.c, test_groups). Set by grid_all_tri_update. */
    bool all_tri;

    /* Non-NULL: cell_start, cell_items and tri are read-only memory of this set-up
     * cache (grid_cache.c), held until grid_free (tri_hit, which holds this process's
     * material pointers, is rebuilt and owned); cell_items becomes the grid's
     * own copy if grid_set_packing must change it (items_copied). */
    SetupCache *cache;
    bool items_copied;

    /* The primitive table of grid_build (grid_build_table borrows the caller's). */
    PrimTable own_table;
};

/* The course counts, made on first call (thread-safe: the first caller builds them
 * under course_lock, later ones read the published array). NULL when out of memory. */
const uint32_t *grid_course_counts(const Grid *g);

/* Tag bit on cell_items entries: the primitive is a packed triangle. */
#define GRID_ITEM_TRI 0x80000000u
#define GRID_ITEM_INDEX(e) ((e) & ~GRID_ITEM_TRI)

/* grid_pack.c: g->all_tri from cell_items (after they are tagged or retagged). */
void grid_all_tri_update(Grid *g);

/* grid_cache.c (-cache): the grid of key from c over t, NULL when c has none (or a
 * section that does not fit t); and the built grid g added to c under key. req is the
 * resolution asked for (the build may have made it coarser: then the build's warning is
 * repeated). */
Grid *grid_cache_load(const PrimTable *t, SetupCache *c, SetupKey key, Diag *diag);
void grid_cache_store(const Grid *g, const PrimTable *t, SetupCache *c, SetupKey key,
                      const int req[3]);
/* grid.c: the warning of a resolution made coarser to fit the reference cap. */
void grid_warn_refit(Diag *diag, const int req[3], const int n[3], uint64_t cap);
/* grid.c: the march's tmin factor over the table's Transform chains (Grid.march_tmin_scale). */
float grid_table_tmin_scale(const PrimTable *t);
/* grid.c: grid_build_table for a resolution that grid_fit_refs has already fitted to
 * grid_ref_cap_auto (grid_choose_auto, the two-level grid's top): the build's own fit
 * to the larger grid_ref_cap would keep it (the estimate is at most the smaller cap,
 * or the resolution is 1 x 1 x 1), so its pass over the primitives (two estimates per
 * build) is skipped. */
Grid *grid_build_table_fitted(const PrimTable *t, const int n[3], Diag *diag);
/* grid.c: a zeroed Grid with its lock, or NULL. */
Grid *grid_alloc(void);

/* Builds g->tri and tags the cell items (after the CSR fill); false when out of memory.
 * g->tri, g->tri_hit and g->prims_spare: NULL, or zeroed arrays of num_prims made for it
 * beforehand (grid_pack_prepare; grid_bin.c has their pages faulted in on the set-up
 * threads). */
bool grid_pack(Grid *g);
/* Makes grid_pack's arrays for n primitives now (those it cannot have stay NULL: grid_pack
 * makes or does without them). With set-up threads (grid_bin.c): the pack's chunks then
 * write the new order into g->prims_spare. (Made by a helper beside the table walk
 * instead, they took longer: two threads mapping and faulting at once contend for the
 * address space, and the trimming munmaps interrupt the other CPU.) */
void grid_pack_prepare(Grid *g, uint32_t n);
/* Whether grid_pack packs g (it has primitives, and not too many for the tag bit); the
 * same for a grid of n primitives. */
bool grid_pack_wanted(const Grid *g);
bool grid_pack_wanted_for(uint32_t n);
/* Makes g->occupied from cell_start (left NULL when out of memory: the walk then reads
 * cell_start for every cell, with the same answers) and sets g->prefetch_tri. */
void grid_occupancy_make(Grid *g);
void grid_pack_free(Grid *g);

/* Where the march (its box clip, first cell and grid_ray_too_far) starts for a query
 * with this tmin: never beyond a hit some leaf would accept. The leaves themselves are
 * still tested against tmin. */
static inline float grid_march_tmin(const Grid *g, float tmin)
{
    if (!(tmin > 0.0f) || !isfinite(tmin) || g->march_tmin_scale >= 1.0f)
        return tmin;
    return tmin * g->march_tmin_scale;
}

static inline uint32_t grid_cell_index(const Grid *g, int i, int j, int k)
{
    return ((uint32_t)k * (uint32_t)g->n[1] + (uint32_t)j) * (uint32_t)g->n[0] + (uint32_t)i;
}

/* The leaf's intersect, through its flattened transform path when it has one. */
static inline bool grid_test_prim(const GridPrim *p, const Ray *ray, Hit *hit, float tmin,
                                  RenderCtx *ctx)
{
    return prim_intersect(p->obj, p->xf, ray, hit, tmin, ctx);
}

/* The shadow query's test of one primitive: prim_occluded (tmin < t < tmax). */
static inline bool grid_occluded_prim(const GridPrim *p, const Ray *ray, float tmin,
                                      float tmax, RenderCtx *ctx)
{
    return prim_occluded(p->obj, p->xf, ray, tmin, tmax, ctx);
}

/* One ray's march (one ray, one tmin) carried into a Transform chain's object space:
 * the first step of every test of a leaf below chain xf (transform_path_to_object),
 * kept for the next leaf below the same chain, as the other triangles of a transformed
 * mesh. NULL xf: none yet. */
typedef struct XfMemo {
    const PrimXform *xf;
    Ray ray;
    float tmin;
} XfMemo;

static inline const Ray *grid_xf_memo(const PrimXform *xf, const Ray *ray, float tmin,
                                      XfMemo *xm)
{
    if (xm->xf != xf) {
        xm->xf = xf;
        xm->tmin = tmin;
        xm->ray = transform_path_to_object(&xf->path, ray, &xm->tmin);
    }
    return &xm->ray;
}

/* prim_intersect's steps after the first, for a ray already in the object space of p's
 * chain (local, with the tmin of that space; the ray itself when p has no chain): the
 * leaf's intersect, and the hit's normal back to world space. Shared by the single-ray
 * march (XfMemo) and the packet walk (Packet.xf_ray). */
static inline bool grid_test_local(const GridPrim *p, const Ray *local, Hit *hit,
                                   float tmin, RenderCtx *ctx)
{
    if (!obj_intersect(p->obj, local, hit, tmin, ctx))
        return false;
    if (p->xf)
        hit->normal = transform_path_normal_to_world(&p->xf->path, hit->normal);
    return true;
}

/* grid_test_prim and grid_occluded_prim for the rays of one march: prim_intersect's and
 * prim_occluded's steps, with the ray in object space from xm (the same arithmetic on
 * the same inputs, so the same bits). */
static inline bool grid_test_prim_memo(const GridPrim *p, const Ray *ray, Hit *hit,
                                       float tmin, RenderCtx *ctx, XfMemo *xm)
{
    if (!p->xf)
        return obj_intersect(p->obj, ray, hit, tmin, ctx);
    const Ray *local = grid_xf_memo(p->xf, ray, tmin, xm); /* sets xm->tmin: first */
    return grid_test_local(p, local, hit, xm->tmin, ctx);
}

static inline bool grid_occluded_prim_memo(const GridPrim *p, const Ray *ray, float tmin,
                                           float tmax, RenderCtx *ctx, XfMemo *xm)
{
    if (!p->xf)
        return obj_occluded(p->obj, ray, tmin, tmax, ctx);
    const Ray *local = grid_xf_memo(p->xf, ray, tmin, xm);
    return obj_occluded(p->obj, local, xm->tmin, tmax, ctx);
}

/* grid_cast.c, for the packet traversal (grid_packet.c): */
/* grid_intersect / grid_occluded without the unbounded primitives (the caller tests
 * those first), for one ray. */
/* Tests: 0 keeps the single-ray queries' baseline (SSE2) copy, 1 (the default) lets
 * them take the AVX2 copy where the CPU has AVX2 (grid_cast.c). Set before a render. */
void grid_cast_path_set(int cap);
bool grid_march_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin, RenderCtx *ctx);
bool grid_march_occluded(const Grid *g, const Ray *ray, float tmin, float tmax, RenderCtx *ctx);
/* True when the ray starts so far out that the march's rounding could exceed the
 * padding (it is then tested against every primitive). */
bool grid_ray_too_far(const Grid *g, const Ray *ray, float tmin);
/* A fresh mailbox stamp for one ray or packet, 0 when there is no usable mailbox. */
uint32_t grid_begin_ray(const Grid *g, RenderCtx *ctx);
/* The cell loop of the march over n entries (cell_items format) for one ray, marking
 * in mb with stamp (mb NULL: no marking): nearest hit (updates hit), or any occluder
 * accepted by h (true at the first). For accelerators built on a grid's entries. */
bool grid_items_intersect(const Grid *g, const uint32_t *items, uint32_t n, const Ray *ray,
                          Hit *hit, float tmin, uint32_t *mb, uint32_t stamp, RenderCtx *ctx);
bool grid_items_occluded(const Grid *g, const uint32_t *items, uint32_t n, const Ray *ray,
                         Hit *h, float tmin, uint32_t *mb, uint32_t stamp, RenderCtx *ctx);
/* Bound on the march's float rounding for this ray (world units): a grid whose padding
 * is below it cannot be marched exactly by this ray. */
float grid_march_error(const Grid *g, const Ray *ray);

/* nextafterf(x, +INFINITY) and nextafterf(x, -INFINITY), the same results for every x
 * (NaN, zeros of either sign, the infinities), by stepping the bit pattern: libm's
 * general version was 5% of a 40k-triangle set-up. */
static inline float grid_float_step_up(float x)
{
    if (x != x || x == INFINITY)
        return x;
    uint32_t u;
    memcpy(&u, &x, sizeof u);
    if (x == 0.0f)
        u = 1u;             /* the smallest subnormal, from +0 and from -0 */
    else if (u >> 31)
        u--;                /* negative: toward zero */
    else
        u++;
    memcpy(&x, &u, sizeof x);
    return x;
}

static inline float grid_float_step_down(float x) { return -grid_float_step_up(-x); }

#endif
