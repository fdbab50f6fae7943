/* Unit tests of the primitives: hit, miss, tangent, inside, transforms with
 * non-uniform scale, tie-break order and intersection counting. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "harness.h"
#include "rt/arena.h"
#include "rt/bigmem.h"
#include "rt/geom.h"
#include "rt/material.h"

static Arena arena;
static const Material *mat;

static void setup(void)
{
    arena_init(&arena);
    PhongParams p = phong_defaults();
    mat = phong_new(&arena, &p);
}

static Ray ray(Vec3 o, Vec3 d)
{
    Ray r = {o, d};
    return r;
}

static void test_sphere(void)
{
    setup();
    RenderCtx ctx = {0};
    Object3D *s = sphere_new(&arena, v3(0, 0, 0), 1, mat);
    group_assign_ids(s);
    Hit h = hit_none();
    Ray r = ray(v3(0, 0, 5), v3(0, 0, -1));
    CHECK(obj_intersect(s, &r, &h, 0, &ctx));
    CHECK_NEAR(h.t, 4, 1e-6);
    CHECK_NEAR(h.normal.z, 1, 1e-6);
    CHECK(h.material == mat);
    /* Miss, and a non-unit direction: t scales accordingly. */
    Hit h2 = hit_none();
    Ray miss = ray(v3(0, 2, 5), v3(0, 0, -1));
    CHECK(!obj_intersect(s, &miss, &h2, 0, &ctx));
    Ray slow = ray(v3(0, 0, 5), v3(0, 0, -2));
    CHECK(obj_intersect(s, &slow, &h2, 0, &ctx));
    CHECK_NEAR(h2.t, 2, 1e-6);
    /* Inside: the far root; normal still points outward. */
    Hit h3 = hit_none();
    Ray in = ray(v3(0, 0, 0), v3(1, 0, 0));
    CHECK(obj_intersect(s, &in, &h3, 0, &ctx));
    CHECK_NEAR(h3.t, 1, 1e-6);
    CHECK_NEAR(h3.normal.x, 1, 1e-6);
    /* Tangent ray grazes at one point. */
    Hit h4 = hit_none();
    Ray tan_r = ray(v3(-5, 1, 0), v3(1, 0, 0));
    CHECK(obj_intersect(s, &tan_r, &h4, 0, &ctx));
    CHECK_NEAR(h4.t, 5, 1e-3);
    /* Behind the origin with tmin 0: nothing. */
    Hit h5 = hit_none();
    Ray away = ray(v3(0, 0, 5), v3(0, 0, 1));
    CHECK(!obj_intersect(s, &away, &h5, 0, &ctx));
    /* A farther hit never replaces a nearer one. */
    Hit near = hit_none();
    near.t = 3;
    near.id = 7;
    CHECK(!obj_intersect(s, &r, &near, 0, &ctx));
    CHECK_INT(ctx.stats.intersections, 7);
}

static void test_plane(void)
{
    setup();
    RenderCtx ctx = {0};
    Object3D *p = plane_new(&arena, v3(0, 2, 0), 2, mat); /* y = 1, normal not unit */
    group_assign_ids(p);
    CHECK(!p->bounded);
    Hit h = hit_none();
    Ray down = ray(v3(0, 5, 0), v3(0, -1, 0));
    CHECK(obj_intersect(p, &down, &h, 0, &ctx));
    CHECK_NEAR(h.t, 4, 1e-6);
    CHECK_NEAR(h.normal.y, 1, 1e-6);
    Hit h2 = hit_none();
    Ray par = ray(v3(0, 5, 0), v3(1, 0, 0));
    CHECK(!obj_intersect(p, &par, &h2, 0, &ctx));
    Ray up = ray(v3(0, 5, 0), v3(0, 1, 0));
    CHECK(!obj_intersect(p, &up, &h2, 0, &ctx));
}

static void test_triangle(void)
{
    setup();
    RenderCtx ctx = {0};
    Object3D *t = triangle_new(&arena, v3(0, 0, 0), v3(1, 0, 0), v3(0, 1, 0), mat);
    group_assign_ids(t);
    Vec3 n = triangle_normal(t);
    CHECK_NEAR(n.z, 1, 0); /* counter-clockwise seen from +z */
    Hit h = hit_none();
    Ray r = ray(v3(0.25f, 0.25f, 3), v3(0, 0, -1));
    CHECK(obj_intersect(t, &r, &h, 0, &ctx));
    CHECK_NEAR(h.t, 3, 1e-6);
    Hit h2 = hit_none();
    Ray out = ray(v3(0.75f, 0.75f, 3), v3(0, 0, -1));
    CHECK(!obj_intersect(t, &out, &h2, 0, &ctx));
    /* An edge point counts (closed triangle), from the back side too. */
    Ray edge = ray(v3(0.5f, 0, -3), v3(0, 0, 1));
    CHECK(obj_intersect(t, &edge, &h2, 0, &ctx));
    CHECK_NEAR(h2.normal.z, 1, 0); /* the normal is not flipped by intersect */
    Ray par = ray(v3(-1, 0.2f, 0), v3(1, 0, 0));
    Hit h3 = hit_none();
    CHECK(!obj_intersect(t, &par, &h3, 0, &ctx));
}

static void test_transform_nonuniform(void)
{
    setup();
    RenderCtx ctx = {0};
    /* Sphere of radius 1 scaled by (2,1,1) and moved to x = 5: an ellipsoid. */
    Object3D *s = sphere_new(&arena, v3(0, 0, 0), 1, mat);
    Mat4 t = mat4_translate(v3(5, 0, 0)), sc = mat4_scale(v3(2, 1, 1));
    Mat4 m = mat4_mul(&t, &sc);
    Object3D *x = transform_new(&arena, &m, s);
    CHECK(x != NULL);
    group_assign_ids(x);
    CHECK_NEAR(x->bbox.min.x, 3, 1e-6);
    CHECK_NEAR(x->bbox.max.x, 7, 1e-6);
    Hit h = hit_none();
    Ray r = ray(v3(0, 0, 0), v3(1, 0, 0));
    CHECK(obj_intersect(x, &r, &h, 0, &ctx));
    CHECK_NEAR(h.t, 3, 1e-5); /* world-space t */
    CHECK_NEAR(h.normal.x, -1, 1e-6);
    /* Normal by the inverse transpose: at 45 degrees on the unit sphere, the ellipsoid
     * normal is (1/2, 1, 0) normalised, not the transformed (2, 1, 0) direction. */
    float a = (float)(sqrt(0.5));
    Ray r2 = ray(v3(5 + 2 * a, a, 5), v3(0, 0, -1));
    Hit h2 = hit_none();
    CHECK(obj_intersect(x, &r2, &h2, 0, &ctx));
    Vec3 want = v3_normalize(v3(0.5f * a, a, 0));
    CHECK_NEAR(h2.normal.x, want.x, 1e-3);
    CHECK_NEAR(h2.normal.y, want.y, 1e-3);
    /* Singular matrices are refused. */
    Mat4 z = mat4_scale(v3(0, 1, 1));
    CHECK(transform_new(&arena, &z, s) == NULL);
}

/* A positive tmin (the epsilon of secondary rays) is a distance in the space of the
 * primitive hit: under a scale of 0.25 along x, a face 0.0006 ahead in the world is
 * 0.0024 ahead in its own space, beyond an epsilon of 0.001 (course scene 11's cubes,
 * output6_11a); the flattened path of the grid agrees. Camera rays (tmin 0) are not
 * affected. */
static void test_transform_tmin_object_space(void)
{
    setup();
    RenderCtx ctx = {0};
    /* A triangle in the plane x = 1, facing -x; scaled by 0.25 it sits at x = 0.25. */
    Object3D *tri = triangle_new(&arena, v3(1, -1, -1), v3(1, 1, -1), v3(1, 0, 2), mat);
    Mat4 sc = mat4_scale(v3(0.25f, 1, 1));
    Object3D *x = transform_new(&arena, &sc, tri);
    group_assign_ids(x);
    XformPath path = {{x}, 1};
    Object3D *plain = triangle_new(&arena, v3(0.25f, -1, -1), v3(0.25f, 1, -1),
                                   v3(0.25f, 0, 2), mat);
    group_assign_ids(plain);
    const float eps = 1e-3f;
    struct {
        float gap;      /* world distance from the origin to the face */
        bool hit;       /* through the transform, with tmin = eps */
    } cases[] = {{0.0006f, true}, {0.0002f, false}, {0.01f, true}};
    for (int i = 0; i < 3; i++) {
        Ray r = ray(v3(0.25f - cases[i].gap, 0, 0), v3(1, 0, 0));
        Hit h1 = hit_none(), h2 = hit_none(), h3 = hit_none();
        bool b1 = obj_intersect(x, &r, &h1, eps, &ctx);
        bool b2 = transform_path_intersect(&path, tri, &r, &h2, eps, &ctx);
        CHECK_MSG(b1 == cases[i].hit, "gap %g: hit %d, want %d", (double)cases[i].gap, b1,
                  cases[i].hit);
        CHECK(b1 == b2);
        if (b1 && b2) {
            CHECK_NEAR(h1.t, cases[i].gap, 1e-6);
            CHECK(h1.t == h2.t);
        }
        /* The untransformed twin compares t with the epsilon directly. */
        CHECK(obj_intersect(plain, &r, &h3, eps, &ctx) == (cases[i].gap > eps));
    }
    /* tmin 0 stays 0: a face 0.0002 ahead is hit. */
    Ray r = ray(v3(0.25f - 0.0002f, 0, 0), v3(1, 0, 0));
    Hit h = hit_none();
    CHECK(obj_intersect(x, &r, &h, 0.0f, &ctx));
}

static void test_path_matches_tree(void)
{
    setup();
    RenderCtx ctx = {0};
    Object3D *tri = triangle_new(&arena, v3(-1, -1, 0), v3(1, -1, 0), v3(0, 1, 0.3f), mat);
    Mat4 a = mat4_rotate_axis(v3(0.2f, 0.9f, 0.1f), 23), b = mat4_scale(v3(1.7f, 0.4f, 2.2f));
    Mat4 c = mat4_translate(v3(0.3f, -0.2f, 1.1f));
    Object3D *inner = transform_new(&arena, &b, tri);
    Object3D *mid = transform_new(&arena, &a, inner);
    Object3D *outer = transform_new(&arena, &c, mid);
    group_assign_ids(outer);
    XformPath path = {{outer, mid, inner}, 3};
    int agree = 0, hits = 0;
    for (int i = 0; i < 400; i++) {
        float u = (float)(i % 20) / 10.0f - 1.0f, v = (float)(i / 20) / 10.0f - 1.0f;
        Ray r = ray(v3(u, v, 5), v3(0.01f * u, -0.02f, -1));
        Hit h1 = hit_none(), h2 = hit_none();
        bool b1 = obj_intersect(outer, &r, &h1, 0, &ctx);
        bool b2 = transform_path_intersect(&path, tri, &r, &h2, 0, &ctx);
        hits += b1;
        if (b1 == b2 && (!b1 || (h1.t == h2.t && h1.normal.x == h2.normal.x &&
                                 h1.normal.y == h2.normal.y && h1.normal.z == h2.normal.z)))
            agree++;
    }
    CHECK(hits > 50);
    CHECK_INT(agree, 400);
}

static void test_group_and_ties(void)
{
    setup();
    RenderCtx ctx = {0};
    Object3D *g = group_new(&arena, 3);
    /* Two coplanar triangles sharing an edge, and a sphere behind them. */
    Object3D *t0 = triangle_new(&arena, v3(0, 0, 0), v3(1, 0, 0), v3(0, 1, 0), mat);
    Object3D *t1 = triangle_new(&arena, v3(1, 0, 0), v3(1, 1, 0), v3(0, 1, 0), mat);
    Object3D *s = sphere_new(&arena, v3(0, 0, -5), 1, mat);
    group_set_child(g, 0, s);
    group_set_child(g, 1, t1);
    group_set_child(g, 2, t0);
    group_finish(g);
    CHECK_INT(group_assign_ids(g), 3);
    CHECK_INT(s->id, 0);
    CHECK_INT(t1->id, 1);
    CHECK_INT(t0->id, 2);
    CHECK_NEAR(g->bbox.min.z, -6, 0);
    /* On the shared edge both triangles give the same t: the lower id wins in either
     * testing order. */
    Ray r = ray(v3(0.5f, 0.5f, 2), v3(0, 0, -1));
    Hit h = hit_none();
    CHECK(obj_intersect(g, &r, &h, 0, &ctx));
    CHECK_INT(h.id, 1);
    Hit h2 = hit_none();
    CHECK(obj_intersect(t0, &r, &h2, 0, &ctx));
    CHECK(obj_intersect(t1, &r, &h2, 0, &ctx));
    CHECK_INT(h2.id, 1);
    /* Groups and transforms do not count as intersections; leaves do. */
    RenderCtx c2 = {0};
    Hit h3 = hit_none();
    obj_intersect(g, &r, &h3, 0, &c2);
    CHECK_INT(c2.stats.intersections, 3);
}

/* A small generator of our own, so the rays do not depend on the C library. */
static uint64_t rng = 88172645463325252ull;
static float rnd(float lo, float hi)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return lo + (hi - lo) * (float)(rng >> 40) / (float)(1 << 24);
}

/* occluded(tmin, tmax) is intersect's answer for a (tmax, id 0) hit, for every shape
 * and through Transforms, and counts the same tests: rays from inside and outside,
 * tmax at, just below and just above the nearest hit, the tmins of cameras and bounces. */
static void test_occluded_matches_intersect(void)
{
    setup();
    Mat4 s = mat4_scale(v3(2.0f, 0.5f, 1.0f)), r = mat4_rotate_axis(v3(1, 2, 3), 30.0f);
    Object3D *leaves[4] = {sphere_new(&arena, v3(0.2f, -0.1f, 0.3f), 1.1f, mat),
                           plane_new(&arena, v3(0.3f, 1, 0.2f), -0.4f, mat),
                           triangle_new(&arena, v3(-1, -1, 0.5f), v3(1.5f, -0.5f, 0),
                                        v3(0, 1.2f, -0.2f), mat),
                           sphere_new(&arena, v3(0, 0, 0), 0.7f, mat)};
    Object3D *inner = transform_new(&arena, &r, leaves[3]);
    Object3D *outer = transform_new(&arena, &s, inner);
    Object3D *g = group_new(&arena, 4);
    for (int i = 0; i < 3; i++)
        group_set_child(g, i, leaves[i]);
    group_set_child(g, 3, outer);
    group_finish(g);
    group_assign_ids(g);
    XformPath path = {{outer, inner}, 2};
    const float tmins[3] = {-INFINITY, 0.0f, 1e-3f};
    int agree = 0, occluded = 0, tree_agree = 0;
    for (int k = 0; k < 4000; k++) {
        Ray ry = ray(v3(rnd(-3, 3), rnd(-3, 3), rnd(-3, 3)),
                     v3_normalize(v3(rnd(-1, 1), rnd(-1, 1), rnd(-1, 1))));
        float tmin = tmins[k % 3];
        int leaf = k % 4;
        Hit near = hit_none();
        RenderCtx c0 = {0};
        if (leaf == 3)
            transform_path_intersect(&path, leaves[3], &ry, &near, tmin, &c0);
        else
            obj_intersect(leaves[leaf], &ry, &near, tmin, &c0);
        float tmax = rnd(0.1f, 6.0f);
        if (isfinite(near.t) && k % 2)
            tmax = (k / 2) % 3 == 0 ? near.t : nextafterf(near.t, (k / 2) % 3 == 1 ? 0.0f : INFINITY);
        Hit h = hit_none();
        h.t = tmax;
        h.id = 0;
        RenderCtx ci = {0}, co = {0};
        bool want, got;
        if (leaf == 3) {
            want = transform_path_intersect(&path, leaves[3], &ry, &h, tmin, &ci);
            got = transform_path_occluded(&path, leaves[3], &ry, tmin, tmax, &co);
        } else {
            want = obj_intersect(leaves[leaf], &ry, &h, tmin, &ci);
            got = obj_occluded(leaves[leaf], &ry, tmin, tmax, &co);
        }
        agree += want == got && ci.stats.intersections == 1 && co.stats.intersections == 1;
        occluded += got;
        /* The tree: Group and Transforms give the answer of the whole group's search. */
        Hit hg = hit_none();
        hg.t = tmax;
        hg.id = 0;
        RenderCtx cg = {0};
        tree_agree += obj_intersect(g, &ry, &hg, tmin, &cg) == obj_occluded(g, &ry, tmin, tmax, &cg);
    }
    CHECK_INT(agree, 4000);
    CHECK_INT(tree_agree, 4000);
    CHECK_MSG(occluded > 400 && occluded < 3600, "%d of 4000 rays occluded", occluded);
}

/* A request that fills a new block of its own (a mesh's triangles) leaves the block with
 * room as the one that serves the next small allocations; the big one is zeroed. */
static void test_arena_big_block_behind_head(void)
{
    Arena a;
    arena_init(&a);
    char *s1 = arena_alloc(&a, 100);
    size_t big_n = (size_t)BIGMEM_MIN_BYTES * 3;
    unsigned char *big = arena_alloc(&a, big_n);
    char *s2 = arena_alloc(&a, 100);
    CHECK(s1 && big && s2);
    if (s1 && big && s2) {
        CHECK_MSG(s2 == s1 + 112, "the small allocation after the big one is %td bytes "
                  "after the one before it (112: the same block)", s2 - s1);
        size_t nonzero = 0;
        for (size_t i = 0; i < big_n; i += 4096)
            nonzero += big[i] != 0 || big[big_n - 1 - i] != 0;
        CHECK_INT(nonzero, 0);
    }
    arena_free(&a);
}

/* A mesh built in a too-small adopted buffer (fresh memory then), and in a big enough
 * one (old bytes cleared): the same triangles and children either way. */
static void test_mesh_children_in_block(void)
{
    enum { N = 3000 };
    Vec3 *verts = malloc((N + 2) * sizeof *verts);
    int(*faces)[3] = malloc(N * sizeof *faces);
    for (int i = 0; i < N + 2; i++)
        verts[i] = v3((float)i, (float)(i % 7), (float)(i % 13));
    for (int i = 0; i < N; i++) {
        faces[i][0] = i;
        faces[i][1] = i + 1;
        faces[i][2] = i + 2;
    }
    Arena a;
    arena_init(&a);
    char *small = arena_buffer_new(1000);
    char *roomy = arena_buffer_new((size_t)N * 200);
    memset(small, 0x5a, 1000);
    memset(roomy, 0x5a, (size_t)N * 200);
    Object3D *g1 = triangle_mesh_new_in(&a, small, verts, (const int(*)[3])faces, N, NULL);
    Object3D *g2 = triangle_mesh_new_in(&a, roomy, verts, (const int(*)[3])faces, N, NULL);
    Object3D *g3 = triangle_mesh_new(&a, verts, (const int(*)[3])faces, N, NULL);
    CHECK(g1 && g2 && g3);
    if (g1 && g2 && g3) {
        CHECK_INT(group_count(g1), N);
        CHECK_INT(group_count(g2), N);
        int bad = 0;
        for (int i = 0; i < N && group_count(g1) == N && group_count(g2) == N; i++) {
            const Object3D *t[3] = {group_child(g1, i), group_child(g2, i), group_child(g3, i)};
            Vec3 v[3][3], n[3];
            for (int k = 0; k < 3; k++) {
                triangle_vertices(t[k], v[k]);
                n[k] = triangle_normal(t[k]);
            }
            for (int k = 0; k < 2; k++)
                bad += memcmp(v[k], v[2], sizeof v[2]) != 0 || memcmp(&n[k], &n[2], sizeof n[2]) != 0 ||
                       memcmp(&t[k]->bbox, &t[2]->bbox, sizeof t[2]->bbox) != 0 ||
                       t[k]->material != t[2]->material || t[k]->ops != t[2]->ops;
        }
        CHECK_INT(bad, 0);
    }
    arena_free(&a);
    free(verts);
    free(faces);
}

/* A mapped text buffer too small to adopt is freed by arena_adopt_buffer, not kept with
 * the arena: rt/bigmem.h then keeps its mapping as a spare, and the next big array of
 * its size takes it instead of a fresh mapping (whose 2 MB page the kernel would zero). */
static void test_adopt_frees_small_buffer(void)
{
    if (!bigmem_maps_large())
        return; /* AddressSanitizer builds: every block is malloc'd */
    Arena a;
    arena_init(&a);
    size_t text = 1200u << 10; /* a 2 MB mapping, like the 40k bunny's 1.3 MB text */
    char *buf = arena_buffer_new(text);
    CHECK(buf != NULL);
    if (!buf)
        return;
    memset(buf, 0x5a, text);
    bool zeroed = false;
    char *mem = arena_adopt_buffer(&a, buf, 3u << 20, &zeroed);
    CHECK(mem != NULL && zeroed);
    /* The buffer's mapping (its data starts a header behind it) is handed out again. */
    char *next = bigmem_alloc(640u << 10);
    CHECK_MSG(next && next < buf && buf - next < 4096, "buffer at %p, next block at %p",
              (void *)buf, (void *)next);
    CHECK(next && next[0] == 0 && next[(640u << 10) - 1] == 0);
    bigmem_free(next);
    arena_free(&a);
}

/* A unit-size sphere made of a sphere of radius 2/s under UniformScale s, for the
 * scales the parser accepts (up to 1e12 either way): in the sphere's space the ray
 * direction's squared length a is 1/s^2, and a times the root's term h left float's
 * range. At s = 1e12 a * h of rays missing the sphere underflowed to -0 and passed as
 * hits (every ray of a picture "hit"); at s = 1e-10 it overflowed, the roots were
 * infinite and the sphere came out a flat disc; at 1e11 it was denormal (bits lost).
 * Each must give what s = 1 gives: the hit at t = 28 with normal +z, the ray 2.5 off
 * the axis missing, one 1.2 off hitting at t = 30 - sqrt(4 - 1.44) with the normal
 * (0, 0.6, 0.8), both under the tree's Transform and the grid's flattened path. */
static void test_sphere_extreme_scales(void)
{
    setup();
    const float scales[] = {1, 1e12f, 1e11f, 1e-10f, 1e-11f, 1e-12f * 1.5f};
    for (size_t k = 0; k < sizeof scales / sizeof scales[0]; k++) {
        float sc = scales[k];
        RenderCtx ctx = {0};
        Object3D *s = sphere_new(&arena, v3(0, 0, 0), 2.0f / sc, mat);
        Mat4 m = mat4_scale(v3(sc, sc, sc));
        Object3D *x = transform_new(&arena, &m, s);
        CHECK(x != NULL);
        if (!x)
            continue;
        group_assign_ids(x);
        XformPath path = {{x}, 1};
        for (int via = 0; via < 2; via++) {
            Hit h = hit_none();
            Ray r = ray(v3(0, 0, 30), v3(0, 0, -1));
            bool hit = via ? transform_path_intersect(&path, s, &r, &h, 0, &ctx)
                           : obj_intersect(x, &r, &h, 0, &ctx);
            CHECK_MSG(hit, "scale %g: the axis ray misses", (double)sc);
            CHECK_MSG(fabsf(h.t - 28) < 1e-4f && fabsf(h.normal.z - 1) < 1e-5f,
                      "scale %g: t %g, normal z %g", (double)sc, (double)h.t,
                      (double)h.normal.z);
            Hit h2 = hit_none();
            Ray off = ray(v3(0, 2.5f, 30), v3(0, 0, -1));
            hit = via ? transform_path_intersect(&path, s, &off, &h2, 0, &ctx)
                      : obj_intersect(x, &off, &h2, 0, &ctx);
            CHECK_MSG(!hit, "scale %g: a ray 2.5 off the axis hits at t %g", (double)sc,
                      (double)h2.t);
            Hit h3 = hit_none();
            Ray side = ray(v3(0, 1.2f, 30), v3(0, 0, -1));
            hit = via ? transform_path_intersect(&path, s, &side, &h3, 0, &ctx)
                      : obj_intersect(x, &side, &h3, 0, &ctx);
            CHECK_MSG(hit && fabsf(h3.t - (30 - 1.6f)) < 1e-4f &&
                          fabsf(h3.normal.y - 0.6f) < 1e-5f && fabsf(h3.normal.z - 0.8f) < 1e-5f,
                      "scale %g: off-axis hit %d at t %g, normal (%g, %g, %g)", (double)sc, hit,
                      (double)h3.t, (double)h3.normal.x, (double)h3.normal.y,
                      (double)h3.normal.z);
            CHECK(!obj_occluded(x, &off, 0, INFINITY, &ctx));
            CHECK(obj_occluded(x, &side, 0, INFINITY, &ctx));
        }
    }
}

/* The normals made once per primitive, where float's squared length overflows or
 * underflows: a floor Triangle with vertices at 1e10 (e1 x e2 of length 4e20, squared
 * 1.6e41) had the normal 0 and was lit by no light; one with edges of 1e-12 (squared
 * length 1e-48, 0 in float) kept the tiny vector as its "unit" normal; a Plane's
 * normal as given likewise (0 1e20 0, 0 1e-25 0). Each must be the unit vector, and an
 * ordinary triangle's must keep its bits (the float path). */
static void test_normals_of_huge_and_tiny(void)
{
    setup();
    const float sizes[] = {1e10f, 1e15f, 1e-12f, 1e-20f};
    for (size_t k = 0; k < sizeof sizes / sizeof sizes[0]; k++) {
        float e = sizes[k];
        Object3D *t = triangle_new(&arena, v3(-e, -1, e), v3(e, -1, e), v3(0, -1, -e), mat);
        Vec3 n = triangle_normal(t);
        CHECK_MSG(n.x == 0 && n.y == 1 && n.z == 0, "triangle of size %g: normal (%g, %g, %g)",
                  (double)e, (double)n.x, (double)n.y, (double)n.z);
    }
    Object3D *t = triangle_new(&arena, v3(0.1f, 0.2f, 0.3f), v3(1.7f, -0.4f, 0.9f),
                               v3(-0.3f, 1.1f, 2.3f), mat);
    Vec3 want = v3_normalize(v3_cross(v3_sub(v3(1.7f, -0.4f, 0.9f), v3(0.1f, 0.2f, 0.3f)),
                                      v3_sub(v3(-0.3f, 1.1f, 2.3f), v3(0.1f, 0.2f, 0.3f))));
    Vec3 got = triangle_normal(t);
    CHECK(memcmp(&want, &got, sizeof want) == 0);
    const float lens[] = {1e20f, 1e-25f};
    for (size_t k = 0; k < 2; k++) {
        Object3D *p = plane_new(&arena, v3(0, lens[k], 0), 0, mat);
        Vec3 u = plane_unit_normal(p);
        CHECK_MSG(u.x == 0 && u.y == 1 && u.z == 0, "plane normal 0 %g 0: unit (%g, %g, %g)",
                  (double)lens[k], (double)u.x, (double)u.y, (double)u.z);
    }
}

static const TestCase tests[] = {
    {"geom: arena: a mapped buffer too small to adopt is freed, its mapping reused", test_adopt_frees_small_buffer},
    {"geom: arena: a block filled by one request goes behind the head", test_arena_big_block_behind_head},
    {"geom: mesh in a fresh, an adopted and a plain block: same triangles", test_mesh_children_in_block},
    {"geom: sphere hit, miss, inside, tangent", test_sphere},
    {"geom: plane", test_plane},
    {"geom: triangle hit, miss, edge, parallel", test_triangle},
    {"geom: transform with non-uniform scale", test_transform_nonuniform},
    {"geom: sphere under UniformScale 1e12 .. 1e-12", test_sphere_extreme_scales},
    {"geom: normals of huge and tiny triangles and planes", test_normals_of_huge_and_tiny},
    {"geom: transform: tmin is a distance in the primitive's space", test_transform_tmin_object_space},
    {"geom: flattened path == nested transforms", test_path_matches_tree},
    {"geom: group nearest hit, tie-break, counting", test_group_and_ties},
    {"geom: occluded == intersect against (tmax, id 0), same counts", test_occluded_matches_intersect},
};
RT_TEST_MAIN(tests)
