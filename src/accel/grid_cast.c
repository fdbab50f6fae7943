/* RayCastFast (the course's grid cast; docs/grid.md): nearest hit and shadow queries
 * through the grid's cells, front to back, with marking (mailboxing) so a primitive
 * spanning many cells is intersected at most once per ray. Reads the grid only; per-ray
 * state is in ctx. */
#include "grid_internal.h"
#include "twolevel_internal.h"

#include <float.h>
#include <math.h>
#include <string.h>

#include "rt/cpu.h"
#include "rt/geom.h"
#include "rt/options.h" /* RT_GRID_MAX_CELLS */

#if defined(__SSE2__)
#include <emmintrin.h>
#define RT_GRID_SIMD 1
#else
#define RT_GRID_SIMD 0
#endif


/* Cell entry e: a packed triangle inline (grid_pack.c), anything else through its ops.
 * Both do exactly what Triangle::intersect does, so the hit is the same to the bit.
 * any (the shadow query, hit = (tmax, id 0)): only whether there is a hit; hit is not
 * written and other primitives answer through their occluded op. */
static inline __attribute__((always_inline)) bool test_entry(const Grid *g, uint32_t e,
                                                              const Ray *ray, Hit *hit,
                                                              float tmin, RenderCtx *ctx,
                                                              XfMemo *xm, bool any)
{
    uint32_t p = GRID_ITEM_INDEX(e);
    if (!(e & GRID_ITEM_TRI))
        return any ? grid_occluded_prim_memo(&g->prims[p], ray, tmin, hit->t, ctx, xm)
                   : grid_test_prim_memo(&g->prims[p], ray, hit, tmin, ctx, xm);
    const PackedTri *pt = &g->tri[p];
    ctx->stats.intersections++;
    float t;
    if (!triangle_ray_t(pt->v0, pt->e1, pt->e2, ray, &t) || !(t > tmin) ||
        !hit_accepts(hit, t, pt->id))
        return false;
    if (any)
        return true;
    hit->t = t;
    hit->normal = g->tri_hit[p].normal;
    hit->material = g->tri_hit[p].material;
    hit->id = pt->id;
    return true;
}

#if RT_GRID_SIMD
/* Four packed triangles at once: triangle_ray_t lane by lane. SSE2 add, sub, mul and
 * div are IEEE operations like their scalar forms and are applied in the same order
 * (no fused multiply-add), so every lane computes exactly the scalar t and verdict.
 * The lanes' outcomes are then applied in any order: the nearest hit under
 * hit_accepts' (t, id) order does not depend on the order candidates are offered. */
typedef struct TriBatch {
    uint32_t p[4];
    int n;
} TriBatch;

typedef struct RaySimd {
    __m128 ox, oy, oz, dx, dy, dz, tmin;
} RaySimd;

static inline RaySimd ray_simd(const Ray *ray, float tmin)
{
    RaySimd r = {_mm_set1_ps(ray->origin.x), _mm_set1_ps(ray->origin.y),
                 _mm_set1_ps(ray->origin.z), _mm_set1_ps(ray->dir.x),
                 _mm_set1_ps(ray->dir.y),    _mm_set1_ps(ray->dir.z), _mm_set1_ps(tmin)};
    return r;
}

/* Tests packed triangles p0..p3; returns the lane mask of hits with t > tmin and their
 * t's in *tout. */
static inline __attribute__((always_inline)) int tri4_test(const Grid *g, uint32_t p0,
                                                          uint32_t p1, uint32_t p2,
                            uint32_t p3, const RaySimd *r, __m128 *tout)
{
    const float *t0 = (const float *)&g->tri[p0], *t1 = (const float *)&g->tri[p1];
    const float *t2 = (const float *)&g->tri[p2], *t3 = (const float *)&g->tri[p3];
    __m128 a0 = _mm_load_ps(t0), a1 = _mm_load_ps(t1), a2 = _mm_load_ps(t2), a3 = _mm_load_ps(t3);
    _MM_TRANSPOSE4_PS(a0, a1, a2, a3); /* v0x v0y v0z e1x */
    __m128 b0 = _mm_load_ps(t0 + 4), b1 = _mm_load_ps(t1 + 4), b2 = _mm_load_ps(t2 + 4),
           b3 = _mm_load_ps(t3 + 4);
    _MM_TRANSPOSE4_PS(b0, b1, b2, b3); /* e1y e1z e2x e2y */
    __m128 c0 = _mm_load_ps(t0 + 8), c1 = _mm_load_ps(t1 + 8), c2 = _mm_load_ps(t2 + 8),
           c3 = _mm_load_ps(t3 + 8);
    _MM_TRANSPOSE4_PS(c0, c1, c2, c3); /* e2z id box.lo[0] box.lo[1] */
    __m128 v0x = a0, v0y = a1, v0z = a2, e1x = a3, e1y = b0, e1z = b1, e2x = b2, e2y = b3,
           e2z = c0;
    /* triangle_ray_t's formula, 4 lanes wide (rt/geom.h) */
    RT_MOLLER_TRUMBORE(__m128, _mm_set1_ps(1.0f), r->ox, r->oy, r->oz, r->dx, r->dy, r->dz,
                       v0x, v0y, v0z, e1x, e1y, e1z, e2x, e2y, e2z, det, u, v, tt);
    __m128 zero = _mm_setzero_ps(), lo = _mm_set1_ps(-RT_TRI_EDGE_TOL);
    __m128 hi = _mm_set1_ps(1.0f + RT_TRI_FAR_TOL);
    __m128 ok = _mm_cmpneq_ps(det, zero);
    ok = _mm_and_ps(ok, _mm_cmpge_ps(u, lo));
    ok = _mm_and_ps(ok, _mm_cmpge_ps(v, lo));
    ok = _mm_and_ps(ok, _mm_cmple_ps(_mm_add_ps(u, v), hi));
    ok = _mm_and_ps(ok, _mm_cmpgt_ps(tt, r->tmin));
    *tout = tt;
    return _mm_movemask_ps(ok);
}

/* Tests batch->p[0..3]; returns the lane mask of hits with t > tmin and t[] per lane. */
static inline int batch_test(const Grid *g, const TriBatch *b, const RaySimd *r, float t[4])
{
    __m128 tt;
    int mask = tri4_test(g, b->p[0], b->p[1], b->p[2], b->p[3], r, &tt);
    _mm_storeu_ps(t, tt);
    return mask;
}

/* Offers the batch's hits to hit (nearest-hit query). */
static inline bool batch_intersect(const Grid *g, const TriBatch *b, const RaySimd *r,
                                   Hit *hit, RenderCtx *ctx)
{
    float t[4];
    int mask = batch_test(g, b, r, t);
    ctx->stats.intersections += 4;
    bool found = false;
    for (int i = 0; i < 4; i++) {
        if (!(mask & (1 << i)))
            continue;
        uint32_t p = b->p[i];
        uint32_t id = g->tri[p].id;
        if (!hit_accepts(hit, t[i], id))
            continue;
        hit->t = t[i];
        hit->normal = g->tri_hit[p].normal;
        hit->material = g->tri_hit[p].material;
        hit->id = id;
        found = true;
    }
    return found;
}

/* The shadow query's batch: true when a lane holds an occluder (t < h->t, as
 * hit_accepts against the query's (tmax, id 0) takes it). Counts the tests the scalar
 * loop would have made: up to and including the first occluding lane. */
static inline bool batch_occluded(const Grid *g, const TriBatch *b, const RaySimd *r,
                                  const Hit *h, RenderCtx *ctx)
{
    float t[4];
    int mask = batch_test(g, b, r, t);
    for (int i = 0; i < 4; i++)
        if ((mask & (1 << i)) && t[i] < h->t) {
            ctx->stats.intersections += (uint64_t)i + 1;
            return true;
        }
    ctx->stats.intersections += 4;
    return false;
}
#endif

/* Declares rsimd, the ray as the cell loop's 4-lane batches take it (ray_simd), or NULL
 * without SIMD. */
#if RT_GRID_SIMD
#define MARCH_RAY_SIMD(rsimd, ray, tmin)                                                   \
    RaySimd rsimd##_rs = ray_simd(ray, tmin);                                              \
    const void *rsimd = &rsimd##_rs
#else
#define MARCH_RAY_SIMD(rsimd, ray, tmin) const void *rsimd = NULL
#endif

/* A fresh stamp for this ray, or 0 when there is no usable mailbox. Stamps wrap after
 * 2^32 - 1 rays: then every slot is cleared, so no stale stamp can match. */
uint32_t grid_begin_ray(const Grid *g, RenderCtx *ctx)
{
    if (!ctx->mailbox || ctx->num_mailbox < g->num_prims || g->num_prims == 0)
        return 0;
    uint32_t s = ++ctx->ray_stamp;
    if (s == 0) {
        memset(ctx->mailbox, 0, (size_t)ctx->num_mailbox * sizeof *ctx->mailbox);
        s = ctx->ray_stamp = 1;
    }
    return s;
}

/* Whether entry p must be tested now. With marking, an entry already stamped for this
 * ray is skipped: its earlier test already found its nearest hit beyond tmin, which a
 * second test could only repeat. Without marking, repeats are tested and counted. */
static inline bool should_test(const Grid *g, uint32_t *mb, uint32_t stamp, uint32_t p,
                               RenderCtx *ctx)
{
    if (!mb)
        return true;
    if (mb[p] == stamp) {
        if (g->marking) {
            ctx->stats.mailbox_skips++;
            return false;
        }
        ctx->stats.repeat_tests++;
        return true;
    }
    mb[p] = stamp;
    return true;
}

/* Float rounding of the march grows with the size of the coordinates it works with:
 * o + t*d and the border crossings (lo - o)/d carry an error of a few ulps of
 * |o| + |box|. The cells are padded against a fixed margin (g->pad), so a ray whose
 * origin is so far away that this error exceeds the margin (thousands of box sizes,
 * e.g. a secondary ray leaving a distant plane hit) may be walked through the wrong
 * cells. Such rays test every bounded primitive instead: rare, slow, exact. */
static inline float march_error(const Grid *g, const Ray *ray)
{
    float m = fabsf(ray->origin.x);
    if (fabsf(ray->origin.y) > m)
        m = fabsf(ray->origin.y);
    if (fabsf(ray->origin.z) > m)
        m = fabsf(ray->origin.z);
    return 4.0f * FLT_EPSILON * (m + g->box_mag);
}

/* True when the march cannot be trusted for this ray AND the ray passes near enough
 * to the box to hit something in it (a far ray that misses the widened box is left to
 * march_init, which rejects it). */
bool grid_ray_too_far(const Grid *g, const Ray *ray, float tmin)
{
    float err = march_error(g, ray);
    if (err < g->min_pad)
        return false;
    if (!isfinite(err))
        return true;
    BBox wide = g->box;
    wide.min = v3_sub(wide.min, v3(g->pad[0] + err, g->pad[1] + err, g->pad[2] + err));
    wide.max = v3_add(wide.max, v3(g->pad[0] + err, g->pad[1] + err, g->pad[2] + err));
    float t0, t1;
    return bbox_ray_interval(&wide, ray->origin, ray->dir, &t0, &t1) && t1 >= tmin;
}

static bool brute_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin,
                            RenderCtx *ctx)
{
    bool found = false;
    for (uint32_t p = 0; p < g->num_prims; p++)
        found |= grid_test_prim(&g->prims[p], ray, hit, tmin, ctx);
    return found;
}

/* brute_intersect's shadow query: stops at the first occluder and counts the tests
 * it skips (one intersection per leaf), so the counters are brute_intersect's. */
static bool brute_occluded(const Grid *g, const Ray *ray, float tmin, float tmax,
                           RenderCtx *ctx)
{
    for (uint32_t p = 0; p < g->num_prims; p++)
        if (grid_occluded_prim(&g->prims[p], ray, tmin, tmax, ctx)) {
            ctx->stats.intersections += g->num_prims - p - 1;
            return true;
        }
    return false;
}

/* march_init's reciprocals of the direction. */
static inline __attribute__((always_inline)) void ray_inv_dir(const Ray *ray, float inv[3])
{
    inv[0] = 1.0f / ray->dir.x;
    inv[1] = 1.0f / ray->dir.y;
    inv[2] = 1.0f / ray->dir.z;
}

/* The cast's march (lean_init starts it), for the queries without a ray tree, in
 * registers: march_next step for step (the axis with the smallest t_next, ties to x,
 * then y; the same t's: the stepped axis' next boundary is base + (float)k * dt, with
 * k kept as a float, exact because no axis has 2^24 cells), with the cell's index kept
 * as one number (plus the axis' stride at each step) and the steps left to the box's
 * end counted down per axis instead of the cell's coordinates. */
_Static_assert(RT_GRID_MAX_CELLS <= (1 << 24), "a cell coordinate + 1 is exact in a float");
typedef struct LeanMarch {
    float t;                    /* entry t of the current cell */
    float tn0, tn1, tn2;        /* t_next per axis */
    float b0, b1, b2, dt0, dt1, dt2, k0, k1, k2, s0, s1, s2; /* base, dt, k, step */
    int left0, left1, left2;    /* steps left inside the box per axis */
    /* lean_next_band only (set by band_walk, not by lean_init): how far along the ray
     * (in t) the band beyond each face reaches (the grid's band width over the
     * direction's component; 0 when parallel), and the axes held in it (bits). */
    float p0, p1, p2;
    unsigned held;
    int32_t d0, d1, d2;         /* index stride of one step per axis (signed) */
    uint32_t c;                 /* the current cell's index (grid_cell_index) */
    int left_sum;               /* left0 + left1 + left2 at the start (lean_cells) */
} LeanMarch;

/* march_exit_t of the current cell. */
static inline __attribute__((always_inline)) float lean_exit_t(const LeanMarch *m)
{
    float a = m->tn0 < m->tn1 ? m->tn0 : m->tn1;
    return a < m->tn2 ? a : m->tn2;
}

/* The next cell: the axis (ties to x, then y) by selects, then one branch per axis that
 * checks and counts down that axis' steps left, moves the index and updates its t_next
 * (only the stepped axis' counter can reach zero; fewer instructions than selects for all
 * three counters and the index, 214bc03); false when the ray leaves the box or runs
 * parallel to every axis left.
 * With band (a constant at each call): a step that would leave the box along an axis
 * holds that axis at its last cell instead, until the ray leaves the band beyond that
 * face (p0..p2: march_band_width, rt/marching_info.h), and the march goes on along the
 * other axes. The triangle test accepts points a little outside a triangle
 * (RT_TRI_EDGE_TOL, rt/geom.h), so a ray running along a face of the box just outside it
 * can hit a triangle in a cell it reaches only after crossing that face; the cells are
 * padded for such hits, and the plain loop finds them (docs/grid.md, "Beyond the box's
 * faces"). band_walk takes those cells, leaving them out of the counts: the course's
 * march ends at the box. */
static inline __attribute__((always_inline)) bool lean_next_band(LeanMarch *m, bool band)
{
again:;
    bool y = m->tn1 < m->tn0;
    float tm = y ? m->tn1 : m->tn0;
    bool z = m->tn2 < tm;
    tm = z ? m->tn2 : tm;
    if (!(tm < INFINITY))
        return false;
    if (z) {
        if (m->left2 == 0) {
            if (!band || (m->held & 4u))
                return false; /* the step leaves the box (or the band) */
            m->held |= 4u;
            m->tn2 += m->p2; /* from the face to the band's side */
            goto again;
        }
        m->left2--;
        m->c += (uint32_t)m->d2;
        m->k2 += m->s2;
        m->tn2 = m->b2 + m->k2 * m->dt2;
    } else if (y) {
        if (m->left1 == 0) {
            if (!band || (m->held & 2u))
                return false;
            m->held |= 2u;
            m->tn1 += m->p1; /* from the face to the band's side */
            goto again;
        }
        m->left1--;
        m->c += (uint32_t)m->d1;
        m->k1 += m->s1;
        m->tn1 = m->b1 + m->k1 * m->dt1;
    } else {
        if (m->left0 == 0) {
            if (!band || (m->held & 1u))
                return false;
            m->held |= 1u;
            m->tn0 += m->p0; /* from the face to the band's side */
            goto again;
        }
        m->left0--;
        m->c += (uint32_t)m->d0;
        m->k0 += m->s0;
        m->tn0 = m->b0 + m->k0 * m->dt0;
    }
    m->t = tm;
    return true;
}

/* lean_next without the band: the two-level walk's marches, whose leaf grids pad their
 * triangles' boxes for the tolerance instead (twolevel.c, tri_tolerance). */
static inline __attribute__((always_inline)) bool lean_next(LeanMarch *m)
{
    return lean_next_band(m, false);
}

/* The cells entered after the first: every step counts one axis' steps left down by
 * one, so their sum fell by one per step (a counter of its own cost a memory
 * increment per step: the march's state does not fit the registers). */
static inline __attribute__((always_inline)) uint64_t lean_cells(const LeanMarch *m)
{
    return (uint64_t)(m->left_sum - (m->left0 + m->left1 + m->left2));
}

/* What lean_init takes from the ray alone (its origin, direction, reciprocals and which
 * axes it runs parallel to), made once per ray for the two-level walk's marches: the
 * top grid's and each leaf grid's the ray enters. */
typedef struct LeanRay {
    float o[3], d[3], inv[3];
    bool par[3]; /* march_init's parallel axes: d == 0 or 1/d not finite */
} LeanRay;

static inline __attribute__((always_inline)) void lean_ray(const Ray *ray, LeanRay *r)
{
    r->o[0] = ray->origin.x;
    r->o[1] = ray->origin.y;
    r->o[2] = ray->origin.z;
    r->d[0] = ray->dir.x;
    r->d[1] = ray->dir.y;
    r->d[2] = ray->dir.z;
    ray_inv_dir(ray, r->inv);
    /* march_init's test is d == 0 || !isfinite(1 / d); a zero d (either sign) has an
     * infinite reciprocal, so the second half alone gives the same answer. */
    for (int a = 0; a < 3; a++)
        r->par[a] = !isfinite(r->inv[a]);
}

/* The cast's own march start: march_init for one grid (n cells per axis, whose indices
 * start at base), the same float expressions in the same order, so the same t, cells and
 * t_next's, with the grid's constants (lo = the box's min corner, the padded slab's
 * sides, n / extent and the cell size, each computed once by march_init's own
 * expression) instead of six divisions per ray, the ray's part from r, and without what
 * only the ray tree reads (the entered face's normal, started_inside), written straight
 * into the lean march (k, the steps left, the index strides, the cell's index). Used
 * when no ray tree is being recorded; with one, march_init/march_next record it.
 * Counts nothing (the callers count the first cell). */
static inline __attribute__((always_inline)) bool lean_init(
    const float lo[3], const float slab_lo[3], const float slab_hi[3],
    const float inv_size[3], const float size[3], const int n[3], uint32_t base,
    const LeanRay *r, float tmin, LeanMarch *m)
{
    float t_enter = -INFINITY, t_exit = INFINITY;
    int enter_axis = -1;
    bool outside = false; /* parallel to an axis outside the slab: no cell */
    for (int a = 0; a < 3; a++) {
        if (r->par[a]) {
            outside |= !(r->o[a] >= slab_lo[a] && r->o[a] <= slab_hi[a]);
            continue;
        }
        march_slab_axis(slab_lo[a], slab_hi[a], r->o[a], r->inv[a], a, &t_enter, &t_exit, &enter_axis);
    }
    if (outside || enter_axis < 0)
        return false;
    if (!(t_enter <= t_exit) || t_exit < tmin)
        return false;
    bool inside = t_enter < tmin;
    float t = inside ? tmin : t_enter;
    int cell[3], step[3];
    float tn[3], b[3], dt[3], k[3];
    for (int a = 0; a < 3; a++) {
        bool up = r->par[a] || !(r->d[a] < 0.0f); /* step +1 */
        step[a] = up ? 1 : -1;
        if (!inside && a == enter_axis)
            cell[a] = up ? 0 : n[a] - 1;
        else
            cell[a] = march_cell_of(r->o[a] + t * r->d[a], lo[a], inv_size[a], n[a]);
        k[a] = (float)(cell[a] + up);
        if (r->par[a]) {
            b[a] = 0.0f;
            dt[a] = 0.0f;
            tn[a] = INFINITY;
        } else {
            b[a] = (lo[a] - r->o[a]) * r->inv[a];
            dt[a] = size[a] * r->inv[a];
            tn[a] = b[a] + k[a] * dt[a];
        }
    }
    m->t = t;
    m->tn0 = tn[0];
    m->tn1 = tn[1];
    m->tn2 = tn[2];
    m->b0 = b[0];
    m->b1 = b[1];
    m->b2 = b[2];
    m->dt0 = dt[0];
    m->dt1 = dt[1];
    m->dt2 = dt[2];
    m->k0 = k[0];
    m->k1 = k[1];
    m->k2 = k[2];
    m->s0 = (float)step[0];
    m->s1 = (float)step[1];
    m->s2 = (float)step[2];
    m->left0 = step[0] > 0 ? n[0] - 1 - cell[0] : cell[0];
    m->left1 = step[1] > 0 ? n[1] - 1 - cell[1] : cell[1];
    m->left2 = step[2] > 0 ? n[2] - 1 - cell[2] : cell[2];
    m->d0 = step[0];
    m->d1 = step[1] * n[0];
    m->d2 = step[2] * n[0] * n[1];
    m->c = base + ((uint32_t)cell[2] * (uint32_t)n[1] + (uint32_t)cell[1]) * (uint32_t)n[0] +
           (uint32_t)cell[0];
    m->left_sum = m->left0 + m->left1 + m->left2;
    return true;
}

/* The counts of a march as the course's march makes them, which ends at the box: the
 * cells entered beyond a face (band_walk, march_next_band), and the tests made in them,
 * are left out of every counter (cells traversed, intersections, and the mailbox's
 * skips and repeats, so that with and without marking they still add up:
 * test_grid_course). band_note notes the counts when the band begins, band_restore puts
 * them back at the end. */
typedef struct LeanBand {
    bool on;
    uint64_t intersections, mailbox_skips, repeat_tests; /* when the band began */
} LeanBand;

/* The band's counts: noted when it begins (held: its first cell is current), put back
 * at the end. Shared with the ray-tree march (march_next_band). */
static inline __attribute__((always_inline)) void band_note(bool held, LeanBand *b,
                                                             const RenderCtx *ctx)
{
    if (__builtin_expect(held && !b->on, 0)) {
        b->on = true;
        b->intersections = ctx->stats.intersections;
        b->mailbox_skips = ctx->stats.mailbox_skips;
        b->repeat_tests = ctx->stats.repeat_tests;
    }
}

static inline __attribute__((always_inline)) void band_restore(const LeanBand *b,
                                                                RenderCtx *ctx)
{
    if (__builtin_expect(b->on, 0)) {
        ctx->stats.intersections = b->intersections;
        ctx->stats.mailbox_skips = b->mailbox_skips;
        ctx->stats.repeat_tests = b->repeat_tests;
    }
}

/* Whether cell c has entries: the occupancy bits when the grid has them. */
static inline __attribute__((always_inline)) bool cell_occupied(const Grid *g, uint32_t c)
{
    return !g->occupied || (g->occupied[c >> 6] >> (c & 63) & 1);
}

/* cell_occupied with the grid's occupancy bits (or NULL) held by the caller: the lean
 * loops read g->occupied once per ray instead of at every cell (the stores to the
 * mailbox and counters in between keep the compiler from doing so). */
static inline __attribute__((always_inline)) bool cell_occupied_in(const uint64_t *occ,
                                                                   uint32_t c)
{
    return !occ || (occ[c >> 6] >> (c & 63) & 1);
}

/* lean_init over grid g's cells (the march of the queries without a ray tree),
 * counting its first cell. */
static inline __attribute__((always_inline)) bool cast_lean_init(const Grid *g,
                                                                  const Ray *ray,
                                                                  float tmin,
                                                                  RenderCtx *ctx,
                                                                  LeanMarch *m)
{
    const float lo[3] = {g->box.min.x, g->box.min.y, g->box.min.z};
    LeanRay lr;
    lean_ray(ray, &lr);
    if (!lean_init(lo, g->slab_lo, g->slab_hi, g->inv_size, g->size, g->n, 0, &lr, tmin, m))
        return false;
    ctx->stats.cells_traversed++;
    return true;
}

/* Where both queries' march starts (grid_march_tmin); false when the ray starts too far
 * out for the march (grid_ray_too_far) and must test every bounded primitive. */
static inline __attribute__((always_inline)) bool march_start(const Grid *g, const Ray *ray,
                                                              float tmin, float *tmarch)
{
    *tmarch = grid_march_tmin(g, tmin);
    /* grid_ray_too_far's first test inline: nearly every ray passes it. */
    return march_error(g, ray) < g->min_pad || !grid_ray_too_far(g, ray, *tmarch);
}

/* The ray's mailbox stamp; *mb NULL: no marking. */
static inline __attribute__((always_inline)) uint32_t march_stamp(const Grid *g,
                                                                  RenderCtx *ctx,
                                                                  uint32_t **mb)
{
    uint32_t stamp = grid_begin_ray(g, ctx);
    *mb = stamp ? ctx->mailbox : NULL;
    return stamp;
}

#if RT_GRID_SIMD
/* test_items when every entry is a packed triangle (g->all_tri): the entries four at a
 * time as they stand in the list, each group's lanes masked by the mailbox instead of
 * being gathered into a batch one entry at a time, and the last one to three entries
 * of a list tested as a masked group instead of one by one. The same tests in the same
 * order as test_items' batches and scalar tail (the tested entries in list order), so
 * the same hits and the same intersection counts: a nearest-hit query offers every
 * hit lane to hit_accepts (whose choice does not depend on the order of the offers);
 * a shadow query counts the tested lanes up to and including its first occluder, as
 * batch_occluded and the scalar tail do. What differs is the mailbox's bookkeeping:
 * a group's lanes are stamped and its skips counted before its test, so a shadow query
 * that stops in a group has also counted the skipped lanes after its occluder
 * (mailbox_skips only; the -stats block does not show it). Lanes past the list's end
 * repeat its first entry of the group and are masked off. */
/* Set bits of a 4-bit lane mask (the build has no popcnt instruction: the builtin is a
 * library call). */
static inline int lanes_count(int m)
{
    return (int)((0x4332322132212110ull >> (4 * (m & 15))) & 15);
}

static inline __attribute__((always_inline)) bool test_groups(const Grid *g,
                                                               const uint32_t *items,
                                                               uint32_t n, Hit *hit,
                                                               RenderCtx *ctx, uint32_t *mb,
                                                               uint32_t stamp,
                                                               const RaySimd *rs, bool any)
{
    bool found = false;
    /* Lanes before the current group and their mailbox hits: the tests made are the
     * lanes so far less the skipped ones (with marking). */
    uint32_t e = 0;
    uint64_t seen_total = 0, seen_cur = 0, tests_here = 0;
    __m128i stamps = _mm_set1_epi32((int)stamp);
    for (; e < n; e += 4) {
        uint32_t left = n - e;
        uint32_t p0 = GRID_ITEM_INDEX(items[e]), p1, p2, p3;
        int lanes;
        if (left >= 4) {
            p1 = GRID_ITEM_INDEX(items[e + 1]);
            p2 = GRID_ITEM_INDEX(items[e + 2]);
            p3 = GRID_ITEM_INDEX(items[e + 3]);
            lanes = 15;
        } else {
            p1 = left > 1 ? GRID_ITEM_INDEX(items[e + 1]) : p0;
            p2 = left > 2 ? GRID_ITEM_INDEX(items[e + 2]) : p0;
            p3 = p0;
            lanes = (1 << left) - 1;
        }
        int valid = lanes;
        if (mb) {
            /* A list names a primitive at most once, so the four lookups are
             * independent: all read before any stamp is written. */
            __m128i st = _mm_set_epi32((int)mb[p3], (int)mb[p2], (int)mb[p1], (int)mb[p0]);
            int seen = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(st, stamps))) & lanes;
            mb[p0] = stamp;
            mb[p1] = stamp;
            mb[p2] = stamp;
            mb[p3] = stamp;
            seen_cur = 0;
            if (seen) {
                seen_cur = (uint64_t)lanes_count(seen);
                seen_total += seen_cur;
                if (g->marking) {
                    valid &= ~seen;
                    if (!valid)
                        continue;
                }
            }
        }
        __m128 tt;
        int mask = tri4_test(g, p0, p1, p2, p3, rs, &tt) & valid;
        if (any) {
            /* hit_accepts against (tmax, id 0): exactly t < tmax */
            int occ = mask & _mm_movemask_ps(_mm_cmplt_ps(tt, _mm_set1_ps(hit->t)));
            if (occ) {
                /* This group's tests up to and including the occluder; its skips were
                 * counted above, its tested lanes are counted here. */
                int below = (2 << __builtin_ctz((unsigned)occ)) - 1;
                tests_here = (uint64_t)lanes_count(valid & below);
                found = true;
                break;
            }
            continue;
        }
        if (!mask)
            continue;
        float t[4];
        _mm_storeu_ps(t, tt);
        const uint32_t p[4] = {p0, p1, p2, p3};
        do {
            int i = __builtin_ctz((unsigned)mask);
            mask &= mask - 1;
            uint32_t id = g->tri[p[i]].id;
            if (!hit_accepts(hit, t[i], id))
                continue;
            hit->t = t[i];
            hit->normal = g->tri_hit[p[i]].normal;
            hit->material = g->tri_hit[p[i]].material;
            hit->id = id;
            found = true;
        } while (mask);
    }
    /* The tests: every lane of the groups before e less (with marking) their skips;
     * at a shadow query's stop, e is the stopping group's start, whose skips (seen_cur)
     * are in seen_total and whose tests up to the occluder are tests_here. */
    bool stopped = any && found;
    uint64_t skipped = g->marking ? seen_total - (stopped ? seen_cur : 0) : 0;
    ctx->stats.intersections += (stopped ? e : n) - skipped + tests_here;
    if (g->marking)
        ctx->stats.mailbox_skips += seen_total;
    else
        ctx->stats.repeat_tests += seen_total;
    return found;
}
#endif

/* The one cell loop of both queries: tests the entries (cell_items format) not yet
 * tested for this ray, packed triangles four at a time. any (a constant at each call, so each
 * query gets its own copy of the loop): return at the first hit, the shadow query's
 * early exit. */
static inline __attribute__((always_inline)) bool test_items(const Grid *g,
                                                              const uint32_t *items,
                                                              uint32_t n, const Ray *ray,
                                                              Hit *hit, float tmin,
                                                              RenderCtx *ctx, uint32_t *mb,
                                                              uint32_t stamp,
                                                              const void *rsimd, XfMemo *xm,
                                                              bool any)
{
    bool found = false;
#if RT_GRID_SIMD
    const RaySimd *rs = rsimd;
    if (g->all_tri)
        return test_groups(g, items, n, hit, ctx, mb, stamp, rs, any);
    TriBatch batch;
    batch.n = 0;
#else
    (void)rsimd;
#endif
    for (uint32_t e = 0; e < n; e++) {
        uint32_t item = items[e];
        if (!should_test(g, mb, stamp, GRID_ITEM_INDEX(item), ctx))
            continue;
#if RT_GRID_SIMD
        if (item & GRID_ITEM_TRI) {
            batch.p[batch.n++] = GRID_ITEM_INDEX(item);
            if (batch.n == 4) {
                if (any && batch_occluded(g, &batch, rs, hit, ctx))
                    return true; /* the first occluder settles it */
                if (!any)
                    found |= batch_intersect(g, &batch, rs, hit, ctx);
                batch.n = 0;
            }
            continue;
        }
#endif
        found |= test_entry(g, item, ray, hit, tmin, ctx, xm, any);
        if (any && found)
            return true;
    }
#if RT_GRID_SIMD
    for (int i = 0; i < batch.n; i++) { /* the last one to three: scalar */
        found |= test_entry(g, batch.p[i] | GRID_ITEM_TRI, ray, hit, tmin, ctx, xm, any);
        if (any && found)
            return true;
    }
#endif
    return found;
}

/* Cell c's entries (test_items over its run of cell_items). */
static inline __attribute__((always_inline)) bool test_cell(const Grid *g, uint32_t c,
                                                             const Ray *ray, Hit *hit,
                                                             float tmin, RenderCtx *ctx,
                                                             uint32_t *mb, uint32_t stamp,
                                                             const void *rsimd, XfMemo *xm,
                                                             bool any)
{
    uint32_t s0 = g->cell_start[c];
    return test_items(g, g->cell_items + s0, g->cell_start[c + 1] - s0, ray, hit, tmin, ctx,
                      mb, stamp, rsimd, xm, any);
}

static inline __attribute__((always_inline)) int lean_exit_axis(const LeanMarch *m, float *tm_out)
{
    /* lean_next's choice of the axis it failed on (-1: parallel to every axis left) */
    bool y = m->tn1 < m->tn0;
    float tm = y ? m->tn1 : m->tn0;
    bool z = m->tn2 < tm;
    tm = z ? m->tn2 : tm;
    *tm_out = tm;
    if (!(tm < INFINITY))
        return -1;
    return z ? 2 : y ? 1 : 0;
}

/* Whether the band beyond the face crossed on axis a at tm reaches another of m's cells
 * (another axis' next border) no later than limit. */
static inline __attribute__((always_inline)) bool band_reaches(const Grid *g, const LeanMarch *m,
                                                                const Ray *ray, int a, float tm,
                                                                float limit)
{
    float d = a == 0 ? ray->dir.x : a == 1 ? ray->dir.y : ray->dir.z;
    float reach = tm + g->band[a] * fabsf(1.0f / d); /* as lean_next_band holds it */
    float other = a == 0   ? min_nan_last(m->tn1, m->tn2)
                  : a == 1 ? min_nan_last(m->tn0, m->tn2)
                           : min_nan_last(m->tn0, m->tn1);
    return other <= reach && other <= limit;
}

/* After a lean march that ended by leaving the box: whether the band beyond the face it
 * left by (lean_next_band) reaches another cell before limit (the best hit's t, or the
 * shadow ray's tmax). Most rays leave far from any other cell's border, so the walk
 * below is rare; it stays out of the march's loop, whose state fills the registers. */
static inline __attribute__((always_inline)) bool band_needed(const Grid *g, const LeanMarch *m,
                                                               const Ray *ray, float limit)
{
    float tm;
    int a = lean_exit_axis(m, &tm);
    return a >= 0 && band_reaches(g, m, ray, a, tm, limit);
}

/* The cells the ray enters in that band, in order (lean_next_band from where the march
 * stopped), tested like the march's, with the counts left as they were. */
static __attribute__((noinline, cold)) bool band_walk(const Grid *g, LeanMarch at,
                                                      const Ray *ray, Hit *hit, float tmin,
                                                      RenderCtx *ctx, uint32_t *mb,
                                                      uint32_t stamp, const void *rsimd,
                                                      XfMemo *xm, bool any)
{
    /* A copy: the march's own state stays in registers (its address is never taken). */
    LeanMarch *m = &at;
    const float inv[3] = {1.0f / ray->dir.x, 1.0f / ray->dir.y, 1.0f / ray->dir.z};
    m->p0 = g->band[0] * fabsf(inv[0]);
    m->p1 = g->band[1] * fabsf(inv[1]);
    m->p2 = g->band[2] * fabsf(inv[2]);
    m->held = 0;
    LeanBand band = {false, 0, 0, 0};
    band_note(true, &band, ctx);
    bool found = false;
    const uint64_t *occ = g->occupied;
    while (lean_next_band(m, true)) {
        if (m->t > hit->t)
            break;
        if (cell_occupied_in(occ, m->c) &&
            test_cell(g, m->c, ray, hit, tmin, ctx, mb, stamp, rsimd, xm, any)) {
            found = true;
            if (any)
                break;
        }
        if (!any && hit->t <= lean_exit_t(m))
            break;
    }
    band_restore(&band, ctx);
    return found;
}

/* Everything of grid_intersect after the unbounded primitives: the march (or the
 * brute-force loop for rays too far out), updating hit. */
static inline __attribute__((always_inline)) bool march_intersect(const Grid *g,
                                                                  const Ray *ray, Hit *hit,
                                                                  float tmin, RenderCtx *ctx)
{
    bool found = false;
    float tmarch;
    if (!march_start(g, ray, tmin, &tmarch))
        return brute_intersect(g, ray, hit, tmin, ctx);
    uint32_t stamp, *mb;
    MARCH_RAY_SIMD(rsimd, ray, tmin);
    XfMemo xm = {NULL, {{0, 0, 0}, {0, 0, 0}}, 0.0f};
    if (!ctx->tree) { /* the loop below, in registers */
        LeanMarch m;
        if (!cast_lean_init(g, ray, tmarch, ctx, &m))
            return false;
        stamp = march_stamp(g, ctx, &mb);
        const uint64_t *occ = g->occupied;
        do {
            if (m.t > hit->t)
                break;
            if (cell_occupied_in(occ, m.c))
                found |= test_cell(g, m.c, ray, hit, tmin, ctx, mb, stamp, rsimd, &xm, false);
            if (hit->t <= lean_exit_t(&m))
                break;
        } while (lean_next(&m));
        ctx->stats.cells_traversed += lean_cells(&m);
        /* Ended by leaving the box (neither break holds): the band beyond its face. */
        if (hit->t > lean_exit_t(&m) && band_needed(g, &m, ray, hit->t))
            found |= band_walk(g, m, ray, hit, tmin, ctx, mb, stamp, rsimd, &xm, false);
        return found;
    }
    MarchingInfo mi;
    if (!march_init(&mi, &g->box, g->n, g->pad, ray, tmarch, ctx))
        return false;
    stamp = march_stamp(g, ctx, &mb);
    LeanBand band = {false, 0, 0, 0};
    do {
        band_note(mi.held != 0, &band, ctx);
        /* 4. The cell starts beyond the best hit: nothing in it or later is nearer. */
        if (mi.t > hit->t)
            break;
        uint32_t c = grid_cell_index(g, mi.cell[0], mi.cell[1], mi.cell[2]);
        found |= test_cell(g, c, ray, hit, tmin, ctx, mb, stamp, rsimd, &xm, false);
        /* 3. A hit inside this cell or an earlier one is final: every primitive that
         * could be hit sooner lies in a cell already tested (cells are padded, so this
         * holds up to float rounding at borders). A hit beyond it stays a candidate. */
        if (hit->t <= march_exit_t(&mi))
            break;
    } while (march_next_band(&mi, ctx));
    band_restore(&band, ctx);
    return found;
}

/* The march and cell loop compiled a second time for AVX2 CPUs (this file's baseline is
 * SSE2). The code is the same C: the same 4-lane SSE operations and scalar float
 * operations in the same order, without FMA (no fma target, so nothing is contracted),
 * hence the same bits; the AVX encoding's three-operand forms drop most of the
 * register copies the two-operand SSE forms need (line 07 with -stats: see
 * bench/REPORT.txt, line22). grid_cast_path_set(0) (tests) keeps the baseline copy. */
static int cast_path_cap = 1;

void grid_cast_path_set(int cap) { cast_path_cap = cap; }

#if defined(RT_CPU_X86) && RT_GRID_SIMD
#define RT_CAST_AVX2 1
__attribute__((target("avx2"))) static bool march_intersect_avx2(const Grid *g,
                                                                 const Ray *ray, Hit *hit,
                                                                 float tmin, RenderCtx *ctx)
{
    return march_intersect(g, ray, hit, tmin, ctx);
}
#else
#define RT_CAST_AVX2 0
#endif

static inline bool cast_avx2(void) { return RT_CAST_AVX2 && cast_path_cap >= 1 && cpu_has_avx2(); }

/* march_intersect in the copy for this CPU. */
static inline __attribute__((always_inline)) bool march_intersect_isa(const Grid *g,
                                                                      const Ray *ray,
                                                                      Hit *hit, float tmin,
                                                                      RenderCtx *ctx)
{
#if RT_CAST_AVX2
    if (cast_avx2())
        return march_intersect_avx2(g, ray, hit, tmin, ctx);
#endif
    return march_intersect(g, ray, hit, tmin, ctx);
}

bool grid_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin, RenderCtx *ctx)
{
    bool found = false;
    /* 1. Infinite primitives first: their hit bounds the march (early rejection). */
    for (uint32_t u = 0; u < g->num_unbounded; u++)
        found |= grid_test_prim(&g->unbounded[u], ray, hit, tmin, ctx);
    return march_intersect_isa(g, ray, hit, tmin, ctx) || found;
}

bool grid_march_intersect(const Grid *g, const Ray *ray, Hit *hit, float tmin, RenderCtx *ctx)
{
    return march_intersect_isa(g, ray, hit, tmin, ctx);
}

/* The shadow query: the same march and cell loop, stopping at the first occluder
 * (hp->t = tmax, id 0: hit_accepts takes exactly the hits with t < tmax). */
static inline __attribute__((always_inline)) bool march_occluded(const Grid *g,
                                                                  const Ray *ray, Hit *hp,
                                                                  float tmin, float tmax,
                                                                  RenderCtx *ctx)
{
    Hit h = *hp;
    float tmarch;
    if (!march_start(g, ray, tmin, &tmarch))
        return brute_occluded(g, ray, tmin, tmax, ctx);
    uint32_t stamp, *mb;
    MARCH_RAY_SIMD(rsimd, ray, tmin);
    XfMemo xm = {NULL, {{0, 0, 0}, {0, 0, 0}}, 0.0f};
    if (!ctx->tree) { /* the loop below, in registers */
        LeanMarch m;
        if (!cast_lean_init(g, ray, tmarch, ctx, &m))
            return false;
        stamp = march_stamp(g, ctx, &mb);
        bool occluded = false;
        const uint64_t *occ = g->occupied;
        do {
            if (m.t > tmax)
                break;
            if (cell_occupied_in(occ, m.c) &&
                test_cell(g, m.c, ray, &h, tmin, ctx, mb, stamp, rsimd, &xm, true)) {
                occluded = true; /* the first occluder settles it */
                break;
            }
        } while (lean_next(&m));
        ctx->stats.cells_traversed += lean_cells(&m);
        if (!occluded && m.t <= tmax && band_needed(g, &m, ray, tmax))
            occluded = band_walk(g, m, ray, &h, tmin, ctx, mb, stamp, rsimd, &xm, true);
        return occluded;
    }
    MarchingInfo mi;
    if (!march_init(&mi, &g->box, g->n, g->pad, ray, tmarch, ctx))
        return false;
    stamp = march_stamp(g, ctx, &mb);
    LeanBand band = {false, 0, 0, 0};
    bool occluded = false;
    do {
        band_note(mi.held != 0, &band, ctx);
        if (mi.t > tmax)
            break;
        uint32_t c = grid_cell_index(g, mi.cell[0], mi.cell[1], mi.cell[2]);
        if (test_cell(g, c, ray, &h, tmin, ctx, mb, stamp, rsimd, &xm, true)) {
            occluded = true; /* the first occluder settles it */
            break;
        }
    } while (march_next_band(&mi, ctx));
    band_restore(&band, ctx);
    return occluded;
}

#if RT_CAST_AVX2
__attribute__((target("avx2"))) static bool march_occluded_avx2(const Grid *g,
                                                                const Ray *ray, Hit *hp,
                                                                float tmin, float tmax,
                                                                RenderCtx *ctx)
{
    return march_occluded(g, ray, hp, tmin, tmax, ctx);
}
#endif

/* march_occluded in the copy for this CPU. */
static inline __attribute__((always_inline)) bool march_occluded_isa(const Grid *g,
                                                                     const Ray *ray, Hit *hp,
                                                                     float tmin, float tmax,
                                                                     RenderCtx *ctx)
{
#if RT_CAST_AVX2
    if (cast_avx2())
        return march_occluded_avx2(g, ray, hp, tmin, tmax, ctx);
#endif
    return march_occluded(g, ray, hp, tmin, tmax, ctx);
}

bool grid_occluded(const Grid *g, const Ray *ray, float tmin, float tmax, RenderCtx *ctx)
{
    /* hit_accepts with t = tmax and id 0 takes exactly the hits with t < tmax. */
    Hit h = hit_none();
    h.t = tmax;
    h.id = 0;
    for (uint32_t u = 0; u < g->num_unbounded; u++)
        if (grid_occluded_prim(&g->unbounded[u], ray, tmin, tmax, ctx))
            return true;
    return march_occluded_isa(g, ray, &h, tmin, tmax, ctx);
}

bool grid_march_occluded(const Grid *g, const Ray *ray, float tmin, float tmax, RenderCtx *ctx)
{
    Hit h = hit_none();
    h.t = tmax;
    h.id = 0;
    return march_occluded_isa(g, ray, &h, tmin, tmax, ctx);
}

/* ---- entries of a list, for accelerators built on the grid's entries (twolevel.c) ---- */

bool grid_items_intersect(const Grid *g, const uint32_t *items, uint32_t n, const Ray *ray,
                          Hit *hit, float tmin, uint32_t *mb, uint32_t stamp, RenderCtx *ctx)
{
    if (n == 0)
        return false;
    MARCH_RAY_SIMD(rsimd, ray, tmin);
    XfMemo xm = {NULL, {{0, 0, 0}, {0, 0, 0}}, 0.0f};
    return test_items(g, items, n, ray, hit, tmin, ctx, mb, stamp, rsimd, &xm, false);
}

bool grid_items_occluded(const Grid *g, const uint32_t *items, uint32_t n, const Ray *ray,
                         Hit *h, float tmin, uint32_t *mb, uint32_t stamp, RenderCtx *ctx)
{
    if (n == 0)
        return false;
    MARCH_RAY_SIMD(rsimd, ray, tmin);
    XfMemo xm = {NULL, {{0, 0, 0}, {0, 0, 0}}, 0.0f};
    return test_items(g, items, n, ray, h, tmin, ctx, mb, stamp, rsimd, &xm, true);
}

float grid_march_error(const Grid *g, const Ray *ray) { return march_error(g, ray); }

/* ---- the two-level grid's walk (twolevel.c builds it; twolevel_internal.h) ---- */

/* Beyond the scene box's faces (docs/grid.md and docs/twolevel.md, "Beyond the box's
 * faces"). The top march ends at the box as the uniform grid's did: tl_walk then walks
 * the band beyond the face with band_walk (the top cells' whole lists). A leaf grid
 * tiles its primitives' boxes (widened by the triangle test's tolerance, tri_tolerance in
 * twolevel.c) clipped to its top cell, so where that cell lies on a face of the box, the
 * clipping cuts off the band beyond the face where the triangle test still accepts hits,
 * and the leaf march ends at the face too. (Inside the box, a point beyond a leaf grid's
 * face lies in another top cell, whose list or leaf grid holds those primitives.)
 * leaf_band: after a leaf march that left its grid, with last the axes along which its
 * top cell is the last the ray meets (the top march's steps left are 0): when it left
 * along one of them and the band beyond that face (the top grid's band width, as
 * band_walk's) reaches another leaf cell before the best hit, the leaf cells in that band
 * are walked, with the counts left as they were and without marking (the walk goes on
 * after it, and a primitive marked here would be skipped there, changing its counts).
 * Out of the walk's loop: most calls are rays leaving a border cell's leaf grid, and
 * return at the test. */
static __attribute__((noinline, cold)) bool leaf_band(const TwoLevelGrid *t, unsigned last,
                                                      LeanMarch at, const Ray *ray, Hit *hit,
                                                      float tmin, RenderCtx *ctx,
                                                      const void *rsimd, XfMemo *xm, bool any)
{
    const Grid *g = t->top;
    LeanMarch *m = &at;
    float tm;
    int a = lean_exit_axis(m, &tm);
    if (a < 0 || !(last & (1u << a)) || !band_reaches(g, m, ray, a, tm, hit->t))
        return false;
    const float inv[3] = {1.0f / ray->dir.x, 1.0f / ray->dir.y, 1.0f / ray->dir.z};
    m->p0 = g->band[0] * fabsf(inv[0]);
    m->p1 = g->band[1] * fabsf(inv[1]);
    m->p2 = g->band[2] * fabsf(inv[2]);
    m->held = 0;
    LeanBand band = {false, 0, 0, 0};
    band_note(true, &band, ctx);
    bool found = false;
    while (lean_next_band(m, true)) {
        if (m->t > hit->t)
            break;
        uint32_t s0 = t->start[m->c], nl = t->start[m->c + 1] - s0;
        if (nl && test_items(g, t->items + s0, nl, ray, hit, tmin, ctx, NULL, 0, rsimd, xm,
                             any)) {
            found = true;
            if (any)
                break;
        }
        if (!any && hit->t <= lean_exit_t(m))
            break;
    }
    band_restore(&band, ctx);
    return found;
}

/* Why the leaf march may stop the whole walk when the best hit lies within the current
 * leaf cell: every point of the ray before it lies in a top cell already walked, or in
 * this top cell, where the only primitives to hit (this cell's entries) lie in the
 * leaf grid's box and so in a leaf cell already walked (cells padded against rounding,
 * as the course grid's), or among its large entries, all tested on entering the cell. A top cell whose leaf grid
 * the ray misses holds nothing it can hit there. Rays too far out to march the leaf grid exactly test the cell's whole
 * list instead. */
/* The walk without a ray tree: the top grid's march and each leaf grid's, as
 * lean_init and LeanMarch (the same cells and t's as march_init and march_next),
 * with the cell loop inlined and the ray's reciprocals, SIMD broadcast and counters
 * made once per ray. Counts as tl_tree_*: the top cells entered, every leaf cell
 * entered (the one that stops the leaf march included), and test_items' tests. any:
 * the shadow query (hit = (tmax, id 0), true at the first occluder, no early stop at a
 * hit). */
static inline __attribute__((always_inline)) bool tl_walk(const TwoLevelGrid *t,
                                                           const Ray *ray, Hit *hit,
                                                           float tmin, float tmarch,
                                                           RenderCtx *ctx, bool any)
{
    const Grid *g = t->top;
    const float lo[3] = {g->box.min.x, g->box.min.y, g->box.min.z};
    LeanRay lr;
    lean_ray(ray, &lr);
    LeanMarch m;
    if (!lean_init(lo, g->slab_lo, g->slab_hi, g->inv_size, g->size, g->n, 0, &lr, tmarch, &m))
        return false;
    uint32_t stamp = grid_begin_ray(g, ctx);
    uint32_t *mb = stamp ? ctx->mailbox : NULL;
    float err = march_error(g, ray);
    MARCH_RAY_SIMD(rsimd, ray, tmin);
    XfMemo xm = {NULL, {{0, 0, 0}, {0, 0, 0}}, 0.0f};
    uint64_t cells = 1; /* the first top cell; the rest are lean_cells(&m) */
    bool found = false, left = false;
    for (;;) {
        if (m.t > hit->t)
            break;
        /* Empty top cells (most of what a ray crosses in a sparse scene) are passed on
         * their occupancy bit alone: a cell with a leaf grid holds entries. */
        uint32_t c = m.c, s;
        if (!cell_occupied(g, c)) {
            /* nothing to test */
        } else if ((s = t->sub_of[c]) == TWOLEVEL_NO_SUB || !(err < t->subs[s].min_pad)) {
            if (test_cell(g, c, ray, hit, tmin, ctx, mb, stamp, rsimd, &xm, any)) {
                found = true;
                if (any)
                    break;
            }
        } else {
            const SubGrid *sg = &t->subs[s];
            if (test_items(g, t->items + sg->big_start, sg->big_count, ray, hit, tmin, ctx, mb,
                           stamp, rsimd, &xm, any)) {
                found = true;
                if (any)
                    break;
            }
            const float slo[3] = {sg->box.min.x, sg->box.min.y, sg->box.min.z};
            LeanMarch l;
            if (lean_init(slo, sg->slab_lo, sg->slab_hi, sg->inv_size, sg->size, sg->n, sg->base,
                          &lr, tmarch, &l)) {
                bool stop = false;
                for (;;) {
                    cells++;
                    if (l.t > hit->t)
                        break;
                    uint32_t s0 = t->start[l.c], nl = t->start[l.c + 1] - s0;
                    if (nl && test_items(g, t->items + s0, nl, ray, hit, tmin, ctx, mb, stamp,
                                         rsimd, &xm, any)) {
                        found = true;
                        if (any) {
                            stop = true;
                            break;
                        }
                    }
                    if (!any && hit->t <= lean_exit_t(&l)) {
                        stop = true;
                        break;
                    }
                    if (!lean_next(&l)) {
                        /* Left the leaf grid: in a top cell that is the last the ray
                         * meets along some axis, the band beyond that face of the box
                         * (leaf_band; here only the cheap test, in registers). */
                        unsigned last = (unsigned)(m.left0 == 0) | (unsigned)(m.left1 == 0) << 1 |
                                        (unsigned)(m.left2 == 0) << 2;
                        if (__builtin_expect(last != 0, 0) &&
                            leaf_band(t, last, l, ray, hit, tmin, ctx, rsimd, &xm, any)) {
                            found = true;
                            stop = any;
                        }
                        break;
                    }
                }
                if (stop)
                    break;
            }
        }
        if (!any && hit->t <= lean_exit_t(&m))
            break;
        if (!lean_next(&m)) {
            left = true;
            break;
        }
    }
    ctx->stats.cells_traversed += cells + lean_cells(&m);
    /* Ended by leaving the box: the band beyond its face, as march_intersect's (the
     * cells' whole lists, which their padding makes hold the band's primitives). */
    if (left && band_needed(g, &m, ray, hit->t))
        found |= band_walk(g, m, ray, hit, tmin, ctx, mb, stamp, rsimd, &xm, any);
    return found;
}

/* With a ray tree: the same walk by march_init and march_next, which record the top
 * cells in it. */
static inline uint32_t leaf_cell(const SubGrid *sg, const MarchingInfo *sm)
{
    return sg->base + ((uint32_t)sm->cell[2] * (uint32_t)sg->n[1] + (uint32_t)sm->cell[1]) *
                          (uint32_t)sg->n[0] + (uint32_t)sm->cell[0];
}

/* leaf_band for the ray-tree walk's leaf march sm, which march_next has just ended
 * (top: the top march, in the leaf grid's top cell): the same choice of axis, the same
 * test and the same cells (march_next_band with the top grid's band widths), nothing
 * counted or recorded, nothing marked. any: the shadow query (hit = (tmax, id 0)). */
static bool tl_tree_leaf_band(const TwoLevelGrid *t, const SubGrid *sg, const MarchingInfo *top,
                              MarchingInfo sm, const Ray *ray, Hit *hit, float tmin,
                              RenderCtx *ctx, bool any)
{
    const Grid *g = t->top;
    int a = 0;
    if (sm.t_next[1] < sm.t_next[a])
        a = 1;
    if (sm.t_next[2] < sm.t_next[a])
        a = 2;
    float tm = sm.t_next[a];
    int c = top->cell[a] + top->step[a];
    if (!(tm < INFINITY) || (c >= 0 && c < top->n[a]))
        return false;
    const float d[3] = {ray->dir.x, ray->dir.y, ray->dir.z};
    float reach = tm + g->band[a] * fabsf(1.0f / d[a]);
    float other = a == 0 ? min_nan_last(sm.t_next[1], sm.t_next[2])
                  : a == 1 ? min_nan_last(sm.t_next[0], sm.t_next[2])
                           : min_nan_last(sm.t_next[0], sm.t_next[1]);
    if (!(other <= reach && other <= hit->t))
        return false;
    for (int k = 0; k < 3; k++)
        sm.band_t[k] = g->band[k] * fabsf(1.0f / d[k]);
    sm.held = 0;
    LeanBand band = {false, 0, 0, 0};
    band_note(true, &band, ctx);
    bool found = false;
    while (march_next_band(&sm, NULL)) {
        if (sm.t > hit->t)
            break;
        uint32_t lc = leaf_cell(sg, &sm);
        const uint32_t *items = t->items + t->start[lc];
        uint32_t n = t->start[lc + 1] - t->start[lc];
        if (any ? grid_items_occluded(g, items, n, ray, hit, tmin, NULL, 0, ctx)
                : grid_items_intersect(g, items, n, ray, hit, tmin, NULL, 0, ctx)) {
            found = true;
            if (any)
                break;
        }
        if (!any && hit->t <= march_exit_t(&sm))
            break;
    }
    band_restore(&band, ctx);
    return found;
}

static bool tl_tree_intersect(const TwoLevelGrid *t, const Ray *ray, Hit *hit, float tmin,
                              float tmarch, RenderCtx *ctx)
{
    const Grid *g = t->top;
    bool found = false;
    MarchingInfo mi;
    if (!march_init(&mi, &g->box, g->n, g->pad, ray, tmarch, ctx))
        return found;
    uint32_t stamp = grid_begin_ray(g, ctx);
    uint32_t *mb = stamp ? ctx->mailbox : NULL;
    float err = grid_march_error(g, ray);
    LeanBand band = {false, 0, 0, 0};
    do {
        /* Beyond the box's face (march_next_band; uncounted): the cell's whole list,
         * as tl_walk's band_walk. */
        band_note(mi.held != 0, &band, ctx);
        if (mi.t > hit->t)
            break;
        uint32_t c = grid_cell_index(g, mi.cell[0], mi.cell[1], mi.cell[2]);
        uint32_t s = t->sub_of[c];
        if (s == TWOLEVEL_NO_SUB || !(err < t->subs[s].min_pad) || mi.held) {
            found |= grid_items_intersect(g, g->cell_items + g->cell_start[c],
                                          g->cell_start[c + 1] - g->cell_start[c], ray, hit,
                                          tmin, mb, stamp, ctx);
        } else {
            const SubGrid *sg = &t->subs[s];
            found |= grid_items_intersect(g, t->items + sg->big_start, sg->big_count, ray, hit,
                                          tmin, mb, stamp, ctx);
            MarchingInfo sm;
            if (march_init(&sm, &sg->box, sg->n, sg->pad, ray, tmarch, NULL)) {
                do {
                    ctx->stats.cells_traversed++;
                    if (sm.t > hit->t)
                        break;
                    uint32_t lc = leaf_cell(sg, &sm);
                    found |= grid_items_intersect(g, t->items + t->start[lc],
                                                  t->start[lc + 1] - t->start[lc], ray, hit,
                                                  tmin, mb, stamp, ctx);
                    if (hit->t <= march_exit_t(&sm))
                        return found; /* never in the band: held cells take the list */
                    if (!march_next(&sm, NULL)) {
                        found |= tl_tree_leaf_band(t, sg, &mi, sm, ray, hit, tmin, ctx, false);
                        break;
                    }
                } while (true);
            }
        }
        if (hit->t <= march_exit_t(&mi))
            break;
    } while (march_next_band(&mi, ctx));
    band_restore(&band, ctx);
    return found;
}

static bool tl_tree_occluded(const TwoLevelGrid *t, const Ray *ray, float tmin, float tmax,
                             float tmarch, RenderCtx *ctx)
{
    const Grid *g = t->top;
    Hit h = hit_none();
    h.t = tmax;
    h.id = 0;
    MarchingInfo mi;
    if (!march_init(&mi, &g->box, g->n, g->pad, ray, tmarch, ctx))
        return false;
    uint32_t stamp = grid_begin_ray(g, ctx);
    uint32_t *mb = stamp ? ctx->mailbox : NULL;
    float err = grid_march_error(g, ray);
    LeanBand band = {false, 0, 0, 0};
    bool occluded = false;
    do {
        band_note(mi.held != 0, &band, ctx);
        if (mi.t > tmax)
            break;
        uint32_t c = grid_cell_index(g, mi.cell[0], mi.cell[1], mi.cell[2]);
        uint32_t s = t->sub_of[c];
        if (s == TWOLEVEL_NO_SUB || !(err < t->subs[s].min_pad) || mi.held) {
            if (grid_items_occluded(g, g->cell_items + g->cell_start[c],
                                    g->cell_start[c + 1] - g->cell_start[c], ray, &h, tmin, mb,
                                    stamp, ctx)) {
                occluded = true;
                break;
            }
        } else {
            const SubGrid *sg = &t->subs[s];
            if (grid_items_occluded(g, t->items + sg->big_start, sg->big_count, ray, &h, tmin,
                                    mb, stamp, ctx))
                return true; /* before any band: nothing to restore */
            MarchingInfo sm;
            if (march_init(&sm, &sg->box, sg->n, sg->pad, ray, tmarch, NULL)) {
                do {
                    ctx->stats.cells_traversed++;
                    if (sm.t > tmax)
                        break;
                    uint32_t lc = leaf_cell(sg, &sm);
                    if (grid_items_occluded(g, t->items + t->start[lc],
                                            t->start[lc + 1] - t->start[lc], ray, &h, tmin, mb,
                                            stamp, ctx))
                        return true;
                    if (!march_next(&sm, NULL)) {
                        if (tl_tree_leaf_band(t, sg, &mi, sm, ray, &h, tmin, ctx, true))
                            return true;
                        break;
                    }
                } while (true);
            }
        }
    } while (march_next_band(&mi, ctx));
    band_restore(&band, ctx);
    return occluded;
}

/* The walk compiled a second time for AVX2 CPUs, as march_intersect_avx2 and
 * march_occluded_avx2 are: the same C without an FMA target, so the same bits and
 * counts; the VEX three-operand forms drop the SSE forms' register copies.
 * grid_cast_path_set(0) (tests) keeps the baseline copy. */
#if RT_CAST_AVX2
__attribute__((target("avx2"))) static bool tl_walk_intersect_avx2(const TwoLevelGrid *t,
                                                                   const Ray *ray, Hit *hit,
                                                                   float tmin, float tmarch,
                                                                   RenderCtx *ctx)
{
    return tl_walk(t, ray, hit, tmin, tmarch, ctx, false);
}

__attribute__((target("avx2"))) static bool tl_walk_occluded_avx2(const TwoLevelGrid *t,
                                                                  const Ray *ray, Hit *hit,
                                                                  float tmin, float tmarch,
                                                                  RenderCtx *ctx)
{
    return tl_walk(t, ray, hit, tmin, tmarch, ctx, true);
}
#endif

/* tl_walk in the copy for this CPU (any: a constant at each call). */
static inline __attribute__((always_inline)) bool tl_walk_isa(const TwoLevelGrid *t,
                                                               const Ray *ray, Hit *hit,
                                                               float tmin, float tmarch,
                                                               RenderCtx *ctx, bool any)
{
#if RT_CAST_AVX2
    if (cast_avx2())
        return any ? tl_walk_occluded_avx2(t, ray, hit, tmin, tmarch, ctx)
                   : tl_walk_intersect_avx2(t, ray, hit, tmin, tmarch, ctx);
#endif
    return tl_walk(t, ray, hit, tmin, tmarch, ctx, any);
}

bool twolevel_intersect(const TwoLevelGrid *t, const Ray *ray, Hit *hit, float tmin,
                        RenderCtx *ctx)
{
    const Grid *g = t->top;
    bool found = false;
    for (uint32_t u = 0; u < g->num_unbounded; u++)
        found |= grid_test_prim(&g->unbounded[u], ray, hit, tmin, ctx);
    float tmarch = grid_march_tmin(g, tmin);
    if (grid_ray_too_far(g, ray, tmarch))
        return grid_march_intersect(g, ray, hit, tmin, ctx) || found;
    if (ctx->tree)
        return tl_tree_intersect(t, ray, hit, tmin, tmarch, ctx) || found;
    return tl_walk_isa(t, ray, hit, tmin, tmarch, ctx, false) || found;
}

bool twolevel_occluded(const TwoLevelGrid *t, const Ray *ray, float tmin, float tmax,
                       RenderCtx *ctx)
{
    const Grid *g = t->top;
    for (uint32_t u = 0; u < g->num_unbounded; u++)
        if (grid_occluded_prim(&g->unbounded[u], ray, tmin, tmax, ctx))
            return true;
    float tmarch = grid_march_tmin(g, tmin);
    if (grid_ray_too_far(g, ray, tmarch))
        return grid_march_occluded(g, ray, tmin, tmax, ctx);
    if (ctx->tree)
        return tl_tree_occluded(t, ray, tmin, tmax, tmarch, ctx);
    /* hit_accepts with t = tmax and id 0 takes exactly the hits with t < tmax. */
    Hit h = hit_none();
    h.t = tmax;
    h.id = 0;
    return tl_walk_isa(t, ray, &h, tmin, tmarch, ctx, true);
}
