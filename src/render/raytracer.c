/* RayTracer (A4-A6): Whitted recursion as the course's traceRay, over the accelerator
 * (rt/accel.h): brute force (RayCast), the grid march (RayCastFast) or any other. */
#include "rt/raytracer.h"

#include <stdlib.h>
#include <string.h>

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
} ShadeState;

/* False when the colour is final already: a back face without -shade_back is black,
 * with no ambient term and no secondary rays. */
static bool shade_begin(const RayTracer *rt, const Ray *ray, const Hit *h, ShadeState *st)
{
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
    st->color = v3_mul(rt->scene->ambient, mat_diffuse_at(h->material, h->point));
    return true;
}

static void shade_light(ShadeState *st, const Ray *ray, Vec3 l, Vec3 lc)
{
    st->color = v3_add(st->color, mat_shade(st->sh.material, ray, &st->sh, l, lc));
}

static Vec3 trace(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin, int depth,
                  float weight, float ior, Hit *hit_out, RaySegKind kind);

static void shade_finish(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, ShadeState *st,
                         int depth, float weight, float ior)
{
    if (depth >= rt->bounces)
        return;
    const Material *m = st->sh.material;
    Vec3 p = st->sh.point, n = st->sh.normal, d = ray->dir;
    Vec3 color = st->color;
    Vec3 kr = mat_reflective_at(m, p);
    if (!v3_is_zero(kr)) {
        float w = weight * v3_length(kr);
        if (w >= rt->weight) {
            Ray r = {p, v3_sub(d, v3_scale(n, 2.0f * v3_dot(d, n)))};
            Vec3 c = trace(rt, ctx, &r, RT_EPSILON, depth + 1, w, ior, NULL, RAYSEG_REFLECTED);
            color = v3_add(color, v3_mul(kr, c));
        }
    }
    Vec3 kt = mat_transparent_at(m, p);
    if (!v3_is_zero(kt)) {
        float w = weight * v3_length(kt);
        if (w >= rt->weight) {
            /* Objects sit in vacuum, not nested (A4): entering goes 1 -> eta_m. */
            float eta_m = mat_ior_at(m, p);
            float eta_i = st->entering ? 1.0f : eta_m;
            float eta_t = st->entering ? eta_m : 1.0f;
            float eta = eta_i / eta_t;
            float cos_i = -v3_dot(n, d);
            float k = 1.0f - eta * eta * (1.0f - cos_i * cos_i);
            if (k >= 0.0f) { /* k < 0: total internal reflection adds nothing */
                Vec3 t = v3_normalize(
                    v3_add(v3_scale(d, eta), v3_scale(n, eta * cos_i - sqrtf(k))));
                Ray r = {p, t};
                Vec3 c = trace(rt, ctx, &r, RT_EPSILON, depth + 1, w, eta_t, NULL,
                               RAYSEG_TRANSMITTED);
                color = v3_add(color, v3_mul(kt, c));
            }
        }
    }
    st->color = color;
}

static Vec3 trace(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin, int depth,
                  float weight, float ior, Hit *hit_out, RaySegKind kind)
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
    if (!shade_begin(rt, ray, &h, &st))
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
        shade_light(&st, ray, l, lc);
    }
    shade_finish(rt, ctx, ray, &st, depth, weight, ior);
    return st.color;
}

Vec3 raytracer_trace(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin,
                     int depth, float weight, float ior, Hit *hit_out)
{
    return trace(rt, ctx, ray, tmin, depth, weight, ior, hit_out, RAYSEG_MAIN);
}

void raytracer_trace_packet(const RayTracer *rt, RenderCtx *ctx, const Ray *rays, int n,
                            float tmin, Vec3 *colors, Hit *hits)
{
    if (!accel_has_packets(rt->accel) || ctx->tree || !ctx->packet_rays ||
        n > ACCEL_PACKET_MAX) {
        for (int i = 0; i < n; i++)
            colors[i] = trace(rt, ctx, &rays[i], tmin, 0, 1.0f, 1.0f, &hits[i], RAYSEG_MAIN);
        return;
    }
    const Scene *scene = rt->scene;
    ctx->stats.nonshadow_rays += (uint64_t)n;
    for (int i = 0; i < n; i++)
        hits[i] = hit_none();
    uint64_t found = accel_intersect_packet(rt->accel, rays, n, hits, tmin, ctx);

    ShadeState st[ACCEL_PACKET_MAX];
    uint64_t live = 0;
    for (int i = 0; i < n; i++) {
        if (!(found >> i & 1)) {
            colors[i] = scene->background;
            continue;
        }
        hits[i].point = ray_at(&rays[i], hits[i].t);
        if (shade_begin(rt, &rays[i], &hits[i], &st[i]))
            live |= (uint64_t)1 << i;
        else
            colors[i] = st[i].color;
    }
    for (int li = 0; li < scene->num_lights && live; li++) {
        Ray srays[ACCEL_PACKET_MAX];
        Vec3 lcol[ACCEL_PACKET_MAX];
        float dist[ACCEL_PACKET_MAX];
        for (uint64_t m = live; m; m &= m - 1) {
            int i = __builtin_ctzll(m);
            srays[i].origin = hits[i].point;
            light_illuminate(&scene->lights[li], hits[i].point, &srays[i].dir, &lcol[i],
                             &dist[i]);
        }
        uint64_t blocked = 0;
        if (rt->shadows) {
            ctx->stats.shadow_rays += (uint64_t)__builtin_popcountll(live);
            blocked = accel_occluded_packet(rt->accel, srays, live, RT_EPSILON, dist, ctx);
        }
        for (uint64_t m = live & ~blocked; m; m &= m - 1) {
            int i = __builtin_ctzll(m);
            shade_light(&st[i], &rays[i], srays[i].dir, lcol[i]);
        }
    }
    for (uint64_t m = live; m; m &= m - 1) {
        int i = __builtin_ctzll(m);
        shade_finish(rt, ctx, &rays[i], &st[i], 0, 1.0f, 1.0f);
        colors[i] = st[i].color;
    }
}

bool raytracer_ctx_init(RenderCtx *ctx, const RayTracer *rt)
{
    memset(ctx, 0, sizeof *ctx);
    uint32_t n = accel_scratch_size(rt->accel);
    if (n) {
        ctx->mailbox = calloc(n, sizeof *ctx->mailbox);
        if (!ctx->mailbox)
            return false;
        ctx->num_mailbox = n;
        if (!rt->single_rays && accel_has_packets(rt->accel)) {
            ctx->packet_rays = malloc((size_t)n * sizeof *ctx->packet_rays);
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
    free(ctx->mailbox);
    ctx->mailbox = NULL;
    free(ctx->packet_rays);
    ctx->packet_rays = NULL;
    ctx->num_mailbox = 0;
}
