/* The quick blend lanes' light loop (raytracer.c, blend_lights_group), written once and
 * included there once per width: the includer defines BL_NAME (the function's name) and
 * BL_W (lanes per vector: 4, 8 or 16, the width of the instruction set the inclusion is
 * compiled for, so GCC and clang keep the vectors in registers instead of splitting
 * them lane by lane) and has BlendLanes and PhongParams defined. Each lane's operations
 * are phong_term's and v3_lerp's single IEEE operations in their order (no FMA: the
 * file is built with -ffp-contract=off), so every width gives the same bits.
 *
 * BL_NAME: one directional light (l, lc); BL_NAME_each: one light of a direction and
 * colour per lane (a point light's, in a LightLanes). Either on the quick lanes of
 * mask, all of one material of children p1, p2: per lane and channel k, with
 * nl = n . l, diffuse = nl > 0 ? nl : 0, term_j = lc_k (d_j diffuse + s_j 0)
 * (phong_term without powf, whose specular factor is then 0), and the blend
 * blend_of(term_1, term_2, t) added to the colour. */

#define BL_CAT2(a, b) a##b
#define BL_CAT(a, b) BL_CAT2(a, b)
#define BL_V BL_CAT(BL_NAME, _v)
#define BL_M BL_CAT(BL_NAME, _m)
#define BL_LOAD BL_CAT(BL_NAME, _load)
#define BL_STORE BL_CAT(BL_NAME, _store)
#define BL_SET BL_CAT(BL_NAME, _set)
#define BL_SEL BL_CAT(BL_NAME, _sel)
#define BL_BODY BL_CAT(BL_NAME, _body)
#define BL_EACH BL_CAT(BL_NAME, _each)
#if BL_W == 4
#define BL_REP(x) x, x, x, x
#define BL_BITS 1, 2, 4, 8
#elif BL_W == 8
#define BL_REP(x) x, x, x, x, x, x, x, x
#define BL_BITS 1, 2, 4, 8, 16, 32, 64, 128
#elif BL_W == 16
#define BL_REP(x) x, x, x, x, x, x, x, x, x, x, x, x, x, x, x, x
#define BL_BITS 1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 1024, 2048, 4096, 8192, 16384, 32768
#else
#error "BL_W is 4, 8 or 16"
#endif
_Static_assert(ACCEL_PACKET_MAX % BL_W == 0, "whole vectors of lanes");

typedef float BL_V __attribute__((vector_size(4 * BL_W)));
typedef int32_t BL_M __attribute__((vector_size(4 * BL_W)));

static inline __attribute__((always_inline)) BL_V BL_LOAD(const float *p)
{
    BL_V v;
    memcpy(&v, p, sizeof v);
    return v;
}
static inline __attribute__((always_inline)) void BL_STORE(float *p, BL_V v)
{
    memcpy(p, &v, sizeof v);
}
/* Every lane a: lane 0 spread (a lane-by-lane initialiser compiled to one masked load
 * per lane in the AVX-512 copy). */
static inline __attribute__((always_inline)) BL_V BL_SET(float a)
{
    BL_V v = {a};
    return __builtin_shufflevector(v, v, BL_REP(0));
}
static inline __attribute__((always_inline)) BL_V BL_SEL(BL_M m, BL_V a, BL_V b)
{
    return (BL_V)(((BL_M)a & m) | ((BL_M)b & ~m));
}

/* The light the same for every lane (ll NULL: l, lc) or each lane's own (ll's columns);
 * always inlined with ll a constant, so each case is compiled for itself. */
static inline __attribute__((always_inline)) void BL_BODY(BlendLanes *bl, uint64_t mask,
                                                          const PhongParams *p1,
                                                          const PhongParams *p2, Vec3 l,
                                                          Vec3 lc, const LightLanes *ll)
{
    BL_V lx = BL_SET(l.x), ly = BL_SET(l.y), lz = BL_SET(l.z), zero = BL_SET(0.0f),
         one = BL_SET(1.0f);
    const BL_M bit = {BL_BITS};
    const float lck[3] = {lc.x, lc.y, lc.z};
    const float *llc[3] = {ll ? ll->r : NULL, ll ? ll->g : NULL, ll ? ll->b : NULL};
    const float d1[3] = {p1->diffuse.x, p1->diffuse.y, p1->diffuse.z};
    const float s1[3] = {p1->specular.x, p1->specular.y, p1->specular.z};
    const float d2[3] = {p2->diffuse.x, p2->diffuse.y, p2->diffuse.z};
    const float s2[3] = {p2->specular.x, p2->specular.y, p2->specular.z};
    for (int g = __builtin_ctzll(mask) & -BL_W; g < ACCEL_PACKET_MAX && mask >> g;
         g += BL_W) {
        int32_t m = (int32_t)((mask >> g) & ((1u << BL_W) - 1));
        if (!m)
            continue;
        BL_M on = ((m + (BL_M){0}) & bit) != 0;
        if (ll) {
            lx = BL_LOAD(ll->x + g);
            ly = BL_LOAD(ll->y + g);
            lz = BL_LOAD(ll->z + g);
        }
        BL_V nl = BL_LOAD(bl->nx + g) * lx + BL_LOAD(bl->ny + g) * ly + BL_LOAD(bl->nz + g) * lz;
        BL_V diffuse = BL_SEL(nl > zero, nl, zero);
        BL_V t = BL_LOAD(bl->t + g), u = one - t;
        BL_M hi = t >= one, lo = t <= zero;
        for (int k = 0; k < 3; k++) {
            BL_V c = ll ? BL_LOAD(llc[k] + g) : BL_SET(lck[k]);
            BL_V a = c * (BL_SET(d1[k]) * diffuse + BL_SET(s1[k]) * zero);
            BL_V b = c * (BL_SET(d2[k]) * diffuse + BL_SET(s2[k]) * zero);
            BL_V term = BL_SEL(hi, a, BL_SEL(lo, b, a * t + b * u));
            BL_V old = BL_LOAD(bl->c[k] + g);
            BL_STORE(bl->c[k] + g, BL_SEL(on, old + term, old));
        }
    }
}

static void BL_NAME(BlendLanes *bl, uint64_t mask, const PhongParams *p1,
                    const PhongParams *p2, Vec3 l, Vec3 lc)
{
    BL_BODY(bl, mask, p1, p2, l, lc, NULL);
}

static void BL_EACH(BlendLanes *bl, uint64_t mask, const PhongParams *p1,
                    const PhongParams *p2, const LightLanes *ll)
{
    BL_BODY(bl, mask, p1, p2, v3(0, 0, 0), v3(0, 0, 0), ll);
}

#undef BL_BODY
#undef BL_EACH
#undef BL_CAT2
#undef BL_CAT
#undef BL_V
#undef BL_M
#undef BL_LOAD
#undef BL_STORE
#undef BL_SET
#undef BL_SEL
#undef BL_REP
#undef BL_BITS
#undef BL_NAME
#undef BL_W
