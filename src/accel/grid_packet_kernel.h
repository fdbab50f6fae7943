/* The packet walk and its per-ray set-up, written once and compiled once per kernel:
 * by grid_packet.c for the baseline instruction set, by grid_packet_avx2.c for AVX2 and
 * by grid_packet_avx512.c for AVX-512. The includer defines PK_WALK, PK_PREP and
 * PK_SPREAD (the functions' names) and optionally PK_W, the lanes of one ray group (8,
 * the default, or 16), and includes this file once. The Packet's columns are the same
 * memory for either width: group gi of width W is rays [W gi, W gi + W).
 *
 * Coherent grid traversal (Wald, Ize, Kensler, Knoll, Parker, SIGGRAPH 2006): the
 * packet advances one slice of cells at a time along its main axis K. In a slice, the
 * rays' parts between the slice's two planes span a rectangle of cells in the other two
 * axes; every primitive of those cells is tested against every ray in the slice. A ray
 * leaves the walk when its best hit lies before the slice's far plane (nothing nearer
 * can be in a later slice: the argument of grid_intersect's step 3, made per slice) or
 * when it leaves the box. Each ray therefore tests a superset of the primitives its own
 * march would test, in another order; hit_accepts' (t, id) order makes the answer
 * independent of the order, and each test is triangle_ray_t's arithmetic lane by lane
 * (IEEE add, sub, mul, div in the same order, never fused), so the answers are bit for
 * bit those of the single-ray query. */

#include <float.h>
#include <stddef.h>
#include <math.h>
#include <string.h>

#if defined(__AVX__)
#include <immintrin.h>
#elif defined(__SSE2__)
#include <emmintrin.h>
#endif

/* The 8-lane helpers below are always inlined, so no vector crosses a call and the
 * ABI note GCC gives for 32-byte vectors without AVX does not apply. */
#pragma GCC diagnostic ignored "-Wpsabi"

#define PK_INLINE static inline __attribute__((always_inline))

#ifndef PK_W
#define PK_W 8
#endif
#if PK_W == 8
#define PK_REP(x) x, x, x, x, x, x, x, x
#elif PK_W == 16
#define PK_REP(x) x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x
#else
#error "PK_W is 8 or 16"
#endif
#define PK_NG (GRID_PACKET_MAX / PK_W)   /* ray groups of a packet */
#define PK_BATCH 32                      /* a cell's entries culled at a time */
#define PK_WMASK ((1u << PK_W) - 1u)     /* a group's bits in a 64-bit ray mask */

/* A group's lanes, and the same types for reading and writing the Packet's columns
 * (pk_f8 arrays, grid_packet.h) as groups of PK_W: may_alias. */
typedef float pk_fv __attribute__((vector_size(4 * PK_W)));
typedef int32_t pk_iv __attribute__((vector_size(4 * PK_W)));
typedef uint32_t pk_uv __attribute__((vector_size(4 * PK_W)));
typedef float pk_fv_mem __attribute__((vector_size(4 * PK_W), may_alias));
typedef int32_t pk_iv_mem __attribute__((vector_size(4 * PK_W), may_alias));
typedef uint32_t pk_uv_mem __attribute__((vector_size(4 * PK_W), may_alias));
#define PKF(col, gi) (((pk_fv_mem *)(col))[gi])
#define PKI(col, gi) (((pk_iv_mem *)(col))[gi])
#define PKU(col, gi) (((pk_uv_mem *)(col))[gi])

PK_INLINE pk_fv pk_splat(float x) { return (pk_fv){PK_REP(x)}; }
PK_INLINE pk_iv pk_spliti(int32_t x) { return (pk_iv){PK_REP(x)}; }
PK_INLINE pk_f8 pk8_splat(float x) { return (pk_f8){x, x, x, x, x, x, x, x}; }

PK_INLINE pk_fv pk_blend(pk_iv m, pk_fv a, pk_fv b) /* m ? a : b, lane by lane */
{
    return (pk_fv)((m & (pk_iv)a) | (~m & (pk_iv)b));
}

PK_INLINE pk_f8 pk8_blend(pk_i8 m, pk_f8 a, pk_f8 b)
{
    return (pk_f8)((m & (pk_i8)a) | (~m & (pk_i8)b));
}

/* a < b ? a : b and a > b ? a : b, lane by lane: exactly what the x86 min and max
 * instructions compute (the second operand when the comparison is false: equal
 * values, or a NaN on either side). */
#if defined(__AVX__)
PK_INLINE pk_f8 pk8_min(pk_f8 a, pk_f8 b) { return (pk_f8)_mm256_min_ps((__m256)a, (__m256)b); }
PK_INLINE pk_f8 pk8_max(pk_f8 a, pk_f8 b) { return (pk_f8)_mm256_max_ps((__m256)a, (__m256)b); }
#else
PK_INLINE pk_f8 pk8_min(pk_f8 a, pk_f8 b) { return pk8_blend(a < b, a, b); }
PK_INLINE pk_f8 pk8_max(pk_f8 a, pk_f8 b) { return pk8_blend(a > b, a, b); }
#endif
#if PK_W == 8
PK_INLINE pk_fv pk_min(pk_fv a, pk_fv b) { return pk8_min(a, b); }
PK_INLINE pk_fv pk_max(pk_fv a, pk_fv b) { return pk8_max(a, b); }
#elif defined(__AVX512F__)
PK_INLINE pk_fv pk_min(pk_fv a, pk_fv b) { return (pk_fv)_mm512_min_ps((__m512)a, (__m512)b); }
PK_INLINE pk_fv pk_max(pk_fv a, pk_fv b) { return (pk_fv)_mm512_max_ps((__m512)a, (__m512)b); }
#else
PK_INLINE pk_fv pk_min(pk_fv a, pk_fv b) { return pk_blend(a < b, a, b); }
PK_INLINE pk_fv pk_max(pk_fv a, pk_fv b) { return pk_blend(a > b, a, b); }
#endif

/* Bit l set when lane l of m (8 lanes) is set. */
PK_INLINE unsigned pk8_bits(pk_i8 m)
{
#if defined(__AVX__)
    return (unsigned)_mm256_movemask_ps((__m256)m);
#elif defined(__SSE2__)
    __m128 lo, hi;
    memcpy(&lo, &m, sizeof lo);
    memcpy(&hi, (const char *)&m + sizeof lo, sizeof hi);
    return (unsigned)_mm_movemask_ps(lo) | (unsigned)_mm_movemask_ps(hi) << 4;
#else
    unsigned r = 0;
    for (int l = 0; l < 8; l++)
        r |= (unsigned)(m[l] & 1) << l;
    return r;
#endif
}

/* ... and of a group's lanes. */
PK_INLINE unsigned pk_bits(pk_iv m)
{
#if PK_W == 8
    return pk8_bits(m);
#elif defined(__AVX512DQ__)
    return (unsigned)_mm512_movepi32_mask((__m512i)m);
#else
    return pk8_bits(__builtin_shufflevector(m, m, 0, 1, 2, 3, 4, 5, 6, 7)) |
           pk8_bits(__builtin_shufflevector(m, m, 8, 9, 10, 11, 12, 13, 14, 15)) << 8;
#endif
}

/* The lane mask of a group's bits. */
PK_INLINE pk_iv pk_lanes(unsigned bits)
{
#if PK_W == 8
    const pk_iv bit = {1, 2, 4, 8, 16, 32, 64, 128};
#else
    const pk_iv bit = {1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384, 32768};
#endif
    return (pk_spliti((int32_t)bits) & bit) != pk_spliti(0);
}

/* The smallest and the largest lane (no NaN lanes; of +0 and -0 either may come out,
 * which compare and convert to cells alike). A tree of halves: 3 steps for 8 lanes. */
PK_INLINE float pk8_hmin(pk_f8 v)
{
    v = pk8_min(v, __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3));
    v = pk8_min(v, __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5));
    v = pk8_min(v, __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6));
    return v[0];
}

PK_INLINE float pk8_hmax(pk_f8 v)
{
    v = pk8_max(v, __builtin_shufflevector(v, v, 4, 5, 6, 7, 0, 1, 2, 3));
    v = pk8_max(v, __builtin_shufflevector(v, v, 2, 3, 0, 1, 6, 7, 4, 5));
    v = pk8_max(v, __builtin_shufflevector(v, v, 1, 0, 3, 2, 5, 4, 7, 6));
    return v[0];
}

#if PK_W == 8
PK_INLINE pk_f8 pk_lo8(pk_fv v) { return v; }
PK_INLINE float pk_hmin(pk_fv v) { return pk8_hmin(v); }
PK_INLINE float pk_hmax(pk_fv v) { return pk8_hmax(v); }
#else
/* The two 8-lane halves of a 16-lane group (the cull's ray groups are 8 rays). */
PK_INLINE pk_f8 pk_lo8(pk_fv v) { return __builtin_shufflevector(v, v, 0, 1, 2, 3, 4, 5, 6, 7); }
PK_INLINE pk_f8 pk_hi8(pk_fv v)
{
    return __builtin_shufflevector(v, v, 8, 9, 10, 11, 12, 13, 14, 15);
}
PK_INLINE float pk_hmin(pk_fv v) { return pk8_hmin(pk8_min(pk_lo8(v), pk_hi8(v))); }
PK_INLINE float pk_hmax(pk_fv v) { return pk8_hmax(pk8_max(pk_lo8(v), pk_hi8(v))); }
#endif

PK_INLINE pk_fv pk_abs(pk_fv x)
{
    const pk_iv m = pk_spliti(0x7fffffff);
    return (pk_fv)((pk_iv)x & m);
}

/* march_cell_of lane by lane (lanes outside the slice may hold anything: clamped). */
PK_INLINE pk_iv pk_cells(pk_fv x, float lo, float inv_size, int n)
{
    pk_fv f = (x - lo) * inv_size;
    f = pk_max(f, pk_splat(0.0f)); /* a NaN lane compares false and becomes 0 */
    f = pk_min(f, pk_splat((float)(n - 1)));
    return __builtin_convertvector(f, pk_iv);
}

/* The packet walk's triangle cull (Wald et al. 2006 cull a slice's triangles against
 * the packet's frustum; this is the same idea per group of rays, against the slice's
 * box of each group). The grid's own rule: the point o + t*d of a hit lies within
 * the rounding pad of the triangle (the march stops at a cell's exit on it, and the
 * cells were filled with that pad), i.e. within its padded box (TriBox). In a slice, a
 * ray's part lies in its rectangle (its ends across the slice, widened by the pad for
 * the rounding of o + t*d, as for its cells). So when a group's rectangle (the union
 * of its rays') misses the padded box in U or V, no ray of the group has its hit with
 * this triangle in this slice: a hit of theirs lies in another slice, in a cell that
 * holds the triangle and that the ray's rectangle covers there, where it is tested
 * (the triangle is marked only for the rays that test it; a ray leaves the walk only
 * when its best hit is nearer than any later slice). The answers do not change; only
 * tests that cannot succeed are skipped. Returns the 64-bit mask of the rays in groups
 * that may hit it. Lane gi of the rectangles is group gi. */
_Static_assert(GRID_PACKET_MAX == 64, "the cull holds one group of 8 rays per lane");
/* Entry b: byte gi all ones where bit gi of b is set (groups to rays). */
#define PK_GR1(b) (((b) & 1 ? 0xffull : 0) | ((b) & 2 ? 0xff00ull : 0) |                       \
                   ((b) & 4 ? 0xff0000ull : 0) | ((b) & 8 ? 0xff000000ull : 0) |               \
                   ((b) & 16 ? 0xff00000000ull : 0) | ((b) & 32 ? 0xff0000000000ull : 0) |     \
                   ((b) & 64 ? 0xff000000000000ull : 0) | ((b) & 128 ? 0xff00000000000000ull : 0))
#define PK_GR4(b) PK_GR1(b), PK_GR1(b + 1), PK_GR1(b + 2), PK_GR1(b + 3)
#define PK_GR16(b) PK_GR4(b), PK_GR4(b + 4), PK_GR4(b + 8), PK_GR4(b + 12)
#define PK_GR64(b) PK_GR16(b), PK_GR16(b + 16), PK_GR16(b + 32), PK_GR16(b + 48)
static const uint64_t pk_group_rays[256] = {PK_GR64(0), PK_GR64(64), PK_GR64(128),
                                            PK_GR64(192)};
#undef PK_GR64
#undef PK_GR16
#undef PK_GR4
#undef PK_GR1
PK_INLINE uint64_t pk_cull(const TriBox *b, int U, int V, pk_f8 gu0, pk_f8 gu1, pk_f8 gv0,
                           pk_f8 gv1)
{
    pk_i8 over = (pk8_splat(b->lo[U]) <= gu1) & (pk8_splat(b->hi[U]) >= gu0) &
                 (pk8_splat(b->lo[V]) <= gv1) & (pk8_splat(b->hi[V]) >= gv0);
    return pk_group_rays[pk8_bits(over)];
}

/* The cull of a packet whose rays all have one direction d (shadow rays towards a
 * directional light), a beam: besides the slice rectangles above, its rays against the
 * triangle's padded box seen along d. F(p) = p_U - p_K r_U and G(p) = p_V - p_K r_V
 * (r = d_U / d_K, d_V / d_K) stay (nearly) constant along a ray, so a ray whose line
 * meets the box has F(o), G(o) within the box's range of F, G (widened by the rounding
 * margin: PK_WALK); a ray outside it has no hit on the triangle anywhere (the grid's
 * rule above: a hit lies within the padded box). The box's range: F is linear, its
 * extremes at the box's K sides. Each group of 8 rays' range of F(o), G(o) (bu0 ..
 * bv1, lane j for rays [8 j, 8 j + 8)) is made once a walk. (Also ray by ray, before a
 * triangle's test: more instructions than the tests it saved on the blob and the
 * bunny, callgrind.)
 * Which K side gives the larger product with r_U is the sign of r_U, the same for the
 * whole walk (rounding is monotone: lo_K <= hi_K and r_U >= 0 give lo_K r_U <= hi_K
 * r_U), so PkBeam holds the sides' places, chosen once a walk, instead of a comparison
 * and a select per triangle: the same products and differences as before, 3.6% fewer
 * instructions in the blob's shadow pass. (The eight numbers made as one vector, a
 * permute of the box's last 32 bytes, took fewer instructions still but more time on
 * Zen 3, broadcast either by shuffles or through memory; see bench/REPORT.txt.) */
typedef struct PkBeam {
    float ru, rv;
    /* Byte offsets in a TriBox of the K side whose product with ru (rv) is the larger
     * (x) and the smaller (n). */
    uint32_t kxu, knu, kxv, knv;
} PkBeam;

PK_INLINE PkBeam pk_beam_make(int K, float ru, float rv)
{
    const uint32_t lo_k = (uint32_t)(offsetof(TriBox, lo) + (size_t)K * sizeof(float));
    const uint32_t hi_k = (uint32_t)(offsetof(TriBox, hi) + (size_t)K * sizeof(float));
    PkBeam bm = {ru, rv, ru >= 0.0f ? hi_k : lo_k, ru >= 0.0f ? lo_k : hi_k,
                 rv >= 0.0f ? hi_k : lo_k, rv >= 0.0f ? lo_k : hi_k};
    return bm;
}

/* The box's number at byte offset off (PkBeam's places). */
PK_INLINE float pk_box_at(const TriBox *b, uint32_t off)
{
    return *(const float *)(const void *)((const char *)b + off);
}

PK_INLINE uint64_t pk_cull_beam(const TriBox *b, const PkBeam *bm, int U, int V, pk_f8 gu0,
                                pk_f8 gu1, pk_f8 gv0, pk_f8 gv1, pk_f8 bu0, pk_f8 bu1,
                                pk_f8 bv0, pk_f8 bv1)
{
    const float r0 = b->lo[U] - pk_box_at(b, bm->kxu) * bm->ru;
    const float r1 = b->hi[U] - pk_box_at(b, bm->knu) * bm->ru;
    const float r2 = b->lo[V] - pk_box_at(b, bm->kxv) * bm->rv;
    const float r3 = b->hi[V] - pk_box_at(b, bm->knv) * bm->rv;
    pk_i8 over = (pk8_splat(b->lo[U]) <= gu1) & (pk8_splat(b->hi[U]) >= gu0) &
                 (pk8_splat(b->lo[V]) <= gv1) & (pk8_splat(b->hi[V]) >= gv0) &
                 (pk8_splat(r0) <= bu1) & (pk8_splat(r1) >= bu0) &
                 (pk8_splat(r2) <= bv1) & (pk8_splat(r3) >= bv0);
    return pk_group_rays[pk8_bits(over)];
}

/* One bit per group of `rays` with a ray in it (a group's top bit): sum each group's
 * low bits with all ones below the top, so a carry reaches the top bit exactly when
 * one of them is set, and or in the top bits themselves. */
#if PK_W == 8
#define PK_GROUP_LOW 0x7f7f7f7f7f7f7f7full
#else
#define PK_GROUP_LOW 0x7fff7fff7fff7fffull
#endif
PK_INLINE uint64_t pk_groups_of(uint64_t rays)
{
    return (((rays & PK_GROUP_LOW) + PK_GROUP_LOW) | rays) & ~PK_GROUP_LOW;
}

/* Packed triangle p against the rays of `want` (a 64-bit ray mask). */
PK_INLINE void pk_test_tri(const Grid *g, Packet *pk, uint32_t p, uint64_t want)
{
    const PackedTri *pt = &g->tri[p];
    const float v0x = pt->v0.x, v0y = pt->v0.y, v0z = pt->v0.z;
    const float e1x = pt->e1.x, e1y = pt->e1.y, e1z = pt->e1.z;
    const float e2x = pt->e2.x, e2y = pt->e2.y, e2z = pt->e2.z;
    const pk_fv zero = pk_splat(0.0f), one = pk_splat(1.0f), tmin = pk_splat(pk->tmin);
    const pk_fv lo = pk_splat(-RT_TRI_EDGE_TOL), hi = pk_splat(1.0f + RT_TRI_FAR_TOL);
    const uint32_t id = pt->id;
    if (pk->same_dir && pk->shadow) {
        /* Every ray has direction pk->dir (shadow rays towards a directional light,
         * whose walked lanes hold it in pk->d): the direction's half of the formula
         * (d x e2, det and its reciprocal) once for the triangle, the same lanes the
         * groups would each make. */
        const pk_fv dx = pk_splat(pk->dir[0]), dy = pk_splat(pk->dir[1]),
                    dz = pk_splat(pk->dir[2]);
        RT_MT_DIR(pk_fv, one, dx, dy, dz, e1x, e1y, e1z, e2x, e2y, e2z, px, py, pz, det, inv);
        /* det is the same in every lane: det == 0 fails every lane's test. */
        if (det[0] == 0.0f)
            return;
        const pk_fv tmax = pk_splat(pk->same_tmax); /* every lane's best_t */
        /* Only the groups with rays to test, by their bits; a lane outside `want` is
         * dropped from the answer's bits after the test (its lanes are harmless
         * numbers, grid_packet.c). */
        for (uint64_t gm = pk_groups_of(want); gm; gm &= gm - 1) {
            const int gi = __builtin_ctzll(gm) / PK_W;
            const unsigned bits = (unsigned)(want >> (PK_W * gi)) & PK_WMASK;
            RT_MT_ORIGIN(pk_fv, PKF(pk->o[0], gi), PKF(pk->o[1], gi), PKF(pk->o[2], gi), dx, dy,
                         dz, v0x, v0y, v0z, e1x, e1y, e1z, e2x, e2y, e2z, px, py, pz, inv, u, v,
                         t);
            /* hit_accepts against (tmax, id 0): exactly t < tmax (as below) */
            pk_iv ok = (u >= lo) & (v >= lo) & (u + v <= hi) & (t > tmin) & (t < tmax);
            unsigned hitb = pk_bits(ok) & bits;
            if (hitb)
                pk->hit |= (uint64_t)hitb << (PK_W * gi);
        }
        return;
    }
    for (uint64_t gm = pk_groups_of(want); gm; gm &= gm - 1) {
        const int gi = __builtin_ctzll(gm) / PK_W;
        const unsigned bits = (unsigned)(want >> (PK_W * gi)) & PK_WMASK;
        pk_fv dx = PKF(pk->d[0], gi), dy = PKF(pk->d[1], gi), dz = PKF(pk->d[2], gi);
        /* triangle_ray_t's formula, PK_W lanes wide (rt/geom.h) */
        RT_MOLLER_TRUMBORE(pk_fv, one, PKF(pk->o[0], gi), PKF(pk->o[1], gi), PKF(pk->o[2], gi),
                           dx, dy, dz, v0x, v0y, v0z, e1x, e1y, e1z, e2x, e2y, e2z, det, u, v, t);
        pk_iv ok = (det != zero) & (u >= lo) & (v >= lo) & (u + v <= hi) &
                   (t > tmin) & pk_lanes(bits);
        pk_fv bt = PKF(pk->best_t, gi);
        if (pk->shadow) {
            /* hit_accepts against (tmax, id 0): exactly t < tmax */
            ok &= t < bt;
            unsigned hitb = pk_bits(ok);
            if (hitb)
                pk->hit |= (uint64_t)hitb << (PK_W * gi);
            continue;
        }
        pk_uv bid = PKU(pk->best_id, gi);
        pk_uv idv = {PK_REP(id)};
        ok &= (t < bt) | ((t == bt) & (pk_iv)(idv < bid));
        PKF(pk->best_t, gi) = pk_blend(ok, t, bt);
        PKU(pk->best_id, gi) = (pk_uv)pk_blend(ok, (pk_fv)idv, (pk_fv)bid);
        PKI(pk->best_prim, gi) =
            (pk_iv)pk_blend(ok, (pk_fv)pk_spliti((int32_t)p), (pk_fv)PKI(pk->best_prim, gi));
    }
}

/* Any other primitive (sphere, transformed triangle, ...): its own intersect, ray by
 * ray, through the caller's Hit (nearest), or its occluded op up to the ray's tmax
 * (shadow). Below Transforms, prim_intersect's steps (transform_path_intersect) with the
 * ray carried into object space once per chain and lane (pk->xf): the same
 * arithmetic on the same inputs, so the same bits. */
static void pk_test_prim(const Grid *g, Packet *pk, uint32_t p, uint64_t want, RenderCtx *ctx)
{
    const GridPrim *gp = &g->prims[p];
    const PrimXform *xf = gp->xf;
    if (xf && xf != pk->xf) {
        pk->xf = xf;
        pk->xf_lanes = 0;
    }
    while (want) {
        int i = __builtin_ctzll(want);
        want &= want - 1;
        int gi = i / PK_LANES, l = i % PK_LANES;
        const Ray r = packet_ray(pk, i), *ray = &r;
        float tmin = pk->tmin;
        if (xf) {
            uint64_t bit = (uint64_t)1 << i;
            if (!(pk->xf_lanes & bit)) {
                pk->xf_tmin[i] = tmin;
                pk->xf_ray[i] = transform_path_to_object(&xf->path, ray, &pk->xf_tmin[i]);
                pk->xf_lanes |= bit;
            }
            ray = &pk->xf_ray[i];
            tmin = pk->xf_tmin[i];
        }
        if (pk->shadow) {
            if (obj_occluded(gp->obj, ray, tmin, pk->best_t[gi][l], ctx))
                pk->hit |= (uint64_t)1 << i;
            continue;
        }
        Hit *h = &pk->hits[i];
        h->t = pk->best_t[gi][l];
        h->id = pk->best_id[gi][l];
        if (grid_test_local(gp, ray, h, tmin, ctx)) {
            pk->best_t[gi][l] = h->t;
            pk->best_id[gi][l] = h->id;
            pk->best_prim[gi][l] = -1;
            pk->hit |= (uint64_t)1 << i;
        }
    }
}

void PK_WALK(const Grid *g, Packet *pk, RenderCtx *ctx)
{
    const int K = pk->axis, U = (K + 1) % 3, V = (K + 2) % 3;
    const float lo_k = v3_comp(g->box.min, K), size_k = g->size[K];
    const float lo_u = v3_comp(g->box.min, U), lo_v = v3_comp(g->box.min, V);
    const float inv_su = 1.0f / g->size[U], inv_sv = 1.0f / g->size[V];
    const float pad_u = g->pad[U], pad_v = g->pad[V];
    const int nk = g->n[K], nu = g->n[U], nv = g->n[V];
    const uint32_t *start = g->cell_start, *items = g->cell_items;
    const uint64_t *occ = g->occupied;
    const PackedTri *prefetch = g->prefetch_tri ? g->tri : NULL;
    const pk_fv inf = pk_splat(INFINITY), ninf = pk_splat(-INFINITY);
    const pk_f8 inf8 = pk8_splat(INFINITY), ninf8 = pk8_splat(-INFINITY);

    /* A beam (every ray has direction pk->dir: shadow rays towards a directional
     * light): each group's range of F(o) = o_U - o_K r_U and G(o) = o_V - o_K r_V
     * (pk_cull_beam), lane j for rays [8 j, 8 j + 8), over the walked rays, widened by
     * the rounding margin. Rounding (u = 2^-24, every coordinate of the origins, the
     * boxes and the hit points at most M, |r| <= R): F(o) and the box's extremes of F
     * are each within u M (1 + 2R) of their real values; a hit point o + t d within
     * 3 u M of the real line, which moves F by at most 3 u M (1 + R); F changes along
     * the line by t (d_U - d_K r_U), at most u |t d_U| <= 2 u M as r_U is d_U / d_K
     * rounded. In all less than 7 u M (1 + R) = 3.5 FLT_EPSILON M (1 + R); the margin
     * is 32 FLT_EPSILON M (1 + R) with M twice the largest of |o| and the box's
     * coordinates (the padded boxes lie within the box and its pad). */
    const bool beam = pk->same_dir && pk->shadow;
    float ru = 0.0f, rv = 0.0f;
    pk_f8 bu0 = ninf8, bu1 = inf8, bv0 = ninf8, bv1 = inf8;
    if (beam) {
        ru = pk->dir[U] / pk->dir[K];
        rv = pk->dir[V] / pk->dir[K];
        const pk_fv fru = pk_splat(ru), frv = pk_splat(rv);
        pk_fv mag = pk_splat(0.0f);
        bu0 = inf8, bu1 = ninf8, bv0 = inf8, bv1 = ninf8;
        for (int gi = 0; gi < PK_NG; gi++) {
            unsigned bits = (unsigned)(pk->active >> (PK_W * gi)) & PK_WMASK;
            if (!bits)
                continue;
            const pk_iv m = pk_lanes(bits);
            const pk_fv ok_ = PKF(pk->o[K], gi), ou = PKF(pk->o[U], gi), ov = PKF(pk->o[V], gi);
            const pk_fv su = ou - ok_ * fru, sv = ov - ok_ * frv;
            const pk_fv su0 = pk_blend(m, su, inf), su1 = pk_blend(m, su, ninf);
            const pk_fv sv0 = pk_blend(m, sv, inf), sv1 = pk_blend(m, sv, ninf);
            mag = pk_max(mag, pk_blend(m, pk_max(pk_abs(ok_), pk_max(pk_abs(ou), pk_abs(ov))),
                                       pk_splat(0.0f)));
            const int j = gi * (PK_W / 8);
            bu0[j] = pk8_hmin(pk_lo8(su0));
            bu1[j] = pk8_hmax(pk_lo8(su1));
            bv0[j] = pk8_hmin(pk_lo8(sv0));
            bv1[j] = pk8_hmax(pk_lo8(sv1));
#if PK_W == 16
            bu0[j + 1] = pk8_hmin(pk_hi8(su0));
            bu1[j + 1] = pk8_hmax(pk_hi8(su1));
            bv0[j + 1] = pk8_hmin(pk_hi8(sv0));
            bv1[j + 1] = pk8_hmax(pk_hi8(sv1));
#endif
        }
        float M = pk_hmax(mag);
        M = 2.0f * (M > g->box_mag ? M : g->box_mag);
        const float mu = 32.0f * FLT_EPSILON * M * (1.0f + fabsf(ru));
        const float mv = 32.0f * FLT_EPSILON * M * (1.0f + fabsf(rv));
        bu0 -= pk8_splat(mu), bu1 += pk8_splat(mu);
        bv0 -= pk8_splat(mv), bv1 += pk8_splat(mv);
    }
    const PkBeam bm = pk_beam_make(K, ru, rv);

    /* Marking as for the single-ray march (on when the context has a mailbox), in the
     * thread's small table (grid_packet.h). */
    PacketMarks *marks = grid_begin_ray(g, ctx) ? grid_packet_marks() : NULL;
    const uint32_t gen = marks ? marks->gen : 0;
    /* Statistics: each ray counts the cells of its own range in every slice, summed
     * lane by lane and added up once at the end. A ray's ranges are disjoint sets of
     * cells, so a lane (at most 8 rays) gains at most 8 x 16M < 2^31 (grids hold at most
     * 16M cells). */
    pk_iv cells_acc = pk_spliti(0);
    uint64_t cells_one = 0;

    for (int k = pk->k_first; k >= 0 && k < nk && pk->active; k += pk->sign) {
        /* The slice's near and far planes; the grid's first and last slices reach out
         * to the padded box (the rays' t0 and t1 bound them there). */
        int b_near = pk->sign > 0 ? k : k + 1, b_far = pk->sign > 0 ? k + 1 : k;
        bool first = pk->sign > 0 ? k == 0 : k == nk - 1;
        bool last = pk->sign > 0 ? k == nk - 1 : k == 0;
        float p_near = lo_k + (float)b_near * size_k, p_far = lo_k + (float)b_far * size_k;

        pk_fv umin = inf, umax = ninf, vmin = inf, vmax = ninf;
        /* Each ray's range across the slice (ray lanes outside the slice: an empty
         * range), kept for the per-ray cells and the group rectangles, both made only
         * when needed. */
        pk_fv ru0[PK_NG], ru1[PK_NG], rv0[PK_NG], rv1[PK_NG];
        pk_fv tfar[PK_NG];
        uint64_t in = 0;
        for (int gi = 0; gi < PK_NG; gi++) {
            unsigned bits = (unsigned)(pk->active >> (PK_W * gi)) & PK_WMASK;
            if (!bits)
                continue;
            pk_fv ok_ = PKF(pk->o[K], gi), inv_k = PKF(pk->inv_k, gi);
            pk_fv ta = first ? ninf : (p_near - ok_) * inv_k;
            pk_fv tb = last ? inf : (p_far - ok_) * inv_k;
            tfar[gi] = tb;
            pk_fv lo = pk_max(ta, PKF(pk->t0, gi));
            pk_fv hi = pk_min(tb, PKF(pk->t1, gi));
            if (!pk->shadow)
                hi = pk_min(hi, PKF(pk->best_t, gi));
            pk_iv m = (lo <= hi) & pk_lanes(bits);
            unsigned mbits = pk_bits(m);
            if (!mbits)
                continue;
            in |= (uint64_t)mbits << (PK_W * gi);
            pk_fv ou = PKF(pk->o[U], gi), du = PKF(pk->d[U], gi);
            pk_fv ov = PKF(pk->o[V], gi), dv = PKF(pk->d[V], gi);
            pk_fv ua = ou + lo * du, ub = ou + hi * du;
            pk_fv va = ov + lo * dv, vb = ov + hi * dv;
            /* Each ray's own cells in this slice (widened by the padding, as the
             * rectangle below), so a cell is tested only for the rays that cross it. */
            pk_fv u0 = pk_min(ua, ub) - pad_u, u1 = pk_max(ua, ub) + pad_u;
            pk_fv v0 = pk_min(va, vb) - pad_v, v1 = pk_max(va, vb) + pad_v;
            ru0[gi] = pk_blend(m, u0, inf), ru1[gi] = pk_blend(m, u1, ninf);
            rv0[gi] = pk_blend(m, v0, inf), rv1[gi] = pk_blend(m, v1, ninf);
            umin = pk_min(umin, ru0[gi]);
            umax = pk_max(umax, ru1[gi]);
            vmin = pk_min(vmin, rv0[gi]);
            vmax = pk_max(vmax, rv1[gi]);
        }

        if (in) {
            /* The rectangle widened by the padding the cells were filled with, so a
             * rounding of o + t*d cannot lose a cell. */
            int iu0 = march_cell_of(pk_hmin(umin), lo_u, inv_su, nu);
            int iu1 = march_cell_of(pk_hmax(umax), lo_u, inv_su, nu);
            int iv0 = march_cell_of(pk_hmin(vmin), lo_v, inv_sv, nv);
            int iv1 = march_cell_of(pk_hmax(vmax), lo_v, inv_sv, nv);
            bool one_cell = iu0 == iu1 && iv0 == iv1;
            /* Each ray's own cells in this slice, so a cell is tested only for the rays
             * that cross it; in a one-cell rectangle every ray's range is that cell. */
            pk_iv cu0[PK_NG], cu1[PK_NG], cv0[PK_NG], cv1[PK_NG];
            if (one_cell) {
                cells_one += (uint64_t)__builtin_popcountll(in); /* statistics */
            } else {
                for (int gi = 0; gi < PK_NG; gi++) {
                    if (!((in >> (PK_W * gi)) & PK_WMASK))
                        continue;
                    pk_iv m = pk_lanes((unsigned)(in >> (PK_W * gi)) & PK_WMASK);
                    cu0[gi] = pk_cells(ru0[gi], lo_u, inv_su, nu);
                    cu1[gi] = pk_cells(ru1[gi], lo_u, inv_su, nu);
                    cv0[gi] = pk_cells(rv0[gi], lo_v, inv_sv, nv);
                    cv1[gi] = pk_cells(rv1[gi], lo_v, inv_sv, nv);
                    /* Statistics: each ray counts the cells of its own range. */
                    cells_acc += ((cu1[gi] - cu0[gi] + 1) * (cv1[gi] - cv0[gi] + 1)) & m;
                }
            }
            /* Each group of 8 rays' rectangle (lane j: rays [8 j, 8 j + 8); an empty one
             * for groups with no ray here), for the triangle cull, made at the first
             * packed triangle of the slice. */
            pk_f8 gu0 = inf8, gu1 = ninf8, gv0 = inf8, gv1 = ninf8;
            bool have_rects = false;
            int c[3];
            c[K] = k;
            for (int iv = iv0; iv <= iv1; iv++) {
                c[V] = iv;
                for (int iu = iu0; iu <= iu1; iu++) {
                    c[U] = iu;
                    uint32_t cell = grid_cell_index(g, c[0], c[1], c[2]);
                    if (occ && !(occ[cell >> 6] >> (cell & 63) & 1))
                        continue; /* empty: cell_start not read */
                    uint32_t e = start[cell], end = start[cell + 1];
                    if (e == end)
                        continue;
                    uint64_t crossing = in;
                    if (!one_cell) {
                        crossing = 0;
                        const pk_iv ivu = pk_spliti(iu), ivv = pk_spliti(iv);
                        for (int gi = 0; gi < PK_NG; gi++) {
                            unsigned bits = (unsigned)(in >> (PK_W * gi)) & PK_WMASK;
                            if (!bits)
                                continue;
                            pk_iv m = (cu0[gi] <= ivu) & (ivu <= cu1[gi]) & (cv0[gi] <= ivv) &
                                      (ivv <= cv1[gi]);
                            crossing |= (uint64_t)(pk_bits(m) & bits) << (PK_W * gi);
                        }
                    }
                    /* No ray left here (none crosses the cell, or every one that does
                     * is occluded): the entries are not read. */
                    if (!(pk->shadow ? crossing & ~pk->hit : crossing))
                        continue;
                    /* The cell's packed triangles on their way into the cache
                     * together, instead of one miss after the other (on grids
                     * whose triangles outgrow the cache, grid_internal.h). */
                    if (prefetch)
                        for (uint32_t f = e; f < end; f++)
                            __builtin_prefetch(&prefetch[GRID_ITEM_INDEX(items[f])]);
                    if (!have_rects) {
                        for (int gi = 0; gi < PK_NG; gi++) {
                            if (!((in >> (PK_W * gi)) & PK_WMASK))
                                continue;
                            int j = gi * (PK_W / 8);
                            gu0[j] = pk8_hmin(pk_lo8(ru0[gi]));
                            gu1[j] = pk8_hmax(pk_lo8(ru1[gi]));
                            gv0[j] = pk8_hmin(pk_lo8(rv0[gi]));
                            gv1[j] = pk8_hmax(pk_lo8(rv1[gi]));
#if PK_W == 16
                            gu0[j + 1] = pk8_hmin(pk_hi8(ru0[gi]));
                            gu1[j + 1] = pk8_hmax(pk_hi8(ru1[gi]));
                            gv0[j + 1] = pk8_hmin(pk_hi8(rv0[gi]));
                            gv1[j + 1] = pk8_hmax(pk_hi8(rv1[gi]));
#endif
                        }
                        have_rects = true;
                    }
                    bool cell_done = false;
                    while (e < end && !cell_done) {
                        /* The cull first, for a batch of the cell's entries, without a
                         * branch on its outcome: the entries some group keeps, in
                         * order, with the rays that may hit them. */
                        uint32_t kept[PK_BATCH];
                        uint64_t kept_rays[PK_BATCH];
                        int nkept = 0;
                        uint32_t stop = end - e > PK_BATCH ? e + PK_BATCH : end;
                        /* The cull: a group whose rectangle (or a beam's range,
                         * pk_cull_beam) misses the triangle's padded box skips it here
                         * (and stays unmarked). One loop for each kind of packet. */
                        if (beam) {
                            for (; e < stop; e++) {
                                uint32_t item = items[e];
                                const TriBox *tb = &g->tri[GRID_ITEM_INDEX(item)].box;
                                uint64_t w = item & GRID_ITEM_TRI
                                                 ? pk_cull_beam(tb, &bm, U, V, gu0, gu1, gv0,
                                                                gv1, bu0, bu1, bv0, bv1)
                                                 : ~(uint64_t)0;
                                kept[nkept] = item;
                                kept_rays[nkept] = w & crossing;
                                nkept += kept_rays[nkept] != 0;
                            }
                        } else {
                            for (; e < stop; e++) {
                                uint32_t item = items[e];
                                uint64_t w = item & GRID_ITEM_TRI
                                                 ? pk_cull(&g->tri[GRID_ITEM_INDEX(item)].box,
                                                           U, V, gu0, gu1, gv0, gv1)
                                                 : ~(uint64_t)0;
                                kept[nkept] = item;
                                kept_rays[nkept] = w & crossing;
                                nkept += kept_rays[nkept] != 0;
                            }
                        }
                        for (int j = 0; j < nkept; j++) {
                            uint32_t item = kept[j];
                            uint32_t p = GRID_ITEM_INDEX(item);
                            uint64_t want = kept_rays[j];
                            if (pk->shadow) {
                                if (!(crossing & ~pk->hit)) {
                                    cell_done = true;
                                    break;
                                }
                                want &= ~pk->hit;
                                if (!want)
                                    continue;
                            }
                            if (marks) {
                                /* Packet marking: a ray that has tested p skips it. */
                                PacketMark *pm = &marks->slot[p & (PK_MARK_SLOTS - 1)];
                                if (pm->gen == gen && pm->prim == p) {
                                    uint64_t seen = pm->rays & want;
                                    if (g->marking) {
                                        ctx->stats.mailbox_skips +=
                                            (uint64_t)__builtin_popcountll(seen);
                                        want &= ~seen;
                                        if (!want)
                                            continue;
                                    } else {
                                        ctx->stats.repeat_tests +=
                                            (uint64_t)__builtin_popcountll(seen);
                                    }
                                    pm->rays |= want;
                                } else {
                                    pm->gen = gen;
                                    pm->prim = p;
                                    pm->rays = want;
                                }
                            }
                            if (item & GRID_ITEM_TRI) {
                                ctx->stats.intersections += (uint64_t)__builtin_popcountll(want);
                                pk_test_tri(g, pk, p, want);
                            } else {
                                pk_test_prim(g, pk, p, want, ctx);
                            }
                        }
                    }
                }
            }
        }

        /* Who is done: rays past the box, rays whose best hit lies before the far
         * plane, occluded shadow rays. */
        uint64_t done = pk->shadow ? pk->hit : 0;
        for (int gi = 0; gi < PK_NG; gi++) {
            unsigned bits = (unsigned)(pk->active >> (PK_W * gi)) & PK_WMASK;
            if (!bits)
                continue;
            pk_iv m = tfar[gi] >= PKF(pk->t1, gi);
            if (!pk->shadow)
                m |= PKF(pk->best_t, gi) <= tfar[gi];
            done |= (uint64_t)(pk_bits(m) & bits) << (PK_W * gi);
        }
        pk->active &= ~done;
    }
    uint64_t cells = cells_one;
    for (int l = 0; l < PK_W; l++)
        cells += (uint64_t)(uint32_t)cells_acc[l];
    ctx->stats.cells_traversed += cells;
}

/* A ray leaves the packet for the single-ray march when its main-axis component is
 * small against its largest one: it would cross many cells per slice and widen the
 * slice rectangle for every ray of the packet. Any value is correct; this one keeps
 * each ray within about three cells' width per slice on cubic cells. */
#ifndef PK_MIN_AXIS_SHARE
#define PK_MIN_AXIS_SHARE 0.35f
#endif

/* Finite lanes: x - x is 0 exactly for finite x, NaN for infinities and NaN. */
PK_INLINE pk_iv pk_finite(pk_fv x) { return (x - x) == pk_splat(0.0f); }

/* The per-ray set-up of a packet (grid_packet.c, packet_prepare), eight rays at a
 * time, for the rays of cand along main axis pk->axis: which rays the packet walks
 * (returned), which go to the single-ray march (*single_out; rays missing the box are
 * in neither), and for the walked ones their columns, box span, first slice and span
 * ends. The box span is march_init's padded slab test with its arithmetic and its
 * verdicts, lane by lane, so a ray is walked exactly when its march would start. */
_Static_assert(sizeof(Ray) == 6 * sizeof(float), "a ray is six packed floats (the gathers)");
uint64_t PK_PREP(const Grid *g, Packet *pk, uint64_t cand, const float *tmax,
                 uint64_t *single_out)
{
    const int K = pk->axis, U = (K + 1) % 3, V = (K + 2) % 3, sign = pk->sign;
    const Ray *rays = pk->rays;
    const float lo_k = v3_comp(g->box.min, K), inv_sk = 1.0f / g->size[K];
    /* Rays starting within this distance of the origin need no far-origin check: the
     * march's rounding there stays below the padding (grid_ray_too_far's bound). */
    const pk_fv near = pk_splat(0.5f * (g->min_pad / (4.0f * FLT_EPSILON) - g->box_mag));
    const pk_fv zero = pk_splat(0.0f), one = pk_splat(1.0f), tminv = pk_splat(pk->march_tmin);
    const pk_fv inf = pk_splat(INFINITY), ninf = pk_splat(-INFINITY);
    /* One direction and one tmax for every ray (pk->same_dir: shadow rays towards a
     * directional light): their lanes and the reciprocals made once here, the same
     * floats the gathers and the lane-wise divisions below would give. */
    const bool same = pk->same_dir;
    const pk_fv tm_same = same ? pk_splat(pk->same_tmax) : inf;
    pk_fv sd[3], sinv[3];
    for (int a = 0; a < 3; a++) {
        sd[a] = same ? pk_splat(pk->dir[a]) : one;
        sinv[a] = same ? pk_splat(1.0f / pk->dir[a]) : one;
    }
    uint64_t single = 0, walk = 0;
    for (int gi = 0; gi < PK_NG; gi++) {
        unsigned byte = (unsigned)(cand >> (PK_W * gi)) & PK_WMASK;
        if (!byte)
            continue;
        pk_fv o[3], d[3], tm = tm_same; /* tmax (below) only without same */
        /* The group's rays into columns (lanes without a candidate: origin 0, direction
         * 1, tmax infinite). With AVX2 or AVX-512, masked gathers: lane by lane, each
         * insert went through memory and the vector read back after them waited for
         * all of them (a store-forwarding stall; ~12% of this function's time). The
         * same values either way: only loads. */
#if PK_W == 16 && defined(__AVX512F__)
        {
            const float *base = (const float *)(const void *)(rays + PK_W * gi);
            const __m512i idx = _mm512_mullo_epi32(
                _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
                _mm512_set1_epi32(6));
            const __mmask16 km = (__mmask16)byte;
            if (byte == PK_WMASK) {
                /* A whole group (all 96 floats are the caller's): six plain loads and,
                 * per component, three two-vector permutes and two blends instead of a
                 * gather. Float f = 6 l + a of the group (ray l, component a) lies in
                 * vector pair f / 32 at index f mod 32 (vpermt2ps reads the index's
                 * low five bits); lane l takes pair 1 where 32 <= f < 64, pair 2 from
                 * 64 on. Only loads and moves: the same values. */
                __m512 z[6];
                for (int v = 0; v < 6; v++)
                    z[v] = _mm512_loadu_ps(base + 16 * v);
                const __m512i six = _mm512_mullo_epi32(
                    _mm512_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15),
                    _mm512_set1_epi32(6));
                for (int a = 0; a < 6; a++) {
                    if (same && a >= 3)
                        break;
                    __m512i f = _mm512_add_epi32(six, _mm512_set1_epi32(a));
                    __mmask16 p1 = _mm512_cmpge_epi32_mask(f, _mm512_set1_epi32(32));
                    __mmask16 p2 = _mm512_cmpge_epi32_mask(f, _mm512_set1_epi32(64));
                    __m512 r = _mm512_permutex2var_ps(z[0], f, z[1]);
                    r = _mm512_mask_mov_ps(r, p1, _mm512_permutex2var_ps(z[2], f, z[3]));
                    r = _mm512_mask_mov_ps(r, p2, _mm512_permutex2var_ps(z[4], f, z[5]));
                    if (a < 3)
                        o[a] = (pk_fv)r;
                    else
                        d[a - 3] = (pk_fv)r;
                }
                if (same)
                    for (int a = 0; a < 3; a++)
                        d[a] = sd[a];
            } else {
                for (int a = 0; a < 3; a++) {
                    o[a] = (pk_fv)_mm512_mask_i32gather_ps((__m512)zero, km, idx, base + a, 4);
                    d[a] = same ? sd[a]
                                : (pk_fv)_mm512_mask_i32gather_ps((__m512)one, km, idx,
                                                                  base + 3 + a, 4);
                }
            }
            if (tmax)
                tm = (pk_fv)_mm512_mask_loadu_ps((__m512)inf, km, tmax + PK_W * gi);
        }
#elif PK_W == 8 && defined(__AVX2__)
        {
            const float *base = (const float *)(const void *)(rays + PK_W * gi);
            const __m256 km = (__m256)pk_lanes(byte);
            if (byte == PK_WMASK) {
                /* A whole group (every ray of it is the caller's, so all 48 floats may
                 * be read): plain loads and a transpose. A gather costs about eight
                 * loads' time on Zen 3, and six of them were most of this function
                 * there. Ray i + 4's floats beside ray i's in each row: a 4 x 4
                 * transpose per 128-bit half gives lanes 0-3 and 4-7 in order. */
                __m256 r[4], q[4];
                for (int i = 0; i < 4; i++) {
                    r[i] = _mm256_loadu2_m128(base + 6 * (i + 4), base + 6 * i);
                    q[i] = _mm256_loadu2_m128(base + 6 * (i + 4) + 2, base + 6 * i + 2);
                }
                /* r: o.x o.y o.z d.x; q: o.z d.x d.y d.z */
                __m256 t0 = _mm256_unpacklo_ps(r[0], r[1]), t1 = _mm256_unpacklo_ps(r[2], r[3]);
                o[0] = (pk_fv)_mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(1, 0, 1, 0));
                o[1] = (pk_fv)_mm256_shuffle_ps(t0, t1, _MM_SHUFFLE(3, 2, 3, 2));
                __m256 u0 = _mm256_unpacklo_ps(q[0], q[1]), u1 = _mm256_unpacklo_ps(q[2], q[3]);
                o[2] = (pk_fv)_mm256_shuffle_ps(u0, u1, _MM_SHUFFLE(1, 0, 1, 0));
                if (same) {
                    for (int a = 0; a < 3; a++)
                        d[a] = sd[a];
                } else {
                    __m256 u2 = _mm256_unpackhi_ps(q[0], q[1]);
                    __m256 u3 = _mm256_unpackhi_ps(q[2], q[3]);
                    d[0] = (pk_fv)_mm256_shuffle_ps(u0, u1, _MM_SHUFFLE(3, 2, 3, 2));
                    d[1] = (pk_fv)_mm256_shuffle_ps(u2, u3, _MM_SHUFFLE(1, 0, 1, 0));
                    d[2] = (pk_fv)_mm256_shuffle_ps(u2, u3, _MM_SHUFFLE(3, 2, 3, 2));
                }
                if (tmax)
                    tm = (pk_fv)_mm256_loadu_ps(tmax + PK_W * gi);
            } else {
                const __m256i idx = _mm256_setr_epi32(0, 6, 12, 18, 24, 30, 36, 42);
                for (int a = 0; a < 3; a++) {
                    o[a] = (pk_fv)_mm256_mask_i32gather_ps((__m256)zero, base + a, idx, km, 4);
                    d[a] = same ? sd[a]
                                : (pk_fv)_mm256_mask_i32gather_ps((__m256)one, base + 3 + a,
                                                                  idx, km, 4);
                }
                if (tmax) /* masked lanes read as 0, then infinite */
                    tm = pk_blend((pk_iv)km,
                                  (pk_fv)_mm256_maskload_ps(tmax + PK_W * gi, (__m256i)km), inf);
            }
        }
#else
        for (int a = 0; a < 3; a++)
            o[a] = zero, d[a] = sd[a];
        for (int l = 0; l < PK_W; l++) {
            if (!(byte >> l & 1))
                continue;
            const Ray *r = &rays[PK_W * gi + l];
            o[0][l] = r->origin.x, o[1][l] = r->origin.y, o[2][l] = r->origin.z;
            if (!same)
                d[0][l] = r->dir.x, d[1][l] = r->dir.y, d[2][l] = r->dir.z;
            if (tmax)
                tm[l] = tmax[PK_W * gi + l];
        }
#endif
        if (pk->num_planes) {
            /* The unbounded planes first, plane_intersect's (plane_occluded's) arithmetic
             * lane by lane: a nearer best for the walk; a shadow ray they block is done. */
            pk_iv live = pk_lanes(byte);
            const pk_fv ptmin = pk_splat(pk->tmin);
            pk_fv bt = PKF(pk->best_t, gi);
            pk_uv bid = PKU(pk->best_id, gi);
            pk_iv bp = PKI(pk->best_prim, gi), blocked = ~live & live;
            for (int u = 0; u < pk->num_planes; u++) {
                const PacketPlane *pl = &pk->planes[u];
                pk_fv nx = pk_splat(pl->n[0]), ny = pk_splat(pl->n[1]), nz = pk_splat(pl->n[2]);
                pk_fv den = nx * d[0] + ny * d[1] + nz * d[2];
                pk_fv t = (pk_splat(pl->offset) - (nx * o[0] + ny * o[1] + nz * o[2])) / den;
                pk_iv ok = live & (den != zero) & (t > ptmin);
                if (pk->shadow) {
                    blocked |= ok & (t < tm);
                    continue;
                }
                const uint32_t id = pl->id;
                pk_uv idv = {PK_REP(id)};
                ok &= (t < bt) | ((t == bt) & (pk_iv)(idv < bid));
                bt = pk_blend(ok, t, bt);
                bid = (pk_uv)pk_blend(ok, (pk_fv)idv, (pk_fv)bid);
                bp = (pk_iv)pk_blend(ok, (pk_fv)pk_spliti(-2 - u), (pk_fv)bp);
            }
            if (pk->shadow) {
                unsigned bb = pk_bits(blocked);
                pk->hit |= (uint64_t)bb << (PK_W * gi);
                byte &= ~bb;
                if (!byte)
                    continue;
            } else {
                PKF(pk->best_t, gi) = bt;
                PKU(pk->best_id, gi) = bid;
                PKI(pk->best_prim, gi) = bp;
            }
        }
        pk_fv dk = d[K];
        pk_fv big = pk_max(pk_abs(d[0]), pk_max(pk_abs(d[1]), pk_abs(d[2])));
        pk_fv far = pk_max(pk_abs(o[0]), pk_max(pk_abs(o[1]), pk_abs(o[2])));
        pk_iv ok = pk_finite(d[0]) & pk_finite(d[1]) & pk_finite(d[2]) & pk_finite(o[0]) &
                   pk_finite(o[1]) & pk_finite(o[2]) & (sign > 0 ? dk > zero : dk < zero) &
                   (pk_abs(dk) >= PK_MIN_AXIS_SHARE * big);
        unsigned fits = pk_bits(ok & (far < near)) & byte;
        /* Far origins: the exact check, ray by ray (rare). */
        for (unsigned slow = pk_bits(ok) & byte & ~fits; slow; slow &= slow - 1) {
            int l = __builtin_ctz(slow);
            const Ray r = packet_ray(pk, PK_W * gi + l);
            if (!grid_ray_too_far(g, &r, pk->march_tmin))
                fits |= 1u << l;
        }
        single |= (uint64_t)(byte & ~fits) << (PK_W * gi);

        pk_fv t_enter = ninf, t_exit = inf, invs[3];
        pk_iv any_axis = pk_spliti(0), inside = ~any_axis;
        for (int a = 0; a < 3; a++) {
            pk_fv inv = invs[a] = same ? sinv[a] : one / d[a];
            pk_iv par = (d[a] == zero) | ~pk_finite(inv);
            float plo = v3_comp(g->box.min, a) - g->pad[a], phi = v3_comp(g->box.max, a) + g->pad[a];
            inside &= ~par | ((o[a] >= pk_splat(plo)) & (o[a] <= pk_splat(phi)));
            pk_fv ta = (plo - o[a]) * inv, tb = (phi - o[a]) * inv;
            pk_iv neg = inv < zero;
            pk_fv lo = pk_blend(neg, tb, ta), hi = pk_blend(neg, ta, tb);
            pk_iv up = ~par & (lo > t_enter);
            t_enter = pk_blend(up, lo, t_enter);
            any_axis |= up;
            t_exit = pk_blend(~par & (hi < t_exit), hi, t_exit);
        }
        pk_iv in_box = inside & any_axis & (t_enter <= t_exit) & ~(t_exit < tminv);
        unsigned w = fits & pk_bits(in_box);
        walk |= (uint64_t)w << (PK_W * gi);
        /* No ray of the group walks (all miss the box, are blocked or go to the
         * march): nothing reads its columns (the walk, the spread and the first
         * slice read only the walked rays' groups). */
        if (!w)
            continue;

        pk_iv wm = pk_lanes(w);
        pk_fv t0 = pk_blend(t_enter < tminv, tminv, t_enter);
        pk_fv t1 = pk->shadow ? pk_blend(tm < t_exit, tm, t_exit) : t_exit;
        for (int a = 0; a < 3; a++) {
            PKF(pk->o[a], gi) = pk_blend(wm, o[a], zero);
            PKF(pk->d[a], gi) = pk_blend(wm, d[a], one);
        }
        PKF(pk->inv_k, gi) = pk_blend(wm, invs[K], one); /* one / dk, made above */
        PKF(pk->t0, gi) = pk_blend(wm, t0, zero);
        PKF(pk->t1, gi) = pk_blend(wm, t1, zero);
        pk_iv ks = pk_cells(pk_blend(wm, o[K] + t0 * dk, zero), lo_k, inv_sk, g->n[K]);
        pk_fv e[4] = {o[U] + t0 * d[U], o[V] + t0 * d[V], o[U] + t1 * d[U], o[V] + t1 * d[V]};
        memcpy(&pk->k_start[PK_W * gi], &ks, sizeof ks);
        for (int j = 0; j < 4; j++)
            memcpy(&pk->end[j][PK_W * gi], &e[j], sizeof e[j]);
    }
    *single_out = single;
    return walk;
}

/* How many cells wide the rays of `walk` are across the main axis, at the wider end
 * (grid_packet.c splits a packet that is too wide). */
float PK_SPREAD(const Grid *g, const Packet *pk, uint64_t walk)
{
    const int U = (pk->axis + 1) % 3, V = (pk->axis + 2) % 3;
    const float inv_s[2] = {1.0f / g->size[U], 1.0f / g->size[V]};
    const pk_fv inf = pk_splat(INFINITY), ninf = pk_splat(-INFINITY);
    pk_fv mn[4] = {inf, inf, inf, inf}, mx[4] = {ninf, ninf, ninf, ninf};
    for (int gi = 0; gi < PK_NG; gi++) {
        unsigned byte = (unsigned)(walk >> (PK_W * gi)) & PK_WMASK;
        if (!byte)
            continue;
        pk_iv in = pk_lanes(byte);
        for (int j = 0; j < 4; j++) {
            pk_fv e;
            memcpy(&e, &pk->end[j][PK_W * gi], sizeof e);
            mn[j] = pk_min(pk_blend(in, e, inf), mn[j]);
            mx[j] = pk_max(pk_blend(in, e, ninf), mx[j]);
        }
    }
    float w = 0.0f;
    for (int j = 0; j < 4; j++) {
        float c = (pk_hmax(mx[j]) - pk_hmin(mn[j])) * inv_s[j % 2];
        w = c > w ? c : w;
    }
    return w;
}
