/* Property test of the accelerator interface (rt/accel.h): on seeded random scenes
 * (spheres, triangles, meshes with shared edges, nested Transforms with rotations and
 * non-uniform scales, planes, and a primitive of a kind no accelerator knows), EVERY registered accelerator, at
 * several settings, returns bit for bit the answer of "none" (t, normal, material,
 * primitive id; same found flag) for nearest-hit and occlusion queries, for single rays
 * and, where it has them, for packets. "none" itself is held to the scene tree's own
 * intersect (the course's RayCast). A new accelerator in the registry is tested here
 * without touching this file. */
#include <stdlib.h>
#include <string.h>

#include "../harness.h"
#include "rt/accel.h"
#include "rt/arena.h"
#include "rt/bigmem.h"
#include "rt/geom.h"
#include "rt/material.h"
#include "rt/raytracer.h"
#include "rt/scene.h"

static uint64_t seed_state;

/* xorshift64*: deterministic, seeded per scene. */
static uint64_t next_u64(void)
{
    seed_state ^= seed_state >> 12;
    seed_state ^= seed_state << 25;
    seed_state ^= seed_state >> 27;
    return seed_state * 0x2545F4914F6CDD1Dull;
}

static float uniform(float lo, float hi)
{
    return lo + (hi - lo) * (float)((double)(next_u64() >> 40) / (double)(1ull << 24));
}

static int pick(int n) { return (int)(next_u64() % (uint64_t)n); }

static Vec3 point_in(float lo, float hi)
{
    return v3(uniform(lo, hi), uniform(lo, hi), uniform(lo, hi));
}

static Vec3 direction(void)
{
    for (;;) {
        Vec3 d = point_in(-1, 1);
        float len = v3_length(d);
        if (len > 0.1f && len <= 1.0f)
            return v3_scale(d, 1.0f / len);
    }
}

/* A primitive no accelerator knows (OBJ_OTHER), as a new primitive would be: an
 * axis-aligned cube given by centre and half size, with only intersect and bounds.
 * Accelerators must bin it by its bounds and still agree with "none". */
typedef struct Cube {
    Object3D base;
    Vec3 c;
    float h;
} Cube;

static bool cube_intersect(const Object3D *self, const Ray *ray, Hit *hit, float tmin,
                           RenderCtx *ctx)
{
    const Cube *q = (const Cube *)self;
    ctx->stats.intersections++;
    float t0, t1;
    if (!bbox_ray_interval(&self->bbox, ray->origin, ray->dir, &t0, &t1))
        return false;
    float t = t0 > tmin ? t0 : t1;
    if (!(t > tmin) || !hit_accepts(hit, t, self->id))
        return false;
    /* The face hit: the axis along which the point is farthest out. */
    Vec3 d = v3_sub(ray_at(ray, t), q->c);
    int a = fabsf(d.x) >= fabsf(d.y) && fabsf(d.x) >= fabsf(d.z) ? 0 : fabsf(d.y) >= fabsf(d.z) ? 1 : 2;
    float s = v3_comp(d, a) < 0.0f ? -1.0f : 1.0f;
    hit->t = t;
    hit->normal = v3(a == 0 ? s : 0.0f, a == 1 ? s : 0.0f, a == 2 ? s : 0.0f);
    hit->material = self->material;
    hit->id = self->id;
    return true;
}

static BBox cube_bounds(const Object3D *self, const Mat4 *to_world)
{
    return to_world ? bbox_transform(&self->bbox, to_world) : self->bbox;
}

static const Object3DOps cube_ops = {.type_name = "Cube", .kind = OBJ_OTHER,
                                     .intersect = cube_intersect,
                                     .occluded = obj_occluded_by_intersect,
                                     .bounds = cube_bounds};

static Object3D *cube_new(Arena *a, Vec3 c, float h, const Material *m)
{
    Cube *q = arena_alloc(a, sizeof *q);
    if (!q)
        return NULL;
    memset(q, 0, sizeof *q);
    q->base.ops = &cube_ops;
    q->base.material = m;
    q->base.bounded = true;
    q->base.id = RT_NO_ID;
    q->base.bbox.min = v3_sub(c, v3(h, h, h));
    q->base.bbox.max = v3_add(c, v3(h, h, h));
    q->c = c;
    q->h = h;
    return &q->base;
}

typedef struct World {
    Scene s;
    const Material *mat[3];
    Vec3 corners[64]; /* shared mesh vertices, aimed at (ties between triangles) */
    int num_corners;
} World;

/* Rotations, non-uniform scales and translations, one to three of them. */
static Mat4 some_matrix(void)
{
    Mat4 m = mat4_identity();
    for (int k = 1 + pick(3); k > 0; k--) {
        Mat4 step;
        switch (pick(4)) {
        case 0: step = mat4_translate(point_in(-1, 1)); break;
        case 1: step = mat4_scale(v3(uniform(0.4f, 1.8f), uniform(0.4f, 1.8f), uniform(0.4f, 1.8f))); break;
        case 2: step = mat4_rotate_z(uniform(-90, 90)); break;
        default: step = mat4_rotate_axis(direction(), uniform(-180, 180)); break;
        }
        m = mat4_mul(&m, &step);
    }
    return m;
}

/* A grid of quads as one TriangleMesh: its triangles share edges and corners. */
static Object3D *some_mesh(World *w)
{
    enum { N = 3 };
    Vec3 verts[(N + 1) * (N + 1)];
    int faces[2 * N * N][3];
    Vec3 origin = point_in(-2, 1);
    float step = uniform(0.2f, 0.5f);
    for (int i = 0; i <= N; i++)
        for (int j = 0; j <= N; j++) {
            Vec3 v = v3_add(origin, v3((float)i * step, (float)((i + 2 * j) % 3) * 0.25f,
                                       (float)j * step));
            verts[i * (N + 1) + j] = v;
            if (w->num_corners < 64)
                w->corners[w->num_corners++] = v;
        }
    int f = 0;
    for (int i = 0; i < N; i++)
        for (int j = 0; j < N; j++) {
            int a = i * (N + 1) + j, b = a + 1, c = a + N + 1, d = c + 1;
            faces[f][0] = a, faces[f][1] = b, faces[f][2] = d, f++;
            faces[f][0] = a, faces[f][1] = d, faces[f][2] = c, f++;
        }
    return triangle_mesh_new(&w->s.arena, verts, (const int(*)[3])faces, f, w->mat[pick(3)]);
}

static Object3D *some_object(World *w, int depth)
{
    Arena *a = &w->s.arena;
    const Material *m = w->mat[pick(3)];
    switch (pick(depth < 3 ? 7 : 5)) {
    case 0:
        return sphere_new(a, point_in(-2, 2), uniform(0.1f, 0.8f), m);
    case 1:
        return pick(2) ? sphere_new(a, point_in(-2, 2), uniform(0.1f, 0.8f), m)
                       : cube_new(a, point_in(-2, 2), uniform(0.1f, 0.6f), m);
    case 2: {
        Vec3 c = point_in(-2, 2);
        return triangle_new(a, v3_add(c, point_in(-1, 1)), v3_add(c, point_in(-1, 1)),
                            v3_add(c, point_in(-1, 1)), m);
    }
    case 3:
        return some_mesh(w);
    case 4:
        return plane_new(a, direction(), uniform(-3, 3), m);
    default: {
        int n = 1 + pick(3);
        Object3D *g = group_new(a, n);
        for (int i = 0; i < n; i++)
            group_set_child(g, i, some_object(w, depth + 1));
        group_finish(g);
        Mat4 mm = some_matrix();
        Object3D *x = transform_new(a, &mm, g);
        return x ? x : g;
    }
    }
}

static void world_make(World *w, uint64_t seed, int objects)
{
    memset(w, 0, sizeof *w);
    seed_state = seed * 0x9E3779B97F4A7C15ull + 1;
    arena_init(&w->s.arena);
    for (int i = 0; i < 3; i++) {
        PhongParams p = phong_defaults();
        p.diffuse = point_in(0, 1);
        w->mat[i] = phong_new(&w->s.arena, &p);
    }
    Object3D *root = group_new(&w->s.arena, objects);
    for (int i = 0; i < objects; i++)
        group_set_child(root, i, some_object(w, 0));
    group_finish(root);
    w->s.root = root;
    w->s.num_primitives = group_assign_ids(root);
    w->s.bounds = root->bounded ? root->bbox : bbox_empty();
}

/* Camera-like rays toward random points or shared mesh corners, some axis-parallel,
 * some unnormalised, some starting far away; tmin as cameras and bounces use it. */
static void some_ray(const World *w, Ray *ray, float *tmin)
{
    Vec3 target = w->num_corners && pick(3) == 0 ? w->corners[pick(w->num_corners)]
                                                 : point_in(-2.5f, 2.5f);
    Vec3 from = pick(10) == 0 ? point_in(-400, 400) : point_in(-6, 6);
    Vec3 d = v3_sub(target, from);
    if (pick(8) == 0) {
        int a = pick(3);
        d = v3(a == 0, a == 1, a == 2);
        from = v3_sub(target, v3_scale(d, 5));
    } else if (pick(2)) {
        d = v3_normalize(d);
    }
    ray->origin = from;
    ray->dir = d;
    int k = pick(4);
    *tmin = k == 0 ? -INFINITY : k == 1 ? 1e-3f : 0.0f;
}

static bool same_bits(const Hit *a, const Hit *b)
{
    return memcmp(&a->t, &b->t, sizeof a->t) == 0 &&
           memcmp(&a->normal, &b->normal, sizeof a->normal) == 0 &&
           a->material == b->material && a->id == b->id;
}

typedef struct Tracer {
    Accel accel;
    RayTracer rt;
    RenderCtx ctx;
} Tracer;

static bool tracer_init(Tracer *tr, const AccelOps *ops, const PrimTable *t,
                        const AccelConfig *cfg)
{
    memset(tr, 0, sizeof *tr);
    Diag d;
    diag_init(&d, NULL);
    if (!accel_init(&tr->accel, ops, t, cfg, &d))
        return false;
    tr->rt.accel = &tr->accel;
    return raytracer_ctx_init(&tr->ctx, &tr->rt);
}

static void tracer_free(Tracer *tr)
{
    raytracer_ctx_free(&tr->ctx);
    accel_free(&tr->accel);
}

enum { RAYS = 600, PACKETS = 12 };

/* Compares accelerator tr against reference ref on the world's random rays. */
static void compare(const World *w, Tracer *ref, Tracer *tr, const char *what)
{
    int bad = 0;
    for (int i = 0; i < RAYS && bad < 3; i++) {
        Ray ray;
        float tmin;
        some_ray(w, &ray, &tmin);
        Hit a = hit_none(), b = hit_none();
        bool fa = accel_intersect(&ref->accel, &ray, &a, tmin, &ref->ctx);
        bool fb = accel_intersect(&tr->accel, &ray, &b, tmin, &tr->ctx);
        if (fa != fb || !same_bits(&a, &b)) {
            harness_fail(__FILE__, __LINE__, "%s: ray %d: hit t=%.9g id=%u vs none t=%.9g id=%u",
                         what, i, (double)b.t, b.id, (double)a.t, a.id);
            bad++;
        }
        /* Occlusion up to a random distance, often just at or around the nearest hit. */
        float tmax = isfinite(a.t) && pick(2) ? a.t * (pick(2) ? 1.0f : 1.0001f)
                                              : uniform(0.1f, 20.0f);
        float tmin_s = tmin > 0.0f ? tmin : 1e-3f;
        bool oa = accel_occluded(&ref->accel, &ray, tmin_s, tmax, &ref->ctx);
        bool ob = accel_occluded(&tr->accel, &ray, tmin_s, tmax, &tr->ctx);
        if (oa != ob) {
            harness_fail(__FILE__, __LINE__, "%s: ray %d: occluded %d vs none %d (tmax %.9g)",
                         what, i, ob, oa, (double)tmax);
            bad++;
        }
    }
    if (!accel_has_packets(&tr->accel) || !tr->ctx.packet_rays)
        return;
    for (int p = 0; p < PACKETS && bad < 3; p++) {
        /* Coherent (a camera's tile) or not (random rays), 1 to ACCEL_PACKET_MAX rays. */
        int n = 1 + pick(ACCEL_PACKET_MAX);
        Ray rays[ACCEL_PACKET_MAX];
        Hit hits[ACCEL_PACKET_MAX];
        float tmax[ACCEL_PACKET_MAX];
        bool coherent = pick(3) != 0;
        Vec3 eye = point_in(-6, 6), aim = point_in(-1, 1);
        float tmin = 0.0f;
        for (int i = 0; i < n; i++) {
            if (coherent) {
                rays[i].origin = eye;
                rays[i].dir = v3_normalize(v3_sub(v3_add(aim, v3(0.05f * (float)(i % 8), 0.05f * (float)(i / 8), 0)), eye));
            } else {
                float tm;
                some_ray(w, &rays[i], &tm);
            }
            hits[i] = hit_none();
            tmax[i] = uniform(0.5f, 15.0f);
        }
        uint64_t found = accel_intersect_packet(&tr->accel, rays, n, hits, tmin, &tr->ctx);
        uint64_t mask = n == 64 ? ~0ull : ((1ull << n) - 1);
        uint64_t blocked = accel_occluded_packet(&tr->accel, rays, mask, 1e-3f, tmax, &tr->ctx);
        for (int i = 0; i < n; i++) {
            Hit a = hit_none();
            bool fa = accel_intersect(&ref->accel, &rays[i], &a, tmin, &ref->ctx);
            bool oa = accel_occluded(&ref->accel, &rays[i], 1e-3f, tmax[i], &ref->ctx);
            if (fa != (bool)(found >> i & 1) || (fa && !same_bits(&a, &hits[i])) ||
                oa != (bool)(blocked >> i & 1)) {
                harness_fail(__FILE__, __LINE__, "%s: packet %d ray %d of %d differs from none",
                             what, p, i, n);
                bad++;
                break;
            }
        }
    }
}

/* The settings each accelerator is tried with: its defaults and grids of several shapes
 * (other accelerators ignore grid_n). */
static const AccelConfig configs[] = {
    {.grid_n = {1, 1, 1}, .grid_auto = false, .no_marking = false, .visualize = false},
    {.grid_n = {4, 7, 3}, .grid_auto = false, .no_marking = false, .visualize = false},
    {.grid_n = {0, 0, 0}, .grid_auto = true, .no_marking = false, .visualize = false},
    {.grid_n = {19, 11, 23}, .grid_auto = false, .no_marking = false, .visualize = false},
    {.grid_n = {9, 9, 9}, .grid_auto = false, .no_marking = true, .visualize = false},
};

static void run_world(uint64_t seed, int objects)
{
    World w;
    world_make(&w, seed, objects);
    PrimTable t;
    CHECK(prim_table_build(&t, &w.s));
    Tracer ref;
    CHECK(tracer_init(&ref, &accel_none_ops, &t, NULL));

    /* "none" is the tree walk's answer, to the bit. */
    for (int i = 0; i < RAYS; i++) {
        Ray ray;
        float tmin;
        some_ray(&w, &ray, &tmin);
        Hit a = hit_none(), b = hit_none();
        bool fa = obj_intersect(w.s.root, &ray, &a, tmin, &ref.ctx);
        bool fb = accel_intersect(&ref.accel, &ray, &b, tmin, &ref.ctx);
        CHECK_MSG(fa == fb && same_bits(&a, &b), "seed %llu ray %d: none differs from the tree walk",
                  (unsigned long long)seed, i);
        /* Its shadow query stops at the first occluder, yet answers and counts like the
         * tree walk's full loop (a (tmax, id 0) hit; every primitive tested). */
        float tmax = isfinite(a.t) && pick(2) ? a.t * (pick(2) ? 1.0f : 1.0001f)
                                              : uniform(0.1f, 20.0f);
        float tmin_s = tmin > 0.0f ? tmin : 1e-3f;
        Hit h = hit_none();
        h.t = tmax;
        h.id = 0;
        uint64_t c0 = ref.ctx.stats.intersections;
        bool oa = obj_intersect(w.s.root, &ray, &h, tmin_s, &ref.ctx);
        uint64_t c1 = ref.ctx.stats.intersections;
        bool ob = accel_occluded(&ref.accel, &ray, tmin_s, tmax, &ref.ctx);
        uint64_t c2 = ref.ctx.stats.intersections;
        CHECK_MSG(oa == ob && c2 - c1 == c1 - c0 && c1 - c0 == t.num_prims,
                  "seed %llu ray %d: none occluded %d (%llu tests) vs tree walk %d (%llu tests)",
                  (unsigned long long)seed, i, ob, (unsigned long long)(c2 - c1), oa,
                  (unsigned long long)(c1 - c0));
    }

    for (int r = 0; accel_registry[r]; r++) {
        const AccelOps *ops = accel_registry[r];
        for (size_t c = 0; c < sizeof configs / sizeof configs[0]; c++) {
            for (int packets = 0; packets < 2; packets++) {
                Tracer tr;
                memset(&tr, 0, sizeof tr);
                if (!tracer_init(&tr, ops, &t, &configs[c])) {
                    /* Only planes: the accelerator has nothing to hold (main falls back
                     * to "none"); anything else is a failure. */
                    CHECK_MSG(t.num_bounded == 0, "%s: could not be built", ops->name);
                    continue;
                }
                if (!packets) {
                    bigmem_free(tr.ctx.packet_rays); /* raytracer_ctx_init's (bigmem) */
                    tr.ctx.packet_rays = NULL;
                }
                char what[96];
                snprintf(what, sizeof what, "seed %llu, %s, setting %zu%s",
                         (unsigned long long)seed, ops->name, c, packets ? ", packets" : "");
                seed_state = seed; /* every accelerator sees the same rays */
                compare(&w, &ref, &tr, what);
                tracer_free(&tr);
            }
        }
    }
    tracer_free(&ref);
    prim_table_free(&t);
    arena_free(&w.s.arena);
}

static void test_small_worlds(void)
{
    for (uint64_t seed = 1; seed <= 12; seed++)
        run_world(seed, 1 + (int)(seed % 5));
}

static void test_larger_worlds(void)
{
    for (uint64_t seed = 100; seed < 106; seed++)
        run_world(seed, 12 + (int)(seed % 7) * 3);
}

/* Every registered accelerator has a distinct name, a summary and the required ops. */
static void test_registry(void)
{
    int n = 0;
    for (int r = 0; accel_registry[r]; r++, n++) {
        const AccelOps *ops = accel_registry[r];
        CHECK(ops->name && ops->summary && ops->create && ops->intersect && ops->occluded);
        CHECK((ops->intersect_packet == NULL) == (ops->occluded_packet == NULL));
        CHECK(accel_find(ops->name) == ops);
        CHECK_CONTAINS(accel_names(), ops->name);
    }
    CHECK(n >= 2);
    CHECK(accel_find("none") == &accel_none_ops);
    CHECK(accel_find("no-such-accelerator") == NULL);
}

static const TestCase tests[] = {
    {"registry", test_registry},
    {"small_worlds", test_small_worlds},
    {"larger_worlds", test_larger_worlds},
};

RT_TEST_MAIN(tests)
