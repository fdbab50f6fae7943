/* The grid's binning: every primitive's marching cells in parallel chunks on the set-up
 * threads (rt/par.h), the CSR arrays, then grid_pack. The result is the same on any
 * number of threads. */
#include "grid_build.h"

#include <stdlib.h>
#include <string.h>

#include "rt/bigmem.h"
#include "rt/par.h"

RecKind grid_rec_kind(const Prim *p)
{
    ObjKind k = obj_kind(p->obj);
    return k == OBJ_TRIANGLE ? REC_TRIANGLE : k == OBJ_SPHERE && !p->xf ? REC_SPHERE : REC_BOX;
}

RecKind grid_prim_rec_kind(const GridPrim *gp)
{
    Prim p;
    memset(&p, 0, sizeof p);
    p.obj = gp->obj;
    p.xf = gp->xf;
    return grid_rec_kind(&p);
}

/* The record of a primitive of kind kind. */
void grid_make_rec(const GridPrim *gp, RecKind kind, GridBuildRec *rec)
{
    rec->obj = gp->obj;
    rec->gp = gp->xf;
    rec->kind = kind;
    rec->r = 0.0f;
    if (rec->kind == REC_TRIANGLE) {
        triangle_vertices(rec->obj, rec->v);
        if (rec->gp)
            for (int i = 0; i < 3; i++)
                rec->v[i] = mat4_point(&rec->gp->m, rec->v[i]);
    } else if (rec->kind == REC_BOX) {
        BBox b = rec->obj->ops->bounds(rec->obj, rec->gp ? &rec->gp->m : NULL);
        rec->v[0] = b.min;
        rec->v[1] = b.max;
    } else {
        rec->v[0] = sphere_center(rec->obj);
        rec->r = sphere_radius(rec->obj);
    }
}

/* The record of prims[p] as the walk left it (kind in prim_ncells[p]). */
static void make_rec(const GridBuild *b, uint32_t p, GridBuildRec *rec)
{
    grid_make_rec(&b->g->prims[p], (RecKind)b->prim_ncells[p], rec);
}

void grid_free_build_state(GridBuild *b)
{
    bigmem_free(b->prim_ncells);
    b->prim_ncells = NULL;
    free(b->cell_axis);
    b->cell_axis = NULL;
}


/* Bytes of the packed arrays faulted in per extra chunk of the binning job. */
enum { PREFAULT_BYTES = 2 << 20 };

/* The binning job: the marching cells of every primitive (bin_chunk), then chunks that
 * fault in the pages of grid_pack's arrays (made before the job). Those pages are
 * first touched in any case, and zeroing a fresh 2 MB page takes 0.1-0.2 ms on the
 * virtual machines measured: touched in the pack, they were paid by one thread while the
 * other waited for the same page (the pack ran no faster on two threads than on one);
 * here they go to whichever thread runs out of binning work first. */
typedef struct BinJob {
    Grid *g;
    GridBuild *b;
    uint32_t nchunks;     /* binning chunks; chunks from nchunks on fault pages in */
    char *fault[2];       /* g->tri, g->tri_hit (or NULL) */
    size_t fault_len[2];
    uint32_t fault_chunks[2];
    BinPart part[PAR_MAX_WORKERS];
    BinChunk *chunk;
} BinJob;

/* Worker w's per-cell array in part->*field: worker 0 uses the grid's own, the others
 * fresh zero pages (faulted in by the worker itself). */
static uint32_t *part_cells(BinJob *job, int worker, uint32_t **field, uint32_t *own)
{
    if (!*field) {
        if (worker == 0) {
            *field = own;
        } else {
            *field = bigmem_calloc(job->g->num_cells, sizeof **field);
        }
    }
    return *field;
}

/* Extra chunk k: one store per 4 KB page of PREFAULT_BYTES of a packed array (the
 * memory is zero and nobody reads it before the job ends; a zero is stored). */
static void prefault_chunk(const BinJob *job, uint32_t k)
{
    int a = k < job->fault_chunks[0] ? 0 : 1;
    if (a == 1)
        k -= job->fault_chunks[0];
    size_t off = (size_t)k * PREFAULT_BYTES;
    size_t end = job->fault_len[a] - off > PREFAULT_BYTES ? off + PREFAULT_BYTES
                                                          : job->fault_len[a];
    volatile char *p = job->fault[a];
    for (size_t at = off; at < end; at += 4096)
        p[at] = 0;
}

/* The marching cells of chunk i of prims; prim_ncells[p] becomes p's cell count. */
static void bin_chunk(void *ctx, int i, int worker)
{
    BinJob *job = ctx;
    if ((uint32_t)i >= job->nchunks) {
        prefault_chunk(job, (uint32_t)i - job->nchunks);
        return;
    }
    Grid *g = job->g;
    BinPart *bp = &job->part[worker];
    if (bp->oom || bp->too_many || bp->stopped)
        return;
    /* A stop (Ctrl-C) is looked for once per BIN_CHUNK primitives: the 1.3M-triangle
     * blob's binning is ~0.4 s of a thread, so it ends within a millisecond or so. */
    if (par_stop_requested()) {
        bp->stopped = true;
        return;
    }
    if (!bp->pairs) {
        bp->g = g;
        bp->cell_axis = job->b->cell_axis;
        /* Room for about two cells per primitive, so the list rarely grows; three on
         * one thread, where this part takes every primitive: the course's 40k bunny
         * has 2.36 (94,407 entries), and its grown list was a fresh 2 MB mapping and a
         * copy, where 3 x 40k entries still come from bigmem's pool (rt/bigmem.h). */
        bp->cap_pairs = (par_threads() > 1 ? 2 : 3) * (size_t)g->num_prims + 1024;
        bp->pairs = bigmem_calloc(bp->cap_pairs, sizeof *bp->pairs);
        if (!bp->pairs || !part_cells(job, worker, &bp->count, g->cell_start + 1)) {
            bp->oom = true;
            return;
        }
    }
    uint32_t p0 = (uint32_t)i * BIN_CHUNK;
    uint32_t p1 = g->num_prims - p0 > BIN_CHUNK ? p0 + BIN_CHUNK : g->num_prims;
    size_t off = bp->num_pairs;
    for (uint32_t p = p0; p < p1; p++) {
        GridBuildRec rec;
        make_rec(job->b, p, &rec);
        uint32_t ncells = 0;
        if (!grid_tight_insert(bp, &rec, &ncells))
            return;
        job->b->prim_ncells[p] = ncells;
    }
    job->chunk[i].off = off;
    job->chunk[i].len = bp->num_pairs - off;
    job->chunk[i].worker = worker;
}

static bool parts_ok(const BinJob *job)
{
    for (int w = 0; w < PAR_MAX_WORKERS; w++)
        if (job->part[w].oom || job->part[w].too_many || job->part[w].stopped)
            return false;
    return true;
}

bool grid_fill_items(uint32_t *items, uint32_t *cursor, const uint32_t *ncells, uint32_t n,
                     const BinChunk *chunk, const BinPart *part)
{
    uint32_t nchunks = n / BIN_CHUNK + (n % BIN_CHUNK != 0);
    for (uint32_t k = 0; k < nchunks; k++) {
        /* One thread writes every entry here (tens of ms at 1.3M triangles): a stop is
         * looked for every FILL_STOP_CHUNKS chunks, about a millisecond apart. */
        if (k % FILL_STOP_CHUNKS == FILL_STOP_CHUNKS - 1 && par_stop_requested())
            return false;
        const uint32_t *cell = part[chunk[k].worker].pairs + chunk[k].off;
        uint32_t p1 = n - k * BIN_CHUNK > BIN_CHUNK ? (k + 1) * BIN_CHUNK : n;
        for (uint32_t p = k * BIN_CHUNK; p < p1; p++)
            for (uint32_t j = ncells[p]; j > 0; j--)
                items[cursor[*cell++]++] = p;
    }
    return true;
}

/* The marching cells of every primitive (bin_chunk, in parallel), the CSR arrays, then
 * grid_pack. The CSR fill adds the workers' counts
 * up into offsets and writes the entries chunk by chunk, i.e. in primitive order within
 * every cell, as one sequential pass writes them. False when out of memory, or with
 * b->too_many when the entries overflow a uint32_t. */
bool grid_bin_fill_pack(GridBuild *b)
{
    Grid *g = b->g;
    uint32_t n = g->num_prims, cells = g->num_cells;
    BinJob job;
    memset(&job, 0, sizeof job);
    job.g = g;
    job.b = b;
    job.nchunks = n / BIN_CHUNK + (n % BIN_CHUNK != 0);
    job.chunk = calloc(job.nchunks ? job.nchunks : 1, sizeof *job.chunk);
    bool ok = job.chunk != NULL;
    /* grid_pack's arrays, made now so the job faults them in (when they cannot be had,
     * grid_pack tries again and reports). */
    if (ok && grid_pack_wanted(g) && par_threads() > 1) {
        grid_pack_prepare(g, n);
        job.fault[0] = (char *)g->tri;
        job.fault[1] = (char *)g->tri_hit;
        job.fault_len[0] = g->tri ? (size_t)n * sizeof *g->tri : 0;
        job.fault_len[1] = g->tri_hit ? (size_t)n * sizeof *g->tri_hit : 0;
        for (int a = 0; a < 2; a++)
            job.fault_chunks[a] =
                (uint32_t)((job.fault_len[a] + PREFAULT_BYTES - 1) / PREFAULT_BYTES);
    }
    uint64_t total = 0;
    if (ok) {
        uint32_t all_chunks = job.nchunks + job.fault_chunks[0] + job.fault_chunks[1];
        par_for((int)all_chunks, bin_chunk, &job);
        for (int w = 0; w < PAR_MAX_WORKERS; w++) {
            b->too_many = b->too_many || job.part[w].too_many;
            b->stopped = b->stopped || job.part[w].stopped;
            total += job.part[w].num_pairs;
        }
        ok = parts_ok(&job);
        if (total > UINT32_MAX - 1u) {
            b->too_many = true;
            ok = false;
        }
    }
    if (ok) {
        /* Offsets; cell_start[c] is the fill cursor. */
        uint32_t *start = g->cell_start, run = 0;
        const uint32_t *more[PAR_MAX_WORKERS]; /* the helpers' counts that exist */
        int nmore = 0;
        for (int w = 1; w < PAR_MAX_WORKERS; w++)
            if (job.part[w].count)
                more[nmore++] = job.part[w].count;
        for (uint32_t c = 0; c < cells; c++) {
            uint32_t m = start[c + 1];
            for (int k = 0; k < nmore; k++)
                m += more[k][c];
            start[c] = run;
            run += m;
        }
        g->cell_items = bigmem_calloc((size_t)total + 1, sizeof *g->cell_items);
        ok = g->cell_items != NULL;
    }
    if (ok)
        ok = grid_fill_items(g->cell_items, g->cell_start, b->prim_ncells, n, job.chunk,
                             job.part);
    if (ok) {
        /* Each cursor now stands at the start of the next cell. */
        memmove(g->cell_start + 1, g->cell_start, (size_t)cells * sizeof *g->cell_start);
        g->cell_start[0] = 0;
        grid_free_build_state(b);
    }
    for (int w = 0; w < PAR_MAX_WORKERS; w++) {
        bigmem_free(job.part[w].pairs);
        job.part[w].pairs = NULL;
        if (w > 0)
            bigmem_free(job.part[w].count);
        job.part[w].count = NULL;
    }
    /* Packed copies of the untransformed triangles for the hot loop (grid_pack.c), which
     * fails when a stop cut it short too. */
    if (ok && par_stop_requested())
        ok = false;
    if (ok)
        ok = grid_pack(g);
    if (!ok && par_stop_requested())
        b->stopped = true;
    if (ok)
        grid_occupancy_make(g);
    free(job.chunk);
    return ok;
}
