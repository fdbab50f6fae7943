/* The grid's lifecycle (docs/grid.md, How it works): geometry of the cells, the build
 * from the primitive table (its parts: grid_bin.c, grid_course.c, grid_cells.c),
 * accessors, free. Two cell sets are built: the course's occupancy counts (what
 * -visualize_grid shows) and tighter, rounding-padded lists (what the march tests). */
#include "grid_build.h"
#include "rt/bigmem.h"
#include "rt/options.h"

#include <limits.h>
#include <stdlib.h>
#include <string.h>

#include "rt/par.h"
#include "rt/scene.h"

/* Upper bound on nx*ny*nz: 16M cells keep the offsets and counts under 128 MB. It is
 * the limit users see with -grid (rt/options.h), so no size passes one check and fails
 * the other. */
#define GRID_MAX_CELLS ((uint32_t)RT_GRID_MAX_CELLS)

/* Appends a bounded primitive to prims. Its kind waits in prim_ncells until bin_part
 * replaces it by the primitive's cell count. */
static void append_prim(GridBuild *b, const Prim *p, RecKind kind)
{
    Grid *g = b->g;
    g->prims[g->num_prims].obj = p->obj;
    g->prims[g->num_prims].xf = p->xf;
    b->prim_ncells[g->num_prims] = (uint32_t)kind;
    g->num_prims++;
}

void grid_free(Grid *g)
{
    if (!g)
        return;
    if (!g->cache || g->items_copied)
        bigmem_free(g->cell_items);
    if (g->cache) {
        bigmem_free(g->tri_hit);       /* the grid's own (it holds pointers) */
        setup_cache_release(g->cache); /* cell_start and tri were its memory */
    } else {
        bigmem_free(g->cell_start);
        grid_pack_free(g);
    }
    bigmem_free(g->occupied);
    bigmem_free(atomic_load_explicit(&g->course_count, memory_order_relaxed));
    pthread_mutex_destroy(&g->course_lock);
    if (g->prims_block) {
        bigmem_free(g->prims_block);
    } else {
        bigmem_free(g->prims);
        bigmem_free(g->prims_spare);
    }
    bigmem_free(g->unbounded);
    prim_table_free(&g->own_table);
    free(g);
}

/* Sets the box the cells tile and the rounding pad. Zero-thickness axes (a flat scene)
 * get a small symmetric thickness so cell sizes stay positive. */
void grid_setup_geometry(Grid *g)
{
    float ext_max = 0.0f, mag = 0.0f;
    for (int a = 0; a < 3; a++) {
        float lo = v3_comp(g->bounds.min, a), hi = v3_comp(g->bounds.max, a);
        ext_max = fmaxf(ext_max, hi - lo);
        mag = fmaxf(mag, fmaxf(fabsf(lo), fabsf(hi)));
    }
    float thick = fmaxf(1e-4f * ext_max, fmaxf(1e-5f * mag, 1e-6f));
    float lo3[3], hi3[3];
    for (int a = 0; a < 3; a++) {
        lo3[a] = v3_comp(g->bounds.min, a);
        hi3[a] = v3_comp(g->bounds.max, a);
        if (!(hi3[a] - lo3[a] >= thick * 1e-3f)) {
            lo3[a] -= thick;
            hi3[a] += thick;
        }
    }
    g->box.min = v3(lo3[0], lo3[1], lo3[2]);
    g->box.max = v3(hi3[0], hi3[1], hi3[2]);
    for (int a = 0; a < 3; a++) {
        g->size[a] = (hi3[a] - lo3[a]) / (float)g->n[a];
        /* Rounding margin: 1% of a cell plus a few float ulps of the coordinates.
         * It only adds primitives lying within the margin of a cell's border. 1% (not
         * less) keeps the march exact for ray origins up to ~100 box sizes away; rays
         * from farther away are tested without the march (grid_cast.c). */
        g->pad[a] = 1e-2f * g->size[a] + 1e-5f * mag;
    }
    g->min_pad = fminf(g->pad[0], fminf(g->pad[1], g->pad[2]));
    for (int a = 0; a < 3; a++)
        g->band[a] = march_band_width(&g->box, g->pad[a]);
    g->box_mag = mag;
    for (int a = 0; a < 3; a++) {
        g->inv_size[a] = (float)g->n[a] / (hi3[a] - lo3[a]);
        g->slab_lo[a] = lo3[a] - g->pad[a];
        g->slab_hi[a] = hi3[a] + g->pad[a];
    }
}

void grid_warn_refit(Diag *diag, const int req[3], const int n[3], uint64_t cap)
{
    diag_warning(diag, NULL, "a %dx%dx%d grid would exceed %llu cell references (%d per "
                 "bounded primitive + %u): using %dx%dx%d instead", req[0], req[1], req[2],
                 (unsigned long long)cap, GRID_REFS_PER_PRIM, GRID_REFS_FLOOR, n[0], n[1],
                 n[2]);
}

float grid_table_tmin_scale(const PrimTable *t)
{
    float scale = 1.0f;
    for (uint32_t i = 0; i < t->num_xforms; i++) {
        float s = transform_path_tmin_scale(&t->xforms[i]->path);
        if (s < scale)
            scale = s;
    }
    return scale;
}

Grid *grid_alloc(void)
{
    Grid *g = calloc(1, sizeof *g);
    if (!g)
        return NULL;
    atomic_init(&g->course_count, NULL);
    pthread_mutex_init(&g->course_lock, NULL);
    g->marking = true;
    g->march_tmin_scale = 1.0f;
    return g;
}

static Grid *build(const PrimTable *t, int nx, int ny, int nz, bool fitted, Diag *diag)
{
    if (nx < 1 || ny < 1 || nz < 1) {
        diag_error(diag, NULL, "grid resolution must be positive, got %dx%dx%d", nx, ny, nz);
        return NULL;
    }
    uint64_t cells = (uint64_t)nx * (uint64_t)ny * (uint64_t)nz;
    if (cells > GRID_MAX_CELLS) {
        diag_error(diag, NULL, "grid resolution %dx%dx%d too large (at most %u cells)", nx,
                   ny, nz, GRID_MAX_CELLS);
        return NULL;
    }
    if (!v3_isfinite(t->scene_bounds.min) || !v3_isfinite(t->scene_bounds.max) ||
        !v3_isfinite(v3_sub(t->scene_bounds.max, t->scene_bounds.min))) {
        diag_error(diag, NULL, "cannot build a grid: the scene's bounding box is not finite");
        return NULL;
    }
    /* Time and memory within a multiple of the primitive count (grid_budget.c). */
    int n[3] = {nx, ny, nz};
    uint64_t cap = grid_ref_cap(t->num_bounded);
    if (!fitted && grid_fit_refs(t, n, cap, NULL)) {
        int req[3] = {nx, ny, nz};
        grid_warn_refit(diag, req, n, cap);
        nx = n[0];
        ny = n[1];
        nz = n[2];
        cells = (uint64_t)nx * (uint64_t)ny * (uint64_t)nz;
    }
    GridBuild b;
    memset(&b, 0, sizeof b);
    Grid *g = b.g = grid_alloc();
    if (!g)
        goto oom;
    g->bounds = t->scene_bounds;
    g->n[0] = nx;
    g->n[1] = ny;
    g->n[2] = nz;
    g->num_cells = (uint32_t)cells;
    g->marking = true;
    g->march_tmin_scale = grid_table_tmin_scale(t);
    grid_setup_geometry(g);
    g->cell_start = bigmem_calloc((size_t)cells + 1, sizeof *g->cell_start);
    if (!g->cell_start)
        goto oom;

    if (!grid_setup_cell_axis(&b))
        goto oom;
    uint32_t nb = t->num_bounded, nu = t->num_prims - t->num_bounded;
    /* grid_pack copies the primitives into a second array in their new order (which it
     * writes whole): both arrays in one block here. With set-up threads that array was
     * made apart (grid_pack_prepare), a mapping of its own (640 KB of the 40k bunny's in
     * 2 MB) whose fresh huge page the kernel zeroes on first touch (0.25 ms or more on
     * this project's VMs). On one thread there was none, and the primitives were moved
     * into their order in place, cycle by cycle: 0.6 ms of random reads and writes on
     * line 07, where the copy is one more store in the pack's chunks; it is made there
     * too when the first array's mapping has room for it (the bunny's 2 MB), so it costs
     * no page; a bigger table (the 1.3M blob's 21 MB) is still moved in place. */
    size_t one = (size_t)(nb ? nb : 1) * sizeof *g->prims;
    bool two = grid_pack_wanted_for(nb) && par_threads() > 1;
    g->prims = bigmem_alloc(two ? 2 * one : one);
    if (g->prims && !two && grid_pack_wanted_for(nb) && bigmem_capacity(g->prims) >= 2 * one) {
        GridPrim *both = bigmem_resize(g->prims, 2 * one); /* in place */
        if (both) {
            g->prims = both;
            two = true;
        }
    }
    if (two && g->prims) {
        g->prims_block = g->prims;
        g->prims_spare = g->prims + nb;
    }
    b.prim_ncells = bigmem_calloc(nb ? nb : 1, sizeof *b.prim_ncells);
    g->unbounded = bigmem_calloc(nu ? nu : 1, sizeof *g->unbounded);
    if (!g->prims || !b.prim_ncells || !g->unbounded)
        goto oom;
    /* The bounded primitives go into cells in table (depth-first) order; the others are
     * tested for every ray. */
    for (uint32_t i = 0; i < t->num_prims; i++) {
        const Prim *p = &t->prims[i];
        if (p->bounded) {
            append_prim(&b, p, grid_rec_kind(p));
        } else {
            g->unbounded[g->num_unbounded].obj = p->obj;
            g->unbounded[g->num_unbounded].xf = p->xf;
            g->num_unbounded++;
        }
    }
    if (!grid_bin_fill_pack(&b)) {
        if (b.stopped) { /* nothing to report: the caller says "interrupted" */
            grid_free_build_state(&b);
            grid_free(g);
            return NULL;
        }
        if (!b.too_many)
            goto oom;
        diag_error(diag, NULL, "grid %dx%dx%d would hold too many entries; use fewer cells",
                   nx, ny, nz);
        grid_free_build_state(&b);
        grid_free(g);
        return NULL;
    }
    grid_free_build_state(&b);
    return g;

oom:
    diag_error(diag, NULL, "out of memory building a %dx%dx%d grid", nx, ny, nz);
    grid_free_build_state(&b);
    grid_free(g);
    return NULL;
}

static Grid *build_table(const PrimTable *t, int nx, int ny, int nz, bool fitted, Diag *diag)
{
    if (!t || t->num_bounded == 0 || bbox_is_empty(&t->scene_bounds))
        return NULL;
    /* Wake the binning helpers now: the set-up gives them time to get a CPU. */
    if (t->num_bounded >= 2 * BIN_CHUNK)
        par_prepare();
    /* The helpers are not let go after the grid: idle, they sleep, and the render's
     * workers run on them (rt/par.h). */
    return build(t, nx, ny, nz, fitted, diag);
}

Grid *grid_build_table(const PrimTable *t, int nx, int ny, int nz, Diag *diag)
{
    return build_table(t, nx, ny, nz, false, diag);
}

Grid *grid_build_table_fitted(const PrimTable *t, const int n[3], Diag *diag)
{
    return build_table(t, n[0], n[1], n[2], true, diag);
}

Grid *grid_build(const Scene *scene, int nx, int ny, int nz, Diag *diag)
{
    if (!scene || !scene->root || bbox_is_empty(&scene->bounds))
        return NULL;
    PrimTable t;
    if (!prim_table_build(&t, scene)) {
        diag_error(diag, NULL, "out of memory building a %dx%dx%d grid", nx, ny, nz);
        return NULL;
    }
    Grid *g = grid_build_table(&t, nx, ny, nz, diag);
    if (g)
        g->own_table = t;  /* the grid's prims point into it */
    else
        prim_table_free(&t);
    return g;
}

/* ---- the course counts, on first use ---- */

/* Primitives per chunk of the course counts' parallel pass. */
enum { COURSE_CHUNK = 2048 };

/* The course counts' pass on the set-up threads (rt/par.h): worker 0 counts into the
 * result, the others into arrays of their own that are added in afterwards. The counts
 * are sums, so any split gives the same array. */
typedef struct CourseJob {
    const Grid *g;
    uint32_t *count[PAR_MAX_WORKERS];
    bool oom;
} CourseJob;

static void course_chunk(void *ctx, int k, int worker)
{
    CourseJob *job = ctx;
    const Grid *g = job->g;
    if (!job->count[worker]) {
        uint32_t *c = bigmem_calloc(g->num_cells, sizeof *c);
        if (!c) {
            /* Read only after the par_for returns: a plain flag suffices. */
            job->oom = true;
            return;
        }
        job->count[worker] = c;
    }
    uint32_t p0 = (uint32_t)k * COURSE_CHUNK;
    uint32_t p1 = g->num_prims - p0 > COURSE_CHUNK ? p0 + COURSE_CHUNK : g->num_prims;
    for (uint32_t p = p0; p < p1; p++) {
        GridBuildRec rec;
        grid_make_rec(&g->prims[p], grid_prim_rec_kind(&g->prims[p]), &rec);
        grid_course_insert(g, job->count[worker], &rec);
    }
}

/* The counts into c (zeroed): false when out of memory. */
static bool course_count_all(const Grid *g, uint32_t *c)
{
    uint32_t nchunks = g->num_prims / COURSE_CHUNK + (g->num_prims % COURSE_CHUNK != 0);
    CourseJob job;
    memset(&job, 0, sizeof job);
    job.g = g;
    job.count[0] = c;
    par_for((int)nchunks, course_chunk, &job);
    for (int w = 1; w < PAR_MAX_WORKERS; w++) {
        if (!job.count[w])
            continue;
        for (uint32_t i = 0; i < g->num_cells; i++)
            c[i] += job.count[w][i];
        bigmem_free(job.count[w]);
    }
    return !job.oom;
}

const uint32_t *grid_course_counts(const Grid *g)
{
    uint32_t *c = atomic_load_explicit(&g->course_count, memory_order_acquire);
    if (c)
        return c;
    /* The counts are a cache of the (immutable) grid: made once, under the lock, by
     * whichever thread asks first; everyone else reads the published array. */
    Grid *mg = (Grid *)g;
    pthread_mutex_lock(&mg->course_lock);
    c = atomic_load_explicit(&mg->course_count, memory_order_relaxed);
    if (!c) {
        c = bigmem_calloc(g->num_cells, sizeof *c);
        /* The counts are sums, so the order of the primitives (grid_pack renumbered
         * them) does not matter. */
        if (c && !course_count_all(g, c)) {
            bigmem_free(c);
            c = NULL;
        }
        if (c)
            atomic_store_explicit(&mg->course_count, c, memory_order_release);
    }
    pthread_mutex_unlock(&mg->course_lock);
    return c;
}

/* ---- accessors ---- */

BBox grid_bounds(const Grid *g) { return g->bounds; }

void grid_dims(const Grid *g, int n[3])
{
    n[0] = g->n[0];
    n[1] = g->n[1];
    n[2] = g->n[2];
}

int grid_cell_count(const Grid *g, int i, int j, int k)
{
    if (i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2])
        return 0;
    const uint32_t *course = grid_course_counts(g);
    if (!course)
        return 0;
    uint32_t c = course[grid_cell_index(g, i, j, k)];
    return c > INT_MAX ? INT_MAX : (int)c;
}

int grid_cell_marching_count(const Grid *g, int i, int j, int k)
{
    if (i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2])
        return 0;
    uint32_t c = grid_cell_index(g, i, j, k);
    return (int)(g->cell_start[c + 1] - g->cell_start[c]);
}

uint32_t grid_mailbox_size(const Grid *g) { return g ? g->num_prims : 0; }

void grid_set_marking(Grid *g, bool on) { g->marking = on; }
bool grid_marking(const Grid *g) { return g->marking; }

void grid_entry_totals(const Grid *g, uint64_t *course, uint64_t *marching)
{
    uint64_t sum = 0;
    const uint32_t *count = grid_course_counts(g);
    for (uint32_t c = 0; count && c < g->num_cells; c++)
        sum += count[c];
    if (course)
        *course = sum;
    if (marching)
        *marching = g->cell_start[g->num_cells];
}
