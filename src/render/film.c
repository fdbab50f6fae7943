/* The film (A7): samples traced in packets, held strip by strip within a memory budget,
 * filtered into the requested rectangle; and the course's two diagnostic pictures. */
#include "rt/film.h"
#include "rt/cpu.h"
#include "rt/bigmem.h"
#include "rt/clock.h"
#include "rt/render.h"

#include <float.h>
#include <math.h>
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#include <immintrin.h>
#endif
#include <stdlib.h>
#include <string.h>

#define TILE RENDER_TILE

/* One strip's worth of samples: film rows y0 .. y0+rows-1 (image rows), columns
 * sx0 .. sx0+fw-1, in a ring of rows_cap buffer rows (film_row(y): row y0 at buffer
 * row ring0). Pixel (x, y) holds count[film_row(y) fw + x - sx0] samples; a sample
 * has `stride` channels: offset x, y; colour; depth grey and |normal| when wanted.
 * Channel c of sample s of pixel (x, y) is at film_row(y) * rs + (x - sx0) * xs +
 * s * ss + c * cs. In planes (the colour-only filters with neighbours to weigh): for each film
 * row, sample slot and channel a row of fw floats, one per column, rows pw floats
 * apart (film_plane_width: xs = 1, cs = pw);
 * else pixel by pixel, a sample's channels side by side (cs = 1). The separable filter's weights
 * towards the 2R+1 columns and rows around (when used: `per` = 2(2R+1) of them, column
 * weights first) are planes of their own in the same order. Neighbouring pixels' same
 * sample and channel lie side by side: the filter adds each term to a whole span of
 * output pixels at a time, four columns per vector (film_filter_span). */
typedef struct Film {
    const FilmConfig *cfg;
    const RayTracer *rt;
    const Camera *camera;
    float tmin;
    int R;
    int sx0, sx1, sy0, sy1, fw;
    int pw;                     /* floats from a plane row to the next (film_plane_width) */
    int slots;                  /* most samples a pixel can hold */
    int stride;                 /* floats per sample */
    int off_depth, off_normal;  /* -1: not stored */
    int per;                    /* weights per sample; 0: not precomputed */
    size_t ss, ws;              /* floats from a sample to the next: data, weights */
    size_t cs, xs, rs;          /* ... from a channel, a column, a row to the next */
    bool planes;                /* the data in planes (xs = 1) */
    bool row_weights;           /* weights computed row by row (film_row_weights) */
    int rows_cap;               /* film rows the buffer holds */
    int y0, rows;               /* film rows held now */
    int ring0;                  /* the buffer row of film row y0 (film_row) */
    float *data;                /* NULL with moments and no samples picture */
    float *weights;             /* per floats per slot, or NULL */
    /* Moments (film_moments_cfg): each output pixel is the sum, over the pixels of its
     * support (columns outer, rows inner), of that pixel's own weighted sums towards it
     * (its samples in order, from zero), over the sum of the same weights. mom: those
     * sums where only the colour is wanted, made as a tile is traced (film_tile_moments;
     * the box 0.5 with 16 samples in film_tile_quads): film row y's plane
     * p = 4 (kx side + ky) + c (c: red, green, blue, weight; kx, ky:
     * towards column x - kx + R and row y - ky + R) at mom + film_row(y) ms + p pw, one
     * float per column. 4 (2R+1)^2 floats a pixel instead of its samples and their
     * weights (36 against 176 for 16 samples and the Gaussian 0.4). */
    bool moments;
    float *mom;
    size_t ms;
    int *failed;                /* set by a band that could not get its scratch (moments) */
    int *count;
    float *table;               /* fixed offsets: the weights, [(a-i+R)(2R+1) + (b-j+R)][s] */
    float *fixed_xy;            /* fixed offsets: the sampler's, the same in every pixel */
    bool avx2;                  /* the CPU has AVX2 (film_filter_span's vectors) */
    bool avx512;                /* ... and AVX-512 (film_span_sums_avx512) */
    int r0, r1;                 /* rows being traced (film_band) */
    int out0, out1;             /* output rows of the strip being filtered */
    bool pairs;                 /* filter jobs of two rows (film_filter_pair) */
    bool lobes;                 /* the filter has negative lobes (film_fix_lobes) */
    bool lobes_inside_ok;       /* ... and with fixed offsets, the pixels whose support
                                   the image does not cut are trusted */
    volatile int *cancel;       /* the stop flag, polled before every tile as well */
    /* Where the filter stores output pixels: cfg's whole images, or with cfg->rows the
     * strip images (one strip's output rows, handed to cfg->rows when filtered). Pixel
     * (i, j) of the full image goes to (i - ox, j - oy) of them. */
    Image *color, *depth, *normals;
    int ox, oy;
} Film;

/* The buffer row of film row y (y0 <= y < y0 + rows_cap): the buffer is a ring of
 * rows_cap rows, film row y0 at buffer row ring0, so the 2R rows a strip shares with
 * the next stay where they are (the ring turns instead of their data moving). A
 * compare, not a division: film_queue_pixel and the tile copy ask it per pixel. */
static inline size_t film_row(const Film *f, int y)
{
    int r = y - f->y0 + f->ring0;
    return (size_t)(r >= f->rows_cap ? r - f->rows_cap : r);
}

/* Channel 0 of sample s of pixel (x, y); channel c is c * cs floats further, the next
 * sample ss floats further. */
static float *film_sample(const Film *f, int x, int y, int s)
{
    return f->data + film_row(f, y) * f->rs + (size_t)(x - f->sx0) * f->xs +
           (size_t)s * f->ss;
}

/* Weight k of sample s of pixel (x, y) (k < 2R+1: towards column x - R + k; then
 * towards row y - R + (k - 2R - 1)); weight k + 1 is fw floats further, the next
 * sample ws floats further. */
static float *film_weights(const Film *f, int x, int y, int s, int k)
{
    size_t r = film_row(f, y) * (size_t)f->slots + (size_t)s;
    return f->weights + r * f->ws + (size_t)k * (size_t)f->pw + (size_t)(x - f->sx0);
}

static int *film_count(const Film *f, int x, int y)
{
    return f->count + film_row(f, y) * (size_t)f->fw + (size_t)(x - f->sx0);
}

/* Column x of film row y's moment plane p. */
static inline float *film_mom(const Film *f, int x, int y, int p)
{
    return f->mom + film_row(f, y) * f->ms + (size_t)p * (size_t)f->pw + (size_t)(x - f->sx0);
}

/* Rays waiting to be traced as one packet, and the sample each belongs to: channel c
 * of the sample at dest + c * cs (cs = 1: a tile's scratch, one sample's channels
 * side by side; cs = fw: the film's planes). */
typedef struct Stream {
    int n;
    size_t cs;
    Ray rays[ACCEL_PACKET_MAX];
    float *dest[ACCEL_PACKET_MAX];
} Stream;

/* A colour-only sample with its channels side by side (a tile's scratch, or a film
 * pixel by pixel: cs = 1, five floats a sample) takes its position when queued and its
 * colour when traced. A pixel's samples are consecutive lanes of the stream and lie
 * five floats apart, so sixteen of them are an 80-float block: with AVX-512 the
 * positions go in as five masked stores of permuted vectors of the pixel's xy, and
 * the colours of 16 lanes (48 floats of the packet's colours) as five more, instead of
 * two and three scalar stores per sample through per-lane pointers. Float f = 16 o + l
 * of a block (vector o, lane l) is channel c = f % 5 of sample i = f / 5: the permute
 * index of channels 0 and 1 into the 32 floats of xy, and of channels 2..4 into two of
 * the colours' three vectors (float 3 i + c - 2: vectors 0 and 1 for o < 2, else 1 and
 * 2), with the masks of those lanes. Only copies: the same bits. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define FILM_RUN_F(o, l) (16 * (o) + (l))
#define FILM_RUN_I(o, l) (FILM_RUN_F(o, l) / 5)
#define FILM_RUN_C(o, l) (FILM_RUN_F(o, l) % 5)
#define FILM_RUN_XY(o, l) (FILM_RUN_C(o, l) < 2 ? 2 * FILM_RUN_I(o, l) + FILM_RUN_C(o, l) : 0)
#define FILM_RUN_RGB(o, l)                                                                \
    (FILM_RUN_C(o, l) >= 2 ? 3 * FILM_RUN_I(o, l) + FILM_RUN_C(o, l) - 2 - ((o) < 2 ? 0 : 16) : 0)
#define FILM_RUN_ROW(T, o)                                                                \
    {T(o, 0), T(o, 1), T(o, 2),  T(o, 3),  T(o, 4),  T(o, 5),  T(o, 6),  T(o, 7),          \
     T(o, 8), T(o, 9), T(o, 10), T(o, 11), T(o, 12), T(o, 13), T(o, 14), T(o, 15)}
#define FILM_RUN_TABLE(T)                                                                 \
    {FILM_RUN_ROW(T, 0), FILM_RUN_ROW(T, 1), FILM_RUN_ROW(T, 2), FILM_RUN_ROW(T, 3),      \
     FILM_RUN_ROW(T, 4)}
#define FILM_RUN_XYBIT(o, l) (FILM_RUN_C(o, l) < 2 ? 1u << (l) : 0u)
#define FILM_RUN_RGBBIT(o, l) (FILM_RUN_C(o, l) >= 2 ? 1u << (l) : 0u)
#define FILM_RUN_MASK(P, o)                                                               \
    (uint16_t)(P(o, 0) | P(o, 1) | P(o, 2) | P(o, 3) | P(o, 4) | P(o, 5) | P(o, 6) |       \
               P(o, 7) | P(o, 8) | P(o, 9) | P(o, 10) | P(o, 11) | P(o, 12) | P(o, 13) |  \
               P(o, 14) | P(o, 15))
#define FILM_RUN_MASKS(P)                                                                 \
    {FILM_RUN_MASK(P, 0), FILM_RUN_MASK(P, 1), FILM_RUN_MASK(P, 2), FILM_RUN_MASK(P, 3),  \
     FILM_RUN_MASK(P, 4)}
static const int32_t film_run_xy[5][16] __attribute__((aligned(64))) = FILM_RUN_TABLE(FILM_RUN_XY);
static const int32_t film_run_rgb[5][16] __attribute__((aligned(64))) =
    FILM_RUN_TABLE(FILM_RUN_RGB);
static const uint16_t film_run_xymask[5] = FILM_RUN_MASKS(FILM_RUN_XYBIT);
static const uint16_t film_run_rgbmask[5] = FILM_RUN_MASKS(FILM_RUN_RGBBIT);
_Static_assert(sizeof(Vec3) == 3 * sizeof(float), "a colour is three packed floats");

#define FILM_RUN_AVX512 target("avx512f,avx512vl,avx512bw,avx512dq")

/* The 16 samples of a block at d: channels 0 and 1 from xy[0..31], and their
 * destinations d + 5 k into dest[0..15]. */
__attribute__((FILM_RUN_AVX512)) static void film_run_positions(float *d, const float *xy,
                                                               float **dest)
{
    __m512 a = _mm512_loadu_ps(xy), b = _mm512_loadu_ps(xy + 16);
    for (int o = 0; o < 5; o++)
        _mm512_mask_storeu_ps(d + 16 * o, film_run_xymask[o],
                              _mm512_permutex2var_ps(a, _mm512_load_si512(film_run_xy[o]), b));
    __m512i lo = _mm512_add_epi64(_mm512_set1_epi64((long long)(uintptr_t)d),
                                  _mm512_setr_epi64(0, 20, 40, 60, 80, 100, 120, 140));
    _mm512_storeu_si512(dest, lo);
    _mm512_storeu_si512(dest + 8, _mm512_add_epi64(lo, _mm512_set1_epi64(160)));
}

/* Whether the 16 lanes' destinations from dest[0] on are one block (five floats
 * apart), and if so their colours (c[0..15]) into channels 2..4. */
__attribute__((FILM_RUN_AVX512)) static bool film_run_colors(float *const *dest, const Vec3 *c)
{
    __m512i base = _mm512_set1_epi64((long long)(uintptr_t)dest[0]);
    const __m512i step = _mm512_setr_epi64(0, 20, 40, 60, 80, 100, 120, 140);
    __m512i lo = _mm512_add_epi64(base, step);
    __m512i hi = _mm512_add_epi64(lo, _mm512_set1_epi64(160));
    if (_mm512_cmpneq_epi64_mask(_mm512_loadu_si512(dest), lo) ||
        _mm512_cmpneq_epi64_mask(_mm512_loadu_si512(dest + 8), hi))
        return false;
    const float *cf = (const float *)c;
    __m512 v0 = _mm512_loadu_ps(cf), v1 = _mm512_loadu_ps(cf + 16), v2 = _mm512_loadu_ps(cf + 32);
    float *d = dest[0];
    for (int o = 0; o < 5; o++) {
        __m512i idx = _mm512_load_si512(film_run_rgb[o]);
        __m512 t = o < 2 ? _mm512_permutex2var_ps(v0, idx, v1) : _mm512_permutex2var_ps(v1, idx, v2);
        _mm512_mask_storeu_ps(d + 16 * o, film_run_rgbmask[o], t);
    }
    return true;
}

/* A whole block of 16 samples at d (80 floats, five vectors): channels 0 and 1 from
 * xy[0..31], channels 2..4 from the colours c[0..15], each vector one plain store of
 * the two permutes blended (film_tile_quads: no masked stores, which the Zen 4 host
 * drains slowly). */
__attribute__((FILM_RUN_AVX512)) static void film_put_block(float *d, const float *xy,
                                                           const Vec3 *c)
{
    __m512 a = _mm512_loadu_ps(xy), b = _mm512_loadu_ps(xy + 16);
    const float *cf = (const float *)c;
    __m512 v0 = _mm512_loadu_ps(cf), v1 = _mm512_loadu_ps(cf + 16), v2 = _mm512_loadu_ps(cf + 32);
    for (int o = 0; o < 5; o++) {
        __m512 p = _mm512_permutex2var_ps(a, _mm512_load_si512(film_run_xy[o]), b);
        __m512i idx = _mm512_load_si512(film_run_rgb[o]);
        __m512 t = o < 2 ? _mm512_permutex2var_ps(v0, idx, v1) : _mm512_permutex2var_ps(v1, idx, v2);
        _mm512_storeu_ps(d + 16 * o, _mm512_mask_blend_ps(film_run_xymask[o], t, p));
    }
}
#define FILM_HAVE_RUNS 1
#endif

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* stream_flush's colour copy where the CPU has AVX2: lane i's four floats from
 * dest[i] + 1 (its y position and colour) rewritten in one plain store, the y kept by a
 * blend with the colour read as four floats from colors + i less one float. Lane 0 (whose
 * read would start before the array) is the caller's. Returns the lanes done from lane
 * 1 on. Until e2bf0e0's successor this was a masked store of the three floats: fewer
 * instructions, but on the Zen 3 host (perf, 17a uniform 16) the copy took 3.1% of the
 * samples against 1.4% for stream_flush's scalar loop: AMD's masked stores are slow. */
__attribute__((target("avx2"))) static int film_put_colors_avx2(float *const *dest,
                                                                const Vec3 *colors, int lanes)
{
    const float *c = (const float *)colors;
    int i = 1;
    /* Four lanes a step, written out (gcc kept the loop's count per lane). */
#define FILM_PUT_COLOR(I)                                                                  \
    do {                                                                                   \
        float *d_ = dest[I] + 1;                                                           \
        _mm_storeu_ps(d_, _mm_blend_ps(_mm_loadu_ps(c + 3 * (I) - 1), _mm_loadu_ps(d_), 1)); \
    } while (0)
    for (; i + 4 <= lanes; i += 4) {
        FILM_PUT_COLOR(i);
        FILM_PUT_COLOR(i + 1);
        FILM_PUT_COLOR(i + 2);
        FILM_PUT_COLOR(i + 3);
    }
    for (; i < lanes; i++)
        FILM_PUT_COLOR(i);
#undef FILM_PUT_COLOR
    return lanes;
}
#define FILM_HAVE_COLORS8 1
#endif

/* Makes the packet's n colours finite before they reach the film: +-inf becomes
 * +-FLT_MAX and NaN becomes 0. The filter multiplies every sample of a pixel's support
 * by its weight, and inf times a zero weight (a sample beyond a tent's or a box's reach
 * or past Mitchell's lobes) is NaN, which the quantiser writes as 0: one infinite
 * sample (a scene with huge light or material values) made every pixel whose support
 * held it black, instead of only brightening those it weighs in (a 20 x 20 sphere of
 * inf red, uniform 4, tent 1.5: all 24 inner pixels black; the one-sample image has
 * them red). FLT_MAX times any weight of 2^-100 or more, over any weight sum the
 * supports reach, still saturates the byte as inf did; and since every weight is at
 * most 1 in size, no term is infinite, so a sum can overflow to +-inf but never meet
 * the other infinity (no NaN). A NaN channel counts as 0, the byte the one-sample image
 * writes for it, instead of blacking out its neighbours. Finite colours are not
 * touched: their images keep their bytes. One pass of compares over the packet (3 n
 * floats) finds none in the usual case. */
typedef uint32_t FilmFiniteV __attribute__((vector_size(16)));

static void film_finite_colors(Vec3 *c, int n)
{
    float *v = (float *)c;
    /* The test four floats at a time on their bits (all exponent bits set: inf or NaN);
     * one float at a time, it was 2% of a jittered 16-sample render's instructions. */
    FilmFiniteV acc = {0, 0, 0, 0};
    int i = 0, m = 3 * n;
    for (; i + 4 <= m; i += 4) {
        FilmFiniteV b;
        memcpy(&b, v + i, sizeof b);
        acc |= (FilmFiniteV)((b & 0x7f800000u) == 0x7f800000u);
    }
    bool bad = (acc[0] | acc[1] | acc[2] | acc[3]) != 0;
    for (; i < m; i++)
        bad |= !(fabsf(v[i]) <= FLT_MAX);
    if (!bad)
        return;
    for (i = 0; i < m; i++)
        if (!(fabsf(v[i]) <= FLT_MAX))
            v[i] = v[i] != v[i] ? 0.0f : v[i] > 0.0f ? FLT_MAX : -FLT_MAX;
}

/* A pixel's moment sum (Film.moments) made finite as film_finite_colors makes a
 * sample's colour: +-inf becomes +-FLT_MAX (its terms are finite, so it is never NaN).
 * The filter adds the sums of a support's pixels, and one pixel's sum overflowing to
 * +inf with a neighbour's to -inf (colours of +-1e30 side by side) made a NaN output
 * pixel, which the quantiser writes as 0; the samples' one running sum, before the
 * moments, could reach +-inf but never meet the other infinity. Clamped, the sums of
 * the moments cannot either. Finite sums keep their bits. */
static inline float film_finite_sum(float v)
{
    return v > FLT_MAX ? FLT_MAX : v < -FLT_MAX ? -FLT_MAX : v;
}

static void stream_flush(const Film *f, RenderCtx *ctx, Stream *st)
{
    if (st->n == 0)
        return;
    Vec3 colors[ACCEL_PACKET_MAX];
    Hit hits[ACCEL_PACKET_MAX];
    raytracer_trace_packet(f->rt, ctx, st->rays, st->n, f->tmin, colors, hits);
    film_finite_colors(colors, st->n);
    size_t cs = st->cs;
    int lanes = st->n;
    st->n = 0;
    if (f->off_depth < 0 && f->off_normal < 0 && cs == 1) {
        /* Colour only into a tile's scratch or a pixel-by-pixel film: the usual case,
         * without the per-lane tests of the general loop below. */
        int i = 0;
#ifdef FILM_HAVE_RUNS
        if (f->avx512)
            for (; i + 16 <= lanes; i += 16)
                if (!film_run_colors(st->dest + i, colors + i))
                    break;
#endif
#ifdef FILM_HAVE_COLORS8
        if (f->avx2 && !f->avx512 && i == 0 && lanes > 1) {
            float *d = st->dest[0];
            d[2] = colors[0].x;
            d[3] = colors[0].y;
            d[4] = colors[0].z;
            i = film_put_colors_avx2(st->dest, colors, lanes);
        }
#endif
        for (; i < lanes; i++) {
            float *d = st->dest[i];
            d[2] = colors[i].x;
            d[3] = colors[i].y;
            d[4] = colors[i].z;
        }
        return;
    }
    for (int i = 0; i < lanes; i++) {
        float *d = st->dest[i];
        if (cs == 1) { /* the usual case: a sample's channels side by side */
            d[2] = colors[i].x;
            d[3] = colors[i].y;
            d[4] = colors[i].z;
        } else {
            d[2 * cs] = colors[i].x;
            d[3 * cs] = colors[i].y;
            d[4 * cs] = colors[i].z;
        }
        if (f->off_depth >= 0) {
            Vec3 g = render_depth_color(&hits[i], f->cfg->depth_min, f->cfg->depth_max);
            float *e = d + (size_t)f->off_depth * cs;
            e[0] = g.x;
            e[cs] = g.y;
            e[2 * cs] = g.z;
        }
        if (f->off_normal >= 0) {
            Vec3 n = render_normal_color(&hits[i]);
            float *e = d + (size_t)f->off_normal * cs;
            e[0] = n.x;
            e[cs] = n.y;
            e[2 * cs] = n.z;
        }
    }
}

/* The separable filter's weights of the n samples at offsets xy of pixel (x, y):
 * towards the 2R+1 columns and rows around, by filter_weights_1d_offsets on the
 * samples' x, then y positions (a batch: the Gaussian's vectorise), then stored into
 * their planes: the bits film_row_weights and film_tile's blocks give the same
 * positions (the Gaussian at R = 1 and 2 makes them from the position itself, not from
 * arguments rounded one by one). */
typedef float FilmV4f __attribute__((vector_size(16)));
typedef int32_t FilmV4i __attribute__((vector_size(16)));

static void film_sample_weights(const Film *f, int x, int y, int n, const float *xy)
{
    /* w holds 2R+1 weights of up to CHUNK samples: fewer samples a batch where the
     * filter reaches further. R is not bounded by FILTER_MAX_RADIUS: the Gaussian's
     * reach is 2 sigma, so sigma 16 has R = 32 (65 weights a position); with a buffer
     * sized for R <= 16 the weights of sigma above 8.25 were left unwritten. Batches
     * of any length give the same bits (filter_weights_1d_offsets). */
    enum { CHUNK = 64, WBUF = 33 * CHUNK };
    int R = f->R, side = 2 * R + 1;
    float pos[CHUNK], w[WBUF];
    int chunk = WBUF / side < CHUNK ? WBUF / side : CHUNK;
    if (n <= 0 || f->per <= 0 || chunk < 1) /* (never: samples, weights, R <= 1055) */
        return;
    size_t ws = f->ws;
    for (int i0 = 0; i0 < n; i0 += chunk) {
        int m = n - i0 < chunk ? n - i0 : chunk;
        for (int axis = 0; axis < 2; axis++) {
            for (int i = 0; i < m; i++)
                pos[i] = xy[2 * (i0 + i) + axis];
            filter_weights_1d_offsets(f->cfg->filter, pos, m, R, w, (size_t)m);
            for (int k = 0; k < side; k++) {
                float *d = film_weights(f, x, y, i0, axis * side + k);
                const float *wk = w + k * m;
                for (int i = 0; i < m; i++, d += ws)
                    *d = wk[i];
            }
        }
    }
}

/* The separable weights of every sample of film row y, once it is traced (every pixel
 * holding `slots` samples: not with adaptive refinement, whose pixels get theirs in
 * film_sample_weights): a plane at a time, the positions of one sample slot across the
 * row as the arguments (filter_weights_1d_offsets: (position - 0.5) - R in double,
 * plus k, rounded to float once, as film_sample_weights' arguments), the 2R+1 weights
 * of each straight into their planes, pw floats apart. */
static void film_row_weights(const Film *f, int y)
{
    int side = 2 * f->R + 1;
    for (int s = 0; s < f->slots; s++)
        for (int axis = 0; axis < 2; axis++)
            filter_weights_1d_offsets(f->cfg->filter,
                                      film_sample(f, f->sx0, y, s) + (size_t)axis * f->cs,
                                      f->fw, f->R, film_weights(f, f->sx0, y, s, axis * side),
                                      (size_t)f->pw);
}

/* Places the samples of pixel (x, y) with sampler s and queues their rays; sample i's
 * channels go to aos + i * stride (a tile's scratch, st->cs = 1) or, aos NULL, to the
 * film's planes (st->cs = fw). */
static void film_queue_pixel(const Film *f, RenderCtx *ctx, Stream *st, const Sampler *s,
                             int x, int y, float *aos)
{
    float buf[2 * SAMPLER_MAX_COUNT];
    const float *xy = buf;
    if (f->fixed_xy && s == f->cfg->sampler)
        xy = f->fixed_xy; /* asked once (uniform: 8 divisions per pixel otherwise) */
    else
        sampler_pixel(s, x, y, buf);
    *film_count(f, x, y) = s->count;
    const FilmConfig *c = f->cfg;
    if (f->per && !f->row_weights)
        film_sample_weights(f, x, y, s->count, xy);
    /* The rays go straight into the packet, as many of the pixel's as it has room for
     * at a time (camera_sample_rays: several samples per step). */
    float *d = aos ? aos : film_sample(f, x, y, 0);
    size_t step = aos ? (size_t)f->stride : f->ss, cs = st->cs;
    for (int i0 = 0; i0 < s->count;) {
        int m = ACCEL_PACKET_MAX - st->n;
        m = m < s->count - i0 ? m : s->count - i0;
        if (f->avx2 && !f->avx512 && cs == 1) {
            /* The rays, the positions into the scratch and the destinations in one
             * pass (eight samples a step with AVX2). */
            camera_sample_rays_put(f->camera, x, y, xy + 2 * i0, m, c->full_width,
                                   c->full_height, &st->rays[st->n], d, step,
                                   st->dest + st->n);
            st->n += m;
            d += (size_t)m * step;
            i0 += m;
            if (st->n == ACCEL_PACKET_MAX)
                stream_flush(f, ctx, st);
            continue;
        }
        camera_sample_rays(f->camera, x, y, xy + 2 * i0, m, c->full_width, c->full_height,
                           &st->rays[st->n]);
        int i = i0;
#ifdef FILM_HAVE_RUNS
        if (f->avx512 && cs == 1 && step == 5)
            for (; i + 16 <= i0 + m; i += 16, d += 80, st->n += 16)
                film_run_positions(d, xy + 2 * i, st->dest + st->n);
#endif
        for (; i < i0 + m; i++, d += step) {
            d[0] = xy[2 * i];
            d[cs] = xy[2 * i + 1];
            st->dest[st->n++] = d;
        }
        i0 += m;
        if (st->n == ACCEL_PACKET_MAX)
            stream_flush(f, ctx, st);
    }
}

/* Adaptive sampling: do the pixel's samples disagree by more than the threshold? */
static bool film_disagrees(const Film *f, int x, int y)
{
    int n = *film_count(f, x, y);
    float lo[3], hi[3];
    for (int s = 0; s < n; s++) {
        const float *d = film_sample(f, x, y, s);
        for (int k = 0; k < 3; k++) {
            float c = d[(size_t)(2 + k) * f->cs];
            if (s == 0 || c < lo[k])
                lo[k] = c;
            if (s == 0 || c > hi[k])
                hi[k] = c;
        }
    }
    for (int k = 0; k < 3 && n > 0; k++)
        if (hi[k] - lo[k] > f->cfg->threshold)
            return true;
    return false;
}

/* The samples picture of pixel (x, y): its block, then its dots. A dot whose position
 * rounds onto the next block (px just below 1) is not drawn: in the course's drawing
 * order (i outer, j inner) that block is painted later and covers it. */
static void film_draw_samples(const Film *f, int x, int y)
{
    const FilmConfig *c = f->cfg;
    int z = c->samples_zoom;
    int bx = (x - c->x0 + c->out_x) * z, by = (y - c->y0) * z;
    Vec3 bg = ((x + y) & 1) == 0 ? v3(0.2f, 0.2f, 0.2f) : v3(0, 0, 0);
    for (int j = 0; j < z; j++)
        for (int i = 0; i < z; i++)
            image_set(c->samples, bx + i, by + j, bg);
    int n = *film_count(f, x, y);
    int maxx = c->full_width * z - 1, maxy = c->full_height * z - 1;
    for (int s = 0; s < n; s++) {
        const float *d = film_sample(f, x, y, s);
        size_t cs = f->cs;
        int X = (int)floorf(((float)x + d[0]) * (float)z);
        int Y = (int)floorf(((float)y + d[cs]) * (float)z);
        X = X > maxx ? maxx : X;
        Y = Y > maxy ? maxy : Y;
        X -= (c->x0 - c->out_x) * z;
        Y -= c->y0 * z;
        if (X >= bx && X < bx + z && Y >= by && Y < by + z)
            image_set(c->samples, X, Y, v3(d[2 * cs], d[3 * cs], d[4 * cs]));
    }
}

/* The first row (or column) of the packet tile holding row (column) v >= 0. */
static int film_grid_floor(int v) { return v - v % TILE; }

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* Floats k .. k+7 of the eight pixels at p, p + per_px, ...: v[m] holds float k + m of
 * pixels 0..7 (an 8 x 8 transpose in registers). */
__attribute__((always_inline, target("avx2"))) static inline void
film_transpose8(const float *p, size_t per_px, __m256 *v)
{
    __m256 r0 = _mm256_loadu_ps(p), r1 = _mm256_loadu_ps(p + per_px);
    __m256 r2 = _mm256_loadu_ps(p + 2 * per_px), r3 = _mm256_loadu_ps(p + 3 * per_px);
    __m256 r4 = _mm256_loadu_ps(p + 4 * per_px), r5 = _mm256_loadu_ps(p + 5 * per_px);
    __m256 r6 = _mm256_loadu_ps(p + 6 * per_px), r7 = _mm256_loadu_ps(p + 7 * per_px);
    __m256 t0 = _mm256_unpacklo_ps(r0, r1), t1 = _mm256_unpackhi_ps(r0, r1);
    __m256 t2 = _mm256_unpacklo_ps(r2, r3), t3 = _mm256_unpackhi_ps(r2, r3);
    __m256 t4 = _mm256_unpacklo_ps(r4, r5), t5 = _mm256_unpackhi_ps(r4, r5);
    __m256 t6 = _mm256_unpacklo_ps(r6, r7), t7 = _mm256_unpackhi_ps(r6, r7);
    /* u0: float 0 of pixels 0-3 (low half) and float 4 (high half); u1: 1 and 5 ... */
    __m256 u0 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(1, 0, 1, 0));
    __m256 u1 = _mm256_shuffle_ps(t0, t2, _MM_SHUFFLE(3, 2, 3, 2));
    __m256 u2 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(1, 0, 1, 0));
    __m256 u3 = _mm256_shuffle_ps(t1, t3, _MM_SHUFFLE(3, 2, 3, 2));
    __m256 u4 = _mm256_shuffle_ps(t4, t6, _MM_SHUFFLE(1, 0, 1, 0));
    __m256 u5 = _mm256_shuffle_ps(t4, t6, _MM_SHUFFLE(3, 2, 3, 2));
    __m256 u6 = _mm256_shuffle_ps(t5, t7, _MM_SHUFFLE(1, 0, 1, 0));
    __m256 u7 = _mm256_shuffle_ps(t5, t7, _MM_SHUFFLE(3, 2, 3, 2));
    v[0] = _mm256_permute2f128_ps(u0, u4, 0x20);
    v[1] = _mm256_permute2f128_ps(u1, u5, 0x20);
    v[2] = _mm256_permute2f128_ps(u2, u6, 0x20);
    v[3] = _mm256_permute2f128_ps(u3, u7, 0x20);
    v[4] = _mm256_permute2f128_ps(u0, u4, 0x31);
    v[5] = _mm256_permute2f128_ps(u1, u5, 0x31);
    v[6] = _mm256_permute2f128_ps(u2, u6, 0x31);
    v[7] = _mm256_permute2f128_ps(u3, u7, 0x31);
}

/* A whole tile row from the scratch into the planes: float k (channel k % 5 of sample
 * k / 5) of pixel dx, at src + dx * per_px + k, goes to d + (k / 5) ss + (k % 5) cs + dx.
 * Eight floats of the eight pixels at a time: an 8 x 8 transpose in registers, then one
 * store of the eight columns per float (one by one, each sample's five channels cost
 * eight scattered stores per pixel). Copies only: the bits are the scratch's. With pos
 * (the separable weights made from the scratch, film_tile), sample s's x and y of the
 * eight pixels also go to pos + 16 s and pos + 16 s + 8, and to the planes only with
 * keep_pos (the weights are then all that reads them, unless the samples picture is
 * drawn): 2 of the 5 planes' lines not written, nor read back by film_row_weights. */
__attribute__((target("avx2"))) static void film_copy_row8(const float *src, size_t per_px,
                                                          int floats, float *d, size_t ss,
                                                          size_t cs, float *pos,
                                                          bool keep_pos)
{
    int k = 0;
    if (pos) {
        /* eight samples (40 floats: five transposes) at a time; unrolled, float 8 t + m
         * of the 40 is channel (8 t + m) % 5 of sample (8 t + m) / 5, constants: no
         * test per store, and the transposes' vectors stay in registers */
        for (; k + 40 <= floats; k += 40) {
            float *d0 = d + (size_t)(k / 5) * ss, *p0 = pos + 16 * (k / 5);
#pragma GCC unroll 5
            for (int t = 0; t < 5; t++) {
                __m256 v[8];
                film_transpose8(src + k + 8 * t, per_px, v);
#pragma GCC unroll 8
                for (int m = 0; m < 8; m++) {
                    int smp = (8 * t + m) / 5, ch = (8 * t + m) % 5;
                    float *dd = d0 + (size_t)smp * ss + (size_t)ch * cs;
                    if (ch >= 2) {
                        _mm256_storeu_ps(dd, v[m]);
                    } else {
                        _mm256_storeu_ps(p0 + 16 * smp + 8 * ch, v[m]);
                        if (keep_pos)
                            _mm256_storeu_ps(dd, v[m]);
                    }
                }
            }
        }
    }
    /* then eight floats at a time (all of them without pos): float k is channel c of
     * sample k / 5, stored at d + o */
    int c = 0;
    size_t o = (size_t)(k / 5) * ss;
    for (; k + 8 <= floats; k += 8) {
        __m256 v[8];
        film_transpose8(src + k, per_px, v);
        for (int m = 0; m < 8; m++) {
            if (!pos || c >= 2 || keep_pos)
                _mm256_storeu_ps(d + o, v[m]);
            if (pos && c < 2)
                _mm256_storeu_ps(pos + 16 * ((k + m) / 5) + 8 * c, v[m]);
            o += cs;
            if (++c == 5) {
                c = 0;
                o += ss - 5 * cs;
            }
        }
    }
    /* the rest a float at a time */
    for (; k < floats; k++)
        for (int dx = 0; dx < 8; dx++) {
            float v = src[(size_t)dx * per_px + (size_t)k];
            int ch = k % 5;
            if (pos && ch < 2)
                pos[16 * (k / 5) + 8 * ch + dx] = v;
            if (!pos || ch >= 2 || keep_pos)
                d[(size_t)(k / 5) * ss + (size_t)ch * cs + (size_t)dx] = v;
        }
}
#define FILM_HAVE_COPY_ROW8 1
_Static_assert(TILE == 8, "film_copy_row8 copies rows of eight pixels");
#endif

#ifdef FILM_HAVE_RUNS
/* film_tile's first pass with 16 samples a pixel where the CPU has AVX-512, colour only,
 * each sample's channels side by side (film_queue_pixel's film_run_positions case): the
 * pixels a packet has room for (four, or fewer where the tile is cut) are placed one
 * after the other, then their rays made in one call, whose chains of divisions and
 * square roots overlap two pixels at a time (camera_sample_rays_pixels; a pixel a call,
 * the rays were 4% of a 17a jittered 16 render, waiting on their own divisions). Once
 * the packet is traced each pixel's block of positions and colours is written whole
 * (film_put_block; the positions' and the colours' masked stores, film_run_positions
 * and film_run_colors, were 3 ms of that render). The same positions and rays in the
 * same lanes and packets as film_queue_pixel's, so the same bits. Returns the tile's
 * queued pixels (bit dy * TILE + dx); the stream is empty on return. */
static uint64_t film_tile_quads(const Film *f, RenderCtx *ctx, Stream *st, int x0, int by,
                                int y0, int y1, float *scratch, bool sums0)
{
    const FilmConfig *c = f->cfg;
    const Sampler *s = c->sampler;
    size_t per_px = (size_t)f->slots * (size_t)f->stride;
    enum { QUAD = ACCEL_PACKET_MAX / 16 };
    _Static_assert(QUAD * 16 == ACCEL_PACKET_MAX, "a packet is four pixels of 16 samples");
    /* The tile's pixels inside the band and the strip's columns, in Morton order. */
    uint8_t in[TILE * TILE];
    int m = 0;
    for (int k = 0; k < TILE * TILE; k++) {
        int dx, dy;
        render_tile_order(k, &dx, &dy);
        int x = x0 + dx, y = by + dy;
        if (x >= f->sx0 && x < f->sx1 && y >= y0 && y < y1)
            in[m++] = (uint8_t)(dy * TILE + dx);
    }
    float buf[QUAD][32] __attribute__((aligned(64)));
    const float *xy[QUAD];
    float *dst[QUAD];
    int px[QUAD], py[QUAD];
    Vec3 colors[ACCEL_PACKET_MAX];
    Hit hits[ACCEL_PACKET_MAX];
    uint64_t queued = 0;
    for (int i0 = 0; i0 < m; i0 += QUAD) {
        int np = m - i0 < QUAD ? m - i0 : QUAD;
        for (int i = 0; i < np; i++) {
            int t = in[i0 + i], x = x0 + t % TILE, y = by + t / TILE;
            if (f->fixed_xy) {
                xy[i] = f->fixed_xy; /* asked once */
            } else {
                sampler_pixel(s, x, y, buf[i]);
                xy[i] = buf[i];
            }
            *film_count(f, x, y) = 16;
            if (f->per && !f->row_weights)
                film_sample_weights(f, x, y, 16, xy[i]);
            dst[i] = scratch ? scratch + (size_t)t * per_px : film_sample(f, x, y, 0);
            px[i] = x;
            py[i] = y;
            queued |= (uint64_t)1 << t;
        }
        /* traced as stream_flush would */
        int n = 16 * np;
        camera_sample_rays_pixels(f->camera, np, px, py, xy, c->full_width, c->full_height,
                                  st->rays);
        raytracer_trace_packet(f->rt, ctx, st->rays, n, f->tmin, colors, hits);
        film_finite_colors(colors, n);
        if (sums0) {
            /* The box 0.5's moments straight from the colours: each pixel's sums of its
             * samples in order, weight 1 each (film_moments_cfg), the operations of
             * film_tile_moments' lanes; the samples go nowhere else. */
            for (int i = 0; i < np; i++) {
                const Vec3 *cl = colors + 16 * i;
                float sr = 0.0f, sg = 0.0f, sb = 0.0f, sw = 0.0f;
                for (int k = 0; k < 16; k++) {
                    sr += cl[k].x * 1.0f;
                    sg += cl[k].y * 1.0f;
                    sb += cl[k].z * 1.0f;
                    sw += 1.0f;
                }
                *film_mom(f, px[i], py[i], 0) = film_finite_sum(sr);
                *film_mom(f, px[i], py[i], 1) = film_finite_sum(sg);
                *film_mom(f, px[i], py[i], 2) = film_finite_sum(sb);
                *film_mom(f, px[i], py[i], 3) = sw;
            }
            continue;
        }
        for (int i = 0; i < np; i++)
            film_put_block(dst[i], xy[i], colors + 16 * i);
    }
    st->n = 0;
    return queued;
}
#endif

/* Moments (Film.moments) as a tile is traced. A tile row's samples are brought into
 * eight-column planes (lane dx: column x0 + dx): sample s's position at pos + 16 s
 * (x) and pos + 16 s + 8 (y), its colour at col + 40 s + 8 c (c = 2, 3, 4: red, green,
 * blue); the separable weights of those positions at wl: weight k of group v (2s: the x
 * positions, towards columns; 2s + 1: the y ones, towards rows) at wl + 8 (v side + k).
 * Then each lane's sums towards the (2R+1)^2 pixels around go to res: towards (kx, ky),
 * channel c at res + 8 (4 (kx side + ky) + c). Each sum starts from 0 and adds its
 * samples in order, the weight wx * wy then sum += colour * weight and the weight sum
 * += weight, separate multiplies and adds, the same IEEE single operations in every
 * lane and in film_filter_line's general loop: the same bits on every path. */
typedef float FilmV8f __attribute__((vector_size(32)));

#define FILM_V8(p) ({ FilmV8f v_; memcpy(&v_, (p), sizeof v_); v_; })
#define FILM_V8_PUT(p, v) do { FilmV8f w_ = (v); memcpy((p), &w_, sizeof w_); } while (0)

/* R = 1 (side 3), the Gaussian 0.4's: the twelve sums of one kx in registers. */
#define FILM_MOMENTS_3(NAME, ...)                                                          \
    __attribute__((__VA_ARGS__)) static void NAME(const float *col, const float *wl,       \
                                                  int n, float *res)                        \
    {                                                                                      \
        for (int kx = 0; kx < 3; kx++) {                                                   \
            FilmV8f z = {0}, r0 = z, g0 = z, b0 = z, w0 = z, r1 = z, g1 = z, b1 = z,       \
                    w1 = z, r2 = z, g2 = z, b2 = z, w2 = z;                                \
            for (int s = 0; s < n; s++) {                                                  \
                const float *c = col + 40 * s;                                             \
                FilmV8f wx = FILM_V8(wl + 8 * (6 * s + kx));                               \
                FilmV8f cr = FILM_V8(c + 16), cg = FILM_V8(c + 24), cb = FILM_V8(c + 32);  \
                const float *wy = wl + 8 * (6 * s + 3);                                    \
                FilmV8f u = wx * FILM_V8(wy);                                              \
                r0 += cr * u, g0 += cg * u, b0 += cb * u, w0 += u;                         \
                u = wx * FILM_V8(wy + 8);                                                  \
                r1 += cr * u, g1 += cg * u, b1 += cb * u, w1 += u;                         \
                u = wx * FILM_V8(wy + 16);                                                 \
                r2 += cr * u, g2 += cg * u, b2 += cb * u, w2 += u;                         \
            }                                                                              \
            float *o = res + 8 * 4 * (3 * kx);                                             \
            FILM_V8_PUT(o, r0); FILM_V8_PUT(o + 8, g0); FILM_V8_PUT(o + 16, b0);           \
            FILM_V8_PUT(o + 24, w0); FILM_V8_PUT(o + 32, r1); FILM_V8_PUT(o + 40, g1);     \
            FILM_V8_PUT(o + 48, b1); FILM_V8_PUT(o + 56, w1); FILM_V8_PUT(o + 64, r2);     \
            FILM_V8_PUT(o + 72, g2); FILM_V8_PUT(o + 80, b2); FILM_V8_PUT(o + 88, w2);     \
        }                                                                                  \
    }

/* Any R: the sums in res, added to in place. */
#define FILM_MOMENTS_N(NAME, ...)                                                          \
    __attribute__((__VA_ARGS__)) static void NAME(const float *col, const float *wl,       \
                                                  int n, int side, float *res)              \
    {                                                                                      \
        memset(res, 0, (size_t)32 * (size_t)side * (size_t)side * sizeof *res);            \
        for (int kx = 0; kx < side; kx++)                                                  \
            for (int s = 0; s < n; s++) {                                                  \
                const float *c = col + 40 * s;                                             \
                FilmV8f wx = FILM_V8(wl + 8 * ((size_t)2 * s * side + kx));                \
                FilmV8f cr = FILM_V8(c + 16), cg = FILM_V8(c + 24), cb = FILM_V8(c + 32);  \
                const float *wy = wl + 8 * ((size_t)(2 * s + 1) * side);                   \
                for (int ky = 0; ky < side; ky++) {                                        \
                    FilmV8f u = wx * FILM_V8(wy + 8 * ky);                                 \
                    float *o = res + 32 * (kx * side + ky);                                \
                    FILM_V8_PUT(o, FILM_V8(o) + cr * u);                                   \
                    FILM_V8_PUT(o + 8, FILM_V8(o + 8) + cg * u);                           \
                    FILM_V8_PUT(o + 16, FILM_V8(o + 16) + cb * u);                         \
                    FILM_V8_PUT(o + 24, FILM_V8(o + 24) + u);                              \
                }                                                                          \
            }                                                                              \
    }

FILM_MOMENTS_3(film_moments3, unused)
FILM_MOMENTS_N(film_moments_n, unused)
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
FILM_MOMENTS_3(film_moments3_avx2, target("avx2"))
FILM_MOMENTS_N(film_moments_n_avx2, target("avx2"))
#define FILM_HAVE_MOMENTS_AVX2 1
#endif

/* film_finite_sum on a tile row's colour sums (res: groups of four planes of eight
 * lanes, red, green, blue and the weight, which is finite), by min and max: the same
 * floats (the sums are never NaN). Callgrind, 17a 120 x 120, jittered 16 + Gaussian
 * 0.4, one thread, AVX2: +0.09% instructions (a float at a time with branches, +1.8%). */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* Eight sums at p made finite (film_finite_sum in eight lanes). */
__attribute__((target("avx2"), always_inline)) static inline __m256 film_finite8(const float *p)
{
    return _mm256_min_ps(_mm256_max_ps(_mm256_loadu_ps(p), _mm256_set1_ps(-FLT_MAX)),
                         _mm256_set1_ps(FLT_MAX));
}

__attribute__((target("avx2"))) static void film_finite_sums8_avx2(float *res, int planes)
{
    for (float *q = res, *end = res + 8 * planes; q < end; q += 32)
        for (int c = 0; c < 24; c += 8)
            _mm256_storeu_ps(q + c, film_finite8(q + c));
}
#endif

/* A whole tile row's sums (film_finite_sums8's clamp of the colour planes; the weight
 * planes, every fourth, are finite) stored straight into the moment planes: one pass
 * instead of the clamp in place and then a copy. The same floats. */
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
__attribute__((target("avx2"))) static void film_put_sums8_avx2(const Film *f,
                                                                const float *res, int planes,
                                                                int x0, int y)
{
    float *d = film_mom(f, x0, y, 0);
    size_t pw = (size_t)f->pw;
    for (int p = 0; p < planes; p += 4, d += 4 * pw, res += 32) {
        for (int c = 0; c < 3; c++)
            _mm256_storeu_ps(d + (size_t)c * pw, film_finite8(res + 8 * c));
        _mm256_storeu_ps(d + 3 * pw, _mm256_loadu_ps(res + 24));
    }
}
#endif

static void film_finite_sums8(const Film *f, float *res, int planes)
{
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
    if (f->avx2) {
        film_finite_sums8_avx2(res, planes);
        return;
    }
    const __m128 hi = _mm_set1_ps(FLT_MAX), lo = _mm_set1_ps(-FLT_MAX);
    for (int p = 0; p < planes; p += 4)
        for (int k = 0; k < 24; k += 4) {
            float *q = res + 8 * p + k;
            _mm_storeu_ps(q, _mm_min_ps(_mm_max_ps(_mm_loadu_ps(q), lo), hi));
        }
#else
    (void)f;
    for (int p = 0; p < planes; p += 4)
        for (int k = 0; k < 24; k++)
            res[8 * p + k] = film_finite_sum(res[8 * p + k]);
#endif
}

/* The samples of a tile row (bits `row` of the tile's columns, their channels side by
 * side from src) into the film (planes, or pixel by pixel with R = 0): only for the
 * samples picture with moments. */
static void film_row_to_planes(const Film *f, const float *src, int x0, int y, unsigned row)
{
    size_t per_px = (size_t)f->slots * 5, cs = f->cs;
#ifdef FILM_HAVE_COPY_ROW8
    if (f->avx2 && f->planes && row == 0xffu) {
        film_copy_row8(src, per_px, f->slots * 5, film_sample(f, x0, y, 0), f->ss, cs, NULL,
                       false);
        return;
    }
#endif
    for (int dx = 0; dx < TILE; dx++) {
        if (!(row >> dx & 1))
            continue;
        const float *p = src + (size_t)dx * per_px;
        float *d = film_sample(f, x0 + dx, y, 0);
        for (int i = 0; i < f->slots; i++, p += 5, d += f->ss)
            for (int c = 0; c < 5; c++)
                d[(size_t)c * cs] = p[c];
    }
}

/* The moments of a traced tile's pixels (bits `queued`, dy * TILE + dx), their samples
 * in the scratch (channels side by side); work: the planes above (film_band's, behind
 * the scratch). Rows of the tile's eight pixels through film_copy_row8 where the CPU
 * has AVX2, else (and for cut rows) a float at a time; a column without a pixel gets
 * position 0.5 and colour 0, and its sums are not stored. */
static void film_tile_moments(const Film *f, int x0, int by, uint64_t queued,
                              const float *scratch, float *work)
{
    const FilmConfig *c = f->cfg;
    int n = f->slots, R = f->R, side = 2 * R + 1;
    size_t per_px = (size_t)n * 5;
    float *pos = work, *col = pos + 16 * (size_t)n, *wl = col + 40 * (size_t)n;
    float *res = wl + 16 * (size_t)side * (size_t)n;
    for (int dy = 0; dy < TILE; dy++) {
        unsigned row = (unsigned)(queued >> (dy * TILE)) & 0xffu;
        if (!row)
            continue;
        int y = by + dy;
        const float *src = scratch + (size_t)(dy * TILE) * per_px;
        if (c->samples)
            film_row_to_planes(f, src, x0, y, row);
        bool done = false;
#ifdef FILM_HAVE_COPY_ROW8
        if (f->avx2 && row == 0xffu) {
            film_copy_row8(src, per_px, 5 * n, col, 40, 8, pos, false);
            done = true;
        }
#endif
        if (!done)
            for (int dx = 0; dx < TILE; dx++) {
                const float *p = src + (size_t)dx * per_px;
                bool in = row >> dx & 1;
                for (int s = 0; s < n; s++, p += 5) {
                    pos[16 * s + dx] = in ? p[0] : 0.5f;
                    pos[16 * s + 8 + dx] = in ? p[1] : 0.5f;
                    for (int ch = 2; ch < 5; ch++)
                        col[40 * s + 8 * ch + dx] = in ? p[ch] : 0.0f;
                }
            }
        if (R > 0)
            filter_weights_1d_blocks(c->filter, pos, 2 * n, R, wl, 8, (size_t)side * 8);
        else /* the box 0.5's weight of every own sample (film_moments_cfg) */
            for (int k = 0; k < 16 * n; k++)
                wl[k] = 1.0f;
#ifdef FILM_HAVE_MOMENTS_AVX2
        if (f->avx2) {
            if (side == 3)
                film_moments3_avx2(col, wl, n, res);
            else
                film_moments_n_avx2(col, wl, n, side, res);
        } else
#endif
        {
            if (side == 3)
                film_moments3(col, wl, n, res);
            else
                film_moments_n(col, wl, n, side, res);
        }
        int planes = 4 * side * side;
#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
        if (row == 0xffu && f->avx2) {
            film_put_sums8_avx2(f, res, planes, x0, y);
            continue;
        }
#endif
        film_finite_sums8(f, res, planes);
        if (row == 0xffu) {
            for (int p = 0; p < planes; p++)
                memcpy(film_mom(f, x0, y, p), res + 8 * p, 8 * sizeof *res);
        } else {
            for (int dx = 0; dx < TILE; dx++)
                if (row >> dx & 1)
                    for (int p = 0; p < planes; p++)
                        *film_mom(f, x0 + dx, y, p) = res[8 * p + dx];
        }
    }
}

/* One 8 x 8 tile of a band (columns x0.., rows by.., those inside [sx0, sx1) and
 * [y0, y1)): its pixels' samples queued in Morton order (with `refine`: only the
 * pixels whose first samples disagree, sampled again), traced, and, through the
 * tile's scratch, stored into the film's planes. The tracer writes a sample's channels
 * side by side in the scratch (the film's planes would take a cache line per channel
 * and sample while the packets run); the copy then writes whole runs of the tile's
 * columns. Without scratch (out of memory) the samples go to the planes directly. */
static void film_tile(const Film *f, RenderCtx *ctx, Stream *st, int x0, int by, int y0,
                      int y1, bool refine, float *scratch, float *pos)
{
    const FilmConfig *c = f->cfg;
    size_t per_px = (size_t)f->slots * (size_t)f->stride;
    uint64_t queued = 0;
    st->cs = scratch ? 1 : f->cs;
#ifdef FILM_HAVE_RUNS
    if (!refine && c->sampler->count == 16 && f->avx512 && st->cs == 1 &&
        (scratch ? (size_t)f->stride : f->ss) == 5) {
        /* R = 0 moments (the box 0.5) summed there, nothing left to do here */
        bool sums0 = f->mom && f->R == 0 && !c->samples;
        queued = film_tile_quads(f, ctx, st, x0, by, y0, y1, scratch, sums0);
        if (sums0)
            return;
    } else
#endif
        for (int k = 0; k < TILE * TILE; k++) {
            int dx, dy;
            render_tile_order(k, &dx, &dy);
            int x = x0 + dx, y = by + dy;
            if (x < f->sx0 || x >= f->sx1 || y < y0 || y >= y1)
                continue;
            if (refine && !film_disagrees(f, x, y))
                continue;
            int t = dy * TILE + dx;
            film_queue_pixel(f, ctx, st, refine ? c->refine : c->sampler, x, y,
                             scratch ? scratch + (size_t)t * per_px : NULL);
            queued |= (uint64_t)1 << t;
        }
    stream_flush(f, ctx, st);
    if (!scratch)
        return;
    if (f->mom) {
        film_tile_moments(f, x0, by, queued, scratch, pos);
        return;
    }
    size_t cs = f->cs;
    /* The separable weights (film_row_weights' planes and bits) from the scratch, a tile
     * row at a time, while its positions are in registers or L1: weights is set where
     * the film's planes have them and this band's caller (film_band) leaves them to us.
     * The positions then reach the planes only for the samples picture. */
    bool weights = pos != NULL;
    bool keep_pos = !weights || c->samples != NULL;
    int side = 2 * f->R + 1;
    for (int dy = 0; dy < TILE; dy++) {
        uint64_t row = (queued >> (dy * TILE)) & 0xff;
        if (!row)
            continue;
        int y = by + dy;
#ifdef FILM_HAVE_COPY_ROW8
        /* A whole row of pixels with the sampler's count, colour only: transposed. */
        if (f->avx2 && row == 0xff && f->stride == 5) {
            bool full = true;
            for (int dx = 0; dx < TILE; dx++)
                full &= *film_count(f, x0 + dx, y) == f->slots;
            if (full) {
                film_copy_row8(scratch + (size_t)(dy * TILE) * per_px, per_px, f->slots * 5,
                               film_sample(f, x0, y, 0), f->ss, cs, weights ? pos : NULL,
                               keep_pos);
                /* slot s's x positions (group 2s) weigh towards columns, its y (2s + 1)
                 * towards rows: weight k of group v at v side + k planes on */
                if (weights)
                    filter_weights_1d_blocks(c->filter, pos, 2 * f->slots, f->R,
                                             film_weights(f, x0, y, 0, 0), (size_t)f->pw,
                                             (size_t)side * (size_t)f->pw);
                continue;
            }
        }
#endif
        for (int dx = 0; dx < TILE; dx++) {
            if (!(row >> dx & 1))
                continue;
            int x = x0 + dx, n = *film_count(f, x, y), stride = f->stride;
            const float *src = scratch + (size_t)(dy * TILE + dx) * per_px;
            float *d = film_sample(f, x, y, 0);
            size_t ss = f->ss;
            if (weights) { /* this pixel's weights as film_queue_pixel would make them */
                float *xy = pos;
                for (int i = 0; i < n; i++) {
                    xy[2 * i] = src[(size_t)i * (size_t)stride];
                    xy[2 * i + 1] = src[(size_t)i * (size_t)stride + 1];
                }
                film_sample_weights(f, x, y, n, xy);
            }
            if (stride == 5) /* colour only: the common case, unrolled */
                for (int i = 0; i < n; i++, src += 5, d += ss) {
                    d[0] = src[0];
                    d[cs] = src[1];
                    d[2 * cs] = src[2];
                    d[3 * cs] = src[3];
                    d[4 * cs] = src[4];
                }
            else
                for (int i = 0; i < n; i++, src += stride, d += ss)
                    for (int ch = 0; ch < stride; ch++)
                        d[(size_t)ch * cs] = src[ch];
        }
    }
}

/* The first row of the strip's first band: on the packet grid when strips are whole
 * bands (rows_cap >= TILE); strips of fewer rows (a tiny budget, or many samples on a
 * wide image) keep their bands from their own first row, as the grid would cut each
 * of them into two thin bands. */
static int film_band_base(const Film *f)
{
    return f->rows_cap >= TILE ? film_grid_floor(f->r0) : f->r0;
}

static void film_band(void *user, RenderCtx *ctx, int band)
{
    const Film *f = user;
    const FilmConfig *c = f->cfg;
    /* Bands and tiles lie on the full image's grid of TILE x TILE packet tiles (rows
     * and columns counted from 0 at the bottom left, as render_image's; rows only when
     * strips are whole bands, film_band_base): a rectangle, a -tile band or a strip
     * traces the same packets as the whole render wherever its edges lie on that grid,
     * and cuts only the tiles its edges cross. */
    int by = film_band_base(f) + band * TILE;
    int y0 = by > f->r0 ? by : f->r0, y1 = by + TILE < f->r1 ? by + TILE : f->r1;
    int bx = film_grid_floor(f->sx0);
    uint64_t rays0 = ctx->stats.nonshadow_rays + ctx->stats.shadow_rays;
    Stream st;
    st.n = 0;
    /* The tile's scratch, for planes and moments only (NULL: the samples go to the film
     * directly), and behind it, with row weights, the positions of a tile row (film_tile:
     * 2 slots groups of eight, or a pixel's x y pairs) from which film_tile makes the
     * weights, or film_tile_moments' planes. */
    size_t tile_floats = (size_t)TILE * TILE * (size_t)f->slots * (size_t)f->stride;
    size_t side = 2 * (size_t)f->R + 1, work = f->row_weights ? (size_t)16 * (size_t)f->slots : 0;
    if (f->mom) /* film_tile_moments' planes: positions, colours, weights, sums */
        work = (56 + 16 * side) * (size_t)f->slots + 32 * side * side;
    float *scratch = f->planes || f->mom ? malloc((tile_floats + work) * sizeof *scratch) : NULL;
    float *pos = scratch && (f->row_weights || f->mom) ? scratch + tile_floats : NULL;
    if (f->mom && !scratch) {
        /* The moments are made from the scratch only: the render fails (out of memory). */
        __atomic_store_n(f->failed, 1, __ATOMIC_RELAXED);
        return;
    }
    /* Tiles of 8 x 8 pixels in Morton order, each pixel's samples in a row: the rays of
     * one packet come from a few neighbouring pixels (16 samples: a 2 x 2 block; a
     * tile's 64 n rays fill whole packets). A band of many samples takes long: a stop
     * is noticed at the next tile (the run then returns false and its film is thrown
     * away). */
    for (int x0 = bx; x0 < f->sx1 && !(f->cancel && *f->cancel); x0 += TILE)
        film_tile(f, ctx, &st, x0, by, y0, y1, false, scratch, pos);
    if (f->cancel && *f->cancel) {
        free(scratch);
        return; /* a cut band: no refinement, no progress */
    }
    if (f->row_weights && !pos) /* no scratch (out of memory): from the planes */
        for (int y = y0; y < y1; y++)
            film_row_weights(f, y);
    if (c->refine)
        for (int x0 = bx; x0 < f->sx1; x0 += TILE)
            film_tile(f, ctx, &st, x0, by, y0, y1, true, scratch, NULL);
    free(scratch);
    progress_add(c->progress, (uint64_t)(y1 - y0) * (uint64_t)f->fw,
                 ctx->stats.nonshadow_rays + ctx->stats.shadow_rays - rays0);
    if (c->samples)
        for (int y = y0 > c->y0 ? y0 : c->y0; y < y1 && y < c->y0 + c->height; y++)
            for (int x = c->x0; x < c->x0 + c->width; x++)
                film_draw_samples(f, x, y);
}

/* The weight of sample s (data d) of pixel (a, b) for output pixel (i, j). */
static inline float film_weight(const Film *f, const float *d, int a, int b, int i, int j,
                                int s)
{
    int R = f->R;
    if (f->table)
        return f->table[((a - i + R) * (2 * R + 1) + (b - j + R)) * f->slots + s];
    if (f->per)
        return *film_weights(f, a, b, s, a - i + R) *
               *film_weights(f, a, b, s, 2 * R + 1 + b - j + R);
    /* The exact offset from the centre of pixel (i, j), rounded to float once (the
     * general loop's films are pixel by pixel: channels side by side). */
    float dx = (float)((double)(a - i) + (double)d[0] - 0.5);
    float dy = (float)((double)(b - j) + (double)d[1] - 0.5);
    return filter_weight(f->cfg->filter, dx, dy);
}

/* The output pixels i0 .. i1-1 of row j whose columns of support lie inside the image,
 * in the plain case (colour only, every pixel with the sampler's count; fixed or
 * separable weights), SPAN pixels at a time: their sums in arrays, each pixel's terms
 * added in film_filter_row's order (columns, rows, samples) with the same float
 * operations, so the same bits. One term (column offset ta, row b, sample s) is added
 * to the whole span before the next: the colour and weight planes are read in runs of
 * consecutive columns, four per vector, and the span's sums stay in L1. (Pixel by
 * pixel, or four in the lanes of a vector, every term of a pixel was a new cache line
 * 8 KB from the last -- a channel plane per sample slot -- and filtering was bound by
 * those loads.) */
enum { FILM_SPAN = 256 };

/* acc[q .. q+L-1] += v * w (or += w without v), as vectors of the type V. */
#define FILM_SPAN_ADD(V, acc, v, w)                                                       \
    do {                                                                                  \
        V a_;                                                                             \
        memcpy(&a_, (acc), sizeof a_);                                                    \
        a_ += (v) * (w);                                                                  \
        memcpy((acc), &a_, sizeof a_);                                                    \
    } while (0)

/* The sums of the span's m pixels from p0 on (film_filter_span), vectors of type V of
 * L floats, then the rest one by one with the same operations. */
#define FILM_SPAN_SUMS(NAME, V, L)                                                        \
    static void NAME(const Film *f, int j, int b0, int b1, int p0, int m, float *sr,      \
                     float *sg, float *sb, float *sw)                                     \
    {                                                                                     \
        int R = f->R, side = 2 * R + 1, n = f->slots;                                     \
        size_t cs = f->cs;                                                                \
        const V one = (V){0} + 1.0f;                                                      \
        for (int ta = 0; ta < side; ta++) {                                               \
            int a = p0 - R + ta; /* pixel p0 + q's column ta is a + q */                 \
            for (int b = b0; b <= b1; b++)                                                \
                for (int s = 0; s < n; s++) {                                             \
                    const float *d = film_sample(f, a, b, s);                             \
                    const float *cr = d + 2 * cs, *cg = d + 3 * cs, *cb = d + 4 * cs;     \
                    const float *wx = NULL, *wy = NULL;                                   \
                    float t = 0.0f;                                                       \
                    if (f->per) {                                                         \
                        wx = film_weights(f, a, b, s, ta);                                \
                        wy = film_weights(f, a, b, s, side + b - j + R);                  \
                    } else {                                                              \
                        t = f->table[(ta * side + (b - j + R)) * f->slots + s];           \
                    }                                                                     \
                    V tv = t - (V){0}; /* a broadcast: x - 0 is x, -0 too */              \
                    int q = 0;                                                            \
                    for (; q + L <= m; q += L) {                                          \
                        V w = tv, wyv, v;                                                 \
                        if (wx) {                                                         \
                            memcpy(&w, wx + q, sizeof w);                                 \
                            memcpy(&wyv, wy + q, sizeof wyv);                             \
                            w *= wyv;                                                     \
                        }                                                                 \
                        memcpy(&v, cr + q, sizeof v);                                     \
                        FILM_SPAN_ADD(V, sr + q, v, w);                                   \
                        memcpy(&v, cg + q, sizeof v);                                     \
                        FILM_SPAN_ADD(V, sg + q, v, w);                                   \
                        memcpy(&v, cb + q, sizeof v);                                     \
                        FILM_SPAN_ADD(V, sb + q, v, w);                                   \
                        FILM_SPAN_ADD(V, sw + q, w, one);                                 \
                    }                                                                     \
                    for (; q < m; q++) {                                                  \
                        float w = wx ? wx[q] * wy[q] : t;                                 \
                        sr[q] += cr[q] * w;                                               \
                        sg[q] += cg[q] * w;                                               \
                        sb[q] += cb[q] * w;                                               \
                        sw[q] += w;                                                       \
                    }                                                                     \
                }                                                                         \
        }                                                                                 \
    }

FILM_SPAN_SUMS(film_span_sums, FilmV4f, 4)

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
/* The sums where the CPU has AVX2: film_span_sums_avx512's loop, 16 pixels at a time
 * (two vectors of 8) keeping their four sums in registers through all the terms (8 of
 * the 16 registers), the terms' plane pointers listed first (FILM_TERMS8 at a time),
 * each term as there: the weight wx * wy (or the table's), then sum += colour * weight
 * per channel and the weight sum += weight, separate multiplies and adds (no FMA is
 * enabled), each pixel's terms in film_filter_row's order: the same bits as
 * film_span_sums. The span's last block through masked loads and stores. Until
 * 2026-11-27 the AVX2 sums were film_span_sums' loop in vectors of 8, which loads and
 * stores every sum for every term (13 memory operations per 8 pixels and term against
 * 5 here); on the Zen 3 host (17a 400x400, jittered 16 + Gaussian 0.4, 1 thread, 12
 * interleaved rounds) filtering took 23.2 ms (median) with those, 18.5 with these and
 * the prefetches (per-round ratio 0.85). */
#define FILM_HAVE_AVX2 1
enum { FILM_TERMS8 = 256, FILM_BLOCK8 = 16 };

/* One block of 16 pixels from q on; tail: only `left` (< 16) of them exist. */
__attribute__((always_inline, target("avx2"))) static inline void
film_block8(const float *const *col, const float *const *wxp, const float *const *wyp,
            const float *tw, int nt, size_t cs, int q, bool tail, int left, float *sr,
            float *sg, float *sb, float *sw)
{
    __m256i m0 = _mm256_setzero_si256(), m1 = m0;
    if (tail) {
        const __m256i lane = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
        m0 = _mm256_cmpgt_epi32(_mm256_set1_epi32(left), lane);
        m1 = _mm256_cmpgt_epi32(_mm256_set1_epi32(left - 8), lane);
    }
#define FILM_LD8(p, mk) (tail ? _mm256_maskload_ps((p), (mk)) : _mm256_loadu_ps(p))
    __m256 r0 = FILM_LD8(sr + q, m0), r1 = FILM_LD8(sr + q + 8, m1);
    __m256 g0 = FILM_LD8(sg + q, m0), g1 = FILM_LD8(sg + q + 8, m1);
    __m256 c0 = FILM_LD8(sb + q, m0), c1 = FILM_LD8(sb + q + 8, m1);
    __m256 s0 = FILM_LD8(sw + q, m0), s1 = FILM_LD8(sw + q + 8, m1);
    for (int k = 0; k < nt; k++) {
        const float *cr = col[k] + q, *cg = cr + cs, *cb = cg + cs;
        __m256 w0, w1;
        /* the next block's line of each plane (720 streams at 16 samples: more than
         * the hardware prefetcher follows) */
        _mm_prefetch((const char *)(cr + FILM_BLOCK8), _MM_HINT_T0);
        _mm_prefetch((const char *)(cg + FILM_BLOCK8), _MM_HINT_T0);
        _mm_prefetch((const char *)(cb + FILM_BLOCK8), _MM_HINT_T0);
        if (wxp) {
            const float *x = wxp[k] + q, *y = wyp[k] + q;
            _mm_prefetch((const char *)(x + FILM_BLOCK8), _MM_HINT_T0);
            _mm_prefetch((const char *)(y + FILM_BLOCK8), _MM_HINT_T0);
            w0 = _mm256_mul_ps(FILM_LD8(x, m0), FILM_LD8(y, m0));
            w1 = _mm256_mul_ps(FILM_LD8(x + 8, m1), FILM_LD8(y + 8, m1));
        } else {
            w0 = w1 = _mm256_set1_ps(tw[k]);
        }
        r0 = _mm256_add_ps(r0, _mm256_mul_ps(FILM_LD8(cr, m0), w0));
        r1 = _mm256_add_ps(r1, _mm256_mul_ps(FILM_LD8(cr + 8, m1), w1));
        g0 = _mm256_add_ps(g0, _mm256_mul_ps(FILM_LD8(cg, m0), w0));
        g1 = _mm256_add_ps(g1, _mm256_mul_ps(FILM_LD8(cg + 8, m1), w1));
        c0 = _mm256_add_ps(c0, _mm256_mul_ps(FILM_LD8(cb, m0), w0));
        c1 = _mm256_add_ps(c1, _mm256_mul_ps(FILM_LD8(cb + 8, m1), w1));
        s0 = _mm256_add_ps(s0, w0);
        s1 = _mm256_add_ps(s1, w1);
    }
#undef FILM_LD8
#define FILM_ST8(p, mk, v)                                                                \
    do {                                                                                  \
        if (tail)                                                                         \
            _mm256_maskstore_ps((p), (mk), (v));                                          \
        else                                                                              \
            _mm256_storeu_ps((p), (v));                                                   \
    } while (0)
    FILM_ST8(sr + q, m0, r0);
    FILM_ST8(sr + q + 8, m1, r1);
    FILM_ST8(sg + q, m0, g0);
    FILM_ST8(sg + q + 8, m1, g1);
    FILM_ST8(sb + q, m0, c0);
    FILM_ST8(sb + q + 8, m1, c1);
    FILM_ST8(sw + q, m0, s0);
    FILM_ST8(sw + q + 8, m1, s1);
#undef FILM_ST8
}

__attribute__((target("avx2"))) static void film_span_sums_avx2(const Film *f, int j, int b0,
                                                                int b1, int p0, int m,
                                                                float *sr, float *sg,
                                                                float *sb, float *sw)
{
    int R = f->R, side = 2 * R + 1, n = f->slots, rows = b1 - b0 + 1;
    size_t cs = f->cs;
    const float *col[FILM_TERMS8], *wxp[FILM_TERMS8], *wyp[FILM_TERMS8];
    float tw[FILM_TERMS8];
    int total = side * rows * n;
    /* term t: column ta, row b, sample s (t = (ta rows + b - b0) n + s), counted up
     * (no divisions: their latency was a tenth of the sums' time at 64 columns) */
    int ta = 0, b = b0, s = 0;
    for (int t0 = 0; t0 < total; t0 += FILM_TERMS8) {
        int nt = total - t0 < FILM_TERMS8 ? total - t0 : FILM_TERMS8;
        for (int k = 0; k < nt; k++) {
            int a = p0 - R + ta;
            col[k] = film_sample(f, a, b, s) + 2 * cs;
            if (f->per) {
                wxp[k] = film_weights(f, a, b, s, ta);
                wyp[k] = film_weights(f, a, b, s, side + b - j + R);
            } else {
                tw[k] = f->table[(ta * side + (b - j + R)) * n + s];
            }
            if (++s == n) {
                s = 0;
                if (++b > b1) {
                    b = b0;
                    ta++;
                }
            }
        }
        const float *const *wx = f->per ? wxp : NULL;
        int q = 0;
        for (; q + FILM_BLOCK8 <= m; q += FILM_BLOCK8)
            film_block8(col, wx, wyp, tw, nt, cs, q, false, 0, sr, sg, sb, sw);
        if (q < m)
            film_block8(col, wx, wyp, tw, nt, cs, q, true, m - q, sr, sg, sb, sw);
    }
}

/* The sums with AVX-512, 32 pixels at a time (two vectors of 16) that keep their four
 * sums in registers through all the terms: the vectors above add each term to the
 * span's sums in memory, a load and a store of each sum per term (13 memory operations
 * per 8 pixels and term, the sums' cost on 16-sample Gaussian renders, where every
 * output pixel has 144 terms). Each pixel still adds its terms in film_filter_row's
 * order (columns, rows, samples), each term a product rounded to float and then a sum
 * (separate multiply and add instructions: no fused multiply-add), so the same bits:
 * the weight wx * wy, then sum += colour * weight per channel, and the weight sum +=
 * weight (the vectors' w * 1, which is w). The terms' plane pointers are listed first,
 * FILM_TERMS at a time (more terms: the sums go back to memory between batches, in
 * order); the span's last block is masked. */
enum { FILM_TERMS = 256, FILM_BLOCK = 32 };

#define FILM_AVX512 target("avx512f,avx512vl,avx512bw,avx512dq")

/* The masks of a block's two vectors of 16 pixels when `left` pixels of the span
 * remain from the block's first on (the span's last block may be short). */
__attribute__((always_inline, FILM_AVX512)) static inline void
film_block_masks(int left, __mmask16 *m0, __mmask16 *m1)
{
    *m0 = left >= 16 ? (__mmask16)0xffff : (__mmask16)((1u << left) - 1);
    *m1 = left >= 32 ? (__mmask16)0xffff
          : left <= 16 ? (__mmask16)0
                       : (__mmask16)((1u << (left - 16)) - 1);
}

__attribute__((FILM_AVX512)) static void film_span_sums_avx512(const Film *f, int j, int b0,
                                                               int b1, int p0, int m,
                                                               float *sr, float *sg,
                                                               float *sb, float *sw)
{
    int R = f->R, side = 2 * R + 1, n = f->slots, rows = b1 - b0 + 1;
    size_t cs = f->cs;
    const float *col[FILM_TERMS], *wxp[FILM_TERMS], *wyp[FILM_TERMS];
    float tw[FILM_TERMS];
    int total = side * rows * n;
    for (int t0 = 0; t0 < total; t0 += FILM_TERMS) {
        int nt = total - t0 < FILM_TERMS ? total - t0 : FILM_TERMS;
        for (int k = 0; k < nt; k++) { /* term t: column ta, row b, sample s */
            int t = t0 + k, s = t % n, b = b0 + t / n % rows, ta = t / (n * rows);
            int a = p0 - R + ta;
            col[k] = film_sample(f, a, b, s) + 2 * cs;
            if (f->per) {
                wxp[k] = film_weights(f, a, b, s, ta);
                wyp[k] = film_weights(f, a, b, s, side + b - j + R);
            } else {
                tw[k] = f->table[(ta * side + (b - j + R)) * n + s];
            }
        }
        for (int q = 0; q < m; q += FILM_BLOCK) {
            __mmask16 m0, m1;
            film_block_masks(m - q, &m0, &m1);
            __m512 r0 = _mm512_maskz_loadu_ps(m0, sr + q), r1 = _mm512_maskz_loadu_ps(m1, sr + q + 16);
            __m512 g0 = _mm512_maskz_loadu_ps(m0, sg + q), g1 = _mm512_maskz_loadu_ps(m1, sg + q + 16);
            __m512 c0 = _mm512_maskz_loadu_ps(m0, sb + q), c1 = _mm512_maskz_loadu_ps(m1, sb + q + 16);
            __m512 s0 = _mm512_maskz_loadu_ps(m0, sw + q), s1 = _mm512_maskz_loadu_ps(m1, sw + q + 16);
            for (int k = 0; k < nt; k++) {
                const float *cr = col[k] + q, *cg = cr + cs, *cb = cg + cs;
                __m512 w0, w1;
                _mm_prefetch((const char *)(cr + FILM_BLOCK), _MM_HINT_T0);
                _mm_prefetch((const char *)(cr + FILM_BLOCK + 16), _MM_HINT_T0);
                _mm_prefetch((const char *)(cg + FILM_BLOCK), _MM_HINT_T0);
                _mm_prefetch((const char *)(cg + FILM_BLOCK + 16), _MM_HINT_T0);
                _mm_prefetch((const char *)(cb + FILM_BLOCK), _MM_HINT_T0);
                _mm_prefetch((const char *)(cb + FILM_BLOCK + 16), _MM_HINT_T0);
                if (f->per) {
                    const float *x = wxp[k] + q, *y = wyp[k] + q;
                    _mm_prefetch((const char *)(x + FILM_BLOCK), _MM_HINT_T0);
                    _mm_prefetch((const char *)(x + FILM_BLOCK + 16), _MM_HINT_T0);
                    _mm_prefetch((const char *)(y + FILM_BLOCK), _MM_HINT_T0);
                    _mm_prefetch((const char *)(y + FILM_BLOCK + 16), _MM_HINT_T0);
                    w0 = _mm512_mul_ps(_mm512_maskz_loadu_ps(m0, x), _mm512_maskz_loadu_ps(m0, y));
                    w1 = _mm512_mul_ps(_mm512_maskz_loadu_ps(m1, x + 16),
                                       _mm512_maskz_loadu_ps(m1, y + 16));
                } else {
                    w0 = w1 = _mm512_set1_ps(tw[k]);
                }
                r0 = _mm512_add_ps(r0, _mm512_mul_ps(_mm512_maskz_loadu_ps(m0, cr), w0));
                r1 = _mm512_add_ps(r1, _mm512_mul_ps(_mm512_maskz_loadu_ps(m1, cr + 16), w1));
                g0 = _mm512_add_ps(g0, _mm512_mul_ps(_mm512_maskz_loadu_ps(m0, cg), w0));
                g1 = _mm512_add_ps(g1, _mm512_mul_ps(_mm512_maskz_loadu_ps(m1, cg + 16), w1));
                c0 = _mm512_add_ps(c0, _mm512_mul_ps(_mm512_maskz_loadu_ps(m0, cb), w0));
                c1 = _mm512_add_ps(c1, _mm512_mul_ps(_mm512_maskz_loadu_ps(m1, cb + 16), w1));
                s0 = _mm512_add_ps(s0, w0);
                s1 = _mm512_add_ps(s1, w1);
            }
            _mm512_mask_storeu_ps(sr + q, m0, r0);
            _mm512_mask_storeu_ps(sr + q + 16, m1, r1);
            _mm512_mask_storeu_ps(sg + q, m0, g0);
            _mm512_mask_storeu_ps(sg + q + 16, m1, g1);
            _mm512_mask_storeu_ps(sb + q, m0, c0);
            _mm512_mask_storeu_ps(sb + q + 16, m1, c1);
            _mm512_mask_storeu_ps(sw + q, m0, s0);
            _mm512_mask_storeu_ps(sw + q + 16, m1, s1);
        }
    }
}
#define FILM_HAVE_AVX512 1

/* Two output rows j and j + 1 at once (separable weights): their supports share the
 * rows b0n .. b1 (all but one at each end with R = 1), and a term of a shared row and
 * sample loads its colour and column weight once for both rows (12 loads for two terms
 * instead of 20), the rows' sums side by side in registers (16 vectors for 32 pixels).
 * Each row still adds its own terms in film_filter_row's order: per column offset ta,
 * the rows only j has (b0 .. b0n-1), then the shared rows, then the rows only j + 1
 * has (b1+1 .. b1n), samples innermost, each term as in film_span_sums_avx512. terms
 * are listed in that order (col, wx, and the two rows' row weights, NULL where a row
 * has no term); at most FILM_TERMS2 (callers check film_pair_terms). */
enum { FILM_TERMS2 = 512 };

static int film_pair_terms(const Film *f, int b0, int b1n)
{
    return (2 * f->R + 1) * (b1n - b0 + 1) * f->slots;
}

/* The terms of rows j and j + 1 in the order above, for both vector widths: col the
 * sample's colour column, wxp its column weight, wya / wyb its row weight for row j /
 * j + 1 (NULL where that row has no term). */
static void film_pair_term_lists(const Film *f, int j, int b0, int b1, int b0n, int b1n,
                                 int p0, const float **col, const float **wxp,
                                 const float **wya, const float **wyb)
{
    int R = f->R, side = 2 * R + 1, n = f->slots;
    size_t cs = f->cs, ss = f->ss, ws = f->ws;
    int k = 0;
    for (int ta = 0; ta < side; ta++) {
        int a = p0 - R + ta;
        for (int b = b0; b <= b1n; b++) {
            /* sample s's planes lie s ss (data) and s ws (weights) floats after sample
             * 0's: film_sample's and film_weights' addresses, counted up */
            const float *c0 = film_sample(f, a, b, 0) + 2 * cs;
            const float *x0 = film_weights(f, a, b, 0, ta);
            const float *ya = b <= b1 ? film_weights(f, a, b, 0, side + b - j + R) : NULL;
            const float *yb = b >= b0n ? film_weights(f, a, b, 0, side + b - j - 1 + R) : NULL;
            for (int s = 0; s < n; s++, k++) {
                col[k] = c0 + (size_t)s * ss;
                wxp[k] = x0 + (size_t)s * ws;
                wya[k] = ya ? ya + (size_t)s * ws : NULL;
                wyb[k] = yb ? yb + (size_t)s * ws : NULL;
            }
        }
    }
}

/* One term into one row's sums (P0 .. P7: r, g, b, weight; each as the block's two
 * vectors), weights w0, w1. Named vectors, not arrays: GCC kept arrays of vectors on
 * the stack (the filter phase was 25% slower than one row at a time). */
#define FILM_PAIR_ADD(P, w0, w1)                                                          \
    do {                                                                                  \
        P##0 = _mm512_add_ps(P##0, _mm512_mul_ps(c0, w0));                                \
        P##1 = _mm512_add_ps(P##1, _mm512_mul_ps(c1, w1));                                \
        P##2 = _mm512_add_ps(P##2, _mm512_mul_ps(c2, w0));                                \
        P##3 = _mm512_add_ps(P##3, _mm512_mul_ps(c3, w1));                                \
        P##4 = _mm512_add_ps(P##4, _mm512_mul_ps(c4, w0));                                \
        P##5 = _mm512_add_ps(P##5, _mm512_mul_ps(c5, w1));                                \
        P##6 = _mm512_add_ps(P##6, w0);                                                   \
        P##7 = _mm512_add_ps(P##7, w1);                                                   \
    } while (0)

/* sa[0..3]: row j's r, g, b and weight sums (zero on entry), sb[0..3] row j + 1's. */
__attribute__((FILM_AVX512)) static void film_span_sums2_avx512(const Film *f, int j, int b0,
                                                                int b1, int b0n, int b1n,
                                                                int p0, int m,
                                                                float *const *sa,
                                                                float *const *sb)
{
    int R = f->R, side = 2 * R + 1, n = f->slots, rows = b1n - b0 + 1;
    size_t cs = f->cs;
    const float *col[FILM_TERMS2], *wxp[FILM_TERMS2], *wya[FILM_TERMS2], *wyb[FILM_TERMS2];
    film_pair_term_lists(f, j, b0, b1, b0n, b1n, p0, col, wxp, wya, wyb);
    int only_a = (b0n - b0) * n, both = (b1 - b0n + 1) * n, per_ta = rows * n;
    for (int q = 0; q < m; q += FILM_BLOCK) {
        __mmask16 m0, m1;
        film_block_masks(m - q, &m0, &m1);
        const __m512 z = _mm512_setzero_ps();
        __m512 A0 = z, A1 = z, A2 = z, A3 = z, A4 = z, A5 = z, A6 = z, A7 = z;
        __m512 B0 = z, B1 = z, B2 = z, B3 = z, B4 = z, B5 = z, B6 = z, B7 = z;
        __m512 c0, c1, c2, c3, c4, c5;
#define FILM_PAIR_PLANE(p, v0, v1)                                                        \
    do {                                                                                  \
        _mm_prefetch((const char *)((p) + FILM_BLOCK), _MM_HINT_T0);                      \
        _mm_prefetch((const char *)((p) + FILM_BLOCK + 16), _MM_HINT_T0);                 \
        v0 = _mm512_maskz_loadu_ps(m0, (p));                                              \
        v1 = _mm512_maskz_loadu_ps(m1, (p) + 16);                                         \
    } while (0)
#define FILM_PAIR_LOAD(k)                                                                 \
    do {                                                                                  \
        const float *cr_ = col[k] + q;                                                    \
        FILM_PAIR_PLANE(cr_, c0, c1);                                                     \
        FILM_PAIR_PLANE(cr_ + cs, c2, c3);                                                \
        FILM_PAIR_PLANE(cr_ + 2 * cs, c4, c5);                                            \
        const float *x_ = wxp[k] + q;                                                     \
        _mm_prefetch((const char *)(x_ + FILM_BLOCK), _MM_HINT_T0);                       \
        _mm_prefetch((const char *)(x_ + FILM_BLOCK + 16), _MM_HINT_T0);                  \
        x0 = _mm512_maskz_loadu_ps(m0, x_);                                               \
        x1 = _mm512_maskz_loadu_ps(m1, x_ + 16);                                          \
    } while (0)
#define FILM_PAIR_W(wy, k, w0, w1)                                                        \
    do {                                                                                  \
        const float *y_ = wy[k] + q;                                                      \
        _mm_prefetch((const char *)(y_ + FILM_BLOCK), _MM_HINT_T0);                       \
        _mm_prefetch((const char *)(y_ + FILM_BLOCK + 16), _MM_HINT_T0);                  \
        w0 = _mm512_mul_ps(x0, _mm512_maskz_loadu_ps(m0, y_));                            \
        w1 = _mm512_mul_ps(x1, _mm512_maskz_loadu_ps(m1, y_ + 16));                       \
    } while (0)
        for (int ta = 0; ta < side; ta++) {
            int t = ta * per_ta, e;
            __m512 x0, x1, u0, u1, v0, v1;
            for (e = t + only_a; t < e; t++) {
                FILM_PAIR_LOAD(t);
                FILM_PAIR_W(wya, t, u0, u1);
                FILM_PAIR_ADD(A, u0, u1);
            }
            for (e = t + both; t < e; t++) {
                FILM_PAIR_LOAD(t);
                FILM_PAIR_W(wya, t, u0, u1);
                FILM_PAIR_W(wyb, t, v0, v1);
                FILM_PAIR_ADD(A, u0, u1);
                FILM_PAIR_ADD(B, v0, v1);
            }
            for (e = (ta + 1) * per_ta; t < e; t++) {
                FILM_PAIR_LOAD(t);
                FILM_PAIR_W(wyb, t, v0, v1);
                FILM_PAIR_ADD(B, v0, v1);
            }
        }
#undef FILM_PAIR_PLANE
#undef FILM_PAIR_LOAD
#undef FILM_PAIR_W
#define FILM_PAIR_STORE(d, v0, v1)                                                        \
    do {                                                                                  \
        _mm512_mask_storeu_ps((d) + q, m0, v0);                                           \
        _mm512_mask_storeu_ps((d) + q + 16, m1, v1);                                      \
    } while (0)
        FILM_PAIR_STORE(sa[0], A0, A1);
        FILM_PAIR_STORE(sa[1], A2, A3);
        FILM_PAIR_STORE(sa[2], A4, A5);
        FILM_PAIR_STORE(sa[3], A6, A7);
        FILM_PAIR_STORE(sb[0], B0, B1);
        FILM_PAIR_STORE(sb[1], B2, B3);
        FILM_PAIR_STORE(sb[2], B4, B5);
        FILM_PAIR_STORE(sb[3], B6, B7);
#undef FILM_PAIR_STORE
    }
}
#undef FILM_PAIR_ADD
#define FILM_HAVE_PAIRS 1
#endif

#ifdef FILM_HAVE_AVX2
/* film_span_sums2_avx512 where the CPU has AVX2: the two rows' terms listed in its
 * order, eight pixels a block (one vector per sum: the two rows' four sums are 8 of
 * the 16 registers, with a term's three colours, its column weight and the two row
 * weights 14), a shared row's colours and column weight loaded once for both rows; each
 * row adds its own terms in film_filter_row's order with film_block8's operations (the
 * weight wx * wy, sum += colour * weight, weight sum += weight; separate multiplies and
 * adds), so the same bits as film_span_sums. The span's last block through masked
 * loads and stores. No prefetches: with them (each plane's next line, as film_block8's)
 * filtering was slower (scene6_01 400x400, jittered 16 + Gaussian 0.4, 15 rounds:
 * 15.8 ms median against 12.9 without). On the Zen 3 host (17a, same settings, 1 thread,
 * perf samples of the sums per sample of octaves_lanes_avx2, 4 runs of each): 0.225
 * with film_span_sums_avx2 one row at a time, 0.200 with these. */
#define FILM_PAIR8_ADD(P, w)                                                              \
    do {                                                                                  \
        P##0 = _mm256_add_ps(P##0, _mm256_mul_ps(c0, w));                                 \
        P##1 = _mm256_add_ps(P##1, _mm256_mul_ps(c1, w));                                 \
        P##2 = _mm256_add_ps(P##2, _mm256_mul_ps(c2, w));                                 \
        P##3 = _mm256_add_ps(P##3, w);                                                    \
    } while (0)

__attribute__((always_inline, target("avx2"))) static inline void
film_pair_block8(const float *const *col, const float *const *wxp, const float *const *wya,
                 const float *const *wyb, int side, int per_ta, int only_a, int both,
                 size_t cs, int q, bool tail, int left, float *const *sa, float *const *sb)
{
    __m256i mk = _mm256_setzero_si256();
    if (tail)
        mk = _mm256_cmpgt_epi32(_mm256_set1_epi32(left),
                                _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7));
#define FILM_LD(p) (tail ? _mm256_maskload_ps((p), mk) : _mm256_loadu_ps(p))
    const __m256 z = _mm256_setzero_ps();
    __m256 A0 = z, A1 = z, A2 = z, A3 = z, B0 = z, B1 = z, B2 = z, B3 = z;
    __m256 c0, c1, c2, x;
#define FILM_PAIR8_LOAD(k)                                                                \
    do {                                                                                  \
        const float *cr_ = col[k] + q, *x_ = wxp[k] + q;                                  \
        c0 = FILM_LD(cr_);                                                                \
        c1 = FILM_LD(cr_ + cs);                                                           \
        c2 = FILM_LD(cr_ + 2 * cs);                                                       \
        x = FILM_LD(x_);                                                                  \
    } while (0)
#define FILM_PAIR8_W(wy, k)                                                               \
    _mm256_mul_ps(x, FILM_LD(wy[k] + q))
    for (int ta = 0; ta < side; ta++) {
        int t = ta * per_ta, e;
        for (e = t + only_a; t < e; t++) {
            FILM_PAIR8_LOAD(t);
            __m256 u = FILM_PAIR8_W(wya, t);
            FILM_PAIR8_ADD(A, u);
        }
        for (e = t + both; t < e; t++) {
            FILM_PAIR8_LOAD(t);
            __m256 u = FILM_PAIR8_W(wya, t);
            __m256 v = FILM_PAIR8_W(wyb, t);
            FILM_PAIR8_ADD(A, u);
            FILM_PAIR8_ADD(B, v);
        }
        for (e = (ta + 1) * per_ta; t < e; t++) {
            FILM_PAIR8_LOAD(t);
            __m256 v = FILM_PAIR8_W(wyb, t);
            FILM_PAIR8_ADD(B, v);
        }
    }
#undef FILM_PAIR8_LOAD
#undef FILM_PAIR8_W
#undef FILM_LD
#define FILM_ST(d, v)                                                                     \
    do {                                                                                  \
        if (tail)                                                                         \
            _mm256_maskstore_ps((d) + q, mk, (v));                                        \
        else                                                                              \
            _mm256_storeu_ps((d) + q, (v));                                               \
    } while (0)
    FILM_ST(sa[0], A0);
    FILM_ST(sa[1], A1);
    FILM_ST(sa[2], A2);
    FILM_ST(sa[3], A3);
    FILM_ST(sb[0], B0);
    FILM_ST(sb[1], B1);
    FILM_ST(sb[2], B2);
    FILM_ST(sb[3], B3);
#undef FILM_ST
}
#undef FILM_PAIR8_ADD

/* sa[0..3]: row j's r, g, b and weight sums, sb[0..3] row j + 1's (written, not added
 * to: every pixel of the span gets all its terms here). */
__attribute__((target("avx2"))) static void film_span_sums2_avx2(const Film *f, int j, int b0,
                                                               int b1, int b0n, int b1n,
                                                               int p0, int m,
                                                               float *const *sa,
                                                               float *const *sb)
{
    int R = f->R, side = 2 * R + 1, n = f->slots, rows = b1n - b0 + 1;
    size_t cs = f->cs;
    const float *col[FILM_TERMS2], *wxp[FILM_TERMS2], *wya[FILM_TERMS2], *wyb[FILM_TERMS2];
    film_pair_term_lists(f, j, b0, b1, b0n, b1n, p0, col, wxp, wya, wyb);
    int only_a = (b0n - b0) * n, both = (b1 - b0n + 1) * n, per_ta = rows * n;
    int q = 0;
    for (; q + 8 <= m; q += 8)
        film_pair_block8(col, wxp, wya, wyb, side, per_ta, only_a, both, cs, q, false, 0, sa,
                         sb);
    if (q < m)
        film_pair_block8(col, wxp, wya, wyb, side, per_ta, only_a, both, cs, q, true, m - q,
                         sa, sb);
}
#define FILM_HAVE_PAIRS 1
#endif

static void film_margin(int x0, int n, int R, int full, int *lo, int *hi);

/* The columns (rows) lo..hi, inclusive, whose samples output column (row) v of an image
 * `full` wide (high) weighs: its support of radius R, cropped at the border. */
static void film_support(int v, int R, int full, int *lo, int *hi)
{
    film_margin(v, 1, R, full, lo, hi);
    --*hi;
}

/* Pixel (i, j) of the rectangle when no sample of its support got a non-zero weight (a
 * box, tent or Mitchell narrower than the gaps between the samples, or a Gaussian whose
 * weights all underflow to 0: sigma 0.02 with uniform 4): the colour (and depth grey,
 * |normal|) of the support's sample nearest the pixel's centre, the first of the
 * nearest in the sums' order (columns, rows, samples), distances from the exact
 * offsets (a - i) + position - 0.5 in double. That is the limit the weighted average
 * tends to as the Gaussian narrows, and a box or tent too narrow to catch a sample
 * asks for the colour at the centre. Before, such pixels were black: half the pixels
 * of a 40 x 40 jittered 4 render with the box 0.2, the whole image of a uniform 4
 * render with the box 0.1 or the Gaussian 0.02. The positions are asked of the
 * sampler again (a pixel's are a function of pixel, index and seed; a refined pixel,
 * with the refining sampler's larger count, of that sampler's): the planes of a
 * separable filter do not keep them (film_tile). Pixels with weight keep their bytes. */
static void film_put_unweighted(const Film *f, int i, int j)
{
    const FilmConfig *c = f->cfg;
    int R = f->R;
    int a0, a1, b0, b1;
    film_support(i, R, c->full_width, &a0, &a1);
    film_support(j, R, c->full_height, &b0, &b1);
    size_t cs = f->cs;
    const float *best = NULL;
    double best_d2 = 0.0;
    float xy[2 * SAMPLER_MAX_COUNT];
    for (int a = a0; a <= a1; a++)
        for (int b = b0; b <= b1; b++) {
            int n = *film_count(f, a, b);
            const Sampler *smp = c->refine && n == c->refine->count ? c->refine : c->sampler;
            if (n != smp->count) /* (never: a pixel holds one sampler's samples) */
                continue;
            sampler_pixel(smp, a, b, xy);
            for (int s = 0; s < n; s++) {
                double dx = (double)(a - i) + (double)xy[2 * s] - 0.5;
                double dy = (double)(b - j) + (double)xy[2 * s + 1] - 0.5;
                double d2 = dx * dx + dy * dy;
                if (!best || d2 < best_d2) {
                    best = film_sample(f, a, b, s);
                    best_d2 = d2;
                }
            }
        }
    int x = i - f->ox, y = j - f->oy;
    if (!best) { /* (never: every pixel of the support holds its samples) */
        if (f->color)
            image_put(f->color, x, y, v3(0, 0, 0));
        return;
    }
    if (f->color)
        image_put(f->color, x, y, v3(best[2 * cs], best[3 * cs], best[4 * cs]));
    /* depth and normals are stored only pixel by pixel (cs = 1: channels side by side) */
    if (f->depth && f->off_depth >= 0) {
        const float *e = best + f->off_depth;
        image_put(f->depth, x, y, v3(e[0], e[1], e[2]));
    }
    if (f->normals && f->off_normal >= 0) {
        const float *e = best + f->off_normal;
        image_put(f->normals, x, y, v3(e[0], e[1], e[2]));
    }
}

#ifdef FILM_HAVE_AVX2
/* film_put_sums' quotients eight pixels at a time (vdivps: correctly rounded, as the
 * scalar divisions); returns the first pixel not done. (A 16-sample Gaussian render
 * puts every pixel through here; its 24 scalar divisions per eight pixels were 9.5M of
 * the filter's instructions at 400x400.) */
__attribute__((target("avx2"))) static int film_put_sums8(const Film *f, int j, int p0,
                                                         int m, const float *sr,
                                                         const float *sg, const float *sb,
                                                         const float *sw)
{
    int q = 0;
    for (; q + 8 <= m; q += 8) {
        __m256 w = _mm256_loadu_ps(sw + q);
        float qr[8], qg[8], qb[8];
        _mm256_storeu_ps(qr, _mm256_div_ps(_mm256_loadu_ps(sr + q), w));
        _mm256_storeu_ps(qg, _mm256_div_ps(_mm256_loadu_ps(sg + q), w));
        _mm256_storeu_ps(qb, _mm256_div_ps(_mm256_loadu_ps(sb + q), w));
        for (int k = 0; k < 8; k++)
            if (sw[q + k] != 0.0f)
                image_put(f->color, p0 + q + k - f->ox, j - f->oy, v3(qr[k], qg[k], qb[k]));
            else
                film_put_unweighted(f, p0 + q + k, j);
    }
    return q;
}
#endif

/* Output pixels p0 .. p0+m-1 of row j from their sums: colour over weight (where no
 * weight reached the pixel, film_put_unweighted). */
static void film_put_sums(const Film *f, int j, int p0, int m, const float *sr,
                          const float *sg, const float *sb, const float *sw)
{
    if (!f->color)
        return;
    int q = 0;
#ifdef FILM_HAVE_AVX2
    if (f->avx2)
        q = film_put_sums8(f, j, p0, m, sr, sg, sb, sw);
#endif
    for (; q < m; q++) {
        float w = sw[q];
        if (w != 0.0f)
            image_put(f->color, p0 + q - f->ox, j - f->oy,
                      v3(sr[q] / w, sg[q] / w, sb[q] / w));
        else
            film_put_unweighted(f, p0 + q, j);
    }
}

/* The output columns [*in0, *in1) of the rectangle whose supports lie inside the
 * image (the spans film_filter_span sums; empty when *in1 <= *in0). */
static void film_span_cols(const Film *f, int *in0, int *in1)
{
    const FilmConfig *c = f->cfg;
    int R = f->R;
    *in0 = c->x0 > R ? c->x0 : R;
    *in1 = c->x0 + c->width < c->full_width - R ? c->x0 + c->width : c->full_width - R;
}

static void film_filter_span(const Film *f, int j, int b0, int b1, int i0, int i1)
{
    float sr[FILM_SPAN], sg[FILM_SPAN], sb[FILM_SPAN], sw[FILM_SPAN];
    for (int p0 = i0; p0 < i1; p0 += FILM_SPAN) {
        int m = i1 - p0 < FILM_SPAN ? i1 - p0 : FILM_SPAN;
        memset(sr, 0, sizeof sr);
        memset(sg, 0, sizeof sg);
        memset(sb, 0, sizeof sb);
        memset(sw, 0, sizeof sw);
#ifdef FILM_HAVE_AVX512
        if (f->avx512)
            film_span_sums_avx512(f, j, b0, b1, p0, m, sr, sg, sb, sw);
        else
#endif
#ifdef FILM_HAVE_AVX2
        if (f->avx2)
            film_span_sums_avx2(f, j, b0, b1, p0, m, sr, sg, sb, sw);
        else
#endif
            film_span_sums(f, j, b0, b1, p0, m, sr, sg, sb, sw);
        film_put_sums(f, j, p0, m, sr, sg, sb, sw);
    }
}

#ifdef FILM_HAVE_PAIRS
/* Output rows j and j + 1 (j + 1 < the image height), pixels i0 .. i1-1 of each, as
 * film_filter_span does each row (film_span_sums2_avx512; more terms than it lists:
 * one row at a time). */
static void film_filter_span2(const Film *f, int j, int i0, int i1)
{
    const FilmConfig *c = f->cfg;
    int R = f->R, last = c->full_height - 1;
    int b0 = j - R > 0 ? j - R : 0, b1 = j + R < last ? j + R : last;
    int b0n = j + 1 - R > 0 ? j + 1 - R : 0, b1n = j + 1 + R < last ? j + 1 + R : last;
    if (film_pair_terms(f, b0, b1n) > FILM_TERMS2) {
        film_filter_span(f, j, b0, b1, i0, i1);
        film_filter_span(f, j + 1, b0n, b1n, i0, i1);
        return;
    }
    float sums[8][FILM_SPAN];
    float *const sa[4] = {sums[0], sums[1], sums[2], sums[3]};
    float *const sb[4] = {sums[4], sums[5], sums[6], sums[7]};
    for (int p0 = i0; p0 < i1; p0 += FILM_SPAN) {
        int m = i1 - p0 < FILM_SPAN ? i1 - p0 : FILM_SPAN;
#ifdef FILM_HAVE_AVX512
        if (f->avx512)
            film_span_sums2_avx512(f, j, b0, b1, b0n, b1n, p0, m, sa, sb);
        else
#endif
            film_span_sums2_avx2(f, j, b0, b1, b0n, b1n, p0, m, sa, sb);
        film_put_sums(f, j, p0, m, sa[0], sa[1], sa[2], sa[3]);
        film_put_sums(f, j + 1, p0, m, sb[0], sb[1], sb[2], sb[3]);
    }
}
#endif

/* Output pixels i0 .. i1-1 of row j when each is the box-weighted average of its own
 * random-position samples only (R = 0, colour only, pixel by pixel: jittered or random
 * samples with the box 0.5), the box compared in float as box_weight does, written out
 * (no call per sample). FILM_OWN pixels at a time in the lanes of a vector, each lane
 * adding its own pixel's terms in film_filter_row's order with the same float
 * operations, so the same bits (17a 400x400, jittered 16: filtering 9.0 -> 5.2 ms).
 * The fixed weights' table (uniform) stays in film_filter_row's loop: four pixels at
 * a time were slower there (3.3 -> 4.2 ms). Returns the first pixel not done (pixels
 * with another count than the sampler's go to film_filter_row's loop). */
enum { FILM_OWN = 4 };

static int film_filter_own(const Film *f, int j, int i0, int i1)
{
    const FilmConfig *c = f->cfg;
    if (f->table || !filter_is_box(c->filter))
        return i0;
    const float r = c->filter->r;
    const int n = f->slots;
    const size_t ss = f->ss;
    int i = i0;
    for (; i + FILM_OWN <= i1; i += FILM_OWN) {
        const float *d0 = film_sample(f, i, j, 0), *d1 = film_sample(f, i + 1, j, 0);
        const float *d2 = film_sample(f, i + 2, j, 0), *d3 = film_sample(f, i + 3, j, 0);
        bool full = true;
        for (int k = 0; k < FILM_OWN; k++)
            full &= *film_count(f, i + k, j) == n;
        if (!full)
            break;
        /* Lane k: pixel i + k (lane-wise IEEE operations: each lane is the scalar sum). */
        FilmV4f sr = {0, 0, 0, 0}, sg = sr, sb = sr, sw = sr;
        const FilmV4f one = {1.0f, 1.0f, 1.0f, 1.0f}, rr = {r, r, r, r};
        for (int s = 0; s < n; s++, d0 += ss, d1 += ss, d2 += ss, d3 += ss) {
            /* film_filter_row's random-position case with a = i, b = j */
            const double da = 0.0, db = 0.0;
            FilmV4f dx = {(float)(da + (double)d0[0] - 0.5), (float)(da + (double)d1[0] - 0.5),
                          (float)(da + (double)d2[0] - 0.5), (float)(da + (double)d3[0] - 0.5)};
            FilmV4f dy = {(float)(db + (double)d0[1] - 0.5), (float)(db + (double)d1[1] - 0.5),
                          (float)(db + (double)d2[1] - 0.5), (float)(db + (double)d3[1] - 0.5)};
            FilmV4f ax = {fabsf(dx[0]), fabsf(dx[1]), fabsf(dx[2]), fabsf(dx[3])};
            FilmV4f ay = {fabsf(dy[0]), fabsf(dy[1]), fabsf(dy[2]), fabsf(dy[3])};
            FilmV4i in = (ax <= rr) & (ay <= rr);
            FilmV4f w = (FilmV4f)((FilmV4i)one & in); /* 1.0f or +0.0f, as box_weight */
            FilmV4f vr = {d0[2], d1[2], d2[2], d3[2]};
            FilmV4f vg = {d0[3], d1[3], d2[3], d3[3]};
            FilmV4f vb = {d0[4], d1[4], d2[4], d3[4]};
            sr += vr * w;
            sg += vg * w;
            sb += vb * w;
            sw += w;
        }
        if (f->color)
            for (int k = 0; k < FILM_OWN; k++) {
                float w = sw[k];
                if (w != 0.0f)
                    image_put(f->color, i + k - f->ox, j - f->oy,
                              v3(sr[k] / w, sg[k] / w, sb[k] / w));
                else
                    film_put_unweighted(f, i + k, j);
            }
    }
    return i;
}

#ifdef FILM_HAVE_AVX2
/* film_filter_own's pixels, and the fixed weights' (uniform sampling, R = 0: weight
 * table[s] for sample s of every pixel, film_filter_line's table loop), eight at a time
 * where the CPU has AVX2: lane k adds pixel i + k's terms in film_filter_row's order
 * with the same IEEE single operations (separate multiplies and adds: -ffp-contract=off
 * and intrinsics), the box's offsets (0 + position) - 0.5 in double rounded to float
 * once and compared in float, as film_filter_own's: the same bits. A pixel's samples
 * lie side by side (five floats each, the eight pixels xs floats apart), so they are
 * read by 8 x 8 transposes (film_copy_row8's, eight floats of the eight pixels at a
 * time) into a block of vectors, vector 5 s + c holding channel c of sample s of all
 * eight: the 4-lane loop built each lane's vector from scalars (17a 400x400, 16
 * samples, 1 thread: filtering 6.3-7.6 ms uniform, 8.7-9.5 jittered + box before).
 * Returns the first pixel not done (blocks with another count than the sampler's, the
 * last pixels, more than FILM_OWN8_MAX samples: the callers' loops). */
enum { FILM_OWN8_MAX = 64 };

__attribute__((target("avx2"))) static int film_filter_own8(const Film *f, int j, int i0,
                                                          int i1)
{
    const FilmConfig *c = f->cfg;
    const int n = f->slots, floats = 5 * n;
    const bool box = !f->table;
    if (n > FILM_OWN8_MAX || f->stride != 5 || (box && !filter_is_box(c->filter)))
        return i0;
    const float *table = f->table; /* R = 0: sample s's weight is table[s] */
    const size_t xs = f->xs;
    const __m256 rr = _mm256_set1_ps(c->filter->r), one = _mm256_set1_ps(1.0f);
    const __m256 sign = _mm256_set1_ps(-0.0f);
    const __m256d zero = _mm256_setzero_pd(), half = _mm256_set1_pd(0.5);
    __attribute__((aligned(32))) float v[5 * FILM_OWN8_MAX][8];
    int i = i0;
    for (; i + 8 <= i1; i += 8) {
        bool full = true;
        for (int k = 0; k < 8; k++)
            full &= *film_count(f, i + k, j) == n;
        if (!full)
            break;
        const float *src = film_sample(f, i, j, 0); /* pixel i + p at src + p xs */
        int k = 0;
        for (; k + 8 <= floats; k += 8) {
            __m256 w[8];
            film_transpose8(src + k, xs, w); /* float k + m of pixels 0..7 in w[m] */
            for (int m = 0; m < 8; m++)
                _mm256_store_ps(v[k + m], w[m]);
        }
        for (; k < floats; k++)
            for (int p = 0; p < 8; p++)
                v[k][p] = src[(size_t)p * xs + (size_t)k];
        __m256 sr = _mm256_setzero_ps(), sg = sr, sb = sr, sw = sr;
        for (int s = 0; s < n; s++) {
            const float(*d)[8] = v + 5 * s;
            __m256 w;
            if (box) {
                /* film_filter_own's (float)(da + (double)d[0] - 0.5) with da = 0 */
                __m256 px = _mm256_load_ps(d[0]), py = _mm256_load_ps(d[1]);
#define FILM_OWN8_OFF(q)                                                                   \
    _mm256_set_m128(                                                                       \
        _mm256_cvtpd_ps(_mm256_sub_pd(_mm256_add_pd(zero, _mm256_cvtps_pd(_mm256_extractf128_ps(q, 1))), half)), \
        _mm256_cvtpd_ps(_mm256_sub_pd(_mm256_add_pd(zero, _mm256_cvtps_pd(_mm256_castps256_ps128(q))), half)))
                __m256 ax = _mm256_andnot_ps(sign, FILM_OWN8_OFF(px));
                __m256 ay = _mm256_andnot_ps(sign, FILM_OWN8_OFF(py));
#undef FILM_OWN8_OFF
                __m256 in = _mm256_and_ps(_mm256_cmp_ps(ax, rr, _CMP_LE_OQ),
                                          _mm256_cmp_ps(ay, rr, _CMP_LE_OQ));
                w = _mm256_and_ps(one, in); /* 1.0f or +0.0f, as box_weight */
            } else {
                w = _mm256_set1_ps(table[s]);
            }
            sr = _mm256_add_ps(sr, _mm256_mul_ps(_mm256_load_ps(d[2]), w));
            sg = _mm256_add_ps(sg, _mm256_mul_ps(_mm256_load_ps(d[3]), w));
            sb = _mm256_add_ps(sb, _mm256_mul_ps(_mm256_load_ps(d[4]), w));
            sw = _mm256_add_ps(sw, w);
        }
        if (f->color) {
            /* colour over weight, correctly rounded as the scalar divisions;
             * film_put_unweighted where no weight reached the pixel */
            float qr[8], qg[8], qb[8], ws[8];
            _mm256_storeu_ps(qr, _mm256_div_ps(sr, sw));
            _mm256_storeu_ps(qg, _mm256_div_ps(sg, sw));
            _mm256_storeu_ps(qb, _mm256_div_ps(sb, sw));
            _mm256_storeu_ps(ws, sw);
            for (int q = 0; q < 8; q++)
                if (ws[q] != 0.0f)
                    image_put(f->color, i + q - f->ox, j - f->oy,
                              v3(qr[q], qg[q], qb[q]));
                else
                    film_put_unweighted(f, i + q, j);
        }
    }
    return i;
}
#endif

/* The weight sum of an output pixel over the sum of its weights' magnitudes (rho),
 * below which a filter with negative lobes is not trusted there (film_fix_lobes). The
 * normalised colour can lie beyond the range of its samples' colours by at most
 * (1 - rho) / (2 rho) of that range: densely sampled, Mitchell's rho is 0.87 (its
 * negative lobes weigh 6.8% of its positive part, in 2-D), at most 7%; at 0.7, 21%.
 * With one sample per pixel a pixel's few samples can put most of the weight in the
 * negative lobes: rho near 0 blows the colour up, a negative rho turns it over (at
 * radius 1, 7% of the course's checkerboard pixels were more than a quarter of the
 * range beyond their samples; none are now: bench/REPORT.txt, polish31). */
#define FILM_LOBE_TRUST 0.7f

/* Whether a pixel whose weights sum to sum, pos of it from the positive ones, is
 * trusted: rho = sum / (sum of magnitudes) = sum / (2 pos - sum) >= FILM_LOBE_TRUST.
 * No weight at all (both 0: film_put_unweighted's pixel) counts as trusted. */
static inline bool film_lobes_trusted(float pos, float sum)
{
    return sum >= FILM_LOBE_TRUST * (2.0f * pos - sum);
}

/* The weight sums of output pixel (i, j) (film_lobes_trusted's pos and sum): terms in
 * the order film_lobe_sums4 adds them (columns, rows, samples), each weight as the
 * filter loops make it (film_weight, times the adaptive share). */
static void film_lobe_sums(const Film *f, int i, int j, float *pos_out, float *sum_out)
{
    const FilmConfig *c = f->cfg;
    int R = f->R;
    int a0, a1, b0, b1;
    film_support(i, R, c->full_width, &a0, &a1);
    film_support(j, R, c->full_height, &b0, &b1);
    bool adaptive = c->refine != NULL;
    float pos = 0.0f, sum = 0.0f;
    for (int a = a0; a <= a1; a++)
        for (int b = b0; b <= b1; b++) {
            int n = *film_count(f, a, b);
            const float *d = film_sample(f, a, b, 0);
            float share = adaptive ? 1.0f / (float)n : 1.0f;
            for (int s = 0; s < n; s++, d += f->ss) {
                float w = film_weight(f, d, a, b, i, j, s) * share;
                if (w > 0.0f)
                    pos += w;
                sum += w;
            }
        }
    *pos_out = pos;
    *sum_out = sum;
}

/* film_lobe_sums of the four pixels i .. i+3 of row j at once, each in its own lane
 * (the same terms in the same order, the same float operations, so the same bits):
 * planes with separable weights (every pixel with the sampler's count), the four
 * supports' columns inside the image. Their weights towards a column offset lie side
 * by side, as the spans' sums read them. */
static void film_lobe_sums4(const Film *f, int i, int j, float pos_out[4], float sum_out[4])
{
    const FilmConfig *c = f->cfg;
    int R = f->R, n = c->sampler->count, b0, b1;
    film_support(j, R, c->full_height, &b0, &b1);
    const FilmV4f zero = {0.0f, 0.0f, 0.0f, 0.0f};
    FilmV4f pos = zero, sum = zero;
    for (int da = -R; da <= R; da++)
        for (int b = b0; b <= b1; b++) {
            const float *wx = film_weights(f, i + da, b, 0, da + R);
            const float *wy = film_weights(f, i + da, b, 0, 2 * R + 1 + b - j + R);
            for (int s = 0; s < n; s++, wx += f->ws, wy += f->ws) {
                FilmV4f x, y;
                memcpy(&x, wx, sizeof x);
                memcpy(&y, wy, sizeof y);
                FilmV4f w = x * y;
                pos += (FilmV4f)((FilmV4i)w & (w > zero)); /* w where positive, else +0 */
                sum += w;
            }
        }
    memcpy(pos_out, &pos, sizeof pos);
    memcpy(sum_out, &sum, sizeof sum);
}

/* Output pixel (i, j) from its samples weighted by the filter's positive part only
 * (max(w, 0), the same weights as film_lobe_sums), whose sum is pos > 0. */
static void film_put_positive_part(const Film *f, int i, int j, float pos)
{
    const FilmConfig *c = f->cfg;
    int R = f->R;
    int a0, a1, b0, b1;
    film_support(i, R, c->full_width, &a0, &a1);
    film_support(j, R, c->full_height, &b0, &b1);
    bool adaptive = c->refine != NULL;
    size_t cs = f->cs;
    Vec3 sum = v3(0, 0, 0), sum_d = v3(0, 0, 0), sum_n = v3(0, 0, 0);
    for (int a = a0; a <= a1; a++)
        for (int b = b0; b <= b1; b++) {
            int n = *film_count(f, a, b);
            const float *d = film_sample(f, a, b, 0);
            float share = adaptive ? 1.0f / (float)n : 1.0f;
            for (int s = 0; s < n; s++, d += f->ss) {
                float w = film_weight(f, d, a, b, i, j, s) * share;
                if (!(w > 0.0f))
                    continue;
                sum = v3_add(sum, v3_scale(v3(d[2 * cs], d[3 * cs], d[4 * cs]), w));
                /* depth and normals are stored only pixel by pixel (cs = 1) */
                if (f->off_depth >= 0) {
                    const float *e = d + f->off_depth;
                    sum_d = v3_add(sum_d, v3_scale(v3(e[0], e[1], e[2]), w));
                }
                if (f->off_normal >= 0) {
                    const float *e = d + f->off_normal;
                    sum_n = v3_add(sum_n, v3_scale(v3(e[0], e[1], e[2]), w));
                }
            }
        }
    /* pos is the sum of these weights, added in the same order, so a constant channel
     * comes out exactly (a reciprocal's product was one byte low). */
    int x = i - f->ox, y = j - f->oy;
    if (f->color)
        image_put(f->color, x, y, v3(sum.x / pos, sum.y / pos, sum.z / pos));
    if (f->depth && f->off_depth >= 0)
        image_put(f->depth, x, y, v3(sum_d.x / pos, sum_d.y / pos, sum_d.z / pos));
    if (f->normals && f->off_normal >= 0)
        image_put(f->normals, x, y, v3(sum_n.x / pos, sum_n.y / pos, sum_n.z / pos));
}

/* Output pixels of row j from the moments (Film.mom): pixel i's sums are those of the
 * pixels of its support, columns outer and rows inner, each added whole (film_mom's
 * plane towards i, j), from zero; then colour over weight. Eight pixels whose support
 * the image does not cut at a time in the lanes of a vector, each lane adding its
 * pixel's terms in that order with the same IEEE single operations as the one-pixel
 * loop, and dividing as it does (correctly rounded): the same bits. The weight is never
 * 0 (film_moments_cfg). */
#define FILM_MOMENTS_PUT8(NAME, ...)                                                       \
    __attribute__((__VA_ARGS__)) static void NAME(const Film *f, int i, int j, int b0,     \
                                                  int b1)                                   \
    {                                                                                      \
        int R = f->R, side = 2 * R + 1;                                                    \
        size_t pw = (size_t)f->pw;                                                         \
        FilmV8f z = {0}, sr = z, sg = z, sb = z, sw = z;                                   \
        for (int ta = 0; ta < side; ta++)                                                  \
            for (int b = b0; b <= b1; b++) {                                               \
                const float *m = film_mom(f, i - R + ta, b, 4 * (ta * side + b - j + R));  \
                sr += FILM_V8(m);                                                          \
                sg += FILM_V8(m + pw);                                                     \
                sb += FILM_V8(m + 2 * pw);                                                 \
                sw += FILM_V8(m + 3 * pw);                                                 \
            }                                                                              \
        sr /= sw, sg /= sw, sb /= sw;                                                      \
        for (int k = 0; k < 8; k++)                                                        \
            image_put(f->color, i + k - f->ox, j - f->oy, v3(sr[k], sg[k], sb[k]));        \
    }

FILM_MOMENTS_PUT8(film_moments_put8, unused)
#ifdef FILM_HAVE_MOMENTS_AVX2
FILM_MOMENTS_PUT8(film_moments_put8_avx2, target("avx2"))
#endif

static void film_filter_moments(const Film *f, int j)
{
    const FilmConfig *c = f->cfg;
    if (!f->color)
        return;
    int R = f->R, side = 2 * R + 1, b0, b1, in0, in1;
    size_t pw = (size_t)f->pw;
    film_support(j, R, c->full_height, &b0, &b1);
    film_span_cols(f, &in0, &in1);
    for (int i = c->x0; i < c->x0 + c->width;) {
        if (i >= in0 && i + 8 <= in1) {
#ifdef FILM_HAVE_MOMENTS_AVX2
            if (f->avx2)
                film_moments_put8_avx2(f, i, j, b0, b1);
            else
#endif
                film_moments_put8(f, i, j, b0, b1);
            i += 8;
            continue;
        }
        int a0, a1;
        film_support(i, R, c->full_width, &a0, &a1);
        float sr = 0.0f, sg = 0.0f, sb = 0.0f, sw = 0.0f;
        for (int a = a0; a <= a1; a++)
            for (int b = b0; b <= b1; b++) {
                const float *m = film_mom(f, a, b, 4 * ((a - i + R) * side + b - j + R));
                sr += m[0];
                sg += m[pw];
                sb += m[2 * pw];
                sw += m[3 * pw];
            }
        image_put(f->color, i - f->ox, j - f->oy, v3(sr / sw, sg / sw, sb / sw));
        i++;
    }
}

/* Output row (out0 + job) of the rectangle: every pixel is the weighted average of the
 * samples of its support (cropped at the image border), columns outer, rows inner,
 * samples innermost, in float, divided by the sum of the weights used. */
static void film_filter_line(const Film *f, int j, bool span)
{
    const FilmConfig *c = f->cfg;
    if (f->mom) {
        film_filter_moments(f, j);
        return;
    }
    int R = f->R;
    int b0, b1;
    film_support(j, R, c->full_height, &b0, &b1);
    bool adaptive = c->refine != NULL;
    /* The colour-only case without adaptive shares has its own loops (the common one,
     * and most of the filtering time); both paths add the same terms in the same order. */
    bool plain = !adaptive && f->off_depth < 0 && f->off_normal < 0;
    size_t ss = f->ss, cs = f->cs;
    /* The span of output pixels film_filter_span sums (none: in0 = in1 = -1). */
    int in0 = -1, in1 = -1;
    if (plain && f->planes && (f->per || f->table)) {
        film_span_cols(f, &in0, &in1);
    }
    int first = c->x0;
    if (plain && R == 0 && !f->planes && !f->per) {
#ifdef FILM_HAVE_AVX2
        if (f->avx2) /* the box's own pixels, or the table's: eight at a time */
            first = film_filter_own8(f, j, first, c->x0 + c->width);
#endif
        first = film_filter_own(f, j, first, c->x0 + c->width); /* the box's own pixels */
    }
    for (int i = first; i < c->x0 + c->width; i++) {
        if (i == in0 && in1 > in0) {
            if (span) /* else the caller's (film_filter_pair) */
                film_filter_span(f, j, b0, b1, in0, in1);
            i = in1 - 1;
            continue;
        }
        int a0, a1;
        film_support(i, R, c->full_width, &a0, &a1);
        Vec3 sum = v3(0, 0, 0), sum_d = v3(0, 0, 0), sum_n = v3(0, 0, 0);
        float wsum = 0.0f, wpos = 0.0f; /* wpos: the general loop's positive weights */
        for (int a = a0; a <= a1; a++)
            for (int b = b0; b <= b1; b++) {
                int n = *film_count(f, a, b);
                const float *d = film_sample(f, a, b, 0);
                if (plain && f->per) {
                    const float *wx = film_weights(f, a, b, 0, a - i + R);
                    const float *wy = film_weights(f, a, b, 0, 2 * R + 1 + b - j + R);
                    for (int s = 0; s < n; s++, d += ss, wx += f->ws, wy += f->ws) {
                        float w = *wx * *wy;
                        sum.x += d[2 * cs] * w;
                        sum.y += d[3 * cs] * w;
                        sum.z += d[4 * cs] * w;
                        wsum += w;
                    }
                    continue;
                }
                if (plain && f->table) {
                    const float *t = f->table + ((a - i + R) * (2 * R + 1) + (b - j + R)) * f->slots;
                    for (int s = 0; s < n; s++, d += ss) {
                        float w = t[s];
                        sum.x += d[2 * cs] * w;
                        sum.y += d[3 * cs] * w;
                        sum.z += d[4 * cs] * w;
                        wsum += w;
                    }
                    continue;
                }
                if (plain) {
                    /* Random positions without precomputed weights (jittered + box
                     * 0.5): film_weight's last case, without its other cases' tests
                     * and the general loop's per-sample channel tests. Not planes. */
                    const Filter *flt = c->filter;
                    double da = (double)(a - i), db = (double)(b - j);
                    for (int s = 0; s < n; s++, d += ss) {
                        float dx = (float)(da + (double)d[0] - 0.5);
                        float dy = (float)(db + (double)d[1] - 0.5);
                        float w = filter_weight(flt, dx, dy);
                        sum.x += d[2] * w;
                        sum.y += d[3] * w;
                        sum.z += d[4] * w;
                        wsum += w;
                    }
                    continue;
                }
                /* The general loop: never planes (film_render), so a sample's channels
                 * lie side by side. Adaptive: each pixel weighs as one pixel's area,
                 * however many samples. */
                float share = adaptive ? 1.0f / (float)n : 1.0f;
                /* With moments each pixel's own sums from zero, then added whole (the
                 * order of film_tile_moments and film_filter_moments). */
                Vec3 ps = v3(0, 0, 0), pd = ps, pn = ps;
                float pws = 0.0f;
                Vec3 *S = f->moments ? &ps : &sum, *SD = f->moments ? &pd : &sum_d;
                Vec3 *SN = f->moments ? &pn : &sum_n;
                float *WS = f->moments ? &pws : &wsum;
                for (int s = 0; s < n; s++, d += ss) {
                    float w = film_weight(f, d, a, b, i, j, s);
                    if (adaptive)
                        w *= share;
                    if (w > 0.0f)
                        wpos += w;
                    *S = v3_add(*S, v3_scale(v3(d[2], d[3], d[4]), w));
                    if (f->off_depth >= 0) {
                        const float *e = d + f->off_depth;
                        *SD = v3_add(*SD, v3_scale(v3(e[0], e[1], e[2]), w));
                    }
                    if (f->off_normal >= 0) {
                        const float *e = d + f->off_normal;
                        *SN = v3_add(*SN, v3_scale(v3(e[0], e[1], e[2]), w));
                    }
                    *WS += w;
                }
                if (f->moments) {
                    ps = v3(film_finite_sum(ps.x), film_finite_sum(ps.y), film_finite_sum(ps.z));
                    sum = v3_add(sum, ps);
                    sum_d = v3_add(sum_d, pd);
                    sum_n = v3_add(sum_n, pn);
                    wsum += pws;
                }
            }
        int x = i - f->ox, y = j - f->oy;
        /* No weight at all (a filter whose support misses every sample): the nearest
         * sample's values. */
        if (wsum == 0.0f) {
            film_put_unweighted(f, i, j);
            continue;
        }
        /* Negative lobes not outweighed (film_fix_lobes, which does the plain case's
         * pixels after the row): wpos and wsum are film_lobe_sums' sums. */
        if (f->lobes && !plain && !film_lobes_trusted(wpos, wsum)) {
            if (wpos > 0.0f)
                film_put_positive_part(f, i, j, wpos);
            else
                film_put_unweighted(f, i, j);
            continue;
        }
        if (f->color)
            image_put(f->color, x, y, v3(sum.x / wsum, sum.y / wsum, sum.z / wsum));
        if (f->depth)
            image_put(f->depth, x, y, v3(sum_d.x / wsum, sum_d.y / wsum, sum_d.z / wsum));
        if (f->normals)
            image_put(f->normals, x, y, v3(sum_n.x / wsum, sum_n.y / wsum, sum_n.z / wsum));
    }
}

/* Output row j again where the filter has negative lobes: a pixel whose weight sum is
 * not clearly positive (rho < FILM_LOBE_TRUST) gets the average of the same samples
 * weighted by the filter's positive part only (film_put_positive_part: its central
 * lobe, a positive filter, so the colour stays between the samples'), or the nearest
 * sample's values when no sample lies in that lobe (film_put_unweighted). The other
 * pixels keep what the filter loops stored. With 16 samples per pixel and radius 1.5
 * or more no pixel falls back. The same weights as the loops (film_weight), summed in
 * one order by every path, so the same result for any -threads, -tile or strip. The
 * fixed offsets' weights (uniform) are the same in every pixel whose support the image
 * does not cut: judged once (lobes_inside_ok), and only the border pixels one by one. */
static void film_fix_lobes(const Film *f, int j)
{
    const FilmConfig *c = f->cfg;
    if (c->refine || f->off_depth >= 0 || f->off_normal >= 0)
        return; /* film_filter_line's general loop judged its pixels as it summed them */
    int R = f->R;
    bool rows_inside = j - R >= 0 && j + R <= c->full_height - 1;
    bool fours = f->planes && f->per; /* (rows cut at the border alike in every lane) */
    for (int i = c->x0; i < c->x0 + c->width;) {
        float pos[4], sum[4];
        int m = 1;
        bool inside = rows_inside && i - R >= 0 && i + R <= c->full_width - 1;
        if (f->table && inside && f->lobes_inside_ok) {
            i++;
            continue;
        }
        if (fours && i - R >= 0 && i + 3 + R <= c->full_width - 1 &&
            i + 3 < c->x0 + c->width) {
            film_lobe_sums4(f, i, j, pos, sum);
            m = 4;
        } else {
            film_lobe_sums(f, i, j, &pos[0], &sum[0]);
        }
        for (int k = 0; k < m; k++) {
            if (film_lobes_trusted(pos[k], sum[k]))
                continue;
            if (pos[k] > 0.0f)
                film_put_positive_part(f, i + k, j, pos[k]);
            else
                film_put_unweighted(f, i + k, j);
        }
        i += m;
    }
}

static void film_filter_row(void *user, RenderCtx *ctx, int job)
{
    (void)ctx;
    const Film *f = user;
    film_filter_line(f, f->out0 + job, true);
    if (f->lobes)
        film_fix_lobes(f, f->out0 + job);
}

/* Output rows out0 + 2 job and the next (when the strip has it), their spans together
 * (film_filter_span2), their other pixels by film_filter_line. f->pairs only: the
 * span's case (colour only, planes, separable weights) on a CPU with AVX2 or AVX-512. */
static void film_filter_pair(void *user, RenderCtx *ctx, int job)
{
    (void)ctx;
    const Film *f = user;
    int j = f->out0 + 2 * job;
#ifdef FILM_HAVE_PAIRS
    int in0, in1;
    film_span_cols(f, &in0, &in1);
    if (j + 1 < f->out1 && in1 > in0) {
        film_filter_line(f, j, false);
        film_filter_line(f, j + 1, false);
        film_filter_span2(f, j, in0, in1);
    } else
#endif
    {
        film_filter_line(f, j, true);
        if (j + 1 < f->out1)
            film_filter_line(f, j + 1, true);
    }
    if (f->lobes) {
        film_fix_lobes(f, j);
        if (j + 1 < f->out1)
            film_fix_lobes(f, j + 1);
    }
}

/* The floats from one plane row to the next (data in planes, weights) for rows of fw
 * floats: fw, or from 4 KB on a multiple of 16 floats whose distance to a multiple of
 * 4 KB (1024 floats) is at least 256 bytes. The AVX-512 sums read a block of 32
 * columns of every term's planes (hundreds of rows) before the next block: rows a
 * multiple of 4 KB apart, give or take a few floats (widths 1024, 2048, 4096: fw =
 * width + 2R), fall into a few cache sets: the Gaussian 0.4's filtering took 1.3-1.7
 * times the AVX2 sums' (bench/REPORT.txt, review19; padded, 0.6-0.9 times: 36 samples
 * at 1024 x 64, 20.8 ms -> 9.3; 64 samples at 2048 x 32, 54 -> 24). Only columns
 * sx0 .. sx1-1 of a row are read or written. */
static int film_plane_width(int fw)
{
    if (fw < 1024)
        return fw;
    int pw = (fw + 15) & ~15, r = pw % 1024;
    if (r < 64)
        pw += 64 - r;
    else if (r > 1024 - 64)
        pw += 1024 - r + 64;
    return pw;
}

/* The traced columns or rows [lo, hi) of a span [x0, x0 + n) of an image of `full`. */
static void film_margin(int x0, int n, int R, int full, int *lo, int *hi)
{
    *lo = x0 - R > 0 ? x0 - R : 0;
    *hi = x0 + n + R < full ? x0 + n + R : full;
}

/* Whether an output (FILM_COLOR, FILM_DEPTH or FILM_NORMALS) is asked for: as a whole
 * image or strip by strip. */
static bool film_wants(const FilmConfig *c, unsigned which)
{
    const Image *whole = which == FILM_DEPTH ? c->depth : which == FILM_NORMALS ? c->normals
                                                                                : c->color;
    return whole || (c->rows && (c->rows_wanted & which));
}

static bool film_check(const FilmConfig *c)
{
    if (c->rows && (c->color || c->depth || c->normals || c->samples || !c->rows_wanted ||
                    (c->rows_wanted & ~(unsigned)(FILM_COLOR | FILM_DEPTH | FILM_NORMALS))))
        return false;
    return c->sampler && c->filter && c->full_width > 0 && c->full_height > 0 &&
           c->x0 >= 0 && c->y0 >= 0 && c->width > 0 && c->height > 0 &&
           c->x0 + c->width <= c->full_width && c->y0 + c->height <= c->full_height &&
           (!c->refine || c->refine->count >= 1) && (!c->samples || c->samples_zoom >= 1);
}

/* Whether cfg's film sums by moments (Film.moments), never with adaptive refinement:
 * random or jittered positions with a separable filter that reaches the pixels around
 * (R > 0) and has no negative lobes, whose weight towards a pixel's own samples cannot
 * be 0; or, with any sampler, the box 0.5 (R = 0), which weighs every sample of its
 * pixel 1 (|position - 0.5| <= 0.5 on each axis), so a pixel's one moment is the plain
 * sum of its samples in order, the bits film_filter_own8 and the table's loop give.
 * Every output pixel then has weight from its own samples, so film_put_unweighted
 * (which reads the samples themselves, not kept with moments) is never needed. A
 * pixel's own samples lie within 0.5 of its centre on each axis, and these filters
 * (box, Gaussian) do not grow with the distance, so their least weight there is at
 * +-0.5; the margin keeps a product of two weights a normal float by far. */
static bool film_moments_cfg(const FilmConfig *cfg)
{
    const Filter *flt = cfg->filter;
    if (cfg->refine)
        return false;
    /* Only where the moments are at most a third of the floats they replace (a sample's
     * five and its 2(2R+1) weights): with few samples and a wide support the moments
     * cost more than the samples (17a 400x400, one thread, 5 paired rounds: jittered 4
     * with the Gaussian 2.0 73 -> 100 ms, 4 with 0.4 54.6 -> 57.3, 16 with 1.0 197 ->
     * 201; jittered 9 with 0.4, at 2.75 times, 113 either way; 25 with 1.0, at 3.75
     * times, 350 -> 324; 16 with 0.4 174 -> 164). */
    size_t n = (size_t)cfg->sampler->count, side = 2 * (size_t)flt->support + 1;
    if (n * (5 + (flt->support > 0 ? 2 * side : 0)) < 12 * side * side)
        return false;
    if (flt->support == 0)
        return filter_is_box(flt) && flt->r >= 0.5f;
    if (cfg->sampler->ops->fixed || !flt->ops->weight_1d || filter_has_negative_lobes(flt))
        return false;
    float a = flt->ops->weight_1d(flt, -0.5f), b = flt->ops->weight_1d(flt, 0.5f);
    return a >= 1e-15f && b >= 1e-15f;
}

/* ... and keeps only them (colour only: with depth or normals the general loop sums in
 * the same order from the samples). */
static bool film_moments_kept_cfg(const FilmConfig *cfg)
{
    return film_moments_cfg(cfg) && !film_wants(cfg, FILM_DEPTH) &&
           !film_wants(cfg, FILM_NORMALS);
}

/* The floats a traced column of cfg's film holds per row, as film_render_rect lays
 * them out: its samples' (position, colour, depth grey and |normal| when wanted; with
 * kept moments only for the samples picture), their separable weights (2(2R+1) a
 * sample, not with kept moments), and the moments (4 (2R+1)^2 where kept). */
static void film_column_floats(const FilmConfig *cfg, size_t *data, size_t *weights,
                               size_t *mom)
{
    int R = cfg->filter->support;
    size_t side = 2 * (size_t)R + 1, slots = (size_t)cfg->sampler->count;
    if (cfg->refine && (size_t)cfg->refine->count > slots)
        slots = (size_t)cfg->refine->count;
    size_t stride = 5 + (film_wants(cfg, FILM_DEPTH) ? 3 : 0) +
                    (film_wants(cfg, FILM_NORMALS) ? 3 : 0);
    bool fixed = cfg->sampler->ops->fixed && !cfg->refine;
    size_t per = !fixed && cfg->filter->ops->weight_1d && R > 0 ? 2 * side : 0;
    bool kept = film_moments_kept_cfg(cfg);
    *data = kept && !cfg->samples ? 0 : slots * stride;
    *weights = kept ? 0 : slots * per;
    *mom = kept ? 4 * side * side : 0;
}

/* film_path_set's cap: read once per render, written only between renders. */
static int film_path_cap = 2;

void film_path_set(int cap) { film_path_cap = cap; }

/* film_render of one column chunk (or of the whole rectangle). */
static bool film_render_rect(const RayTracer *rt, const Camera *camera, FilmConfig *cfg,
                             int threads, RtStats *stats_out, volatile int *cancel)
{
    cfg->trace_cpu = cfg->filter_cpu = 0.0;
    cfg->held = 0;
    if (stats_out)
        memset(stats_out, 0, sizeof *stats_out);
    if (!film_check(cfg))
        return false;
    Film f;
    memset(&f, 0, sizeof f);
    int failed = 0;
    f.failed = &failed;
    f.cancel = cancel;
    f.cfg = cfg;
    f.color = cfg->color;
    f.depth = cfg->depth;
    f.normals = cfg->normals;
    f.ox = cfg->x0 - cfg->out_x;
    f.oy = cfg->y0;
#ifdef FILM_HAVE_AVX2
    f.avx2 = film_path_cap >= 1 && cpu_has_avx2();
#endif
#ifdef FILM_HAVE_AVX512
    f.avx512 = film_path_cap >= 2 && cpu_has_avx512();
#endif
    f.rt = rt;
    f.camera = camera;
    f.tmin = camera_tmin(camera);
    int R = f.R = cfg->filter->support;
    film_margin(cfg->x0, cfg->width, R, cfg->full_width, &f.sx0, &f.sx1);
    film_margin(cfg->y0, cfg->height, R, cfg->full_height, &f.sy0, &f.sy1);
    f.fw = f.sx1 - f.sx0;
    f.slots = cfg->sampler->count;
    if (cfg->refine && cfg->refine->count > f.slots)
        f.slots = cfg->refine->count;
    f.stride = 5;
    f.off_depth = f.off_normal = -1;
    if (film_wants(cfg, FILM_DEPTH)) {
        f.off_depth = f.stride;
        f.stride += 3;
    }
    if (film_wants(cfg, FILM_NORMALS)) {
        f.off_normal = f.stride;
        f.stride += 3;
    }
    bool fixed = cfg->sampler->ops->fixed && !cfg->refine;
    if (fixed) {
        /* The same offsets in every pixel: every weight is known before rendering. */
        f.fixed_xy = malloc(2 * (size_t)f.slots * sizeof *f.fixed_xy);
        if (!f.fixed_xy)
            return false;
        float *xy = f.fixed_xy;
        sampler_pixel(cfg->sampler, 0, 0, xy);
        int side = 2 * R + 1;
        f.table = malloc((size_t)side * (size_t)side * (size_t)f.slots * sizeof *f.table);
        if (!f.table) {
            free(f.fixed_xy);
            return false;
        }
        for (int da = -R; da <= R; da++)
            for (int db = -R; db <= R; db++)
                for (int s = 0; s < f.slots; s++) {
                    float dx = (float)((double)da + (double)xy[2 * s] - 0.5);
                    float dy = (float)((double)db + (double)xy[2 * s + 1] - 0.5);
                    f.table[((da + R) * side + (db + R)) * f.slots + s] =
                        filter_weight(cfg->filter, dx, dy);
                }
    } else if (cfg->filter->ops->weight_1d && R > 0) {
        f.per = 2 * (2 * R + 1);
    }
    /* Planes where the vector filter runs and has neighbours to weigh. With R = 0 a
     * pixel's samples side by side and the scalar loop were as fast (uniform: 3 ms of
     * filtering at 400x400); each sample's own 2-D weight in a plane (jittered + box
     * 0.5) filtered in 4 ms instead of 12 but cost more than that in the trace phase
     * (the weight pass and the tile copy; paired runs in bench/REPORT.txt). */
    f.planes = !cfg->refine && f.off_depth < 0 && f.off_normal < 0 && R > 0 &&
               (f.per || f.table);
    f.row_weights = f.per && f.planes;
    f.moments = film_moments_cfg(cfg);
    /* Moments kept (colour only; with R > 0 exactly where the data would be in planes):
     * the samples and their weights stay in the tile's scratch (film_tile_moments); the
     * samples reach the film only for the samples picture. */
    bool mom = film_moments_kept_cfg(cfg);
    /* Filter jobs of two rows where their spans share loads (film_span_sums2_avx512,
     * film_span_sums2_avx2). */
    f.pairs = f.row_weights && (f.avx512 || f.avx2) && !mom;
    f.lobes = filter_has_negative_lobes(cfg->filter);
    if (f.lobes && f.table) {
        /* film_lobe_sums of a pixel whose support is whole, from the table */
        float pos = 0.0f, sum = 0.0f;
        for (int k = 0; k < (2 * R + 1) * (2 * R + 1) * f.slots; k++) {
            float w = f.table[k];
            if (w > 0.0f)
                pos += w;
            sum += w;
        }
        f.lobes_inside_ok = film_lobes_trusted(pos, sum);
    }
    size_t px_floats = (size_t)f.slots * (size_t)f.stride;
    f.pw = f.planes || f.per ? film_plane_width(f.fw) : f.fw;
    f.rs = (size_t)(f.planes ? f.pw : f.fw) * px_floats;
    if (f.planes) {
        f.cs = (size_t)f.pw;
        f.ss = (size_t)f.stride * (size_t)f.pw;
        f.xs = 1;
    } else {
        f.cs = 1;
        f.ss = (size_t)f.stride;
        f.xs = px_floats;
    }
    f.ws = (size_t)f.per * (size_t)f.pw;

    /* Floats a film row holds per column (the layout above) */
    size_t data_floats, weight_floats, mom_floats;
    film_column_floats(cfg, &data_floats, &weight_floats, &mom_floats);
    size_t col_floats = data_floats + weight_floats + mom_floats;
    f.ms = mom_floats * (size_t)f.pw;

    /* Strip height from the budget; at least 2R + 1 rows so a strip makes progress. */
    size_t budget = cfg->budget ? cfg->budget : FILM_DEFAULT_BUDGET;
    size_t row_bytes = (size_t)f.pw * (col_floats * sizeof(float) + sizeof(int));
    size_t cap = budget / row_bytes;
    if (cap < (size_t)(2 * R + 1))
        cap = (size_t)(2 * R + 1);
    /* Strips of whole packet bands, so that they cut no packet tile (film_band): the
     * rows held are rounded down to a multiple of TILE, or up (at most TILE - 1 rows
     * over the budget) when that would leave a worker without a band of its own or
     * too few rows for the margins. Below one band's rows (tiny budgets) as they are. */
    int workers = threads > 0 ? threads : render_default_threads();
    if (cap >= TILE) {
        size_t down = cap - cap % TILE;
        if (down / TILE < (size_t)workers || down < (size_t)(2 * R + TILE))
            down += TILE;
        cap = down;
    }
    /* One worker: a strip of one new band and the 2R rows kept from the strip before
     * at most (fewer when the budget holds fewer: 64 samples 2048 wide, 3 rows), in
     * film_row's ring (kept rows are not moved, so thin strips cost no moves). The
     * buffer is then reused band after band, so the render touches 1 MB of fresh
     * memory instead of the budget's 8 (16 samples at 400 wide, R = 0), or 2.8 MB
     * instead of 6.8 (the Gaussian 0.4, R = 1: with its weights 283 KB a row, the
     * budget held 24 rows); on this VM a fresh huge page sometimes costs a millisecond
     * to fault in (clear_page_erms 0.2-9% of a 16-sample 17a render between runs), and
     * the strip just traced is filtered while more of it is still in cache. With
     * several workers every strip keeps the budget's bands: a strip of one band per
     * worker waits at each strip's end for its slowest band (2 threads, 2 bands a
     * strip: +9% wall time). */
    if (workers == 1 && cap > (size_t)(TILE + 2 * R))
        cap = (size_t)(TILE + 2 * R);
    if (cap > (size_t)(f.sy1 - f.sy0))
        cap = (size_t)(f.sy1 - f.sy0);
    f.rows_cap = (int)cap;
    if (data_floats)
        f.data = bigmem_alloc(cap * (size_t)f.pw * data_floats * sizeof(float));
    f.count = bigmem_alloc(cap * (size_t)f.fw * sizeof(int));
    if (weight_floats)
        f.weights = bigmem_alloc(cap * (size_t)f.pw * weight_floats * sizeof(float));
    if (mom)
        f.mom = bigmem_alloc(cap * f.ms * sizeof(float));
    bool ok = (f.data || !data_floats) && f.count && (f.weights || !weight_floats) &&
              (f.mom || !mom);
    /* Strip by strip (cfg->rows): byte images of a strip's output rows, at most the
     * rows held (a strip's output rows are among its traced ones), each of a strip's
     * pixels put once, so they are reused without clearing. */
    Image strip[3];
    memset(strip, 0, sizeof strip);
    if (cfg->rows) {
        int sh = f.rows_cap < cfg->height ? f.rows_cap : cfg->height;
        Image **outs[3] = {&f.color, &f.depth, &f.normals};
        static const unsigned which[3] = {FILM_COLOR, FILM_DEPTH, FILM_NORMALS};
        for (int k = 0; k < 3 && ok; k++)
            if (cfg->rows_wanted & which[k]) {
                ok = image_init_bytes(&strip[k], cfg->width, sh);
                *outs[k] = &strip[k];
            }
        f.ox = cfg->x0;
    }
    cfg->held = cap * (size_t)f.pw * col_floats * sizeof(float) + cap * (size_t)f.fw * sizeof(int);

    RtStats total = {0};
    f.y0 = f.sy0;
    f.rows = 0;
    for (int oy = cfg->y0; ok && oy < cfg->y0 + cfg->height;) {
        /* Drop the rows no later output row needs; keep the rest (the shared margin). */
        int need0 = oy - R > f.sy0 ? oy - R : f.sy0;
        if (need0 > f.y0) {
            int drop = need0 - f.y0, keep = f.rows - drop;
            f.ring0 = (f.ring0 + drop) % f.rows_cap; /* the kept rows stay in place */
            f.y0 = need0;
            f.rows = keep > 0 ? keep : 0;
        }
        /* The strip's output rows: all the rest when the remaining film rows fit,
         * else as many as leave room for their R rows above. */
        int out1 = cfg->y0 + cfg->height;
        if (f.sy1 - f.y0 > f.rows_cap && f.y0 + f.rows_cap - R < out1) {
            out1 = f.y0 + f.rows_cap - R;
            /* The traced rows end on a packet band's edge when that still gives an
             * output row: the next strip's traced rows then start on one too. */
            int r1 = film_grid_floor(f.y0 + f.rows_cap);
            if (r1 - R > oy)
                out1 = r1 - R;
        }
        int need1 = out1 + R < f.sy1 ? out1 + R : f.sy1;
        f.r0 = f.y0 + f.rows;
        f.r1 = need1;
        if (f.r1 > f.r0) {
            RtStats st;
            int bands = (f.r1 - film_band_base(&f) + TILE - 1) / TILE;
            double t0 = clock_thread_cpu();
            ok = render_parallel(rt, threads, bands, film_band, &f, &st, cancel);
            if (__atomic_load_n(&failed, __ATOMIC_RELAXED))
                ok = false;
            cfg->trace_cpu += clock_thread_cpu() - t0;
            stats_merge(&total, &st);
            f.rows = f.r1 - f.y0;
        }
        f.out0 = oy;
        f.out1 = out1;
        if (cfg->rows)
            f.oy = oy; /* the strip images' row 0 */
        if (ok) {
            double t0 = clock_thread_cpu();
            if (f.pairs)
                ok = render_parallel(NULL, threads, (out1 - oy + 1) / 2, film_filter_pair, &f,
                                     NULL, cancel);
            else
                ok = render_parallel(NULL, threads, out1 - oy, film_filter_row, &f, NULL,
                                     cancel);
            cfg->filter_cpu += clock_thread_cpu() - t0;
        }
        if (ok && cfg->rows) {
            /* The strip's rows, as images of their height (the same bytes). */
            Image view[3];
            const Image *give[3] = {NULL, NULL, NULL};
            for (int k = 0; k < 3; k++)
                if (strip[k].bytes) {
                    view[k] = strip[k];
                    view[k].height = out1 - oy;
                    give[k] = &view[k];
                }
            FilmRows r = {cfg->out_x, oy - cfg->y0, give[0], give[1], give[2]};
            cfg->rows(cfg->rows_user, &r);
        }
        oy = out1;
    }
    for (int k = 0; k < 3; k++)
        image_free(&strip[k]);
    bigmem_free(f.data);
    bigmem_free(f.count);
    bigmem_free(f.weights);
    bigmem_free(f.mom);
    free(f.table);
    free(f.fixed_xy);
    if (stats_out)
        *stats_out = total;
    return ok;
}

/* Bytes a traced column of cfg's strips holds per row (film_column_floats' floats and
 * the pixel's count), without the plane rows' padding. */
static size_t film_column_bytes(const FilmConfig *cfg)
{
    size_t data, weights, mom;
    film_column_floats(cfg, &data, &weights, &mom);
    return (data + weights + mom) * sizeof(float) + sizeof(int);
}

/* The width of cfg's column chunks (a multiple of TILE, counted from the image's left
 * edge), or 0: the rectangle in one piece. Chunks only where the thinnest strip of the
 * whole width (2R + 1 rows) would hold more than strip_limit; a chunk is then as wide as
 * lets a strip of one band and its margins (TILE + 2R rows) fit that limit, and at
 * least 16 R columns (its margins at most 1/8 more rays) and TILE. Chunks sized to the
 * 8 MB budget instead were 8 columns wide with the Mitchell 4 at 256 samples: twice the
 * rays, and the render (2000 x 40) took 54 s instead of 17. */
static int film_chunk_width(const FilmConfig *cfg)
{
    int R = cfg->filter->support, x0, x1;
    film_margin(cfg->x0, cfg->width, R, cfg->full_width, &x0, &x1);
    size_t col = film_column_bytes(cfg);
    size_t limit = cfg->strip_limit ? cfg->strip_limit : FILM_STRIP_LIMIT;
    if ((size_t)(2 * R + 1) * (size_t)(x1 - x0) * col <= limit)
        return 0;
    size_t cols = limit / ((size_t)(TILE + 2 * R) * col);
    cols = cols > (size_t)(2 * R) ? cols - (size_t)(2 * R) : 0;
    if (cols < (size_t)(16 * R))
        cols = (size_t)(16 * R);
    cols -= cols % TILE;
    if (cols < TILE)
        cols = TILE;
    return cols >= (size_t)cfg->width ? 0 : (int)cols;
}

/* Column chunk k's columns [*c0, *c1) of cfg's rectangle for chunks of width cw (the
 * first and last cut by the rectangle); false past the last. */
static bool film_chunk(const FilmConfig *cfg, int cw, int k, int *c0, int *c1)
{
    int first = cfg->x0 - cfg->x0 % cw, end = cfg->x0 + cfg->width;
    int a = first + k * cw, b = a + cw;
    if (a >= end)
        return false;
    *c0 = a > cfg->x0 ? a : cfg->x0;
    *c1 = b < end ? b : end;
    return true;
}

bool film_render(const RayTracer *rt, const Camera *camera, FilmConfig *cfg,
                 int threads, RtStats *stats_out, volatile int *cancel)
{
    int cw = film_check(cfg) ? film_chunk_width(cfg) : 0;
    if (cw == 0)
        return film_render_rect(rt, camera, cfg, threads, stats_out, cancel);
    /* Chunk after chunk, each the whole height: the same pixels as one piece (as -tile
     * columns are), each chunk tracing its own margin of R columns again. */
    cfg->trace_cpu = cfg->filter_cpu = 0.0;
    cfg->held = 0;
    RtStats total = {0};
    bool ok = true;
    int c0, c1;
    for (int k = 0; ok && film_chunk(cfg, cw, k, &c0, &c1); k++) {
        FilmConfig c = *cfg;
        c.x0 = c0;
        c.width = c1 - c0;
        c.out_x = cfg->out_x + (c0 - cfg->x0);
        RtStats st;
        ok = film_render_rect(rt, camera, &c, threads, &st, cancel);
        cfg->trace_cpu += c.trace_cpu;
        cfg->filter_cpu += c.filter_cpu;
        if (c.held > cfg->held)
            cfg->held = c.held;
        stats_merge(&total, &st);
    }
    if (stats_out)
        *stats_out = total;
    return ok;
}

uint64_t film_traced_pixels(const FilmConfig *cfg)
{
    if (!film_check(cfg))
        return 0;
    int R = cfg->filter->support, x0, x1, y0, y1;
    film_margin(cfg->y0, cfg->height, R, cfg->full_height, &y0, &y1);
    int cw = film_chunk_width(cfg), c0 = cfg->x0, c1 = cfg->x0 + cfg->width;
    uint64_t cols = 0;
    for (int k = 0; cw == 0 ? k == 0 : film_chunk(cfg, cw, k, &c0, &c1); k++) {
        film_margin(c0, c1 - c0, R, cfg->full_width, &x0, &x1);
        cols += (uint64_t)(x1 - x0);
    }
    return cols * (uint64_t)(y1 - y0);
}

void film_filter_picture(const Filter *f, int width, int height, int zoom, Image *out)
{
    image_fill(out, v3(0, 0, 0.5f));
    int R = f->support;
    int c = width / 2; /* both coordinates from the width, as the course's film.C */
    for (int i = c - R; i <= c + R; i++)
        for (int j = c - R; j <= c + R; j++) {
            if (i < 0 || j < 0 || i >= width || j >= height)
                continue;
            for (int i2 = 0; i2 < zoom; i2++)
                for (int j2 = 0; j2 < zoom; j2++) {
                    float x = (float)((double)i + (double)i2 / zoom - ((double)c + 0.5));
                    float y = (float)((double)j + (double)j2 / zoom - ((double)c + 0.5));
                    float w = filter_weight(f, x, y);
                    image_set(out, i * zoom + i2, j * zoom + j2, v3(w, w, w));
                }
        }
    for (int y = 0; y < out->height; y++)
        for (int x = 0; x < out->width; x++)
            if (x % zoom == 0 || y % zoom == 0)
                image_set(out, x, y, v3(0, 0, 1.0f));
}
