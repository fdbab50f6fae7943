/* Orthographic and perspective cameras (A1, A2): the basis from direction and up, and
 * the ray through a screen point, rounded like the course's camera (rt/camera.h states
 * the formulas, docs/camera.md the measurements behind them). */
#include "rt/camera.h"
#include "rt/cpu.h"

#include <float.h>
#include <math.h>
#include <string.h>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif
#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#endif

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

/* Unit vector by dividing each component by the length, as the course's Vec3f does:
 * multiplying by the reciprocal rounds differently, and on grazing floors (a7 03a, A6
 * 17a) that last bit of the ray direction decides a pixel's colour. */
static Vec3 unit_by_division(Vec3 a)
{
    float l = v3_length(a);
    return l > 0.0f ? v3(a.x / l, a.y / l, a.z / l) : a;
}

bool camera_rebasis(Camera *c)
{
    Vec3 d = unit_by_division(c->direction);
    if (v3_is_zero(d) || !v3_isfinite(d))
        return false;
    Vec3 h = unit_by_division(v3_cross(d, unit_by_division(c->up)));
    if (v3_is_zero(h) || !v3_isfinite(h))
        return false;
    /* Orthogonal to d by construction and unit up to rounding; not renormalised, which
     * is what the official images were rendered with (measured, docs/camera.md). */
    Vec3 up = v3_cross(h, d);
    c->direction = d;
    c->up = up;
    c->horizontal = h;
    c->tan_half = tanf(c->angle * 0.5f);
    /* The screen at distance 1, in world space: corner center + d - t up - t h, edges
     * 2t h and 2t up (each product rounded in this order). */
    float t = c->tan_half;
    c->lower_left = v3_sub(v3_sub(v3_add(c->center, d), v3_scale(up, t)), v3_scale(h, t));
    c->x_axis = v3_scale(v3_scale(h, 2.0f), t);
    c->y_axis = v3_scale(v3_scale(up, 2.0f), t);
    c->screen_offset = v3_sub(v3_sub(d, v3_scale(up, t)), v3_scale(h, t));
    float far = fmaxf(fabsf(c->center.x), fmaxf(fabsf(c->center.y), fabsf(c->center.z)));
    c->far_eye = c->kind == CAMERA_PERSPECTIVE && far >= CAMERA_FAR_EYE;
    return true;
}

bool camera_init_orthographic(Camera *c, Vec3 center, Vec3 direction, Vec3 up, float size)
{
    c->kind = CAMERA_ORTHOGRAPHIC;
    c->center = center;
    c->direction = direction;
    c->up = up;
    c->size = size;
    c->angle = 0.0f;
    if (!(size > 0.0f) || !isfinite(size) || !v3_isfinite(center))
        return false;
    return camera_rebasis(c);
}

bool camera_init_perspective(Camera *c, Vec3 center, Vec3 direction, Vec3 up,
                             float angle_radians)
{
    c->kind = CAMERA_PERSPECTIVE;
    c->center = center;
    c->direction = direction;
    c->up = up;
    c->size = 0.0f;
    c->angle = angle_radians;
    if (!(angle_radians > 0.0f) || !(angle_radians < (float)M_PI) || !v3_isfinite(center))
        return false;
    return camera_rebasis(c);
}

Ray camera_generate_ray(const Camera *c, float u, float v)
{
    Ray r;
    if (c->kind == CAMERA_ORTHOGRAPHIC) {
        r.origin = v3_add(c->center, v3_add(v3_scale(c->horizontal, (u - 0.5f) * c->size),
                                            v3_scale(c->up, (v - 0.5f) * c->size)));
        r.dir = c->direction;
    } else if (c->far_eye) {
        /* The screen relative to the eye: world space would round the directions of
         * neighbouring pixels to the same few values (rt/camera.h). */
        Vec3 p = v3_add(v3_add(c->screen_offset, v3_scale(c->x_axis, u)), v3_scale(c->y_axis, v));
        r.origin = c->center;
        r.dir = unit_by_division(p);
    } else {
        /* The screen point in world space minus the eye (not d + offsets): the
         * course's rounding, which the official images need (rt/camera.h). */
        Vec3 p = v3_add(v3_add(c->lower_left, v3_scale(c->x_axis, u)), v3_scale(c->y_axis, v));
        r.origin = c->center;
        r.dir = unit_by_division(v3_sub(p, c->center));
    }
    return r;
}

/* Where pixel (i, j) of a block goes: rays[slot[j nx + i]], or rays[j nx + i]. */
static inline Ray *block_ray(Ray *rays, const uint8_t *slot, int nx, int i, int j)
{
    return &rays[slot ? slot[j * nx + i] : j * nx + i];
}

/* The perspective rays of columns [i0, i1) of every row (col and row as
 * camera_pixel_rays makes them), one lane per column: d = (col + row) - eye, its length
 * sqrtf((x x + y y) + z z), then each component divided by it when positive; the same
 * IEEE single operations in the same order as the scalar loop, in every lane (sqrt and
 * division are correctly rounded in SSE and AVX as in scalar code). */
#if defined(__SSE2__)
static int rows_sse2(Vec3 e, const float *cx, const float *cy, const float *cz,
                     const Vec3 *row, int i0, int i1, int nx, int ny, const uint8_t *slot,
                     Ray *rays)
{
    __m128 ex = _mm_set1_ps(e.x), ey = _mm_set1_ps(e.y), ez = _mm_set1_ps(e.z);
    __m128 zero = _mm_setzero_ps();
    int i = i0;
    for (; i + 4 <= i1; i += 4)
        for (int j = 0; j < ny; j++) {
            __m128 dx = _mm_sub_ps(_mm_add_ps(_mm_loadu_ps(cx + i), _mm_set1_ps(row[j].x)), ex);
            __m128 dy = _mm_sub_ps(_mm_add_ps(_mm_loadu_ps(cy + i), _mm_set1_ps(row[j].y)), ey);
            __m128 dz = _mm_sub_ps(_mm_add_ps(_mm_loadu_ps(cz + i), _mm_set1_ps(row[j].z)), ez);
            __m128 l = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                                              _mm_mul_ps(dz, dz)));
            __m128 pos = _mm_cmpgt_ps(l, zero);
            float ox[4], oy[4], oz[4];
            _mm_storeu_ps(ox, _mm_or_ps(_mm_and_ps(pos, _mm_div_ps(dx, l)), _mm_andnot_ps(pos, dx)));
            _mm_storeu_ps(oy, _mm_or_ps(_mm_and_ps(pos, _mm_div_ps(dy, l)), _mm_andnot_ps(pos, dy)));
            _mm_storeu_ps(oz, _mm_or_ps(_mm_and_ps(pos, _mm_div_ps(dz, l)), _mm_andnot_ps(pos, dz)));
            for (int k = 0; k < 4; k++) {
                Ray *r = block_ray(rays, slot, nx, i + k, j);
                r->origin = e;
                r->dir = v3(ox[k], oy[k], oz[k]);
            }
        }
    return i;
}
#endif

#if defined(__x86_64__) && defined(__GNUC__)
/* Eight rays' unit directions from their unnormalised components: each divided by the
 * length where the length is positive (as the scalar camera does), x into ox[0..7] and
 * the (y, z) pairs in ray order into oyz[0..15], so that each ray goes out in two
 * stores: (eye, dir.x) and (dir.y, dir.z). rows_avx2 and lanes_avx2 share it so that
 * both make the same bits. */
__attribute__((target("avx2"))) static inline void unit8_avx2(__m256 dx, __m256 dy, __m256 dz,
                                                              float ox[8], float oyz[16])
{
    __m256 l = _mm256_sqrt_ps(_mm256_add_ps(
        _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz)));
    __m256 pos = _mm256_cmp_ps(l, _mm256_setzero_ps(), _CMP_GT_OQ);
    __m256 qy = _mm256_blendv_ps(dy, _mm256_div_ps(dy, l), pos);
    __m256 qz = _mm256_blendv_ps(dz, _mm256_div_ps(dz, l), pos);
    _mm256_storeu_ps(ox, _mm256_blendv_ps(dx, _mm256_div_ps(dx, l), pos));
    /* y0 z0 y1 z1 | y4 z4 y5 z5 and y2 z2 y3 z3 | y6 z6 y7 z7 (per 128-bit half) */
    __m256 lo = _mm256_unpacklo_ps(qy, qz), hi = _mm256_unpackhi_ps(qy, qz);
    _mm256_storeu_ps(oyz, _mm256_permute2f128_ps(lo, hi, 0x20));
    _mm256_storeu_ps(oyz + 8, _mm256_permute2f128_ps(lo, hi, 0x31));
}

/* rows_sse2 eight columns at a time, for CPUs with AVX2 (no FMA: nothing can fuse). */
__attribute__((target("avx2"))) static int rows_avx2(Vec3 e, const float *cx, const float *cy,
                                                     const float *cz, const Vec3 *row, int i0,
                                                     int i1, int nx, int ny,
                                                     const uint8_t *slot, Ray *rays)
{
    __m256 ex = _mm256_set1_ps(e.x), ey = _mm256_set1_ps(e.y), ez = _mm256_set1_ps(e.z);
    int i = i0;
    for (; i + 8 <= i1; i += 8)
        for (int j = 0; j < ny; j++) {
            __m256 dx = _mm256_sub_ps(_mm256_add_ps(_mm256_loadu_ps(cx + i), _mm256_set1_ps(row[j].x)), ex);
            __m256 dy = _mm256_sub_ps(_mm256_add_ps(_mm256_loadu_ps(cy + i), _mm256_set1_ps(row[j].y)), ey);
            __m256 dz = _mm256_sub_ps(_mm256_add_ps(_mm256_loadu_ps(cz + i), _mm256_set1_ps(row[j].z)), ez);
            float ox[8], oyz[16];
            unit8_avx2(dx, dy, dz, ox, oyz);
            __m128 eye = _mm_setr_ps(e.x, e.y, e.z, 0.0f);
            _Static_assert(sizeof(Ray) == 6 * sizeof(float), "a ray is six packed floats");
            for (int k = 0; k < 8; k++) {
                float *r = (float *)block_ray(rays, slot, nx, i + k, j);
                _mm_storeu_ps(r, _mm_insert_ps(eye, _mm_set_ss(ox[k]), 0x30));
                memcpy(r + 4, oyz + 2 * k, 2 * sizeof(float));
            }
        }
    return i;
}
#define HAVE_ROWS_AVX2 1

/* camera_block8_rays' perspective rays in lane order: for lanes k..k+7, the column i and
 * row j of each lane's pixel (lane[k] = 8 j + i) pick their terms out of the eight
 * columns' and rows' (one permute each), then rows_avx2's operations in its order
 * ((col + row) - eye, its length, each component divided where positive), so the same
 * bits; the rays go to rays[k..k+7] in order, without rows_avx2's placing of each ray
 * through a slot table. */
__attribute__((target("avx2"))) static void lanes_avx2(Vec3 e, const Vec3 *col,
                                                       const Vec3 *row, const uint8_t *lane,
                                                       Ray *rays)
{
    float t[6][8];
    for (int i = 0; i < 8; i++) {
        t[0][i] = col[i].x;
        t[1][i] = col[i].y;
        t[2][i] = col[i].z;
        t[3][i] = row[i].x;
        t[4][i] = row[i].y;
        t[5][i] = row[i].z;
    }
    __m256 cx = _mm256_loadu_ps(t[0]), cy = _mm256_loadu_ps(t[1]), cz = _mm256_loadu_ps(t[2]);
    __m256 rx = _mm256_loadu_ps(t[3]), ry = _mm256_loadu_ps(t[4]), rz = _mm256_loadu_ps(t[5]);
    __m256 ex = _mm256_set1_ps(e.x), ey = _mm256_set1_ps(e.y), ez = _mm256_set1_ps(e.z);
    __m256i seven = _mm256_set1_epi32(7);
    __m128 eye = _mm_setr_ps(e.x, e.y, e.z, 0.0f);
    for (int k = 0; k < 64; k += 8) {
        __m256i p = _mm256_cvtepu8_epi32(_mm_loadl_epi64((const __m128i *)(lane + k)));
        __m256i pi = _mm256_and_si256(p, seven), pj = _mm256_srli_epi32(p, 3);
        __m256 dx = _mm256_sub_ps(_mm256_add_ps(_mm256_permutevar8x32_ps(cx, pi),
                                                _mm256_permutevar8x32_ps(rx, pj)), ex);
        __m256 dy = _mm256_sub_ps(_mm256_add_ps(_mm256_permutevar8x32_ps(cy, pi),
                                                _mm256_permutevar8x32_ps(ry, pj)), ey);
        __m256 dz = _mm256_sub_ps(_mm256_add_ps(_mm256_permutevar8x32_ps(cz, pi),
                                                _mm256_permutevar8x32_ps(rz, pj)), ez);
        float ox[8], oyz[16];
        unit8_avx2(dx, dy, dz, ox, oyz);
        float *r = (float *)(rays + k);
        for (int q = 0; q < 8; q++, r += 6) {
            _mm_storeu_ps(r, _mm_insert_ps(eye, _mm_set_ss(ox[q]), 0x30));
            memcpy(r + 4, oyz + 2 * q, 2 * sizeof(float));
        }
    }
}
#endif

/* The terms of one column (u) and of one row (v) of a block, in the order
 * camera_generate_ray adds them: perspective (lower_left + x_axis u) + y_axis v,
 * orthographic center + (horizontal (u - 0.5) size + up (v - 0.5) size). */
static void block_terms(const Camera *c, int x0, int y0, int nx, int ny, int width,
                        int height, Vec3 *col, Vec3 *row)
{
    bool ortho = c->kind == CAMERA_ORTHOGRAPHIC;
    /* u and v of camera_pixel_to_screen, each alone: the same expressions. */
    float side = (float)(width > height ? width : height);
    for (int i = 0; i < nx; i++) {
        float u = ((float)(x0 + i) + 0.5f + (side - (float)width) * 0.5f) / side;
        col[i] = ortho ? v3_scale(c->horizontal, (u - 0.5f) * c->size)
                       : v3_add(c->lower_left, v3_scale(c->x_axis, u));
    }
    for (int j = 0; j < ny; j++) {
        float v = ((float)(y0 + j) + 0.5f + (side - (float)height) * 0.5f) / side;
        row[j] = ortho ? v3_scale(c->up, (v - 0.5f) * c->size) : v3_scale(c->y_axis, v);
    }
}

void camera_pixel_rays(const Camera *c, int x0, int y0, int nx, int ny, int width,
                       int height, const uint8_t *slot, Ray *rays)
{
    Vec3 col[CAMERA_BLOCK_MAX], row[CAMERA_BLOCK_MAX];
    bool ortho = c->kind == CAMERA_ORTHOGRAPHIC;
    block_terms(c, x0, y0, nx, ny, width, height, col, row);
    if (ortho) {
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                Ray *r = block_ray(rays, slot, nx, i, j);
                r->origin = v3_add(c->center, v3_add(col[i], row[j]));
                r->dir = c->direction;
            }
        return;
    }
    if (c->far_eye) {
        /* camera_generate_ray's own form, one ray at a time: the lanes below aim in
         * world space. */
        for (int j = 0; j < ny; j++)
            for (int i = 0; i < nx; i++) {
                float u, v;
                camera_pixel_to_screen(x0 + i, y0 + j, width, height, &u, &v);
                *block_ray(rays, slot, nx, i, j) = camera_generate_ray(c, u, v);
            }
        return;
    }
    Vec3 e = c->center;
    int done = 0;
#if defined(__SSE2__)
    float cx[CAMERA_BLOCK_MAX], cy[CAMERA_BLOCK_MAX], cz[CAMERA_BLOCK_MAX];
    for (int i = 0; i < nx; i++) {
        cx[i] = col[i].x;
        cy[i] = col[i].y;
        cz[i] = col[i].z;
    }
#ifdef HAVE_ROWS_AVX2
    /* Asked on every call (a load): a copy cached in a static that render threads
     * write would be a data race. */
    if (cpu_has_avx2())
        done = rows_avx2(e, cx, cy, cz, row, done, nx, nx, ny, slot, rays);
#endif
    done = rows_sse2(e, cx, cy, cz, row, done, nx, nx, ny, slot, rays);
#endif
    for (int j = 0; j < ny; j++)
        for (int i = done; i < nx; i++) {
            Ray *r = block_ray(rays, slot, nx, i, j);
            r->origin = e;
            /* unit_by_division of (screen point - eye), written out so the compiler
             * keeps it in registers; the same operations in the same order. */
            Vec3 d = v3_sub(v3_add(col[i], row[j]), e);
            float l = sqrtf(d.x * d.x + d.y * d.y + d.z * d.z);
            r->dir = l > 0.0f ? v3(d.x / l, d.y / l, d.z / l) : d;
        }
}

static bool g_block8_plain; /* camera_block8_rays_plain */

void camera_block8_rays_plain(bool on) { g_block8_plain = on; }

void camera_block8_rays(const Camera *c, int x0, int y0, int width, int height,
                        const uint8_t *lane, Ray *rays)
{
#ifdef HAVE_ROWS_AVX2
    /* Asked on every call (a load), as camera_pixel_rays does. */
    if (c->kind != CAMERA_ORTHOGRAPHIC && !c->far_eye && !g_block8_plain && cpu_has_avx2()) {
        Vec3 col[8], row[8];
        block_terms(c, x0, y0, 8, 8, width, height, col, row);
        lanes_avx2(c->center, col, row, lane, rays);
        return;
    }
#endif
    /* camera_pixel_rays placing pixel p at slot[p], the lane showing it. */
    uint8_t slot[64];
    for (int k = 0; k < 64; k++)
        slot[lane[k]] = (uint8_t)k;
    camera_pixel_rays(c, x0, y0, 8, 8, width, height, slot, rays);
}

#if defined(__x86_64__) && defined(__GNUC__)
/* Where sample_rays_avx512's 16 rays (6 floats each: origin, direction) find their
 * floats in its six output vectors: float l of vector o is channel c = (16 o + l) % 6
 * of ray i = (16 o + l) / 6. xy: the permute index into (dir.x, dir.y) of the 16 rays
 * (i, or 16 + i) for c = 3, 4, with those lanes' mask; z: i for c = 5, with its mask;
 * eye: c for c < 3 (an index into (eye.x, eye.y, eye.z, 0, ...)), else 3. */
typedef struct SampleRayLanes {
    int32_t xy[16] __attribute__((aligned(64)));
    int32_t z[16] __attribute__((aligned(64)));
    int32_t eye[16] __attribute__((aligned(64)));
    uint16_t xymask, zmask;
} SampleRayLanes;

#define SRL_F(o, l) (16 * (o) + (l))
#define SRL_C(o, l) (SRL_F(o, l) % 6)
#define SRL_I(o, l) (SRL_F(o, l) / 6)
#define SRL_XY(o, l) (SRL_C(o, l) == 3 ? SRL_I(o, l) : SRL_C(o, l) == 4 ? 16 + SRL_I(o, l) : 0)
#define SRL_Z(o, l) (SRL_C(o, l) == 5 ? SRL_I(o, l) : 0)
#define SRL_EYE(o, l) (SRL_C(o, l) < 3 ? SRL_C(o, l) : 3)
#define SRL_XYBIT(o, l) (SRL_C(o, l) == 3 || SRL_C(o, l) == 4 ? 1u << (l) : 0u)
#define SRL_ZBIT(o, l) (SRL_C(o, l) == 5 ? 1u << (l) : 0u)
#define SRL_ROW(T, o)                                                                      \
    {T(o, 0), T(o, 1), T(o, 2),  T(o, 3),  T(o, 4),  T(o, 5),  T(o, 6),  T(o, 7),           \
     T(o, 8), T(o, 9), T(o, 10), T(o, 11), T(o, 12), T(o, 13), T(o, 14), T(o, 15)}
#define SRL_MASK(P, o)                                                                     \
    (uint16_t)(P(o, 0) | P(o, 1) | P(o, 2) | P(o, 3) | P(o, 4) | P(o, 5) | P(o, 6) |        \
               P(o, 7) | P(o, 8) | P(o, 9) | P(o, 10) | P(o, 11) | P(o, 12) | P(o, 13) |   \
               P(o, 14) | P(o, 15))
#define SRL_VECTOR(o)                                                                      \
    {SRL_ROW(SRL_XY, o), SRL_ROW(SRL_Z, o), SRL_ROW(SRL_EYE, o), SRL_MASK(SRL_XYBIT, o),   \
     SRL_MASK(SRL_ZBIT, o)}
static const SampleRayLanes sample_ray_lanes[6] = {SRL_VECTOR(0), SRL_VECTOR(1), SRL_VECTOR(2),
                                                   SRL_VECTOR(3), SRL_VECTOR(4), SRL_VECTOR(5)};

/* The camera's terms of sample_rays_avx512, broadcast once per call. */
typedef struct SampleRayConsts {
    __m512 S, cx, cy, llx, lly, llz, xax, xay, xaz, yax, yay, yaz, ex, ey, ez, e0, e1, e2;
} SampleRayConsts;

__attribute__((always_inline, target("avx512f"))) static inline void
sample_ray_consts(const Camera *c, int width, int height, SampleRayConsts *K)
{
    float s = (float)(width > height ? width : height);
    Vec3 ll = c->lower_left, xa = c->x_axis, ya = c->y_axis, e = c->center;
    K->S = _mm512_set1_ps(s);
    K->cx = _mm512_set1_ps((s - (float)width) * 0.5f);
    K->cy = _mm512_set1_ps((s - (float)height) * 0.5f);
    K->llx = _mm512_set1_ps(ll.x);
    K->lly = _mm512_set1_ps(ll.y);
    K->llz = _mm512_set1_ps(ll.z);
    K->xax = _mm512_set1_ps(xa.x);
    K->xay = _mm512_set1_ps(xa.y);
    K->xaz = _mm512_set1_ps(xa.z);
    K->yax = _mm512_set1_ps(ya.x);
    K->yay = _mm512_set1_ps(ya.y);
    K->yaz = _mm512_set1_ps(ya.z);
    K->ex = _mm512_set1_ps(e.x);
    K->ey = _mm512_set1_ps(e.y);
    K->ez = _mm512_set1_ps(e.z);
    /* The eye's floats at the origin channels of the output vectors: vector o's pattern
     * is vector (o % 3)'s (48 floats are eight whole rays). */
    const __m512 eye = _mm512_setr_ps(e.x, e.y, e.z, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0);
    K->e0 = _mm512_permutexvar_ps(_mm512_load_si512(sample_ray_lanes[0].eye), eye);
    K->e1 = _mm512_permutexvar_ps(_mm512_load_si512(sample_ray_lanes[1].eye), eye);
    K->e2 = _mm512_permutexvar_ps(_mm512_load_si512(sample_ray_lanes[2].eye), eye);
}

/* G groups of 16 samples (G = 1 or 2; group g: the pixel (x[g], y[g]), its 16 (x, y)
 * position pairs at xy[g], the rays to rays[g]), each step of all groups before the
 * next step: one group's chain of divisions and square root (about 80 cycles on the
 * Zen 4 host) waits on its own results, while a second group's fills the gaps (one
 * group at a time, sixteen rays took 36 ns where the divider alone needs 11). The same
 * IEEE single operations in the same order in every lane as the SSE lanes and the
 * scalar functions (no FMA: camera.o is built with -ffp-contract=off, and every
 * operation is an intrinsic). */
__attribute__((always_inline, target("avx512f"))) static inline void
sample_ray_groups(const SampleRayConsts *K, int G, const int *x, const int *y,
                  const float *const *xy, Ray *const *rays)
{
    /* Even and odd floats of two vectors: the x and the y of 16 (x, y) pairs. */
    const __m512i even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26,
                                           28, 30);
    const __m512i odd = _mm512_setr_epi32(1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 25, 27,
                                          29, 31);
    __m512 u[2], v[2], dx[2], dy[2], dz[2], l[2];
#pragma GCC unroll 2
    for (int g = 0; g < G; g++) {
        __m512 a = _mm512_loadu_ps(xy[g]), b = _mm512_loadu_ps(xy[g] + 16);
        __m512 px = _mm512_permutex2var_ps(a, even, b);
        __m512 py = _mm512_permutex2var_ps(a, odd, b);
        u[g] = _mm512_div_ps(_mm512_add_ps(_mm512_add_ps(_mm512_set1_ps((float)x[g]), px), K->cx),
                             K->S);
        v[g] = _mm512_div_ps(_mm512_add_ps(_mm512_add_ps(_mm512_set1_ps((float)y[g]), py), K->cy),
                             K->S);
    }
#define RT_AXIS(L, X, Y, E, g)                                                             \
    _mm512_sub_ps(_mm512_add_ps(_mm512_add_ps(K->L, _mm512_mul_ps(K->X, u[g])),             \
                                _mm512_mul_ps(K->Y, v[g])),                                \
                  K->E)
#pragma GCC unroll 2
    for (int g = 0; g < G; g++) {
        dx[g] = RT_AXIS(llx, xax, yax, ex, g);
        dy[g] = RT_AXIS(lly, xay, yay, ey, g);
        dz[g] = RT_AXIS(llz, xaz, yaz, ez, g);
    }
#undef RT_AXIS
#pragma GCC unroll 2
    for (int g = 0; g < G; g++)
        l[g] = _mm512_sqrt_ps(_mm512_add_ps(_mm512_add_ps(_mm512_mul_ps(dx[g], dx[g]),
                                                          _mm512_mul_ps(dy[g], dy[g])),
                                            _mm512_mul_ps(dz[g], dz[g])));
#pragma GCC unroll 2
    for (int g = 0; g < G; g++) {
        /* l > 0: d / l; otherwise d itself (as unit_by_division). */
        __mmask16 pos = _mm512_cmp_ps_mask(l[g], _mm512_setzero_ps(), _CMP_GT_OQ);
        __m512 qx = _mm512_mask_div_ps(dx[g], pos, dx[g], l[g]);
        __m512 qy = _mm512_mask_div_ps(dy[g], pos, dy[g], l[g]);
        __m512 qz = _mm512_mask_div_ps(dz[g], pos, dz[g], l[g]);
        /* The 16 rays' 96 floats as six whole vectors: in vector o, float l is channel
         * (16 o + l) % 6 of ray (16 o + l) / 6 (sample_ray_lanes): the eye's pattern,
         * the x and y of the directions from one two-vector permute, the z from one
         * more. Per ray, a store of (eye, dir.x) and one of (dir.y, dir.z) read back
         * from a spilled vector took more instructions than the rest of the function. */
        _Static_assert(sizeof(Ray) == 6 * sizeof(float), "a ray is six packed floats");
        float *r = (float *)rays[g];
#pragma GCC unroll 6
        for (int o = 0; o < 6; o++) {
            const SampleRayLanes *t = &sample_ray_lanes[o];
            __m512 dxy = _mm512_permutex2var_ps(qx, _mm512_load_si512(t->xy), qy);
            __m512 ez = _mm512_mask_permutexvar_ps(o % 3 == 0 ? K->e0 : o % 3 == 1 ? K->e1 : K->e2,
                                                   t->zmask, _mm512_load_si512(t->z), qz);
            _mm512_storeu_ps(r + 16 * o, _mm512_mask_mov_ps(ez, t->xymask, dxy));
        }
    }
}

/* camera_sample_rays' perspective lanes sixteen samples at a time, for CPUs with
 * AVX-512 (a pixel's 16 samples in one pass instead of four: the divisions and the
 * square root of a group, latency-bound in four-lane steps, overlap), two groups at a
 * time where there are two (sample_ray_groups). Returns the samples done (a multiple of
 * 16). */
__attribute__((target("avx512f"))) static int sample_rays_avx512(const Camera *c, int x, int y,
                                                                 const float *xy, int n,
                                                                 int width, int height,
                                                                 Ray *rays)
{
    SampleRayConsts K;
    sample_ray_consts(c, width, height, &K);
    const int px[2] = {x, x}, py[2] = {y, y};
    int k = 0;
    for (; k + 32 <= n; k += 32) {
        const float *p[2] = {xy + 2 * k, xy + 2 * k + 32};
        Ray *r[2] = {rays + k, rays + k + 16};
        sample_ray_groups(&K, 2, px, py, p, r);
    }
    if (k + 16 <= n) {
        const float *p[1] = {xy + 2 * k};
        Ray *r[1] = {rays + k};
        sample_ray_groups(&K, 1, px, py, p, r);
        k += 16;
    }
    return k;
}

/* camera_sample_rays_pixels' lanes: pixels two at a time. */
__attribute__((target("avx512f"))) static void sample_rays_pixels_avx512(
    const Camera *c, int npx, const int *x, const int *y, const float *const *xy, int width,
    int height, Ray *rays)
{
    SampleRayConsts K;
    sample_ray_consts(c, width, height, &K);
    int i = 0;
    for (; i + 2 <= npx; i += 2) {
        Ray *r[2] = {rays + 16 * i, rays + 16 * i + 16};
        sample_ray_groups(&K, 2, x + i, y + i, xy + i, r);
    }
    if (i < npx) {
        Ray *r[1] = {rays + 16 * i};
        sample_ray_groups(&K, 1, x + i, y + i, xy + i, r);
    }
}
#define HAVE_SAMPLE_RAYS_AVX512 1
#endif

#if defined(__x86_64__) && defined(__GNUC__)
/* sample_rays_avx512 eight samples at a time, for CPUs with AVX2 (the SSE lanes'
 * divisions and square root, latency-bound in four-lane steps, in half as many
 * steps): the same IEEE single operations in the same order in every lane (no FMA:
 * -ffp-contract=off and intrinsics only). Returns the samples done (a multiple of 8). */
/* With pos (sample_rays_put_avx2), each sample's position pair also goes to
 * pos + k * stride and that address to dest[k] (the film's scratch and its packet's
 * destinations), from the pair vectors the rays are made from: the film's own pass
 * over the samples, and this function's set-up per call, saved. */
__attribute__((always_inline, target("avx2"))) static inline int
sample_rays_avx2_body(const Camera *c, int x, int y, const float *xy, int n, int width,
                      int height, Ray *rays, float *pos, size_t stride, float **dest)
{
    float s = (float)(width > height ? width : height);
    __m256 S = _mm256_set1_ps(s);
    __m256 ox = _mm256_set1_ps((float)x), oy = _mm256_set1_ps((float)y);
    __m256 cx = _mm256_set1_ps((s - (float)width) * 0.5f);
    __m256 cy = _mm256_set1_ps((s - (float)height) * 0.5f);
    Vec3 ll = c->lower_left, xa = c->x_axis, ya = c->y_axis, e = c->center;
    __m256 ez = _mm256_set1_ps(e.z);
    _Static_assert(sizeof(Ray) == 6 * sizeof(float), "a ray is six packed floats");
    int k = 0;
    for (; k + 8 <= n; k += 8) {
        __m256 a = _mm256_loadu_ps(xy + 2 * k), b = _mm256_loadu_ps(xy + 2 * k + 8);
        if (pos) {
            /* Pairs 0..3 are a's 64-bit quarters, 4..7 b's: one 8-byte store each; the
             * eight addresses as two vectors of four. */
            float *p = pos + (size_t)k * stride;
            /* Written out: gcc kept a loop over the halves (and the halves in memory). */
#define RT_PAIRS(H, Q)                                                                     \
    _mm_storel_pi((__m64 *)(void *)(p + 2 * (H) * stride), (Q));                           \
    _mm_storeh_pi((__m64 *)(void *)(p + (2 * (H) + 1) * stride), (Q))
            RT_PAIRS(0, _mm256_castps256_ps128(a));
            RT_PAIRS(1, _mm256_extractf128_ps(a, 1));
            RT_PAIRS(2, _mm256_castps256_ps128(b));
            RT_PAIRS(3, _mm256_extractf128_ps(b, 1));
#undef RT_PAIRS
            long long s4 = (long long)(stride * sizeof(float));
            __m256i lo = _mm256_add_epi64(_mm256_set1_epi64x((long long)(uintptr_t)p),
                                          _mm256_setr_epi64x(0, s4, 2 * s4, 3 * s4));
            _mm256_storeu_si256((__m256i *)(void *)(dest + k), lo);
            _mm256_storeu_si256((__m256i *)(void *)(dest + k + 4),
                                _mm256_add_epi64(lo, _mm256_set1_epi64x(4 * s4)));
        }
        /* Even floats (x) and odd ones (y) of the eight pairs: in the order of samples
         * 0 1 4 5 | 2 3 6 7 per 128-bit half, put back in order by the 64-bit permute. */
        __m256 px = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0));
        __m256 py = _mm256_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1));
        px = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(px), 0xd8));
        py = _mm256_castpd_ps(_mm256_permute4x64_pd(_mm256_castps_pd(py), 0xd8));
        __m256 u = _mm256_div_ps(_mm256_add_ps(_mm256_add_ps(ox, px), cx), S);
        __m256 v = _mm256_div_ps(_mm256_add_ps(_mm256_add_ps(oy, py), cy), S);
#define RT_AXIS(L, X, Y, E)                                                                \
    _mm256_sub_ps(_mm256_add_ps(_mm256_add_ps(_mm256_set1_ps(L),                           \
                                              _mm256_mul_ps(_mm256_set1_ps(X), u)),        \
                                _mm256_mul_ps(_mm256_set1_ps(Y), v)),                      \
                  _mm256_set1_ps(E))
        __m256 dx = RT_AXIS(ll.x, xa.x, ya.x, e.x);
        __m256 dy = RT_AXIS(ll.y, xa.y, ya.y, e.y);
        __m256 dz = RT_AXIS(ll.z, xa.z, ya.z, e.z);
#undef RT_AXIS
        __m256 l = _mm256_sqrt_ps(_mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(dx, dx), _mm256_mul_ps(dy, dy)), _mm256_mul_ps(dz, dz)));
        /* l > 0: d / l; otherwise d itself (as unit_by_division). */
        __m256 gt = _mm256_cmp_ps(l, _mm256_setzero_ps(), _CMP_GT_OQ);
        __m256 qx = _mm256_blendv_ps(dx, _mm256_div_ps(dx, l), gt);
        __m256 qy = _mm256_blendv_ps(dy, _mm256_div_ps(dy, l), gt);
        __m256 qz = _mm256_blendv_ps(dz, _mm256_div_ps(dz, l), gt);
        /* Ray i's floats 2..5 are (eye.z, dir): the columns of the 4 x 8 rows eye.z,
         * qx, qy, qz, a 4 x 4 transpose per 128-bit half (rays i and i + 4); floats
         * 0..1 are eye.x, eye.y. */
        __m256 t0 = _mm256_unpacklo_ps(ez, qy), t1 = _mm256_unpacklo_ps(qx, qz);
        __m256 t2 = _mm256_unpackhi_ps(ez, qy), t3 = _mm256_unpackhi_ps(qx, qz);
        /* Written out (as the pairs above): the four columns stay in registers. */
#define RT_RAYS(I, COL)                                                                    \
    do {                                                                                   \
        __m256 col_ = (COL);                                                               \
        float *r0 = (float *)&rays[k + (I)], *r1 = (float *)&rays[k + (I) + 4];            \
        memcpy(r0, &e.x, 2 * sizeof(float));                                               \
        memcpy(r1, &e.x, 2 * sizeof(float));                                               \
        _mm_storeu_ps(r0 + 2, _mm256_castps256_ps128(col_));                               \
        _mm_storeu_ps(r1 + 2, _mm256_extractf128_ps(col_, 1));                             \
    } while (0)
        RT_RAYS(0, _mm256_unpacklo_ps(t0, t1));
        RT_RAYS(1, _mm256_unpackhi_ps(t0, t1));
        RT_RAYS(2, _mm256_unpacklo_ps(t2, t3));
        RT_RAYS(3, _mm256_unpackhi_ps(t2, t3));
#undef RT_RAYS
    }
    return k;
}

__attribute__((target("avx2"))) static int sample_rays_avx2(const Camera *c, int x, int y,
                                                            const float *xy, int n, int width,
                                                            int height, Ray *rays)
{
    return sample_rays_avx2_body(c, x, y, xy, n, width, height, rays, NULL, 0, NULL);
}

__attribute__((target("avx2"))) static int sample_rays_put_avx2(const Camera *c, int x, int y,
                                                                const float *xy, int n,
                                                                int width, int height,
                                                                Ray *rays, float *pos,
                                                                size_t stride, float **dest)
{
    return sample_rays_avx2_body(c, x, y, xy, n, width, height, rays, pos, stride, dest);
}
#define HAVE_SAMPLE_RAYS_AVX2 1
#endif

/* Which copy of camera_sample_rays' lanes runs: -1 the widest this CPU has, else the
 * one camera_sample_rays_use_kernel chose (0 SSE, 1 AVX2, 2 AVX-512). Written only
 * there (tests, before any render thread), read on every call. */
static int sample_isa = -1;

bool camera_sample_rays_use_kernel(const char *isa)
{
    static const char *const names[] = {"base", "avx2", "avx512"};
    for (int i = 0; i < 3; i++)
        if (!strcmp(isa, names[i]) && cpu_runs(isa)) {
#ifndef HAVE_SAMPLE_RAYS_AVX2
            if (i == 1)
                return false;
#endif
#ifndef HAVE_SAMPLE_RAYS_AVX512
            if (i == 2)
                return false;
#endif
            sample_isa = i;
            return true;
        }
    return false;
}

void camera_sample_rays_pixels(const Camera *c, int npx, const int *x, const int *y,
                               const float *const *xy, int width, int height, Ray *rays)
{
#ifdef HAVE_SAMPLE_RAYS_AVX512
    int isa = sample_isa >= 0 ? sample_isa : cpu_has_avx512() ? 2 : 0;
    if (c->kind == CAMERA_PERSPECTIVE && !c->far_eye && isa == 2) {
        sample_rays_pixels_avx512(c, npx, x, y, xy, width, height, rays);
        return;
    }
#endif
    for (int i = 0; i < npx; i++)
        camera_sample_rays(c, x[i], y[i], xy[i], 16, width, height, rays + 16 * i);
}

void camera_sample_rays(const Camera *c, int x, int y, const float *xy, int n, int width,
                        int height, Ray *rays)
{
    if (c->far_eye) {
        /* camera_generate_ray's own form, one ray at a time: the lanes below aim in
         * world space (rt/camera.h). */
        for (int k = 0; k < n; k++) {
            float u, v;
            camera_sample_to_screen(x, y, xy[2 * k], xy[2 * k + 1], width, height, &u, &v);
            rays[k] = camera_generate_ray(c, u, v);
        }
        return;
    }
    int k = 0;
    /* Asked on every call (a load), as camera_pixel_rays does. */
    int isa = sample_isa >= 0 ? sample_isa : cpu_has_avx512() ? 2 : cpu_has_avx2() ? 1 : 0;
#ifdef HAVE_SAMPLE_RAYS_AVX512
    if (c->kind == CAMERA_PERSPECTIVE && n >= 16 && isa == 2)
        k = sample_rays_avx512(c, x, y, xy, n, width, height, rays);
#endif
#ifdef HAVE_SAMPLE_RAYS_AVX2
    /* After AVX-512's groups of 16, a group of 8 of them may remain. */
    if (c->kind == CAMERA_PERSPECTIVE && n - k >= 8 && isa >= 1)
        k += sample_rays_avx2(c, x, y, xy + 2 * k, n - k, width, height, rays + k);
#endif
#if defined(__SSE2__)
    if (c->kind == CAMERA_PERSPECTIVE) {
        /* camera_sample_to_screen and camera_generate_ray for four samples at once: the
         * same IEEE single operations in the same order in every lane (sqrt and
         * division are correctly rounded in SSE as in scalar code). */
        float s = (float)(width > height ? width : height);
        __m128 S = _mm_set1_ps(s);
        __m128 ox = _mm_set1_ps((float)x), oy = _mm_set1_ps((float)y);
        __m128 cx = _mm_set1_ps((s - (float)width) * 0.5f);
        __m128 cy = _mm_set1_ps((s - (float)height) * 0.5f);
        Vec3 ll = c->lower_left, xa = c->x_axis, ya = c->y_axis, e = c->center;
        for (; k + 4 <= n; k += 4) {
            __m128 a = _mm_loadu_ps(xy + 2 * k), b = _mm_loadu_ps(xy + 2 * k + 4);
            __m128 px = _mm_shuffle_ps(a, b, _MM_SHUFFLE(2, 0, 2, 0));
            __m128 py = _mm_shuffle_ps(a, b, _MM_SHUFFLE(3, 1, 3, 1));
            __m128 u = _mm_div_ps(_mm_add_ps(_mm_add_ps(ox, px), cx), S);
            __m128 v = _mm_div_ps(_mm_add_ps(_mm_add_ps(oy, py), cy), S);
#define RT_AXIS(L, X, Y, E)                                                                \
    _mm_sub_ps(_mm_add_ps(_mm_add_ps(_mm_set1_ps(L), _mm_mul_ps(_mm_set1_ps(X), u)),        \
                          _mm_mul_ps(_mm_set1_ps(Y), v)),                                  \
               _mm_set1_ps(E))
            __m128 dx = RT_AXIS(ll.x, xa.x, ya.x, e.x);
            __m128 dy = RT_AXIS(ll.y, xa.y, ya.y, e.y);
            __m128 dz = RT_AXIS(ll.z, xa.z, ya.z, e.z);
#undef RT_AXIS
            __m128 l = _mm_sqrt_ps(_mm_add_ps(_mm_add_ps(_mm_mul_ps(dx, dx), _mm_mul_ps(dy, dy)),
                                              _mm_mul_ps(dz, dz)));
            /* l > 0: d / l; otherwise d itself (as unit_by_division). */
            __m128 pos = _mm_cmpgt_ps(l, _mm_setzero_ps());
            __m128 qx = _mm_div_ps(dx, l), qy = _mm_div_ps(dy, l), qz = _mm_div_ps(dz, l);
            qx = _mm_or_ps(_mm_and_ps(pos, qx), _mm_andnot_ps(pos, dx));
            qy = _mm_or_ps(_mm_and_ps(pos, qy), _mm_andnot_ps(pos, dy));
            qz = _mm_or_ps(_mm_and_ps(pos, qz), _mm_andnot_ps(pos, dz));
            float fx[4], fy[4], fz[4];
            _mm_storeu_ps(fx, qx);
            _mm_storeu_ps(fy, qy);
            _mm_storeu_ps(fz, qz);
            for (int i = 0; i < 4; i++) {
                rays[k + i].origin = e;
                rays[k + i].dir = v3(fx[i], fy[i], fz[i]);
            }
        }
    }
#endif
    for (; k < n; k++) {
        float u, v;
        camera_sample_to_screen(x, y, xy[2 * k], xy[2 * k + 1], width, height, &u, &v);
        rays[k] = camera_generate_ray(c, u, v);
    }
}

void camera_sample_rays_put(const Camera *c, int x, int y, const float *xy, int n, int width,
                            int height, Ray *rays, float *pos, size_t stride, float **dest)
{
    int k = 0;
#ifdef HAVE_SAMPLE_RAYS_AVX2
    /* The AVX2 lanes whenever the CPU has them (camera_sample_rays_use_kernel("base")
     * for the other path): the caller asks for this only where it would otherwise
     * take them through camera_sample_rays. */
    int isa = sample_isa >= 0 ? sample_isa : cpu_has_avx2() ? 1 : 0;
    if (c->kind == CAMERA_PERSPECTIVE && !c->far_eye && n >= 8 && isa >= 1)
        k = sample_rays_put_avx2(c, x, y, xy, n, width, height, rays, pos, stride, dest);
#endif
    if (k < n)
        camera_sample_rays(c, x, y, xy + 2 * k, n - k, width, height, rays + k);
    for (; k < n; k++) {
        float *p = pos + (size_t)k * stride;
        p[0] = xy[2 * k];
        p[1] = xy[2 * k + 1];
        dest[k] = p;
    }
}

float camera_tmin(const Camera *c)
{
    /* Orthographic cameras see behind the image plane (A1 scene1_07); a finite
     * stand-in for -infinity keeps the grid's arithmetic free of inf - inf. */
    return c->kind == CAMERA_ORTHOGRAPHIC ? -FLT_MAX : 0.0f;
}

void camera_pixel_to_screen(int i, int j, int width, int height, float *u, float *v)
{
    camera_sample_to_screen(i, j, 0.5f, 0.5f, width, height, u, v);
}

void camera_sample_to_screen(int i, int j, float px, float py, int width, int height,
                             float *u, float *v)
{
    /* In float and in this order, so (0.5, 0.5) is the pixel-centre ray to the bit:
     * the point's offset from the square screen's left (bottom) edge over its size.
     * The older form ((i + px) - W/2) / S + 0.5 is the same number but rounds
     * differently, and the official images follow this one (docs/camera.md). */
    float s = (float)(width > height ? width : height);
    *u = ((float)i + px + (s - (float)width) * 0.5f) / s;
    *v = ((float)j + py + (s - (float)height) * 0.5f) / s;
}
