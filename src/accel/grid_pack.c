/* The grid's hot-loop layout: untransformed triangles copied into one packed array
 * (v0, edges, id and what a hit records: 64 bytes, no pointer chasing, no indirect
 * call), and their cell entries tagged so grid_cast.c intersects them inline with
 * triangle_ray_t, the same arithmetic as Triangle::intersect, hence the same hits to
 * the bit. */
#include "grid_internal.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rt/bigmem.h"
#include "rt/geom.h"
#include "rt/par.h"

/* The renumbering of the primitives in the order the cells first mention them, so the
 * packed triangles (and the mailbox stamps) a cell's entries point to lie next to each
 * other in memory instead of in scene order: newix[p] is prims[p]'s new index, and the
 * entries are rewritten to it. Hits do not depend on the numbering: ties are broken by
 * the depth-first id, not by this index. NULL when out of memory. */
static uint32_t *renumber_entries(Grid *g)
{
    uint32_t n = g->num_prims;
    uint32_t *newix = bigmem_calloc(n, sizeof *newix);
    if (!newix)
        return NULL;
    for (uint32_t p = 0; p < n; p++)
        newix[p] = UINT32_MAX;
    uint32_t next = 0;
    size_t m = g->cell_start[g->num_cells];
    for (size_t e = 0; e < m; e++) {
        uint32_t p = g->cell_items[e];
        if (newix[p] == UINT32_MAX)
            newix[p] = next++;
        g->cell_items[e] = newix[p];
    }
    /* Primitives in no cell (possible after tight insertion) take the last slots. */
    for (uint32_t p = 0; p < n; p++)
        if (newix[p] == UINT32_MAX)
            newix[p] = next++;
    return newix;
}

/* Moves prims[p] to prims[newix[p]] in place, cycle by cycle (no second array: fresh
 * pages cost more than the moves here); GRID_ITEM_TRI marks placed slots of newix. */
static void move_prims(Grid *g, uint32_t *newix)
{
    for (uint32_t s0 = 0; s0 < g->num_prims; s0++) {
        if (newix[s0] & GRID_ITEM_TRI)
            continue;
        GridPrim carry = g->prims[s0];
        uint32_t dst = newix[s0];
        newix[s0] |= GRID_ITEM_TRI;
        while (dst != s0) {
            GridPrim tmp = g->prims[dst];
            g->prims[dst] = carry;
            carry = tmp;
            uint32_t nd = newix[dst];
            newix[dst] |= GRID_ITEM_TRI;
            dst = nd;
        }
        g->prims[s0] = carry;
    }
}

/* The packed copy of *gp (and what a hit on it records), or id RT_NO_ID when it is not
 * an untransformed triangle. */

static void pack_prim(const Grid *g, const GridPrim *gp, PackedTri *pt, TriHit *th)
{
    if (gp->xf || obj_kind(gp->obj) != OBJ_TRIANGLE) {
        pt->id = RT_NO_ID; /* not packed */
        return;
    }
    Vec3 v[3];
    triangle_vertices(gp->obj, v);
    /* The same subtractions as triangle_new: bit-identical edges. */
    pt->v0 = v[0];
    pt->e1 = v3_sub(v[1], v[0]);
    pt->e2 = v3_sub(v[2], v[0]);
    pt->id = gp->obj->id;
    th->normal = triangle_normal(gp->obj);
    th->material = gp->obj->material;
    /* Widened by the pad the cells were filled with, then by a further ulp of the
     * coordinate for the rounding of the subtraction: the box holds every point
     * within pad[a] of the triangle. */
    TriBox *b = &pt->box;
    for (int a = 0; a < 3; a++) {
        float x0 = v3_comp(v[0], a), x1 = v3_comp(v[1], a), x2 = v3_comp(v[2], a);
        float lo = min_nan_last(x0, min_nan_last(x1, x2));
        float hi = max_nan_last(x0, max_nan_last(x1, x2));
        b->lo[a] = grid_float_step_down(lo - g->pad[a]);
        b->hi[a] = grid_float_step_up(hi + g->pad[a]);
    }
}

/* Primitives per chunk of the pack's parallel pass, and entries per chunk of the
 * tagging. A tagging chunk is a quick pass over memory (94k entries of the 40k bunny:
 * 0.1 ms on one thread), and in 4096-entry chunks it took twice as long on two threads
 * as on one (handing out the chunks, waking the helper): only bigger meshes split it. */
enum { PACK_CHUNK = 4096, TAG_CHUNK = 256 << 10, PACK_AHEAD = 16 };

typedef struct PackJob {
    Grid *g;
    const uint32_t *newix;
    GridPrim *dst; /* NULL, or where prims go in their new order */
} PackJob;

/* Chunk k of the table: each primitive packed into its new slot (disjoint slots: newix
 * is a permutation). */
static void pack_chunk(void *ctx, int k, int worker)
{
    (void)worker;
    const PackJob *job = ctx;
    if (par_stop_requested())
        return; /* grid_pack fails: the grid is thrown away */
    Grid *g = job->g;
    uint32_t p0 = (uint32_t)k * PACK_CHUNK;
    uint32_t p1 = g->num_prims - p0 > PACK_CHUNK ? p0 + PACK_CHUNK : g->num_prims;
    for (uint32_t p = p0; p < p1; p++) {
        /* The slots are scattered (cell order): their lines are fetched for writing
         * ahead, which took about a fifth of the pack's samples off on the 40k bunny
         * (perf, 8x8 renders, 2 x 20 runs each). */
        if (p + PACK_AHEAD < p1) {
            __builtin_prefetch(&g->tri[job->newix[p + PACK_AHEAD]], 1);
            __builtin_prefetch(&g->tri_hit[job->newix[p + PACK_AHEAD]], 1);
        }
        pack_prim(g, &g->prims[p], &g->tri[job->newix[p]], &g->tri_hit[job->newix[p]]);
    }
    if (job->dst)
        for (uint32_t p = p0; p < p1; p++)
            job->dst[job->newix[p]] = g->prims[p];
}

/* Chunk k of the entries: tagged when they name a packed triangle. */
static void tag_chunk(void *ctx, int k, int worker)
{
    (void)worker;
    const PackJob *job = ctx;
    Grid *g = job->g;
    size_t n = g->cell_start[g->num_cells];
    size_t e0 = (size_t)k * TAG_CHUNK, e1 = n - e0 > TAG_CHUNK ? e0 + TAG_CHUNK : n;
    for (size_t e = e0; e < e1; e++)
        if (g->tri[g->cell_items[e]].id != RT_NO_ID)
            g->cell_items[e] |= GRID_ITEM_TRI;
}

/* g->tri and g->tri_hit for n primitives where they are missing (those that cannot be
 * had stay NULL). Both missing: one block, tri_hit behind tri. Why: each alone was a
 * mapping of its own with its last 2 MB page mostly unused (the 40k bunny's 2.56 MB of
 * tri in 4 MB, 0.96 MB of tri_hit in 2 MB), and every fresh 2 MB page is zeroed by the
 * kernel on first touch (0.25 ms or more on this project's VMs): together they fit in
 * tri's 4 MB. */
static void pack_arrays(Grid *g, uint32_t n)
{
    if (!g->tri && !g->tri_hit) {
        size_t tri_bytes = (size_t)n * sizeof *g->tri;
        char *block = bigmem_alloc(tri_bytes + (size_t)n * sizeof *g->tri_hit);
        if (block) {
            _Static_assert(sizeof(PackedTri) % _Alignof(TriHit) == 0, "tri_hit aligned");
            g->tri = (PackedTri *)(void *)block;
            g->tri_hit = (TriHit *)(void *)(block + tri_bytes);
            g->hit_in_tri = true;
            return;
        }
    }
    if (!g->tri)
        g->tri = bigmem_calloc(n, sizeof *g->tri);
    if (!g->tri_hit)
        g->tri_hit = bigmem_calloc(n, sizeof *g->tri_hit);
}

void grid_pack_prepare(Grid *g, uint32_t n)
{
    if (n == 0)
        return;
    pack_arrays(g, n);
    if (!g->prims_spare)
        g->prims_spare = bigmem_calloc(n, sizeof *g->prims_spare);
}

bool grid_pack_wanted_for(uint32_t n)
{
    /* The tag bit must stay free: from 2^31 primitives on, scene order and the generic
     * path. */
    return n > 0 && n < GRID_ITEM_TRI;
}

bool grid_pack_wanted(const Grid *g) { return grid_pack_wanted_for(g->num_prims); }

bool grid_pack(Grid *g)
{
    if (!grid_pack_wanted(g)) {
        grid_pack_free(g);
        return true;
    }
    uint32_t *newix = renumber_entries(g);
    if (!newix)
        return false;
    pack_arrays(g, g->num_prims);
    if (!g->tri || !g->tri_hit) {
        bigmem_free(newix);
        return false;
    }
    /* Packed in table order (the leaves' memory order: a mesh's triangles one after the
     * other) into their new slots, then the table follows. In the new order every
     * leaf read was a cache miss (on the 40k bunny most of the pack's time). Both the
     * packing and the tagging write each slot or entry from one chunk only, so they run
     * on the set-up threads (rt/par.h) with the same result. */
    /* The table into its new order: copied by the same chunks into the second array
     * (made with the first by grid.c, or by grid_pack_prepare), else, when there is
     * none, moved in place afterwards. */
    PackJob job = {g, newix, g->prims_spare};
    par_for((int)(g->num_prims / PACK_CHUNK + (g->num_prims % PACK_CHUNK != 0)), pack_chunk,
            &job);
    if (par_stop_requested()) { /* chunks were skipped (the flag is never cleared) */
        bigmem_free(newix);
        return false;
    }
    if (job.dst) {
        g->prims_spare = g->prims;
        g->prims = job.dst;
    } else {
        move_prims(g, newix);
    }
    bigmem_free(newix);
    size_t n = g->cell_start[g->num_cells];
    par_for((int)(n / TAG_CHUNK + (n % TAG_CHUNK != 0)), tag_chunk, &job);
    return true;
}

void grid_set_packing(Grid *g, bool on)
{
    if (!g->tri)
        return;
    if (g->cache && !g->items_copied) {
        /* The entries are the cache's read-only memory: change a copy. */
        size_t bytes = ((size_t)g->cell_start[g->num_cells] + 1) * sizeof *g->cell_items;
        uint32_t *own = bigmem_alloc(bytes);
        if (!own)
            return;
        memcpy(own, g->cell_items, bytes - sizeof *own);
        g->cell_items = own;
        g->items_copied = true;
    }
    size_t n = g->cell_start[g->num_cells];
    for (size_t e = 0; e < n; e++) {
        uint32_t p = GRID_ITEM_INDEX(g->cell_items[e]);
        bool packable = g->tri[p].id != RT_NO_ID;
        g->cell_items[e] = (on && packable) ? (p | GRID_ITEM_TRI) : p;
    }
    g->packing_off = !on;
    grid_all_tri_update(g);
}

void grid_all_tri_update(Grid *g)
{
    bool all = g->tri != NULL && !g->packing_off;
    size_t n = g->cell_start ? g->cell_start[g->num_cells] : 0;
    uint32_t and_all = GRID_ITEM_TRI;
    for (size_t e = 0; all && e < n; e++)
        and_all &= g->cell_items[e];
    g->all_tri = all && and_all != 0;
}

bool grid_packing(const Grid *g) { return g->tri && !g->packing_off; }

/* Packed triangles above this size are prefetched by the packet walk. */
#define GRID_PREFETCH_BYTES ((size_t)8 << 20)

void grid_occupancy_make(Grid *g)
{
    size_t words = ((size_t)g->num_cells + 63) / 64;
    uint64_t *occ = bigmem_calloc(words ? words : 1, sizeof *occ);
    if (occ) {
        const uint32_t *start = g->cell_start;
        for (uint32_t c = 0; c < g->num_cells; c++)
            occ[c >> 6] |= (uint64_t)(start[c + 1] != start[c]) << (c & 63);
    }
    g->occupied = occ;
    grid_all_tri_update(g);
    /* Prefetching pays where the packed triangles outgrow the caches (blob's
     * measurements in bench/REPORT.txt); below, it is only instructions. */
    g->prefetch_tri = g->tri && (size_t)g->num_prims * sizeof *g->tri > GRID_PREFETCH_BYTES;
}

void grid_pack_free(Grid *g)
{
    bigmem_free(g->tri);
    if (!g->hit_in_tri)
        bigmem_free(g->tri_hit);
    g->tri = NULL;
    g->tri_hit = NULL;
    g->hit_in_tri = false;
}
