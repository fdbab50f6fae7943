/* Grid construction: flattens the scene tree into a uniform grid (semantics.md 7.1-7.2).
 * Two cell sets are built from one walk: the course's occupancy counts (what
 * -visualize_grid shows) and tighter, rounding-padded lists (what the march tests); the
 * binning runs on the set-up threads (rt/par.h), with the same result on any number. */
#include "grid_internal.h"
#include "rt/options.h"
#include "grid_build.h"

#include <limits.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "rt/geom.h"
#include "rt/par.h"
#include "rt/scene.h"

/* Upper bound on nx*ny*nz: 16M cells keep the offsets and counts under 128 MB. */
/* The limit users see with -grid (rt/options.h), so no size passes one check and fails the other. */
#define GRID_MAX_CELLS ((uint32_t)RT_GRID_MAX_CELLS)

typedef enum RecKind { REC_SPHERE, REC_SPHERE_XF, REC_TRIANGLE } RecKind;

/* A primitive with what its insertion needs in world space, made by the binning pass
 * (bin_part) from the walk's GridPrim and kept on its stack. */
struct GridBuildRec {
    const Object3D *obj;
    const PrimXform *gp;  /* NULL: no Transform above it */
    RecKind kind;
    Vec3 v[3];            /* sphere: v[0] = centre (object space); triangle: world vertices */
    float r;              /* sphere radius (object space) */
};

/* One binning worker's scratch (rt/par.h): its own counts and cell list, so workers
 * share nothing they write (worker 0 writes the grid's arrays). Which worker bins which primitives varies from run to run;
 * the result does not: the counts are sums, and the fill pass reads the chunks' cell
 * lists in primitive order. */
typedef struct BinPart {
    const Grid *g;
    uint32_t *course;     /* per cell: course counts (worker 0: g->course_count) */
    uint32_t *count;      /* per cell: marching entries (worker 0: g->cell_start + 1) */
    uint32_t *pairs;      /* cells of each binned primitive's marching set, in order */
    size_t num_pairs, cap_pairs;
    bool oom, too_many;
} BinPart;

/* Appends a bounded primitive to prims. Its kind waits in prim_ncells until bin_part
 * replaces it by the primitive's cell count. */
static void append_prim(Grid *g, const Prim *p, RecKind kind)
{
    g->prims[g->num_prims].obj = p->obj;
    g->prims[g->num_prims].xf = p->xf;
    g->prim_ncells[g->num_prims] = (uint32_t)kind;
    g->num_prims++;
}

/* The record of a primitive of kind kind. */
static void make_rec_of(const GridPrim *gp, RecKind kind, GridBuildRec *rec)
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
    } else {
        rec->v[0] = sphere_center(rec->obj);
        rec->r = sphere_radius(rec->obj);
    }
}

/* The record of prims[p] as the walk left it (kind in prim_ncells[p]). */
static void make_rec(const Grid *g, uint32_t p, GridBuildRec *rec)
{
    make_rec_of(&g->prims[p], (RecKind)g->prim_ncells[p], rec);
}

/* ---- the course's occupancy rules (semantics.md 7.2), in float like the course ---- */

typedef struct CellRange {
    int lo[3], hi[3];
} CellRange;

/* The cell ranges below are ceil(y) - 1 and floor(z), clamped to [0, n-1], where NaN
 * and everything below 0 give 0. Written with compares and one conversion instead of
 * ceil/floor (libm calls without SSE4.1), with the same result for every input:
 * ceil(y) - 1 >= 0 iff y > 0, ceil(y) - 1 >= n - 1 iff y > n - 1, floor(z) >= 0 iff
 * z >= 0, floor(z) >= n - 1 iff z >= n - 1; in between, y and z are small positive
 * numbers whose conversion truncates exactly. n <= 2^24, so n - 1 is exact in float. */
static inline int range_lo_f(float y, int n)
{
    if (!(y > 0.0f))
        return 0;
    if (y > (float)(n - 1))
        return n - 1;
    int i = (int)y;
    return (float)i < y ? i : i - 1;
}

static inline int range_hi_f(float z, int n)
{
    if (!(z >= 0.0f))
        return 0;
    if (z >= (float)(n - 1))
        return n - 1;
    return (int)z;
}

static inline int range_lo_d(double y, int n)
{
    if (!(y > 0.0))
        return 0;
    if (y > (double)(n - 1))
        return n - 1;
    int i = (int)y;
    return (double)i < y ? i : i - 1;
}

static inline int range_hi_d(double z, int n)
{
    if (!(z >= 0.0))
        return 0;
    if (z >= (double)(n - 1))
        return n - 1;
    return (int)z;
}

/* Box rule: every cell whose closed box meets the closed box [bmin, bmax], touching
 * cells included (lo = ceil(..) - 1, not floor: output5_05/5_10 need it). tol widens
 * the box by that fraction of a cell on each side. A primitive placed through a
 * Transform gets 1e-4: its world vertices that lie exactly on a border in exact
 * arithmetic (rotated and scaled cubes of scene6_10/6_12) land a rounding error to
 * either side depending on how the matrices were built; counting them as touching
 * reproduces output6_10c and 6_12c exactly (99.6% of pixels without). An untransformed
 * triangle gets 0: its vertices are the file's numbers, which the course bins as they
 * are; a tolerance there adds a cell wherever a vertex of a dense mesh falls within
 * 1e-4 of a cell of a border (about 25 vertices of the 40k bunny on a 40x40x33 grid,
 * 0.3% of the pixels of its -visualize_grid picture). */
static CellRange course_box_range(const Grid *g, Vec3 bmin, Vec3 bmax, float tol)
{
    CellRange r;
    for (int a = 0; a < 3; a++) {
        float mn = v3_comp(g->box.min, a), s = g->size[a];
        r.lo[a] = range_lo_f((v3_comp(bmin, a) - mn) / s - tol, g->n[a]);
        r.hi[a] = range_hi_f((v3_comp(bmax, a) - mn) / s + tol, g->n[a]);
    }
    return r;
}

static void count_range(const Grid *g, uint32_t *course, const CellRange *r)
{
    /* grid_cell_index, with the row start hoisted: the stores through course may alias
     * g->n (unsigned and int), so the compiler would reload it for every cell. */
    uint32_t n0 = (uint32_t)g->n[0], n1 = (uint32_t)g->n[1];
    for (int k = r->lo[2]; k <= r->hi[2]; k++)
        for (int j = r->lo[1]; j <= r->hi[1]; j++) {
            uint32_t *row = course + ((uint32_t)k * n1 + (uint32_t)j) * n0;
            for (int i = r->lo[0]; i <= r->hi[0]; i++)
                row[i]++;
        }
}

/* Adds rec's cells by the course's rules to course[] (per-cell counts). */
static void course_insert(const Grid *g, uint32_t *course, const GridBuildRec *rec)
{
    if (rec->kind == REC_SPHERE) {
        /* Cell centre within r + half the cell diagonal of the centre. */
        Vec3 c = rec->v[0];
        float half_diag = 0.5f * v3_length(v3(g->size[0], g->size[1], g->size[2]));
        float reach = rec->r + half_diag;
        Vec3 e = v3(reach, reach, reach);
        CellRange r = course_box_range(g, v3_sub(c, e), v3_add(c, e), 1e-4f);
        for (int k = r.lo[2]; k <= r.hi[2]; k++)
            for (int j = r.lo[1]; j <= r.hi[1]; j++)
                for (int i = r.lo[0]; i <= r.hi[0]; i++) {
                    Vec3 cc = v3(g->box.min.x + ((float)i + 0.5f) * g->size[0],
                                 g->box.min.y + ((float)j + 0.5f) * g->size[1],
                                 g->box.min.z + ((float)k + 0.5f) * g->size[2]);
                    if (v3_length(v3_sub(cc, c)) <= reach)
                        course[grid_cell_index(g, i, j, k)]++;
                }
        return;
    }
    BBox b;
    if (rec->kind == REC_SPHERE_XF) {
        Vec3 e = v3(rec->r, rec->r, rec->r);
        BBox local = {v3_sub(rec->v[0], e), v3_add(rec->v[0], e)};
        b = bbox_transform(&local, &rec->gp->m);
    } else {
        b.min = v3_min(v3_min(rec->v[0], rec->v[1]), rec->v[2]);
        b.max = v3_max(v3_max(rec->v[0], rec->v[1]), rec->v[2]);
    }
    CellRange r = course_box_range(g, b.min, b.max, rec->gp ? 1e-4f : 0.0f);
    count_range(g, course, &r);
}

/* ---- tight, padded insertion for marching (double precision) ---- */

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
        r.lo[a] = range_lo_d((bmin[a] - p - mn) / s, g->n[a]);
        r.hi[a] = range_hi_d((bmax[a] + p - mn) / s, g->n[a]);
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
    return tight_sphere_xf_cell(rec, lo, hi);
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

static bool setup_cell_axis(Grid *g)
{
    size_t n = (size_t)g->n[0] + (size_t)g->n[1] + (size_t)g->n[2];
    g->cell_axis = malloc(n * CELL_AXIS_STRIDE * sizeof *g->cell_axis);
    if (!g->cell_axis)
        return false;
    double *e = g->cell_axis;
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
static inline void cell_axis(const Grid *g, int a, int c, double bmin, double bmax,
                             double out[3])
{
    size_t off = a == 0 ? 0 : a == 1 ? (size_t)g->n[0] : (size_t)g->n[0] + (size_t)g->n[1];
    const double *e = &g->cell_axis[(off + (size_t)c) * CELL_AXIS_STRIDE];
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
        cell_axis(g, 2, k2, bmin[2], bmax[2], ax[2]);
        for (int k = 0; k < 3; k++) {
            v[k][2] = P[k][2] - ax[2][0];
            in2[k] = fabs(v[k][2]) <= ax[2][2];
        }
        for (int j = r.lo[1]; j <= r.hi[1]; j++) {
            cell_axis(g, 1, j, bmin[1], bmax[1], ax[1]);
            for (int k = 0; k < 3; k++) {
                v[k][1] = P[k][1] - ax[1][0];
                in12[k] = in2[k] && fabs(v[k][1]) <= ax[1][2];
            }
            for (int i = r.lo[0]; i <= r.hi[0]; i++) {
                cell_axis(g, 0, i, bmin[0], bmax[0], ax[0]);
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
static bool tight_insert(BinPart *bp, const GridBuildRec *rec, uint32_t *ncells)
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

/* ---- the binning pass, in parallel over chunks of prims ---- */

static void free_build_state(Grid *g)
{
    free(g->prim_ncells);
    g->prim_ncells = NULL;
    free(g->cell_axis);
    g->cell_axis = NULL;
}

/* Primitives per chunk of the binning passes: enough to make handing out a chunk cheap,
 * few enough that the threads finish close together (40 chunks on the 40k bunny). */
enum { BIN_CHUNK = 1024 };

typedef struct BinChunk {
    size_t off, len;      /* its run in the pairs of the worker that binned it */
    int worker;
} BinChunk;

/* The binning job: the marching cells of every primitive (bin_chunk), then the course
 * counts (course_chunk) next to grid_pack (pack_chunk). */
typedef struct BinJob {
    Grid *g;
    uint32_t nchunks;
    BinPart part[PAR_MAX_WORKERS];
    BinChunk *chunk;
    /* The primitives in walk order with their kinds, for the course counts: grid_pack
     * renumbers g->prims while they are counted. */
    GridPrim *snap;
    uint8_t *kind;
    bool pack_failed;
} BinJob;

/* Worker w's per-cell array in part->*field: worker 0 uses the grid's own, the others
 * fresh zero pages (faulted in by the worker itself). */
static uint32_t *part_cells(BinJob *job, int worker, uint32_t **field, uint32_t *own)
{
    if (!*field) {
        if (worker == 0) {
            *field = own;
        } else {
            *field = calloc(job->g->num_cells, sizeof **field);
        }
    }
    return *field;
}

/* The marching cells of chunk i of prims; prim_ncells[p] becomes p's cell count. */
static void bin_chunk(void *ctx, int i, int worker)
{
    BinJob *job = ctx;
    Grid *g = job->g;
    BinPart *bp = &job->part[worker];
    if (bp->oom || bp->too_many)
        return;
    if (!bp->pairs) {
        bp->g = g;
        /* About two cells per primitive, so the list rarely grows. */
        bp->cap_pairs = 2 * (size_t)g->num_prims + 1024;
        bp->pairs = malloc(bp->cap_pairs * sizeof *bp->pairs);
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
        make_rec(g, p, &rec);
        job->snap[p] = g->prims[p];
        job->kind[p] = (uint8_t)rec.kind;
        uint32_t ncells = 0;
        if (!tight_insert(bp, &rec, &ncells))
            return;
        g->prim_ncells[p] = ncells;
    }
    job->chunk[i].off = off;
    job->chunk[i].len = bp->num_pairs - off;
    job->chunk[i].worker = worker;
}

/* Chunk 0: grid_pack (one thread); chunk i > 0: the course counts of chunk i - 1 of
 * the primitives. The counts are sums, so they do not depend on who adds what. */
static void course_chunk(void *ctx, int i, int worker)
{
    BinJob *job = ctx;
    Grid *g = job->g;
    if (i == 0) {
        job->pack_failed = !grid_pack(g);
        return;
    }
    BinPart *bp = &job->part[worker];
    if (bp->oom)
        return;
    uint32_t *course = part_cells(job, worker, &bp->course, g->course_count);
    if (!course) {
        bp->oom = true;
        return;
    }
    uint32_t p0 = (uint32_t)(i - 1) * BIN_CHUNK;
    uint32_t p1 = g->num_prims - p0 > BIN_CHUNK ? p0 + BIN_CHUNK : g->num_prims;
    for (uint32_t p = p0; p < p1; p++) {
        GridBuildRec rec;
        make_rec_of(&job->snap[p], (RecKind)job->kind[p], &rec);
        course_insert(g, course, &rec);
    }
}

static bool parts_ok(const BinJob *job)
{
    for (int w = 0; w < PAR_MAX_WORKERS; w++)
        if (job->part[w].oom || job->part[w].too_many)
            return false;
    return true;
}

/* The marching cells of every primitive (bin_chunk, in parallel), the CSR arrays, then
 * the course counts in parallel with grid_pack. The CSR fill adds the workers' counts
 * up into offsets and writes the entries chunk by chunk, i.e. in primitive order within
 * every cell, as one sequential pass writes them. False when out of memory, or with
 * g->too_many when the entries overflow a uint32_t. */
static bool bin_fill_pack(Grid *g)
{
    uint32_t n = g->num_prims, cells = g->num_cells;
    BinJob job;
    memset(&job, 0, sizeof job);
    job.g = g;
    job.nchunks = n / BIN_CHUNK + (n % BIN_CHUNK != 0);
    job.chunk = calloc(job.nchunks ? job.nchunks : 1, sizeof *job.chunk);
    job.snap = malloc((n ? n : 1) * sizeof *job.snap);
    job.kind = malloc(n ? n : 1);
    bool ok = job.chunk && job.snap && job.kind;
    uint64_t total = 0;
    if (ok) {
        par_for((int)job.nchunks, bin_chunk, &job);
        for (int w = 0; w < PAR_MAX_WORKERS; w++) {
            g->too_many = g->too_many || job.part[w].too_many;
            total += job.part[w].num_pairs;
        }
        ok = parts_ok(&job);
        if (total > UINT32_MAX - 1u) {
            g->too_many = true;
            ok = false;
        }
    }
    if (ok) {
        /* Offsets; cell_start[c] is the fill cursor. */
        uint32_t *start = g->cell_start, run = 0;
        for (uint32_t c = 0; c < cells; c++) {
            uint32_t m = start[c + 1];
            for (int w = 1; w < PAR_MAX_WORKERS; w++)
                if (job.part[w].count)
                    m += job.part[w].count[c];
            start[c] = run;
            run += m;
        }
        g->cell_items = malloc(((size_t)total + 1) * sizeof *g->cell_items);
        ok = g->cell_items != NULL;
    }
    if (ok) {
        uint32_t *items = g->cell_items, *cursor = g->cell_start;
        for (uint32_t k = 0; k < job.nchunks; k++) {
            const uint32_t *cell = job.part[job.chunk[k].worker].pairs + job.chunk[k].off;
            uint32_t p1 = n - k * BIN_CHUNK > BIN_CHUNK ? (k + 1) * BIN_CHUNK : n;
            for (uint32_t p = k * BIN_CHUNK; p < p1; p++)
                for (uint32_t j = g->prim_ncells[p]; j > 0; j--)
                    items[cursor[*cell++]++] = p;
        }
        /* Each cursor now stands at the start of the next cell. */
        memmove(g->cell_start + 1, g->cell_start, (size_t)cells * sizeof *g->cell_start);
        g->cell_start[0] = 0;
        free_build_state(g);
    }
    for (int w = 0; w < PAR_MAX_WORKERS; w++) {
        free(job.part[w].pairs);
        job.part[w].pairs = NULL;
        if (w > 0)
            free(job.part[w].count);
        job.part[w].count = NULL;
    }
    if (ok) {
        /* Packed copies of the untransformed triangles for the hot loop (grid_pack.c),
         * while the course counts are made. */
        par_for((int)job.nchunks + 1, course_chunk, &job);
        ok = !job.pack_failed && parts_ok(&job);
        for (int w = 1; ok && w < PAR_MAX_WORKERS; w++)
            if (job.part[w].course)
                for (uint32_t c = 0; c < cells; c++)
                    g->course_count[c] += job.part[w].course[c];
    }
    for (int w = 1; w < PAR_MAX_WORKERS; w++)
        free(job.part[w].course);
    free(job.chunk);
    free(job.snap);
    free(job.kind);
    return ok;
}


void grid_free(Grid *g)
{
    if (!g)
        return;
    free_build_state(g);
    free(g->cell_start);
    free(g->cell_items);
    grid_pack_free(g);
    free(g->course_count);
    free(g->prims);
    free(g->unbounded);
    prim_table_free(&g->own_table);
    free(g);
}

/* Sets the box the cells tile and the rounding pad. Zero-thickness axes (a flat scene)
 * get a small symmetric thickness so cell sizes stay positive (semantics.md 7.1). */
static void setup_geometry(Grid *g)
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
    g->box_mag = mag;
}

static Grid *build(const PrimTable *t, int nx, int ny, int nz, Diag *diag)
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
    Grid *g = calloc(1, sizeof *g);
    if (!g)
        goto oom;
    g->bounds = t->scene_bounds;
    g->n[0] = nx;
    g->n[1] = ny;
    g->n[2] = nz;
    g->num_cells = (uint32_t)cells;
    g->marking = true;
    setup_geometry(g);
    g->cell_start = calloc((size_t)cells + 1, sizeof *g->cell_start);
    g->course_count = calloc((size_t)cells, sizeof *g->course_count);
    if (!g->cell_start || !g->course_count)
        goto oom;

    if (!setup_cell_axis(g))
        goto oom;
    uint32_t nb = t->num_bounded, nu = t->num_prims - t->num_bounded;
    g->prims = malloc((nb ? nb : 1) * sizeof *g->prims);
    g->prim_ncells = malloc((nb ? nb : 1) * sizeof *g->prim_ncells);
    g->unbounded = malloc((nu ? nu : 1) * sizeof *g->unbounded);
    if (!g->prims || !g->prim_ncells || !g->unbounded)
        goto oom;
    /* The bounded primitives go into cells in table (depth-first) order; the others are
     * tested for every ray. */
    for (uint32_t i = 0; i < t->num_prims; i++) {
        const Prim *p = &t->prims[i];
        if (p->bounded) {
            RecKind kind = obj_kind(p->obj) == OBJ_TRIANGLE ? REC_TRIANGLE
                           : p->xf                          ? REC_SPHERE_XF
                                                            : REC_SPHERE;
            append_prim(g, p, kind);
        } else {
            g->unbounded[g->num_unbounded].obj = p->obj;
            g->unbounded[g->num_unbounded].xf = p->xf;
            g->num_unbounded++;
        }
    }
    if (!bin_fill_pack(g)) {
        if (!g->too_many)
            goto oom;
        diag_error(diag, NULL, "grid %dx%dx%d would hold too many entries; use fewer cells",
                   nx, ny, nz);
        grid_free(g);
        return NULL;
    }
    return g;

oom:
    diag_error(diag, NULL, "out of memory building a %dx%dx%d grid", nx, ny, nz);
    grid_free(g);
    return NULL;
}

Grid *grid_build_table(const PrimTable *t, int nx, int ny, int nz, Diag *diag)
{
    if (!t || t->num_bounded == 0 || bbox_is_empty(&t->scene_bounds))
        return NULL;
    /* Wake the binning helpers now: the set-up gives them time to get a CPU. */
    if (t->num_bounded >= 2 * BIN_CHUNK)
        par_prepare();
    Grid *g = build(t, nx, ny, nz, diag);
    /* The grid is the last step before the render, which wants the cores. */
    par_release();
    return g;
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
    uint32_t c = g->course_count[grid_cell_index(g, i, j, k)];
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
    for (uint32_t c = 0; c < g->num_cells; c++)
        sum += g->course_count[c];
    if (course)
        *course = sum;
    if (marching)
        *marching = g->cell_start[g->num_cells];
}
