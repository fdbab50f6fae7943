/* Property test of RayCastFast: over seeded random scenes (spheres, triangles, meshes with
 * shared edges, nested Transforms with rotations and non-uniform scales, planes) and
 * thousands of seeded random rays (camera-like, secondary rays leaving surfaces, rays
 * aimed at cell borders and mesh vertices), grid_intersect returns exactly the hit of the
 * brute-force tree walk (t bit-equal, same primitive, normal, material) at several
 * resolutions, grid_occluded agrees with a brute-force occlusion test, and with marking on
 * no primitive is intersected twice for one ray (counted independently by wrapping the
 * primitives' ops). The packet queries (grid_intersect_packet, grid_occluded_packet)
 * are held to the same brute-force answers on coherent, incoherent and shadow-like
 * packets. */
#include <stdlib.h>
#include <string.h>

#include "../harness.h"
#include "../../src/accel/grid_internal.h"
#include "rt/arena.h"
#include "rt/geom.h"
#include "rt/grid.h"
#include "rt/material.h"
#include "rt/render.h"
#include "rt/scene.h"

#include "test_rng.h"

/* ---- counting wrapper around the primitives' intersect ---- */

/* One wrapped ops table per primitive type met, found by the original table: nothing
 * here is indexed by ObjKind, so a kind added to the enum cannot overrun it. */
enum { MAX_WRAPPED = 16 };
static const Object3DOps *orig_ops[MAX_WRAPPED];
static Object3DOps wrapped_ops[MAX_WRAPPED];
static int num_wrapped;
static uint32_t *test_counts; /* per primitive id, for the current ray */
static uint32_t num_counted;

static bool counting_intersect(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                               RenderCtx *ctx)
{
    if (test_counts && self->id < num_counted)
        test_counts[self->id]++;
    return orig_ops[self->ops - wrapped_ops]->intersect(self, ray, hit, tmin, ctx);
}

static void wrap(Object3D *o)
{
    if (o->ops >= wrapped_ops && o->ops < wrapped_ops + MAX_WRAPPED)
        return; /* wrapped already */
    int k = 0;
    while (k < num_wrapped && orig_ops[k] != o->ops)
        k++;
    if (k == num_wrapped) {
        CHECK_MSG(num_wrapped < MAX_WRAPPED, "more than %d primitive types", MAX_WRAPPED);
        if (num_wrapped >= MAX_WRAPPED)
            return;
        orig_ops[k] = o->ops;
        wrapped_ops[k] = *o->ops;
        wrapped_ops[k].intersect = counting_intersect;
        num_wrapped++;
    }
    o->ops = &wrapped_ops[k];
}

/* ---- random scenes ---- */

typedef struct RScene {
    Scene s;
    Material *mats[4];
    Vec3 vertices[256]; /* mesh vertices in world space (for aimed rays) */
    int num_vertices;
} RScene;

static Mat4 random_matrix(void)
{
    Mat4 m = mat4_identity(), t;
    int parts = 1 + irand(3);
    for (int i = 0; i < parts; i++) {
        switch (irand(5)) {
        case 0: t = mat4_translate(vrand(-1.5f, 1.5f)); break;
        case 1: t = mat4_scale(v3(frand(0.3f, 2), frand(0.3f, 2), frand(0.3f, 2))); break;
        case 2: t = mat4_rotate_x(frand(-180, 180)); break;
        case 3: t = mat4_rotate_y(frand(-180, 180)); break;
        default: t = mat4_rotate_axis(unit_rand(), frand(-180, 180)); break;
        }
        m = mat4_mul(&m, &t);
    }
    return m;
}

static Object3D *random_leaf(RScene *r, int depth);

/* A small height-field mesh: triangles sharing edges and vertices (ties in t). */
static Object3D *random_mesh(RScene *r, bool record)
{
    Arena *a = &r->s.arena;
    int nx = 2 + irand(4), nz = 2 + irand(4);
    Vec3 base = vrand(-2, 1);
    float step = frand(0.1f, 0.5f);
    Object3D *g = group_new(a, 2 * nx * nz);
    int k = 0;
    for (int i = 0; i < nx; i++)
        for (int j = 0; j < nz; j++) {
            Vec3 p[4];
            for (int c = 0; c < 4; c++) {
                int di = c & 1, dj = c >> 1;
                /* Integer-ish heights keep many shared vertices exactly representable. */
                float h = (float)(((i + di) * 7 + (j + dj) * 3) % 4) * 0.125f;
                p[c] = v3_add(base, v3((float)(i + di) * step, h, (float)(j + dj) * step));
                if (record && r->num_vertices < 256)
                    r->vertices[r->num_vertices++] = p[c];
            }
            const Material *m = r->mats[irand(4)];
            group_set_child(g, k++, triangle_new(a, p[0], p[1], p[3], m));
            group_set_child(g, k++, triangle_new(a, p[0], p[3], p[2], m));
        }
    group_finish(g);
    return g;
}

static Object3D *random_leaf(RScene *r, int depth)
{
    Arena *a = &r->s.arena;
    const Material *m = r->mats[irand(4)];
    int choice = irand(depth < 3 ? 10 : 7);
    if (choice <= 2) {
        return sphere_new(a, vrand(-2, 2), frand(0.05f, 0.9f), m);
    } else if (choice <= 4) {
        Vec3 c = vrand(-2, 2);
        float s = frand(0.1f, 1.5f);
        return triangle_new(a, v3_add(c, vrand(-s, s)), v3_add(c, vrand(-s, s)),
                            v3_add(c, vrand(-s, s)), m);
    } else if (choice == 5) {
        return random_mesh(r, depth == 0);
    } else if (choice == 6) {
        /* Axis-aligned triangle lying exactly on a likely cell border plane. */
        float y = (float)irand(5) * 0.5f - 1.0f;
        Vec3 c = vrand(-2, 2);
        return triangle_new(a, v3(c.x, y, c.z), v3(c.x + 1, y, c.z), v3(c.x, y, c.z + 1), m);
    } else {
        /* A Transform above a group of 1-3 leaves (nesting grows with depth). */
        int n = 1 + irand(3);
        Object3D *g = group_new(a, n);
        for (int i = 0; i < n; i++)
            group_set_child(g, i, random_leaf(r, depth + 1));
        group_finish(g);
        Mat4 mm = random_matrix();
        Object3D *x = transform_new(a, &mm, g);
        return x ? x : g;
    }
}

static void rscene_make(RScene *r, int num_objects, int num_planes)
{
    memset(r, 0, sizeof *r);
    arena_init(&r->s.arena);
    for (int i = 0; i < 4; i++) {
        PhongParams p = phong_defaults();
        p.diffuse = vrand(0, 1);
        r->mats[i] = phong_new(&r->s.arena, &p);
    }
    Object3D *root = group_new(&r->s.arena, num_objects + num_planes);
    int k = 0;
    for (int i = 0; i < num_objects; i++) {
        if (k < num_objects + num_planes && irand(num_objects) < num_planes) {
            Vec3 n = unit_rand();
            Object3D *p = plane_new(&r->s.arena, n, frand(-3, 3), r->mats[irand(4)]);
            if (irand(2)) {
                Mat4 mm = random_matrix();
                Object3D *x = transform_new(&r->s.arena, &mm, p);
                p = x ? x : p;
            }
            group_set_child(root, k++, p);
        }
        group_set_child(root, k++, random_leaf(r, 0));
    }
    while (k < num_objects + num_planes)
        group_set_child(root, k++, sphere_new(&r->s.arena, vrand(-2, 2), 0.3f, r->mats[0]));
    group_finish(root);
    r->s.root = root;
    r->s.num_primitives = group_assign_ids(root);
    r->s.bounds = root->bounded ? root->bbox : bbox_empty();
}

static void wrap_tree(Object3D *o)
{
    switch (obj_kind(o)) {
    case OBJ_GROUP:
        for (int i = 0; i < group_count(o); i++)
            wrap_tree((Object3D *)group_child(o, i));
        break;
    case OBJ_TRANSFORM:
        wrap_tree((Object3D *)transform_child(o));
        break;
    default:
        wrap(o);
        break;
    }
}

/* ---- rays ---- */

typedef struct TestRay {
    Ray ray;
    float tmin;
} TestRay;

static TestRay random_ray(const RScene *r, const Grid *g)
{
    TestRay tr;
    tr.tmin = 0.0f;
    BBox b = grid_bounds(g);
    int n[3];
    grid_dims(g, n);
    Vec3 target;
    switch (irand(4)) {
    case 0: /* aim at a point on a cell border plane */
        target = v3(frand(b.min.x, b.max.x), frand(b.min.y, b.max.y), frand(b.min.z, b.max.z));
        {
            int a = irand(3);
            float lo = v3_comp(b.min, a), hi = v3_comp(b.max, a);
            float s = (hi - lo) / (float)n[a];
            float v = lo + (float)irand(n[a] + 1) * s;
            if (a == 0) target.x = v; else if (a == 1) target.y = v; else target.z = v;
        }
        break;
    case 1: /* aim at a mesh vertex (shared by several triangles) */
        target = r->num_vertices ? r->vertices[irand(r->num_vertices)] : vrand(-2, 2);
        break;
    default:
        target = vrand(-2.5f, 2.5f);
        break;
    }
    Vec3 o = vrand(-6, 6);
    if (irand(8) == 0) {
        /* Axis-parallel ray. Its other two components are +0, -0 or +-1e-39 (a
         * subnormal whose reciprocal overflows to infinity): every march takes such an
         * axis as parallel (march_init: d == 0 or 1 / d not finite; the lean marches:
         * 1 / d not finite), and check_same_march holds them to each other. */
        int a = irand(3);
        const float tiny[3] = {0.0f, -0.0f, 1e-39f};
        float o0 = tiny[irand(3)], o1 = tiny[irand(3)];
        o0 = irand(2) ? o0 : -o0;
        o1 = irand(2) ? o1 : -o1;
        const float other[2] = {o0, o1};
        float s = irand(2) ? 1.0f : -1.0f, c[3];
        for (int k = 0, j = 0; k < 3; k++)
            c[k] = k == a ? s : other[j++];
        Vec3 d = v3(c[0], c[1], c[2]);
        tr.ray.origin = v3_sub(target, v3_scale(d, 6));
        tr.ray.dir = d;
        return tr;
    }
    Vec3 d = v3_sub(target, o);
    if (irand(3))
        d = v3_normalize(d);
    tr.ray.origin = o;
    tr.ray.dir = d;
    int k = irand(6);
    if (k == 0)
        tr.tmin = -INFINITY; /* orthographic camera */
    else if (k == 1)
        tr.tmin = frand(0, 0.5f);
    return tr;
}

static bool same_hit(const Hit *a, const Hit *b)
{
    return a->t == b->t && a->id == b->id && a->material == b->material &&
           a->normal.x == b->normal.x && a->normal.y == b->normal.y &&
           a->normal.z == b->normal.z;
}

typedef struct RunTotals {
    long rays, hits, occl, grid_tests, brute_tests, repeats_seen;
} RunTotals;

/* A render context for grid g: its mailbox, and the packet walk's per-primitive stamps
 * when packets are traced. Freed by grid_test_ctx_free. */
static void grid_test_ctx(RenderCtx *ctx, const Grid *g, bool packets)
{
    memset(ctx, 0, sizeof *ctx);
    ctx->num_mailbox = grid_mailbox_size(g);
    ctx->mailbox = calloc(ctx->num_mailbox + 1, sizeof *ctx->mailbox);
    if (packets)
        ctx->packet_rays = calloc(ctx->num_mailbox + 1, sizeof *ctx->packet_rays);
}

static void grid_test_ctx_free(RenderCtx *ctx)
{
    free(ctx->packet_rays);
    free(ctx->mailbox);
}

/* The cast marches on its own when no ray tree is recorded (grid_cast.c) and through
 * march_init/march_next when one is: both must visit the same cells and make the same
 * tests, so -stats counts and answers do not depend on the preview. Runs the query
 * again with a tree (sharing ctx's mailbox and stamps) and compares with ctx's delta. */
static RayTree probe_tree;

static void check_same_march(const Grid *g, RenderCtx *ctx, const RtStats *before,
                             const TestRay *tr, float tmax, bool occl, bool found,
                             const Hit *h)
{
    RenderCtx t = *ctx;
    memset(&t.stats, 0, sizeof t.stats);
    ray_tree_clear(&probe_tree);
    t.tree = &probe_tree;
    Hit ht = hit_none();
    bool ft = occl ? grid_occluded(g, &tr->ray, tr->tmin, tmax, &t)
                   : grid_intersect(g, &tr->ray, &ht, tr->tmin, &t);
    ctx->ray_stamp = t.ray_stamp;
    CHECK_MSG(ft == found, "%s with a ray tree: %d, without %d", occl ? "occluded" : "hit",
              ft, found);
    if (!occl && ft && found)
        CHECK_MSG(memcmp(&ht.t, &h->t, sizeof ht.t) == 0 && ht.id == h->id,
                  "hit with a ray tree t=%.9g id=%u, without t=%.9g id=%u", (double)ht.t,
                  ht.id, (double)h->t, h->id);
    CHECK_MSG(t.stats.cells_traversed == ctx->stats.cells_traversed - before->cells_traversed,
              "cells with a ray tree %llu, without %llu",
              (unsigned long long)t.stats.cells_traversed,
              (unsigned long long)(ctx->stats.cells_traversed - before->cells_traversed));
    CHECK(t.stats.intersections == ctx->stats.intersections - before->intersections);
    CHECK(t.stats.mailbox_skips == ctx->stats.mailbox_skips - before->mailbox_skips);
}

/* One ray: grid vs brute force, marking checked through the wrapper counts. */
static void check_ray(const RScene *r, const Grid *g, RenderCtx *ctx, const TestRay *tr,
                      RunTotals *tot, Hit *brute_out)
{
    uint32_t np = r->s.num_primitives;
    memset(test_counts, 0, np * sizeof *test_counts);
    Hit hg = hit_none();
    uint64_t rep0 = ctx->stats.repeat_tests;
    RtStats before = ctx->stats;
    bool fg = grid_intersect(g, &tr->ray, &hg, tr->tmin, ctx);
    long repeats = 0, tested = 0;
    for (uint32_t i = 0; i < np; i++) {
        tested += test_counts[i];
        if (test_counts[i] > 1)
            repeats += test_counts[i] - 1;
    }
    tot->grid_tests += tested;
    tot->repeats_seen += repeats;
    /* The wrapper sees every test only when packed triangles go through their ops. */
    if (grid_packing(g))
        ;
    else if (grid_marking(g))
        CHECK_MSG(repeats == 0, "marking on, but %ld repeated primitive tests", repeats);
    else if (ctx->mailbox)
        /* The tests in cells beyond a face of the box (the march's band: lean_next_band
         * in src/accel/grid_cast.c) are left out of the counters, so they may hold
         * fewer repeats than the wrapper sees, never more. */
        CHECK(ctx->stats.repeat_tests - rep0 <= (uint64_t)repeats);
    check_same_march(g, ctx, &before, tr, 0.0f, false, fg, &hg);

    memset(test_counts, 0, np * sizeof *test_counts);
    Hit hb = hit_none();
    RenderCtx bctx;
    memset(&bctx, 0, sizeof bctx);
    bool fb = obj_intersect(r->s.root, &tr->ray, &hb, tr->tmin, &bctx);
    tot->brute_tests += (long)bctx.stats.intersections;
    tot->rays++;
    CHECK_MSG(fg == fb && (!fb || same_hit(&hg, &hb)),
              "ray o=(%.9g,%.9g,%.9g) d=(%.9g,%.9g,%.9g) tmin=%g: grid %d t=%.9g id=%u, "
              "brute %d t=%.9g id=%u",
              (double)tr->ray.origin.x, (double)tr->ray.origin.y, (double)tr->ray.origin.z,
              (double)tr->ray.dir.x, (double)tr->ray.dir.y, (double)tr->ray.dir.z,
              (double)tr->tmin, fg, (double)hg.t, hg.id, fb, (double)hb.t, hb.id);
    if (fb)
        tot->hits++;
    *brute_out = hb;
    if (!fb)
        brute_out->t = INFINITY;

    /* Occlusion up to a random distance (sometimes exactly the nearest hit's t: the
     * hit itself must then not count, t < tmax is strict). */
    float tmax = fb && irand(3) == 0 ? hb.t : frand(0.0f, 12.0f);
    float tmin = isfinite(tr->tmin) ? tr->tmin : 0.0f;
    Hit ho = hit_none();
    ho.t = tmax;
    ho.id = 0;
    memset(&bctx, 0, sizeof bctx);
    bool ob = obj_intersect(r->s.root, &tr->ray, &ho, tmin, &bctx);
    before = ctx->stats;
    bool og = grid_occluded(g, &tr->ray, tmin, tmax, ctx);
    TestRay to = *tr;
    to.tmin = tmin;
    check_same_march(g, ctx, &before, &to, tmax, true, og, NULL);
    CHECK_MSG(ob == og, "occlusion to %.9g: grid %d, brute %d", (double)tmax, og, ob);
    tot->occl += ob;
}

/* ---- packets ---- */

/* One packet of n rays sharing tmin: grid_intersect_packet and grid_occluded_packet
 * must give every ray exactly the brute-force answer. */
static void check_packet(const RScene *r, const Grid *g, RenderCtx *ctx, const Ray *rays,
                         int n, float tmin, const float *tmax, RunTotals *tot)
{
    Hit hits[GRID_PACKET_MAX];
    for (int i = 0; i < n; i++)
        hits[i] = hit_none();
    uint64_t found = grid_intersect_packet(g, rays, n, hits, tmin, ctx);
    uint64_t mask = 0;
    for (int i = 0; i < n; i++)
        if (irand(5))
            mask |= (uint64_t)1 << i;
    uint64_t occl = grid_occluded_packet(g, rays, mask, tmin, tmax, ctx);
    for (int i = 0; i < n; i++) {
        RenderCtx bctx;
        memset(&bctx, 0, sizeof bctx);
        Hit hb = hit_none();
        bool fb = obj_intersect(r->s.root, &rays[i], &hb, tmin, &bctx);
        bool fg = (found >> i) & 1;
        tot->rays++;
        tot->hits += fb;
        CHECK_MSG(fg == fb && (!fb || same_hit(&hits[i], &hb)),
                  "packet ray %d/%d o=(%.9g,%.9g,%.9g) d=(%.9g,%.9g,%.9g) tmin=%g: packet %d "
                  "t=%.9g id=%u, brute %d t=%.9g id=%u", i, n, (double)rays[i].origin.x,
                  (double)rays[i].origin.y, (double)rays[i].origin.z, (double)rays[i].dir.x,
                  (double)rays[i].dir.y, (double)rays[i].dir.z, (double)tmin, fg,
                  (double)hits[i].t, hits[i].id, fb, (double)hb.t, hb.id);
        Hit ho = hit_none();
        ho.t = tmax[i];
        ho.id = 0;
        bool ob = (mask >> i & 1) && obj_intersect(r->s.root, &rays[i], &ho, tmin, &bctx);
        bool og = (occl >> i) & 1;
        CHECK_MSG(ob == og, "packet ray %d/%d: occlusion to %.9g: packet %d, brute %d", i, n,
                  (double)tmax[i], og, ob);
        tot->occl += ob;
    }
}

/* Shadow rays towards a directional light through grid_occluded_packet_dir: every answer
 * as grid_occluded_packet gives with the direction and tmax written into each ray, and
 * the same cells (the packet's axis and walk must be the ones its summed directions
 * choose). The rays' own directions are NaN for the _dir call: it must not read them.
 * Its triangle tests are those of the rays' packet less the ones its beam cull drops
 * (pk_cull_beam: no more, and the answers the same); the marks it skips may be fewer. */
static long dir_tests, dir_ray_tests; /* the triangle tests of the two, summed */
static void check_packet_dir(const Grid *g, RenderCtx *ctx, Ray *rays, int n, Vec3 dir,
                             float tmax1)
{
    float tmax[GRID_PACKET_MAX] = {0.0f};
    uint64_t mask = 0;
    for (int i = 0; i < n; i++) {
        rays[i].dir = dir;
        tmax[i] = tmax1;
        if (irand(6))
            mask |= (uint64_t)1 << i;
    }
    RtStats s0 = ctx->stats;
    uint64_t a = grid_occluded_packet(g, rays, mask, 1e-3f, tmax, ctx);
    RtStats s1 = ctx->stats;
    for (int i = 0; i < n; i++)
        rays[i].dir = v3(NAN, NAN, NAN);
    uint64_t b = grid_occluded_packet_dir(g, rays, mask, 1e-3f, tmax1, dir, ctx);
    RtStats s2 = ctx->stats;
    dir_tests += (long)(s2.intersections - s1.intersections);
    dir_ray_tests += (long)(s1.intersections - s0.intersections);
    CHECK_MSG(a == b, "directional packet d=(%.9g,%.9g,%.9g) n=%d tmax=%g: occluded %llx, by "
              "rays %llx", (double)dir.x, (double)dir.y, (double)dir.z, n, (double)tmax1,
              (unsigned long long)b, (unsigned long long)a);
    CHECK_MSG(s2.intersections - s1.intersections <= s1.intersections - s0.intersections &&
                  s2.cells_traversed - s1.cells_traversed ==
                      s1.cells_traversed - s0.cells_traversed,
              "directional packet d=(%.9g,%.9g,%.9g) n=%d: tests %llu, by rays %llu; cells "
              "%llu, by rays %llu", (double)dir.x, (double)dir.y, (double)dir.z, n,
              (unsigned long long)(s2.intersections - s1.intersections),
              (unsigned long long)(s1.intersections - s0.intersections),
              (unsigned long long)(s2.cells_traversed - s1.cells_traversed),
              (unsigned long long)(s1.cells_traversed - s0.cells_traversed));
}

/* A direction whose two largest components are equal in magnitude or a few units in
 * the last place apart (where rounding in the sums could decide the packet's axis),
 * else a random one. */
static Vec3 tie_dir(void)
{
    if (irand(3) == 0)
        return unit_rand();
    float c[3];
    float big = frand(0.3f, 0.7f);
    int a = irand(3), b = (a + 1 + irand(2)) % 3;
    c[a] = big;
    c[b] = nextafterf(big, irand(2) ? 1.0f : 0.0f);
    for (int k = irand(4); k > 0; k--)
        c[b] = nextafterf(c[b], irand(2) ? 1.0f : 0.0f);
    if (irand(3) == 0)
        c[b] = big * (1.0f + 1e-4f * (float)(irand(5) - 2));
    c[3 - a - b] = frand(-0.9f, 0.9f) * big;
    for (int k = 0; k < 3; k++)
        if (irand(2))
            c[k] = -c[k];
    return v3(c[0], c[1], c[2]);
}

/* Camera-like packets (one origin, directions through a window of random width, so
 * some are split and some not), random incoherent ones, and shadow-like ones from their
 * hit points towards a directional or a point light. */
static void check_packets(const RScene *r, const Grid *g, RenderCtx *ctx, int count,
                          RunTotals *tot)
{
    Ray rays[GRID_PACKET_MAX];
    float tmax[GRID_PACKET_MAX];
    for (int p = 0; p < count; p++) {
        int n = irand(4) ? GRID_PACKET_MAX : 1 + irand(GRID_PACKET_MAX);
        int kind = irand(3);
        Vec3 o = vrand(-6, 6), target = vrand(-2, 2);
        Vec3 w = unit_rand();
        Vec3 a = v3_normalize(v3_cross(w, v3(0.3f, 1, 0.1f))), b = v3_cross(w, a);
        float width = irand(2) ? frand(0.0f, 0.05f) : frand(0.0f, 1.0f);
        for (int i = 0; i < n; i++) {
            if (kind == 2) {
                TestRay tr = random_ray(r, g);
                rays[i] = tr.ray;
            } else {
                /* Z order over an 8x8 window, as the renderer lays out a tile. */
                int x = 0, y = 0;
                for (int bit = 0; bit < 3; bit++) {
                    x |= ((i >> (2 * bit)) & 1) << bit;
                    y |= ((i >> (2 * bit + 1)) & 1) << bit;
                }
                Vec3 t = v3_add(target, v3_add(v3_scale(a, width * (float)x / 8.0f),
                                               v3_scale(b, width * (float)y / 8.0f)));
                rays[i].origin = o;
                rays[i].dir = v3_normalize(v3_sub(t, o));
                if (kind == 1 && irand(8) == 0)
                    rays[i].dir = v3_neg(rays[i].dir); /* a stray ray going the other way */
            }
            tmax[i] = irand(2) ? INFINITY : frand(0.0f, 12.0f);
        }
        float tmin = irand(2) ? 0.0f : 1e-3f;
        check_packet(r, g, ctx, rays, n, tmin, tmax, tot);

        /* Shadow-like: from each hit towards one light. */
        Ray srays[GRID_PACKET_MAX];
        Hit hits[GRID_PACKET_MAX];
        for (int i = 0; i < n; i++)
            hits[i] = hit_none();
        uint64_t found = grid_intersect_packet(g, rays, n, hits, tmin, ctx);
        Vec3 ldir = unit_rand(), lpos = vrand(-5, 5);
        bool point = irand(2);
        int m = 0;
        for (int i = 0; i < n; i++) {
            if (!(found >> i & 1) || !isfinite(hits[i].t))
                continue;
            srays[m].origin = ray_at(&rays[i], hits[i].t);
            Vec3 to = v3_sub(lpos, srays[m].origin);
            srays[m].dir = point ? v3_normalize(to) : ldir;
            tmax[m] = point ? v3_length(to) : INFINITY;
            m++;
        }
        if (m)
            check_packet(r, g, ctx, srays, m, 1e-3f, tmax, tot);
        if (m >= 2) /* the same points towards a directional light */
            check_packet_dir(g, ctx, srays, m, tie_dir(), irand(2) ? INFINITY : frand(0.0f, 8.0f));
    }
}

static void run_scene(int seed, int objects, int planes, int rays, bool marking,
                      RunTotals *tot)
{
    rng_state = (uint64_t)seed * 7919u + 17u;
    RScene r;
    rscene_make(&r, objects, planes);
    wrap_tree(r.s.root);
    num_counted = r.s.num_primitives;
    test_counts = calloc(num_counted + 1, sizeof *test_counts);
    static const int res[][3] = {{1, 1, 1}, {3, 5, 2}, {8, 8, 8}, {17, 9, 23}, {48, 48, 48}};
    for (size_t rp = 0; rp < 2 * sizeof res / sizeof res[0]; rp++) {
        size_t ri = rp / 2;
        bool packing = rp % 2 == 0; /* packed triangles inline, then all through ops */
        Diag d;
        diag_init(&d, stderr);
        Grid *g = grid_build(&r.s, res[ri][0], res[ri][1], res[ri][2], &d);
        if (bbox_is_empty(&r.s.bounds)) {
            CHECK(g == NULL);
            continue;
        }
        CHECK(g != NULL);
        if (!g)
            continue;
        grid_set_marking(g, marking);
        grid_set_packing(g, packing);
        RenderCtx ctx;
        grid_test_ctx(&ctx, g, true);
        /* Start near the wrap-around of the stamps: it must clear and go on. */
        ctx.ray_stamp = UINT32_MAX - 5;
        for (int i = 0; i < rays; i++) {
            TestRay tr = random_ray(&r, g);
            Hit hb;
            check_ray(&r, g, &ctx, &tr, tot, &hb);
            /* Secondary rays from the hit point, like reflection/shadow rays. */
            if (isfinite(hb.t) && irand(2)) {
                TestRay s;
                s.ray.origin = ray_at(&tr.ray, hb.t);
                s.ray.dir = irand(2) ? unit_rand() : v3_neg(tr.ray.dir);
                s.tmin = 1e-3f;
                Hit h2;
                check_ray(&r, g, &ctx, &s, tot, &h2);
            }
        }
        if (marking)
            CHECK_INT(ctx.stats.repeat_tests, 0);
        /* Every kernel the CPU has; the generic one is the fallback. */
        static const char *const kernels[] = {"generic", "avx2", "avx512", "avx512x8"};
        static bool said_no[4];
        const char *default_kernel = grid_packet_kernel();
        for (int k = 0; k < 4; k++) {
            /* The AVX-512 kernels draw their packets from a copy of the generator, so
             * the rays of everything after them stay the same on every CPU. */
            uint64_t saved = rng_state;
            if (grid_packet_use_kernel(kernels[k])) {
                check_packets(&r, g, &ctx, rays / 20, tot);
                if (k >= 2)
                    rng_state = saved;
            } else {
                CHECK_MSG(k != 0, "the generic packet kernel must always be usable");
                if (!said_no[k])
                    printf("    skipped: the %s packet kernel (this CPU lacks it); the "
                           "others are tested\n", kernels[k]);
                said_no[k] = true;
            }
        }
        CHECK(grid_packet_use_kernel(default_kernel));
        if (marking)
            CHECK_INT(ctx.stats.repeat_tests, 0);
        grid_test_ctx_free(&ctx);
        grid_free(g);
    }
    free(test_counts);
    test_counts = NULL;
    arena_free(&r.s.arena);
}

static void test_random_scenes_marking_on(void)
{
    RunTotals tot = {0};
    for (int seed = 1; seed <= 12; seed++)
        run_scene(seed, 4 + seed * 3, seed % 3, 400, true, &tot);
    printf("    %ld rays, %ld hits, %ld occluded; tests grid %ld vs brute %ld\n", tot.rays,
           tot.hits, tot.occl, tot.grid_tests, tot.brute_tests);
    CHECK(tot.rays > 10000);
    CHECK(tot.hits > tot.rays / 10); /* the rays do hit things */
    CHECK(tot.grid_tests < tot.brute_tests);
}

static void test_random_scenes_marking_off(void)
{
    RunTotals tot = {0};
    for (int seed = 100; seed < 106; seed++)
        run_scene(seed, 20, 1, 300, false, &tot);
    printf("    %ld rays, %ld repeated tests without marking\n", tot.rays, tot.repeats_seen);
    CHECK(tot.repeats_seen > 0); /* big primitives do span several cells */
}

/* Without a mailbox (NULL) the march still answers exactly. */
static void test_no_mailbox(void)
{
    rng_state = 4242;
    RScene r;
    rscene_make(&r, 25, 1);
    Diag d;
    diag_init(&d, stderr);
    Grid *g = grid_build(&r.s, 12, 12, 12, &d);
    CHECK(g != NULL);
    if (g) {
        RenderCtx ctx;
        memset(&ctx, 0, sizeof ctx);
        for (int i = 0; i < 2000; i++) {
            TestRay tr = random_ray(&r, g);
            Hit hg = hit_none(), hb = hit_none();
            RenderCtx bctx;
            memset(&bctx, 0, sizeof bctx);
            bool fg = grid_intersect(g, &tr.ray, &hg, tr.tmin, &ctx);
            bool fb = obj_intersect(r.s.root, &tr.ray, &hb, tr.tmin, &bctx);
            CHECK(fg == fb && (!fb || same_hit(&hg, &hb)));
        }
        CHECK_INT(ctx.stats.mailbox_skips, 0);
        grid_free(g);
    }
    arena_free(&r.s.arena);
}

/* The tile order the packets rely on (rt/render.h): Morton order, i.e. a bijection
 * onto the tile in which every quarter of the order is a quarter of the tile (the
 * packet walk splits a wide packet that way). Checked against the bit interleaving
 * written out bit by bit. */
static void test_tile_order(void)
{
    bool seen[RENDER_TILE][RENDER_TILE] = {{false}};
    for (int k = 0; k < RENDER_TILE * RENDER_TILE; k++) {
        int dx = -1, dy = -1, x = 0, y = 0;
        render_tile_order(k, &dx, &dy);
        for (int b = 0; (1 << (2 * b)) < RENDER_TILE * RENDER_TILE; b++) {
            x |= ((k >> (2 * b)) & 1) << b;
            y |= ((k >> (2 * b + 1)) & 1) << b;
        }
        CHECK_MSG(dx == x && dy == y, "k=%d: (%d,%d), expected (%d,%d)", k, dx, dy, x, y);
        if (dx < 0 || dx >= RENDER_TILE || dy < 0 || dy >= RENDER_TILE)
            continue;
        CHECK(!seen[dy][dx]);
        seen[dy][dx] = true;
        int q = k / (RENDER_TILE * RENDER_TILE / 4), h = RENDER_TILE / 2;
        CHECK_INT(dx / h + 2 * (dy / h), q);
    }
}

/* A positive tmin is a distance in the space of the leaf hit (Transform): a triangle
 * under a Transform scaling by 0.25, 0.1 ahead of the ray's origin, is hit with
 * tmin = 0.3 (0.075 in its own units). The grid must not start its march at the world
 * tmin, beyond the cells holding that triangle: its answers, single and packet, nearest
 * and shadow, are the brute-force walk's. */
static void test_shrinking_transform_tmin(void)
{
    Scene s;
    memset(&s, 0, sizeof s);
    arena_init(&s.arena);
    PhongParams pp = phong_defaults();
    Material *m = phong_new(&s.arena, &pp);
    Object3D *inner = group_new(&s.arena, 1);
    group_set_child(inner, 0, triangle_new(&s.arena, v3(-1, -1, -1), v3(1, -1, -1),
                                           v3(0, 1, -1), m));
    group_finish(inner);
    Mat4 sc = mat4_scale(v3(0.25f, 0.25f, 0.25f));
    Object3D *root = group_new(&s.arena, 2);
    group_set_child(root, 0, transform_new(&s.arena, &sc, inner));
    group_set_child(root, 1, sphere_new(&s.arena, v3(0, 0, 5), 1.0f, m));
    group_finish(root);
    s.root = root;
    s.num_primitives = group_assign_ids(root);
    s.bounds = root->bbox;

    Ray rays[8];
    for (int i = 0; i < 8; i++) {
        rays[i].origin = v3(-0.04f + 0.01f * (float)i, 0.0f, -0.35f);
        rays[i].dir = v3(0, 0, 1);
    }
    const float tmin = 0.3f;
    RenderCtx bctx;
    memset(&bctx, 0, sizeof bctx);
    Hit hb = hit_none();
    CHECK(obj_intersect(s.root, &rays[0], &hb, tmin, &bctx));
    CHECK_MSG(fabsf(hb.t - 0.1f) < 1e-5f && hb.id == 0, "brute force: t=%g id=%u",
              (double)hb.t, hb.id);

    Diag d;
    diag_init(&d, stderr);
    Grid *g = grid_build(&s, 1, 1, 60, &d);
    CHECK(g != NULL);
    if (g) {
        RenderCtx ctx;
        grid_test_ctx(&ctx, g, true);
        float tmax[8];
        for (int i = 0; i < 8; i++)
            tmax[i] = 1.0f;
        for (int packing = 0; packing < 2; packing++) {
            grid_set_packing(g, packing);
            Hit hg = hit_none();
            bool fg = grid_intersect(g, &rays[0], &hg, tmin, &ctx);
            CHECK_MSG(fg && same_hit(&hg, &hb), "grid: %d t=%g id=%u", fg, (double)hg.t,
                      hg.id);
            CHECK(grid_occluded(g, &rays[0], tmin, 0.2f, &ctx));
            Hit hits[8];
            for (int i = 0; i < 8; i++)
                hits[i] = hit_none();
            uint64_t found = grid_intersect_packet(g, rays, 8, hits, tmin, &ctx);
            uint64_t occl = grid_occluded_packet(g, rays, 0xff, tmin, tmax, &ctx);
            for (int i = 0; i < 8; i++) {
                Hit h = hit_none();
                memset(&bctx, 0, sizeof bctx);
                bool fb = obj_intersect(s.root, &rays[i], &h, tmin, &bctx);
                CHECK(fb);
                CHECK_MSG((found >> i & 1) && same_hit(&hits[i], &h),
                          "packet ray %d: t=%g id=%u", i, (double)hits[i].t, hits[i].id);
                CHECK_MSG(occl >> i & 1, "packet ray %d: not occluded", i);
            }
        }
        grid_test_ctx_free(&ctx);
        grid_free(g);
    }
    arena_free(&s.arena);
}

/* Rays along lattice diagonals of a cubic grid whose cells are exact binary fractions:
 * their boundary crossings tie on two or three axes at once at every step, where the
 * march's rule (ties to x, then y) decides which neighbour comes first. The cast's own
 * march (no ray tree) must take the same cells as march_init/march_next, so every ray's
 * cells, tests and hit are compared with and without a ray tree over a soup of small
 * triangles that fills the cells unevenly (a different neighbour, other tests). */
static void test_lattice_ties(void)
{
    rng_state = 4242u;
    Scene s;
    memset(&s, 0, sizeof s);
    arena_init(&s.arena);
    PhongParams pp = phong_defaults();
    Material *m = phong_new(&s.arena, &pp);
    enum { TRIS = 600 };
    Object3D *root = group_new(&s.arena, TRIS + 2);
    /* Two specks pin the box to [-2, 2]^3: cells of 0.5 on an 8^3 grid. */
    group_set_child(root, 0, triangle_new(&s.arena, v3(-2, -2, -2), v3(-1.99f, -2, -2),
                                          v3(-2, -1.99f, -2), m));
    group_set_child(root, 1, triangle_new(&s.arena, v3(2, 2, 2), v3(1.99f, 2, 2),
                                          v3(2, 1.99f, 2), m));
    for (int i = 0; i < TRIS; i++) {
        Vec3 c = vrand(-1.9f, 1.9f);
        group_set_child(root, i + 2, triangle_new(&s.arena, v3_add(c, vrand(-0.1f, 0.1f)),
                                                  v3_add(c, vrand(-0.1f, 0.1f)),
                                                  v3_add(c, vrand(-0.1f, 0.1f)), m));
    }
    group_finish(root);
    s.root = root;
    s.num_primitives = group_assign_ids(root);
    s.bounds = root->bbox;
    Diag d;
    diag_init(&d, stderr);
    Grid *g = grid_build(&s, 8, 8, 8, &d);
    CHECK(g != NULL);
    if (g) {
        RenderCtx ctx;
        grid_test_ctx(&ctx, g, false);
        long rays = 0;
        for (int i = 0; i < 2000; i++) {
            TestRay tr;
            /* A lattice point (inside or on the box), a direction of +-1 or 0 per axis
             * (at least two non-zero) scaled by 1 or 0.5: exact inverses. */
            tr.ray.origin = v3(-2.0f + 0.5f * (float)irand(9), -2.0f + 0.5f * (float)irand(9),
                               -2.0f + 0.5f * (float)irand(9));
            float dc[3];
            int nonzero;
            do {
                nonzero = 0;
                for (int a = 0; a < 3; a++) {
                    dc[a] = (float)(irand(3) - 1);
                    nonzero += dc[a] != 0.0f;
                }
            } while (nonzero < 2);
            float sc = irand(2) ? 1.0f : 0.5f;
            tr.ray.dir = v3(dc[0] * sc, dc[1] * sc, dc[2] * sc);
            tr.tmin = irand(2) ? 0.0f : 1e-3f;
            float tmax = 2.0f + (float)irand(8);
            /* With the occupancy bits (empty cells skipped by a bit) and without them
             * (what grid_occupancy_make leaves when out of memory). */
            uint64_t *bits = g->occupied;
            for (int use_bits = 0; use_bits < 2; use_bits++)
                for (int occl = 0; occl < 2; occl++) {
                    g->occupied = use_bits ? bits : NULL;
                    RtStats before = ctx.stats;
                    Hit h = hit_none();
                    bool f = occl ? grid_occluded(g, &tr.ray, tr.tmin, tmax, &ctx)
                                  : grid_intersect(g, &tr.ray, &h, tr.tmin, &ctx);
                    g->occupied = bits;
                    check_same_march(g, &ctx, &before, &tr, tmax, occl, f, &h);
                    rays++;
                }
        }
        CHECK(g->occupied != NULL); /* the bits were exercised */
        CHECK(rays == 8000);
        grid_test_ctx_free(&ctx);
        grid_free(g);
    }
    arena_free(&s.arena);
}

/* The group loop (test_groups: every entry a packed triangle, g->all_tri) against the
 * batch loop it replaces (all_tri cleared) and the brute-force walk, on all-triangle
 * scenes (separate triangles, meshes with shared edges and vertices, triangles on cell
 * border planes, a cluster of many small ones so cells hold 1 to 20 entries): every
 * nearest hit (bits) and occlusion, and the -stats counts (intersections, cells
 * traversed) of each query, in both copies of the single-ray queries (baseline and, on
 * an AVX2 CPU, AVX2), with marking on and off and without a mailbox. */
static Object3D *tri_leaf(RScene *r)
{
    Arena *a = &r->s.arena;
    const Material *m = r->mats[irand(4)];
    int choice = irand(6);
    if (choice == 0)
        return random_mesh(r, true);
    if (choice == 1) {
        float y = (float)irand(5) * 0.5f - 1.0f;
        Vec3 c = vrand(-2, 2);
        return triangle_new(a, v3(c.x, y, c.z), v3(c.x + 1, y, c.z), v3(c.x, y, c.z + 1), m);
    }
    Vec3 c = choice == 2 ? vrand(-0.5f, 0.5f) : vrand(-2, 2);
    float sz = choice == 2 ? frand(0.02f, 0.2f) : frand(0.1f, 1.5f);
    return triangle_new(a, v3_add(c, vrand(-sz, sz)), v3_add(c, vrand(-sz, sz)),
                        v3_add(c, vrand(-sz, sz)), m);
}

static void tri_scene(RScene *r, int num_objects)
{
    memset(r, 0, sizeof *r);
    arena_init(&r->s.arena);
    for (int i = 0; i < 4; i++) {
        PhongParams p = phong_defaults();
        p.diffuse = vrand(0, 1);
        r->mats[i] = phong_new(&r->s.arena, &p);
    }
    Object3D *root = group_new(&r->s.arena, num_objects);
    for (int i = 0; i < num_objects; i++)
        group_set_child(root, i, tri_leaf(r));
    group_finish(root);
    r->s.root = root;
    r->s.num_primitives = group_assign_ids(root);
    r->s.bounds = root->bounded ? root->bbox : bbox_empty();
}

/* One query with the group loop or the batch loop, in cast path copy `path`. */
static bool groups_query(Grid *g, RenderCtx *ctx, bool groups, int path, const TestRay *tr,
                         float tmax, bool occl, Hit *h, RtStats *delta)
{
    bool saved = g->all_tri;
    g->all_tri = groups && saved;
    grid_cast_path_set(path);
    RtStats before = ctx->stats;
    *h = hit_none();
    bool f = occl ? grid_occluded(g, &tr->ray, tr->tmin, tmax, ctx)
                  : grid_intersect(g, &tr->ray, h, tr->tmin, ctx);
    delta->intersections = ctx->stats.intersections - before.intersections;
    delta->cells_traversed = ctx->stats.cells_traversed - before.cells_traversed;
    grid_cast_path_set(1);
    g->all_tri = saved;
    return f;
}

static void test_group_loop(void)
{
    long queries = 0, groups_used = 0, hits = 0, occluded = 0;
    for (int seed = 1; seed <= 10; seed++) {
        rng_state = (uint64_t)seed * 104729u + 5u;
        RScene r;
        tri_scene(&r, 30 + 25 * seed);
        static const int res[][3] = {{1, 1, 1}, {4, 7, 3}, {12, 12, 12}, {31, 17, 26}};
        for (size_t ri = 0; ri < sizeof res / sizeof res[0]; ri++) {
            Diag d;
            diag_init(&d, stderr);
            Grid *g = grid_build(&r.s, res[ri][0], res[ri][1], res[ri][2], &d);
            CHECK(g != NULL);
            if (!g)
                continue;
            CHECK_MSG(g->all_tri, "an all-triangle scene's grid must take the group loop");
            groups_used += g->all_tri;
            for (int mode = 0; mode < 3; mode++) { /* marking, no marking, no mailbox */
                grid_set_marking(g, mode != 1);
                RenderCtx ctx;
                grid_test_ctx(&ctx, g, false);
                if (mode == 2) {
                    free(ctx.mailbox);
                    ctx.mailbox = NULL;
                }
                for (int i = 0; i < 300; i++) {
                    TestRay tr = random_ray(&r, g);
                    for (int occl = 0; occl < 2; occl++) {
                        float tmax = frand(0.0f, 12.0f);
                        if (occl && !isfinite(tr.tmin))
                            tr.tmin = 0.0f;
                        Hit hb = hit_none();
                        hb.t = occl ? tmax : INFINITY;
                        hb.id = 0;
                        RenderCtx bctx;
                        memset(&bctx, 0, sizeof bctx);
                        bool fb = obj_intersect(r.s.root, &tr.ray, &hb, tr.tmin, &bctx);
                        Hit href;
                        RtStats sref;
                        bool fref = groups_query(g, &ctx, false, 0, &tr, tmax, occl, &href,
                                                 &sref);
                        CHECK(fref == fb && (occl || !fb || same_hit(&href, &hb)));
                        for (int path = 0; path < 2; path++) {
                            Hit hq;
                            RtStats sq;
                            bool fq = groups_query(g, &ctx, true, path, &tr, tmax, occl, &hq,
                                                   &sq);
                            CHECK_MSG(fq == fref && (occl || !fq || same_hit(&hq, &href)),
                                      "groups (path %d) %s: %d t=%.9g id=%u, batches %d "
                                      "t=%.9g id=%u",
                                      path, occl ? "occluded" : "hit", fq, (double)hq.t, hq.id,
                                      fref, (double)href.t, href.id);
                            CHECK_MSG(sq.intersections == sref.intersections &&
                                          sq.cells_traversed == sref.cells_traversed,
                                      "groups (path %d, mode %d) %s: %llu tests %llu cells, "
                                      "batches %llu tests %llu cells",
                                      path, mode, occl ? "occluded" : "hit",
                                      (unsigned long long)sq.intersections,
                                      (unsigned long long)sq.cells_traversed,
                                      (unsigned long long)sref.intersections,
                                      (unsigned long long)sref.cells_traversed);
                        }
                        queries++;
                        if (fb && occl)
                            occluded++;
                        else if (fb)
                            hits++;
                    }
                }
                grid_test_ctx_free(&ctx);
                ctx.mailbox = NULL;
            }
            grid_free(g);
        }
        arena_free(&r.s.arena);
    }
    printf("    %ld queries (%ld hits, %ld occluded) on %ld all-triangle grids\n", queries,
           hits, occluded, groups_used);
    CHECK(queries == 10L * 4 * 3 * 300 * 2);
    CHECK(hits > queries / 20 && occluded > queries / 20);
}

/* Cells crowded with more packed triangles than the packet walk culls in one batch
 * (PK_BATCH in grid_packet_kernel.h: it culls a batch of a cell's entries, then tests
 * the ones kept), and triangles lying along the light's direction (det 0 towards a
 * directional light, whose packets make the direction's half of each test once per
 * triangle). Every kernel's packets, nearest and shadow, by rays and towards the light,
 * against the brute-force walk (check_packets), and towards +y and -y, which the
 * vertical triangles lie along, ray by ray against brute force. */
static void test_crowded_cells(void)
{
    rng_state = 9090;
    RScene r;
    memset(&r, 0, sizeof r);
    arena_init(&r.s.arena);
    PhongParams pp = phong_defaults();
    for (int i = 0; i < 4; i++)
        r.mats[i] = phong_new(&r.s.arena, &pp);
    enum { NQ = 14, NV = 48, NH = 24 };
    Object3D *root = group_new(&r.s.arena, 2 * NQ * NQ + NV + NH);
    int k = 0;
    /* A height field of 392 triangles in a square 1.4 wide ... */
    for (int i = 0; i < NQ; i++)
        for (int j = 0; j < NQ; j++) {
            Vec3 p[4];
            for (int c = 0; c < 4; c++) {
                int di = c & 1, dj = c >> 1;
                float h = (float)(((i + di) * 7 + (j + dj) * 3) % 5) * 0.04f;
                p[c] = v3(-0.7f + 0.1f * (float)(i + di), h, -0.7f + 0.1f * (float)(j + dj));
            }
            group_set_child(root, k++, triangle_new(&r.s.arena, p[0], p[1], p[3], r.mats[0]));
            group_set_child(root, k++, triangle_new(&r.s.arena, p[0], p[3], p[2], r.mats[1]));
        }
    /* ... and small vertical triangles in planes z = c standing on it: e2 along y. */
    for (int v = 0; v < NV; v++) {
        Vec3 b = v3(frand(-0.7f, 0.5f), frand(0.0f, 0.3f), frand(-0.7f, 0.7f));
        group_set_child(root, k++,
                        triangle_new(&r.s.arena, b, v3(b.x + 0.2f, b.y, b.z),
                                     v3(b.x, b.y + 0.3f, b.z), r.mats[2]));
    }
    /* Horizontal ones above, so that some of the rays towards +y are blocked. */
    for (int h = 0; h < NH; h++) {
        Vec3 b = v3(frand(-0.7f, 0.4f), frand(0.4f, 0.8f), frand(-0.7f, 0.4f));
        group_set_child(root, k++,
                        triangle_new(&r.s.arena, b, v3(b.x + 0.3f, b.y, b.z),
                                     v3(b.x, b.y, b.z + 0.3f), r.mats[3]));
    }
    group_finish(root);
    r.s.root = root;
    r.s.num_primitives = group_assign_ids(root);
    r.s.bounds = root->bbox;

    static const int res[][3] = {{1, 1, 1}, {2, 1, 2}, {3, 2, 3}};
    static const char *const kernels[] = {"generic", "avx2", "avx512", "avx512x8"};
    const char *default_kernel = grid_packet_kernel();
    RunTotals tot = {0};
    long vertical_tests = 0, occluded = 0;
    for (size_t ri = 0; ri < sizeof res / sizeof res[0]; ri++) {
        Diag d;
        diag_init(&d, stderr);
        Grid *g = grid_build(&r.s, res[ri][0], res[ri][1], res[ri][2], &d);
        CHECK(g != NULL);
        if (!g)
            continue;
        RenderCtx ctx;
        grid_test_ctx(&ctx, g, true);
        for (int kk = 0; kk < 4; kk++) {
            if (!grid_packet_use_kernel(kernels[kk]))
                continue;
            check_packets(&r, g, &ctx, 60, &tot);
            /* Points on the surface towards +y and -y. */
            for (int rep = 0; rep < 40; rep++) {
                Ray rays[GRID_PACKET_MAX];
                int n = 2 + irand(GRID_PACKET_MAX - 1);
                Vec3 c = v3(frand(-0.6f, 0.6f), 1.0f, frand(-0.6f, 0.6f));
                float w = frand(0.05f, 0.6f);
                for (int i = 0; i < n; i++) {
                    rays[i].origin = v3(c.x + w * (float)(i % 8) / 8.0f, c.y,
                                        c.z + w * (float)(i / 8) / 8.0f);
                    rays[i].dir = v3(0.0f, -1.0f, 0.0f);
                }
                Hit hits[GRID_PACKET_MAX];
                for (int i = 0; i < n; i++)
                    hits[i] = hit_none();
                uint64_t found = grid_intersect_packet(g, rays, n, hits, 1e-3f, &ctx);
                Ray srays[GRID_PACKET_MAX];
                uint64_t mask = 0;
                for (int i = 0; i < n; i++) {
                    srays[i].origin = (found >> i & 1) ? ray_at(&rays[i], hits[i].t)
                                                       : rays[i].origin;
                    if (irand(6))
                        mask |= (uint64_t)1 << i;
                }
                Vec3 dir = v3(0.0f, irand(2) ? 1.0f : -1.0f, 0.0f);
                float tmax1 = irand(2) ? INFINITY : frand(0.05f, 2.0f);
                uint64_t b = grid_occluded_packet_dir(g, srays, mask, 1e-3f, tmax1, dir, &ctx);
                for (int i = 0; i < n; i++) {
                    if (!(mask >> i & 1)) {
                        CHECK(!(b >> i & 1));
                        continue;
                    }
                    Ray sr = {srays[i].origin, dir};
                    RenderCtx bctx;
                    memset(&bctx, 0, sizeof bctx);
                    Hit ho = hit_none();
                    ho.t = tmax1;
                    ho.id = 0;
                    bool ob = obj_intersect(r.s.root, &sr, &ho, 1e-3f, &bctx);
                    CHECK_MSG(ob == (bool)(b >> i & 1),
                              "%s kernel, grid %dx%dx%d: ray %d/%d from (%.9g,%.9g,%.9g) "
                              "towards y %g: packet %d, brute %d", kernels[kk], res[ri][0],
                              res[ri][1], res[ri][2], i, n, (double)sr.origin.x,
                              (double)sr.origin.y, (double)sr.origin.z, (double)dir.y,
                              (int)(b >> i & 1), ob);
                    occluded += ob;
                    vertical_tests++;
                }
            }
        }
        CHECK(grid_packet_use_kernel(default_kernel));
        grid_test_ctx_free(&ctx);
        grid_free(g);
    }
    printf("    %ld packet rays, %ld occluded; %ld rays along +-y, %ld occluded\n", tot.rays,
           tot.occl, vertical_tests, occluded);
    CHECK(occluded > 0 && occluded < vertical_tests);
    arena_free(&r.s.arena);
}


/* The directional packets' beam cull (pk_cull_beam in grid_packet_kernel.h) at its
 * edges: a fan of small triangles at every tilt, some almost along the light, in grids
 * of 1 to 4x5x3 cells, and packets of rays towards the light aimed at the triangles'
 * edges and corners (offsets from 1e-7 to 1e-2 of a triangle, inside and outside) from
 * near and far along the light, or spread over the fan. Every kernel's answer ray by
 * ray against brute force, and against the same rays' packet without the shared
 * direction (check_packet_dir). It fails with the beam's shear or its sign wrong, a
 * group's range made from the wrong lanes or the box's K sides swapped (each kernel's
 * choice of the K side by the shear's sign, pk_beam_make: generic and AVX2 each broken
 * once), or the AVX2 cull's lanes permuted wrong. */
static void test_beam_edges(void)
{
    rng_state = 4242;
    RScene r;
    memset(&r, 0, sizeof r);
    arena_init(&r.s.arena);
    PhongParams pp = phong_defaults();
    r.mats[0] = phong_new(&r.s.arena, &pp);
    enum { NT = 160 };
    Object3D *root = group_new(&r.s.arena, NT);
    Vec3 tv[NT][3];
    for (int i = 0; i < NT; i++) {
        Vec3 c = vrand(-1, 1);
        float size = irand(3) ? frand(0.01f, 0.08f) : frand(0.1f, 0.5f);
        for (int j = 0; j < 3; j++)
            tv[i][j] = v3_add(c, v3_scale(unit_rand(), size));
        group_set_child(root, i, triangle_new(&r.s.arena, tv[i][0], tv[i][1], tv[i][2],
                                              r.mats[0]));
    }
    group_finish(root);
    r.s.root = root;
    r.s.num_primitives = group_assign_ids(root);
    r.s.bounds = root->bbox;

    static const int res[][3] = {{1, 1, 1}, {4, 5, 3}, {9, 7, 11}};
    static const char *const kernels[] = {"generic", "avx2", "avx512", "avx512x8"};
    const char *default_kernel = grid_packet_kernel();
    long rays_checked = 0, occluded = 0;
    long tests0 = dir_tests, ray_tests0 = dir_ray_tests;
    for (size_t ri = 0; ri < sizeof res / sizeof res[0]; ri++) {
        Diag d;
        diag_init(&d, stderr);
        Grid *g = grid_build(&r.s, res[ri][0], res[ri][1], res[ri][2], &d);
        CHECK(g != NULL);
        if (!g)
            continue;
        RenderCtx ctx;
        grid_test_ctx(&ctx, g, true);
        for (int kk = 0; kk < 4; kk++) {
            if (!grid_packet_use_kernel(kernels[kk]))
                continue;
            for (int rep = 0; rep < 150; rep++) {
                /* The light: random, or close to an axis, or along a triangle's plane. */
                Vec3 dir = unit_rand();
                int kind = irand(4);
                if (kind == 1) {
                    int a = irand(3);
                    float c[3] = {frand(-0.05f, 0.05f), frand(-0.05f, 0.05f),
                                  frand(-0.05f, 0.05f)};
                    /* Sometimes exactly along the axis (the shear r_U, r_V +0 or -0:
                     * the cull's choice of the box's K side by their sign). */
                    if (irand(3) == 0)
                        for (int q = 0; q < 3; q++)
                            c[q] = irand(2) ? 0.0f : -0.0f;
                    c[a] = irand(2) ? 1.0f : -1.0f;
                    dir = v3(c[0], c[1], c[2]);
                } else if (kind == 2) {
                    const Vec3 *t = tv[irand(NT)];
                    Vec3 e1 = v3_sub(t[1], t[0]), e2 = v3_sub(t[2], t[0]);
                    dir = v3_normalize(v3_add(v3_scale(e1, frand(-1, 1)),
                                              v3_scale(e2, frand(-1, 1))));
                }
                int n = 2 + irand(GRID_PACKET_MAX - 1);
                Ray rays[GRID_PACKET_MAX];
                const Vec3 *t = tv[irand(NT)];
                for (int i = 0; i < n; i++) {
                    /* A point on an edge or at a corner of one triangle (mostly one
                     * triangle per packet, as a beam's rays are neighbours), moved in
                     * or out by a tiny to small amount, and the ray's origin some way
                     * back towards the light's opposite side. */
                    if (irand(4) == 0)
                        t = tv[irand(NT)];
                    int e = irand(3);
                    float s = irand(3) ? frand(0, 1) : (float)irand(2);
                    Vec3 p = v3_add(v3_scale(t[e], 1.0f - s), v3_scale(t[(e + 1) % 3], s));
                    Vec3 cen = v3_scale(v3_add(v3_add(t[0], t[1]), t[2]), 1.0f / 3.0f);
                    float off = powf(10.0f, frand(-7.0f, -2.0f)) * (irand(2) ? 1.0f : -1.0f);
                    p = v3_add(p, v3_scale(v3_sub(p, cen), off));
                    float back = irand(2) ? frand(0.0f, 0.3f) : frand(0.3f, 6.0f);
                    rays[i].origin = v3_sub(p, v3_scale(dir, back));
                    if (irand(8) == 0)
                        rays[i].origin = vrand(-1.5f, 1.5f); /* a stray one */
                    rays[i].dir = dir;
                }
                uint64_t mask = 0;
                for (int i = 0; i < n; i++)
                    if (irand(6))
                        mask |= (uint64_t)1 << i;
                float tmin = irand(2) ? 0.0f : 1e-3f;
                float tmax1 = irand(3) ? INFINITY : frand(0.0f, 4.0f);
                uint64_t b = grid_occluded_packet_dir(g, rays, mask, tmin, tmax1, dir, &ctx);
                for (int i = 0; i < n; i++) {
                    if (!(mask >> i & 1)) {
                        CHECK(!(b >> i & 1));
                        continue;
                    }
                    RenderCtx bctx;
                    memset(&bctx, 0, sizeof bctx);
                    Hit ho = hit_none();
                    ho.t = tmax1;
                    ho.id = 0;
                    bool ob = obj_intersect(r.s.root, &rays[i], &ho, tmin, &bctx);
                    CHECK_MSG(ob == (bool)(b >> i & 1),
                              "%s kernel, grid %dx%dx%d: ray %d/%d o=(%.9g,%.9g,%.9g) "
                              "d=(%.9g,%.9g,%.9g) tmin %g tmax %g: packet %d, brute %d",
                              kernels[kk], res[ri][0], res[ri][1], res[ri][2], i, n,
                              (double)rays[i].origin.x, (double)rays[i].origin.y,
                              (double)rays[i].origin.z, (double)dir.x, (double)dir.y,
                              (double)dir.z, (double)tmin, (double)tmax1, (int)(b >> i & 1),
                              ob);
                    occluded += ob;
                    rays_checked++;
                }
                /* tmin 1e-3 there; the same rays with the direction in every ray. */
                check_packet_dir(g, &ctx, rays, n, dir, tmax1);
            }
        }
        CHECK(grid_packet_use_kernel(default_kernel));
        grid_test_ctx_free(&ctx);
        grid_free(g);
    }
    long tests = dir_tests - tests0, ray_tests = dir_ray_tests - ray_tests0;
    printf("    %ld rays, %ld occluded; triangle tests towards the light %ld, by rays %ld\n",
           rays_checked, occluded, tests, ray_tests);
    CHECK(occluded > rays_checked / 10 && occluded < rays_checked);
    /* The beam cull drops tests the slice rectangles keep. */
    CHECK(tests < ray_tests);
    arena_free(&r.s.arena);
}

static const TestCase tests[] = {
    {"tile_order", test_tile_order},
    {"random_scenes_marking_on", test_random_scenes_marking_on},
    {"random_scenes_marking_off", test_random_scenes_marking_off},
    {"no_mailbox", test_no_mailbox},
    {"shrinking_transform_tmin", test_shrinking_transform_tmin},
    {"lattice_ties", test_lattice_ties},
    {"group_loop", test_group_loop},
    {"crowded_cells", test_crowded_cells},
    {"beam_edges", test_beam_edges},
};

RT_TEST_MAIN(tests)
