/* The uniform grid in the set-up cache (-cache, rt/setup_cache.h): the arrays a build
 * makes (cell offsets, entries, packed triangles and their boxes, and which table
 * primitive each grid primitive is) are stored once, and later processes use them
 * straight from the cache's memory (the file's bytes). Everything else of the Grid
 * (the cells' geometry, the planes, the march's tmin factor) is recomputed from the
 * table, as the build does, so the grid is the built one to the bit. */
#include "grid_build.h"

#include <stdlib.h>
#include <string.h>

#include "rt/bigmem.h"
#include "rt/options.h"
#include "rt/par.h"

/* Part 0 of a grid section. */
typedef struct GridCacheHead {
    int32_t req[3], n[3];          /* asked for; built (smaller when the cap applied) */
    uint32_t num_prims, num_unbounded;
    uint32_t table_prims, table_bounded;
    uint32_t entries, packed;
    float bounds[6];               /* the table's scene box, as the build saw it */
} GridCacheHead;

enum { PART_HEAD, PART_START, PART_ITEMS, PART_INDEX, PART_TRI, NUM_PARTS };

static void box_floats(const BBox *b, float out[6])
{
    out[0] = b->min.x;
    out[1] = b->min.y;
    out[2] = b->min.z;
    out[3] = b->max.x;
    out[4] = b->max.y;
    out[5] = b->max.z;
}

/* Everything the build read from t, checked against the section: the key already
 * covers the inputs, these checks keep a damaged or foreign section from being used
 * (or from making the march read outside its arrays). */
static bool fits(const PrimTable *t, const GridCacheHead *h, const void *const *part,
                 const size_t *len)
{
    uint64_t cells = 1;
    for (int a = 0; a < 3; a++) {
        if (h->n[a] < 1 || h->n[a] > h->req[a])
            return false;
        cells *= (uint64_t)h->n[a];
    }
    float tb[6];
    box_floats(&t->scene_bounds, tb);
    if (cells > RT_GRID_MAX_CELLS || h->table_prims != t->num_prims ||
        h->table_bounded != t->num_bounded || h->num_prims != t->num_bounded ||
        h->num_unbounded != t->num_prims - t->num_bounded || memcmp(tb, h->bounds, sizeof tb) ||
        h->num_prims >= GRID_ITEM_TRI || h->packed > 1)
        return false;
    size_t np = h->num_prims;
    if (len[PART_START] != ((size_t)cells + 1) * sizeof(uint32_t) ||
        len[PART_ITEMS] != (size_t)h->entries * sizeof(uint32_t) ||
        len[PART_INDEX] != np * sizeof(uint32_t) ||
        len[PART_TRI] != (h->packed ? np * sizeof(PackedTri) : 0))
        return false;
    const uint32_t *start = part[PART_START], *items = part[PART_ITEMS];
    const uint32_t *index = part[PART_INDEX];
    const PackedTri *tri = part[PART_TRI];
    if (start[0] != 0 || start[cells] != h->entries)
        return false;
    for (uint64_t c = 0; c < cells; c++)
        if (start[c + 1] < start[c])
            return false;
    for (size_t p = 0; p < np; p++) {
        if (index[p] >= t->num_prims || !t->prims[index[p]].bounded)
            return false;
        const Prim *tp = &t->prims[index[p]];
        /* A packed triangle is an untransformed Triangle with its leaf's id. */
        if (h->packed && tri[p].id != RT_NO_ID &&
            (tri[p].id != tp->id || tp->xf || obj_kind(tp->obj) != OBJ_TRIANGLE))
            return false;
    }
    for (uint32_t e = 0; e < h->entries; e++) {
        uint32_t p = GRID_ITEM_INDEX(items[e]);
        if (p >= np || ((items[e] & GRID_ITEM_TRI) && (!h->packed || tri[p].id == RT_NO_ID)))
            return false;
    }
    return true;
}

Grid *grid_cache_load(const PrimTable *t, SetupCache *c, SetupKey key, Diag *diag)
{
    const void *part[SETUP_CACHE_MAX_PARTS];
    size_t len[SETUP_CACHE_MAX_PARTS];
    int nparts = 0;
    if (!setup_cache_find(c, SETUP_TAG_GRID, key, part, len, &nparts) ||
        nparts != NUM_PARTS || len[PART_HEAD] != sizeof(GridCacheHead))
        return NULL;
    GridCacheHead h;
    memcpy(&h, part[PART_HEAD], sizeof h);
    if (!fits(t, &h, part, len))
        return NULL;
    Grid *g = grid_alloc();
    if (!g)
        return NULL;
    g->bounds = t->scene_bounds;
    for (int a = 0; a < 3; a++)
        g->n[a] = h.n[a];
    g->num_cells = (uint32_t)((uint64_t)h.n[0] * (uint64_t)h.n[1] * (uint64_t)h.n[2]);
    g->march_tmin_scale = grid_table_tmin_scale(t);
    grid_setup_geometry(g);
    uint32_t nb = h.num_prims, nu = h.num_unbounded;
    g->prims = bigmem_calloc(nb ? nb : 1, sizeof *g->prims);
    g->unbounded = bigmem_calloc(nu ? nu : 1, sizeof *g->unbounded);
    if (!g->prims || !g->unbounded) {
        grid_free(g);
        return NULL;
    }
    const uint32_t *index = part[PART_INDEX];
    for (uint32_t p = 0; p < nb; p++) {
        g->prims[p].obj = t->prims[index[p]].obj;
        g->prims[p].xf = t->prims[index[p]].xf;
    }
    g->num_prims = nb;
    for (uint32_t i = 0; i < t->num_prims; i++)
        if (!t->prims[i].bounded) {
            g->unbounded[g->num_unbounded].obj = t->prims[i].obj;
            g->unbounded[g->num_unbounded].xf = t->prims[i].xf;
            g->num_unbounded++;
        }
    /* The cache's arrays: read-only, never written by the queries (grid_set_packing
     * copies the entries first). */
    g->cell_start = (uint32_t *)part[PART_START];
    g->cell_items = (uint32_t *)part[PART_ITEMS];
    g->tri = h.packed ? (PackedTri *)part[PART_TRI] : NULL;
    setup_cache_retain(c);
    g->cache = c;
    if (h.packed) {
        /* What a hit records, from the leaves as grid_pack takes it. */
        g->tri_hit = bigmem_calloc(nb ? nb : 1, sizeof *g->tri_hit);
        if (!g->tri_hit) {
            grid_free(g);
            return NULL;
        }
        for (uint32_t p = 0; p < nb; p++)
            if (g->tri[p].id != RT_NO_ID) {
                g->tri_hit[p].normal = triangle_normal(g->prims[p].obj);
                g->tri_hit[p].material = g->prims[p].obj->material;
            }
    }
    grid_occupancy_make(g);
    int n[3] = {h.n[0], h.n[1], h.n[2]}, req[3] = {h.req[0], h.req[1], h.req[2]};
    if (memcmp(n, req, sizeof n) != 0)
        grid_warn_refit(diag, req, n, grid_ref_cap(t->num_bounded));
    return g;
}

static int ref_cmp(const void *pa, const void *pb)
{
    const PrimRef *a = pa, *b = pb;
    if (a->obj != b->obj)
        return (uintptr_t)a->obj < (uintptr_t)b->obj ? -1 : 1;
    if (a->xf != b->xf)
        return (uintptr_t)a->xf < (uintptr_t)b->xf ? -1 : 1;
    return 0;
}

static inline bool ref_less(const PrimRef *a, const PrimRef *b)
{
    if (a->obj != b->obj)
        return (uintptr_t)a->obj < (uintptr_t)b->obj;
    return (uintptr_t)a->xf < (uintptr_t)b->xf;
}

/* Refs sorted by insertion into runs of this many before the merges. */
enum { SORT_RUN = 16 };

bool grid_cache_sort_refs(PrimRef *refs, uint32_t n, PrimRef *tmp)
{
    /* A stable merge sort of our own rather than qsort, which cannot be stopped inside
     * (a quarter of a second at 1.3M triangles): runs of SORT_RUN by insertion, then
     * passes that merge pairs of runs between refs and tmp, looking at the stop request
     * every SORT_STOP refs written. Stable, as glibc's qsort (a merge sort when it can
     * have its buffer), so equal keys, if ever, keep the same order. */
    for (uint32_t lo = 0; lo < n; lo += SORT_RUN) {
        if (lo % SORT_STOP == 0 && par_stop_requested())
            return false;
        uint32_t hi = n - lo > SORT_RUN ? lo + SORT_RUN : n;
        for (uint32_t i = lo + 1; i < hi; i++) {
            PrimRef r = refs[i];
            uint32_t j = i;
            for (; j > lo && ref_less(&r, &refs[j - 1]); j--)
                refs[j] = refs[j - 1];
            refs[j] = r;
        }
    }
    PrimRef *src = refs, *dst = tmp;
    for (uint64_t width = SORT_RUN; width < n; width *= 2) {
        uint64_t written = 0;
        for (uint64_t lo = 0; lo < n; lo += 2 * width) {
            uint32_t mid = (uint32_t)(lo + width < n ? lo + width : n);
            uint32_t hi = (uint32_t)(lo + 2 * width < n ? lo + 2 * width : n);
            uint32_t a = (uint32_t)lo, b = mid;
            for (uint32_t o = (uint32_t)lo; o < hi; o++) {
                if (++written % SORT_STOP == 0 && par_stop_requested())
                    return false;
                /* The left run's ref first unless the right one is smaller: stable. */
                dst[o] = a < mid && (b >= hi || !ref_less(&src[b], &src[a])) ? src[a++]
                                                                              : src[b++];
            }
        }
        PrimRef *t = src;
        src = dst;
        dst = t;
    }
    if (src != refs)
        memcpy(refs, src, (size_t)n * sizeof *refs);
    return true;
}

void grid_cache_store(const Grid *g, const PrimTable *t, SetupCache *c, SetupKey key,
                      const int req[3])
{
    if (g->packing_off || g->num_prims != t->num_bounded)
        return;
    PrimRef *refs = malloc((t->num_prims ? t->num_prims : 1) * sizeof *refs);
    PrimRef *tmp = malloc((t->num_prims ? t->num_prims : 1) * sizeof *tmp);
    uint32_t *index = malloc((g->num_prims ? g->num_prims : 1) * sizeof *index);
    /* A stop (Ctrl-C, rt/par.h) ends the store: the run writes no cache then. Looked at
     * before the sort, every SORT_STOP refs it writes and every 64K look-ups (a
     * 1.3M-triangle grid's store is ~0.3 s). */
    bool ok = refs && tmp && index && !par_stop_requested();
    uint32_t nr = 0;
    for (uint32_t i = 0; ok && i < t->num_prims; i++)
        if (t->prims[i].bounded)
            refs[nr++] = (PrimRef){t->prims[i].obj, t->prims[i].xf, i};
    if (ok)
        ok = grid_cache_sort_refs(refs, nr, tmp);
    free(tmp);
    tmp = NULL;
    for (uint32_t p = 0; ok && p < g->num_prims; p++) {
        if ((p & 0xFFFF) == 0xFFFF && par_stop_requested()) {
            ok = false;
            break;
        }
        PrimRef want = {g->prims[p].obj, g->prims[p].xf, 0};
        const PrimRef *r = bsearch(&want, refs, nr, sizeof *refs, ref_cmp);
        if (!r)
            ok = false; /* not one of the table's: nothing to store */
        else
            index[p] = r->index;
    }
    if (ok && !par_stop_requested()) {
        GridCacheHead h;
        memset(&h, 0, sizeof h);
        for (int a = 0; a < 3; a++) {
            h.req[a] = req[a];
            h.n[a] = g->n[a];
        }
        h.num_prims = g->num_prims;
        h.num_unbounded = g->num_unbounded;
        h.table_prims = t->num_prims;
        h.table_bounded = t->num_bounded;
        h.entries = g->cell_start[g->num_cells];
        h.packed = g->tri != NULL;
        box_floats(&t->scene_bounds, h.bounds);
        size_t np = g->num_prims;
        const void *part[NUM_PARTS] = {&h, g->cell_start, g->cell_items, index, g->tri};
        size_t len[NUM_PARTS] = {sizeof h, ((size_t)g->num_cells + 1) * sizeof(uint32_t),
                                 (size_t)h.entries * sizeof(uint32_t),
                                 np * sizeof(uint32_t),
                                 h.packed ? np * sizeof(PackedTri) : 0};
        setup_cache_add(c, SETUP_TAG_GRID, key, part, len, NUM_PARTS);
    }
    free(refs);
    free(index);
}
