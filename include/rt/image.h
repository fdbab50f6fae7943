/* Float RGB images and their files. Pixel (x, y): x left->right, y bottom->top,
 * like the course Image class. */
#ifndef RT_IMAGE_H
#define RT_IMAGE_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "rt/diag.h"
#include "rt/vec.h"

typedef struct Image {
    int width, height;
    Vec3 *pixels;       /* width*height, row y = 0 (bottom) first */
} Image;

/* Allocates a black image; false on bad size or out of memory. */
bool image_init(Image *img, int width, int height);
void image_free(Image *img);
void image_fill(Image *img, Vec3 c);
static inline void image_set(Image *img, int x, int y, Vec3 c) { img->pixels[(long)y * img->width + x] = c; }
static inline Vec3 image_get(const Image *img, int x, int y) { return img->pixels[(long)y * img->width + x]; }

/* The course quantisation: clamp(int(c * 255), 0, 255); NaN -> 0 (tga.md 3). */
uint8_t color_to_byte(float c);

/* Writes by file name extension: .tga (course layout), .ppm (P6), .png (when built
 * with libpng). Writes to a temporary file in the same folder and renames it, so a
 * failure leaves no file. Reports failures to diag. */
bool image_write(const Image *img, const char *path, Diag *diag);

/* Several images, all or nothing: each goes to its temporary file first (an existing
 * pipe or device is written in place after those), and the temporary files are renamed
 * into place only when every write succeeded; on failure none is renamed and all are
 * removed. The caller refuses the same path twice. One write at a time per process. */
enum { IMAGE_MAX_OUTPUTS = 8 };
typedef struct ImageOutput {
    const Image *image;
    const char *path;
} ImageOutput;
bool image_write_all(const ImageOutput *outs, int n, Diag *diag);

/* For a signal handler (async-signal-safe): when image_write_all is writing its
 * temporary files, removes them and returns true (the caller then ends the process
 * with _exit, and nothing has been renamed into place); false when no write is under
 * way or the renames have begun (they finish: the images are then complete). */
bool image_write_abort(void);
/* Reads a .tga (uncompressed 24/32-bit, either row order) or .ppm (P6, 8-bit). */
bool image_read(Image *img, const char *path, Diag *diag);

/* Lower-level: encode into a malloc'd buffer (tests check the bytes); the caller frees
 * *out. False only when out of memory. Decoders fill a fresh image (the caller frees it
 * with image_free) or return false with a one-line reason in err and img left empty;
 * they never read past data + len. */
bool tga_encode(const Image *img, uint8_t **out, size_t *out_len);
bool tga_decode(const uint8_t *data, size_t len, Image *img, char *err, size_t errlen);
bool ppm_encode(const Image *img, uint8_t **out, size_t *out_len);
bool ppm_decode(const uint8_t *data, size_t len, Image *img, char *err, size_t errlen);
/* PNG (8-bit RGB). Only functional when built with libpng (RT_HAVE_PNG, mk/png.mk);
 * otherwise they fail. Same contracts as the TGA pair. */
bool png_encode(const Image *img, uint8_t **out, size_t *out_len);
bool png_decode(const uint8_t *data, size_t len, Image *img, char *err, size_t errlen);
/* True when this build can write PNG. */
bool image_png_supported(void);

#endif
