/* The marching sets: for each primitive, the cells whose rounding-padded box its surface
 * may cross (double precision), so the march never misses a hit; with a fast path for
 * triangles (per-axis cell tables, the vertex-inside shortcut). */
#include "grid_build.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "rt/bigmem.h"

/* Cells whose padded box meets [bmin, bmax]. */
static CellRange tight_range(const Grid *g, const double bmin[3], const double bmax[3])
{
    CellRange r;
    for (int a = 0; a < 3; a++) {
        double mn = (double)v3_comp(g->box.min, a), s = (double)g->size[a],
               p = (double)g->pad[a];
        r.lo[a] = grid_range_lo((bmin[a] - p - mn) / s, g->n[a]);
        r.hi[a] = grid_range_hi((bmax[a] + p - mn) / s, g->n[a]);
    }
    return r;
}

/* The padded box of cell (i,j,k). Border cells reach out to include [bmin, bmax], so a
 * primitive that pokes out of the scene box by rounding still lands in them (the march
 * clamps positions outside the box to the border cells the same way). */
static void cell_box(const Grid *g, const int c[3], const double bmin[3],
                     const double bmax[3], double lo[3], double hi[3])
{
    for (int a = 0; a < 3; a++) {
        double mn = (double)v3_comp(g->box.min, a), s = (double)g->size[a],
               p = (double)g->pad[a];
        lo[a] = mn + c[a] * s - p;
        hi[a] = mn + (c[a] + 1) * s + p;
        if (c[a] == 0 && bmin[a] < lo[a])
            lo[a] = bmin[a];
        if (c[a] == g->n[a] - 1 && bmax[a] > hi[a])
            hi[a] = bmax[a];
    }
}

/* World-space box around a primitive other than a triangle (those take the fast path
 * below) for the tight range: its cell_bounds op, or its bounds op when it has none. */
static void tight_bounds(const GridBuildRec *rec, double bmin[3], double bmax[3])
{
    const Object3D *o = rec->obj;
    if (o->ops->cell_bounds) {
        o->ops->cell_bounds(o, rec->gp, bmin, bmax);
        return;
    }
    BBox b = o->ops->bounds(o, rec->gp ? &rec->gp->m : NULL);
    for (int a = 0; a < 3; a++) {
        bmin[a] = (double)v3_comp(b.min, a);
        bmax[a] = (double)v3_comp(b.max, a);
    }
}

/* Whether the surface of a primitive other than a triangle may cross the padded cell
 * box [lo, hi]: its overlaps_box op (every cell of its box when it has none). */
static bool tight_cell(const GridBuildRec *rec, const double lo[3], const double hi[3])
{
    const Object3D *o = rec->obj;
    return !o->ops->overlaps_box || o->ops->overlaps_box(o, rec->gp, lo, hi);
}

/* Appends one cell index to the part's pair list (cells of each primitive, in
 * primitive order); false when out of memory or when the part's entries would overflow
 * a uint32_t (grid_build checks the total). */
static bool push_pair(BinPart *bp, uint32_t cell)
{
    if (bp->num_pairs >= UINT32_MAX - 1u) {
        bp->too_many = true;
        return false;
    }
    if (bp->num_pairs == bp->cap_pairs) {
        size_t cap = bp->cap_pairs ? 2 * bp->cap_pairs : 1024;
        uint32_t *p = cap < SIZE_MAX / sizeof *p ? bigmem_resize(bp->pairs, cap * sizeof *p) : NULL;
        if (!p) {
            bp->oom = true;
            return false;
        }
        bp->pairs = p;
        bp->cap_pairs = cap;
    }
    bp->pairs[bp->num_pairs++] = cell;
    bp->count[cell]++;
    return true;
}

/* ---- the triangle fast path of the marching sets ---- */

/* Per axis a and cell c, CELL_AXIS_STRIDE doubles of cell_box's padded bounds without
 * the border stretch: lo, hi, their centre, half size, and the half size shrunk by a
 * relative 2^-30 (the "vertex well inside" bound of tri_cell_overlap). */
enum { CA_LO, CA_HI, CA_MID, CA_H, CA_HIN, CELL_AXIS_STRIDE };
#define INSIDE_SHRINK GRID_INSIDE_SHRINK

bool grid_setup_cell_axis(GridBuild *b)
{
    const Grid *g = b->g;
    size_t n = (size_t)g->n[0] + (size_t)g->n[1] + (size_t)g->n[2];
    b->cell_axis = malloc(n * CELL_AXIS_STRIDE * sizeof *b->cell_axis);
    if (!b->cell_axis)
        return false;
    double *e = b->cell_axis;
    for (int a = 0; a < 3; a++) {
        double mn = (double)v3_comp(g->box.min, a), s = (double)g->size[a],
               p = (double)g->pad[a];
        for (int c = 0; c < g->n[a]; c++, e += CELL_AXIS_STRIDE) {
            /* cell_box's and tight_cell's expressions, operation for operation. */
            e[CA_LO] = mn + c * s - p;
            e[CA_HI] = mn + (c + 1) * s + p;
            e[CA_MID] = 0.5 * (e[CA_LO] + e[CA_HI]);
            e[CA_H] = 0.5 * (e[CA_HI] - e[CA_LO]);
            e[CA_HIN] = e[CA_H] * INSIDE_SHRINK;
        }
    }
    return true;
}

/* Centre, half size and shrunk half size of cell c on axis a, as cell_box + tight_cell
 * compute them for a triangle with box [bmin, bmax] (border cells stretched). */
static inline void cell_axis(const Grid *g, const double *table, int a, int c, double bmin,
                             double bmax, double out[3])
{
    size_t off = a == 0 ? 0 : a == 1 ? (size_t)g->n[0] : (size_t)g->n[0] + (size_t)g->n[1];
    const double *e = &table[(off + (size_t)c) * CELL_AXIS_STRIDE];
    double lo = e[CA_LO], hi = e[CA_HI];
    bool stretch = false;
    if (c == 0 && bmin < lo) {
        lo = bmin;
        stretch = true;
    }
    if (c == g->n[a] - 1 && bmax > hi) {
        hi = bmax;
        stretch = true;
    }
    if (!stretch) {
        out[0] = e[CA_MID];
        out[1] = e[CA_H];
        out[2] = e[CA_HIN];
        return;
    }
    out[0] = 0.5 * (lo + hi);
    out[1] = 0.5 * (hi - lo);
    out[2] = out[1] * INSIDE_SHRINK;
}

/* triangle_box_overlap(v, h), the same answer for every input, cheaper when a vertex lies
 * well inside the box (the common case: a small triangle straddling a cell border has
 * a vertex in most of its cells). in[k]: |v[k][a]| <= (1 - d) h[a] on every axis,
 * d = 2^-30. Why the answer is the same: such a vertex alone keeps every box axis and
 * every edge axis from separating, in floating point: its projection on an edge axis
 * is ez*vy - ey*vz (and the like), at most (1 - d) times the exact radius
 * h1|ez| + h2|ey| in size, and the rounding of the projection and of the radius is a
 * few 2^-53 of that radius, far below d. The normal axis projects v0 only, so the same
 * bound covers it when k = 0; for k = 1, 2 the normal is tested as triangle_box_overlap
 * tests it, operation for operation. */
static bool tri_cell_overlap(double v[3][3], const double h[3], const bool in[3])
{
    if (in[0])
        return true;
    if (!in[1] && !in[2])
        return triangle_box_overlap(v, h);
    double e0[3], e1[3], nrm[3];
    for (int a = 0; a < 3; a++) {
        e0[a] = v[1][a] - v[0][a];
        e1[a] = v[2][a] - v[1][a];
    }
    d3_cross(e0, e1, nrm);
    double rad = h[0] * fabs(nrm[0]) + h[1] * fabs(nrm[1]) + h[2] * fabs(nrm[2]);
    return !(fabs(d3_dot(nrm, v[0])) > rad);
}

bool grid_tri_box_overlap(double v[3][3], const double h[3]) { return triangle_box_overlap(v, h); }

bool grid_tri_cell_overlap(double v[3][3], const double h[3])
{
    bool in[3];
    for (int k = 0; k < 3; k++) {
        in[k] = true;
        for (int a = 0; a < 3; a++)
            in[k] = in[k] && fabs(v[k][a]) <= h[a] * INSIDE_SHRINK;
    }
    return tri_cell_overlap(v, h, in);
}

bool grid_tri_cell_overlap_in(double v[3][3], const double h[3], const bool in[3])
{
    return tri_cell_overlap(v, h, in);
}

/* tight_insert for a triangle (rec->v, world space): the same cells in the same order,
 * with the per-cell bounds from the tables, the vertex-inside shortcut, and what
 * depends on one axis only computed once per row or slab. */
static bool tight_insert_triangle(BinPart *bp, const GridBuildRec *rec, uint32_t *ncells)
{
    const Grid *g = bp->g;
    double P[3][3], bmin[3], bmax[3];
    for (int k = 0; k < 3; k++)
        for (int a = 0; a < 3; a++)
            P[k][a] = (double)v3_comp(rec->v[k], a);
    for (int a = 0; a < 3; a++) {
        bmin[a] = d_min3(P[0][a], P[1][a], P[2][a]);
        bmax[a] = d_max3(P[0][a], P[1][a], P[2][a]);
    }
    CellRange r = tight_range(g, bmin, bmax);
    if (r.lo[0] == r.hi[0] && r.lo[1] == r.hi[1] && r.lo[2] == r.hi[2]) {
        /* Its padded box fits in one cell: it is in that cell, no test needed. */
        if (!push_pair(bp, grid_cell_index(g, r.lo[0], r.lo[1], r.lo[2])))
            return false;
        *ncells = 1;
        return true;
    }
    uint32_t count = 0;
    double v[3][3], ax[3][3], h[3];
    bool in2[3], in12[3], in[3];
    for (int k2 = r.lo[2]; k2 <= r.hi[2]; k2++) {
        cell_axis(g, bp->cell_axis, 2, k2, bmin[2], bmax[2], ax[2]);
        for (int k = 0; k < 3; k++) {
            v[k][2] = P[k][2] - ax[2][0];
            in2[k] = fabs(v[k][2]) <= ax[2][2];
        }
        for (int j = r.lo[1]; j <= r.hi[1]; j++) {
            cell_axis(g, bp->cell_axis, 1, j, bmin[1], bmax[1], ax[1]);
            for (int k = 0; k < 3; k++) {
                v[k][1] = P[k][1] - ax[1][0];
                in12[k] = in2[k] && fabs(v[k][1]) <= ax[1][2];
            }
            for (int i = r.lo[0]; i <= r.hi[0]; i++) {
                cell_axis(g, bp->cell_axis, 0, i, bmin[0], bmax[0], ax[0]);
                for (int k = 0; k < 3; k++) {
                    v[k][0] = P[k][0] - ax[0][0];
                    in[k] = in12[k] && fabs(v[k][0]) <= ax[0][2];
                }
                h[0] = ax[0][1];
                h[1] = ax[1][1];
                h[2] = ax[2][1];
#ifdef RT_GRID_AABB_ONLY
                bool hit = true; /* analysis build: see tight_insert */
#else
                bool hit = tri_cell_overlap(v, h, in);
#endif
                if (!hit)
                    continue;
                if (!push_pair(bp, grid_cell_index(g, i, j, k2)))
                    return false;
                count++;
            }
        }
    }
    *ncells = count;
    return true;
}

/* Finds the cells of the marching set of rec, counts them into bp->count and remembers
 * them in bp->pairs, so the fill pass needs no second round of tests. False when out of
 * memory or out of entries. */
bool grid_tight_insert(BinPart *bp, const GridBuildRec *rec, uint32_t *ncells)
{
    if (rec->kind == REC_TRIANGLE)
        return tight_insert_triangle(bp, rec, ncells);
    const Grid *g = bp->g;
    double bmin[3], bmax[3];
    tight_bounds(rec, bmin, bmax);
    CellRange r = tight_range(g, bmin, bmax);
    /* A primitive whose padded box fits in one cell is in that cell: no test needed. */
    bool single = r.lo[0] == r.hi[0] && r.lo[1] == r.hi[1] && r.lo[2] == r.hi[2];
    uint32_t count = 0;
    int c[3];
    for (c[2] = r.lo[2]; c[2] <= r.hi[2]; c[2]++)
        for (c[1] = r.lo[1]; c[1] <= r.hi[1]; c[1]++)
            for (c[0] = r.lo[0]; c[0] <= r.hi[0]; c[0]++) {
                double lo[3], hi[3];
                cell_box(g, c, bmin, bmax, lo, hi);
#ifdef RT_GRID_AABB_ONLY
                /* Analysis build (bench/grid_analysis.sh): every cell of the padded
                 * bounding box, to measure what the exact tests save. */
                bool in = true || single || tight_cell(rec, lo, hi);
#else
                bool in = single || tight_cell(rec, lo, hi);
#endif
                if (!in)
                    continue;
                if (!push_pair(bp, grid_cell_index(g, c[0], c[1], c[2])))
                    return false;
                count++;
            }
    *ncells = count;
    return true;
}

uint64_t grid_tight_box_cells(const Grid *g, const GridBuildRec *rec)
{
    double bmin[3], bmax[3];
    if (rec->kind == REC_TRIANGLE) {
        for (int a = 0; a < 3; a++) {
            double x0 = (double)v3_comp(rec->v[0], a), x1 = (double)v3_comp(rec->v[1], a),
                   x2 = (double)v3_comp(rec->v[2], a);
            bmin[a] = d_min3(x0, x1, x2);
            bmax[a] = d_max3(x0, x1, x2);
        }
    } else {
        tight_bounds(rec, bmin, bmax);
    }
    CellRange r = tight_range(g, bmin, bmax);
    return (uint64_t)(r.hi[0] - r.lo[0] + 1) * (uint64_t)(r.hi[1] - r.lo[1] + 1) *
           (uint64_t)(r.hi[2] - r.lo[2] + 1);
}
