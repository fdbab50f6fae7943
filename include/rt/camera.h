/* Cameras (A1, A2): screen point (u,v) in [0,1]^2, (0,0) bottom-left -> ray. */
#ifndef RT_CAMERA_H
#define RT_CAMERA_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "rt/ray.h"

typedef enum CameraKind { CAMERA_ORTHOGRAPHIC, CAMERA_PERSPECTIVE } CameraKind;

typedef struct Camera {
    CameraKind kind;
    Vec3 center;        /* as given (image-plane centre / eye) */
    Vec3 direction;     /* unit */
    Vec3 up;            /* screen up = horizontal x direction: orthogonal to direction,
                         * unit up to rounding (not renormalised, as the course) */
    Vec3 horizontal;    /* unit, direction x up: screen right */
    float size;         /* orthographic: world width of the square screen */
    float angle;        /* perspective: full field of view, radians */
    float tan_half;     /* tanf(angle / 2), set by the init functions and camera_rebasis */
    /* Perspective: the square screen at distance 1 in front of the eye, in world space:
     * its bottom-left corner and its two edges (2 tan_half long). A ray aims at
     * lower_left + u x_axis + v y_axis. */
    Vec3 lower_left, x_axis, y_axis;
    /* Perspective with an eye far from the origin (a coordinate of magnitude
     * CAMERA_FAR_EYE or more): the world-space screen point has lost the bits that
     * tell neighbouring rays apart (ulp(|eye|), 2 at 2^24, where every ray came out
     * sideways and the image empty), so the rays aim at screen_offset + u x_axis +
     * v y_axis, the screen relative to the eye (d - t up - t h), instead. */
    bool far_eye;
    Vec3 screen_offset;
} Camera;

/* The eye coordinate from which a perspective camera aims relative to the eye: at 128
 * the world-space screen point is rounded to 2^-16, under a pixel of a 32768-wide
 * image at 30 degrees; every course and project scene's eye is nearer (at most 95). */
#define CAMERA_FAR_EYE 128.0f

/* Build the basis the course's way: direction and up normalised, horizontal =
 * normalize(direction x up), screen up = horizontal x direction; then the perspective
 * screen. False when direction or up is zero, up is parallel to direction, or
 * size/angle is out of range (size <= 0; angle not in (0, pi)). */
bool camera_init_orthographic(Camera *c, Vec3 center, Vec3 direction, Vec3 up, float size);
bool camera_init_perspective(Camera *c, Vec3 center, Vec3 direction, Vec3 up,
                             float angle_radians);
/* Re-derives horizontal/up and the screen from center, direction and up (and tan_half
 * from angle) after an interactive change. */
bool camera_rebasis(Camera *c);
/* Orthographic: origin center + (u - 0.5) size horizontal + (v - 0.5) size up, the
 * direction. Perspective: origin the eye, direction normalize(screen point - eye), the
 * screen point lower_left + u x_axis + v y_axis computed in world space (in float, in
 * that order), as the course's camera does: its rounding decides colours on grazing
 * floors, where the official images are matched only this way. With far_eye the
 * direction is normalize(screen_offset + u x_axis + v y_axis) instead (the same rays,
 * without the loss). */
Ray camera_generate_ray(const Camera *c, float u, float v);
/* The pixel-centre rays of a block of pixels: rays[j * nx + i] (or rays[slot[j * nx +
 * i]] when slot is not NULL: the renderer's lanes) is the ray of pixel (x0 + i, y0 + j)
 * of a W x H image, camera_generate_ray of camera_pixel_to_screen to the bit, with what
 * depends on the column alone or the row alone computed once per column or row (the
 * renderer's tiles; 1 <= nx, ny <= CAMERA_BLOCK_MAX). */
enum { CAMERA_BLOCK_MAX = 16 };
void camera_pixel_rays(const Camera *c, int x0, int y0, int nx, int ny, int width,
                       int height, const uint8_t *slot, Ray *rays);
/* camera_pixel_rays of the 8 x 8 block at (x0, y0), in lane order: rays[k] is the ray
 * of pixel (x0 + i, y0 + j) where lane[k] = 8 j + i (lane a permutation of 0..63: the
 * renderer's tile order), to the bit. With AVX2 (asked on every call) and a perspective
 * camera the rays are made in that order, eight at a time; else through
 * camera_pixel_rays with the inverse table. */
void camera_block8_rays(const Camera *c, int x0, int y0, int width, int height,
                        const uint8_t *lane, Ray *rays);
/* Tests: camera_block8_rays takes its plain path (camera_pixel_rays) from now on when on
 * is true; the CPU's choice again when false. */
void camera_block8_rays_plain(bool on);
/* The rays of n sample points of pixel (x, y) of a W x H image, the points at offsets
 * xy[2k], xy[2k+1] in [0,1)^2 (A7 samplers): rays[k] is camera_generate_ray of
 * camera_sample_to_screen to the bit, sixteen samples at a time where the CPU running
 * it has AVX-512 (asked on every call), eight at a time where it has AVX2, then four
 * at a time in SSE lanes where the target has them (the film's primary rays: 16 per
 * pixel). */
void camera_sample_rays(const Camera *c, int x, int y, const float *xy, int n, int width,
                        int height, Ray *rays);
/* camera_sample_rays for 16 samples of each of npx pixels: pixel i's position pairs at
 * xy[i] (32 floats), its rays to rays + 16 i. The same rays; where the CPU has AVX-512,
 * two pixels' chains of divisions overlap. */
void camera_sample_rays_pixels(const Camera *c, int npx, const int *x, const int *y,
                               const float *const *xy, int width, int height, Ray *rays);
/* camera_sample_rays, and each sample's position (xy[2k], xy[2k+1]) stored at
 * pos + k * stride (two floats side by side) with that address in dest[k]: the film's
 * scratch and its packet's destinations, in the same pass as the rays (eight at a time
 * where the CPU has AVX2). */
void camera_sample_rays_put(const Camera *c, int x, int y, const float *xy, int n, int width,
                            int height, Ray *rays, float *pos, size_t stride, float **dest);
/* Tests: camera_sample_rays' widest lanes from now on are those of the instruction set
 * isa ("base": SSE where the target has it, "avx2", "avx512"); false, nothing changed,
 * when this build or CPU cannot run them. */
bool camera_sample_rays_use_kernel(const char *isa);
/* -inf (a very large negative number) for orthographic cameras, 0 for perspective. */
float camera_tmin(const Camera *c);

/* Pixel centre (i, j), j from the bottom, of a W x H image -> screen (u, v):
 * u = (i + 0.5 + (S - W)/2) / S, S = max(W, H) (the course's square screen on the
 * larger side, the smaller side cropped symmetrically). */
void camera_pixel_to_screen(int i, int j, int width, int height, float *u, float *v);
/* The same for the point at offset (px, py) in [0,1]^2 inside pixel (i, j) (A7 samples):
 * u = (i + px + (S - W)/2) / S in float; (0.5, 0.5) gives camera_pixel_to_screen. */
void camera_sample_to_screen(int i, int j, float px, float py, int width, int height,
                             float *u, float *v);

#endif
