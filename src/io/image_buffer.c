/* The in-memory Image (the course's Image class) and the course's float->byte
 * quantisation: what every codec builds on. It calls no codec. */
#include "rt/image.h"

#include <stdlib.h>

/* Keeps a single allocation well below what size_t arithmetic or the TGA/PNG size fields
 * can describe; 65535 is also the TGA limit per side. */
enum { IMAGE_MAX_SIDE = 65535 };

bool image_init(Image *img, int width, int height)
{
    img->width = 0;
    img->height = 0;
    img->pixels = NULL;
    if (width <= 0 || height <= 0 || width > IMAGE_MAX_SIDE || height > IMAGE_MAX_SIDE)
        return false;
    Vec3 *p = calloc((size_t)width * (size_t)height, sizeof *p);
    if (!p)
        return false;
    img->width = width;
    img->height = height;
    img->pixels = p;
    return true;
}

void image_free(Image *img)
{
    if (!img)
        return;
    free(img->pixels);
    img->pixels = NULL;
    img->width = img->height = 0;
}

void image_fill(Image *img, Vec3 c)
{
    long n = (long)img->width * img->height;
    for (long i = 0; i < n; i++)
        img->pixels[i] = c;
}

uint8_t color_to_byte(float c)
{
    /* tga.md 3: v = (int)(c * 255), then clamped to 0..255. The clamp happens in float
     * first because converting NaN or a huge float to int is undefined in C; for every
     * finite input the result equals the course's. */
    float v = c * 255.0f;
    if (!(v > 0.0f)) /* also catches NaN */
        return 0;
    if (v >= 255.0f)
        return 255;
    return (uint8_t)(int)v; /* truncation toward zero, like the course */
}
