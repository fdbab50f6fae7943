/* grid_ref: our grid traced the way bench/embree_ref traces Embree, for a like-for-like
 * throughput figure: one primary ray per pixel through our camera, then one shadow ray
 * per light per front-facing hit (epsilon RT_EPSILON), nothing shaded, nothing written.
 * -mode packet: 8x8 pixel tiles as ray packets (grid_intersect_packet /
 * grid_occluded_packet, or grid_occluded_packet_dir towards a directional light: what
 * the renderer does); -mode single: grid_intersect /
 * grid_occluded ray by ray. Prints the same key=value line as embree_ref. Built by
 * `make bench` (mk/bench.mk); docs/benchmarks.md. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <pthread.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "bench_util.h"
#include "rt/bigmem.h"
#include "rt/camera.h"
#include "rt/grid.h"
#include "rt/light.h"
#include "rt/raytracer.h"
#include "rt/render.h"
#include "rt/scene.h"

#define TILE RENDER_TILE /* the renderer's tiles and their order (rt/render.h) */

typedef struct Job {
    const Scene *sc;
    const Grid *grid;
    RayTracer rt;
    int w, h, packets, shade_back;
    int tiles_x;        /* tiles per row of tiles */
    float tmin;
    /* Per ray, in tile order: tile (tx, ty) holds slots [64 * (ty * tiles_x + tx), + 64),
     * its pixels in render_tile_order (the rays that lie in the image first, count[tile]
     * of them). The rays are made before the timed passes, laid out as the packets read
     * them, so the timed work reads each tile's rays in one sequential run and hands
     * them to the packet without copying (the lean anchor makes its rays in registers). */
    Ray *ray;
    unsigned char *count;
    float *t;
    unsigned char *lit;
    atomic_int next;
    atomic_llong shadow_rays, blocked;
} Job;

/* Makes every tile's rays (before the timed passes). */
static void make_tile_rays(Job *jb)
{
    int tiles_y = (jb->h + TILE - 1) / TILE;
    for (int ty = 0; ty < tiles_y; ty++)
        for (int tx = 0; tx < jb->tiles_x; tx++) {
            size_t tile = (size_t)ty * jb->tiles_x + tx;
            int n = 0;
            for (int k = 0; k < TILE * TILE; k++) {
                int dx, dy;
                render_tile_order(k, &dx, &dy);
                int x = tx * TILE + dx, y = ty * TILE + dy;
                if (x >= jb->w || y >= jb->h)
                    continue;
                float u, v;
                camera_pixel_to_screen(x, y, jb->w, jb->h, &u, &v);
                jb->ray[tile * TILE * TILE + n++] = camera_generate_ray(&jb->sc->camera, u, v);
            }
            jb->count[tile] = (unsigned char)n;
        }
}

/* What the primary pass stores per ray (the same as bench/embree_ref): t and the
 * shadow flag. */
static void finish(Job *jb, size_t idx, const Ray *r, const Hit *h, bool found)
{
    jb->t[idx] = found ? h->t : INFINITY;
    int front = found && v3_dot(h->normal, r->dir) <= 0.0f;
    jb->lit[idx] = found && isfinite(h->t) && (front || jb->shade_back);
}

static void primary_tile(Job *jb, RenderCtx *ctx, size_t tile)
{
    const Ray *rays = &jb->ray[tile * TILE * TILE];
    size_t base = tile * TILE * TILE;
    int n = jb->count[tile];
    Hit hits[TILE * TILE];
    for (int i = 0; i < n; i++)
        hits[i] = hit_none();
    if (jb->packets) {
        uint64_t found = grid_intersect_packet(jb->grid, rays, n, hits, jb->tmin, ctx);
        for (int i = 0; i < n; i++)
            finish(jb, base + i, &rays[i], &hits[i], found >> i & 1);
    } else {
        for (int i = 0; i < n; i++) {
            bool f = grid_intersect(jb->grid, &rays[i], &hits[i], jb->tmin, ctx);
            finish(jb, base + i, &rays[i], &hits[i], f);
        }
    }
}

static void shadow_tile(Job *jb, RenderCtx *ctx, size_t tile, long long *count,
                        long long *blocked)
{
    const Scene *sc = jb->sc;
    const Ray *rays = &jb->ray[tile * TILE * TILE];
    size_t base = tile * TILE * TILE;
    int n = jb->count[tile];
    Vec3 p[TILE * TILE];
    uint64_t live = 0;
    for (int k = 0; k < n; k++) {
        if (!jb->lit[base + k])
            continue;
        p[k] = ray_at(&rays[k], jb->t[base + k]);
        live |= (uint64_t)1 << k;
    }
    for (int l = 0; l < sc->num_lights && live; l++) {
        Ray sr[TILE * TILE];
        float dist[TILE * TILE];
        for (uint64_t m = live; m; m &= m - 1) {
            int k = __builtin_ctzll(m);
            Vec3 col;
            sr[k].origin = p[k];
            light_illuminate(&sc->lights[l], p[k], &sr[k].dir, &col, &dist[k]);
        }
        *count += __builtin_popcountll(live);
        if (jb->packets && sc->lights[l].kind == LIGHT_DIRECTIONAL) {
            /* As the renderer casts them (raytracer.c): a directional light's rays share
             * one direction and distance, asked once (grid_occluded_packet_dir; the same
             * answers). The per-ray calls above stay, as on Embree's side. */
            Vec3 l0, c0;
            float d0;
            light_illuminate(&sc->lights[l], v3(0.0f, 0.0f, 0.0f), &l0, &c0, &d0);
            uint64_t b = grid_occluded_packet_dir(jb->grid, sr, live, RT_EPSILON, d0, l0, ctx);
            *blocked += __builtin_popcountll(b);
        } else if (jb->packets) {
            uint64_t b = grid_occluded_packet(jb->grid, sr, live, RT_EPSILON, dist, ctx);
            *blocked += __builtin_popcountll(b);
        } else {
            for (uint64_t m = live; m; m &= m - 1) {
                int k = __builtin_ctzll(m);
                *blocked += grid_occluded(jb->grid, &sr[k], RT_EPSILON, dist[k], ctx);
            }
        }
    }
}

typedef struct Worker {
    Job *jb;
    int pass; /* 0 primary, 1 shadow */
    RenderCtx ctx;
} Worker;

static void *worker_main(void *arg)
{
    Worker *wk = arg;
    Job *jb = wk->jb;
    long long count = 0, blocked = 0;
    for (;;) {
        int y0 = atomic_fetch_add(&jb->next, 1) * TILE;
        if (y0 >= jb->h)
            break;
        size_t tile0 = (size_t)(y0 / TILE) * jb->tiles_x;
        for (int tx = 0; tx < jb->tiles_x; tx++) {
            /* The next tile's rays and answers on their way into the cache while this
             * one is traced (the anchor makes its rays in registers: no memory). */
            if (tx + 1 < jb->tiles_x) {
                size_t next = (tile0 + tx + 1) * TILE * TILE;
                const char *rp = (const char *)&jb->ray[next];
                for (size_t b = 0; b < TILE * TILE * sizeof *jb->ray; b += 64)
                    __builtin_prefetch(rp + b);
                for (size_t b = 0; b < TILE * TILE * sizeof *jb->t; b += 64)
                    __builtin_prefetch((const char *)&jb->t[next] + b, 1);
                __builtin_prefetch(&jb->lit[next], 1);
            }
            if (wk->pass == 0)
                primary_tile(jb, &wk->ctx, tile0 + tx);
            else
                shadow_tile(jb, &wk->ctx, tile0 + tx, &count, &blocked);
        }
    }
    atomic_fetch_add(&jb->shadow_rays, count);
    atomic_fetch_add(&jb->blocked, blocked);
    return NULL;
}

static double run_pass(Job *jb, Worker *wk, int pass, int nthreads, double *cpu)
{
    atomic_store(&jb->next, 0);
    for (int i = 0; i < nthreads; i++)
        wk[i].pass = pass;
    double c0 = cpu_s();
    double t = bench_run_pass(worker_main, wk, sizeof *wk, nthreads, "grid_ref");
    *cpu = cpu_s() - c0;
    return t;
}



static void usage(FILE *out)
{
    fputs("usage: grid_ref -input scene.txt [-size W H] [-grid NX NY NZ | -grid auto]\n"
          "                [-threads N] [-mode single|packet] [-repeat R] [-shadows]\n"
          "                [-shade_back] [-kernel generic|avx2|avx512]\n"
          "Traces our primary rays and (with -shadows) our shadow rays through our grid,\n"
          "nothing else, and prints one line of key=value timings (median of R repeats).\n",
          out);
}

int main(int argc, char **argv)
{
    const char *input = NULL;
    int w = 200, h = 200, threads = 1, packets = 1, repeat = 1, shadows = 0, shade_back = 0;
    int n[3] = {0, 0, 0};
    for (int a = 1; a < argc; a++) {
        if (!strcmp(argv[a], "-input") && a + 1 < argc)
            input = argv[++a];
        else if (!strcmp(argv[a], "-size") && a + 2 < argc)
            w = atoi(argv[a + 1]), h = atoi(argv[a + 2]), a += 2;
        else if (!strcmp(argv[a], "-grid") && a + 1 < argc && !strcmp(argv[a + 1], "auto"))
            n[0] = -1, a++;
        else if (!strcmp(argv[a], "-grid") && a + 3 < argc)
            n[0] = atoi(argv[a + 1]), n[1] = atoi(argv[a + 2]), n[2] = atoi(argv[a + 3]), a += 3;
        else if (!strcmp(argv[a], "-threads") && a + 1 < argc)
            threads = atoi(argv[++a]);
        else if (!strcmp(argv[a], "-kernel") && a + 1 < argc) {
            if (!grid_packet_use_kernel(argv[++a])) {
                fprintf(stderr, "grid_ref: no packet kernel '%s' on this CPU\n", argv[a]);
                return 2;
            }
        } else if (!strcmp(argv[a], "-repeat") && a + 1 < argc)
            repeat = atoi(argv[++a]);
        else if (!strcmp(argv[a], "-mode") && a + 1 < argc) {
            a++;
            if (!strcmp(argv[a], "single"))
                packets = 0;
            else if (strcmp(argv[a], "packet") != 0) {
                usage(stderr);
                return 2;
            }
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
        repeat < 1 || repeat > 1000 || n[0] == 0) {
        usage(stderr);
        return 2;
    }
    Diag diag;
    diag_init(&diag, stderr);
    Scene *sc = scene_load(input, &diag);
    if (!sc)
        return 1;
    if (!sc->has_camera || !sc->root) {
        fprintf(stderr, "grid_ref: %s has no camera or no group\n", input);
        scene_free(sc);
        return 1;
    }
    double t0 = now_s();
    PrimTable prims;
    if (!prim_table_build(&prims, sc)) {
        fprintf(stderr, "grid_ref: out of memory\n");
        scene_free(sc);
        return 1;
    }
    if (n[0] < 0)
        grid_choose_auto(&prims, n);
    Grid *grid = grid_build_table(&prims, n[0], n[1], n[2], &diag);
    double t_build = now_s() - t0;
    if (!grid) {
        fprintf(stderr, "grid_ref: no grid (nothing bounded, or out of memory)\n");
        prim_table_free(&prims);
        scene_free(sc);
        return 1;
    }

    size_t np = (size_t)w * (size_t)h;
    int tiles_x = (w + TILE - 1) / TILE, tiles_y = (h + TILE - 1) / TILE;
    size_t ntiles = (size_t)tiles_x * (size_t)tiles_y, nslots = ntiles * TILE * TILE;
    Job jb = {.sc = sc, .grid = grid, .w = w, .h = h, .packets = packets,
              .shade_back = shade_back, .tiles_x = tiles_x, .tmin = camera_tmin(&sc->camera)};
    jb.rt.scene = sc;
    Accel acc = grid_as_accel(grid);
    jb.rt.accel = &acc;
    jb.rt.single_rays = !packets;
    /* In huge pages where the system has them (rt/bigmem.h): 50 MB of rays at 1080p
     * would otherwise cost a TLB miss every few tiles. */
    jb.t = bigmem_calloc(nslots, sizeof *jb.t);
    jb.ray = bigmem_calloc(nslots, sizeof *jb.ray);
    jb.count = malloc(ntiles);
    jb.lit = bigmem_alloc(nslots);
    Worker *wk = calloc((size_t)threads, sizeof *wk);
    double *tp = malloc((size_t)repeat * sizeof *tp), *ts = malloc((size_t)repeat * sizeof *ts);
    double *cp = malloc((size_t)repeat * sizeof *cp), *cs = malloc((size_t)repeat * sizeof *cs);
    if (!jb.t || !jb.ray || !jb.count || !jb.lit || !wk || !tp || !ts) {
        fprintf(stderr, "grid_ref: out of memory\n");
        return 1;
    }
    make_tile_rays(&jb);
    for (int i = 0; i < threads; i++) {
        wk[i].jb = &jb;
        if (!raytracer_ctx_init(&wk[i].ctx, &jb.rt)) {
            fprintf(stderr, "grid_ref: out of memory\n");
            return 1;
        }
    }
    long long shadow_rays = 0, blocked = 0;
    for (int r = 0; r < repeat; r++) {
        tp[r] = run_pass(&jb, wk, 0, threads, &cp[r]);
        ts[r] = cs[r] = 0.0;
        if (shadows) {
            atomic_store(&jb.shadow_rays, 0);
            atomic_store(&jb.blocked, 0);
            ts[r] = run_pass(&jb, wk, 1, threads, &cs[r]);
            shadow_rays = atomic_load(&jb.shadow_rays);
            blocked = atomic_load(&jb.blocked);
        }
    }
    size_t hits = 0;
    uint64_t t_bits = 0; /* the sum of the t's bit patterns: equal answers, equal sums */
    for (size_t tile = 0; tile < ntiles; tile++)
        for (int i = 0; i < jb.count[tile]; i++) {
            float t = jb.t[tile * TILE * TILE + i];
            uint32_t u;
            memcpy(&u, &t, sizeof u);
            hits += isfinite(t);
            t_bits += u;
        }
    double mp = median(tp, repeat), ms = median(ts, repeat);
    double mcp = median(cp, repeat), mcs = median(cs, repeat);
    printf("grid mode=%s kernel=%s threads=%d size=%dx%d cells=%dx%dx%d build_ms=%.3f "
           "primary_rays=%zu primary_hits=%zu primary_ms=%.3f primary_mrays=%.3f "
           "shadow_rays=%lld shadow_blocked=%lld shadow_ms=%.3f shadow_mrays=%.3f "
           "primary_mrays_cpu=%.3f shadow_mrays_cpu=%.3f t_bits=%016llx\n",
           packets ? "packet" : "single", packets ? grid_packet_kernel() : "-", threads, w, h,
           n[0], n[1], n[2], t_build * 1e3, np, hits, mp * 1e3, (double)np / mp * 1e-6,
           shadow_rays, blocked, ms * 1e3, ms > 0 ? (double)shadow_rays / ms * 1e-6 : 0.0,
           (double)np / mcp * 1e-6, mcs > 0 ? (double)shadow_rays / mcs * 1e-6 : 0.0,
           (unsigned long long)t_bits);
    for (int i = 0; i < threads; i++)
        raytracer_ctx_free(&wk[i].ctx);
    free(wk), free(tp), free(ts), free(cp), free(cs);
    bigmem_free(jb.t), bigmem_free(jb.ray), free(jb.count), bigmem_free(jb.lit);
    grid_free(grid);
    prim_table_free(&prims);
    scene_free(sc);
    return 0;
}
