/* The two-level grid (rt/twolevel.h) against the brute-force tree walk on seeded random
 * UNEVEN scenes: dense clusters of small triangles (meshes with shared edges) and
 * spheres far apart, a few huge triangles spanning the scene, thin flat clusters (a
 * floor), transformed primitives and planes. Every ray's nearest hit must be the brute
 * force's to the bit (t, id, normal, material), occlusion must agree, leaf grids must
 * really be built (the test would otherwise only test the top grid), and degenerate
 * scenes (thousands of co-located spheres, huge overlapping triangles) must build
 * within the documented entry bounds. */
#include <stdlib.h>
#include <string.h>

#include "../harness.h"
#include "rt/arena.h"
#include "rt/geom.h"
#include "rt/grid.h"
#include "rt/material.h"
#include "rt/par.h"
#include "rt/prim.h"
#include "rt/ray_tree.h"
#include "rt/scene.h"
#include "rt/twolevel.h"

#include "test_rng.h"
#include "../../src/accel/grid_build.h"
#include "../../src/accel/twolevel_internal.h"

typedef struct UScene {
    Scene s;
    Material *mats[3];
    Vec3 centres[16];     /* cluster centres (rays are aimed at them) */
    float radius[16];
    int num_clusters;
} UScene;

/* A dense cluster at c of size r: a height-field mesh (shared edges and vertices, so
 * ties in t), small random triangles, small spheres; sometimes under a Transform. */
static Object3D *cluster(UScene *u, Vec3 c, float r, bool flat)
{
    Arena *a = &u->s.arena;
    int nx = 4 + irand(8), nz = 4 + irand(8), extra = 20 + irand(60);
    Object3D *g = group_new(a, 2 * nx * nz + extra);
    int k = 0;
    float step = 2.0f * r / (float)(nx > nz ? nx : nz);
    for (int i = 0; i < nx; i++)
        for (int j = 0; j < nz; j++) {
            Vec3 p[4];
            for (int q = 0; q < 4; q++) {
                int di = q & 1, dj = q >> 1;
                float h = flat ? 0.0f : (float)(((i + di) * 5 + (j + dj) * 3) % 4) * 0.125f * r;
                p[q] = v3_add(c, v3(-r + (float)(i + di) * step, h, -r + (float)(j + dj) * step));
            }
            const Material *m = u->mats[irand(3)];
            group_set_child(g, k++, triangle_new(a, p[0], p[1], p[3], m));
            group_set_child(g, k++, triangle_new(a, p[0], p[3], p[2], m));
        }
    for (int e = 0; e < extra; e++) {
        const Material *m = u->mats[irand(3)];
        Vec3 p = v3_add(c, vrand(-r, r));
        if (flat)
            p.y = c.y;
        if (!flat && irand(4) == 0) {
            group_set_child(g, k++, sphere_new(a, p, frand(0.02f, 0.2f) * r, m));
        } else {
            float s = frand(0.05f, 0.4f) * r;
            Vec3 q1 = v3_add(p, vrand(-s, s)), q2 = v3_add(p, vrand(-s, s));
            if (flat)
                q1.y = q2.y = c.y;
            group_set_child(g, k++, triangle_new(a, p, q1, q2, m));
        }
    }
    group_finish(g);
    if (!flat && irand(3) == 0) {
        /* Rotate and scale about the centre. */
        Mat4 t1 = mat4_translate(c), t2 = mat4_translate(v3_neg(c));
        Mat4 rot = mat4_rotate_axis(unit_rand(), frand(-180, 180));
        Mat4 sc = mat4_scale(v3(frand(0.5f, 1.5f), frand(0.5f, 1.5f), frand(0.5f, 1.5f)));
        Mat4 m = mat4_mul(&t1, &rot);
        m = mat4_mul(&m, &sc);
        m = mat4_mul(&m, &t2);
        Object3D *x = transform_new(a, &m, g);
        return x ? x : g;
    }
    return g;
}

static void uscene_make(UScene *u, int clusters, float spread, int huge, int planes)
{
    memset(u, 0, sizeof *u);
    arena_init(&u->s.arena);
    for (int i = 0; i < 3; i++) {
        PhongParams p = phong_defaults();
        p.diffuse = vrand(0, 1);
        u->mats[i] = phong_new(&u->s.arena, &p);
    }
    Arena *a = &u->s.arena;
    Object3D *root = group_new(a, clusters + huge + planes);
    int k = 0;
    for (int i = 0; i < clusters; i++) {
        Vec3 c = vrand(-spread, spread);
        float r = frand(0.2f, 1.5f);
        bool flat = irand(4) == 0;
        u->centres[u->num_clusters] = c;
        u->radius[u->num_clusters++] = r;
        group_set_child(root, k++, cluster(u, c, r, flat));
    }
    for (int i = 0; i < huge; i++)
        group_set_child(root, k++, triangle_new(a, vrand(-spread, spread), vrand(-spread, spread),
                                                vrand(-spread, spread), u->mats[irand(3)]));
    for (int i = 0; i < planes; i++)
        group_set_child(root, k++, plane_new(a, unit_rand(), frand(-spread, spread) * 1.5f,
                                             u->mats[irand(3)]));
    group_finish(root);
    u->s.root = root;
    u->s.num_primitives = group_assign_ids(root);
    u->s.bounds = root->bounded ? root->bbox : bbox_empty();
}

static bool same_hit(const Hit *a, const Hit *b)
{
    return a->t == b->t && a->id == b->id && a->material == b->material &&
           a->normal.x == b->normal.x && a->normal.y == b->normal.y &&
           a->normal.z == b->normal.z;
}

typedef struct Totals {
    long rays, hits, occl, tests, brute_tests;
} Totals;

/* The walk without a ray tree (lean marches with the cell loop inlined, grid_cast.c)
 * against the walk with one (march_init and march_next, which record it): every query
 * must give the same answer and add the same counts (-stats prints them). Set by
 * run_uneven; NULL elsewhere. */
static RenderCtx *walk_lean, *walk_tree;
static long walks_compared, walk_cells;
/* The lean walk again in grid_cast.c's baseline copy (grid_cast_path_set(0)), against
 * walk_lean in the copy for this CPU (the AVX2 one where it has AVX2): same answers,
 * same counts. Set with walk_lean; NULL elsewhere. */
static RenderCtx *walk_base;
static long copies_compared;

static bool same_counts(const RtStats *a0, const RtStats *a1, const RtStats *b0,
                        const RtStats *b1)
{
    return a1->intersections - a0->intersections == b1->intersections - b0->intersections &&
           a1->cells_traversed - a0->cells_traversed ==
               b1->cells_traversed - b0->cells_traversed &&
           a1->mailbox_skips - a0->mailbox_skips == b1->mailbox_skips - b0->mailbox_skips &&
           a1->repeat_tests - a0->repeat_tests == b1->repeat_tests - b0->repeat_tests;
}

static bool same_hit(const Hit *a, const Hit *b);

static void check_walks(const TwoLevelGrid *t, const Ray *ray, float tmin, float t0, float tmax)
{
    if (!walk_lean || !walk_tree)
        return;
    RtStats a0 = walk_lean->stats, b0 = walk_tree->stats;
    Hit ha = hit_none(), hb = hit_none();
    bool fa = twolevel_intersect(t, ray, &ha, tmin, walk_lean);
    ray_tree_clear(walk_tree->tree);
    bool fb = twolevel_intersect(t, ray, &hb, tmin, walk_tree);
    RtStats a1 = walk_lean->stats, b1 = walk_tree->stats;
    CHECK_MSG(fa == fb && (!fa || same_hit(&ha, &hb)) && same_counts(&a0, &a1, &b0, &b1),
              "intersect: lean %d t=%.9g id=%u cells %llu tests %llu, tree %d t=%.9g id=%u "
              "cells %llu tests %llu",
              fa, (double)ha.t, ha.id,
              (unsigned long long)(a1.cells_traversed - a0.cells_traversed),
              (unsigned long long)(a1.intersections - a0.intersections), fb, (double)hb.t, hb.id,
              (unsigned long long)(b1.cells_traversed - b0.cells_traversed),
              (unsigned long long)(b1.intersections - b0.intersections));
    walk_cells += (long)(a1.cells_traversed - a0.cells_traversed);
    bool oa = twolevel_occluded(t, ray, t0, tmax, walk_lean);
    ray_tree_clear(walk_tree->tree);
    bool ob = twolevel_occluded(t, ray, t0, tmax, walk_tree);
    RtStats a2 = walk_lean->stats, b2 = walk_tree->stats;
    CHECK_MSG(oa == ob && same_counts(&a1, &a2, &b1, &b2),
              "occluded to %.9g: lean %d cells %llu tests %llu, tree %d cells %llu tests %llu",
              (double)tmax, oa, (unsigned long long)(a2.cells_traversed - a1.cells_traversed),
              (unsigned long long)(a2.intersections - a1.intersections), ob,
              (unsigned long long)(b2.cells_traversed - b1.cells_traversed),
              (unsigned long long)(b2.intersections - b1.intersections));
    walks_compared += 2;
    if (!walk_base)
        return;
    grid_cast_path_set(0);
    RtStats c0 = walk_base->stats;
    Hit hc = hit_none();
    bool fc = twolevel_intersect(t, ray, &hc, tmin, walk_base);
    RtStats c1 = walk_base->stats;
    bool oc = twolevel_occluded(t, ray, t0, tmax, walk_base);
    RtStats c2 = walk_base->stats;
    grid_cast_path_set(1);
    CHECK_MSG(fc == fa && (!fa || same_hit(&hc, &ha)) && same_counts(&c0, &c1, &a0, &a1),
              "intersect: baseline copy %d t=%.9g id=%u cells %llu tests %llu, this CPU's "
              "copy %d t=%.9g id=%u cells %llu tests %llu",
              fc, (double)hc.t, hc.id, (unsigned long long)(c1.cells_traversed - c0.cells_traversed),
              (unsigned long long)(c1.intersections - c0.intersections), fa, (double)ha.t, ha.id,
              (unsigned long long)(a1.cells_traversed - a0.cells_traversed),
              (unsigned long long)(a1.intersections - a0.intersections));
    CHECK_MSG(oc == oa && same_counts(&c1, &c2, &a1, &a2),
              "occluded to %.9g: baseline copy %d cells %llu tests %llu, this CPU's copy %d "
              "cells %llu tests %llu",
              (double)tmax, oc, (unsigned long long)(c2.cells_traversed - c1.cells_traversed),
              (unsigned long long)(c2.intersections - c1.intersections), oa,
              (unsigned long long)(a2.cells_traversed - a1.cells_traversed),
              (unsigned long long)(a2.intersections - a1.intersections));
    copies_compared += 2;
}

static void check_one(const UScene *u, const TwoLevelGrid *t, RenderCtx *ctx, const Ray *ray,
                      float tmin, Totals *tot, Hit *out)
{
    Hit hg = hit_none(), hb = hit_none();
    uint64_t before = ctx->stats.intersections;
    bool fg = twolevel_intersect(t, ray, &hg, tmin, ctx);
    tot->tests += (long)(ctx->stats.intersections - before);
    RenderCtx bctx;
    memset(&bctx, 0, sizeof bctx);
    bool fb = obj_intersect(u->s.root, ray, &hb, tmin, &bctx);
    tot->brute_tests += (long)bctx.stats.intersections;
    tot->rays++;
    tot->hits += fb;
    CHECK_MSG(fg == fb && (!fb || same_hit(&hg, &hb)),
              "ray o=(%.9g,%.9g,%.9g) d=(%.9g,%.9g,%.9g) tmin=%g: twolevel %d t=%.9g id=%u, "
              "brute %d t=%.9g id=%u",
              (double)ray->origin.x, (double)ray->origin.y, (double)ray->origin.z,
              (double)ray->dir.x, (double)ray->dir.y, (double)ray->dir.z, (double)tmin, fg,
              (double)hg.t, hg.id, fb, (double)hb.t, hb.id);
    *out = hb;
    if (!fb)
        out->t = INFINITY;
    float tmax = fb && irand(3) == 0 ? hb.t : frand(0.0f, 40.0f);
    float t0 = isfinite(tmin) ? tmin : 0.0f;
    Hit ho = hit_none();
    ho.t = tmax;
    ho.id = 0;
    memset(&bctx, 0, sizeof bctx);
    bool ob = obj_intersect(u->s.root, ray, &ho, t0, &bctx);
    bool og = twolevel_occluded(t, ray, t0, tmax, ctx);
    CHECK_MSG(ob == og, "occlusion to %.9g: twolevel %d, brute %d", (double)tmax, og, ob);
    tot->occl += ob;
    check_walks(t, ray, tmin, t0, tmax);
}

static void run_uneven(int seed, int clusters, float spread, int huge, int planes, int rays,
                       Totals *tot, uint32_t *subs_out)
{
    rng_state = (uint64_t)seed * 104729u + 3u;
    UScene u;
    uscene_make(&u, clusters, spread, huge, planes);
    Diag d;
    diag_init(&d, stderr);
    PrimTable table;
    CHECK(prim_table_build(&table, &u.s));
    TwoLevelGrid *t = twolevel_build(&table, &d);
    CHECK(t != NULL);
    if (!t) {
        prim_table_free(&table);
        arena_free(&u.s.arena);
        return;
    }
    uint32_t subs;
    twolevel_counts(t, &subs, NULL);
    *subs_out += subs;
    const Grid *g = twolevel_top(t);
    RenderCtx ctx;
    memset(&ctx, 0, sizeof ctx);
    ctx.num_mailbox = grid_mailbox_size(g);
    ctx.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
    ctx.ray_stamp = UINT32_MAX - 3; /* wraps around during the run */
    RenderCtx lean = ctx, tree = ctx, base = ctx;
    lean.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
    tree.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
    base.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
    tree.tree = malloc(sizeof *tree.tree);
    walk_lean = lean.mailbox && tree.mailbox && tree.tree ? &lean : NULL;
    walk_tree = &tree;
    walk_base = base.mailbox ? &base : NULL;
    BBox b = grid_bounds(g);
    for (int i = 0; i < rays; i++) {
        Ray ray;
        float tmin = 0.0f;
        int c = irand(u.num_clusters);
        Vec3 target;
        switch (irand(4)) {
        case 0: /* into a cluster */
            target = v3_add(u.centres[c], vrand(-u.radius[c], u.radius[c]));
            break;
        case 1: /* at a leaf-ish border: a cluster centre exactly */
            target = u.centres[c];
            break;
        default:
            target = v3(frand(b.min.x, b.max.x), frand(b.min.y, b.max.y), frand(b.min.z, b.max.z));
            break;
        }
        Vec3 o = irand(2) ? vrand(-2.0f * spread, 2.0f * spread)
                          : v3_add(u.centres[irand(u.num_clusters)], vrand(-2, 2));
        if (irand(10) == 0) {
            int a = irand(3);
            Vec3 dd = v3(0, 0, 0);
            if (a == 0) dd.x = 1; else if (a == 1) dd.y = -1; else dd.z = 1;
            ray.dir = dd;
            ray.origin = v3_sub(target, v3_scale(dd, 3.0f * spread));
        } else {
            ray.origin = o;
            ray.dir = v3_sub(target, o);
            if (irand(3))
                ray.dir = v3_normalize(ray.dir);
        }
        int k = irand(6);
        if (k == 0)
            tmin = -INFINITY;
        else if (k == 1)
            tmin = frand(0, 0.5f);
        Hit h;
        check_one(&u, t, &ctx, &ray, tmin, tot, &h);
        if (isfinite(h.t) && irand(2)) {
            Ray s;
            s.origin = ray_at(&ray, h.t);
            s.dir = irand(2) ? unit_rand() : v3_neg(ray.dir);
            Hit h2;
            check_one(&u, t, &ctx, &s, 1e-3f, tot, &h2);
        }
    }
    walk_lean = walk_tree = walk_base = NULL;
    free(base.mailbox);
    free(lean.mailbox);
    free(tree.mailbox);
    free(tree.tree);
    free(ctx.mailbox);
    twolevel_free(t);
    prim_table_free(&table);
    arena_free(&u.s.arena);
}

/* Every leaf cell lists exactly the cell's small untransformed triangles that the
 * reference separating-axis test (grid_tri_box_overlap, without the build's shortcuts
 * and per-row tables) finds within their hit tolerance of the padded leaf cell (border
 * cells stretched to the triangle's box, as the course grid's), in top-list order;
 * the last cell of a leaf grid may list the grid's large entries after them. Returns
 * the triangle-cell pairs checked. */
static long check_leaf_cells(const TwoLevelGrid *t)
{
    const Grid *g = t->top;
    long pairs = 0;
    for (uint32_t c = 0; c < g->num_cells; c++) {
        uint32_t s = t->sub_of[c];
        if (s == TWOLEVEL_NO_SUB)
            continue;
        const SubGrid *sg = &t->subs[s];
        const uint32_t *list = g->cell_items + g->cell_start[c];
        uint32_t m = g->cell_start[c + 1] - g->cell_start[c];
        const uint32_t *big = t->items + sg->big_start;
        uint32_t ncells = (uint32_t)(sg->n[0] * sg->n[1] * sg->n[2]);
        for (uint32_t lc = 0; lc < ncells; lc++) {
            int cc[3] = {(int)(lc % (uint32_t)sg->n[0]),
                         (int)(lc / (uint32_t)sg->n[0] % (uint32_t)sg->n[1]),
                         (int)(lc / ((uint32_t)sg->n[0] * (uint32_t)sg->n[1]))};
            const uint32_t *got = t->items + t->start[sg->base + lc];
            uint32_t ngot = t->start[sg->base + lc + 1] - t->start[sg->base + lc];
            uint32_t k = 0, nb = 0; /* next position in got; large entries passed */
            bool same = true;
            for (uint32_t e = 0; e < m && same; e++) {
                if (nb < sg->big_count && list[e] == big[nb]) {
                    nb++;
                    continue;
                }
                const GridPrim *gp = &g->prims[GRID_ITEM_INDEX(list[e])];
                bool listed = k < ngot && got[k] == list[e];
                if (gp->xf || obj_kind(gp->obj) != OBJ_TRIANGLE) {
                    k += listed; /* spheres, transformed: their box range, not checked */
                    continue;
                }
                Vec3 tv[3];
                triangle_vertices(gp->obj, tv);
                Vec3 bmin = v3_min(v3_min(tv[0], tv[1]), tv[2]);
                Vec3 bmax = v3_max(v3_max(tv[0], tv[1]), tv[2]);
                Vec3 ext = v3_sub(bmax, bmin);
                float w = 2.0f * (RT_TRI_EDGE_TOL + RT_TRI_FAR_TOL) * (ext.x + ext.y + ext.z);
                double v[3][3], h[3];
                for (int a = 0; a < 3; a++) {
                    double mn = (double)v3_comp(sg->box.min, a), sz = (double)sg->size[a];
                    double pd = (double)sg->pad[a];
                    double lo = mn + cc[a] * sz - pd, hi = mn + (cc[a] + 1) * sz + pd;
                    double blo = (double)(v3_comp(bmin, a) - w);
                    double bhi = (double)(v3_comp(bmax, a) + w);
                    if (cc[a] == 0 && blo < lo)
                        lo = blo;
                    if (cc[a] == sg->n[a] - 1 && bhi > hi)
                        hi = bhi;
                    double mid = 0.5 * (lo + hi);
                    h[a] = 0.5 * (hi - lo) + (double)w;
                    for (int q = 0; q < 3; q++)
                        v[q][a] = (double)v3_comp(tv[q], a) - mid;
                }
                bool want = grid_tri_box_overlap(v, h);
                same = want == listed;
                k += listed;
                pairs++;
            }
            bool tail = k == ngot ||
                        (lc == ncells - 1 && ngot - k == sg->big_count &&
                         (sg->big_count == 0 || memcmp(got + k, big, sg->big_count * sizeof *big) == 0));
            CHECK_MSG(same && tail, "top cell %u, leaf cell %u (%d %d %d): listed %u, checked "
                      "up to %u", c, lc, cc[0], cc[1], cc[2], ngot, k);
            if (!(same && tail))
                return pairs;
        }
    }
    return pairs;
}

static void test_leaf_cells(void)
{
    long pairs = 0;
    uint32_t subs = 0;
    for (int seed = 1; seed <= 12; seed++) {
        rng_state = (uint64_t)seed * 7919u + 11u;
        UScene u;
        uscene_make(&u, 2 + seed % 5, seed % 2 ? 30.0f : 6.0f, seed % 3, 0);
        Diag d;
        diag_init(&d, stderr);
        PrimTable table;
        CHECK(prim_table_build(&table, &u.s));
        TwoLevelGrid *t = twolevel_build(&table, &d);
        CHECK(t != NULL);
        if (t) {
            subs += t->num_subs;
            pairs += check_leaf_cells(t);
            twolevel_free(t);
        }
        prim_table_free(&table);
        arena_free(&u.s.arena);
    }
    printf("    %u leaf grids, %ld triangle-cell pairs checked\n", subs, pairs);
    CHECK(subs > 12);
    CHECK(pairs > 100000);
}

static void test_uneven_scenes(void)
{
    Totals tot = {0};
    uint32_t subs = 0;
    for (int seed = 1; seed <= 16; seed++)
        run_uneven(seed, 1 + seed % 6, seed % 2 ? 30.0f : 6.0f, seed % 4, seed % 3, 600, &tot,
                   &subs);
    printf("    %ld rays, %ld hits, %ld occluded, %u leaf grids; tests %ld vs brute %ld\n",
           tot.rays, tot.hits, tot.occl, subs, tot.tests, tot.brute_tests);
    printf("    walks with and without a ray tree: %ld queries compared, %ld cells\n",
           walks_compared, walk_cells);
    printf("    the walk's baseline copy against this CPU's: %ld queries compared\n",
           copies_compared);
    CHECK(walks_compared > 20000);
    CHECK(copies_compared == walks_compared);
    CHECK(walk_cells > walks_compared); /* more than two cells per nearest-hit query */
    CHECK(tot.rays > 10000);
    CHECK(tot.hits > tot.rays / 5);
    CHECK(subs > 16);                      /* leaf grids were built and walked */
    CHECK(tot.tests * 4 < tot.brute_tests); /* and they do cut the tests */
}

/* Degenerate inputs: the build must stay within its entry budget (bounded memory and
 * time) and still answer exactly. */
static void test_degenerate(void)
{
    for (int kind = 0; kind < 2; kind++) {
        rng_state = 99u + (uint64_t)kind;
        UScene u;
        memset(&u, 0, sizeof u);
        arena_init(&u.s.arena);
        PhongParams pp = phong_defaults();
        u.mats[0] = u.mats[1] = u.mats[2] = phong_new(&u.s.arena, &pp);
        int n = kind == 0 ? 10000 : 20000;
        Object3D *root = group_new(&u.s.arena, n);
        for (int i = 0; i < n; i++)
            group_set_child(root, i,
                            kind == 0 ? sphere_new(&u.s.arena, v3(1, 2, 3), 0.5f, u.mats[0])
                                      : triangle_new(&u.s.arena, vrand(-10, 10), vrand(-10, 10),
                                                     vrand(-10, 10), u.mats[0]));
        group_finish(root);
        u.s.root = root;
        u.s.num_primitives = group_assign_ids(root);
        u.s.bounds = root->bbox;
        u.centres[0] = v3(1, 2, 3);
        u.radius[0] = 0.5f;
        u.num_clusters = 1;
        Diag d;
        diag_init(&d, stderr);
        PrimTable table;
        CHECK(prim_table_build(&table, &u.s));
        TwoLevelGrid *t = twolevel_build(&table, &d);
        CHECK(t != NULL);
        if (t) {
            uint64_t course = 0, marching = 0, leaf = 0;
            grid_entry_totals(twolevel_top(t), &course, &marching);
            twolevel_counts(t, NULL, &leaf);
            printf("    %s: %d primitives, top entries %llu, leaf cells %llu\n",
                   kind == 0 ? "co-located spheres" : "huge triangles", n,
                   (unsigned long long)marching, (unsigned long long)leaf);
            CHECK(marching <= 8u * (uint64_t)n + 65536u + (uint64_t)n);
            CHECK(leaf <= 16u * (uint64_t)n + 65536u);
            RenderCtx ctx;
            memset(&ctx, 0, sizeof ctx);
            ctx.num_mailbox = grid_mailbox_size(twolevel_top(t));
            ctx.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
            Totals tot = {0};
            for (int i = 0; i < 40; i++) {
                Ray r = {vrand(-20, 20), unit_rand()};
                r.dir = v3_normalize(v3_sub(vrand(-2, 4), r.origin));
                Hit h;
                check_one(&u, t, &ctx, &r, 0.0f, &tot, &h);
            }
            free(ctx.mailbox);
            twolevel_free(t);
        }
        prim_table_free(&table);
        arena_free(&u.s.arena);
    }
}

/* Triangles are hit a little beyond their edges (rt/geom.h tolerances): many large
 * triangles through a dense cluster (more than the cell keeps aside, so they go into the
 * fine leaf grid) and rays aimed just outside their edges, within the tolerance. */
static void test_edge_tolerance(void)
{
    rng_state = 4242;
    UScene u;
    memset(&u, 0, sizeof u);
    arena_init(&u.s.arena);
    PhongParams pp = phong_defaults();
    u.mats[0] = u.mats[1] = u.mats[2] = phong_new(&u.s.arena, &pp);
    enum { BIG = 40 };
    Object3D *root = group_new(&u.s.arena, BIG + 2);
    Vec3 tv[BIG][3];
    for (int i = 0; i < BIG; i++) {
        Vec3 c = vrand(-0.5f, 0.5f);
        for (int k = 0; k < 3; k++)
            tv[i][k] = v3_add(c, vrand(-4, 4));
        group_set_child(root, i, triangle_new(&u.s.arena, tv[i][0], tv[i][1], tv[i][2], u.mats[0]));
    }
    u.centres[0] = v3(0, 0, 0);
    u.radius[0] = 0.5f;
    u.num_clusters = 1;
    group_set_child(root, BIG, cluster(&u, v3(0, 0, 0), 0.5f, false));
    group_set_child(root, BIG + 1, sphere_new(&u.s.arena, v3(60, 60, 60), 0.1f, u.mats[0]));
    group_finish(root);
    u.s.root = root;
    u.s.num_primitives = group_assign_ids(root);
    u.s.bounds = root->bbox;
    Diag d;
    diag_init(&d, stderr);
    PrimTable table;
    CHECK(prim_table_build(&table, &u.s));
    TwoLevelGrid *t = twolevel_build(&table, &d);
    CHECK(t != NULL);
    if (t) {
        uint32_t subs = 0;
        twolevel_counts(t, &subs, NULL);
        CHECK(subs > 0);
        RenderCtx ctx;
        memset(&ctx, 0, sizeof ctx);
        ctx.num_mailbox = grid_mailbox_size(twolevel_top(t));
        ctx.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
        Totals tot = {0};
        for (int i = 0; i < 4000; i++) {
            const Vec3 *v = tv[irand(BIG)];
            /* a point with barycentric u slightly negative (within or just past the
             * tolerance), the others random */
            float bu = irand(2) ? -frand(0.0f, 1.2e-5f) : frand(0.0f, 1.0f);
            float bv = frand(0.0f, 1.0f - (bu > 0 ? bu : 0.0f));
            Vec3 p = v3_add(v[0], v3_add(v3_scale(v3_sub(v[1], v[0]), bu),
                                         v3_scale(v3_sub(v[2], v[0]), bv)));
            Ray r;
            r.origin = v3_add(p, v3_scale(unit_rand(), 6.0f));
            r.dir = v3_sub(p, r.origin);
            Hit h;
            check_one(&u, t, &ctx, &r, 0.0f, &tot, &h);
        }
        free(ctx.mailbox);
        twolevel_free(t);
    }
    prim_table_free(&table);
    arena_free(&u.s.arena);
}

/* Only planes: no grid, no error (as grid_build). */
static void test_planes_only(void)
{
    rng_state = 5;
    UScene u;
    uscene_make(&u, 0, 5.0f, 0, 2);
    Diag d;
    diag_init(&d, stderr);
    PrimTable table;
    CHECK(prim_table_build(&table, &u.s));
    CHECK(twolevel_build(&table, &d) == NULL);
    CHECK_INT(d.errors, 0);
    prim_table_free(&table);
    arena_free(&u.s.arena);
}

/* A positive tmin is a distance in the space of the leaf hit (Transform): a crowded
 * cluster under a Transform scaling by 0.25 holds a triangle 0.1 ahead of the ray's
 * origin, hit with tmin = 0.3 (0.075 in its own units). Neither level may start its
 * march at the world tmin, past the cells holding it. */
static void test_shrinking_transform_tmin(void)
{
    Scene s;
    memset(&s, 0, sizeof s);
    arena_init(&s.arena);
    PhongParams pp = phong_defaults();
    Material *m = phong_new(&s.arena, &pp);
    enum { SIDE = 12 };
    Object3D *inner = group_new(&s.arena, 1 + SIDE * SIDE);
    group_set_child(inner, 0, triangle_new(&s.arena, v3(-1, -1, -1), v3(1, -1, -1),
                                           v3(0, 1, -1), m));
    for (int i = 0; i < SIDE; i++)
        for (int j = 0; j < SIDE; j++) {
            Vec3 c = v3(-1.0f + 2.0f * (float)i / SIDE, -1.0f + 2.0f * (float)j / SIDE,
                        -0.8f - 0.2f * (float)((i + j) % 3) / 3.0f);
            group_set_child(inner, 1 + i * SIDE + j,
                            triangle_new(&s.arena, c, v3_add(c, v3(0.05f, 0, 0)),
                                         v3_add(c, v3(0, 0.05f, 0.01f)), m));
        }
    group_finish(inner);
    Mat4 sc = mat4_scale(v3(0.25f, 0.25f, 0.25f));
    Object3D *root = group_new(&s.arena, 5);
    group_set_child(root, 0, transform_new(&s.arena, &sc, inner));
    group_set_child(root, 1, sphere_new(&s.arena, v3(0, 0, 5), 1.0f, m));
    group_set_child(root, 2, sphere_new(&s.arena, v3(4, 3, 2), 0.5f, m));
    group_set_child(root, 3, sphere_new(&s.arena, v3(-4, -3, -2), 0.5f, m));
    group_set_child(root, 4, sphere_new(&s.arena, v3(-4, 3, 5), 0.5f, m));
    group_finish(root);
    s.root = root;
    s.num_primitives = group_assign_ids(root);
    s.bounds = root->bbox;

    PrimTable table;
    CHECK(prim_table_build(&table, &s));
    Diag d;
    diag_init(&d, stderr);
    TwoLevelGrid *t = twolevel_build(&table, &d);
    CHECK(t != NULL);
    if (t) {
        RenderCtx ctx;
        memset(&ctx, 0, sizeof ctx);
        ctx.num_mailbox = grid_mailbox_size(twolevel_top(t));
        ctx.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
        for (int i = 0; i < 8; i++) {
            Ray ray = {v3(-0.04f + 0.01f * (float)i, 0.0f, -0.35f), v3(0, 0, 1)};
            RenderCtx bctx;
            memset(&bctx, 0, sizeof bctx);
            Hit hb = hit_none(), ht = hit_none();
            CHECK(obj_intersect(s.root, &ray, &hb, 0.3f, &bctx));
            CHECK_MSG(hb.t < 0.3f, "brute force: t=%g, expected below tmin", (double)hb.t);
            bool ft = twolevel_intersect(t, &ray, &ht, 0.3f, &ctx);
            CHECK_MSG(ft && same_hit(&ht, &hb), "ray %d: twolevel %d t=%g id=%u, brute t=%g "
                      "id=%u", i, ft, (double)ht.t, ht.id, (double)hb.t, hb.id);
            CHECK_MSG(twolevel_occluded(t, &ray, 0.3f, 0.2f, &ctx), "ray %d: not occluded", i);
        }
        free(ctx.mailbox);
        twolevel_free(t);
    }
    prim_table_free(&table);
    arena_free(&s.arena);
}

/* The build's whole structure (top resolution, every leaf grid's box, resolution,
 * padding and large entries, every leaf cell's offset and entry, which top cell has
 * which leaf grid), hashed (FNV-1a over the bytes, floats by their bits) on 6 small
 * stadiums (stadium_make: made the same by any compiler), with 1 and 2 set-up
 * threads. Pinned to the value of main at 605775a (before the build wrote its offsets
 * in place and read the estimate's boxes in place): the -stats counts of -grid auto
 * depend on every part of it, so a change of the build's code must leave it as is. */
static uint64_t fnv(uint64_t h, const void *p, size_t n)
{
    const unsigned char *b = p;
    for (size_t i = 0; i < n; i++)
        h = (h ^ b[i]) * 1099511628211u;
    return h;
}

static uint64_t structure_hash(const TwoLevelGrid *t, uint64_t h)
{
    const Grid *g = t->top;
    h = fnv(h, g->n, sizeof g->n);
    h = fnv(h, t->sub_of, (size_t)g->num_cells * sizeof *t->sub_of);
    h = fnv(h, &t->num_subs, sizeof t->num_subs);
    for (uint32_t s = 0; s < t->num_subs; s++) {
        const SubGrid *sg = &t->subs[s];
        float f[6] = {sg->box.min.x, sg->box.min.y, sg->box.min.z,
                      sg->box.max.x, sg->box.max.y, sg->box.max.z};
        h = fnv(h, f, sizeof f);
        h = fnv(h, sg->n, sizeof sg->n);
        h = fnv(h, sg->pad, sizeof sg->pad);
        h = fnv(h, sg->size, sizeof sg->size);
        h = fnv(h, sg->inv_size, sizeof sg->inv_size);
        h = fnv(h, sg->slab_lo, sizeof sg->slab_lo);
        h = fnv(h, sg->slab_hi, sizeof sg->slab_hi);
        h = fnv(h, &sg->min_pad, sizeof sg->min_pad);
        uint32_t u[3] = {sg->base, sg->big_start, sg->big_count};
        h = fnv(h, u, sizeof u);
    }
    uint64_t nc = t->num_cells, ni = t->num_items;
    h = fnv(h, &nc, sizeof nc);
    h = fnv(h, &ni, sizeof ni);
    if (t->num_subs) {
        h = fnv(h, t->start, (t->num_cells + 1) * sizeof *t->start);
        h = fnv(h, t->items, t->num_items * sizeof *t->items);
    }
    return h;
}

/* A small stadium: 16 floor triangles first in the scene (so these large entries head
 * the top cell's list), a far corner stretching the box, and a flat cluster of small
 * triangles above the floor, with long slivers across it when slivers > 0. The leaf
 * grid's fit must estimate its entries from the small entries' boxes only: the floor's
 * would put a whole layer of leaf cells per large entry into the estimate and shrink
 * the grid. */
static void stadium_make(UScene *u, int slivers)
{
    memset(u, 0, sizeof *u);
    arena_init(&u->s.arena);
    PhongParams pp = phong_defaults();
    u->mats[0] = u->mats[1] = u->mats[2] = phong_new(&u->s.arena, &pp);
    Arena *a = &u->s.arena;
    const Material *m = u->mats[0];
    Object3D *root = group_new(a, 17 + 300 + slivers);
    int k = 0;
    for (int i = 0; i < 16; i++) {
        float y = 0.001f * (float)i, e = 40.0f - 0.5f * (float)i;
        group_set_child(root, k++, triangle_new(a, v3(-e, y, -e), v3(e, y, -e), v3(e, y, e), m));
    }
    group_set_child(root, k++, triangle_new(a, v3(39, 20, 39), v3(40, 20, 39), v3(40, 20, 40), m));
    /* One draw per statement: the order of a call's arguments is the compiler's, and
     * the hash below is pinned, so the scene must not depend on it. */
    float r[6];
    for (int i = 0; i < 300 + slivers; i++) {
        for (int j = 0; j < 6; j++)
            r[j] = frand(-1, 1);
        Vec3 p = v3(0.3f + r[0], 0.3f + 0.01f * (r[1] + 1), 0.2f + r[2]);
        Vec3 q1, q2;
        if (i < 300) { /* small */
            q1 = v3(p.x + 0.025f * (r[3] + 1), p.y, p.z);
            q2 = v3(p.x, p.y + 0.01f, p.z + 0.025f * (r[4] + 1));
        } else { /* a sliver across the cluster */
            q1 = v3(0.3f + r[3], 0.3f + 0.01f * (r[4] + 1), 0.2f + r[5]);
            q2 = v3(q1.x, q1.y + 0.01f, q1.z + 0.01f);
        }
        group_set_child(root, k++, triangle_new(a, p, q1, q2, m));
    }
    group_finish(root);
    u->s.root = root;
    u->s.num_primitives = group_assign_ids(root);
    u->s.bounds = root->bounded ? root->bbox : bbox_empty();
}

static void test_structure_pinned(void)
{
    const uint64_t want = UINT64_C(0xe8b12f3ec2b0ae3c);
    for (int helpers = 0; helpers <= 1; helpers++) {
        par_set_helpers(helpers);
        uint64_t h = 14695981039346656037u;
        uint32_t subs = 0;
        for (int seed = 0; seed < 6; seed++) {
            rng_state = (uint64_t)seed * 7919u + 11u;
            UScene u;
            stadium_make(&u, 20 * seed);
            Diag d;
            diag_init(&d, stderr);
            PrimTable table;
            CHECK(prim_table_build(&table, &u.s));
            TwoLevelGrid *t = twolevel_build(&table, &d);
            CHECK(t != NULL);
            if (t) {
                subs += t->num_subs;
                h = structure_hash(t, h);
                twolevel_free(t);
            }
            prim_table_free(&table);
            arena_free(&u.s.arena);
        }
        printf("    %d set-up thread(s): %u leaf grids, structure hash %016llx\n", 1 + helpers,
               subs, (unsigned long long)h);
        CHECK(subs >= 6);
        CHECK_MSG(h == want, "structure hash %016llx, pinned %016llx", (unsigned long long)h,
                  (unsigned long long)want);
    }
    par_set_helpers(-1);
}

/* The walk's copies on all-triangle scenes (stadium_make), where the cell loop is the
 * four-lane group loop (Grid.all_tri) rather than the mixed batch loop of
 * run_uneven's scenes: rays from the room into the cluster, across the floor, and
 * shadow rays from their hits, each against brute force (check_one) and through
 * check_walks (with and without a ray tree; baseline copy against this CPU's). */
static void test_walk_copies_all_triangles(void)
{
    Totals tot = {0};
    long before = copies_compared, all_tri = 0;
    for (int seed = 0; seed < 6; seed++) {
        rng_state = (uint64_t)seed * 6151u + 7u;
        UScene u;
        stadium_make(&u, 20 * seed);
        Diag d;
        diag_init(&d, stderr);
        PrimTable table;
        CHECK(prim_table_build(&table, &u.s));
        TwoLevelGrid *t = twolevel_build(&table, &d);
        CHECK(t != NULL);
        if (!t) {
            prim_table_free(&table);
            arena_free(&u.s.arena);
            continue;
        }
        all_tri += twolevel_top(t)->all_tri;
        RenderCtx ctx;
        memset(&ctx, 0, sizeof ctx);
        ctx.num_mailbox = grid_mailbox_size(twolevel_top(t));
        ctx.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
        RenderCtx lean = ctx, tree = ctx, base = ctx;
        lean.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
        tree.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
        base.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
        tree.tree = malloc(sizeof *tree.tree);
        bool ok = ctx.mailbox && lean.mailbox && tree.mailbox && base.mailbox && tree.tree;
        CHECK(ok);
        walk_lean = ok ? &lean : NULL;
        walk_tree = &tree;
        walk_base = ok ? &base : NULL;
        for (int i = 0; ok && i < 1500; i++) {
            Ray ray;
            float r[6];
            for (int j = 0; j < 6; j++)
                r[j] = frand(-1, 1);
            ray.origin = v3(38.0f * r[0], 12.0f + 11.0f * r[1], 38.0f * r[2]);
            Vec3 target = irand(3) ? v3(0.3f + r[3], 0.305f + 0.02f * r[4], 0.2f + r[5])
                                   : v3(39.0f * r[3], 0.0f, 39.0f * r[5]);
            ray.dir = v3_normalize(v3_sub(target, ray.origin));
            Hit h;
            check_one(&u, t, &ctx, &ray, irand(4) ? 0.0f : frand(0.0f, 5.0f), &tot, &h);
            if (isfinite(h.t)) { /* a shadow ray from the hit toward a light */
                Ray s;
                s.origin = ray_at(&ray, h.t);
                s.dir = v3_normalize(v3(0.4f * r[4], 1.0f, 0.3f * r[5]));
                Hit h2;
                check_one(&u, t, &ctx, &s, 1e-3f, &tot, &h2);
            }
        }
        walk_lean = walk_tree = walk_base = NULL;
        free(base.mailbox);
        free(lean.mailbox);
        free(tree.mailbox);
        free(tree.tree);
        free(ctx.mailbox);
        twolevel_free(t);
        prim_table_free(&table);
        arena_free(&u.s.arena);
    }
    printf("    %ld rays, %ld hits, %ld occluded; copies compared on %ld queries\n", tot.rays,
           tot.hits, tot.occl, copies_compared - before);
    CHECK(all_tri == 6); /* the group loop is the one walked */
    CHECK(tot.rays > 10000);
    CHECK(tot.hits > tot.rays / 4);
    CHECK(tot.occl > 100);
    CHECK(copies_compared - before > 20000);
}

/* Beyond the box's faces (docs/twolevel.md): the e2e reproducer's two triangles (one
 * in the plane z = 0, a face of the scene's box) and small triangles away from them, 12
 * (one top cell, whose leaf grid is clipped at that face) or 126 (2 x 2 x 2 top cells).
 * Rays from points on, just outside and just inside that face, running along it and
 * leaving it by a little, as a camera in the face's plane makes them: the triangle test
 * accepts hits up to its tolerance outside the face, which the walks (with and without a
 * ray tree, both copies: check_walks) ended before. */
static void test_band_beyond_the_box(void)
{
    for (int variant = 0; variant < 2; variant++) {
        rng_state = 777u + (uint64_t)variant;
        int small = variant ? 126 : 12;
        UScene u;
        memset(&u, 0, sizeof u);
        arena_init(&u.s.arena);
        PhongParams pp = phong_defaults();
        u.mats[0] = u.mats[1] = u.mats[2] = phong_new(&u.s.arena, &pp);
        Arena *a = &u.s.arena;
        Object3D *root = group_new(a, 2 + small);
        group_set_child(root, 0, triangle_new(a, v3(-0.136f, -0.158f, 0), v3(0.914f, -0.158f, 0),
                                              v3(0.914f, -0.158f, 1.385f), u.mats[0]));
        group_set_child(root, 1, triangle_new(a, v3(-0.136f, -0.158f, 1.385f),
                                              v3(0.914f, 0.791f, 1.385f),
                                              v3(-0.136f, 0.791f, 1.385f), u.mats[0]));
        for (int i = 0; i < small; i++) {
            float x = 0.5f + 0.003f * (float)(i % 100), y = 0.70f + 0.0005f * (float)i,
                  z = 0.9f + 0.003f * (float)i;
            group_set_child(root, 2 + i, triangle_new(a, v3(x, y, z), v3(x + 0.002f, y, z),
                                                      v3(x, y, z + 0.002f), u.mats[0]));
        }
        group_finish(root);
        u.s.root = root;
        u.s.num_primitives = group_assign_ids(root);
        u.s.bounds = root->bbox;
        Diag d;
        diag_init(&d, stderr);
        PrimTable table;
        CHECK(prim_table_build(&table, &u.s));
        TwoLevelGrid *t = twolevel_build(&table, &d);
        CHECK(t != NULL);
        if (t) {
            uint32_t subs = 0;
            twolevel_counts(t, &subs, NULL);
            int n[3];
            grid_dims(twolevel_top(t), n);
            CHECK(subs == 1);
            CHECK(n[0] * n[1] * n[2] == (variant ? 8 : 1));
            RenderCtx ctx;
            memset(&ctx, 0, sizeof ctx);
            ctx.num_mailbox = grid_mailbox_size(twolevel_top(t));
            ctx.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
            RenderCtx lean = ctx, tree = ctx, base = ctx;
            lean.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
            tree.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
            base.mailbox = calloc(ctx.num_mailbox + 1, sizeof *ctx.mailbox);
            tree.tree = malloc(sizeof *tree.tree);
            bool ok = ctx.mailbox && lean.mailbox && tree.mailbox && base.mailbox && tree.tree;
            CHECK(ok);
            walk_lean = ok ? &lean : NULL;
            walk_tree = &tree;
            walk_base = ok ? &base : NULL;
            Totals tot = {0};
            long outside = 0; /* hits on the first triangle beyond the face z = 0 */
            for (int i = 0; ok && i < 3000; i++) {
                Ray r;
                float z0 = irand(2) ? 0.0f : frand(-2e-5f, 2e-5f);
                r.origin = v3(frand(-0.1f, 0.9f), frand(0.0f, 0.7f), z0);
                r.dir = v3(frand(-0.3f, 0.3f), -1.0f, irand(4) ? -frand(0.0f, 4e-5f) : 0.0f);
                Hit h;
                check_one(&u, t, &ctx, &r, 0.0f, &tot, &h);
                outside += isfinite(h.t) && h.id == 0 && ray_at(&r, h.t).z < 0.0f;
            }
            printf("    %d top cell(s): %ld rays, %ld hits, %ld of them beyond the face\n",
                   n[0] * n[1] * n[2], tot.rays, tot.hits, outside);
            CHECK(outside > 100); /* the case is met */
            walk_lean = walk_tree = walk_base = NULL;
            free(base.mailbox);
            free(lean.mailbox);
            free(tree.mailbox);
            free(tree.tree);
            free(ctx.mailbox);
            twolevel_free(t);
        }
        prim_table_free(&table);
        arena_free(&u.s.arena);
    }
}

static const TestCase tests[] = {
    {"twolevel_uneven_scenes_match_brute_force", test_uneven_scenes},
    {"twolevel_leaf_cells_exact", test_leaf_cells},
    {"twolevel_degenerate_scenes_bounded", test_degenerate},
    {"twolevel_planes_only_no_grid", test_planes_only},
    {"twolevel_triangle_edge_tolerance", test_edge_tolerance},
    {"twolevel_shrinking_transform_tmin", test_shrinking_transform_tmin},
    {"twolevel_structure_pinned", test_structure_pinned},
    {"twolevel_walk_copies_all_triangles", test_walk_copies_all_triangles},
    {"twolevel_band_beyond_the_box", test_band_beyond_the_box},
};

RT_TEST_MAIN(tests)
