/* RayTracer (A4-A6): Whitted recursion as the course's traceRay, over the accelerator
 * (rt/accel.h): brute force (RayCast), the grid march (RayCastFast) or any other. */
#include "rt/raytracer.h"
#include "phong_packet.h"

#include <pthread.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif

#include "rt/bigmem.h"
#include "rt/cpu.h"

bool raytracer_cast(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin, Hit *hit)
{
    return accel_intersect(rt->accel, ray, hit, tmin, ctx);
}

bool raytracer_occluded(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin,
                        float dist)
{
    ctx->stats.shadow_rays++;
    return accel_occluded(rt->accel, ray, tmin, dist, ctx);
}

/* The shading of one hit (ambient, then each light's Phong term unless shadowed, then
 * reflection and refraction, each weighted by the material), in three parts so the packet
 * path can cast the shadow rays of a whole tile together between them: begin (facing
 * normal, ambient), one light after another (shade_light), finish (reflection,
 * refraction). The single-ray and the packet paths run the same parts in the same order
 * per ray, so their colours are the same bits. */
typedef struct ShadeState {
    Hit sh;          /* the hit, its normal turned to face the ray */
    Vec3 color;
    bool entering;
    float cone;      /* width of the pixel's cone at the hit (0: -noise_cutoff off) */
    float footprint; /* what the cone covers on the surface (mat_set_footprint) */
} ShadeState;

void raytracer_set_pixel_cone(RayTracer *rt, const Camera *camera, int width, int height)
{
    float s = (float)(width > height ? width : height);
    if (camera->kind == CAMERA_ORTHOGRAPHIC) {
        rt->pixel_width = camera->size / s;
        rt->pixel_spread = 0.0f;
    } else {
        /* The screen spans 2 tan(angle/2) at distance 1; a pixel 1/S of it. */
        rt->pixel_width = 0.0f;
        rt->pixel_spread = 2.0f * camera->tan_half / s;
    }
}

static inline bool cutoff_on(const RayTracer *rt)
{
    return rt->pixel_width > 0.0f || rt->pixel_spread > 0.0f;
}

/* The cone of a ray that left with width cone0, at its hit t (unit directions: every
 * ray the tracer casts is normalised), and the footprint on the surface: the cone's
 * section stretches by 1/cos(incidence) along the view; the stretch is capped at 8
 * (a grazing view would otherwise wash the texture out across the view as well). The
 * cone is not widened by curved mirrors or lenses: secondary rays keep the spread. */
static void cone_at_hit(const RayTracer *rt, float cone0, const Ray *ray, const Hit *h,
                        ShadeState *st)
{
    st->cone = st->footprint = 0.0f;
    if (!cutoff_on(rt))
        return;
    st->cone = cone0 + rt->pixel_spread * h->t;
    float c = fabsf(v3_dot(h->normal, ray->dir));
    st->footprint = st->cone / (c > 0.125f ? c : 0.125f);
}

/* Before every question to the hit's material: a nested trace has set its own. */
static inline void use_footprint(const RayTracer *rt, const ShadeState *st)
{
    if (cutoff_on(rt))
        mat_set_footprint(st->footprint);
}

/* False when the colour is final already: a back face without -shade_back is black,
 * with no ambient term and no secondary rays. */
static bool shade_begin(const RayTracer *rt, const Ray *ray, const Hit *h, float cone0,
                        ShadeState *st)
{
    cone_at_hit(rt, cone0, ray, h, st);
    Vec3 d = ray->dir;
    Vec3 n = h->normal;
    st->entering = v3_dot(n, d) < 0.0f;
    if (!st->entering && v3_dot(n, d) > 0.0f) {
        if (!rt->shade_back) {
            st->color = v3(0, 0, 0);
            return false;
        }
        n = v3_neg(n);
    }
    st->sh = *h;
    st->sh.normal = n;
    use_footprint(rt, st);
    st->color = v3_mul(rt->scene->ambient, mat_diffuse_at(h->material, h->point));
    return true;
}

static void shade_light(const RayTracer *rt, ShadeState *st, const Ray *ray, Vec3 l, Vec3 lc)
{
    use_footprint(rt, st);
    st->color = v3_add(st->color, mat_shade(st->sh.material, ray, &st->sh, l, lc));
}

static Vec3 trace(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin, int depth,
                  float weight, float ior, float cone0, Hit *hit_out, RaySegKind kind);

/* Whether no more secondary rays are spawned: the run was stopped (ctx->cancel: with
 * deep -bounces and -weight 0 a single pixel's tree can take hours, and its colour is
 * thrown away anyway), or the preview's recording of one tree is full (its colour is
 * not shown). Asked before each spawn, so neither waits for the rest of the tree. */
static bool stop_spawning(const RenderCtx *ctx)
{
    return (ctx->cancel && *ctx->cancel) || (ctx->tree && ray_tree_full(ctx->tree));
}

/* The mirror direction of d about the facing normal n. */
static inline Vec3 reflect_dir(Vec3 d, Vec3 n)
{
    return v3_sub(d, v3_scale(n, 2.0f * v3_dot(d, n)));
}

/* The refracted direction of d through the hit of st on material m at p (Snell's law
 * with the facing normal; objects sit in vacuum, not nested (A4): entering goes
 * 1 -> eta_m, leaving eta_m -> 1), and in *eta_t the index the ray travels on in.
 * False on total internal reflection, which adds nothing. */
static inline bool refract_dir(const ShadeState *st, const Material *m, Vec3 p, Vec3 d,
                               Vec3 *t, float *eta_t)
{
    float eta_m = mat_ior_at(m, p);
    float eta_i = st->entering ? 1.0f : eta_m;
    *eta_t = st->entering ? eta_m : 1.0f;
    float eta = eta_i / *eta_t;
    Vec3 n = st->sh.normal;
    float cos_i = -v3_dot(n, d);
    float k = 1.0f - eta * eta * (1.0f - cos_i * cos_i);
    if (k < 0.0f)
        return false;
    *t = v3_normalize(v3_add(v3_scale(d, eta), v3_scale(n, eta * cos_i - sqrtf(k))));
    return true;
}

static void shade_finish(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, ShadeState *st,
                         int depth, float weight, float ior)
{
    if (depth >= rt->bounces || stop_spawning(ctx))
        return;
    const Material *m = st->sh.material;
    Vec3 p = st->sh.point, n = st->sh.normal, d = ray->dir;
    Vec3 color = st->color;
    use_footprint(rt, st);
    Vec3 kr = mat_reflective_at(m, p);
    if (!v3_is_zero(kr)) {
        float w = weight * v3_length(kr);
        if (w >= rt->weight) {
            Ray r = {p, reflect_dir(d, n)};
            Vec3 c = trace(rt, ctx, &r, RT_EPSILON, depth + 1, w, ior, st->cone, NULL,
                           RAYSEG_REFLECTED);
            color = v3_add(color, v3_mul(kr, c));
        }
    }
    use_footprint(rt, st);
    Vec3 kt = mat_transparent_at(m, p);
    if (!v3_is_zero(kt) && !stop_spawning(ctx)) {
        float w = weight * v3_length(kt);
        Vec3 t;
        float eta_t;
        if (w >= rt->weight && refract_dir(st, m, p, d, &t, &eta_t)) {
            Ray r = {p, t};
            Vec3 c = trace(rt, ctx, &r, RT_EPSILON, depth + 1, w, eta_t, st->cone, NULL,
                           RAYSEG_TRANSMITTED);
            color = v3_add(color, v3_mul(kt, c));
        }
    }
    st->color = color;
}

static Vec3 trace(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin, int depth,
                  float weight, float ior, float cone0, Hit *hit_out, RaySegKind kind)
{
    const Scene *scene = rt->scene;
    ctx->stats.nonshadow_rays++;

    Hit h = hit_none();
    bool any = raytracer_cast(rt, ctx, ray, tmin, &h);
    if (ctx->tree)
        ray_tree_add_segment(ctx->tree, kind, ray, kind == RAYSEG_MAIN ? 0.0f : tmin,
                             any ? h.t : 100.0f);
    if (!any) {
        if (hit_out)
            *hit_out = h;
        return scene->background;
    }
    h.point = ray_at(ray, h.t);
    if (hit_out)
        *hit_out = h;

    ShadeState st;
    if (!shade_begin(rt, ray, &h, cone0, &st))
        return st.color;
    Vec3 p = h.point;
    for (int i = 0; i < scene->num_lights; i++) {
        Vec3 l, lc;
        float dist;
        light_illuminate(&scene->lights[i], p, &l, &lc, &dist);
        if (rt->shadows) {
            Ray sray = {p, l};
            bool blocked = raytracer_occluded(rt, ctx, &sray, RT_EPSILON, dist);
            if (ctx->tree)
                ray_tree_add_segment(ctx->tree, RAYSEG_SHADOW, &sray, 0.0f,
                                     dist < 100.0f ? dist : 100.0f);
            if (blocked)
                continue;
        }
        shade_light(rt, &st, ray, l, lc);
    }
    shade_finish(rt, ctx, ray, &st, depth, weight, ior);
    return st.color;
}

Vec3 raytracer_trace(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin,
                     int depth, float weight, float ior, Hit *hit_out)
{
    return trace(rt, ctx, ray, tmin, depth, weight, ior, rt->pixel_width, hit_out, RAYSEG_MAIN);
}

/* Packets shade their hits on a PhongMaterial inline, a group of lanes at a time
 * (phong_packet.h), when -noise_cutoff is off (packet_inline_ok): the arithmetic of
 * shade_begin and phong_term in the same order, so the same bits as through the
 * material's ops, without the indirect calls, the view vector made once for all lights
 * and a directional light's direction and colour once per packet (a point light's lane
 * by lane, as light_illuminate gives them). */
static bool packet_inline_ok(const RayTracer *rt) { return !cutoff_on(rt); }

/* Whether every light is directional: one direction and colour for all lanes, and the
 * power bracket (which keeps each light's direction and colour for the packet). */
static bool all_directional(const RayTracer *rt)
{
    for (int i = 0; i < rt->scene->num_lights; i++)
        if (rt->scene->lights[i].kind != LIGHT_DIRECTIONAL)
            return false;
    return true;
}

/* Whether a Phong lane needs shade_finish: not without bounces or without reflective
 * and transparent colours (shade_finish adds nothing then). */
static bool phong_lane_bounces(const RayTracer *rt, const PhongParams *p)
{
    return rt->bounces > 0 && !(v3_is_zero(p->reflective) && v3_is_zero(p->transparent));
}

/* The state shade_finish takes for lane i of pp (a lane phong_lane_bounces): the hit
 * with its facing normal, the colour so far; no cone (inline lanes have the cut-off
 * off). */
static void phong_lane_state(const Hit *h, const PhongPacket *pp, int i, bool entering,
                             ShadeState *st)
{
    st->sh = *h;
    st->sh.normal = v3(pp->nx[i], pp->ny[i], pp->nz[i]);
    st->color = phong_packet_color(pp, i);
    st->entering = entering;
    st->cone = st->footprint = 0.0f;
}

/* How a packet shades the hits on one material (packet_kind). */
typedef enum PacketKind {
    PACKET_OPS,     /* through the material's ops (shade_begin, shade_light, shade_finish) */
    PACKET_PHONG,   /* a PhongMaterial: the Phong packet kernel */
    PACKET_CHECKER, /* a Checkerboard that may pick a PhongMaterial: each lane as the
                       child it picks there */
    PACKET_BLEND,   /* a Noise, Marble or Wood of two PhongMaterials: blend lanes */
} PacketKind;

/* The kind of material m when the packet shades inline (packet_inline_ok). Blend lanes
 * need the footprint 0 (their weights are computed for it) and no shade_finish: no
 * bounces, or zero reflective and transparent colours (shade_finish adds nothing). */
static PacketKind packet_kind(const RayTracer *rt, const Material *m, bool blends_ok)
{
    const PhongParams *p1, *p2;
    bool plain;
    if (phong_params_of(m))
        return PACKET_PHONG;
    /* A Checkerboard none of whose picks is a PhongMaterial (a Wood under a checker,
     * say) goes through the ops: checker_lane would pick its child only to give up. */
    if (mat_checker_reaches_phong(m))
        return PACKET_CHECKER;
    if (blends_ok && mat_phong_blend(m, &p1, &p2, &plain) && (plain || rt->bounces == 0))
        return PACKET_BLEND;
    return PACKET_OPS;
}

/* a for t >= 1, b for t <= 0, else t a + (1 - t) b: procedural_blend_shade's and the
 * colour accessors' blend of their children's answers. */
static inline Vec3 blend_of(Vec3 a, Vec3 b, float t)
{
    return t >= 1.0f ? a : t <= 0.0f ? b : v3_lerp(a, b, t);
}

/* One directional light's term on a blend lane: procedural_blend_shade over two
 * PhongMaterials (each phong_shade is phong_term with v = -normalize(ray dir)), with
 * the view vector v made once per lane and the child of weight 0 not asked. */
static inline Vec3 blend_light(const PhongParams *p1, const PhongParams *p2, float t, Vec3 n,
                               Vec3 v, Vec3 l, Vec3 lc)
{
    if (t >= 1.0f)
        return phong_term(p1, n, v, l, lc);
    if (t <= 0.0f)
        return phong_term(p2, n, v, l, lc);
    return v3_lerp(phong_term(p1, n, v, l, lc), phong_term(p2, n, v, l, lc), t);
}

/* Whether phong_term leaves powf out for material p at every normal n with
 * n . n <= 1.125 (its rule, less the per-normal part). */
static bool phong_flat(const PhongParams *p)
{
    return v3_is_zero(p->specular) && p->exponent >= 0.0f && p->exponent <= 1000.0f;
}

/* The blend lanes of a packet (lanes of the packet's blend mask only): each lane's
 * weight, facing normal and colour so far in columns; the lanes whose two children
 * leave powf out there (quick: blend_lights_flat), grouped by material; the children
 * and the view vector of the other lanes. */
typedef struct BlendLanes {
    const PhongParams *p1[ACCEL_PACKET_MAX], *p2[ACCEL_PACKET_MAX];
    float t[ACCEL_PACKET_MAX];
    float nx[ACCEL_PACKET_MAX], ny[ACCEL_PACKET_MAX], nz[ACCEL_PACKET_MAX];
    float c[3][ACCEL_PACKET_MAX];
    Vec3 v[ACCEL_PACKET_MAX]; /* lanes not quick */
    uint64_t quick;
    /* The quick lanes by material: group j's lanes, its two children. */
    int groups;
    uint64_t group_lanes[ACCEL_PACKET_MAX];
    const PhongParams *g1[ACCEL_PACKET_MAX], *g2[ACCEL_PACKET_MAX];
} BlendLanes;

static inline Vec3 blend_normal(const BlendLanes *bl, int i)
{
    return v3(bl->nx[i], bl->ny[i], bl->nz[i]);
}

/* The quick blend lanes' light loop (blend_lanes_kernel.h) at the width of each
 * instruction set: four lanes in the baseline's vectors (SSE on x86-64), eight in AVX2,
 * sixteen in AVX-512; the widest this CPU runs is chosen once. */
typedef void (*BlendGroupFn)(BlendLanes *, uint64_t, const PhongParams *,
                             const PhongParams *, Vec3, Vec3);
typedef void (*BlendEachFn)(BlendLanes *, uint64_t, const PhongParams *, const PhongParams *,
                            const LightLanes *);
#define BL_NAME blend_lights_group_base
#define BL_W 4
#include "blend_lanes_kernel.h"
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define BLEND_WIDE 1
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif
#define BL_NAME blend_lights_group_avx2
#define BL_W 8
#include "blend_lanes_kernel.h"

/* Eight consecutive lanes' hit normals (nx, ny, nz) and ray directions (dx, dy, dz) as
 * AVX2 columns: read with 128-bit loads (t and the normal; the origin's z and the
 * direction) and 4 x 4 transposes. Moves only: the same bits as the structs hold. */
static inline void lanes8_normals_dirs(const Ray *rays, const Hit *hits, int i0, __m256 *nx,
                                       __m256 *ny, __m256 *nz, __m256 *dx, __m256 *dy,
                                       __m256 *dz)
{
    _Static_assert(sizeof(Ray) == 6 * sizeof(float), "a ray is six packed floats");
    _Static_assert(offsetof(Hit, t) == 0 && offsetof(Hit, normal) == sizeof(float),
                   "a hit starts with t and its normal");
    const float *h = (const float *)(const void *)&hits[i0];
    const float *r = (const float *)(const void *)&rays[i0];
    const size_t hs = sizeof(Hit) / sizeof(float);
    /* Written out, not as a loop over arrays: gcc 12 kept such arrays on the stack. */
#define LANE_PAIR(p, stride, l) _mm256_loadu2_m128((p) + (size_t)((l) + 4) * (stride), \
                                                   (p) + (size_t)(l) * (stride))
    const __m256 a[4] = {LANE_PAIR(h, hs, 0), LANE_PAIR(h, hs, 1), LANE_PAIR(h, hs, 2),
                         LANE_PAIR(h, hs, 3)}; /* t n */
    const __m256 b[4] = {LANE_PAIR(r + 2, 6, 0), LANE_PAIR(r + 2, 6, 1), LANE_PAIR(r + 2, 6, 2),
                         LANE_PAIR(r + 2, 6, 3)}; /* o.z d */
#undef LANE_PAIR
    __m256 a0 = _mm256_unpacklo_ps(a[0], a[1]), a1 = _mm256_unpacklo_ps(a[2], a[3]);
    __m256 a2 = _mm256_unpackhi_ps(a[0], a[1]), a3 = _mm256_unpackhi_ps(a[2], a[3]);
    *nx = _mm256_shuffle_ps(a0, a1, _MM_SHUFFLE(3, 2, 3, 2));
    *ny = _mm256_shuffle_ps(a2, a3, _MM_SHUFFLE(1, 0, 1, 0));
    *nz = _mm256_shuffle_ps(a2, a3, _MM_SHUFFLE(3, 2, 3, 2));
    __m256 b0 = _mm256_unpacklo_ps(b[0], b[1]), b1 = _mm256_unpacklo_ps(b[2], b[3]);
    __m256 b2 = _mm256_unpackhi_ps(b[0], b[1]), b3 = _mm256_unpackhi_ps(b[2], b[3]);
    *dx = _mm256_shuffle_ps(b0, b1, _MM_SHUFFLE(3, 2, 3, 2));
    *dy = _mm256_shuffle_ps(b2, b3, _MM_SHUFFLE(1, 0, 1, 0));
    *dz = _mm256_shuffle_ps(b2, b3, _MM_SHUFFLE(3, 2, 3, 2));
}

/* phong_lane_put's columns for lanes 0 .. n-1 eight at a time, lp not filled (the
 * caller sets pp->same); returns the lanes put (n rounded down to eight): about a third
 * of the instructions of scalar puts. */
static int phong_put_run8_avx2(const Ray *rays, const Hit *hits, int n, PhongPacket *pp)
{
    int i0 = 0;
    for (; i0 + 8 <= n; i0 += 8) {
        __m256 nx, ny, nz, dx, dy, dz;
        lanes8_normals_dirs(rays, hits, i0, &nx, &ny, &nz, &dx, &dy, &dz);
        _mm256_storeu_ps(pp->nx + i0, nx);
        _mm256_storeu_ps(pp->ny + i0, ny);
        _mm256_storeu_ps(pp->nz + i0, nz);
        _mm256_storeu_ps(pp->vx + i0, dx);
        _mm256_storeu_ps(pp->vy + i0, dy);
        _mm256_storeu_ps(pp->vz + i0, dz);
    }
    return i0;
}

/* blend_begin's lane loop for eight consecutive lanes i0 .. i0+7 of one material (their
 * weights at t8), in AVX2 vectors: the hits' normals and the rays' directions as
 * columns (lanes8_normals_dirs), then per lane shade_begin's n . d, the
 * ambient term ambient * blend_of(d1, d2, t) (v3_lerp's t*a + (1-t)*b) and n . n, the
 * same single IEEE operations in the same order as the scalar loop (no FMA: AVX2
 * alone, and raytracer.o is built with -ffp-contract=off). Writes every lane's t,
 * normal and colour into bl and returns the lanes it has finished: quick lanes (a
 * front face, a flat material, n . n <= 1.125); the caller does the others (back
 * faces, long normals, non-flat materials) with the scalar loop, which writes theirs
 * again. */
static unsigned blend_begin_run8_avx2(const Ray *rays, const Hit *hits, int i0,
                                      const float *t8, Vec3 d1, Vec3 d2, Vec3 amb,
                                      BlendLanes *bl)
{
    __m256 nx, ny, nz, dx, dy, dz;
    lanes8_normals_dirs(rays, hits, i0, &nx, &ny, &nz, &dx, &dy, &dz);
    __m256 nd = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, dx), _mm256_mul_ps(ny, dy)),
                              _mm256_mul_ps(nz, dz));
    __m256 nn = _mm256_add_ps(_mm256_add_ps(_mm256_mul_ps(nx, nx), _mm256_mul_ps(ny, ny)),
                              _mm256_mul_ps(nz, nz));
    /* Finished: not a back face (n . d > 0 false, also for NaN) and n . n <= 1.125. */
    __m256 done = _mm256_andnot_ps(_mm256_cmp_ps(nd, _mm256_setzero_ps(), _CMP_GT_OQ),
                                   _mm256_cmp_ps(nn, _mm256_set1_ps(1.125f), _CMP_LE_OQ));
    __m256 t = _mm256_loadu_ps(t8);
    __m256 one_t = _mm256_sub_ps(_mm256_set1_ps(1.0f), t);
    __m256 ge1 = _mm256_cmp_ps(t, _mm256_set1_ps(1.0f), _CMP_GE_OQ);
    __m256 le0 = _mm256_cmp_ps(t, _mm256_setzero_ps(), _CMP_LE_OQ);
    const float c1[3] = {d1.x, d1.y, d1.z}, c2[3] = {d2.x, d2.y, d2.z},
                ca[3] = {amb.x, amb.y, amb.z};
    for (int k = 0; k < 3; k++) {
        __m256 p = _mm256_set1_ps(c1[k]), q = _mm256_set1_ps(c2[k]);
        __m256 m = _mm256_add_ps(_mm256_mul_ps(p, t), _mm256_mul_ps(q, one_t));
        m = _mm256_blendv_ps(_mm256_blendv_ps(m, q, le0), p, ge1); /* blend_of's order */
        _mm256_storeu_ps(bl->c[k] + i0, _mm256_mul_ps(_mm256_set1_ps(ca[k]), m));
    }
    _mm256_storeu_ps(bl->t + i0, t);
    _mm256_storeu_ps(bl->nx + i0, nx);
    _mm256_storeu_ps(bl->ny + i0, ny);
    _mm256_storeu_ps(bl->nz + i0, nz);
    return (unsigned)_mm256_movemask_ps(done);
}
#if defined(__clang__)
#pragma clang attribute pop
#pragma clang attribute push(__attribute__((target("avx512f"))), apply_to = function)
#else
#pragma GCC pop_options
#pragma GCC push_options
#pragma GCC target("avx512f")
#endif
#define BL_NAME blend_lights_group_avx512
#define BL_W 16
#include "blend_lanes_kernel.h"
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif

/* blend_begin's eight-lane runs (NULL: lane by lane only). */
typedef unsigned (*BlendRunFn)(const Ray *, const Hit *, int, const float *, Vec3, Vec3, Vec3,
                               BlendLanes *);
/* trace_packet's Phong put eight lanes at a time (NULL: lane by lane only). */
typedef int (*PhongPutFn)(const Ray *, const Hit *, int, PhongPacket *);

static BlendGroupFn blend_lights_group = blend_lights_group_base;
static BlendEachFn blend_lights_each = blend_lights_group_base_each;
static BlendRunFn blend_begin_run8 = NULL;
static PhongPutFn phong_put_run8 = NULL;
static pthread_once_t blend_once = PTHREAD_ONCE_INIT;

static const struct {
    const char *isa;
    BlendGroupFn fn;
    BlendEachFn each;
    BlendRunFn run8;
    PhongPutFn put8;
} blend_kernels[] = {
    {"base", blend_lights_group_base, blend_lights_group_base_each, NULL, NULL},
#if defined(BLEND_WIDE)
    {"avx2", blend_lights_group_avx2, blend_lights_group_avx2_each, blend_begin_run8_avx2,
     phong_put_run8_avx2},
    /* AVX-512 has AVX2 */
    {"avx512", blend_lights_group_avx512, blend_lights_group_avx512_each, blend_begin_run8_avx2,
     phong_put_run8_avx2},
#endif
};

static bool blend_set(const char *name)
{
    for (size_t i = 0; i < sizeof blend_kernels / sizeof blend_kernels[0]; i++)
        if (!strcmp(name, blend_kernels[i].isa) && cpu_runs(name)) {
            blend_lights_group = blend_kernels[i].fn;
            blend_lights_each = blend_kernels[i].each;
            blend_begin_run8 = blend_kernels[i].run8;
            phong_put_run8 = blend_kernels[i].put8;
            return true;
        }
    return false;
}

/* The widest copy this CPU runs (asked once; then only read). */
static void blend_choose(void)
{
    if (!blend_set("avx512"))
        blend_set("avx2");
}

bool raytracer_blend_use_kernel(const char *name)
{
    pthread_once(&blend_once, blend_choose);
    return blend_set(name);
}

static void blend_lights_flat(BlendLanes *bl, uint64_t mask, Vec3 l, Vec3 lc)
{
    pthread_once(&blend_once, blend_choose);
    for (int j = 0; j < bl->groups; j++)
        if (bl->group_lanes[j] & mask)
            blend_lights_group(bl, bl->group_lanes[j] & mask, bl->g1[j], bl->g2[j], l, lc);
}

/* blend_lights_flat for a light of a direction and colour per lane (ll). */
static void blend_lights_lanes(BlendLanes *bl, uint64_t mask, const LightLanes *ll)
{
    pthread_once(&blend_once, blend_choose);
    for (int j = 0; j < bl->groups; j++)
        if (bl->group_lanes[j] & mask)
            blend_lights_each(bl, bl->group_lanes[j] & mask, bl->g1[j], bl->g2[j], ll);
}

/* shade_begin for the blend lanes of mask (their hit points made): the weights of each
 * material's lanes together (mat_blend_weights: the noise a vector of points at a
 * time), then the side, the facing normal and the ambient term. Returns the lanes to
 * shade: mask without back faces unless -shade_back (those get black). */
static uint64_t blend_begin(const RayTracer *rt, const Ray *rays, const Hit *hits,
                            uint64_t mask, BlendLanes *bl, Vec3 *colors)
{
    Vec3 pts[ACCEL_PACKET_MAX];
    float t[ACCEL_PACKET_MAX];
    int idx[ACCEL_PACKET_MAX];
    uint64_t shaded = 0;
    bl->quick = 0;
    bl->groups = 0;
    while (mask) {
        const Material *m = hits[__builtin_ctzll(mask)].material;
        int k = 0;
        for (uint64_t r = mask; r; r &= r - 1) {
            int i = __builtin_ctzll(r);
            if (hits[i].material == m) {
                idx[k] = i;
                pts[k++] = hits[i].point;
                mask &= ~((uint64_t)1 << i);
            }
        }
        const PhongParams *p1, *p2;
        bool plain;
        mat_phong_blend(m, &p1, &p2, &plain);
        mat_blend_weights(m, pts, k, t);
        bool flat = phong_flat(p1) && phong_flat(p2);
        uint64_t group = 0;
        /* Eight consecutive lanes at a time where the CPU has the vectors (flat
         * materials: the common case); the lanes a run leaves go through the loop.
         * blend_begin_run8 is chosen once, by blend_choose, and may only be read after
         * this thread's pthread_once: a render thread's first blend packet comes
         * before its first blend_lights_flat, and reading the pointer there while
         * another thread's blend_choose writes it was a data race (TSan, 2 threads). */
        pthread_once(&blend_once, blend_choose);
        BlendRunFn run8 = flat ? blend_begin_run8 : NULL;
        uint64_t todo = ~(uint64_t)0; /* bit j: lane idx[j] still to do */
        for (int j = 0; run8 && j + 8 <= k; j += 8) {
            if (idx[j + 7] - idx[j] != 7)
                continue; /* not consecutive (idx increases) */
            unsigned fin = run8(rays, hits, idx[j], t + j, p1->diffuse, p2->diffuse,
                                rt->scene->ambient, bl);
            uint64_t lanes = (uint64_t)fin << idx[j];
            shaded |= lanes;
            group |= lanes;
            todo &= ~((uint64_t)fin << j);
        }
        for (int j = 0; j < k; j++) {
            if (!(todo >> j & 1))
                continue;
            int i = idx[j];
            Vec3 d = rays[i].dir, n = hits[i].normal;
            if (v3_dot(n, d) > 0.0f) { /* shade_begin's back face */
                if (!rt->shade_back) {
                    colors[i] = v3(0, 0, 0);
                    continue;
                }
                n = v3_neg(n);
            }
            bl->t[i] = t[j];
            bl->nx[i] = n.x;
            bl->ny[i] = n.y;
            bl->nz[i] = n.z;
            Vec3 a = v3_mul(rt->scene->ambient, blend_of(p1->diffuse, p2->diffuse, t[j]));
            bl->c[0][i] = a.x;
            bl->c[1][i] = a.y;
            bl->c[2][i] = a.z;
            shaded |= (uint64_t)1 << i;
            if (flat && v3_dot(n, n) <= 1.125f) {
                group |= (uint64_t)1 << i;
            } else {
                bl->p1[i] = p1;
                bl->p2[i] = p2;
                bl->v[i] = v3_neg(v3_normalize(d));
            }
        }
        if (group) {
            bl->quick |= group;
            bl->group_lanes[bl->groups] = group;
            bl->g1[bl->groups] = p1;
            bl->g2[bl->groups++] = p2;
        }
    }
    return shaded;
}

/* Lane i of pp (a hit on PhongMaterial p): the normal as intersected and the ray
 * direction into the columns (phong_packet_begin does the rest). */
static inline void phong_lane_put(PhongPacket *pp, const PhongParams **lp, const Hit *h,
                                  const Ray *r, int i, const PhongParams *p)
{
    pp->nx[i] = h->normal.x;
    pp->ny[i] = h->normal.y;
    pp->nz[i] = h->normal.z;
    pp->vx[i] = r->dir.x;
    pp->vy[i] = r->dir.y;
    pp->vz[i] = r->dir.z;
    lp[i] = p;
}

/* A lane on a Checkerboard (its hit point made): the child the checker picks at the
 * hit answers every question about it (shade_finish asks the checker again, which
 * picks it again), so a PhongMaterial child makes it a Phong lane (true); false
 * leaves it to the ops. Out of line: the Phong lanes' loop stays as tight as without. */
__attribute__((noinline)) static bool checker_lane(const RayTracer *rt, PhongPacket *pp,
                                                   const PhongParams **lp, const Hit *h,
                                                   const Ray *r, int i, uint64_t *phong,
                                                   uint64_t *bounce)
{
    const Material *c = h->material;
    while (c && !phong_params_of(c))
        c = mat_checker_child(c, h->point);
    const PhongParams *p = c ? phong_params_of(c) : NULL;
    if (!p)
        return false;
    phong_lane_put(pp, lp, h, r, i, p);
    *phong |= (uint64_t)1 << i;
    *bounce |= phong_lane_bounces(rt, p) ? (uint64_t)1 << i : 0;
    return true;
}

/* Lights whose shadow masks a packet keeps for the bracket's re-shading (scenes with
 * more shade every lane with powf). */
enum { BRACKET_LIGHTS = 16 };

/* A packet of secondary rays (reflected or refracted) at one depth of the recursion:
 * each ray's weight, index of refraction and cone width, as trace takes them. NULL for
 * the eye's rays (depth 0, weight 1, index 1, the pixel's cone). */
typedef struct PacketDepth {
    int depth;
    const float *weight, *ior, *cone;
} PacketDepth;

/* Secondary rays go on in packets up to this depth; deeper ones are traced one by one.
 * Each depth holds a packet's shading state on the stack (trace_packet's frame and
 * finish_packet_wide's, about 20 + 7.5 KB with gcc 12 -O2): seven levels take about
 * 190 KB of a thread's stack. Depth 6 covers the course's -bounces 5; 4 left course
 * line 14 12% slower. */
enum { PACKET_DEPTH_MAX = 6 };

/* The depth this run's packets go to: PACKET_DEPTH_MAX, or 0 (secondary rays one by one,
 * as before packets had depths) when the stack limit is under 1 MiB: the render
 * threads' stacks are that size too (glibc's default), and a deep -bounces that fits
 * one by one in 128 KB overflowed it with packets. Set once, by raytracer_ctx_init,
 * before any packet is traced. */
static int packet_depth_max;
static pthread_once_t depth_once = PTHREAD_ONCE_INIT;

static void depth_choose(void)
{
    struct rlimit rl;
    packet_depth_max = PACKET_DEPTH_MAX;
    if (getrlimit(RLIMIT_STACK, &rl) == 0 && rl.rlim_cur != RLIM_INFINITY &&
        rl.rlim_cur < ((rlim_t)1 << 20))
        packet_depth_max = 0;
}

static bool trace_packet(const RayTracer *rt, RenderCtx *ctx, const Ray *rays, int n,
                         float tmin, Vec3 *colors, Hit *hits, bool to_bytes, float *planes,
                         const PacketDepth *pd);

static bool packets_on(const RayTracer *rt, const RenderCtx *ctx)
{
    return accel_has_packets(rt->accel) && !ctx->tree && ctx->packet_rays;
}

/* A packet of secondary rays: through the packet walk when there are enough of them and
 * their directions stay within SECONDARY_SPREAD of each other in every component (the
 * walk tests every ray against the cells of the whole bundle, so a fan of rays off a
 * faceted gem would test far more than each ray's own march), else one by one. Chosen
 * by instruction counts (callgrind, course lines 11b, 12b, 14, 18a and two project
 * scenes): spreads 0.25 to 2 and minimums 1 to 8 were within 10% of each other on all
 * but the gem, which went 7% below the single rays at 1.0 and 2% above them without
 * the test. */
enum { SECONDARY_MIN = 8 };
#define SECONDARY_SPREAD 1.0f
static void trace_secondary(const RayTracer *rt, RenderCtx *ctx, const Ray *sec, int ns,
                            Vec3 *c, Hit *hits, const PacketDepth *next, RaySegKind kind)
{
    Vec3 lo = sec[0].dir, hi = sec[0].dir;
    for (int j = 1; j < ns; j++) {
        lo = v3_min(lo, sec[j].dir);
        hi = v3_max(hi, sec[j].dir);
    }
    Vec3 ext = v3_sub(hi, lo);
    if (ns >= SECONDARY_MIN && ext.x <= SECONDARY_SPREAD && ext.y <= SECONDARY_SPREAD &&
        ext.z <= SECONDARY_SPREAD) {
        trace_packet(rt, ctx, sec, ns, RT_EPSILON, c, hits, false, NULL, next);
        return;
    }
    for (int j = 0; j < ns; j++)
        c[j] = trace(rt, ctx, &sec[j], RT_EPSILON, next->depth, next->weight[j], next->ior[j],
                     next->cone[j], NULL, kind);
}

/* The colours c of secondary rays j < ns, weighted by k, added to their lanes' colours
 * (shade_finish's color + k * c). */
static void add_secondary(ShadeState *st, const int *lane, const Vec3 *k, const Vec3 *c,
                          int ns)
{
    for (int j = 0; j < ns; j++)
        st[lane[j]].color = v3_add(st[lane[j]].color, v3_mul(k[j], c[j]));
}

/* finish_packet's packets: the reflected rays of all lanes of mask traced as one packet
 * of depth + 1, then the refracted ones as another. Per lane the same queries, rays,
 * recursion and sums in the same order as shade_finish, so the same bits (the lanes
 * only trade places in time; nothing one lane does reads another's). Out of line: its
 * arrays (about 8 KB) stay off trace_packet's frame, which every eye ray's packet holds
 * even without bounces (inlined, they raised the smallest stack a plain render at
 * -threads 2 runs in from about 92 KB to 100 KB: review30, gcc 12). */
__attribute__((noinline)) static void finish_packet_wide(const RayTracer *rt, RenderCtx *ctx,
                                                         const Ray *rays, ShadeState *st,
                                                         uint64_t mask, int depth,
                                                         const float *w, const float *ior)
{
    Ray sec[ACCEL_PACKET_MAX];
    Vec3 k[ACCEL_PACKET_MAX], c[ACCEL_PACKET_MAX];
    Hit hits[ACCEL_PACKET_MAX];
    float sw[ACCEL_PACKET_MAX], sior[ACCEL_PACKET_MAX], scone[ACCEL_PACKET_MAX];
    int lane[ACCEL_PACKET_MAX];
    PacketDepth next = {depth + 1, sw, sior, scone};
    /* The reflected rays. */
    int ns = 0;
    for (uint64_t m = mask; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        if (stop_spawning(ctx))
            return;
        use_footprint(rt, &st[i]);
        Vec3 kr = mat_reflective_at(st[i].sh.material, st[i].sh.point);
        if (v3_is_zero(kr))
            continue;
        float wr = w[i] * v3_length(kr);
        if (wr < rt->weight)
            continue;
        sec[ns] = (Ray){st[i].sh.point, reflect_dir(rays[i].dir, st[i].sh.normal)};
        k[ns] = kr;
        sw[ns] = wr;
        sior[ns] = ior[i];
        scone[ns] = st[i].cone;
        lane[ns++] = i;
    }
    if (ns) {
        trace_secondary(rt, ctx, sec, ns, c, hits, &next, RAYSEG_REFLECTED);
        add_secondary(st, lane, k, c, ns);
    }
    /* The refracted rays. */
    ns = 0;
    for (uint64_t m = mask; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        use_footprint(rt, &st[i]);
        const Material *mat = st[i].sh.material;
        Vec3 p = st[i].sh.point;
        Vec3 kt = mat_transparent_at(mat, p);
        if (v3_is_zero(kt) || stop_spawning(ctx))
            continue;
        float wt = w[i] * v3_length(kt);
        if (wt < rt->weight)
            continue;
        Vec3 t;
        float eta_t;
        if (!refract_dir(&st[i], mat, p, rays[i].dir, &t, &eta_t))
            continue;
        sec[ns] = (Ray){p, t};
        k[ns] = kt;
        sw[ns] = wt;
        sior[ns] = eta_t;
        scone[ns] = st[i].cone;
        lane[ns++] = i;
    }
    if (ns) {
        trace_secondary(rt, ctx, sec, ns, c, hits, &next, RAYSEG_TRANSMITTED);
        add_secondary(st, lane, k, c, ns);
    }
}

/* shade_finish for the lanes of mask at depth (their weights and indices of refraction
 * w and ior): as packets (finish_packet_wide) while packets go that deep, else lane by
 * lane. */
static void finish_packet(const RayTracer *rt, RenderCtx *ctx, const Ray *rays,
                          ShadeState *st, uint64_t mask, int depth, const float *w,
                          const float *ior)
{
    if (depth >= rt->bounces || !mask)
        return;
    if (depth >= packet_depth_max || !packets_on(rt, ctx)) {
        for (uint64_t m = mask; m; m &= m - 1) {
            int i = __builtin_ctzll(m);
            shade_finish(rt, ctx, &rays[i], &st[i], depth, w[i], ior[i]);
        }
        return;
    }
    finish_packet_wide(rt, ctx, rays, st, mask, depth, w, ior);
}

/* hit_none() in every lane: one copy of a packet's worth (a few wide stores) rather
 * than a struct assignment per lane. */
#define HIT_NONE_1 {INFINITY, {0, 0, 0}, {0, 0, 0}, 0, RT_NO_ID}
#define HIT_NONE_4 HIT_NONE_1, HIT_NONE_1, HIT_NONE_1, HIT_NONE_1
#define HIT_NONE_16 HIT_NONE_4, HIT_NONE_4, HIT_NONE_4, HIT_NONE_4
static const Hit hits_none_lanes[ACCEL_PACKET_MAX] = {HIT_NONE_16, HIT_NONE_16, HIT_NONE_16,
                                                      HIT_NONE_16};
_Static_assert(ACCEL_PACKET_MAX == 64, "hits_none_lanes holds 64 lanes");

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* Four hits are 192 bytes, three 64-byte vectors: with AVX-512 those three are loaded
 * once and stored over the packet (16 x 3 stores for 64 lanes). The copy through memcpy
 * (glibc's AVX-512 memmove, 3 KB a packet, loads and stores) was 1% of a 17a jittered
 * 16-sample render, which traces 16 times the packets of one sample. The same bytes. */
_Static_assert(sizeof(Hit) == 48, "four hits are three 64-byte vectors");
__attribute__((target("avx512f"))) static void hits_none_avx512(Hit *hits, int n)
{
    const char *p = (const char *)hits_none_lanes;
    __m512i a = _mm512_loadu_si512(p), b = _mm512_loadu_si512(p + 64),
            c = _mm512_loadu_si512(p + 128);
    int i = 0;
    for (; i + 4 <= n; i += 4) {
        char *d = (char *)(hits + i);
        _mm512_storeu_si512(d, a);
        _mm512_storeu_si512(d + 64, b);
        _mm512_storeu_si512(d + 128, c);
    }
    memcpy(hits + i, hits_none_lanes, (size_t)(n - i) * sizeof *hits);
}
#define HAVE_HITS_NONE_AVX512 1
#endif

static void hits_none(Hit *hits, int n)
{
#ifdef HAVE_HITS_NONE_AVX512
    if (cpu_has_avx512()) {
        hits_none_avx512(hits, n);
        return;
    }
#endif
    memcpy(hits, hits_none_lanes, (size_t)n * sizeof *hits);
}

/* raytracer_trace_packet, and with to_bytes raytracer_trace_packet_bytes: the Phong
 * lanes without bounces may then take the power bracket (phong_packet.h). With planes
 * (to_bytes and n = ACCEL_PACKET_MAX), raytracer_trace_tile_bytes: true when the
 * colours went there. pd: the rays are secondary rays of that depth (NULL: the eye's). */
static bool trace_packet(const RayTracer *rt, RenderCtx *ctx, const Ray *rays, int n,
                         float tmin, Vec3 *colors, Hit *hits, bool to_bytes, float *planes,
                         const PacketDepth *pd)
{
    if (!packets_on(rt, ctx) || n > ACCEL_PACKET_MAX) {
        for (int i = 0; i < n; i++)
            colors[i] = pd ? trace(rt, ctx, &rays[i], tmin, pd->depth, pd->weight[i],
                                   pd->ior[i], pd->cone[i], &hits[i], RAYSEG_MAIN)
                           : trace(rt, ctx, &rays[i], tmin, 0, 1.0f, 1.0f, rt->pixel_width,
                                   &hits[i], RAYSEG_MAIN);
        return false;
    }
    const Scene *scene = rt->scene;
    ctx->stats.nonshadow_rays += (uint64_t)n;
    hits_none(hits, n);
    uint64_t found = accel_intersect_packet(rt->accel, rays, n, hits, tmin, ctx);

    bool inline_ok = packet_inline_ok(rt);
    bool all_dir = all_directional(rt);
    bool blends_ok = inline_ok && mat_footprint() == 0.0f;
    PacketKind last_kind = PACKET_OPS;
    uint64_t blend = 0;
    BlendLanes bl;
    ShadeState st[ACCEL_PACKET_MAX];
    PhongPacket pp;
    pp.brk = 0;
    pp.same = NULL;
    const PhongParams *lp[ACCEL_PACKET_MAX];
    uint64_t live = 0, phong = 0, entering = 0, bounce = 0;
    Ray srays[ACCEL_PACKET_MAX]; /* shadow rays: origins of non-Phong lanes set below */
    const Material *last = NULL;
    const PhongParams *last_p = NULL;
    bool last_bounce = false;
    /* phong_packet works on whole groups of lanes: the lanes past n are filled too. */
    int lanes = (n + PHONG_PACKET_GROUP - 1) / PHONG_PACKET_GROUP * PHONG_PACKET_GROUP;
    uint64_t valid = n >= 64 ? ~(uint64_t)0 : ((uint64_t)1 << n) - 1;
    for (uint64_t m = valid & ~found; m; m &= m - 1)
        colors[__builtin_ctzll(m)] = scene->background;
    /* Every lane hit one PhongMaterial (a tile inside one mesh, the common case): its
     * lanes into pp's columns without a lane mask to walk, eight at a time where the
     * CPU has AVX2 (phong_put_run8), and pp.same instead of lp (not filled then); what
     * the loop below does for them, with the material asked once. The materials are
     * compared first: a tile of several (an edge) goes to the loop below with nothing
     * put. */
    uint64_t todo = valid & found;
    if (inline_ok && todo == valid && n > 0) {
        const Material *m0 = hits[0].material;
        const PhongParams *p0 = phong_params_of(m0);
        /* One OR of differences, no branch per lane: a tile of several materials is
         * rare, and a loop that stopped at the first difference cost three times as
         * many instructions on the others. */
        uintptr_t diff = 0;
        for (int i = 1; i < n; i++)
            diff |= (uintptr_t)hits[i].material ^ (uintptr_t)m0;
        bool same = p0 != NULL && diff == 0;
        if (same) {
            /* Read only after this thread's pthread_once (blend_begin says why). */
            pthread_once(&blend_once, blend_choose);
            int i = phong_put_run8 ? phong_put_run8(rays, hits, n, &pp) : 0;
            for (; i < n; i++)
                phong_lane_put(&pp, lp, &hits[i], &rays[i], i, p0);
            pp.same = p0;
            phong = valid;
            bounce = phong_lane_bounces(rt, p0) ? valid : 0;
            todo = 0;
        }
    }
    /* Hit by hit: either the Phong lane's normal and direction into pp's columns
     * (phong_packet_begin does the rest for all of them) or shade_begin through the
     * ops. */
    for (uint64_t m = todo; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        uint64_t bit = (uint64_t)1 << i;
        const PhongParams *p = NULL;
        if (inline_ok) {
            if (hits[i].material != last) { /* neighbouring lanes mostly share one */
                last = hits[i].material;
                last_p = phong_params_of(last);
                last_bounce = last_p && phong_lane_bounces(rt, last_p);
                last_kind = last_p ? PACKET_PHONG : packet_kind(rt, last, blends_ok);
            }
            p = last_p;
        }
        if (p) {
            phong_lane_put(&pp, lp, &hits[i], &rays[i], i, p);
            phong |= bit;
            bounce |= last_bounce ? bit : 0;
            continue;
        }
        hits[i].point = ray_at(&rays[i], hits[i].t);
        /* The shadow rays' origin stored now, long before the accelerator's set-up
         * reads it with wide loads (which would wait for fresh stores to drain). */
        srays[i].origin = hits[i].point;
        if (last_kind == PACKET_BLEND) { /* (only set when inline_ok) */
            blend |= bit;
            continue;
        }
        if (last_kind == PACKET_CHECKER &&
            checker_lane(rt, &pp, lp, &hits[i], &rays[i], i, &phong, &bounce))
            continue;
        if (shade_begin(rt, &rays[i], &hits[i], pd ? pd->cone[i] : rt->pixel_width, &st[i]))
            live |= bit;
        else
            colors[i] = st[i].color;
    }
    if (blend) {
        blend = blend_begin(rt, rays, hits, blend, &bl, colors);
        live |= blend;
    }
    /* Every other lane of the groups (lanes past n too) holds zeros (when the kernel
     * runs at all). */
    uint64_t group_lanes = lanes >= 64 ? ~(uint64_t)0 : ((uint64_t)1 << lanes) - 1;
    for (uint64_t m = phong ? group_lanes & ~phong : 0; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        pp.nx[i] = pp.ny[i] = pp.nz[i] = 0.0f;
        pp.vx[i] = pp.vy[i] = pp.vz[i] = 0.0f;
        lp[i] = NULL;
    }
    if (phong) {
        /* The bracket for colours that go only to bytes: not for lanes with bounces
         * (shade_finish adds to their colour), nor with too many lights to keep. */
        pp.brk = to_bytes && all_dir && scene->num_lights <= BRACKET_LIGHTS ? phong & ~bounce
                                                                              : 0;
        uint64_t shaded = phong_packet_begin(&pp, lanes, phong, lp, rt->shade_back,
                                             scene->ambient, &entering);
        for (uint64_t m = phong & ~shaded; m; m &= m - 1) /* back faces: black */
            colors[__builtin_ctzll(m)] = v3(0, 0, 0);
        phong = shaded;
        bounce &= shaded;
        live |= shaded;
    }
    /* The shadow rays (and the light directions of the lanes shaded through the ops, and
     * of every lane under a point light) start at the hit points, the same lanes for
     * every light: origins set once (the other lanes' with their hit points above). A
     * Phong lane's hit point is made only here, for its shadow rays, its point lights'
     * directions and its secondary rays. */
    bool points_needed = rt->shadows || !all_dir;
    uint64_t rays_needed = points_needed ? live : live & ~phong;
    /* A point light's direction and colour of the inline lanes, in columns; zeros until
     * a light fills them (the kernels read whole groups). */
    LightLanes ll;
    if (!all_dir && (phong | (blend & bl.quick)))
        memset(&ll, 0, sizeof ll);
    for (uint64_t m = points_needed ? phong : bounce; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        Vec3 p = ray_at(&rays[i], hits[i].t);
        hits[i].point = p;
        srays[i].origin = p;
    }
    uint64_t lit[BRACKET_LIGHTS]; /* Phong lanes not in the shadow of light li */
    Vec3 ldir[BRACKET_LIGHTS], lcolor[BRACKET_LIGHTS];
    for (int li = 0; li < scene->num_lights && live; li++) {
        const Light *light = &scene->lights[li];
        Vec3 lcol[ACCEL_PACKET_MAX];
        float dist[ACCEL_PACKET_MAX];
        bool directional = light->kind == LIGHT_DIRECTIONAL;
        Vec3 l0 = v3(0, 0, 0), lc0 = v3(0, 0, 0);
        float dist0 = 0.0f;
        if (directional) /* the same for every point: asked once */
            light_illuminate(light, v3(0, 0, 0), &l0, &lc0, &dist0);
        if (directional) { /* Phong and blend lanes take lc0 themselves: no lcol */
            /* One direction and distance for all: the shadow rays take them as such
             * (accel_occluded_packet_dir), shade_light takes l0. */
            for (uint64_t m = live & ~phong & ~blend; m; m &= m - 1)
                lcol[__builtin_ctzll(m)] = lc0;
        } else {
            for (uint64_t m = rays_needed; m; m &= m - 1) {
                int i = __builtin_ctzll(m);
                light_illuminate(light, hits[i].point, &srays[i].dir, &lcol[i], &dist[i]);
            }
            for (uint64_t m = phong | (blend & bl.quick); m; m &= m - 1) {
                int i = __builtin_ctzll(m);
                ll.x[i] = srays[i].dir.x;
                ll.y[i] = srays[i].dir.y;
                ll.z[i] = srays[i].dir.z;
                ll.r[i] = lcol[i].x;
                ll.g[i] = lcol[i].y;
                ll.b[i] = lcol[i].z;
            }
        }
        uint64_t blocked = 0;
        if (rt->shadows) {
            ctx->stats.shadow_rays += (uint64_t)__builtin_popcountll(live);
            blocked = directional ? accel_occluded_packet_dir(rt->accel, srays, live,
                                                              RT_EPSILON, dist0, l0, ctx)
                                  : accel_occluded_packet(rt->accel, srays, live, RT_EPSILON,
                                                          dist, ctx);
        }
        if ((phong & ~blocked) && directional)
            phong_packet_light(&pp, lanes, phong & ~blocked, l0, lc0);
        else if (phong & ~blocked)
            phong_packet_light_lanes(&pp, lanes, phong & ~blocked, &ll);
        if (pp.brk) {
            lit[li] = phong & ~blocked;
            ldir[li] = l0;
            lcolor[li] = lc0;
        }
        for (uint64_t m = live & ~phong & ~blend & ~blocked; m; m &= m - 1) {
            int i = __builtin_ctzll(m);
            shade_light(rt, &st[i], &rays[i], directional ? l0 : srays[i].dir, lcol[i]);
        }
        if ((blend & bl.quick & ~blocked) && directional)
            blend_lights_flat(&bl, blend & bl.quick & ~blocked, l0, lc0);
        else if (blend & bl.quick & ~blocked)
            blend_lights_lanes(&bl, blend & bl.quick & ~blocked, &ll);
        for (uint64_t m = blend & ~bl.quick & ~blocked; m; m &= m - 1) {
            int i = __builtin_ctzll(m);
            Vec3 c = v3(bl.c[0][i], bl.c[1][i], bl.c[2][i]);
            c = v3_add(c, blend_light(bl.p1[i], bl.p2[i], bl.t[i], blend_normal(&bl, i), bl.v[i],
                                      directional ? l0 : srays[i].dir,
                                      directional ? lc0 : lcol[i]));
            bl.c[0][i] = c.x;
            bl.c[1][i] = c.y;
            bl.c[2][i] = c.z;
        }
    }
    /* Lanes whose bracket leaves their bytes open are shaded again with powf: the
     * ambient term again, then each light that reached them. */
    uint64_t redo = phong && pp.brk ? phong_packet_settle(&pp, lanes, phong) : 0;
    if (redo) {
        pp.brk &= ~redo;
        for (uint64_t m = redo; m; m &= m - 1) {
            int i = __builtin_ctzll(m);
            pp.cr[i] = scene->ambient.x * pp.dr[i];
            pp.cg[i] = scene->ambient.y * pp.dg[i];
            pp.cb[i] = scene->ambient.z * pp.db[i];
        }
        for (int li = 0; li < scene->num_lights; li++)
            if (lit[li] & redo)
                phong_packet_light(&pp, lanes, lit[li] & redo, ldir[li], lcolor[li]);
    }
    /* Every lane's colour is its Phong column: handed over as they are, 32 wide copies
     * instead of 64 Vec3s made from them (and taken apart again into bytes). */
    if (planes && (phong & ~bounce) == valid && n == ACCEL_PACKET_MAX) {
        memcpy(planes, pp.cr, sizeof pp.cr);
        memcpy(planes + ACCEL_PACKET_MAX, pp.cg, sizeof pp.cg);
        memcpy(planes + 2 * ACCEL_PACKET_MAX, pp.cb, sizeof pp.cb);
        return true;
    }
    phong_packet_colors(&pp, phong & ~bounce, colors);
    for (uint64_t m = blend; m; m &= m - 1) { /* no shade_finish (packet_kind) */
        int i = __builtin_ctzll(m);
        colors[i] = v3(bl.c[0][i], bl.c[1][i], bl.c[2][i]);
    }
    /* The lanes with secondary rays (or whose material is asked for them): their
     * reflections and refractions as packets of the next depth. */
    uint64_t fin = live & ~blend & ~(phong & ~bounce);
    if (!fin)
        return false;
    for (uint64_t m = fin & phong; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        phong_lane_state(&hits[i], &pp, i, (entering >> i) & 1, &st[i]);
    }
    float one[ACCEL_PACKET_MAX];
    if (!pd)
        for (int i = 0; i < n; i++)
            one[i] = 1.0f;
    finish_packet(rt, ctx, rays, st, fin, pd ? pd->depth : 0, pd ? pd->weight : one,
                  pd ? pd->ior : one);
    for (uint64_t m = fin; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        colors[i] = st[i].color;
    }
    return false;
}

void raytracer_trace_packet(const RayTracer *rt, RenderCtx *ctx, const Ray *rays, int n,
                            float tmin, Vec3 *colors, Hit *hits)
{
    (void)trace_packet(rt, ctx, rays, n, tmin, colors, hits, false, NULL, NULL);
}

void raytracer_trace_packet_bytes(const RayTracer *rt, RenderCtx *ctx, const Ray *rays,
                                  int n, float tmin, Vec3 *colors, Hit *hits)
{
    (void)trace_packet(rt, ctx, rays, n, tmin, colors, hits, true, NULL, NULL);
}

bool raytracer_trace_tile_bytes(const RayTracer *rt, RenderCtx *ctx, const Ray *rays,
                                float tmin, Vec3 *colors, float *planes, Hit *hits)
{
    return trace_packet(rt, ctx, rays, ACCEL_PACKET_MAX, tmin, colors, hits, true, planes, NULL);
}

bool raytracer_ctx_init(RenderCtx *ctx, const RayTracer *rt)
{
    memset(ctx, 0, sizeof *ctx);
    pthread_once(&depth_once, depth_choose);
    uint32_t n = accel_scratch_size(rt->accel);
    if (n) {
        /* bigmem: a 40k-triangle grid's stamps (160 KB) come from its huge-page pool
         * instead of ~40 fresh 4 KB pages per thread. */
        ctx->mailbox = bigmem_calloc(n, sizeof *ctx->mailbox);
        if (!ctx->mailbox)
            return false;
        ctx->num_mailbox = n;
        if (!rt->single_rays && accel_has_packets(rt->accel)) {
            /* One mask: the packets mark in a small table of their own (grid_packet.h),
             * so this only switches them on. */
            ctx->packet_rays = bigmem_calloc(1, sizeof *ctx->packet_rays);
            if (!ctx->packet_rays) {
                raytracer_ctx_free(ctx);
                return false;
            }
        }
    }
    return true;
}

void raytracer_ctx_free(RenderCtx *ctx)
{
    bigmem_free(ctx->mailbox);
    ctx->mailbox = NULL;
    bigmem_free(ctx->packet_rays);
    ctx->packet_rays = NULL;
    ctx->num_mailbox = 0;
}
