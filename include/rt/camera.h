/* Cameras (A1, A2): screen point (u,v) in [0,1]^2, (0,0) bottom-left -> ray. */
#ifndef RT_CAMERA_H
#define RT_CAMERA_H

#include <stdbool.h>
#include "rt/ray.h"

typedef enum CameraKind { CAMERA_ORTHOGRAPHIC, CAMERA_PERSPECTIVE } CameraKind;

typedef struct Camera {
    CameraKind kind;
    Vec3 center;        /* as given (image-plane centre / eye) */
    Vec3 direction;     /* unit */
    Vec3 up;            /* unit, orthogonal to direction */
    Vec3 horizontal;    /* unit, direction x up: screen right */
    float size;         /* orthographic: world width of the square screen */
    float angle;        /* perspective: full field of view, radians */
    float tan_half;     /* tanf(angle / 2), set by the init functions and camera_rebasis */
} Camera;

/* Build the basis (direction, up made orthogonal to it, horizontal = direction x up, all
 * unit). False when direction is zero or up is parallel to it, or size/angle is out of
 * range (size <= 0; angle not in (0, pi)). */
bool camera_init_orthographic(Camera *c, Vec3 center, Vec3 direction, Vec3 up, float size);
bool camera_init_perspective(Camera *c, Vec3 center, Vec3 direction, Vec3 up,
                             float angle_radians);
/* Re-derives horizontal/up from direction and up (and tan_half from angle) after an
 * interactive change. */
bool camera_rebasis(Camera *c);
Ray camera_generate_ray(const Camera *c, float u, float v);
/* -inf (a very large negative number) for orthographic cameras, 0 for perspective. */
float camera_tmin(const Camera *c);

/* Pixel centre (i, j), j from the bottom, of a W x H image -> screen (u, v):
 * u = ((i + 0.5) - W/2) / S + 0.5, S = max(W, H) (the course's square screen on the
 * larger side). */
void camera_pixel_to_screen(int i, int j, int width, int height, float *u, float *v);
/* The same for the point at offset (px, py) in [0,1]^2 inside pixel (i, j) (A7 samples):
 * u = ((i + px) - W/2) / S + 0.5 in float; (0.5, 0.5) gives camera_pixel_to_screen. */
void camera_sample_to_screen(int i, int j, float px, float py, int width, int height,
                             float *u, float *v);

#endif
