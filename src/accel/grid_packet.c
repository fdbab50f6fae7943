/* Packets of coherent rays through the grid (grid.h, "Ray packets"): the set-up of a
 * packet, the rays that go through the single-ray march instead, and the choice of
 * kernel. The walk itself is grid_packet_kernel.h. */
#include "grid_packet.h"
#include "rt/cpu.h"

#include <float.h>
#include <math.h>
#include <pthread.h>
#include <string.h>

#define PK_WALK grid_packet_walk_generic
#define PK_PREP grid_packet_prep_generic
#define PK_SPREAD grid_packet_spread_generic
#include "grid_packet_kernel.h"

static _Thread_local PacketMarks thread_marks;

PacketMarks *grid_packet_marks(void)
{
    PacketMarks *m = &thread_marks;
    if (++m->gen == 0) { /* after 2^32 walks: no slot may look current */
        memset(m->slot, 0, sizeof m->slot);
        m->gen = 1;
    }
    return m;
}

typedef void (*WalkFn)(const Grid *, Packet *, RenderCtx *);
typedef uint64_t (*PrepFn)(const Grid *, Packet *, uint64_t, const float *, uint64_t *);
typedef float (*SpreadFn)(const Grid *, const Packet *, uint64_t);

/* The kernels. The default is the best the CPU has: AVX-512 with 16-lane ray groups,
 * else AVX2 with 8 lanes, else the generic one. "avx512x8" (the 8-lane kernel in
 * AVX-512 instructions) is chosen only on request (grid_packet_use_kernel,
 * bench/grid_ref -kernel): on this project's AMD EPYC (Zen 4, 512-bit operations in
 * two halves) 16 lanes traced the 40k bunny at 1080p about 1.25x faster than 2 x 8
 * lanes in the same instructions, and 8 lanes in AVX-512 no faster than in AVX2
 * (interleaved runs, bench/REPORT.txt). */
typedef struct PacketKernel {
    const char *name;
    WalkFn walk;
    PrepFn prep;
    SpreadFn spread;
} PacketKernel;

static const PacketKernel kernels[] = {
    {"generic", grid_packet_walk_generic, grid_packet_prep_generic, grid_packet_spread_generic},
    {"avx2", grid_packet_walk_avx2, grid_packet_prep_avx2, grid_packet_spread_avx2},
    {"avx512", grid_packet_walk_avx512, grid_packet_prep_avx512, grid_packet_spread_avx512},
    {"avx512x8", grid_packet_walk_avx512x8, grid_packet_prep_avx512x8, grid_packet_spread_avx512x8},
};
enum { NUM_KERNELS = sizeof kernels / sizeof kernels[0] };

static WalkFn walk_fn = grid_packet_walk_generic;
static PrepFn prep_fn = grid_packet_prep_generic;
static SpreadFn spread_fn = grid_packet_spread_generic;
static const char *walk_name = "generic";
static pthread_once_t walk_once = PTHREAD_ONCE_INIT;

/* Whether this CPU runs kernels[i] (the generic one runs everywhere). */
static bool kernel_usable(int i)
{
    if (i == 0)
        return true;
    if (i == 1)
        return cpu_has_avx2();
    if (i == 2 || i == 3)
        return cpu_has_avx512();
    return false;
}

static void set_kernel(int i)
{
    walk_fn = kernels[i].walk;
    prep_fn = kernels[i].prep;
    spread_fn = kernels[i].spread;
    walk_name = kernels[i].name;
}

static void choose_walk(void)
{
    set_kernel(kernel_usable(2) ? 2 : kernel_usable(1) ? 1 : 0);
}

const char *grid_packet_kernel(void)
{
    pthread_once(&walk_once, choose_walk);
    return walk_name;
}

bool grid_packet_use_kernel(const char *name)
{
    pthread_once(&walk_once, choose_walk);
    for (int i = 0; i < NUM_KERNELS; i++)
        if (!strcmp(name, kernels[i].name) && kernel_usable(i)) {
            set_kernel(i);
            return true;
        }
    return false;
}

/* packet_prepare's axis and sign for candidates that all have direction d, without
 * their sums, where the sums' rounding cannot change them. The sums of n copies of a
 * component (four partial sums, then two adds: each step monotone, and rounding is
 * symmetric in sign) order their magnitudes as the components' own, and equal
 * magnitudes give equal sums, so only |a| > |b| can come out as a tie; their relative
 * error is at most gamma_63 < 3.8e-6 (n <= 64), so beyond a factor 1.0001 it cannot.
 * False (the caller sums) inside that band, and for components too large to sum
 * finitely (or NaN). */
static bool same_dir_axis(const float d[3], int *axis, int *sign)
{
    float m[3] = {fabsf(d[0]), fabsf(d[1]), fabsf(d[2])};
    for (int a = 0; a < 3; a++)
        if (!(m[a] <= 1e30f))
            return false;
    int K = 0;
    for (int a = 1; a < 3; a++) { /* the sums' "if |sum[a]| > |sum[K]| then K = a" */
        if (m[a] <= m[K])
            continue;
        if (!(m[a] > m[K] * 1.0001f))
            return false;
        K = a;
    }
    *axis = K;
    *sign = d[K] < 0.0f ? -1 : 1;
    return true;
}

/* Chooses the packet's main axis for the rays of `cand` (the largest component of
 * their summed directions, or same_dir_axis's) and runs the kernel's set-up (PK_PREP in
 * grid_packet_kernel.h): returns the rays the packet walks; *single_out gets those it
 * leaves to the single-ray march. Rays that miss the box are in neither: their march
 * would not start either. */
static uint64_t packet_prepare(const Grid *g, Packet *pk, uint64_t cand, const float *tmax,
                               uint64_t *single_out)
{
    pthread_once(&walk_once, choose_walk);
    if (pk->same_dir && same_dir_axis(pk->dir, &pk->axis, &pk->sign))
        return prep_fn(g, pk, cand, tmax, single_out);
    /* Four partial sums: one chain of dependent adds over 64 rays was 5% of the 1080p
     * primary pass. (Any axis gives the same answers; this one only keeps packets
     * wide.) */
    Vec3 part[4] = {{0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f}, {0.0f, 0.0f, 0.0f},
                    {0.0f, 0.0f, 0.0f}};
    if ((cand & (cand + 1)) == 0) {
        int n = __builtin_popcountll(cand); /* rays 0 .. n-1 */
        for (int i = 0; i < n; i++)
            part[i & 3] = v3_add(part[i & 3], packet_ray(pk, i).dir);
    } else {
        int j = 0;
        for (uint64_t m = cand; m; m &= m - 1, j++)
            part[j & 3] = v3_add(part[j & 3], packet_ray(pk, __builtin_ctzll(m)).dir);
    }
    Vec3 sum = v3_add(v3_add(part[0], part[1]), v3_add(part[2], part[3]));
    if (!(isfinite(sum.x) && isfinite(sum.y) && isfinite(sum.z))) {
        /* Rare: leave out the rays whose direction is not finite. */
        sum = v3(0.0f, 0.0f, 0.0f);
        for (uint64_t m = cand; m; m &= m - 1) {
            Vec3 d = packet_ray(pk, __builtin_ctzll(m)).dir;
            if (isfinite(d.x) && isfinite(d.y) && isfinite(d.z))
                sum = v3_add(sum, d);
        }
    }
    int K = 0;
    if (fabsf(sum.y) > fabsf(v3_comp(sum, K)))
        K = 1;
    if (fabsf(sum.z) > fabsf(v3_comp(sum, K)))
        K = 2;
    pk->axis = K;
    pk->sign = v3_comp(sum, K) < 0.0f ? -1 : 1;
    return prep_fn(g, pk, cand, tmax, single_out);
}

/* A packet wider than this many cells is split in four. Each ray only tests the cells
 * it crosses (the kernel's per-cell ray masks), so width costs little until the
 * slice rectangles get large and mostly empty for each ray. Measured on the 40k bunny
 * (bench/grid_ref, 200x200 and 1920x1080): thresholds 8 to 100 trace alike, 4 is 10%
 * slower at 200x200 and 2 is 20% slower. */
#define PK_MAX_SPREAD 12.0f

/* Walks the rays of walk, which lie in [lo, lo + n) (rays in Z order: a quarter of the
 * range is a quarter of the tile), as one packet, or as four when it is too wide.
 * Returns the rays left to the single-ray march. */
static uint64_t packet_walk(const Grid *g, Packet *pk, int lo, int n, uint64_t walk,
                            RenderCtx *ctx)
{
    if (n >= 8 && spread_fn(g, pk, walk) > PK_MAX_SPREAD) {
        uint64_t single = 0;
        for (int q = 0; q < 4; q++) {
            int a = lo + q * n / 4, b = lo + (q + 1) * n / 4;
            uint64_t range = (b - a == 64 ? ~(uint64_t)0 : (((uint64_t)1 << (b - a)) - 1)) << a;
            if (walk & range)
                single |= packet_walk(g, pk, a, b - a, walk & range, ctx);
        }
        return single;
    }
    if (__builtin_popcountll(walk) < 2)
        return walk; /* one ray: its own march is cheaper */
    int k_first = pk->sign > 0 ? g->n[pk->axis] : -1;
    for (uint64_t m = walk; m; m &= m - 1) {
        int k = pk->k_start[__builtin_ctzll(m)];
        if (pk->sign > 0 ? k < k_first : k > k_first)
            k_first = k;
    }
    pk->k_first = k_first;
    pk->active = walk;
    walk_fn(g, pk, ctx); /* chosen by packet_prepare's pthread_once */
    return 0;
}

static uint64_t packet_trace(const Grid *g, Packet *pk, int n, uint64_t cand, const float *tmax,
                             RenderCtx *ctx)
{
    uint64_t single;
    uint64_t walk = packet_prepare(g, pk, cand, tmax, &single);
    return single | (walk ? packet_walk(g, pk, 0, n, walk, ctx) : 0);
}

/* Copies the grid's unbounded primitives into pk->planes when all are untransformed
 * planes (at most PK_MAX_PLANES), for the set-up to test (pk->num_planes; true); else
 * pk->num_planes = 0 and false: each ray tests them through their ops. */
static bool packet_planes(const Grid *g, Packet *pk)
{
    pk->num_planes = 0;
    if (g->num_unbounded > PK_MAX_PLANES)
        return false;
    for (uint32_t u = 0; u < g->num_unbounded; u++) {
        const GridPrim *gp = &g->unbounded[u];
        if (gp->xf || gp->obj->ops->kind != OBJ_PLANE)
            return false;
    }
    for (uint32_t u = 0; u < g->num_unbounded; u++) {
        const Object3D *o = g->unbounded[u].obj;
        Vec3 n = plane_normal(o);
        pk->planes[u] = (PacketPlane){{n.x, n.y, n.z}, plane_offset(o), o->id};
    }
    pk->num_planes = (int)g->num_unbounded;
    return true;
}

/* The best-hit lanes start defined (the callers then set their rays' own); the ray
 * lanes are written by the set-up, harmless values where no ray is walked, for every
 * group where some ray is walked, and the walk reads no other group. */
static void packet_clear(Packet *pk)
{
    memset(pk->best_t, 0, sizeof pk->best_t);
    memset(pk->best_id, 0, sizeof pk->best_id);
    memset(pk->best_prim, 0xff, sizeof pk->best_prim); /* -1: no packed hit */
    pk->hit = 0;
}

/* The single-ray march for the rays of mask (the unbounded primitives are done). */
static uint64_t march_intersect_each(const Grid *g, const Ray *rays, uint64_t mask, Hit *hits,
                                     float tmin, RenderCtx *ctx)
{
    uint64_t found = 0;
    for (; mask; mask &= mask - 1) {
        int i = __builtin_ctzll(mask);
        if (grid_march_intersect(g, &rays[i], &hits[i], tmin, ctx))
            found |= (uint64_t)1 << i;
    }
    return found;
}

uint64_t grid_intersect_packet(const Grid *g, const Ray *rays, int n, Hit *hits, float tmin,
                               RenderCtx *ctx)
{
    if (n > GRID_PACKET_MAX)
        n = GRID_PACKET_MAX; /* contract: n <= GRID_PACKET_MAX */
    uint64_t found = 0, cand = n == 64 ? ~(uint64_t)0 : ((uint64_t)1 << n) - 1;
    Packet pk; /* 64-aligned by its type */
    bool packets = ctx->packet_rays && n >= 2;
    if (!packets || !packet_planes(g, &pk)) {
        for (int i = 0; i < n; i++) {
            bool f = false;
            for (uint32_t u = 0; u < g->num_unbounded; u++)
                f |= grid_test_prim(&g->unbounded[u], &rays[i], &hits[i], tmin, ctx);
            if (f)
                found |= (uint64_t)1 << i;
        }
    }
    if (!packets)
        return found | march_intersect_each(g, rays, cand, hits, tmin, ctx);
    ctx->stats.intersections += (uint64_t)n * (uint64_t)pk.num_planes;

    packet_clear(&pk);
    pk.tmin = tmin;
    pk.march_tmin = grid_march_tmin(g, tmin);
    pk.shadow = false;
    pk.same_dir = false;
    pk.xf = NULL;
    pk.hits = hits;
    pk.rays = rays;
    for (int i = 0; i < n; i++) {
        pk.best_t[i / PK_LANES][i % PK_LANES] = hits[i].t;
        pk.best_id[i / PK_LANES][i % PK_LANES] = hits[i].id;
    }
    uint64_t single = packet_trace(g, &pk, n, cand, NULL, ctx);
    found |= pk.hit;
    /* The packet's answers into the Hits: every ray's plane hit (the single-ray march
     * below goes on from it) and the walked rays' triangle hits. The planes' unit
     * normals and materials asked once. */
    Vec3 plane_n[PK_MAX_PLANES];
    const Material *plane_m[PK_MAX_PLANES];
    for (int u = 0; u < pk.num_planes; u++) {
        const Object3D *o = g->unbounded[u].obj;
        plane_n[u] = plane_unit_normal(o);
        plane_m[u] = o->material;
    }
    for (uint64_t m = cand; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        int p = pk.best_prim[i / PK_LANES][i % PK_LANES];
        if (p == -1)
            continue; /* no packed hit: hits[i] is already the answer */
        hits[i].t = pk.best_t[i / PK_LANES][i % PK_LANES];
        hits[i].id = pk.best_id[i / PK_LANES][i % PK_LANES];
        if (p >= 0) {
            hits[i].normal = g->tri_hit[p].normal;
            hits[i].material = g->tri_hit[p].material;
        } else {
            hits[i].normal = plane_n[-2 - p];
            hits[i].material = plane_m[-2 - p];
        }
        found |= (uint64_t)1 << i;
    }
    return found | march_intersect_each(g, rays, single, hits, tmin, ctx);
}

/* The shadow queries: with dir, ray i is (rays[i].origin, *dir) up to tmax1 (tmax and
 * the rays' directions unread); else rays[i] up to tmax[i]. */
static uint64_t occluded_packet(const Grid *g, const Ray *rays, uint64_t mask, float tmin,
                                const float *tmax, const Vec3 *dir, float tmax1,
                                RenderCtx *ctx)
{
    uint64_t occluded = 0, cand = mask;
    Packet pk; /* 64-aligned by its type */
    pk.rays = rays;
    pk.same_dir = dir != NULL;
    pk.xf = NULL;
    if (dir) {
        pk.dir[0] = dir->x;
        pk.dir[1] = dir->y;
        pk.dir[2] = dir->z;
        pk.same_tmax = tmax1;
    }
    bool packets = ctx->packet_rays && __builtin_popcountll(cand) >= 2;
    if (!packets || !packet_planes(g, &pk)) {
        cand = 0;
        for (uint64_t m = mask; m; m &= m - 1) {
            int i = __builtin_ctzll(m);
            Ray r = packet_ray(&pk, i);
            float t1 = dir ? tmax1 : tmax[i];
            bool blocked = false;
            for (uint32_t u = 0; u < g->num_unbounded && !blocked; u++)
                blocked = grid_occluded_prim(&g->unbounded[u], &r, tmin, t1, ctx);
            if (blocked)
                occluded |= (uint64_t)1 << i;
            else
                cand |= (uint64_t)1 << i;
        }
    }
    uint64_t single = cand;
    if (packets && __builtin_popcountll(cand) >= 2) {
        ctx->stats.intersections +=
            (uint64_t)__builtin_popcountll(cand) * (uint64_t)pk.num_planes;
        packet_clear(&pk);
        pk.tmin = tmin;
        pk.march_tmin = grid_march_tmin(g, tmin);
        pk.shadow = true;
        if (dir) {
            const pk_f8 t8 = {tmax1, tmax1, tmax1, tmax1, tmax1, tmax1, tmax1, tmax1};
            for (int gi = 0; gi < PK_GROUPS; gi++)
                pk.best_t[gi] = t8;
        } else {
            for (uint64_t m = cand; m; m &= m - 1) {
                int i = __builtin_ctzll(m);
                pk.best_t[i / PK_LANES][i % PK_LANES] = tmax[i];
            }
        }
        single = packet_trace(g, &pk, 64 - __builtin_clzll(cand), cand, dir ? NULL : tmax, ctx);
        occluded |= pk.hit;
    }
    /* The single-ray march for the rest. */
    for (; single; single &= single - 1) {
        int i = __builtin_ctzll(single);
        Ray r = packet_ray(&pk, i);
        if (grid_march_occluded(g, &r, tmin, dir ? tmax1 : tmax[i], ctx))
            occluded |= (uint64_t)1 << i;
    }
    return occluded;
}

uint64_t grid_occluded_packet(const Grid *g, const Ray *rays, uint64_t mask, float tmin,
                              const float *tmax, RenderCtx *ctx)
{
    return occluded_packet(g, rays, mask, tmin, tmax, NULL, 0.0f, ctx);
}

uint64_t grid_occluded_packet_dir(const Grid *g, const Ray *rays, uint64_t mask, float tmin,
                                  float tmax, Vec3 dir, RenderCtx *ctx)
{
    return occluded_packet(g, rays, mask, tmin, NULL, &dir, tmax, ctx);
}
