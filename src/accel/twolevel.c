/* TwoLevelGrid (rt/twolevel.h): a coarse course Grid whose crowded cells each get a
 * uniform grid of their own (Kalojanov et al. 2011), fitted to the box the cell's
 * primitives occupy inside it. The leaf grids hold the top grid's own entries (packed
 * triangles tagged as in cell_items), so the cell loop, the mailbox and the hit rule are
 * the top grid's: the answers are the brute-force loop's to the bit. */
#include "twolevel_internal.h"
#include "grid_build.h"

#include <float.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "rt/accel.h"
#include "rt/bigmem.h"
#include "rt/geom.h"
#include "rt/par.h"
#include "rt/prim.h"
#include "rt/twolevel.h"

/* Top cells per primitive and leaf cells per entry of a top cell (Kalojanov et al.
 * use a sparse top level and about one to a few leaf cells per primitive); chosen by
 * measurement on the benchmark's uneven scenes (docs/twolevel.md). */
#define TOP_LAMBDA (1.0 / 16.0)
#define LEAF_LAMBDA 2.0
/* A top cell with at most this many entries keeps its list (a leaf grid would not pay). */
#define LEAF_MIN 12u
/* At most this many large entries per top cell are kept out of its leaf grid. */
#define BIG_MAX 16u
#define TOP_MAX_AXIS 256
#define LEAF_MAX_AXIS 128
/* Memory and time bounds, whatever the input (co-located or huge primitives): the top
 * grid's entries stay under TOP_DUP entries per primitive (its resolution shrinks until
 * the estimate fits), a leaf grid under LEAF_DUP entries per entry of its top cell, and
 * all leaf grids together under LEAF_BUDGET_DUP entries and cells per primitive. */
#define TOP_DUP 8.0
#define LEAF_DUP 6.0
#define LEAF_BUDGET_DUP 16.0
#define BUDGET_SLACK 65536.0

/* -grid auto takes the two levels when the crowding exceeds this many times the cube
 * root of the primitive count. A mesh surface spread over the scene has a crowding of
 * about 2.5 to 3 times it (a surface crosses ~(N/16)^(2/3) top cells); the benchmark's
 * dense mesh in a room 100x its size has 360 times it, its clusters 28 (measured,
 * docs/twolevel.md). */
#define AUTO_CROWDING 8.0

/* ---- world boxes of the table's bounded primitives (for the top resolution) ---- */

/* Their boxes as 6 floats each (min xyz, max xyz); NULL when out of memory. */
static float (*table_boxes(const PrimTable *t, size_t *count))[6]
{
    float (*b)[6] = bigmem_alloc(((size_t)t->num_bounded + 1) * sizeof *b);
    size_t n = 0;
    for (uint32_t i = 0; b && i < t->num_prims; i++) {
        const Prim *p = &t->prims[i];
        if (!p->bounded)
            continue;
        float *d = b[n++];
        d[0] = p->bounds.min.x, d[1] = p->bounds.min.y, d[2] = p->bounds.min.z;
        d[3] = p->bounds.max.x, d[4] = p->bounds.max.y, d[5] = p->bounds.max.z;
    }
    *count = n;
    return b;
}

/* Resolution of about target cells over box, cells as near cubes as the box allows
 * (axes thinner than 1/1000 of the largest get one cell), at most max_axis per axis. */
static void choose_dims(const float lo[3], const float hi[3], double target, int max_axis,
                        int n[3])
{
    double e[3], emax = 0.0, vol = 1.0;
    int dims = 0;
    n[0] = n[1] = n[2] = 1;
    for (int a = 0; a < 3; a++) {
        e[a] = (double)hi[a] - (double)lo[a];
        if (!isfinite(e[a]) || e[a] < 0.0)
            return;
        emax = fmax(emax, e[a]);
    }
    if (!(emax > 0.0) || !(target > 1.0))
        return;
    for (int a = 0; a < 3; a++)
        if (e[a] > 1e-3 * emax) {
            vol *= e[a];
            dims++;
        }
    double k = pow(target / vol, 1.0 / dims);
    for (int a = 0; a < 3; a++) {
        if (!(e[a] > 1e-3 * emax))
            continue;
        double v = floor(e[a] * k + 0.5);
        n[a] = v < 1.0 ? 1 : v > max_axis ? max_axis : (int)v;
    }
}

/* ceil(y) and floor(z) clamped to [0, n - 1] (NaN and below 0 give 0), by compares
 * and one conversion: ceil and floor are library calls without SSE4.1. */
static inline int ceil_clamp(double y, int n)
{
    if (!(y > 0.0))
        return 0;
    if (y >= (double)(n - 1))
        return n - 1;
    int i = (int)y;
    return (double)i < y ? i + 1 : i;
}

static inline int floor_clamp(double z, int n)
{
    if (!(z >= 0.0))
        return 0;
    if (z >= (double)(n - 1))
        return n - 1;
    return (int)z;
}

/* Cell range [*lo, *hi] on one axis of cells starting at mn, size s, padded by p, that
 * the interval [bmin, bmax] meets (a cell's padded span [mn+i*s-p, mn+(i+1)*s+p]). */
static inline void axis_range(double bmin, double bmax, double mn, double s, double p, int n,
                              int *lo, int *hi)
{
    *lo = ceil_clamp((bmin - p - mn) / s - 1.0, n);
    *hi = floor_clamp((bmax + p - mn) / s, n);
}

/* Entries a grid of n cells over [lo, hi] would get from boxes (their box ranges, an
 * estimate: reciprocal cell sizes); stops counting once above limit. The boxes: b[i]
 * for i < count, or (sel non-NULL) b[GRID_ITEM_INDEX(items[sel[i]])], a top cell's
 * selected entries read in place instead of copied out first. */
static double estimate_entries(const float (*b)[6], const uint32_t *items,
                               const uint32_t *sel, size_t count, const float lo[3],
                               const float hi[3], const int n[3], double limit)
{
    double inv[3], mn[3], total = 0.0;
    for (int a = 0; a < 3; a++) {
        mn[a] = (double)lo[a];
        inv[a] = n[a] / ((double)hi[a] - (double)lo[a]);
    }
    for (size_t i = 0; i < count && total <= limit; i++) {
        const float *bi = sel ? b[GRID_ITEM_INDEX(items[sel[i]])] : b[i];
        double cells = 1.0;
        for (int a = 0; a < 3; a++) {
            int l = ceil_clamp(((double)bi[a] - mn[a]) * inv[a] - 1.0, n[a]);
            int h = floor_clamp(((double)bi[3 + a] - mn[a]) * inv[a], n[a]);
            cells *= (double)(h - l + 1);
        }
        total += cells;
    }
    return total;
}

/* Shrinks n (by 4/5 per axis, at least one cell less) until the estimate fits; returns
 * the estimate. */
static double fit_dims(const float (*b)[6], const uint32_t *items, const uint32_t *sel,
                       size_t count, const float lo[3], const float hi[3], double limit,
                       int n[3])
{
    for (;;) {
        double est = estimate_entries(b, items, sel, count, lo, hi, n, limit);
        if (est <= limit || (n[0] == 1 && n[1] == 1 && n[2] == 1))
            return est;
        for (int a = 0; a < 3; a++)
            if (n[a] > 1)
                n[a] = n[a] * 4 / 5 < n[a] - 1 ? n[a] * 4 / 5 : n[a] - 1;
    }
}

/* ---- when the two levels pay: crowding ---- */

double twolevel_crowding(const PrimTable *t)
{
    if (!t || t->num_bounded == 0 || bbox_is_empty(&t->scene_bounds))
        return 0.0;
    const BBox *sb = &t->scene_bounds;
    float lo[3] = {sb->min.x, sb->min.y, sb->min.z};
    float hi[3] = {sb->max.x, sb->max.y, sb->max.z};
    int n[3];
    double inv[3];
    choose_dims(lo, hi, TOP_LAMBDA * (double)t->num_bounded, TOP_MAX_AXIS, n);
    for (int a = 0; a < 3; a++)
        inv[a] = hi[a] > lo[a] ? n[a] / ((double)hi[a] - (double)lo[a]) : 0.0;
    size_t cells = (size_t)n[0] * (size_t)n[1] * (size_t)n[2];
    uint32_t *count = calloc(cells, sizeof *count);
    if (!count)
        return 0.0;
    uint64_t prims = 0;
    for (uint32_t i = 0; i < t->num_prims; i++) {
        const Prim *p = &t->prims[i];
        if (!p->bounded)
            continue;
        size_t c = 0;
        for (int a = 2; a >= 0; a--) {
            double x = 0.5 * ((double)v3_comp(p->bounds.min, a) +
                              (double)v3_comp(p->bounds.max, a));
            c = c * (size_t)n[a] + (size_t)floor_clamp((x - (double)lo[a]) * inv[a], n[a]);
        }
        count[c]++;
        prims++;
    }
    double sum = 0.0;
    for (size_t c = 0; c < cells; c++)
        sum += (double)count[c] * (double)count[c];
    free(count);
    return prims ? sum / (double)prims : 0.0;
}

bool twolevel_preferred(const PrimTable *t)
{
    if (!t || t->num_bounded == 0)
        return false;
    return twolevel_crowding(t) > AUTO_CROWDING * cbrt((double)t->num_bounded);
}

/* ---- the leaf grids ---- */

/* How far beyond its edges a triangle with box b can be hit: the triangle test accepts
 * barycentric coordinates down to -RT_TRI_EDGE_TOL and a sum up to 1 + RT_TRI_FAR_TOL
 * (rt/geom.h), i.e. points up to about that fraction of its edges outside it; the sum of
 * the box's sides bounds every edge. Leaf cells are far finer than the course grid's,
 * so their padding alone need not cover it. */
static float tri_tolerance(BBox b)
{
    Vec3 e = v3_sub(b.max, b.min);
    return 2.0f * (RT_TRI_EDGE_TOL + RT_TRI_FAR_TOL) * (e.x + e.y + e.z);
}

/* World box of top-grid primitive p, widened a little so rounding in a transformed
 * box cannot make it smaller than the primitive (triangles: exact vertex bounds). */
static void prim_box(const Grid *g, uint32_t p, float out[6])
{
    const GridPrim *gp = &g->prims[p];
    BBox b;
    if (!gp->xf && obj_kind(gp->obj) == OBJ_TRIANGLE) {
        Vec3 v[3];
        triangle_vertices(gp->obj, v);
        b.min = v3_min(v3_min(v[0], v[1]), v[2]);
        b.max = v3_max(v3_max(v[0], v[1]), v[2]);
        float w = tri_tolerance(b);
        b.min = v3_sub(b.min, v3(w, w, w));
        b.max = v3_add(b.max, v3(w, w, w));
    } else if (gp->xf) {
        b = bbox_transform(&gp->obj->bbox, &gp->xf->m);
        Vec3 e = v3_sub(b.max, b.min);
        float w = 1e-5f * (fabsf(e.x) + fabsf(e.y) + fabsf(e.z)) + 1e-6f * g->box_mag;
        b.min = v3_sub(b.min, v3(w, w, w));
        b.max = v3_add(b.max, v3(w, w, w));
    } else {
        b = gp->obj->bbox;
    }
    out[0] = b.min.x, out[1] = b.min.y, out[2] = b.min.z;
    out[3] = b.max.x, out[4] = b.max.y, out[5] = b.max.z;
}

static bool grow(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return true;
    size_t cap2 = *cap ? *cap : 1024;
    while (cap2 < need)
        cap2 *= 2;
    void *q = bigmem_resize(*p, cap2 * elem);
    if (!q)
        return false;
    *p = q;
    *cap = cap2;
    return true;
}

/* grow to exactly need elements (when it grows at all): for arrays sized once to what
 * they will hold, so that one of 16 KB to 512 KB comes from bigmem's shared huge-page
 * pool instead of a 2 MB mapping of its own, which the doubling's rounding could
 * reach. */
static bool grow_exact(void **p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return true;
    void *q = bigmem_resize(*p, need * elem);
    if (!q)
        return false;
    *p = q;
    *cap = need;
    return true;
}

/* Scratch of the leaf builds, reused from cell to cell (one per set-up thread). */
typedef struct LeafScratch {
    uint32_t *npairs;      /* per entry: how many leaf cells it went into */
    uint32_t *cells;       /* those cells, entry after entry */
    uint32_t *count;       /* per leaf cell: entries, then the fill cursor */
    size_t cap_npairs, cap_cells, cap_count;
} LeafScratch;

static void scratch_free(LeafScratch *ls)
{
    bigmem_free(ls->npairs);
    bigmem_free(ls->cells);
    bigmem_free(ls->count);
}

/* A leaf grid as planned by plan_leaf (in top-cell order: the budget is spent in that
 * order) and filled by fill_leaf (on any set-up thread, into arrays of its own, which
 * twolevel_build then appends in plan order). */
typedef struct LeafPlan {
    uint32_t c;            /* its top cell */
    SubGrid sg;            /* base and big_start are set when it is appended */
    uint32_t small0, ns;   /* its entries: small[small0 .. small0 + ns), indices into the
                              top cell's list, in list order */
    uint32_t nbig;
    uint32_t cells;
    double est;            /* fit_dims' estimate of its entries: fill_leaf's first
                              capacity for its pairs (a hint; they may exceed it) */
    uint32_t base;         /* its first cell in TwoLevelGrid.start (the cells of the
                              plans before it): fill_leaf writes its cells' offsets
                              there, from 0, and append_leaf shifts them in place */
    uint32_t npairs;       /* filled: its entries (the offset after its last cell) */
    uint32_t *items;       /* filled: the entries of its cells, cell after cell */
    bool ok;               /* filled without running out of memory */
} LeafPlan;

typedef struct LeafPlans {
    LeafPlan *p;
    size_t n, cap;
    uint32_t *small;
    size_t nsmall, cap_small;
} LeafPlans;

/* fminf and fmaxf as glibc's x86-64 code computes them (minss/maxss: x < y ? x : y,
 * x > y ? x : y, so y for equal operands such as -0 and +0; the other operand when one
 * is a NaN), inline: the library calls were 3% of the stadium's set-up. */
static inline float min_f(float x, float y) { return x < y || y != y ? x : y; }
static inline float max_f(float x, float y) { return x > y || y != y ? x : y; }

/* Plans the leaf grid of top cell c (grid coordinates ci): appends it to P when it
 * pays and fits the budget (spending it); false when out of memory. */
static bool plan_leaf(const Grid *g, uint32_t c, const int ci[3], const float (*pbox)[6],
                      double *budget, LeafPlans *P)
{
    const uint32_t *items = g->cell_items + g->cell_start[c];
    uint32_t m = g->cell_start[c + 1] - g->cell_start[c];
    if (m <= LEAF_MIN)
        return true;
    /* The cell's box as the march tiles it, and the primitives' boxes clipped to it:
     * the part of the cell where this cell's entries can be hit. */
    float clo[3], chi[3], lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        float mn = v3_comp(g->box.min, a);
        clo[a] = mn + (float)ci[a] * g->size[a];
        chi[a] = ci[a] == g->n[a] - 1 ? v3_comp(g->box.max, a)
                                      : mn + (float)(ci[a] + 1) * g->size[a];
        lo[a] = INFINITY;
        hi[a] = -INFINITY;
    }
    if (!grow((void **)&P->small, &P->cap_small, P->nsmall + m, sizeof *P->small))
        return false;
    uint32_t *small = P->small + P->nsmall;
    /* Large entries (inside the cell, more than half its side on two axes: a floor, a
     * wall) would stretch the leaf grid over the whole cell; when there are few of
     * them they are kept aside and tested for every ray entering the cell. */
    uint32_t ns = 0, nbig = 0;
    for (uint32_t e = 0; e < m; e++) {
        const float *b = pbox[GRID_ITEM_INDEX(items[e])];
        int wide = 0;
        for (int a = 0; a < 3; a++)
            wide += min_f(b[3 + a], chi[a]) - max_f(b[a], clo[a]) > 0.5f * (chi[a] - clo[a]);
        if (wide >= 2)
            nbig++;
        else
            small[ns++] = e;
    }
    if (nbig > BIG_MAX || ns <= LEAF_MIN) {
        ns = m;
        for (uint32_t e = 0; e < m; e++)
            small[e] = e;
        nbig = 0;
    }
    for (uint32_t q = 0; q < ns; q++) {
        const float *b = pbox[GRID_ITEM_INDEX(items[small[q]])];
        for (int a = 0; a < 3; a++) {
            lo[a] = min_f(lo[a], max_f(b[a], clo[a]));
            hi[a] = max_f(hi[a], min_f(b[3 + a], chi[a]));
        }
    }
    for (int a = 0; a < 3; a++) {
        if (!(lo[a] <= hi[a])) { /* entries only in the cell's padding */
            lo[a] = clo[a];
            hi[a] = chi[a];
        }
        /* Thin axes (a floor) get a small thickness so leaf cells stay positive. */
        float thick = 1e-3f * (chi[a] - clo[a]);
        if (!(hi[a] - lo[a] >= thick)) {
            float mid = 0.5f * (lo[a] + hi[a]);
            lo[a] = mid - thick;
            hi[a] = mid + thick;
        }
    }
    int n[3];
    choose_dims(lo, hi, LEAF_LAMBDA * ns, LEAF_MAX_AXIS, n);
    double est = fit_dims(pbox, items, small, ns, lo, hi, LEAF_DUP * ns, n) + nbig;
    uint64_t cells = (uint64_t)n[0] * (uint64_t)n[1] * (uint64_t)n[2];
    if (cells <= 1)
        return true;
    if (est + (double)cells > *budget)
        return true;
    *budget -= est + (double)cells;

    if (!grow((void **)&P->p, &P->cap, P->n + 1, sizeof *P->p))
        return false;
    LeafPlan *pl = &P->p[P->n++];
    memset(pl, 0, sizeof *pl);
    pl->c = c;
    pl->small0 = (uint32_t)P->nsmall;
    pl->ns = ns;
    pl->nbig = nbig;
    pl->cells = (uint32_t)cells; /* at most LEAF_MAX_AXIS^3 */
    pl->est = est;
    P->nsmall += ns;
    SubGrid *sg = &pl->sg;
    sg->box.min = v3(lo[0], lo[1], lo[2]);
    sg->box.max = v3(hi[0], hi[1], hi[2]);
    for (int a = 0; a < 3; a++) {
        sg->n[a] = n[a];
        /* The march's cell size ((max - min) / n, in float) and the course grid's pad:
         * 1% of a cell plus a few ulps of the scene's coordinates (grid.c). */
        sg->size[a] = (hi[a] - lo[a]) / (float)n[a];
        sg->pad[a] = 1e-2f * sg->size[a] + 1e-5f * g->box_mag;
        /* march_init's own expressions (marching_info.c), for the walk's march */
        sg->inv_size[a] = (float)n[a] / (hi[a] - lo[a]);
        sg->slab_lo[a] = lo[a] - sg->pad[a];
        sg->slab_hi[a] = hi[a] + sg->pad[a];
    }
    sg->min_pad = fminf(sg->pad[0], fminf(sg->pad[1], sg->pad[2]));
    sg->big_count = nbig;
    return true;
}

/* Fills planned leaf grid pl: its cells' entries, in the top list's order within each
 * cell (its offsets into start at pl->base, pl->items; pl->ok false when out of
 * memory). */
static void fill_leaf(const Grid *g, LeafPlan *pl, const uint32_t *small, LeafScratch *ls,
                      const float (*pbox)[6], uint32_t *start)
{
    const uint32_t *items = g->cell_items + g->cell_start[pl->c];
    const SubGrid *sg = &pl->sg;
    const float lo[3] = {sg->box.min.x, sg->box.min.y, sg->box.min.z};
    const int *n = sg->n;
    uint32_t ns = pl->ns, cells = pl->cells;
    if (!grow_exact((void **)&ls->npairs, &ls->cap_npairs, ns, sizeof *ls->npairs) ||
        !grow_exact((void **)&ls->count, &ls->cap_count, cells, sizeof *ls->count))
        return;
    memset(ls->count, 0, cells * sizeof *ls->count);
    /* The pairs' array at about its final size at once: grown pair by pair from 1024,
     * its copies faulted in fresh pages at every doubling (a leaf grid of the stadium
     * has ~60k pairs). */
    if (pl->est < 16e6 && !grow_exact((void **)&ls->cells, &ls->cap_cells, (size_t)pl->est + 1,
                                sizeof *ls->cells))
        return;

    /* Each entry's leaf cells: the padded cells its box meets (border cells stretched
     * to its box, as the course grid's), triangles by the exact overlap test. */
    size_t npairs = 0;
    for (uint32_t q = 0; q < ns; q++) {
        uint32_t e = small[q];
        const float *b = pbox[GRID_ITEM_INDEX(items[e])];
        int r[6];
        for (int a = 0; a < 3; a++)
            axis_range((double)b[a], (double)b[3 + a], (double)lo[a], (double)sg->size[a],
                       (double)sg->pad[a], n[a], &r[a], &r[3 + a]);
        uint32_t p = GRID_ITEM_INDEX(items[e]);
        size_t before = npairs;
        /* Triangles are tested exactly unless their range is one cell; the others
         * (spheres, transformed primitives) go into every cell of their box's range. */
        const GridPrim *gp = &g->prims[p];
        bool test = !gp->xf && obj_kind(gp->obj) == OBJ_TRIANGLE &&
                    (r[0] != r[3] || r[1] != r[4] || r[2] != r[5]);
        double v[3][3], tol = 0.0;
        /* Per axis and cell of the range, what tri_in_cell computes for that axis alone
         * (the padded cell side, border cells stretched to the box; the centre, the half
         * size grown by tol, the vertices relative to the centre and whether each lies
         * well inside): the same doubles by the same operations, made once per row
         * instead of once per cell. Bit k of vin: vertex k is inside on that axis. */
        double ah[3][LEAF_MAX_AXIS], arel[3][LEAF_MAX_AXIS][3];
        unsigned char vin[3][LEAF_MAX_AXIS];
        if (test) {
            Vec3 tv[3];
            triangle_vertices(gp->obj, tv);
            for (int q2 = 0; q2 < 3; q2++)
                for (int a = 0; a < 3; a++)
                    v[q2][a] = (double)v3_comp(tv[q2], a);
            BBox tb = {v3_min(v3_min(tv[0], tv[1]), tv[2]), v3_max(v3_max(tv[0], tv[1]), tv[2])};
            tol = (double)tri_tolerance(tb);
            for (int a = 0; a < 3; a++) {
                double mn = (double)lo[a], sz = (double)sg->size[a], pd = (double)sg->pad[a];
                for (int ca = r[a]; ca <= r[3 + a]; ca++) {
                    double clo2 = mn + ca * sz - pd, chi2 = mn + (ca + 1) * sz + pd;
                    if (ca == 0 && (double)b[a] < clo2)
                        clo2 = (double)b[a];
                    if (ca == n[a] - 1 && (double)b[3 + a] > chi2)
                        chi2 = (double)b[3 + a];
                    int x = ca - r[a];
                    double mid = 0.5 * (clo2 + chi2);
                    ah[a][x] = 0.5 * (chi2 - clo2) + tol;
                    unsigned char bits = 0;
                    for (int k = 0; k < 3; k++) {
                        arel[a][x][k] = v[k][a] - mid;
                        bits |= (unsigned char)((fabs(arel[a][x][k]) <=
                                                 ah[a][x] * GRID_INSIDE_SHRINK) << k);
                    }
                    vin[a][x] = bits;
                }
            }
        }
        for (int k = r[2]; k <= r[5]; k++)
            for (int j = r[1]; j <= r[4]; j++)
                for (int i = r[0]; i <= r[3]; i++) {
                    if (test) {
                        /* tri_in_cell(v, the cell, tol), from the rows' values */
                        int x = i - r[0], y = j - r[1], z = k - r[2];
                        unsigned in = vin[0][x] & vin[1][y] & vin[2][z];
                        if (!(in & 1u)) { /* vertex 0 inside: overlap, without a test */
                            double rel[3][3], h[3] = {ah[0][x], ah[1][y], ah[2][z]};
                            bool inv[3] = {false, (in & 2u) != 0, (in & 4u) != 0};
                            for (int q2 = 0; q2 < 3; q2++) {
                                rel[q2][0] = arel[0][x][q2];
                                rel[q2][1] = arel[1][y][q2];
                                rel[q2][2] = arel[2][z][q2];
                            }
                            if (!grid_tri_cell_overlap_in(rel, h, inv))
                                continue;
                        }
                    }
                    if (!grow((void **)&ls->cells, &ls->cap_cells, npairs + 1,
                              sizeof *ls->cells))
                        return;
                    uint32_t cell = ((uint32_t)k * (uint32_t)n[1] + (uint32_t)j) *
                                        (uint32_t)n[0] + (uint32_t)i;
                    ls->cells[npairs++] = cell;
                    ls->count[cell]++;
                }
        ls->npairs[q] = (uint32_t)(npairs - before);
    }

    /* Its arrays: offsets (its cells' part of t->start; the one after its last cell is
     * the next plan's first, so it is left to append_leaf), then the entries, in
     * top-list order within each cell. */
    pl->items = bigmem_alloc((npairs + 1) * sizeof *pl->items);
    if (!pl->items)
        return;
    uint32_t *st = start + pl->base;
    uint32_t run = 0;
    for (uint32_t k = 0; k < cells; k++) {
        st[k] = run;
        run += ls->count[k];
        ls->count[k] = st[k];
    }
    pl->npairs = run;
    const uint32_t *cell = ls->cells;
    for (uint32_t q = 0; q < ns; q++)
        for (uint32_t j = ls->npairs[q]; j > 0; j--)
            pl->items[ls->count[*cell++]++] = items[small[q]];
    pl->ok = true;
}

/* Appends filled leaf grid pl to t: its cells' offsets (shifted to t's items), its
 * entries, then its large entries in list order. The offset after its last cell is
 * written here and overwritten by the next leaf grid's first (the position after this
 * one's large entries), as when they were appended one by one: the last cell of every
 * leaf grid but the last lists the large entries too (the counts depend on it). */
static bool append_leaf(TwoLevelGrid *t, LeafPlan *pl, const uint32_t *small)
{
    const Grid *g = t->top;
    const uint32_t *items = g->cell_items + g->cell_start[pl->c];
    uint32_t m = g->cell_start[pl->c + 1] - g->cell_start[pl->c];
    uint32_t cells = pl->cells, npairs = pl->npairs, nbig = pl->nbig, ns = pl->ns;
    if (t->num_subs == t->cap_subs) {
        uint32_t cap = t->cap_subs ? 2 * t->cap_subs : 64;
        SubGrid *sp = realloc(t->subs, cap * sizeof *sp);
        if (!sp)
            return false;
        t->subs = sp;
        t->cap_subs = cap;
    }
    if (!grow((void **)&t->start, &t->cap_cells, t->num_cells + cells + 1, sizeof *t->start) ||
        !grow((void **)&t->items, &t->cap_items, t->num_items + npairs + nbig,
              sizeof *t->items))
        return false;
    SubGrid sg = pl->sg;
    sg.base = (uint32_t)t->num_cells; /* = pl->base, where fill_leaf put its offsets */
    uint32_t *st = t->start + t->num_cells;
    uint32_t run = (uint32_t)t->num_items;
    st[0] = run; /* its offset from 0; the slot held the previous plan's last one */
    for (uint32_t k = 1; k < cells; k++)
        st[k] += run;
    st[cells] = run + npairs;
    memcpy(t->items + t->num_items, pl->items, (size_t)npairs * sizeof *t->items);
    t->num_cells += cells;
    t->num_items += npairs;
    /* The large entries after them, in list order. */
    sg.big_start = (uint32_t)t->num_items;
    for (uint32_t e = 0, q = 0; e < m && nbig; e++) {
        if (q < ns && small[q] == e) {
            q++;
            continue;
        }
        t->items[t->num_items++] = items[e];
    }
    t->sub_of[pl->c] = t->num_subs;
    t->subs[t->num_subs++] = sg;
    return true;
}

/* The fill phase on the set-up threads: chunk i fills the plan order[i] (largest
 * first, so the last chunks are short), with that worker's scratch. */
typedef struct FillJob {
    const Grid *g;
    LeafPlans *plans;
    const uint32_t *order;
    const float (*pbox)[6];
    uint32_t *start;       /* TwoLevelGrid.start, at its final size */
    LeafScratch scratch[PAR_MAX_WORKERS];
} FillJob;

static void fill_chunk(void *ctx, int i, int worker)
{
    FillJob *job = ctx;
    LeafPlan *pl = &job->plans->p[job->order[i]];
    if (par_stop_requested())
        return; /* pl->ok stays false: the build ends (twolevel_build) */
    fill_leaf(job->g, pl, job->plans->small + pl->small0, &job->scratch[worker], job->pbox,
              job->start);
}

/* Plans by size, largest first (ties in plan order): (ns, index) pairs for qsort. */
typedef struct PlanKey {
    uint32_t ns, index;
} PlanKey;

static int plan_key_desc(const void *a, const void *b)
{
    const PlanKey *x = a, *y = b;
    if (x->ns != y->ns)
        return x->ns > y->ns ? -1 : 1;
    return x->index < y->index ? -1 : x->index > y->index;
}

void twolevel_free(TwoLevelGrid *t)
{
    if (!t)
        return;
    grid_free(t->top);
    free(t->sub_of);
    free(t->subs);
    bigmem_free(t->start);
    bigmem_free(t->items);
    free(t);
}

TwoLevelGrid *twolevel_build(const PrimTable *table, Diag *diag)
{
    if (!table || table->num_bounded == 0 || bbox_is_empty(&table->scene_bounds))
        return NULL;
    /* The top resolution: about TOP_LAMBDA cells per primitive, fewer when the
     * primitives' boxes would put too many entries in them (huge or co-located ones). */
    size_t nb = 0;
    float (*boxes)[6] = table_boxes(table, &nb);
    if (!boxes) {
        diag_error(diag, NULL, "out of memory building the two-level grid");
        return NULL;
    }
    const BBox *sb = &table->scene_bounds;
    float lo[3] = {sb->min.x, sb->min.y, sb->min.z};
    float hi[3] = {sb->max.x, sb->max.y, sb->max.z};
    int n[3];
    double prims = (double)nb;
    choose_dims(lo, hi, TOP_LAMBDA * prims, TOP_MAX_AXIS, n);
    fit_dims((const float (*)[6])boxes, NULL, NULL, nb, lo, hi, TOP_DUP * prims + BUDGET_SLACK,
             n);
    /* The uniform grid's own cap counts the course's cells too (grid_budget.c): fit it
     * here, quietly, so the top level never gets the warning meant for a request. */
    grid_fit_refs(table, n, grid_ref_cap_auto(table->num_bounded), NULL);

    TwoLevelGrid *t = calloc(1, sizeof *t);
    if (!t) {
        bigmem_free(boxes);
        goto oom;
    }
    t->top = grid_build_table_fitted(table, n, diag);
    if (!t->top) {
        bigmem_free(boxes);
        twolevel_free(t);
        return NULL; /* reported by grid_build_table, or nothing bounded */
    }
    Grid *g = t->top;
    t->sub_of = malloc((size_t)g->num_cells * sizeof *t->sub_of);
    /* The primitives' boxes for the leaf grids go into the top level's box array
     * (one per bounded primitive of the table, as many as the top grid's): a fresh
     * array of that size (~1 MB for 40k triangles) cost its page faults again. */
    float (*pbox)[6] = g->num_prims <= nb ? boxes : NULL;
    if (!pbox) {
        bigmem_free(boxes);
        pbox = bigmem_alloc(((size_t)g->num_prims + 1) * sizeof *pbox);
    }
    FillJob *job = calloc(1, sizeof *job);
    LeafPlans plans;
    memset(&plans, 0, sizeof plans);
    bool ok = job && t->sub_of && pbox &&
              grow((void **)&t->start, &t->cap_cells, 1, sizeof *t->start);
    if (ok) {
        t->start[0] = 0;
        for (uint32_t p = 0; p < g->num_prims; p++)
            prim_box(g, p, pbox[p]);
        for (uint32_t c = 0; c < g->num_cells; c++)
            t->sub_of[c] = TWOLEVEL_NO_SUB;
    }
    /* The leaf grids in three steps: which top cells get one and their resolutions (in
     * cell order, as the budget is spent), their entries (on the set-up threads, each
     * into arrays of its own), then appended in cell order: the same arrays as when
     * each was built and appended in turn. */
    double budget = LEAF_BUDGET_DUP * (double)g->num_prims + BUDGET_SLACK;
    /* The plans' entry lists at their largest size at once (at most every top entry),
     * instead of doubling with a copy into fresh pages each time. */
    ok = ok && grow_exact((void **)&plans.small, &plans.cap_small,
                          g->cell_start[g->num_cells] + 1, sizeof *plans.small);
    for (int k = 0; ok && k < g->n[2]; k++)
        for (int j = 0; ok && j < g->n[1]; j++)
            for (int i = 0; ok && i < g->n[0]; i++) {
                int ci[3] = {i, j, k};
                ok = plan_leaf(g, grid_cell_index(g, i, j, k), ci, (const float (*)[6])pbox,
                               &budget, &plans);
            }
    /* t->start at its final size before the fill, which writes each plan's offsets
     * into it (a copy per plan, appended later, faulted in its pages twice). */
    size_t all_cells = t->num_cells + 1;
    for (size_t i = 0; ok && i < plans.n; i++) {
        plans.p[i].base = (uint32_t)(all_cells - 1);
        all_cells += plans.p[i].cells;
    }
    ok = ok && grow_exact((void **)&t->start, &t->cap_cells, all_cells, sizeof *t->start);
    PlanKey *keys = ok && plans.n ? malloc(plans.n * sizeof *keys) : NULL;
    uint32_t *order = ok && plans.n ? malloc(plans.n * sizeof *order) : NULL;
    ok = ok && (plans.n == 0 || (keys && order));
    if (ok && plans.n) {
        for (size_t i = 0; i < plans.n; i++)
            keys[i] = (PlanKey){plans.p[i].ns, (uint32_t)i};
        qsort(keys, plans.n, sizeof *keys, plan_key_desc);
        for (size_t i = 0; i < plans.n; i++)
            order[i] = keys[i].index;
        job->g = g;
        job->plans = &plans;
        job->order = order;
        job->pbox = (const float (*)[6])pbox;
        job->start = t->start;
        par_for((int)plans.n, fill_chunk, job);
    }
    /* t->items at its final size at once (append_leaf's grow then never moves it):
     * doubled from 1024, it was copied into fresh pages each time. The fills are done
     * with the boxes, so it takes their array's memory, already faulted in (~1 MB for
     * 40k triangles; t->items is about half that). */
    size_t all_items = t->num_items;
    for (size_t i = 0; ok && i < plans.n; i++) {
        ok = plans.p[i].ok;
        if (ok)
            all_items += (size_t)plans.p[i].npairs + plans.p[i].nbig;
    }
    if (ok && all_items && !t->items) {
        uint32_t *it = bigmem_resize(pbox, all_items * sizeof *t->items);
        if (it) {
            pbox = NULL;
            t->items = it;
            t->cap_items = all_items;
        }
    }
    ok = ok && (all_items == 0 ||
                grow((void **)&t->items, &t->cap_items, all_items, sizeof *t->items));
    for (size_t i = 0; ok && i < plans.n; i++)
        ok = plans.p[i].ok && append_leaf(t, &plans.p[i], plans.small + plans.p[i].small0);
    for (size_t i = 0; i < plans.n; i++)
        bigmem_free(plans.p[i].items);
    bigmem_free(plans.p);
    bigmem_free(plans.small);
    free(keys);
    free(order);
    if (job)
        for (int w = 0; w < PAR_MAX_WORKERS; w++)
            scratch_free(&job->scratch[w]);
    free(job);
    bigmem_free(pbox);
    if (!ok && par_stop_requested()) { /* a stop (Ctrl-C): nothing to report */
        twolevel_free(t);
        return NULL;
    }
    if (!ok)
        goto oom;
    /* The leaf lists are copies of the top grid's entries; the group loop also needs
     * them all tagged (grid_internal.h, all_tri). */
    for (size_t e = 0; g->all_tri && e < t->num_items; e++)
        if (!(t->items[e] & GRID_ITEM_TRI))
            g->all_tri = false;
    return t;
oom:
    twolevel_free(t);
    diag_error(diag, NULL, "out of memory building the two-level grid");
    return NULL;
}

Grid *twolevel_top(const TwoLevelGrid *t) { return t->top; }

void twolevel_counts(const TwoLevelGrid *t, uint32_t *subgrids, uint64_t *leaf_cells)
{
    if (subgrids)
        *subgrids = t->num_subs;
    if (leaf_cells)
        *leaf_cells = t->num_cells;
}

/* ---- traversal: twolevel_intersect and twolevel_occluded are in grid_cast.c ---- */

/* ---- the accelerator "twolevel" (rt/accel.h) ---- */

static void *twolevel_create(const PrimTable *t, const AccelConfig *cfg, Diag *diag)
{
    TwoLevelGrid *tl = twolevel_build(t, diag);
    if (tl)
        grid_set_marking(tl->top, !cfg->no_marking);
    return tl;
}

static void twolevel_destroy(void *self) { twolevel_free(self); }

static bool twolevel_accel_intersect(const void *self, const Ray *ray, Hit *hit, float tmin,
                                     RenderCtx *ctx)
{
    return twolevel_intersect(self, ray, hit, tmin, ctx);
}

static bool twolevel_accel_occluded(const void *self, const Ray *ray, float tmin, float tmax,
                                    RenderCtx *ctx)
{
    return twolevel_occluded(self, ray, tmin, tmax, ctx);
}

static uint32_t twolevel_scratch(const void *self)
{
    return grid_mailbox_size(((const TwoLevelGrid *)self)->top);
}

/* The course block prints the top level's resolution. */
static void twolevel_report(const void *self, StatsReport *r)
{
    int n[3];
    grid_dims(((const TwoLevelGrid *)self)->top, n);
    r->nx = n[0];
    r->ny = n[1];
    r->nz = n[2];
}

/* -visualize_grid draws the top level's occupied cells. */
static bool twolevel_cells_intersect(const void *self, const Ray *ray, Hit *hit, float tmin,
                                     RenderCtx *ctx)
{
    return grid_visualize_intersect(((const TwoLevelGrid *)self)->top, ray, hit, tmin, ctx);
}

static bool twolevel_cells_occluded(const void *self, const Ray *ray, float tmin, float tmax,
                                    RenderCtx *ctx)
{
    return grid_visualize_occluded(((const TwoLevelGrid *)self)->top, ray, tmin, tmax, ctx);
}

static const AccelOps twolevel_cells_ops =
    GRID_CELLS_OPS("twolevel", "the two-level grid's top cells, coloured by count "
                               "(-visualize_grid)",
                   twolevel_create, twolevel_destroy, twolevel_cells_intersect,
                   twolevel_cells_occluded, twolevel_scratch, twolevel_report);

const AccelOps accel_twolevel_ops = {
    .name = "twolevel",
    .summary = "two-level grid for uneven scenes (-grid auto's pick)",
    .create = twolevel_create,
    .destroy = twolevel_destroy,
    .intersect = twolevel_accel_intersect,
    .occluded = twolevel_accel_occluded,
    .scratch_size = twolevel_scratch,
    .report = twolevel_report,
    .visualize = &twolevel_cells_ops,
};

const TwoLevelGrid *twolevel_of_accel(const Accel *a)
{
    return a && (a->ops == &accel_twolevel_ops || a->ops == &twolevel_cells_ops) ? a->self
                                                                                 : NULL;
}
