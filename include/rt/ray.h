/* Rays and hits. A Hit's t is the world-space ray parameter (the ray direction is
 * not renormalised through transforms, so t is comparable across the whole scene). */
#ifndef RT_RAY_H
#define RT_RAY_H

#include <stdint.h>
#include "rt/vec.h"

typedef struct Material Material;
typedef struct Object3D Object3D;

typedef struct Ray {
    Vec3 origin;
    Vec3 dir; /* not necessarily unit (object space through transforms) */
} Ray;

static inline Vec3 ray_at(const Ray *r, float t) { return v3_madd(r->origin, r->dir, t); }

#define RT_NO_ID UINT32_MAX

typedef struct Hit {
    float t;                    /* +INFINITY when nothing was hit */
    Vec3 normal;                /* unit, world space, front side as defined (not flipped) */
    Vec3 point;                 /* world-space o + t*d; filled by the tracer, not intersect */
    const Material *material;   /* borrowed; NULL only for "no hit" */
    uint32_t id;                /* leaf primitive id (depth-first order), tie-breaker */
} Hit;

/* A fresh hit: t = +inf, nothing hit. */
static inline Hit hit_none(void)
{
    Hit h = {INFINITY, {0, 0, 0}, {0, 0, 0}, 0, RT_NO_ID};
    return h;
}

/* The single acceptance rule of every primitive: nearer, or as near and earlier in
 * depth-first scene order. The tie-break makes the grid's answer identical to the
 * brute-force loop's even when two primitives give the same t (shared mesh edges). */
static inline bool hit_accepts(const Hit *h, float t, uint32_t id)
{
    return t < h->t || (t == h->t && id < h->id);
}

#endif
