/* The accelerator "grid": the course's uniform grid (rt/grid.h) behind AccelOps, and its
 * visualisation (-visualize_grid), which draws the occupied cells instead of the scene. */
#include "grid_internal.h"
#include "rt/accel.h"
#include "rt/grid.h"

/* The key of the grid cfg asks for over t: the scene's inputs (which make the table)
 * and the options and layouts the build depends on. */
static SetupKey grid_key(const PrimTable *t, const AccelConfig *cfg)
{
    uint64_t what[9] = {SETUP_TAG_GRID, cfg->grid_auto, (uint64_t)cfg->grid_n[0],
                        (uint64_t)cfg->grid_n[1], (uint64_t)cfg->grid_n[2], t->num_prims,
                        t->num_bounded, sizeof(PackedTri) << 16 | sizeof(TriBox),
                        sizeof(GridPrim)};
    if (cfg->grid_auto)
        what[2] = what[3] = what[4] = 0;
    return setup_hash(what, sizeof what, cfg->inputs);
}

static void *grid_create(const PrimTable *t, const AccelConfig *cfg, Diag *diag)
{
    int n[3] = {cfg->grid_n[0], cfg->grid_n[1], cfg->grid_n[2]};
    Grid *g = NULL;
    /* -cache: the grid of an earlier process of the same split render (grid_cache.c). */
    bool cacheable = cfg->cache && t->num_bounded > 0 && !bbox_is_empty(&t->scene_bounds);
    SetupKey key = {0, 0};
    if (cacheable) {
        key = grid_key(t, cfg);
        g = grid_cache_load(t, cfg->cache, key, diag);
    }
    if (!g) {
        if (cfg->grid_auto) {
            grid_choose_auto(t, n); /* fitted to grid_ref_cap_auto */
            g = grid_build_table_fitted(t, n, diag);
        } else {
            g = grid_build_table(t, n[0], n[1], n[2], diag);
        }
        if (g && cacheable)
            grid_cache_store(g, t, cfg->cache, key, n);
    }
    if (g)
        grid_set_marking(g, !cfg->no_marking);
    return g;
}

static void grid_destroy(void *self) { grid_free(self); }

static bool grid_accel_intersect(const void *self, const Ray *ray, Hit *hit, float tmin,
                                 RenderCtx *ctx)
{
    return grid_intersect(self, ray, hit, tmin, ctx);
}

static bool grid_accel_occluded(const void *self, const Ray *ray, float tmin, float tmax,
                                RenderCtx *ctx)
{
    return grid_occluded(self, ray, tmin, tmax, ctx);
}

static uint64_t grid_accel_intersect_packet(const void *self, const Ray *rays, int n,
                                            Hit *hits, float tmin, RenderCtx *ctx)
{
    return grid_intersect_packet(self, rays, n, hits, tmin, ctx);
}

static uint64_t grid_accel_occluded_packet(const void *self, const Ray *rays, uint64_t mask,
                                           float tmin, const float *tmax, RenderCtx *ctx)
{
    return grid_occluded_packet(self, rays, mask, tmin, tmax, ctx);
}

static uint64_t grid_accel_occluded_packet_dir(const void *self, const Ray *rays,
                                               uint64_t mask, float tmin, float tmax,
                                               Vec3 dir, RenderCtx *ctx)
{
    return grid_occluded_packet_dir(self, rays, mask, tmin, tmax, dir, ctx);
}

static uint32_t grid_accel_scratch(const void *self) { return grid_mailbox_size(self); }

/* The course's statistics print the grid's resolution (its box is the scene's). */
static void grid_accel_report(const void *self, StatsReport *r)
{
    int n[3];
    grid_dims(self, n);
    r->nx = n[0];
    r->ny = n[1];
    r->nz = n[2];
}

static bool grid_cells_intersect(const void *self, const Ray *ray, Hit *hit, float tmin,
                                 RenderCtx *ctx)
{
    return grid_visualize_intersect(self, ray, hit, tmin, ctx);
}

static bool grid_cells_occluded(const void *self, const Ray *ray, float tmin, float tmax,
                                RenderCtx *ctx)
{
    return grid_visualize_occluded(self, ray, tmin, tmax, ctx);
}

static const AccelOps grid_cells_ops =
    GRID_CELLS_OPS("grid", "the grid's occupied cells, coloured by count (-visualize_grid)",
                   grid_create, grid_destroy, grid_cells_intersect, grid_cells_occluded,
                   grid_accel_scratch, grid_accel_report);

const AccelOps accel_grid_ops = {
    .name = "grid",
    .summary = "uniform grid (-grid nx ny nz or -grid auto)",
    .create = grid_create,
    .destroy = grid_destroy,
    .intersect = grid_accel_intersect,
    .occluded = grid_accel_occluded,
    .intersect_packet = grid_accel_intersect_packet,
    .occluded_packet = grid_accel_occluded_packet,
    .occluded_packet_dir = grid_accel_occluded_packet_dir,
    .scratch_size = grid_accel_scratch,
    .report = grid_accel_report,
    .visualize = &grid_cells_ops,
};

Accel grid_as_accel(Grid *g)
{
    Accel a = {&accel_grid_ops, g};
    return a;
}

const Grid *grid_of_accel(const Accel *a)
{
    return a && (a->ops == &accel_grid_ops || a->ops == &grid_cells_ops) ? a->self : NULL;
}
