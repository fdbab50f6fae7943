/* PhongMaterial (A3/A4): Blinn-Phong with the course's step at n.L <= 0:
 * no diffuse or specular term from a light behind the surface. */
#include "rt/material.h"
#include "rt/arena.h"

#include <string.h>

typedef struct PhongMaterial {
    Material base;
    PhongParams p;
} PhongMaterial;

static Vec3 phong_shade(const Material *self, const Ray *ray, const Hit *hit, Vec3 l,
                        Vec3 light_color)
{
    const PhongMaterial *m = (const PhongMaterial *)self;
    return phong_term(&m->p, hit->normal, v3_neg(v3_normalize(ray->dir)), l, light_color);
}

static Vec3 phong_diffuse(const Material *self, Vec3 p)
{
    (void)p;
    return ((const PhongMaterial *)self)->p.diffuse;
}
static Vec3 phong_reflective(const Material *self, Vec3 p)
{
    (void)p;
    return ((const PhongMaterial *)self)->p.reflective;
}
static Vec3 phong_transparent(const Material *self, Vec3 p)
{
    (void)p;
    return ((const PhongMaterial *)self)->p.transparent;
}
static float phong_ior(const Material *self, Vec3 p)
{
    (void)p;
    return ((const PhongMaterial *)self)->p.ior;
}
static const Material *phong_preview(const Material *self) { return self; }

static const MaterialOps phong_ops = {"PhongMaterial", phong_shade,       phong_diffuse,
                                      phong_reflective, phong_transparent, phong_ior,
                                      phong_preview};

PhongParams phong_defaults(void)
{
    PhongParams p;
    memset(&p, 0, sizeof p);
    p.diffuse = v3(1, 1, 1);
    p.exponent = 1.0f;
    p.ior = 1.0f;
    return p;
}

Material *phong_new(Arena *a, const PhongParams *p)
{
    PhongMaterial *m = arena_alloc(a, sizeof *m);
    if (!m)
        return NULL;
    m->base.ops = &phong_ops;
    m->p = *p;
    return &m->base;
}

const PhongParams *phong_params_of(const Material *m)
{
    return m && m->ops == &phong_ops ? &((const PhongMaterial *)m)->p : NULL;
}

bool phong_params(const Material *m, PhongParams *out)
{
    if (!m || m->ops != &phong_ops)
        return false;
    *out = ((const PhongMaterial *)m)->p;
    return true;
}
