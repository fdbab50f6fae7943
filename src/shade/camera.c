/* Orthographic and perspective cameras (A1, A2): the orthonormal basis from direction
 * and up, and the ray through a screen point (rt/camera.h states the formulas). */
#include "rt/camera.h"

#include <float.h>
#include <math.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

bool camera_rebasis(Camera *c)
{
    Vec3 d = v3_normalize(c->direction);
    if (v3_is_zero(d) || !v3_isfinite(d))
        return false;
    /* up made orthogonal to d, then horizontal = d x up' (screen right). */
    Vec3 up = v3_normalize(v3_sub(c->up, v3_scale(d, v3_dot(c->up, d))));
    if (v3_is_zero(up) || !v3_isfinite(up))
        return false;
    Vec3 h = v3_normalize(v3_cross(d, up));
    if (v3_is_zero(h))
        return false;
    c->direction = d;
    c->up = up;
    c->horizontal = h;
    c->tan_half = tanf(c->angle * 0.5f);
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
    } else {
        /* angle spans the whole square screen: tan(angle/2) at its edges (computed
         * once per camera, not per ray). */
        float t = c->tan_half;
        Vec3 d = v3_add(c->direction, v3_add(v3_scale(c->horizontal, (2.0f * u - 1.0f) * t),
                                             v3_scale(c->up, (2.0f * v - 1.0f) * t)));
        r.origin = c->center;
        r.dir = v3_normalize(d);
    }
    return r;
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
    /* In float and in this order, so (0.5, 0.5) is the pixel-centre ray to the bit. */
    float s = (float)(width > height ? width : height);
    *u = (((float)i + px) - (float)width / 2.0f) / s + 0.5f;
    *v = (((float)j + py) - (float)height / 2.0f) / s + 0.5f;
}
