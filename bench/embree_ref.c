/* embree_ref: the benchmark's reference tracer. Loads a scene through our own parser,
 * hands its world-space triangles (and untransformed or similarity-transformed spheres)
 * to Embree 3, and traces exactly our rays: one primary per pixel through our camera,
 * then one shadow ray per light per front-facing hit (epsilon RT_EPSILON, our light
 * directions), with single rays (rtcIntersect1/rtcOccluded1) or packets of 16 (4x4
 * pixel tiles, rtcIntersect16/rtcOccluded16). Planes are intersected analytically, as
 * ours are. Built only when libembree-dev is installed (mk/bench.mk); docs/benchmarks.md. */
#define _POSIX_C_SOURCE 200809L
#include <embree3/rtcore.h>
#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench_util.h"
#include "rt/camera.h"
#include "rt/geom.h"
#include "rt/image.h"
#include "rt/light.h"
#include "rt/matrix.h"
#include "rt/raytracer.h"
#include "rt/scene.h"

typedef struct PlaneW {
    Vec3 n;      /* as given (not normalised): t = (d - n.o) / (n.dir), like ours */
    float d;
} PlaneW;

/* World-space geometry collected from the scene tree. */
typedef struct Geo {
    float *tv;          /* triangle vertices, 3 floats each, 3 per triangle */
    Vec3 *tn;           /* unit world normals as our Transform computes their direction */
    size_t ntri, cap_tri;
    float *sp;          /* spheres: x y z r */
    size_t nsph, cap_sph;
    PlaneW *pl;
    size_t npl, cap_pl;
    size_t skipped;     /* spheres under non-similarity transforms, OBJ_OTHER leaves */
} Geo;

static void *grow(void *p, size_t *cap, size_t need, size_t elem)
{
    if (need <= *cap)
        return p;
    size_t c = *cap ? *cap : 256;
    while (c < need)
        c *= 2;
    void *q = realloc(p, c * elem);
    if (!q) {
        fprintf(stderr, "embree_ref: out of memory\n");
        exit(1);
    }
    *cap = c;
    return q;
}

static float det3(const Mat4 *m)
{
    const float(*a)[4] = m->m;
    return a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1]) -
           a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0]) +
           a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0]);
}

static void collect(const Object3D *o, const Mat4 *m, Geo *g)
{
    switch (obj_kind(o)) {
    case OBJ_GROUP:
        for (int i = 0; i < group_count(o); i++)
            collect(group_child(o, i), m, g);
        break;
    case OBJ_TRANSFORM: {
        Mat4 mm = mat4_mul(m, transform_matrix(o));
        collect(transform_child(o), &mm, g);
        break;
    }
    case OBJ_TRIANGLE: {
        Vec3 v[3];
        triangle_vertices(o, v);
        for (int k = 0; k < 3; k++)
            v[k] = mat4_point(m, v[k]);
        /* a mirroring matrix flips the winding; keep the normal our Transform gives
         * (inverse transpose of the object normal) by swapping two vertices */
        if (det3(m) < 0.0f) {
            Vec3 t = v[1];
            v[1] = v[2];
            v[2] = t;
        }
        g->tv = grow(g->tv, &g->cap_tri, g->ntri + 1, 9 * sizeof(float));
        g->tn = realloc(g->tn, g->cap_tri * sizeof(Vec3));
        if (!g->tn) {
            fprintf(stderr, "embree_ref: out of memory\n");
            exit(1);
        }
        float *dst = g->tv + 9 * g->ntri;
        for (int k = 0; k < 3; k++)
            dst[3 * k] = v[k].x, dst[3 * k + 1] = v[k].y, dst[3 * k + 2] = v[k].z;
        g->tn[g->ntri] = v3_normalize(v3_cross(v3_sub(v[1], v[0]), v3_sub(v[2], v[0])));
        g->ntri++;
        break;
    }
    case OBJ_SPHERE: {
        /* a similarity (rotation, uniform scale, translation) keeps a sphere a sphere */
        Vec3 c0 = {m->m[0][0], m->m[1][0], m->m[2][0]}, c1 = {m->m[0][1], m->m[1][1], m->m[2][1]},
             c2 = {m->m[0][2], m->m[1][2], m->m[2][2]};
        float l0 = v3_length(c0), l1 = v3_length(c1), l2 = v3_length(c2);
        if (fabsf(l0 - l1) > 1e-5f * l0 || fabsf(l0 - l2) > 1e-5f * l0 ||
            fabsf(v3_dot(c0, c1)) > 1e-5f * l0 * l0 || fabsf(v3_dot(c0, c2)) > 1e-5f * l0 * l0) {
            g->skipped++;
            break;
        }
        Vec3 c = mat4_point(m, sphere_center(o));
        g->sp = grow(g->sp, &g->cap_sph, g->nsph + 1, 4 * sizeof(float));
        float *dst = g->sp + 4 * g->nsph++;
        dst[0] = c.x, dst[1] = c.y, dst[2] = c.z, dst[3] = sphere_radius(o) * l0;
        break;
    }
    case OBJ_PLANE: {
        Vec3 n = plane_normal(o);
        float d = plane_offset(o);
        Mat4 inv;
        if (!mat4_inverse(m, &inv))
            break;
        /* a point of the plane and the normal carried to world space */
        Vec3 p0 = v3_scale(n, d / v3_dot(n, n));
        Vec3 wp = mat4_point(m, p0), wn = mat4_dir_transposed(&inv, n);
        g->pl = grow(g->pl, &g->cap_pl, g->npl + 1, sizeof(PlaneW));
        g->pl[g->npl].n = wn;
        g->pl[g->npl].d = v3_dot(wn, wp);
        g->npl++;
        break;
    }
    default: /* a leaf Embree is not given (OBJ_OTHER): counted like the spheres above */
        g->skipped++;
        break;
    }
}

/* ---- the run --------------------------------------------------------------------- */

typedef struct Job {
    RTCScene scene;
    const Scene *sc;
    const Geo *geo;
    int w, h, packets, shade_back;
    float tmin;
    /* per pixel: the primary ray, made before the timed passes (ray generation is
     * not Embree's work), then what the primary pass stores: exactly what
     * bench/grid_ref stores on our side (t and the shadow flag) */
    Vec3 *org, *dir;
    float *t;
    unsigned char *lit; /* 1: front-facing hit (or shade_back): shadow rays are cast */
    atomic_int next;    /* next block of rows */
    atomic_llong shadow_rays, blocked;
} Job;

enum { ROWS_PER_BLOCK = 4 };


/* The nearest plane hit below *t; *facing becomes the sign source n.d of the hit
 * (the normal as given: only its side matters here). */
static inline void plane_hit(const Geo *g, Vec3 o, Vec3 d, float tmin, float *t,
                             float *facing)
{
    for (size_t i = 0; i < g->npl; i++) {
        float den = v3_dot(g->pl[i].n, d);
        if (den == 0.0f)
            continue;
        float tt = (g->pl[i].d - v3_dot(g->pl[i].n, o)) / den;
        if (tt > tmin && tt < *t) {
            *t = tt;
            *facing = den;
        }
    }
}

static int plane_blocks(const Geo *g, Vec3 o, Vec3 d, float tmin, float tmax)
{
    for (size_t i = 0; i < g->npl; i++) {
        float den = v3_dot(g->pl[i].n, d);
        if (den == 0.0f)
            continue;
        float tt = (g->pl[i].d - v3_dot(g->pl[i].n, o)) / den;
        if (tt > tmin && tt < tmax)
            return 1;
    }
    return 0;
}

/* Stores the primary hit of pixel idx given Embree's answer: its t and whether it
 * faces the ray (the sign of n.d, from our unit triangle normals or the sphere's
 * radius vector: nothing normalised, nothing else stored). */
static inline void finish_primary(Job *jb, size_t idx, Vec3 o, Vec3 d, float t,
                                  unsigned geom, unsigned prim)
{
    const Geo *g = jb->geo;
    float facing = 0.0f;
    if (geom == 0) {
        facing = v3_dot(g->tn[prim], d);
    } else if (geom == 1) {
        const float *s = g->sp + 4 * prim;
        Vec3 p = v3_madd(o, d, t);
        facing = v3_dot(v3_sub(p, v3(s[0], s[1], s[2])), d);
    } else {
        t = INFINITY;
    }
    if (g->npl)
        plane_hit(g, o, d, jb->tmin, &t, &facing);
    jb->t[idx] = t;
    jb->lit[idx] = isfinite(t) && (facing <= 0.0f || jb->shade_back);
}

static void primary_rows(Job *jb, struct RTCIntersectContext *ctx, int y0, int y1)
{
    if (!jb->packets) {
        for (size_t idx = (size_t)y0 * jb->w; idx < (size_t)y1 * jb->w; idx++) {
            Vec3 o = jb->org[idx], d = jb->dir[idx];
            struct RTCRayHit rh;
            rh.ray.org_x = o.x, rh.ray.org_y = o.y, rh.ray.org_z = o.z;
            rh.ray.dir_x = d.x, rh.ray.dir_y = d.y, rh.ray.dir_z = d.z;
            rh.ray.tnear = jb->tmin, rh.ray.tfar = INFINITY;
            rh.ray.mask = 0xFFFFFFFFu, rh.ray.flags = 0, rh.ray.time = 0.0f, rh.ray.id = 0;
            rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
            rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
            rtcIntersect1(jb->scene, ctx, &rh);
            finish_primary(jb, idx, o, d, rh.ray.tfar, rh.hit.geomID, rh.hit.primID);
        }
        return;
    }
    /* packets of 16 = 4 x 4 pixel tiles (coherent rays) */
    for (int j0 = y0; j0 < y1; j0 += 4)
        for (int i0 = 0; i0 < jb->w; i0 += 4) {
            struct RTCRayHit16 rh __attribute__((aligned(64)));
            int valid[16] __attribute__((aligned(64)));
            size_t idx[16];
            for (int k = 0; k < 16; k++) {
                int i = i0 + (k & 3), j = j0 + (k >> 2);
                valid[k] = (i < jb->w && j < y1) ? -1 : 0;
                idx[k] = valid[k] ? (size_t)j * jb->w + i : (size_t)y0 * jb->w;
                Vec3 o = jb->org[idx[k]], d = jb->dir[idx[k]];
                rh.ray.org_x[k] = o.x, rh.ray.org_y[k] = o.y, rh.ray.org_z[k] = o.z;
                rh.ray.dir_x[k] = d.x, rh.ray.dir_y[k] = d.y, rh.ray.dir_z[k] = d.z;
                rh.ray.tnear[k] = jb->tmin, rh.ray.tfar[k] = INFINITY;
                rh.ray.mask[k] = 0xFFFFFFFFu, rh.ray.flags[k] = 0, rh.ray.time[k] = 0.0f;
                rh.ray.id[k] = (unsigned)k;
                rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
                rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
            }
            rtcIntersect16(valid, jb->scene, ctx, &rh);
            for (int k = 0; k < 16; k++)
                if (valid[k])
                    finish_primary(jb, idx[k], jb->org[idx[k]], jb->dir[idx[k]], rh.ray.tfar[k],
                                   rh.hit.geomID[k], rh.hit.primID[k]);
        }
}

static void shadow_rows(Job *jb, struct RTCIntersectContext *ctx, int y0, int y1)
{
    const Scene *sc = jb->sc;
    long long count = 0, blocked = 0;
    if (!jb->packets) {
        for (int idx = y0 * jb->w; idx < y1 * jb->w; idx++) {
            if (!jb->lit[idx])
                continue;
            Ray pr = {jb->org[idx], jb->dir[idx]};
            Vec3 p = ray_at(&pr, jb->t[idx]);
            for (int l = 0; l < sc->num_lights; l++) {
                Vec3 L, col;
                float dist;
                light_illuminate(&sc->lights[l], p, &L, &col, &dist);
                struct RTCRay r;
                r.org_x = p.x, r.org_y = p.y, r.org_z = p.z;
                r.dir_x = L.x, r.dir_y = L.y, r.dir_z = L.z;
                r.tnear = RT_EPSILON, r.tfar = dist;
                r.mask = 0xFFFFFFFFu, r.flags = 0, r.time = 0.0f, r.id = 0;
                rtcOccluded1(jb->scene, ctx, &r);
                blocked += r.tfar < 0.0f || plane_blocks(jb->geo, p, L, RT_EPSILON, dist);
                count++;
            }
        }
    } else {
        for (int j0 = y0; j0 < y1; j0 += 4)
            for (int i0 = 0; i0 < jb->w; i0 += 4) {
                Vec3 p[16];
                int valid0[16];
                for (int k = 0; k < 16; k++) {
                    int i = i0 + (k & 3), j = j0 + (k >> 2);
                    valid0[k] = 0;
                    if (i >= jb->w || j >= y1)
                        continue;
                    int idx = j * jb->w + i;
                    if (!jb->lit[idx])
                        continue;
                    Ray pr = {jb->org[idx], jb->dir[idx]};
                    p[k] = ray_at(&pr, jb->t[idx]);
                    valid0[k] = -1;
                }
                for (int l = 0; l < sc->num_lights; l++) {
                        struct RTCRay16 r __attribute__((aligned(64)));
                    int valid[16] __attribute__((aligned(64))), any = 0;
                    Vec3 L[16];
                    float dist[16];
                    for (int k = 0; k < 16; k++) {
                        valid[k] = valid0[k];
                        if (!valid[k]) {
                            r.tnear[k] = 0.0f, r.tfar[k] = -INFINITY;
                            continue;
                        }
                        any = 1;
                        Vec3 col;
                        light_illuminate(&sc->lights[l], p[k], &L[k], &col, &dist[k]);
                        r.org_x[k] = p[k].x, r.org_y[k] = p[k].y, r.org_z[k] = p[k].z;
                        r.dir_x[k] = L[k].x, r.dir_y[k] = L[k].y, r.dir_z[k] = L[k].z;
                        r.tnear[k] = RT_EPSILON, r.tfar[k] = dist[k];
                        r.mask[k] = 0xFFFFFFFFu, r.flags[k] = 0, r.time[k] = 0.0f;
                        r.id[k] = (unsigned)k;
                        count++;
                    }
                    if (!any)
                        continue;
                    rtcOccluded16(valid, jb->scene, ctx, &r);
                    for (int k = 0; k < 16; k++)
                        if (valid[k])
                            blocked += r.tfar[k] < 0.0f ||
                                       plane_blocks(jb->geo, p[k], L[k], RT_EPSILON, dist[k]);
                }
            }
    }
    atomic_fetch_add(&jb->shadow_rays, count);
    atomic_fetch_add(&jb->blocked, blocked);
}

typedef struct Worker {
    Job *jb;
    int pass; /* 0 primary, 1 shadow */
} Worker;

static void *worker_main(void *arg)
{
    Worker *wk = arg;
    Job *jb = wk->jb;
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    /* blocks of 4 rows: whole packet tiles, and dynamic hand-out balances the threads */
    for (;;) {
        int b = atomic_fetch_add(&jb->next, 1);
        int y0 = b * ROWS_PER_BLOCK;
        if (y0 >= jb->h)
            break;
        int y1 = y0 + ROWS_PER_BLOCK < jb->h ? y0 + ROWS_PER_BLOCK : jb->h;
        if (wk->pass == 0) {
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
            primary_rows(jb, &ctx, y0, y1);
        } else {
            ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT;
            shadow_rows(jb, &ctx, y0, y1);
        }
    }
    return NULL;
}

/* One pass over the image with nthreads workers; returns its wall time. */
static double run_pass(Job *jb, int pass, int nthreads, double *cpu)
{
    Worker wk[64];
    atomic_store(&jb->next, 0);
    for (int i = 0; i < nthreads; i++)
        wk[i].jb = jb, wk[i].pass = pass;
    double c0 = cpu_s();
    double t = bench_run_pass(worker_main, wk, sizeof *wk, nthreads, "embree_ref");
    *cpu = cpu_s() - c0;
    return t;
}



static void usage(FILE *out)
{
    fputs("usage: embree_ref -input scene.txt [-size W H] [-threads N] [-mode single|packet]\n"
          "                  [-repeat R] [-shadows] [-shade_back] [-depth DMIN DMAX FILE]\n"
          "Traces our primary rays and (with -shadows) our shadow rays with Embree and prints\n"
          "one line of key=value timings (median of R repeats of each pass). -depth writes\n"
          "the primary hits as the course's depth image, to compare with ours.\n",
          out);
}

int main(int argc, char **argv)
{
    const char *input = NULL, *depth_file = NULL;
    float dmin = 0.0f, dmax = 1.0f;
    int w = 200, h = 200, threads = 1, packets = 0, repeat = 1, shadows = 0, shade_back = 0;
    for (int a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "-input") && a + 1 < argc)
            input = argv[++a];
        else if (!strcmp(argv[a], "-size") && a + 2 < argc)
            w = atoi(argv[a + 1]), h = atoi(argv[a + 2]), a += 2;
        else if (!strcmp(argv[a], "-threads") && a + 1 < argc)
            threads = atoi(argv[++a]);
        else if (!strcmp(argv[a], "-repeat") && a + 1 < argc)
            repeat = atoi(argv[++a]);
        else if (!strcmp(argv[a], "-mode") && a + 1 < argc) {
            a++;
            if (!strcmp(argv[a], "packet"))
                packets = 1;
            else if (strcmp(argv[a], "single") != 0) {
                usage(stderr);
                return 2;
            }
        } else if (!strcmp(argv[a], "-depth") && a + 3 < argc) {
            dmin = strtof(argv[a + 1], NULL), dmax = strtof(argv[a + 2], NULL);
            depth_file = argv[a + 3];
            a += 3;
        } else if (!strcmp(argv[a], "-shadows"))
            shadows = 1;
        else if (!strcmp(argv[a], "-shade_back"))
            shade_back = 1;
        else if (!strcmp(argv[a], "-h") || !strcmp(argv[a], "--help")) {
            usage(stdout);
            return 0;
        } else {
            usage(stderr);
            return 2;
        }
    }
    if (!input || w < 1 || h < 1 || w > 16384 || h > 16384 || threads < 1 || threads > 64 ||
        repeat < 1 || repeat > 1000) {
        usage(stderr);
        return 2;
    }

    double t0 = now_s();
    Diag diag;
    diag_init(&diag, stderr);
    Scene *sc = scene_load(input, &diag);
    if (!sc)
        return 1;
    if (!sc->has_camera || !sc->root) {
        fprintf(stderr, "embree_ref: %s has no camera or no group\n", input);
        scene_free(sc);
        return 1;
    }
    double t_load = now_s() - t0;

    Geo geo = {0};
    Mat4 id = mat4_identity();
    collect(sc->root, &id, &geo);

    t0 = now_s();
    char cfg[64];
    snprintf(cfg, sizeof cfg, "threads=%d", threads);
    RTCDevice dev = rtcNewDevice(cfg);
    if (!dev) {
        fprintf(stderr, "embree_ref: rtcNewDevice failed (error %d)\n", (int)rtcGetDeviceError(NULL));
        return 1;
    }
    RTCScene scene = rtcNewScene(dev);
    /* geometry 0: triangles, 1: spheres (ids are fixed by attach order) */
    RTCGeometry tg = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb = rtcSetNewGeometryBuffer(tg, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                        3 * sizeof(float), geo.ntri * 3);
    unsigned *ib = rtcSetNewGeometryBuffer(tg, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                           3 * sizeof(unsigned), geo.ntri);
    if ((geo.ntri && (!vb || !ib))) {
        fprintf(stderr, "embree_ref: cannot allocate Embree buffers\n");
        return 1;
    }
    if (geo.ntri)
        memcpy(vb, geo.tv, geo.ntri * 9 * sizeof(float));
    for (size_t i = 0; i < 3 * geo.ntri; i++)
        ib[i] = (unsigned)i;
    rtcCommitGeometry(tg);
    rtcAttachGeometryByID(scene, tg, 0);
    rtcReleaseGeometry(tg);
    if (geo.nsph) {
        RTCGeometry sg = rtcNewGeometry(dev, RTC_GEOMETRY_TYPE_SPHERE_POINT);
        float *sb = rtcSetNewGeometryBuffer(sg, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT4,
                                            4 * sizeof(float), geo.nsph);
        memcpy(sb, geo.sp, geo.nsph * 4 * sizeof(float));
        rtcCommitGeometry(sg);
        rtcAttachGeometryByID(scene, sg, 1);
        rtcReleaseGeometry(sg);
    }
    rtcCommitScene(scene);
    double t_build = now_s() - t0;

    size_t np = (size_t)w * (size_t)h;
    Job jb = {.scene = scene, .sc = sc, .geo = &geo, .w = w, .h = h, .packets = packets,
              .shade_back = shade_back};
    /* Embree needs tnear >= 0: orthographic cameras (tmin = -inf in the course) get 0 */
    jb.tmin = camera_tmin(&sc->camera) > 0.0f ? camera_tmin(&sc->camera) : 0.0f;
    jb.t = malloc(np * sizeof *jb.t);
    jb.lit = malloc(np);
    jb.dir = malloc(np * sizeof *jb.dir);
    jb.org = malloc(np * sizeof *jb.org);
    if (!jb.t || !jb.lit || !jb.dir || !jb.org) {
        fprintf(stderr, "embree_ref: out of memory\n");
        return 1;
    }
    bench_make_rays(&sc->camera, w, h, jb.org, jb.dir);
    double *tp = malloc((size_t)repeat * sizeof *tp), *ts = malloc((size_t)repeat * sizeof *ts);
    double *cp = malloc((size_t)repeat * sizeof *cp), *cs = malloc((size_t)repeat * sizeof *cs);
    long long shadow_rays = 0, blocked = 0;
    for (int r = 0; r < repeat; r++) {
        tp[r] = run_pass(&jb, 0, threads, &cp[r]);
        ts[r] = cs[r] = 0.0;
        if (shadows) {
            atomic_store(&jb.shadow_rays, 0);
            atomic_store(&jb.blocked, 0);
            ts[r] = run_pass(&jb, 1, threads, &cs[r]);
            shadow_rays = atomic_load(&jb.shadow_rays);
            blocked = atomic_load(&jb.blocked);
        }
    }
    size_t hits = 0;
    for (size_t i = 0; i < np; i++)
        hits += isfinite(jb.t[i]);
    if (depth_file) {
        /* -depth: clamp t to [dmin, dmax], near white; no hit black */
        Image img;
        if (!(dmax > dmin) || !image_init(&img, w, h)) {
            fprintf(stderr, "embree_ref: bad -depth range or out of memory\n");
            return 1;
        }
        for (int j = 0; j < h; j++)
            for (int i = 0; i < w; i++) {
                float t = jb.t[(size_t)j * (size_t)w + (size_t)i], g = 0.0f;
                if (isfinite(t)) {
                    float d = t < dmin ? dmin : t > dmax ? dmax : t;
                    g = (dmax - d) / (dmax - dmin);
                }
                image_set(&img, i, j, v3(g, g, g));
            }
        bool ok = image_write(&img, depth_file, &diag);
        image_free(&img);
        if (!ok)
            return 1;
    }
    double mp = median(tp, repeat), ms = median(ts, repeat);
    double mcp = median(cp, repeat), mcs = median(cs, repeat);
    printf("embree mode=%s threads=%d size=%dx%d triangles=%zu spheres=%zu planes=%zu "
           "skipped=%zu load_ms=%.3f build_ms=%.3f primary_rays=%zu primary_hits=%zu "
           "primary_ms=%.3f primary_mrays=%.3f shadow_rays=%lld shadow_blocked=%lld shadow_ms=%.3f "
           "shadow_mrays=%.3f primary_mrays_cpu=%.3f shadow_mrays_cpu=%.3f\n",
           packets ? "packet" : "single", threads, w, h, geo.ntri, geo.nsph, geo.npl, geo.skipped,
           t_load * 1e3, t_build * 1e3, np, hits, mp * 1e3, (double)np / mp * 1e-6,
           shadow_rays, blocked, ms * 1e3, ms > 0 ? (double)shadow_rays / ms * 1e-6 : 0.0,
           (double)np / mcp * 1e-6, mcs > 0 ? (double)shadow_rays / mcs * 1e-6 : 0.0);
    rtcReleaseScene(scene);
    rtcReleaseDevice(dev);
    free(tp), free(ts), free(cp), free(cs), free(jb.t), free(jb.lit), free(jb.dir), free(jb.org);
    free(geo.tv), free(geo.tn), free(geo.sp), free(geo.pl);
    scene_free(sc);
    return 0;
}
