/* The grid's cell-reference budget: what a resolution costs before anything is built.
 *
 * A primitive is referenced by every cell its marching set holds, and the course's
 * counts visit every cell of its box range. Neither is bounded by the primitive count:
 * 10,000 spheres at one point on a 34^3 grid make 400 million references, 100,000 large
 * triangles a billion. So the build first adds up, per primitive, the cells of the box
 * ranges both passes walk (an upper bound on what either stores or visits), and shrinks
 * the resolution until the sum fits the cap: time and memory then stay within a small
 * multiple of the primitive count (plus the cells themselves, which the option check
 * bounds). The estimate is exact arithmetic on the same ranges as the build, so a grid
 * under the cap is built exactly as before. */
#include "grid_build.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rt/par.h"

uint64_t grid_ref_cap(uint32_t num_bounded)
{
    return (uint64_t)GRID_REFS_PER_PRIM * num_bounded + GRID_REFS_FLOOR;
}

uint64_t grid_ref_cap_auto(uint32_t num_bounded)
{
    return (uint64_t)GRID_AUTO_REFS_PER_PRIM * num_bounded + GRID_AUTO_REFS_FLOOR;
}

/* The cell references of primitive p: the larger of its two box ranges' cell counts. */
static uint64_t prim_refs(const Grid *g, const Prim *p)
{
    GridPrim gp = {p->obj, p->xf};
    GridBuildRec rec;
    grid_make_rec(&gp, grid_rec_kind(p), &rec);
    uint64_t a = grid_tight_box_cells(g, &rec), b = grid_course_box_cells(g, &rec);
    return a > b ? a : b;
}

/* What tri_refs_bound needs of the grid, per axis, made once per estimate
 * (tri_bound_init): with them worked out in every call, the quick bound cost ~115
 * instructions a triangle (0.85 ms of line 07's 14 ms grid build at one thread). */
typedef struct TriBound {
    double k[3];   /* cells per world unit, widened by a relative 2e-6 */
    double c[3];   /* the pads' cells (widened alike), 2.5 and 1e-6 cell per axis cell */
    double n[3];   /* the axis' cells */
} TriBound;

static void tri_bound_init(TriBound *tb, const Grid *g)
{
    for (int a = 0; a < 3; a++) {
        tb->k[a] = 1.0 / (double)g->size[a] * (1.0 + 2e-6);
        tb->c[a] = 2.0 * (double)g->pad[a] * tb->k[a] + 2.5 + 1e-6 * (double)g->n[a];
        tb->n[a] = (double)g->n[a];
    }
}

/* An upper bound on prim_refs(g, p) for a triangle from its world box alone (p->bounds
 * is exactly the box of its world vertices, which both ranges start from), with no
 * division and without its vertices: on each axis a range holds at most
 * (extent + 2 pad) / size + 2 cells (the marching range's pad on both sides, one cell
 * more at each end for a partial cell; the course's tolerance of at most 1e-4 cell and
 * its float rounding are far inside the extra half cell added here, as are the few
 * ulps by which extent * k + c may round below its exact value), and never more than
 * the axis' cells. 0 for anything else (a NaN or inverted box): its refs are counted
 * exactly. Only the decision "within the cap" depends on it, never a result (any upper
 * bound gives the same grid: grid_fit_refs). */
static inline uint64_t tri_refs_bound(const TriBound *tb, const Prim *p)
{
    /* The three axes written out, each capped at n before one conversion: the loop over
     * the axes compiled to about 30 instructions an axis, with a branch for the cap. */
    const BBox *b = &p->bounds;
    double w0 = ((double)b->max.x - (double)b->min.x) * tb->k[0] + tb->c[0];
    double w1 = ((double)b->max.y - (double)b->min.y) * tb->k[1] + tb->c[1];
    double w2 = ((double)b->max.z - (double)b->min.z) * tb->k[2] + tb->c[2];
    if (!(w0 >= 0.0 && w1 >= 0.0 && w2 >= 0.0))
        return 0;
    w0 = w0 < tb->n[0] ? w0 : tb->n[0];
    w1 = w1 < tb->n[1] ? w1 : tb->n[1];
    w2 = w2 < tb->n[2] ? w2 : tb->n[2];
    /* At most n <= 2^24: the conversion to int truncates as the unsigned one would. */
    return (uint64_t)(int)w0 * (uint64_t)(int)w1 * (uint64_t)(int)w2;
}

/* Primitives per chunk of the estimate's parallel pass. */
enum { EST_CHUNK = 2048 };

/* The estimate's per-primitive term (see estimate). */
static inline uint64_t est_term(const Grid *g, const TriBound *tb, const Prim *p, bool quick)
{
    uint64_t r = quick && obj_kind(p->obj) == OBJ_TRIANGLE ? tri_refs_bound(tb, p) : 0;
    return r ? r : prim_refs(g, p);
}

/* The sum of est_term over the table's bounded primitives from index i0 on, with sum
 * and seen already counted before i0; past stop, the extrapolation (see estimate). */
static uint64_t est_serial(const PrimTable *t, const Grid *g, const TriBound *tb,
                           uint32_t i0, uint64_t sum, uint32_t seen, uint64_t stop, bool quick)
{
    for (uint32_t i = i0; i < t->num_prims; i++) {
        const Prim *p = &t->prims[i];
        if (!p->bounded)
            continue;
        sum += est_term(g, tb, p, quick);
        seen++;
        if (sum > stop && seen < t->num_bounded)
            return (uint64_t)((double)sum * ((double)t->num_bounded / (double)seen));
    }
    return sum;
}

/* The parallel pass: each chunk's sum and count of bounded primitives. */
typedef struct EstJob {
    const PrimTable *t;
    const Grid *g;
    const TriBound *tb;
    bool quick;
    uint64_t *sum;
    uint32_t *seen;
} EstJob;

static void est_chunk(void *ctx, int k, int worker)
{
    (void)worker;
    const EstJob *job = ctx;
    uint32_t i0 = (uint32_t)k * EST_CHUNK;
    uint32_t i1 = job->t->num_prims - i0 > EST_CHUNK ? i0 + EST_CHUNK : job->t->num_prims;
    uint64_t sum = 0;
    uint32_t seen = 0;
    for (uint32_t i = i0; i < i1; i++) {
        const Prim *p = &job->t->prims[i];
        if (!p->bounded)
            continue;
        sum += est_term(job->g, job->tb, p, job->quick);
        seen++;
    }
    job->sum[k] = sum;
    job->seen[k] = seen;
}

/* The estimate for n, or (when it passes stop) an extrapolation from the primitives
 * added so far, which is enough to choose the next resolution to try. quick: take
 * tri_refs_bound for triangles, an upper bound on the estimate (used to skip the
 * exact sum when even the bound fits the cap, as on every dense mesh).
 * On the set-up threads (rt/par.h) when it usually runs to the end (the quick bound,
 * the full sum): chunk sums, added in chunk order up to the chunk where the running sum
 * passes stop, from which on the primitives are added one by one as before. Sums of
 * integers, so the result is the serial loop's on any number of threads. The exact
 * estimates of a refit, which usually stop early, stay serial. */
static uint64_t estimate(const PrimTable *t, const int n[3], uint64_t stop, bool quick)
{
    if (!t || t->num_bounded == 0 || bbox_is_empty(&t->scene_bounds))
        return 0;
    Grid g;
    memset(&g, 0, sizeof g);
    g.bounds = t->scene_bounds;
    memcpy(g.n, n, sizeof g.n);
    grid_setup_geometry(&g);
    TriBound tb;
    tri_bound_init(&tb, &g);
    uint32_t nchunks = t->num_prims / EST_CHUNK + (t->num_prims % EST_CHUNK != 0);
    if ((!quick && stop != UINT64_MAX) || nchunks < 2 || par_threads() < 2)
        return est_serial(t, &g, &tb, 0, 0, 0, stop, quick);
    uint64_t *sums = malloc(nchunks * sizeof *sums);
    uint32_t *seens = malloc(nchunks * sizeof *seens);
    if (!sums || !seens) {
        free(sums);
        free(seens);
        return est_serial(t, &g, &tb, 0, 0, 0, stop, quick);
    }
    EstJob job = {t, &g, &tb, quick, sums, seens};
    par_for((int)nchunks, est_chunk, &job);
    uint64_t sum = 0;
    uint32_t seen = 0, k = 0;
    for (; k < nchunks && sum + sums[k] <= stop; k++) {
        sum += sums[k];
        seen += seens[k];
    }
    free(sums);
    free(seens);
    return k == nchunks ? sum
                        : est_serial(t, &g, &tb, k * EST_CHUNK, sum, seen, stop, quick);
}

uint64_t grid_ref_estimate(const PrimTable *t, const int n[3])
{
    return estimate(t, n, UINT64_MAX, false);
}

bool grid_fit_refs(const PrimTable *t, int n[3], uint64_t cap, uint64_t *est_out)
{
    bool changed = false;
    /* Within the cap by the bound: within it exactly. */
    uint64_t est = estimate(t, n, cap, true);
    bool exact = false;
    if (est > cap) {
        est = estimate(t, n, cap, false);
        exact = true;
    }
    while (est > cap && (n[0] > 1 || n[1] > 1 || n[2] > 1)) {
        /* Volume-filling primitives scale with the cell count, surfaces with its 2/3
         * power, points not at all: take the cube root (the most hopeful) and let the
         * loop take further steps, at least 10% each. */
        double f = cbrt((double)cap / (double)est);
        f = f < 0.05 ? 0.05 : f > 0.9 ? 0.9 : f;
        int m[3], big = 0;
        for (int a = 0; a < 3; a++) {
            double v = floor((double)n[a] * f);
            m[a] = v < 1.0 ? 1 : (int)v;
            if (n[a] > n[big])
                big = a;
        }
        if (m[0] == n[0] && m[1] == n[1] && m[2] == n[2])
            m[big] = n[big] - 1;
        memcpy(n, m, sizeof m);
        changed = true;
        est = estimate(t, n, cap, false);
    }
    if (est_out)
        *est_out = exact ? est : estimate(t, n, UINT64_MAX, false);
    return changed;
}
