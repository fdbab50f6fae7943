/* RayTracer (A4-A6): Whitted recursion with shadows, reflection, refraction, as in
 * semantics.md 4. Read-only during rendering; all writes go to the RenderCtx. */
#ifndef RT_RAYTRACER_H
#define RT_RAYTRACER_H

#include "rt/grid.h"
#include "rt/scene.h"

/* epsilon for shadow, reflected and refracted rays (semantics.md 4.1). */
#define RT_EPSILON 1e-3f

typedef struct RayTracer {
    const Scene *scene;
    const Grid *grid;          /* NULL: brute-force RayCast over the scene */
    bool shadows;
    bool shade_back;
    int bounces;               /* max recursion depth; 0 = no secondary rays */
    float weight;              /* cutoff: secondary rays with weight < cutoff not traced */
    bool visualize_grid;       /* needs grid */
} RayTracer;

/* traceRay: colour seen along ray; counts one non-shadow ray. If hit_out is non-NULL it
 * receives the ray's nearest hit (t = +inf when none) with the unflipped normal. */
Vec3 raytracer_trace(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin,
                     int depth, float weight, float ior, Hit *hit_out);
/* Nearest hit (grid march, visualisation or brute force as configured). */
bool raytracer_cast(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin, Hit *hit);
/* True when something lies on the ray with tmin < t < dist. Counts one shadow ray. */
bool raytracer_occluded(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin,
                        float dist);

/* Per-thread context: allocates the grid mailbox when rt->grid is set. */
bool render_ctx_init(RenderCtx *ctx, const RayTracer *rt);
void render_ctx_free(RenderCtx *ctx);

#endif
