/* The in-memory Image (the course's Image class), the course's float->byte
 * quantisation and the text of the region record: what every codec builds on. It calls no codec. */
#include "rt/image.h"

#include "rt/bigmem.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* Keeps a single allocation well below what size_t arithmetic or the TGA/PNG size fields
 * can describe; 65535 is also the TGA limit per side. */
enum { IMAGE_MAX_SIDE = 65535 };

bool image_init(Image *img, int width, int height)
{
    img->width = 0;
    img->height = 0;
    img->pixels = NULL;
    img->has_region = false;
    memset(&img->region, 0, sizeof img->region);
    if (width <= 0 || height <= 0 || width > IMAGE_MAX_SIDE || height > IMAGE_MAX_SIDE)
        return false;
    /* A 1080p frame is 25 MB: in huge pages, 12 faults instead of 6,000. */
    Vec3 *p = bigmem_calloc((size_t)width * (size_t)height, sizeof *p);
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
    bigmem_free(img->pixels);
    img->pixels = NULL;
    img->width = img->height = 0;
}

void image_fill(Image *img, Vec3 c)
{
    long n = (long)img->width * img->height;
    for (long i = 0; i < n; i++)
        img->pixels[i] = c;
}

uint8_t image_color_to_byte(float c)
{
    /* The course: v = (int)(c * 255), then clamped to 0..255. The clamp happens in float
     * first because converting NaN or a huge float to int is undefined in C; for every
     * finite input the result equals the course's. */
    float v = c * 255.0f;
    if (!(v > 0.0f)) /* also catches NaN */
        return 0;
    if (v >= 255.0f)
        return 255;
    return (uint8_t)(int)v; /* truncation toward zero, like the course */
}

/* ---- the region record --------------------------------------------------------- */

bool image_region_format(const Image *img, char *buf, size_t size)
{
    const ImageRegion *r = &img->region;
    int n = snprintf(buf, size, "%d %d %d %d %d %d", r->x, r->y, img->width, img->height,
                     r->full_width, r->full_height);
    return n > 0 && (size_t)n < size;
}

bool image_region_parse(const char *text, size_t len, int w, int h, ImageRegion *out,
                        char *err, size_t errlen)
{
    /* Six decimal numbers separated by single spaces, nothing else: the record is ours,
     * so anything looser is a damaged file. */
    long v[6];
    size_t i = 0;
    for (int k = 0; k < 6; k++) {
        if (k > 0) {
            if (i >= len || text[i] != ' ')
                goto bad;
            i++;
        }
        long x = 0;
        int digits = 0;
        while (i < len && text[i] >= '0' && text[i] <= '9' && digits < 7) {
            x = x * 10 + (text[i++] - '0');
            digits++;
        }
        if (digits == 0)
            goto bad;
        v[k] = x;
    }
    if (i != len)
        goto bad;
    if (v[2] != w || v[3] != h) {
        snprintf(err, errlen, "region record says %ldx%ld but the image is %dx%d", v[2], v[3],
                 w, h);
        return false;
    }
    if (v[4] < 1 || v[5] < 1 || v[4] > IMAGE_MAX_SIDE || v[5] > IMAGE_MAX_SIDE ||
        v[0] + v[2] > v[4] || v[1] + v[3] > v[5]) {
        snprintf(err, errlen, "region %ld %ld %ldx%ld does not lie inside the full %ldx%ld image",
                 v[0], v[1], v[2], v[3], v[4], v[5]);
        return false;
    }
    out->x = (int)v[0];
    out->y = (int)v[1];
    out->full_width = (int)v[4];
    out->full_height = (int)v[5];
    return true;
bad:
    snprintf(err, errlen, "malformed region record '%.*s'", len > 80 ? 80 : (int)len, text);
    return false;
}
