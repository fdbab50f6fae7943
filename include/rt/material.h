/* Material interface (course class Material, with the A6 11/2 update): every accessor
 * takes the world-space hit point so procedural materials can vary with position.
 * Materials live in the scene's arena; children of procedural materials are borrowed. */
#ifndef RT_MATERIAL_H
#define RT_MATERIAL_H

#include "rt/matrix.h"
#include "rt/ray.h"

typedef struct Arena Arena;

typedef struct MaterialOps {
    const char *type_name;
    /* Contribution of one light: dir_to_light L (unit), light_color C (attenuated).
     * hit->normal is the facing normal (flipped with -shade_back), hit->point world. */
    Vec3 (*shade)(const Material *self, const Ray *ray, const Hit *hit, Vec3 dir_to_light,
                  Vec3 light_color);
    Vec3 (*diffuse_at)(const Material *self, Vec3 p);      /* ambient term colour */
    Vec3 (*reflective_at)(const Material *self, Vec3 p);
    Vec3 (*transparent_at)(const Material *self, Vec3 p);
    float (*ior_at)(const Material *self, Vec3 p);
    /* The PhongMaterial the GL preview shows: itself, or a procedural's first child's. */
    const Material *(*preview_material)(const Material *self);
} MaterialOps;

struct Material {
    const MaterialOps *ops;  /* always the first member */
};

static inline Vec3 mat_shade(const Material *m, const Ray *r, const Hit *h, Vec3 l, Vec3 c)
{
    return m->ops->shade(m, r, h, l, c);
}
static inline Vec3 mat_diffuse_at(const Material *m, Vec3 p) { return m->ops->diffuse_at(m, p); }
static inline Vec3 mat_reflective_at(const Material *m, Vec3 p) { return m->ops->reflective_at(m, p); }
static inline Vec3 mat_transparent_at(const Material *m, Vec3 p) { return m->ops->transparent_at(m, p); }
static inline float mat_ior_at(const Material *m, Vec3 p) { return m->ops->ior_at(m, p); }
static inline const Material *mat_preview(const Material *m) { return m->ops->preview_material(m); }

/* The footprint of the point being shaded (-noise_cutoff): the world-space width of
 * the pixel's cone where it meets the surface. Procedural textures leave out the detail
 * finer than it (rt/perlin.h, perlin_octave_weight). 0, the default, means full detail:
 * every image without -noise_cutoff is the same bits as without this mechanism.
 * The accessors above take a point only, so the footprint travels beside them: it is
 * per thread, and the tracer sets it before each question it asks a material about a
 * hit (a nested trace sets its own, so the caller sets it again after one). */
void mat_set_footprint(float world_width);
float mat_footprint(void);

/* PhongMaterial (A3/A4), Blinn-Phong with the course's n.L step
 * (no diffuse or specular term from a light behind the surface). */
typedef struct PhongParams {
    Vec3 diffuse;       /* default (1,1,1) */
    Vec3 specular;      /* default 0 */
    float exponent;     /* default 1 */
    Vec3 reflective;    /* default 0 */
    Vec3 transparent;   /* default 0 */
    float ior;          /* default 1 */
} PhongParams;

PhongParams phong_defaults(void);
Material *phong_new(Arena *a, const PhongParams *p);
/* Copies the parameters of a PhongMaterial; false for any other material type. */
bool phong_params(const Material *m, PhongParams *out);
/* The parameters of a PhongMaterial in place (borrowed, read-only); NULL for any other
 * material type. The tracer shades such hits without the ops (raytracer_trace_packet). */
const PhongParams *phong_params_of(const Material *m);

/* One light's Blinn-Phong term, the whole of PhongMaterial's shade: n is the facing
 * normal, v the unit direction towards the eye (-normalize(ray dir)), l the unit
 * direction to the light, lc its colour. No diffuse or specular term when n.l <= 0 (the
 * course's step). Inline so the packet shading and the material compute the same bits.
 *
 * powf is skipped, exactly, when the material has no specular colour: the term's
 * specular part is then specular * s = +-0 for any finite s >= 0, the sign being the
 * colour's own, so specular itself is added. s = powf(x, e) with x = max(n.h, 0) is
 * finite when 0 <= e <= 1000 and x <= 1.0625, which |n|^2 <= 1.125 and |h| <= 1 (plus
 * rounding) guarantee; outside that range (or with a NaN) powf runs as always.
 * This function always calls powf otherwise: it returns floats. The packet shading
 * leaves powf out in one more case, for colours that only become bytes: an integer
 * exponent by repeated squaring, bracketed, with powf again wherever the bracket leaves
 * a byte open (src/render/phong_packet.h says why the bytes are the same). */
static inline Vec3 phong_term(const PhongParams *p, Vec3 n, Vec3 v, Vec3 l, Vec3 lc)
{
    float nl = v3_dot(n, l);
    float diffuse = nl > 0.0f ? nl : 0.0f;
    float specular = 0.0f;
    if (nl > 0.0f && !(v3_is_zero(p->specular) && p->exponent >= 0.0f &&
                       p->exponent <= 1000.0f && v3_dot(n, n) <= 1.125f)) {
        Vec3 h = v3_normalize(v3_add(l, v));
        float nh = v3_dot(n, h);
        /* pow(0, 0) = 1: exponent 0 gives a constant lobe, as the course's pow. */
        specular = powf(nh > 0.0f ? nh : 0.0f, p->exponent);
    }
    Vec3 c = v3_add(v3_scale(p->diffuse, diffuse), v3_scale(p->specular, specular));
    return v3_mul(lc, c);
}

/* Procedural solid textures (A6, docs/textures.md). texture_xf maps world points to
 * texture space; NULL means identity. m1, m2 are borrowed and may be procedural. */
Material *checkerboard_new(Arena *a, const Mat4 *texture_xf, const Material *m1,
                           const Material *m2);
Material *noise_new(Arena *a, const Mat4 *texture_xf, const Material *m1,
                    const Material *m2, int octaves);
Material *marble_new(Arena *a, const Mat4 *texture_xf, const Material *m1,
                     const Material *m2, int octaves, float frequency, float amplitude);
Material *wood_new(Arena *a, const Mat4 *texture_xf, const Material *m1,
                   const Material *m2, int octaves, float frequency, float amplitude);

/* A material type of its own (a new texture) needs nothing below: the packet tracer
 * shades every hit on a material it does not recognise through the ops, with the same
 * bits as the single-ray tracer. It recognises PhongMaterial (phong_params_of),
 * Checkerboard by its ops table, and a blend of two PhongMaterials made by
 * procedural_blend_new with a weights function (src/shade/procedural.h), whose lanes
 * it computes itself.
 * For the packet tracer, which shades procedural hits without the ops (the same bits):
 * mat_checker_child: the child a Checkerboard delegates every question about world
 * point p to (the same for shade, diffuse, reflective, transparent and ior); NULL when
 * m is not a Checkerboard.
 * mat_checker_reaches_phong: whether m is a Checkerboard that picks a PhongMaterial
 * somewhere (directly or through nested Checkerboards): only then can its hits be
 * shaded as Phong lanes.
 * mat_phong_blend: whether m is a Noise, Marble or Wood whose children are both
 * PhongMaterials; if so their parameters (p1 is weighted by t, p2 by 1 - t) and
 * whether both have zero reflective and transparent colours (*plain).
 * mat_blend_weights: t[i] = the weight of such a blend at world point p[i], i < n, the
 * same bits as its shading uses with the footprint 0 (-noise_cutoff off). Its ops give
 * then: diffuse = blend(diffuse), shade = blend(phong_term) with blend(a, b) = a when
 * t >= 1, b when t <= 0, else v3_lerp(a, b, t). */
const Material *mat_checker_child(const Material *m, Vec3 p);
bool mat_checker_reaches_phong(const Material *m);
bool mat_phong_blend(const Material *m, const PhongParams **p1, const PhongParams **p2,
                     bool *plain);
void mat_blend_weights(const Material *m, const Vec3 *p, int n, float *t);

#endif
