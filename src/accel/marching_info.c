/* The 3D-DDA (Amanatides & Woo 1987) that walks a ray through the grid's cells in order
 * (docs/grid.md). Used by RayCastFast, the shadow query and -visualize_grid. */
#include "rt/marching_info.h"
#include "rt/geom.h"

/* march_band_width before its cap: the tolerance's reach beyond the box, the same for
 * every axis. Plain compares for fmaxf (a libm call at -O2; the box is finite, so no
 * NaN reaches them, and fabsf's +0 and the +0 start leave no signed zero to tell). */
static inline float band_reach(const BBox *box)
{
    float ext = 0.0f, mag = 0.0f;
    const float lo[3] = {box->min.x, box->min.y, box->min.z};
    const float hi[3] = {box->max.x, box->max.y, box->max.z};
    for (int a = 0; a < 3; a++) {
        ext += hi[a] - lo[a];
        float m = fabsf(lo[a]), h = fabsf(hi[a]);
        m = h > m ? h : m;
        mag = m > mag ? m : mag;
    }
    return 2.0f * (RT_TRI_EDGE_TOL + RT_TRI_FAR_TOL) * ext + 1e-5f * mag;
}

float march_band_width(const BBox *box, float pad)
{
    float w = band_reach(box);
    return w < pad ? w : pad;
}

bool march_init(MarchingInfo *mi, const BBox *box, const int n[3], const float pad[3],
                const Ray *ray, float tmin, RenderCtx *ctx)
{
    const float o[3] = {ray->origin.x, ray->origin.y, ray->origin.z};
    const float d[3] = {ray->dir.x, ray->dir.y, ray->dir.z};
    const float lo[3] = {box->min.x, box->min.y, box->min.z};
    const float hi[3] = {box->max.x, box->max.y, box->max.z};
    float inv[3];
    bool parallel[3];
    float t_enter = -INFINITY, t_exit = INFINITY;
    int enter_axis = -1;
    /* band_reach(box) for band_t, made once, for a ray that meets the box, on an axis
     * with a pad: it depends on the box alone, and with pad 0 (-visualize_grid's march)
     * the band is 0 whatever it is. Made per axis and ray it cost -visualize_grid lines
     * up to 70% more instructions (regress37, bench/REPORT.txt). */
    float reach = -1.0f;

    /* Slab test against the padded box (Kay & Kajiya). */
    for (int a = 0; a < 3; a++) {
        inv[a] = 1.0f / d[a];
        parallel[a] = d[a] == 0.0f || !isfinite(inv[a]);
        float plo = lo[a] - pad[a], phi = hi[a] + pad[a];
        if (parallel[a]) {
            if (!(o[a] >= plo && o[a] <= phi))
                return false;
            continue;
        }
        march_slab_axis(plo, phi, o[a], inv[a], a, &t_enter, &t_exit, &enter_axis);
    }
    mi->held = 0;
    if (enter_axis < 0)
        return false; /* zero direction: the ray goes nowhere */
    if (!(t_enter <= t_exit) || t_exit < tmin)
        return false;

    mi->started_inside = t_enter < tmin;
    mi->t = mi->started_inside ? tmin : t_enter;
    for (int a = 0; a < 3; a++) {
        mi->n[a] = n[a];
        mi->step[a] = (!parallel[a] && d[a] < 0.0f) ? -1 : 1;
        float inv_size = (float)n[a] / (hi[a] - lo[a]);
        if (!mi->started_inside && a == enter_axis) {
            /* The entry point lies on the entered face: its cell is known exactly,
             * whatever the rounding of o + t*d. */
            mi->cell[a] = mi->step[a] > 0 ? 0 : n[a] - 1;
        } else {
            mi->cell[a] = march_cell_of(o[a] + mi->t * d[a], lo[a], inv_size, n[a]);
        }
        mi->band_t[a] = 0.0f;
        if (parallel[a]) {
            mi->base[a] = 0.0f;
            mi->dt[a] = 0.0f;
            mi->t_next[a] = INFINITY;
        } else {
            if (pad[a] > 0.0f) {
                if (reach < 0.0f)
                    reach = band_reach(box);
                mi->band_t[a] = (reach < pad[a] ? reach : pad[a]) * fabsf(inv[a]);
            }
            float size = (hi[a] - lo[a]) / (float)n[a];
            mi->base[a] = (lo[a] - o[a]) * inv[a];
            mi->dt[a] = size * inv[a];
            int k = mi->step[a] > 0 ? mi->cell[a] + 1 : mi->cell[a];
            mi->t_next[a] = mi->base[a] + (float)k * mi->dt[a];
        }
    }
    if (mi->started_inside) {
        /* No face was crossed; use the face the dominant axis would have entered. */
        int a = 0;
        if (fabsf(d[1]) > fabsf(d[a]))
            a = 1;
        if (fabsf(d[2]) > fabsf(d[a]))
            a = 2;
        mi->normal = march_axis_normal(a, -mi->step[a]);
    } else {
        mi->normal = march_axis_normal(enter_axis, -mi->step[enter_axis]);
    }
    march_enter_cell(mi, ctx);
    return true;
}
