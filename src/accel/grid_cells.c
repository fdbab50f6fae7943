/* The marching sets: for each primitive, the cells whose rounding-padded box its surface
 * may cross (double precision), so the march never misses a hit; with a fast path for
 * triangles (per-axis cell tables, the vertex-inside shortcut). */
#include "grid_build.h"

#include <math.h>
#include <stdlib.h>

typedef struct DVec {
    double x[3];
} DVec;

static DVec dvec(Vec3 v)
{
    DVec d = {{(double)v.x, (double)v.y, (double)v.z}};
    return d;
}

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

static double dot3(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static void cross3(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double min3(double a, double b, double c)
{
    double m = a < b ? a : b;
    return m < c ? m : c;
}

static inline double max3(double a, double b, double c)
{
    double m = a > b ? a : b;
    return m > c ? m : c;
}

/* Whether the projections p0..p2 of the triangle onto an axis miss [-rad, rad]. */
static inline bool separated(double p0, double p1, double p2, double rad)
{
    return min3(p0, p1, p2) > rad || max3(p0, p1, p2) < -rad;
}

/* Separating-axis test of a triangle against a box given by centre-relative vertices
 * v[3] and half extents h (Akenine-Moller, "Fast 3D Triangle-Box Overlap Testing",
 * 2001): the 3 box normals first (cheapest, they reject most candidates), the triangle
 * normal, then the 9 directions edge x box axis, written out since the box axes are
 * unit vectors: e x X = (0, ez, -ey), e x Y = (-ez, 0, ex), e x Z = (ey, -ex, 0). */
static bool tri_box_overlap(double v[3][3], const double h[3])
{
    for (int a = 0; a < 3; a++)
        if (separated(v[0][a], v[1][a], v[2][a], h[a]))
            return false;
    double e[3][3];
    for (int a = 0; a < 3; a++) {
        e[0][a] = v[1][a] - v[0][a];
        e[1][a] = v[2][a] - v[1][a];
        e[2][a] = v[0][a] - v[2][a];
    }
    double nrm[3];
    cross3(e[0], e[1], nrm);
    double rad = h[0] * fabs(nrm[0]) + h[1] * fabs(nrm[1]) + h[2] * fabs(nrm[2]);
    if (fabs(dot3(nrm, v[0])) > rad)
        return false;
    for (int i = 0; i < 3; i++) {
        double ex = e[i][0], ey = e[i][1], ez = e[i][2];
        double fx = fabs(ex), fy = fabs(ey), fz = fabs(ez);
        if (separated(ez * v[0][1] - ey * v[0][2], ez * v[1][1] - ey * v[1][2],
                      ez * v[2][1] - ey * v[2][2], h[1] * fz + h[2] * fy))
            return false;
        if (separated(ex * v[0][2] - ez * v[0][0], ex * v[1][2] - ez * v[1][0],
                      ex * v[2][2] - ez * v[2][0], h[0] * fz + h[2] * fx))
            return false;
        if (separated(ey * v[0][0] - ex * v[0][1], ey * v[1][0] - ex * v[1][1],
                      ey * v[2][0] - ex * v[2][1], h[0] * fy + h[1] * fx))
            return false;
    }
    return true;
}

/* Relative slack for the sphere surface tests: the hit point of a quadratic solve lies
 * within a few float ulps of the surface; 1e-5 of the size is far above that. */
#define SURFACE_SLACK 1e-5

static bool tight_sphere_cell(const GridBuildRec *rec, const double lo[3],
                              const double hi[3])
{
    DVec c = dvec(rec->v[0]);
    double r = (double)rec->r;
    double eta = SURFACE_SLACK * (fabs(r) + fabs(c.x[0]) + fabs(c.x[1]) + fabs(c.x[2]));
    double dmin2 = 0.0, dmax2 = 0.0;
    for (int a = 0; a < 3; a++) {
        double below = lo[a] - c.x[a], above = c.x[a] - hi[a];
        double out = below > 0 ? below : above > 0 ? above : 0.0;
        dmin2 += out * out;
        double far = fmax(fabs(c.x[a] - lo[a]), fabs(hi[a] - c.x[a]));
        dmax2 += far * far;
    }
    /* Only the surface can be hit: skip cells wholly outside, or wholly inside. */
    return sqrt(dmin2) <= r + eta && sqrt(dmax2) >= r - eta;
}

/* A transformed sphere (ellipsoid) against a cell, tested in the sphere's object space
 * where the cell becomes a parallelepiped: out if even its bounding sphere misses the
 * sphere, out if all 8 corners lie inside (convexity: then the whole cell does). */
static bool tight_sphere_xf_cell(const GridBuildRec *rec, const double lo[3],
                                 const double hi[3])
{
    const Mat4 *inv = &rec->gp->inv;
    DVec c = dvec(rec->v[0]);
    double r = (double)rec->r;
    double frob = 0.0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            frob += (double)inv->m[i][j] * (double)inv->m[i][j];
    frob = sqrt(frob);
    double mid[3], half = 0.0;
    for (int a = 0; a < 3; a++) {
        mid[a] = 0.5 * (lo[a] + hi[a]);
        half += 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
    }
    half = sqrt(half);
    double q[3], d2 = 0.0;
    for (int i = 0; i < 3; i++) {
        q[i] = (double)inv->m[i][3];
        for (int j = 0; j < 3; j++)
            q[i] += (double)inv->m[i][j] * mid[j];
        d2 += (q[i] - c.x[i]) * (q[i] - c.x[i]);
    }
    double slack = SURFACE_SLACK * (fabs(r) + fabs(c.x[0]) + fabs(c.x[1]) + fabs(c.x[2]));
    if (sqrt(d2) > r + frob * half + slack)
        return false;
    for (int corner = 0; corner < 8; corner++) {
        double p[3] = {(corner & 1) ? hi[0] : lo[0], (corner & 2) ? hi[1] : lo[1],
                       (corner & 4) ? hi[2] : lo[2]};
        double e2 = 0.0;
        for (int i = 0; i < 3; i++) {
            double qi = (double)inv->m[i][3];
            for (int j = 0; j < 3; j++)
                qi += (double)inv->m[i][j] * p[j];
            e2 += (qi - c.x[i]) * (qi - c.x[i]);
        }
        if (sqrt(e2) >= r - slack)
            return true; /* a corner outside: the surface may cross the cell */
    }
    return false;
}

/* World-space box around the primitive for the tight range. */
static void tight_bounds(const GridBuildRec *rec, double bmin[3], double bmax[3])
{
    if (rec->kind == REC_TRIANGLE) {
        for (int a = 0; a < 3; a++) {
            double x0 = (double)v3_comp(rec->v[0], a), x1 = (double)v3_comp(rec->v[1], a),
                   x2 = (double)v3_comp(rec->v[2], a);
            bmin[a] = min3(x0, x1, x2);
            bmax[a] = max3(x0, x1, x2);
        }
    } else if (rec->kind == REC_BOX) {
        for (int a = 0; a < 3; a++) {
            bmin[a] = (double)v3_comp(rec->v[0], a);
            bmax[a] = (double)v3_comp(rec->v[1], a);
        }
    } else if (rec->kind == REC_SPHERE) {
        for (int a = 0; a < 3; a++) {
            double c = (double)v3_comp(rec->v[0], a), r = fabs((double)rec->r);
            bmin[a] = c - r;
            bmax[a] = c + r;
        }
    } else {
        /* Exact AABB of the ellipsoid M(S): centre M c, half extent r * |row a of M|. */
        const Mat4 *m = &rec->gp->m;
        DVec c = dvec(rec->v[0]);
        for (int a = 0; a < 3; a++) {
            double w = (double)m->m[a][3], len = 0.0;
            for (int j = 0; j < 3; j++) {
                w += (double)m->m[a][j] * c.x[j];
                len += (double)m->m[a][j] * (double)m->m[a][j];
            }
            double e = fabs((double)rec->r) * sqrt(len);
            bmin[a] = w - e * (1.0 + SURFACE_SLACK);
            bmax[a] = w + e * (1.0 + SURFACE_SLACK);
        }
    }
}

/* Whether rec's surface may cross the padded cell box [lo, hi]. */
static bool tight_cell(const GridBuildRec *rec, const double lo[3], const double hi[3])
{
    if (rec->kind == REC_TRIANGLE) {
        double v[3][3], h[3];
        for (int a = 0; a < 3; a++) {
            double mid = 0.5 * (lo[a] + hi[a]);
            h[a] = 0.5 * (hi[a] - lo[a]);
            for (int k = 0; k < 3; k++)
                v[k][a] = (double)v3_comp(rec->v[k], a) - mid;
        }
        return tri_box_overlap(v, h);
    }
    if (rec->kind == REC_SPHERE)
        return tight_sphere_cell(rec, lo, hi);
    if (rec->kind == REC_SPHERE_XF)
        return tight_sphere_xf_cell(rec, lo, hi);
    return true; /* REC_BOX: every cell its padded box meets */
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
        uint32_t *p = realloc(bp->pairs, cap * sizeof *p);
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
#define INSIDE_SHRINK (1.0 - 0x1p-30)

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

/* tri_box_overlap(v, h), the same answer for every input, cheaper when a vertex lies
 * well inside the box (the common case: a small triangle straddling a cell border has
 * a vertex in most of its cells). in[k]: |v[k][a]| <= (1 - d) h[a] on every axis,
 * d = 2^-30. Why the answer is the same: such a vertex alone keeps every box axis and
 * every edge axis from separating, in floating point: its projection on an edge axis
 * is ez*vy - ey*vz (and the like), at most (1 - d) times the exact radius
 * h1|ez| + h2|ey| in size, and the rounding of the projection and of the radius is a
 * few 2^-53 of that radius, far below d. The normal axis projects v0 only, so the same
 * bound covers it when k = 0; for k = 1, 2 the normal is tested as tri_box_overlap
 * tests it, operation for operation. */
static bool tri_cell_overlap(double v[3][3], const double h[3], const bool in[3])
{
    if (in[0])
        return true;
    if (!in[1] && !in[2])
        return tri_box_overlap(v, h);
    double e0[3], e1[3], nrm[3];
    for (int a = 0; a < 3; a++) {
        e0[a] = v[1][a] - v[0][a];
        e1[a] = v[2][a] - v[1][a];
    }
    cross3(e0, e1, nrm);
    double rad = h[0] * fabs(nrm[0]) + h[1] * fabs(nrm[1]) + h[2] * fabs(nrm[2]);
    return !(fabs(dot3(nrm, v[0])) > rad);
}

bool grid_tri_box_overlap(double v[3][3], const double h[3]) { return tri_box_overlap(v, h); }

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
        bmin[a] = min3(P[0][a], P[1][a], P[2][a]);
        bmax[a] = max3(P[0][a], P[1][a], P[2][a]);
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
