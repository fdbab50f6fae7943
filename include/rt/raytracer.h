/* RayTracer (A4-A6): Whitted recursion with shadows, reflection, refraction, as in
 * the course's traceRay. Read-only during rendering; all writes go to the RenderCtx. */
#ifndef RT_RAYTRACER_H
#define RT_RAYTRACER_H

#include "rt/accel.h"
#include "rt/camera.h"
#include "rt/scene.h"

/* epsilon for shadow, reflected and refracted rays: a distance along the (unit) ray,
 * measured in the space of the primitive hit (Transforms rescale it, rt/geom.h). */
#define RT_EPSILON 1e-3f

typedef struct RayTracer {
    const Scene *scene;
    const Accel *accel;        /* finds the hits (rt/accel.h; "none" is brute force);
                                  built over scene's primitive table, borrowed */
    bool shadows;
    bool shade_back;
    int bounces;               /* max recursion depth; 0 = no secondary rays */
    float weight;              /* cutoff: secondary rays with weight < cutoff not traced */
    bool single_rays;          /* true: no ray packets, every ray traced on its own
                                  (hidden option -no_packets, for comparisons) */
    /* -noise_cutoff: the pixel's cone, whose width at a hit is its footprint
     * (mat_set_footprint): pixel_width at the camera (orthographic: the world width of a
     * pixel) growing by pixel_spread per unit of distance along the path (perspective:
     * the angle a pixel spans). Both 0 (the default): textures at full detail. */
    float pixel_width, pixel_spread;
} RayTracer;

/* Sets rt's pixel cone for camera and a W x H image (-noise_cutoff): a pixel is 1/S of
 * the square screen, S = max(W, H). */
void raytracer_set_pixel_cone(RayTracer *rt, const Camera *camera, int width, int height);

/* traceRay: colour seen along ray; counts one non-shadow ray. If hit_out is non-NULL it
 * receives the ray's nearest hit (t = +inf when none) with the unflipped normal. */
Vec3 raytracer_trace(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin,
                     int depth, float weight, float ior, Hit *hit_out);
/* raytracer_trace(rt, ctx, &rays[i], tmin, 0, 1, 1, &hits[i]) for every i < n
 * (n <= ACCEL_PACKET_MAX): the same colours and hits to the bit, but when the
 * accelerator has packet queries the rays and their first shadow rays go through it as
 * packets. One exception: a hit shaded inline (a PhongMaterial under directional
 * lights) that needs no shadow or secondary ray keeps point (0, 0, 0); only shading
 * reads the point. */
void raytracer_trace_packet(const RayTracer *rt, RenderCtx *ctx, const Ray *rays, int n,
                            float tmin, Vec3 *colors, Hit *hits);
/* raytracer_trace_packet for colours that go to bytes and nowhere else: every component
 * of colors[i] quantises (image_color_to_byte) to the byte raytracer_trace_packet's
 * gives, but the float itself may differ. The Phong lanes shaded inline then take the
 * specular power by repeated squaring instead of powf where the bytes are certain
 * (src/render/phong_packet.h states the rule and why it is exact). */
void raytracer_trace_packet_bytes(const RayTracer *rt, RenderCtx *ctx, const Ray *rays,
                                  int n, float tmin, Vec3 *colors, Hit *hits);
/* raytracer_trace_packet_bytes for a whole packet (n = ACCEL_PACKET_MAX), whose colours
 * may come back as three planes instead: true when every lane is a front face of one
 * PhongMaterial shaded inline without secondary rays (a tile inside one mesh): its
 * colours are then planes[c * ACCEL_PACKET_MAX + k] (channel c of lane k: the Phong
 * kernel's columns, copied) and colors is not written; false: in colors, as
 * raytracer_trace_packet_bytes. The hits are filled either way. */
bool raytracer_trace_tile_bytes(const RayTracer *rt, RenderCtx *ctx, const Ray *rays,
                                float tmin, Vec3 *colors, float *planes, Hit *hits);
/* Nearest hit (through rt->accel). */
bool raytracer_cast(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin, Hit *hit);
/* True when something lies on the ray with tmin < t < dist. Counts one shadow ray. */
bool raytracer_occluded(const RayTracer *rt, RenderCtx *ctx, const Ray *ray, float tmin,
                        float dist);

/* Per-thread context: allocates the accelerator's per-thread scratch (mailbox, packet
 * ray masks) with rt/bigmem.h: release them with raytracer_ctx_free (or bigmem_free),
 * never free. */
bool raytracer_ctx_init(RenderCtx *ctx, const RayTracer *rt);
void raytracer_ctx_free(RenderCtx *ctx);

#endif
