/* Accelerators: one interface (AccelOps) in front of every way of finding the nearest hit
 * among the primitive table's leaves, looked up by name the way SQLite finds a VFS.
 * "none" tests every primitive (the course's RayCast); "grid" is the course's uniform
 * grid (RayCastFast). Every accelerator returns exactly the hit of "none" (same t,
 * normal, material, id; property test tests/unit/test_accel_property.c); only the
 * statistics counters differ. Built once, then read-only (shared by the threads); all
 * per-ray state lives in the thread's RenderCtx. */
#ifndef RT_ACCEL_H
#define RT_ACCEL_H

#include <stdbool.h>
#include <stdint.h>
#include "rt/diag.h"
#include "rt/prim.h"
#include "rt/setup_cache.h"
#include "rt/stats.h"

/* Most rays one packet query takes (a RENDER_TILE x RENDER_TILE tile). */
#define ACCEL_PACKET_MAX 64

/* What the user asked for (options); each accelerator reads what it knows. */
typedef struct AccelConfig {
    int grid_n[3];       /* grid resolution; ignored when grid_auto */
    bool grid_auto;      /* grid: resolution chosen from the scene (grid_choose_auto) */
    bool no_marking;     /* grid: no mailboxing (-no_marking, analysis) */
    bool visualize;      /* draw the structure instead of the scene (-visualize_grid) */
    SetupCache *cache;   /* -cache: where a built structure may be found or kept (NULL:
                            none; only the uniform grid uses it) */
    SetupKey inputs;     /* with cache: Scene.inputs, the key of the table's contents */
} AccelConfig;

typedef struct AccelOps {
    const char *name;      /* what -accel takes: "none", "grid" */
    const char *summary;   /* one line for -h */
    /* Builds over t (borrowed: it must outlive the accelerator). Returns the
     * accelerator's state, or NULL: with an error reported to diag when it failed, or
     * WITHOUT one when this accelerator has nothing to hold (the caller then falls back
     * to "none"). */
    void *(*create)(const PrimTable *t, const AccelConfig *cfg, Diag *diag);
    void (*destroy)(void *self);
    /* Nearest hit with t > tmin that hit_accepts (hit is in/out, as in obj_intersect).
     * Counts intersections (and cells) in ctx->stats. */
    bool (*intersect)(const void *self, const Ray *ray, Hit *hit, float tmin,
                      RenderCtx *ctx);
    /* Is anything hit with tmin < t < tmax? May stop at the first occluder. */
    bool (*occluded)(const void *self, const Ray *ray, float tmin, float tmax,
                     RenderCtx *ctx);
    /* Packets (NULL: none; the renderer then goes ray by ray). For every i < n (n <=
     * ACCEL_PACKET_MAX), like intersect(self, &rays[i], &hits[i], tmin, ctx); returns the
     * mask of rays that found a hit. Without ctx->packet_rays they go ray by ray. */
    uint64_t (*intersect_packet)(const void *self, const Ray *rays, int n, Hit *hits,
                                 float tmin, RenderCtx *ctx);
    /* For the rays of mask: bit i is occluded(self, &rays[i], tmin, tmax[i], ctx). */
    uint64_t (*occluded_packet)(const void *self, const Ray *rays, uint64_t mask, float tmin,
                                const float *tmax, RenderCtx *ctx);
    /* Optional (NULL: the renderer uses occluded_packet): shadow rays towards a
     * directional light, one direction and one tmax for all. Bit i is occluded(self,
     * ray, tmin, tmax, ctx) for the ray from rays[i].origin in direction dir; the rays'
     * own directions are not read. */
    uint64_t (*occluded_packet_dir)(const void *self, const Ray *rays, uint64_t mask,
                                    float tmin, float tmax, Vec3 dir, RenderCtx *ctx);
    /* Per-thread scratch: mailbox slots the RenderCtx needs (0: none). */
    uint32_t (*scratch_size)(const void *self);
    /* Statistics: fills what the accelerator adds to the report (the grid's cells);
     * NULL adds nothing. */
    void (*report)(const void *self, StatsReport *r);
    /* The ops that draw this accelerator's structure instead of the scene
     * (-visualize_grid), sharing create's state; NULL when it has none. */
    const struct AccelOps *visualize;
} AccelOps;

/* One built accelerator: its ops and its state. */
typedef struct Accel {
    const AccelOps *ops;
    void *self;
} Accel;

/* The registered accelerators, in the order -h lists them; NULL-terminated. */
extern const AccelOps *const accel_registry[];
/* The accelerator called name; NULL when there is none. */
const AccelOps *accel_find(const char *name);
/* "none, grid": the registered names, for usage messages. */
const char *accel_names(void);

/* Builds accelerator ops over t into a (its visualisation ops when cfg->visualize and
 * it has them). Returns false when it failed (reported to diag) or when it had nothing
 * to hold (no error reported; a stays empty). */
bool accel_init(Accel *a, const AccelOps *ops, const PrimTable *t, const AccelConfig *cfg,
                Diag *diag);
void accel_free(Accel *a);

static inline bool accel_intersect(const Accel *a, const Ray *ray, Hit *hit, float tmin,
                                   RenderCtx *ctx)
{
    return a->ops->intersect(a->self, ray, hit, tmin, ctx);
}
static inline bool accel_occluded(const Accel *a, const Ray *ray, float tmin, float tmax,
                                  RenderCtx *ctx)
{
    return a->ops->occluded(a->self, ray, tmin, tmax, ctx);
}
static inline bool accel_has_packets(const Accel *a)
{
    return a->ops->intersect_packet != NULL;
}
static inline uint64_t accel_intersect_packet(const Accel *a, const Ray *rays, int n,
                                              Hit *hits, float tmin, RenderCtx *ctx)
{
    return a->ops->intersect_packet(a->self, rays, n, hits, tmin, ctx);
}
static inline uint64_t accel_occluded_packet(const Accel *a, const Ray *rays, uint64_t mask,
                                             float tmin, const float *tmax, RenderCtx *ctx)
{
    return a->ops->occluded_packet(a->self, rays, mask, tmin, tmax, ctx);
}
/* The rays of mask from rays[i].origin in direction dir up to tmax (occluded_packet_dir,
 * or occluded_packet after writing dir into those rays when the accelerator has no
 * such op). */
static inline uint64_t accel_occluded_packet_dir(const Accel *a, Ray *rays, uint64_t mask,
                                                 float tmin, float tmax, Vec3 dir,
                                                 RenderCtx *ctx)
{
    if (a->ops->occluded_packet_dir)
        return a->ops->occluded_packet_dir(a->self, rays, mask, tmin, tmax, dir, ctx);
    float t[ACCEL_PACKET_MAX];
    for (uint64_t m = mask; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        rays[i].dir = dir;
        t[i] = tmax;
    }
    return a->ops->occluded_packet(a->self, rays, mask, tmin, t, ctx);
}
static inline uint32_t accel_scratch_size(const Accel *a)
{
    return a->ops->scratch_size ? a->ops->scratch_size(a->self) : 0;
}
static inline void accel_report(const Accel *a, StatsReport *r)
{
    if (a->ops->report)
        a->ops->report(a->self, r);
}

/* "none": every primitive for every ray (accel_none.c). Tests and tools use it directly. */
extern const AccelOps accel_none_ops;

#endif
