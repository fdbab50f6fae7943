/* The in-memory Image (the course's Image class), the course's float->byte
 * quantisation and the text of the region record: what every codec builds on. It calls no codec. */
#include "rt/image.h"

#include "rt/bigmem.h"

#include <inttypes.h>
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
    img->bytes = NULL;
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

bool image_init_bytes(Image *img, int width, int height)
{
    memset(img, 0, sizeof *img);
    if (width <= 0 || height <= 0 || width > IMAGE_MAX_SIDE || height > IMAGE_MAX_SIDE)
        return false;
    uint8_t *b = bigmem_calloc((size_t)width * (size_t)height, 3);
    if (!b)
        return false;
    img->width = width;
    img->height = height;
    img->bytes = b;
    return true;
}

void image_free(Image *img)
{
    if (!img)
        return;
    bigmem_free(img->pixels);
    img->pixels = NULL;
    bigmem_free(img->bytes);
    img->bytes = NULL;
    img->width = img->height = 0;
}

void image_fill(Image *img, Vec3 c)
{
    long n = (long)img->width * img->height;
    for (long i = 0; i < n; i++)
        img->pixels[i] = c;
}

void image_row_bytes(const Image *img, int y, bool bgr, uint8_t *out)
{
    int w = img->width;
    int r = bgr ? 2 : 0, b = bgr ? 0 : 2;
    if (img->bytes) {
        const uint8_t *in = img->bytes + (size_t)y * (size_t)w * 3;
        if (!bgr) {
            memcpy(out, in, (size_t)w * 3);
            return;
        }
        for (int x = 0; x < w; x++, in += 3, out += 3) {
            out[0] = in[2];
            out[1] = in[1];
            out[2] = in[0];
        }
        return;
    }
    const Vec3 *in = img->pixels + (size_t)y * (size_t)w;
    for (int x = 0; x < w; x++, out += 3) {
        out[r] = image_color_to_byte(in[x].x);
        out[1] = image_color_to_byte(in[x].y);
        out[b] = image_color_to_byte(in[x].z);
    }
}

/* ---- the region record --------------------------------------------------------- */

bool image_region_format(const Image *img, char *buf, size_t size)
{
    const ImageRegion *r = &img->region;
    int n = snprintf(buf, size, "%d %d %d %d %d %d", r->x, r->y, img->width, img->height,
                     r->full_width, r->full_height);
    if (n > 0 && (size_t)n < size && r->has_id)
        n += snprintf(buf + n, size - (size_t)n, " render=%016" PRIx64, r->id);
    return n > 0 && (size_t)n < size;
}

bool image_region_parse(const char *text, size_t len, int w, int h, ImageRegion *out,
                        char *err, size_t errlen)
{
    /* Six decimal numbers separated by single spaces, then the render identity or
     * nothing (an earlier version's record): the record is ours, so anything looser is
     * a damaged file. */
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
    static const char id_tag[] = " render=";
    size_t tag = sizeof id_tag - 1;
    uint64_t id = 0;
    bool has_id = i < len;
    if (has_id) {
        if (len - i != tag + 16 || memcmp(text + i, id_tag, tag) != 0)
            goto bad;
        for (i += tag; i < len; i++) {
            char c = text[i];
            if (c >= '0' && c <= '9')
                id = id << 4 | (uint64_t)(c - '0');
            else if (c >= 'a' && c <= 'f')
                id = id << 4 | (uint64_t)(c - 'a' + 10);
            else
                goto bad;
        }
    }
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
    out->has_id = has_id;
    out->id = id;
    return true;
bad:
    snprintf(err, errlen, "malformed region record '%.*s'", len > 80 ? 80 : (int)len, text);
    return false;
}
