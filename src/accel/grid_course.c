/* The course's occupancy rules (docs/grid.md, How it works), in float like the course:
 * the per-cell counts that -visualize_grid colours and the statistics report. */
#include "grid_build.h"

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
        float lo = (v3_comp(bmin, a) - mn) / s - tol, hi = (v3_comp(bmax, a) - mn) / s + tol;
        r.lo[a] = grid_range_lo((double)lo, g->n[a]);
        r.hi[a] = grid_range_hi((double)hi, g->n[a]);
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

/* The box range grid_course_insert walks for rec. */
static CellRange course_range(const Grid *g, const GridBuildRec *rec)
{
    if (rec->kind == REC_SPHERE) {
        /* Cell centre within r + half the cell diagonal of the centre. */
        Vec3 c = rec->v[0];
        float half_diag = 0.5f * v3_length(v3(g->size[0], g->size[1], g->size[2]));
        float reach = rec->r + half_diag;
        Vec3 e = v3(reach, reach, reach);
        return course_box_range(g, v3_sub(c, e), v3_add(c, e), 1e-4f);
    }
    BBox b;
    if (rec->kind == REC_BOX) {
        b.min = rec->v[0];
        b.max = rec->v[1];
    } else {
        b.min = v3_min(v3_min(rec->v[0], rec->v[1]), rec->v[2]);
        b.max = v3_max(v3_max(rec->v[0], rec->v[1]), rec->v[2]);
    }
    return course_box_range(g, b.min, b.max, rec->gp || rec->kind == REC_BOX ? 1e-4f : 0.0f);
}

uint64_t grid_course_box_cells(const Grid *g, const GridBuildRec *rec)
{
    CellRange r = course_range(g, rec);
    return (uint64_t)(r.hi[0] - r.lo[0] + 1) * (uint64_t)(r.hi[1] - r.lo[1] + 1) *
           (uint64_t)(r.hi[2] - r.lo[2] + 1);
}

/* Adds rec's cells by the course's rules to course[] (per-cell counts). */
void grid_course_insert(const Grid *g, uint32_t *course, const GridBuildRec *rec)
{
    CellRange r = course_range(g, rec);
    if (rec->kind == REC_SPHERE) {
        Vec3 c = rec->v[0];
        float half_diag = 0.5f * v3_length(v3(g->size[0], g->size[1], g->size[2]));
        float reach = rec->r + half_diag;
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
    count_range(g, course, &r);
}
