/* Packets of coherent rays through the grid (grid.h, "Ray packets"): the set-up of a
 * packet, the rays that go through the single-ray march instead, and the choice of
 * kernel. The walk itself is grid_packet_kernel.h. */
#include "grid_packet.h"

#include <math.h>
#include <pthread.h>
#include <string.h>

#define PK_WALK grid_packet_walk_generic
#include "grid_packet_kernel.h"

typedef void (*WalkFn)(const Grid *, Packet *, RenderCtx *);

static WalkFn walk_fn = grid_packet_walk_generic;
static const char *walk_name = "generic";
static pthread_once_t walk_once = PTHREAD_ONCE_INIT;

static void choose_walk(void)
{
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
    __builtin_cpu_init();
    if (__builtin_cpu_supports("avx2")) {
        walk_fn = grid_packet_walk_avx2;
        walk_name = "avx2";
    }
#endif
}

const char *grid_packet_kernel(void)
{
    pthread_once(&walk_once, choose_walk);
    return walk_name;
}

bool grid_packet_use_kernel(const char *name)
{
    pthread_once(&walk_once, choose_walk);
    if (!strcmp(name, "generic")) {
        walk_fn = grid_packet_walk_generic;
        walk_name = "generic";
        return true;
    }
#if (defined(__x86_64__) || defined(__i386__)) && defined(__GNUC__)
    if (!strcmp(name, "avx2") && __builtin_cpu_supports("avx2")) {
        walk_fn = grid_packet_walk_avx2;
        walk_name = "avx2";
        return true;
    }
#endif
    return false;
}

/* A ray leaves the packet for the single-ray march when its main-axis component is
 * small against its largest one: it would cross many cells per slice and widen the
 * slice rectangle for every ray of the packet. Any value is correct; this one keeps
 * each ray within about three cells' width per slice on cubic cells. */
#define PK_MIN_AXIS_SHARE 0.35f

static inline float pk_max3(float a, float b, float c)
{
    float m = a > b ? a : b;
    return m > c ? m : c;
}

/* The padded-box slab test of march_init, with its arithmetic and verdicts, so a ray
 * is walked exactly when its march would start. */
static bool box_span(const Grid *g, const Ray *ray, float tmin, float *t0, float *t1)
{
    const float o[3] = {ray->origin.x, ray->origin.y, ray->origin.z};
    const float d[3] = {ray->dir.x, ray->dir.y, ray->dir.z};
    float t_enter = -INFINITY, t_exit = INFINITY;
    bool any_axis = false;
    for (int a = 0; a < 3; a++) {
        float inv = 1.0f / d[a];
        float plo = v3_comp(g->box.min, a) - g->pad[a], phi = v3_comp(g->box.max, a) + g->pad[a];
        if (d[a] == 0.0f || !isfinite(inv)) {
            if (!(o[a] >= plo && o[a] <= phi))
                return false;
            continue;
        }
        float ta = (plo - o[a]) * inv, tb = (phi - o[a]) * inv;
        if (inv < 0.0f) {
            float tmp = ta;
            ta = tb;
            tb = tmp;
        }
        if (ta > t_enter) {
            t_enter = ta;
            any_axis = true;
        }
        if (tb < t_exit)
            t_exit = tb;
    }
    if (!any_axis || !(t_enter <= t_exit) || t_exit < tmin)
        return false;
    *t0 = t_enter < tmin ? tmin : t_enter;
    *t1 = t_exit;
    return true;
}

/* Fills pk with the rays of `cand` that the packet can walk (*walk) and those it
 * leaves to the single-ray march (*single); *spread is how many cells wide the walked
 * rays' bundle is, at its widest end, across the main axis. */
static void packet_prepare(const Grid *g, Packet *pk, uint64_t cand, const float *tmax,
                           uint64_t *walk_out, uint64_t *single_out, float *spread)
{
    const Ray *rays = pk->rays;
    /* The main axis: the largest component of the summed directions. */
    Vec3 sum = {0.0f, 0.0f, 0.0f};
    for (uint64_t m = cand; m; m &= m - 1) {
        const Ray *r = &rays[__builtin_ctzll(m)];
        if (isfinite(r->dir.x) && isfinite(r->dir.y) && isfinite(r->dir.z))
            sum = v3_add(sum, r->dir);
    }
    int K = 0;
    if (fabsf(sum.y) > fabsf(v3_comp(sum, K)))
        K = 1;
    if (fabsf(sum.z) > fabsf(v3_comp(sum, K)))
        K = 2;
    int sign = v3_comp(sum, K) < 0.0f ? -1 : 1;
    const int U = (K + 1) % 3, V = (K + 2) % 3;

    uint64_t single = 0, walk = 0;
    int k_first = sign > 0 ? g->n[K] : -1;
    const float lo_k = v3_comp(g->box.min, K), inv_sk = 1.0f / g->size[K];
    /* ends[0..1]: u, v at t0; ends[2..3]: at t1; min and max */
    float emin[4] = {INFINITY, INFINITY, INFINITY, INFINITY};
    float emax[4] = {-INFINITY, -INFINITY, -INFINITY, -INFINITY};
    for (uint64_t m = cand; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        const Ray *r = &rays[i];
        float dk = v3_comp(r->dir, K);
        float big = pk_max3(fabsf(r->dir.x), fabsf(r->dir.y), fabsf(r->dir.z));
        bool fits = isfinite(r->dir.x) && isfinite(r->dir.y) && isfinite(r->dir.z) && (sign > 0 ? dk > 0.0f : dk < 0.0f) &&
                    fabsf(dk) >= PK_MIN_AXIS_SHARE * big && isfinite(r->origin.x) &&
                    isfinite(r->origin.y) && isfinite(r->origin.z) &&
                    !grid_ray_too_far(g, r, pk->tmin);
        if (!fits) {
            single |= (uint64_t)1 << i;
            continue;
        }
        float t0, t1;
        if (!box_span(g, r, pk->tmin, &t0, &t1))
            continue; /* misses the box: the march would not start either */
        if (pk->shadow && tmax[i] < t1)
            t1 = tmax[i];
        int gi = i / PK_LANES, l = i % PK_LANES;
        for (int a = 0; a < 3; a++) {
            pk->o[a][gi][l] = v3_comp(r->origin, a);
            pk->d[a][gi][l] = v3_comp(r->dir, a);
        }
        pk->inv_k[gi][l] = 1.0f / dk;
        pk->t0[gi][l] = t0;
        pk->t1[gi][l] = t1;
        int k = pk_cell_of(v3_comp(r->origin, K) + t0 * dk, lo_k, inv_sk, g->n[K]);
        if (sign > 0 ? k < k_first : k > k_first)
            k_first = k;
        float e[4] = {v3_comp(r->origin, U) + t0 * v3_comp(r->dir, U),
                      v3_comp(r->origin, V) + t0 * v3_comp(r->dir, V),
                      v3_comp(r->origin, U) + t1 * v3_comp(r->dir, U),
                      v3_comp(r->origin, V) + t1 * v3_comp(r->dir, V)};
        for (int j = 0; j < 4; j++) {
            emin[j] = e[j] < emin[j] ? e[j] : emin[j];
            emax[j] = e[j] > emax[j] ? e[j] : emax[j];
        }
        walk |= (uint64_t)1 << i;
    }
    float w = 0.0f;
    if (walk) {
        const float inv_s[2] = {1.0f / g->size[U], 1.0f / g->size[V]};
        for (int j = 0; j < 4; j++)
            if ((emax[j] - emin[j]) * inv_s[j % 2] > w)
                w = (emax[j] - emin[j]) * inv_s[j % 2];
    }
    pk->axis = K;
    pk->sign = sign;
    pk->k_first = k_first;
    *walk_out = walk;
    *single_out = single;
    *spread = w;
}

/* A packet wider than this many cells is split in four: its rays would share few cells,
 * and each would be tested against the triangles of the others' cells. Measured on the
 * course bunnies at 200x200 and 1920x1080 (bench/): 1.5 and 2.5 cost 3-15% more than 4;
 * no split at all costs about the same as 4. */
#define PK_MAX_SPREAD 4.0f

/* Walks the rays of cand, which lie in [lo, lo + n) (rays in Z order: a quarter of the
 * range is a quarter of the tile), as one packet, or as four when it is too wide.
 * Returns the rays left to the single-ray march. */
static uint64_t packet_trace(const Grid *g, Packet *pk, int lo, int n, uint64_t cand,
                             const float *tmax, RenderCtx *ctx)
{
    uint64_t walk, single;
    float spread;
    packet_prepare(g, pk, cand, tmax, &walk, &single, &spread);
    if (n >= 8 && spread > PK_MAX_SPREAD) {
        single = 0;
        for (int q = 0; q < 4; q++) {
            int a = lo + q * n / 4, b = lo + (q + 1) * n / 4;
            uint64_t range = (b - a == 64 ? ~(uint64_t)0 : (((uint64_t)1 << (b - a)) - 1)) << a;
            if (cand & range)
                single |= packet_trace(g, pk, a, b - a, cand & range, tmax, ctx);
        }
        return single;
    }
    if (__builtin_popcountll(walk) < 2)
        return single | walk; /* one ray: its own march is cheaper */
    pk->active = walk;
    pthread_once(&walk_once, choose_walk);
    walk_fn(g, pk, ctx);
    return single;
}

/* Lanes of rays outside the walk keep harmless values (they are masked, but still
 * computed). */
static void packet_clear(Packet *pk)
{
    memset(pk, 0, sizeof *pk);
    for (int gi = 0; gi < PK_GROUPS; gi++) {
        for (int a = 0; a < 3; a++)
            pk->d[a][gi] = pk_splat(1.0f);
        pk->inv_k[gi] = pk_splat(1.0f);
        pk->best_prim[gi] = (pk_i8){-1, -1, -1, -1, -1, -1, -1, -1};
    }
}

uint64_t grid_intersect_packet(const Grid *g, const Ray *rays, int n, Hit *hits, float tmin,
                               RenderCtx *ctx)
{
    if (n > GRID_PACKET_MAX)
        n = GRID_PACKET_MAX; /* contract: n <= GRID_PACKET_MAX */
    uint64_t found = 0, cand = 0;
    for (int i = 0; i < n; i++) {
        bool f = false;
        for (uint32_t u = 0; u < g->num_unbounded; u++)
            f |= grid_test_prim(&g->unbounded[u], &rays[i], &hits[i], tmin, ctx);
        if (f)
            found |= (uint64_t)1 << i;
        cand |= (uint64_t)1 << i;
    }
    if (!ctx->packet_rays || n < 2) {
        for (int i = 0; i < n; i++)
            if (grid_march_intersect(g, &rays[i], &hits[i], tmin, ctx))
                found |= (uint64_t)1 << i;
        return found;
    }

    _Alignas(32) Packet pk;
    packet_clear(&pk);
    pk.tmin = tmin;
    pk.shadow = false;
    pk.hits = hits;
    pk.rays = rays;
    for (int i = 0; i < n; i++) {
        pk.best_t[i / PK_LANES][i % PK_LANES] = hits[i].t;
        pk.best_id[i / PK_LANES][i % PK_LANES] = hits[i].id;
    }
    uint64_t single = packet_trace(g, &pk, 0, n, cand, NULL, ctx);
    found |= pk.hit;
    for (uint64_t m = cand & ~single; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        int p = pk.best_prim[i / PK_LANES][i % PK_LANES];
        if (p < 0)
            continue; /* no packed hit: hits[i] is already the answer */
        const Object3D *o = g->prims[p].obj;
        hits[i].t = pk.best_t[i / PK_LANES][i % PK_LANES];
        hits[i].id = pk.best_id[i / PK_LANES][i % PK_LANES];
        hits[i].normal = triangle_normal(o);
        hits[i].material = o->material;
        found |= (uint64_t)1 << i;
    }
    for (uint64_t m = single; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        if (grid_march_intersect(g, &rays[i], &hits[i], tmin, ctx))
            found |= (uint64_t)1 << i;
    }
    return found;
}

uint64_t grid_occluded_packet(const Grid *g, const Ray *rays, uint64_t mask, float tmin,
                              const float *tmax, RenderCtx *ctx)
{
    uint64_t occluded = 0, cand = 0;
    for (uint64_t m = mask; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        Hit h = hit_none();
        h.t = tmax[i];
        h.id = 0;
        bool blocked = false;
        for (uint32_t u = 0; u < g->num_unbounded && !blocked; u++)
            blocked = grid_test_prim(&g->unbounded[u], &rays[i], &h, tmin, ctx);
        if (blocked)
            occluded |= (uint64_t)1 << i;
        else
            cand |= (uint64_t)1 << i;
    }
    if (!ctx->packet_rays || __builtin_popcountll(cand) < 2) {
        for (uint64_t m = cand; m; m &= m - 1) {
            int i = __builtin_ctzll(m);
            if (grid_march_occluded(g, &rays[i], tmin, tmax[i], ctx))
                occluded |= (uint64_t)1 << i;
        }
        return occluded;
    }

    _Alignas(32) Packet pk;
    packet_clear(&pk);
    pk.tmin = tmin;
    pk.shadow = true;
    pk.rays = rays;
    for (uint64_t m = cand; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        pk.best_t[i / PK_LANES][i % PK_LANES] = tmax[i];
    }
    uint64_t single = packet_trace(g, &pk, 0, 64 - __builtin_clzll(cand), cand, tmax, ctx);
    occluded |= pk.hit;
    for (uint64_t m = single; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        if (grid_march_occluded(g, &rays[i], tmin, tmax[i], ctx))
            occluded |= (uint64_t)1 << i;
    }
    return occluded;
}
