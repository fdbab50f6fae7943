/* The image loop: bands of rows handed out to worker threads through an atomic
 * counter. A pixel depends only on its coordinates, and the tiles only on the image
 * size, so images and counters are identical for any thread count. */
#include "rt/render.h"
#include "rt/bigmem.h"
#include "rt/cpu.h"
#include "rt/par.h"

#include <pthread.h>
#include <stdatomic.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#define RENDER_PLANES_AVX2 1
#endif

/* A parallel run: jobs 0..n-1 handed out through an atomic counter. */
typedef struct ParRun {
    RenderJobFn fn;
    void *user;
    int jobs;
    volatile int *cancel;
    atomic_int next;
} ParRun;

/* Each worker on cache lines of its own: its counters change at every cell and test,
 * and two threads writing one line would bounce it between the cores. */
typedef struct Worker {
    _Alignas(128) ParRun *run;
    RenderCtx ctx;
    pthread_t thread;
    bool started;
} Worker;

int render_default_threads(void)
{
    long n = sysconf(_SC_NPROCESSORS_ONLN);
    return n > 0 ? (int)n : 1;
}

/* Rows are rendered in bands of TILE rows, each band in TILE x TILE tiles: a tile's
 * primary rays (and then their shadow rays) go through the grid as one packet. */
#define TILE RENDER_TILE
_Static_assert(TILE * TILE <= ACCEL_PACKET_MAX, "a tile must fit in one ray packet");
_Static_assert(TILE <= CAMERA_BLOCK_MAX, "a tile is one block of camera_pixel_rays");
_Static_assert(TILE == 8, "a whole tile is camera_block8_rays' block");

Vec3 render_depth_color(const Hit *hit, float depth_min, float depth_max)
{
    if (!(hit->material != NULL && isfinite(hit->t)))
        return v3(0, 0, 0);
    /* dmin white, dmax black, linear between them (A1: near white, far black). t is
     * clamped to the range between the two, whichever is larger: with dmin > dmax the
     * same line read the other way (near black, far white); clamped to dmin first and
     * then to dmax, every t came out at one end or the other, a hard step at dmin. */
    float lo = depth_min < depth_max ? depth_min : depth_max;
    float hi = depth_min < depth_max ? depth_max : depth_min;
    float d = hit->t < lo ? lo : hit->t > hi ? hi : hit->t;
    float g = (depth_max - d) / (depth_max - depth_min);
    /* A range wider than the largest float (-depth -3e38 3e38) made the divisor
     * infinite and every hit black: the same ratio of halves, which cannot overflow.
     * Any finite range keeps the division above, bit for bit. */
    if (!isfinite(depth_max - depth_min))
        g = (depth_max * 0.5f - d * 0.5f) / (depth_max * 0.5f - depth_min * 0.5f);
    return v3(g, g, g);
}

Vec3 render_normal_color(const Hit *hit)
{
    if (!(hit->material != NULL && isfinite(hit->t)))
        return v3(0, 0, 0);
    return v3(fabsf(hit->normal.x), fabsf(hit->normal.y), fabsf(hit->normal.z));
}

/* Rows of colour bytes in a file's layout (rt/render.h, color_file and color_rows):
 * row y of the target's rectangle (y = 0 at the bottom), for y <= top, at
 * rows + (top - y) * 3 * w: the whole file's rows (top = h - 1), or one band's. */
typedef struct FileRows {
    uint8_t *rows;
    int top;
} FileRows;

/* Where pixel (x, y) of the target's rectangle goes in f. */
static uint8_t *file_pixel(const FileRows *f, const RenderTarget *t, int x, int y)
{
    return f->rows + 3 * ((size_t)(f->top - y) * (size_t)t->w + (size_t)x);
}

/* The three images a render fills, as indices of its per-image arrays. */
enum { OUT_COLOR, OUT_DEPTH, OUT_NORMALS, OUT_COUNT };

/* Pixel (x, y) of the target's rectangle into f (quantised as image_put does), in
 * B G R order when bgr. */
static void file_put(const FileRows *f, const RenderTarget *t, int x, int y, bool bgr, Vec3 c)
{
    uint8_t *b = file_pixel(f, t, x, y);
    int r = bgr ? 2 : 0;
    b[r] = image_color_to_byte(c.x);
    b[1] = image_color_to_byte(c.y);
    b[2 - r] = image_color_to_byte(c.z);
}

/* Pixel (x, y) of image i of t (NULL: not requested) into f[i], or into the image when
 * f[i] is NULL. */
static void out_put(RenderTarget *t, FileRows *const f[OUT_COUNT], int i, int x, int y, Vec3 c)
{
    Image *img = i == OUT_COLOR ? t->color : i == OUT_DEPTH ? t->depth : t->normals;
    if (!img)
        return;
    if (f[i])
        file_put(f[i], t, x, y, i == OUT_COLOR ? t->color_bgr : t->normals_bgr, c);
    else
        image_put(img, x, y, c);
}

/* (x, y) is a pixel of the full image; the images hold the target's rectangle, and
 * image i goes to f[i] instead when f[i] is not NULL. */
static void store_pixel(RenderTarget *t, FileRows *const f[OUT_COUNT], int x, int y, Vec3 c,
                        const Hit *hit)
{
    x -= t->x0;
    y -= t->y0;
    out_put(t, f, OUT_COLOR, x, y, c);
    if (t->depth)
        out_put(t, f, OUT_DEPTH, x, y, render_depth_color(hit, t->depth_min, t->depth_max));
    if (t->normals)
        out_put(t, f, OUT_NORMALS, x, y, render_normal_color(hit));
}

/* The last bands of a render with several threads are split into parts of whole
 * tiles: when one thread takes the last band, the others would otherwise wait for all
 * of it (a 1080p band of the 40k bunny took ~2.8 ms on the 2-core AMD VM: half of one
 * on average, at every render's end); split, they share its parts, and the first
 * thread to run out of work waits for half a part on average: eight parts of a 1080p
 * band are 30 tiles, ~0.35 ms (four were ~0.7). The tiles and so the packets are the
 * same, hence the same pixels and counters. */
enum { SPLIT_PARTS = 8 };

typedef struct ImageJob {
    const RayTracer *rt;
    const Camera *camera;
    RenderTarget *target;
    RenderRowFn row_done;
    void *user;
    volatile int *cancel;   /* polled before every tile, not only every band */
    int split_from;         /* bands from this one on come in `parts` parts (jobs) */
    int parts;              /* 1: no band is split */
    atomic_int *parts_left; /* per split band: its parts not yet rendered */
    /* With target's color_rows, depth_rows or normals_rows (rows[i] for image i, NULL
     * when that image is not handed out by rows): band buffers (slots) of slot_bytes,
     * the first `pool` taken by one whole band at a time (stage_busy), then one per
     * split band (all of its parts write into it); image i's part of a slot
     * (stage_bytes, TILE rows) begins at part_at[i]. */
    void (*rows[OUT_COUNT])(void *user, int y_lo, int y_hi, const uint8_t *rows);
    uint8_t *stage;
    size_t stage_bytes, slot_bytes, part_at[OUT_COUNT];
    int pool;
    atomic_bool *stage_busy;
} ImageJob;

static bool job_cancelled(const ImageJob *job) { return job->cancel && *job->cancel; }

/* A whole tile's colours (colors[k] is lane k of the packet; pixel (dx, dy) of the
 * tile is lane slot[dy * TILE + dx]) into bytes whose row dy starts at
 * corner + dy * stride (the tile's pixel (0, dy); stride is negative for a file's
 * rows, stored top row first), in B G R order when bgr, else R G B:
 * every colour quantised as image_color_to_byte does, four components at a time
 * (c * 255, then max with 0, which also turns NaN into 0, min with 255 and truncation:
 * the same single-precision operations, so the same bytes), then the pixels of each
 * row left to right, four bytes at a time (a pixel's fourth byte is the next one's
 * first, written again right after) and three for the last, which stays inside the
 * tile; in B G R order byte by byte. */
static void store_tile_bytes(uint8_t *corner, ptrdiff_t stride, bool bgr, const Vec3 *colors,
                             const uint8_t *slot)
{
    enum { N = 3 * TILE * TILE };
    _Static_assert(sizeof(Vec3) == 3 * sizeof(float), "colours are packed floats");
    uint8_t q[N + 4];
    memset(q + N, 0, 4); /* read as a fourth byte, never kept */
    const float *c = (const float *)colors;
#if defined(__SSE2__)
    const __m128 scale = _mm_set1_ps(255.0f), zero = _mm_setzero_ps(),
                 top = _mm_set1_ps(255.0f);
    for (int i = 0; i < N; i += 16) {
        __m128i w[4];
        for (int j = 0; j < 4; j++) {
            __m128 v = _mm_mul_ps(_mm_loadu_ps(c + i + 4 * j), scale);
            v = _mm_min_ps(_mm_max_ps(v, zero), top);
            w[j] = _mm_cvttps_epi32(v);
        }
        __m128i h = _mm_packus_epi16(_mm_packs_epi32(w[0], w[1]), _mm_packs_epi32(w[2], w[3]));
        _mm_storeu_si128((__m128i *)(q + i), h);
    }
#else
    for (int i = 0; i < N; i++)
        q[i] = image_color_to_byte(c[i]);
#endif
    if (bgr) {
        for (int dy = 0; dy < TILE; dy++) {
            uint8_t *b = corner + dy * stride;
            const uint8_t *row = slot + dy * TILE;
#if defined(__GNUC__) && defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__
            /* R G B x as one little-endian word, its bytes reversed (x B G R) and shifted
             * down a byte: B G R 0, stored as four bytes like the R G B path. */
            for (int dx = 0; dx < TILE - 1; dx++) {
                uint32_t v;
                memcpy(&v, q + 3 * row[dx], 4);
                v = __builtin_bswap32(v) >> 8;
                memcpy(b + 3 * dx, &v, 4);
            }
            const uint8_t *p = q + 3 * row[TILE - 1];
            uint8_t *e = b + 3 * (TILE - 1);
            e[0] = p[2];
            e[1] = p[1];
            e[2] = p[0];
#else
            for (int dx = 0; dx < TILE; dx++) {
                const uint8_t *p = q + 3 * row[dx];
                b[3 * dx] = p[2];
                b[3 * dx + 1] = p[1];
                b[3 * dx + 2] = p[0];
            }
#endif
        }
        return;
    }
    for (int dy = 0; dy < TILE; dy++) {
        uint8_t *b = corner + dy * stride;
        const uint8_t *row = slot + dy * TILE;
        for (int dx = 0; dx < TILE - 1; dx++)
            memcpy(b + 3 * dx, q + 3 * row[dx], 4); /* q has 4 bytes to spare */
        memcpy(b + 3 * (TILE - 1), q + 3 * row[TILE - 1], 3);
    }
}

#if defined(RENDER_PLANES_AVX2)
#if defined(__clang__)
#pragma clang attribute push(__attribute__((target("avx2"))), apply_to = function)
#else
#pragma GCC push_options
#pragma GCC target("avx2")
#endif
/* Eight floats of one plane, a row of a tile: lanes slot[0], slot[0] + 1, slot[2],
 * slot[2] + 1, ... (in the tile's Z order each even column's lane is followed by its
 * odd neighbour's), each times 255 then quantised as store_tile_bytes does (max with 0,
 * which also turns NaN into 0, min with 255, truncation: the same single-precision
 * operations, so the same bytes), as eight 32-bit integers. */
static inline __m256i plane_row_bytes(const float *plane, const uint8_t *slot)
{
    __m128 lo = _mm_loadh_pi(_mm_loadl_pi(_mm_setzero_ps(), (const __m64 *)(plane + slot[0])),
                             (const __m64 *)(plane + slot[2]));
    __m128 hi = _mm_loadh_pi(_mm_loadl_pi(_mm_setzero_ps(), (const __m64 *)(plane + slot[4])),
                             (const __m64 *)(plane + slot[6]));
    __m256 v = _mm256_mul_ps(_mm256_set_m128(hi, lo), _mm256_set1_ps(255.0f));
    v = _mm256_min_ps(_mm256_max_ps(v, _mm256_setzero_ps()), _mm256_set1_ps(255.0f));
    return _mm256_cvttps_epi32(v);
}

/* store_tile_bytes for colours in three planes (raytracer_trace_tile_bytes: channel c of
 * lane k at planes[c * 64 + k]): each row's eight pixels quantised together per channel,
 * then packed and shuffled into the row's 24 bytes (B G R or R G B), stored as 16 + 8:
 * nothing written outside the tile's rows. */
static void store_tile_planes(uint8_t *corner, ptrdiff_t stride, bool bgr, const float *planes,
                              const uint8_t *slot)
{
    enum { P = TILE * TILE };
    _Static_assert(P == ACCEL_PACKET_MAX, "a plane is a packet's lanes");
    /* From rg = r0..r7 g0..g7 and b = b0..b7 (0x80: zero), bytes 0-15 and 16-23 of a
     * row: pixel x's bytes at 3x .. 3x+2, in the file's order. */
    const int8_t Z = (int8_t)0x80;
    const __m128i rg_bgr0 = _mm_setr_epi8(Z, 8, 0, Z, 9, 1, Z, 10, 2, Z, 11, 3, Z, 12, 4, Z),
                  b_bgr0 = _mm_setr_epi8(0, Z, Z, 1, Z, Z, 2, Z, Z, 3, Z, Z, 4, Z, Z, 5),
                  rg_bgr1 = _mm_setr_epi8(13, 5, Z, 14, 6, Z, 15, 7, Z, Z, Z, Z, Z, Z, Z, Z),
                  b_bgr1 = _mm_setr_epi8(Z, Z, 6, Z, Z, 7, Z, Z, Z, Z, Z, Z, Z, Z, Z, Z),
                  rg_rgb0 = _mm_setr_epi8(0, 8, Z, 1, 9, Z, 2, 10, Z, 3, 11, Z, 4, 12, Z, 5),
                  b_rgb0 = _mm_setr_epi8(Z, Z, 0, Z, Z, 1, Z, Z, 2, Z, Z, 3, Z, Z, 4, Z),
                  rg_rgb1 = _mm_setr_epi8(13, Z, 6, 14, Z, 7, 15, Z, Z, Z, Z, Z, Z, Z, Z, Z),
                  b_rgb1 = _mm_setr_epi8(Z, 5, Z, Z, 6, Z, Z, 7, Z, Z, Z, Z, Z, Z, Z, Z);
    const __m128i m_rg0 = bgr ? rg_bgr0 : rg_rgb0, m_b0 = bgr ? b_bgr0 : b_rgb0,
                  m_rg1 = bgr ? rg_bgr1 : rg_rgb1, m_b1 = bgr ? b_bgr1 : b_rgb1;
    for (int dy = 0; dy < TILE; dy++) {
        const uint8_t *row = slot + dy * TILE;
        __m256i r = plane_row_bytes(planes, row), g = plane_row_bytes(planes + P, row),
                b = plane_row_bytes(planes + 2 * P, row);
        __m128i r16 = _mm_packs_epi32(_mm256_castsi256_si128(r), _mm256_extracti128_si256(r, 1));
        __m128i g16 = _mm_packs_epi32(_mm256_castsi256_si128(g), _mm256_extracti128_si256(g, 1));
        __m128i b16 = _mm_packs_epi32(_mm256_castsi256_si128(b), _mm256_extracti128_si256(b, 1));
        __m128i rg = _mm_packus_epi16(r16, g16), bb = _mm_packus_epi16(b16, b16);
        uint8_t *out = corner + dy * stride;
        _mm_storeu_si128((__m128i *)out, _mm_or_si128(_mm_shuffle_epi8(rg, m_rg0),
                                                      _mm_shuffle_epi8(bb, m_b0)));
        _mm_storel_epi64((__m128i *)(out + 16), _mm_or_si128(_mm_shuffle_epi8(rg, m_rg1),
                                                             _mm_shuffle_epi8(bb, m_b1)));
    }
}
#if defined(__clang__)
#pragma clang attribute pop
#else
#pragma GCC pop_options
#endif
#endif

/* render_use_tile_planes' switch: on by default where the CPU runs the AVX2 store. */
static bool g_planes_off;

static bool tile_planes_on(void)
{
#if defined(RENDER_PLANES_AVX2)
    return !g_planes_off && cpu_has_avx2();
#else
    return false;
#endif
}

bool render_use_tile_planes(bool on)
{
    g_planes_off = !on;
    return tile_planes_on();
}

/* Rows y0..y1-1 of the rectangle, in the tiles whose left column is in [xa, xb)
 * (a part of the band; xa a multiple of TILE). Tiles stay on the full image's 8 x 8
 * grid, so a rectangle on that grid traces the very packets of the whole render;
 * pixels of a tile outside the rectangle are left out of its packet. */
static void render_band(const ImageJob *job, RenderCtx *ctx, int y0, int y1, int xa, int xb,
                        FileRows *const f[OUT_COUNT])
{
    RenderTarget *t = job->target;
    float tmin = camera_tmin(job->camera);
    Ray rays[TILE * TILE];
    Hit hits[TILE * TILE];
    Vec3 colors[TILE * TILE];
    int px[TILE * TILE], py[TILE * TILE];
    int ylo = y0 < t->y0 ? t->y0 : y0;
    int xlo = t->x0, xhi = t->x0 + t->w;
    /* Lane k of a tile's packet is pixel cell[k] = dy * TILE + dx (render_tile_order). */
    uint8_t cell[TILE * TILE];
    for (int k = 0; k < TILE * TILE; k++) {
        int dx, dy;
        render_tile_order(k, &dx, &dy);
        cell[k] = (uint8_t)(dy * TILE + dx);
    }
    /* Whole tiles (every band but a cut top one, every column but the rectangle's
     * cut edges) skip the per-pixel bounds, and with only a byte colour image to fill
     * store their bytes a tile at a time. */
    bool full_rows = ylo == y0 && y1 - y0 == TILE;
    bool to_bytes = t->color && (t->color->bytes || f[OUT_COLOR]);
    bool bytes_only = to_bytes && !t->depth && !t->normals;
    /* Colours that only become bytes may come from the power bracket (rt/raytracer.h):
     * the same bytes. Depth and normal images read the hits, never the colours. */
    void (*trace)(const RayTracer *, RenderCtx *, const Ray *, int, float, Vec3 *, Hit *) =
        to_bytes ? raytracer_trace_packet_bytes : raytracer_trace_packet;
#if defined(RENDER_PLANES_AVX2)
    /* Whole tiles of one Phong material come back as planes (raytracer_trace_tile_bytes)
     * where the CPU has the AVX2 store for them. */
    bool planes_on = bytes_only && tile_planes_on();
    float planes[3 * TILE * TILE];
#endif
    /* A band of a wide image with deep bounces takes long: a stop (the preview's q, a
     * signal) is noticed at the next tile, within a few milliseconds. */
    /* Pixel dy * TILE + dx is lane slot[...] of a whole tile's packet. */
    uint8_t slot[TILE * TILE];
    for (int k = 0; k < TILE * TILE; k++)
        slot[cell[k]] = (uint8_t)k;
    Ray block[TILE * TILE]; /* a cut tile's rays, row by row */
    int xend = xb < xhi ? xb : xhi;
    for (int x0 = xa; x0 < xend && !job_cancelled(job); x0 += TILE) {
        int n = 0;
        if (full_rows && x0 >= xlo && x0 + TILE <= xhi) {
            camera_block8_rays(job->camera, x0, y0, t->width, t->height, cell, rays);
            if (bytes_only) {
                int tx = x0 - t->x0, ty = y0 - t->y0;
                const FileRows *fc = f[OUT_COLOR];
                uint8_t *corner = fc ? file_pixel(fc, t, tx, ty)
                                     : t->color->bytes + 3 * ((size_t)ty * (size_t)t->color->width +
                                                              (size_t)tx);
                ptrdiff_t stride = fc ? -3 * (ptrdiff_t)t->w : 3 * (ptrdiff_t)t->color->width;
                bool bgr = fc && t->color_bgr;
#if defined(RENDER_PLANES_AVX2)
                if (planes_on && raytracer_trace_tile_bytes(job->rt, ctx, rays, tmin, colors,
                                                            planes, hits)) {
                    store_tile_planes(corner, stride, bgr, planes, slot);
                    continue;
                }
                if (!planes_on)
#endif
                    trace(job->rt, ctx, rays, TILE * TILE, tmin, colors, hits);
                store_tile_bytes(corner, stride, bgr, colors, slot);
            } else {
                trace(job->rt, ctx, rays, TILE * TILE, tmin, colors, hits);
                for (int k = 0; k < TILE * TILE; k++)
                    store_pixel(t, f, x0 + cell[k] % TILE, y0 + cell[k] / TILE, colors[k],
                                &hits[k]);
            }
            continue;
        }
        camera_pixel_rays(job->camera, x0, y0, TILE, y1 - y0, t->width, t->height, NULL,
                          block);
        for (int k = 0; k < TILE * TILE; k++) {
            int dx = cell[k] % TILE, dy = cell[k] / TILE;
            int x = x0 + dx, y = y0 + dy;
            if (x < xlo || x >= xhi || y < ylo || y >= y1)
                continue;
            rays[n] = block[cell[k]];
            px[n] = x;
            py[n++] = y;
        }
        trace(job->rt, ctx, rays, n, tmin, colors, hits);
        for (int i = 0; i < n; i++)
            store_pixel(t, f, px[i], py[i], colors[i], &hits[i]);
    }
}

static void image_band(void *user, RenderCtx *ctx, int index)
{
    /* Bands of the full image's 8-row grid that meet the rectangle; from split_from on,
     * `parts` jobs per band, each a run of its tile columns. */
    const ImageJob *job = user;
    const RenderTarget *t = job->target;
    int band = index, part = 0;
    if (index >= job->split_from) {
        band = job->split_from + (index - job->split_from) / job->parts;
        part = (index - job->split_from) % job->parts;
    }
    int top = t->y0 + t->h;
    int y0 = (t->y0 / TILE + band) * TILE, y1 = y0 + TILE < top ? y0 + TILE : top;
    int xa = t->x0 / TILE * TILE, xb = t->x0 + t->w;
    if (band >= job->split_from) {
        int cols = (xb - xa + TILE - 1) / TILE; /* tile columns, >= parts */
        int c0 = cols * part / job->parts, c1 = cols * (part + 1) / job->parts;
        xb = xa + c1 * TILE;
        xa += c0 * TILE;
    }
    int lo = y0 > t->y0 ? y0 : t->y0; /* the rows of this band inside the rectangle */
    /* Where the bytes go: a band buffer (a free slot of the pool for a whole band; a
     * split band's own) for each image handed out by rows, or for the colour the whole
     * file's rows; else the images. */
    FileRows fr[OUT_COUNT], *f[OUT_COUNT] = {NULL, NULL, NULL};
    int stage = -1;
    if (job->stage) {
        if (band >= job->split_from) {
            stage = job->pool + band - job->split_from;
        } else {
            /* At most `pool` bands are rendered at once (one per thread): one is free. */
            for (stage = 0;; stage = (stage + 1) % job->pool)
                if (!atomic_exchange_explicit(&job->stage_busy[stage], true,
                                              memory_order_acquire))
                    break;
        }
        for (int i = 0; i < OUT_COUNT; i++)
            if (job->rows[i]) {
                fr[i].rows = job->stage + (size_t)stage * job->slot_bytes + job->part_at[i];
                fr[i].top = y1 - 1 - t->y0;
                f[i] = &fr[i];
            }
    }
    if (!f[OUT_COLOR] && t->color_file) {
        fr[OUT_COLOR].rows = t->color_file;
        fr[OUT_COLOR].top = t->h - 1;
        f[OUT_COLOR] = &fr[OUT_COLOR];
    }
    const RtStats *st = &ctx->stats;
    uint64_t rays = st->nonshadow_rays + st->shadow_rays;
    render_band(job, ctx, y0, y1, xa, xb, f);
    uint64_t traced = st->nonshadow_rays + st->shadow_rays - rays;
    /* A split band's rows are done when its last part is: that part's thread reports
     * them (the release and acquire of the count make the other parts' pixels visible
     * to it). */
    bool done = !job_cancelled(job) && /* rows cut short are not done */
                (band < job->split_from ||
                 atomic_fetch_sub_explicit(&job->parts_left[band - job->split_from], 1,
                                           memory_order_acq_rel) == 1);
    if (done && job->stage)
        for (int i = 0; i < OUT_COUNT; i++)
            if (job->rows[i])
                job->rows[i](job->user, lo, y1 - 1, fr[i].rows);
    if (stage >= 0 && stage < job->pool)
        atomic_store_explicit(&job->stage_busy[stage], false, memory_order_release);
    if (job_cancelled(job))
        return;
    if (!done) {
        progress_add(t->progress, 0, traced);
        return;
    }
    progress_add(t->progress, (uint64_t)(y1 - lo), traced);
    if (job->row_done)
        for (int y = y0; y < y1; y++)
            job->row_done(job->user, y);
}

/* Worker w's loop: jobs from the shared counter until none is left (or a stop). */
static void worker_loop(Worker *w)
{
    ParRun *run = w->run;
    for (;;) {
        if (run->cancel && *run->cancel)
            break;
        int job = atomic_fetch_add(&run->next, 1);
        if (job >= run->jobs)
            break;
        run->fn(run->user, &w->ctx, job);
    }
}

/* A thread of render_parallel's own. */
static void *worker_main(void *arg)
{
    par_thread_release_cpus(); /* started off the creator's CPU; now free */
    worker_loop(arg);
    return NULL;
}

/* Chunk i of par_try_for: worker i's loop, on the set-up's threads. A helper was
 * started off its creator's CPU (rt/par.h) and is freed here; the caller never was. */
static void worker_chunk(void *ctx, int i, int thread)
{
    Worker *workers = ctx;
    if (thread != 0)
        par_thread_release_cpus();
    worker_loop(&workers[i]);
}

bool render_parallel(const RayTracer *rt, int threads, int jobs, RenderJobFn fn, void *user,
                     RtStats *stats_out, volatile int *cancel)
{
    if (threads <= 0)
        threads = render_default_threads();
    if (threads > jobs && jobs > 0)
        threads = jobs;
    if (threads < 1)
        threads = 1;

    ParRun run = {fn, user, jobs, cancel, 0};
    Worker *workers = aligned_alloc(_Alignof(Worker), (size_t)threads * sizeof *workers);
    if (!workers)
        return false;
    memset(workers, 0, (size_t)threads * sizeof *workers);
    bool ok = true;
    for (int i = 0; i < threads; i++) {
        workers[i].run = &run;
        if (rt && !raytracer_ctx_init(&workers[i].ctx, rt)) {
            ok = false;
            break;
        }
        workers[i].ctx.cancel = cancel; /* shading polls it inside a pixel's ray tree */
    }
    /* -threads 1 runs its one worker on this thread and starts no thread at all. With
     * more, the workers run on the set-up's helpers when they can (rt/par.h: already
     * started, usually during the scene's reading, so the render starts no thread and
     * waits for none to get a CPU). Any thread may run any worker's chunk (this one
     * too, a helper still spinning from the last job may take chunk 0); a worker whose
     * chunk runs after another's finds no job left, so the result is the same. */
    bool on_helpers = ok && threads > 1 && par_try_for(threads, worker_chunk, workers);
    if (ok && !on_helpers) {
        /* Threads of its own: more than the set-up's helpers, or they are busy. The
         * workers start on other CPUs than this one (rt/par.h): on a small image a
         * worker sharing this CPU for its first milliseconds would cost more than it
         * brings. */
        pthread_attr_t attr;
        bool attr_ok = pthread_attr_init(&attr) == 0;
        if (attr_ok)
            par_attr_keep_off_this_cpu(&attr);
        for (int i = 1; i < threads; i++)
            workers[i].started = pthread_create(&workers[i].thread, attr_ok ? &attr : NULL,
                                                worker_main, &workers[i]) == 0;
        if (attr_ok)
            pthread_attr_destroy(&attr);
        worker_loop(&workers[0]);
        /* A thread that failed to start loses nothing: the others take its jobs. */
        for (int i = 1; i < threads; i++)
            if (workers[i].started)
                pthread_join(workers[i].thread, NULL);
    }
    RtStats total = {0};
    for (int i = 0; i < threads; i++) {
        stats_merge(&total, &workers[i].ctx.stats);
        if (rt)
            raytracer_ctx_free(&workers[i].ctx);
    }
    free(workers);
    if (stats_out)
        *stats_out = total;
    if (cancel && *cancel)
        return false;
    return ok;
}

bool render_image(const RayTracer *rt, const Camera *camera, RenderTarget *target,
                  int threads, RtStats *stats_out, RenderRowFn row_done, void *user,
                  volatile int *cancel)
{
    if (target->w <= 0 || target->h <= 0) {
        target->x0 = target->y0 = 0;
        target->w = target->width;
        target->h = target->height;
    }
    int bands = (target->y0 + target->h + TILE - 1) / TILE - target->y0 / TILE;
    ImageJob job;
    memset(&job, 0, sizeof job);
    job.rt = rt;
    job.camera = camera;
    job.target = target;
    job.row_done = row_done;
    job.user = user;
    job.cancel = cancel;
    job.split_from = bands;
    job.parts = 1;
    /* With several threads, the last 2 bands per thread in parts (SPLIT_PARTS), when
     * the rectangle is that many tiles wide. */
    int nthreads = threads > 0 ? threads : render_default_threads();
    int cols = (target->x0 + target->w + TILE - 1) / TILE - target->x0 / TILE;
    int split = nthreads > 1 && cols >= SPLIT_PARTS ? 2 * nthreads : 0;
    if (split > bands / 2)
        split = bands / 2;
    atomic_int *left = split > 0 ? malloc((size_t)split * sizeof *left) : NULL;
    if (left) {
        for (int b = 0; b < split; b++)
            atomic_init(&left[b], SPLIT_PARTS);
        job.split_from = bands - split;
        job.parts = SPLIT_PARTS;
        job.parts_left = left;
    }
    int jobs = job.split_from + (bands - job.split_from) * job.parts;
    job.rows[OUT_COLOR] = target->color ? target->color_rows : NULL;
    job.rows[OUT_DEPTH] = target->depth ? target->depth_rows : NULL;
    job.rows[OUT_NORMALS] = target->normals ? target->normals_rows : NULL;
    job.stage_bytes = (size_t)TILE * 3 * (size_t)target->w;
    for (int i = 0; i < OUT_COUNT; i++)
        if (job.rows[i]) {
            job.part_at[i] = job.slot_bytes;
            job.slot_bytes += job.stage_bytes;
        }
    if (job.slot_bytes > 0) {
        /* One band buffer per thread and per split band: a few hundred KB at 1080p,
         * used again band after band (in the cache, no fresh pages), instead of the
         * whole images' rows. From bigmem's pool of huge pages: from malloc, the six
         * buffers of 2 threads at 1080p (276 KB) were ~60 fresh 4 KB pages. */
        job.pool = nthreads < jobs ? nthreads : jobs;
        int nsplit = bands - job.split_from;
        job.stage = bigmem_alloc((size_t)(job.pool + nsplit) * job.slot_bytes);
        job.stage_busy = malloc((size_t)job.pool * sizeof *job.stage_busy);
        if (!job.stage || !job.stage_busy || job.pool < 1) {
            bigmem_free(job.stage);
            free(job.stage_busy);
            free(left);
            return false;
        }
        for (int i = 0; i < job.pool; i++)
            atomic_init(&job.stage_busy[i], false);
    }
    bool ok = render_parallel(rt, threads, jobs, image_band, &job, stats_out, cancel);
    bigmem_free(job.stage);
    free(job.stage_busy);
    free(left);
    return ok;
}
