/* Binary PPM (P6, 8 bits per channel) in memory: the course Image class's other format
 * (docs/images.md). Rows top-down, R G B. The reader accepts '#' comments in the header. */
#include "rt/image.h"
#include "rt/bigmem.h"
#include "codec.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static bool ppm_head(const Image *img, uint8_t *b, size_t *top, size_t *out_len, bool *bgr)
{
    int w = img->width, h = img->height;
    /* A part image (-region) names its place in a comment line after the magic. */
    char head[192], rec[96] = "";
    _Static_assert(sizeof head <= IMAGE_HEAD_MAX, "the header fits");
    if (img->has_region && !image_region_format(img, rec, sizeof rec))
        return false;
    int n = snprintf(head, sizeof head, "P6\n%s%s%s%d %d\n255\n",
                     img->has_region ? "# " IMAGE_REGION_TAG " " : "", rec,
                     img->has_region ? "\n" : "", w, h);
    if (n < 0 || (size_t)n >= sizeof head)
        return false;
    memcpy(b, head, (size_t)n);
    *out_len = (size_t)n + (size_t)w * (size_t)h * 3;
    *top = (size_t)n; /* top row first, R G B */
    *bgr = false;
    return true;
}

static bool ppm_layout(const Image *img, uint8_t **out, size_t *out_len, size_t *top,
                       bool *bgr)
{
    return codec_layout_from_head(ppm_head, img, out, out_len, top, bgr);
}

static bool ppm_encode(const Image *img, uint8_t **out, size_t *out_len)
{
    size_t top;
    bool bgr;
    if (!ppm_layout(img, out, out_len, &top, &bgr))
        return false;
    int w = img->width, h = img->height;
    uint8_t *p = *out + top;
    for (int y = h - 1; y >= 0; y--, p += (size_t)w * 3)
        image_row_bytes(img, y, bgr, p);
    return true;
}

static bool is_space(uint8_t c)
{
    return c == ' ' || c == '\t' || c == '\n' || c == '\r' || c == '\v' || c == '\f';
}

/* Skips whitespace and comments (a '#' runs to the end of its line), then reads one
 * decimal number of at most 9 digits. */
static bool read_header_int(const uint8_t *d, size_t len, size_t *pos, long *value)
{
    size_t i = *pos;
    for (;;) {
        while (i < len && is_space(d[i]))
            i++;
        if (i < len && d[i] == '#') {
            while (i < len && d[i] != '\n' && d[i] != '\r')
                i++;
            continue;
        }
        break;
    }
    long v = 0;
    int digits = 0;
    while (i < len && d[i] >= '0' && d[i] <= '9') {
        if (++digits > 9)
            return false;
        v = v * 10 + (d[i] - '0');
        i++;
    }
    if (digits == 0)
        return false;
    *pos = i;
    *value = v;
    return true;
}

/* Everything decode checks before the pixels, from the file's first len bytes of
 * file_len: where the rows lie; -1 when the header does not end within those bytes
 * (comments may make it long). */
static int ppm_rows(const uint8_t *d, size_t len, size_t file_len, ImageRowLayout *lay,
                    char *err, size_t errlen)
{
    memset(lay, 0, sizeof *lay);
    if (len < 2 || d[0] != 'P' || d[1] != '6')
        return codec_fail(err, errlen, "not a binary PPM file (expected \"P6\")");
    bool whole = len == file_len;
    /* Our region record, if any, is the comment line right after the magic. */
    static const char tag[] = "\n# " IMAGE_REGION_TAG " ";
    const char *rec = NULL;
    size_t rec_len = 0;
    if (len > sizeof tag + 1 && memcmp(d + 2, tag, sizeof tag - 1) == 0) {
        rec = (const char *)d + 2 + sizeof tag - 1;
        const char *nl = memchr(rec, '\n', len - 2 - (sizeof tag - 1));
        if (!nl)
            return whole ? codec_fail(err, errlen, "malformed PPM header") : -1;
        rec_len = (size_t)(nl - rec);
    }
    size_t pos = 2;
    long w, h, maxval;
    if (!read_header_int(d, len, &pos, &w) || !read_header_int(d, len, &pos, &h) ||
        !read_header_int(d, len, &pos, &maxval))
        return whole ? codec_fail(err, errlen, "malformed PPM header") : -1;
    /* Exactly one whitespace character separates the header from the samples. */
    if (pos >= len)
        return whole ? codec_fail(err, errlen, "malformed PPM header") : -1;
    if (!is_space(d[pos]))
        return codec_fail(err, errlen, "malformed PPM header");
    pos++;
    if (w <= 0 || h <= 0 || w > 65535 || h > 65535)
        return codec_fail(err, errlen, "unsupported PPM size %ldx%ld", w, h);
    if (maxval <= 0 || maxval > 255)
        return codec_fail(err, errlen, "unsupported PPM maximum value %ld (only 8-bit, 1..255)",
                    maxval);
    size_t need = (size_t)w * (size_t)h * 3;
    if (file_len - pos < need)
        return codec_fail(err, errlen, "truncated PPM file: %ldx%ld needs %zu pixel bytes, "
                    "file has %zu", w, h, need, file_len - pos);
    if (rec && !image_region_parse(rec, rec_len, (int)w, (int)h, &lay->region, err, errlen))
        return 0;
    lay->has_region = rec != NULL;
    lay->width = (int)w;
    lay->height = (int)h;
    lay->offset = pos;
    lay->pixel_bytes = 3;
    lay->top_down = true;
    lay->maxval = (int)maxval;
    return 1;
}

static bool ppm_decode(const uint8_t *d, size_t len, Image *img, char *err, size_t errlen)
{
    memset(img, 0, sizeof *img);   /* every field, so image_free is safe on failure */
    ImageRowLayout lay;
    if (ppm_rows(d, len, len, &lay, err, errlen) != 1)
        return false;
    long w = lay.width, h = lay.height, maxval = lay.maxval;
    if (!image_init(img, (int)w, (int)h))
        return codec_fail(err, errlen, "out of memory for a %ldx%ld image", w, h);
    img->has_region = lay.has_region;
    if (lay.has_region)
        img->region = lay.region;
    const uint8_t *p = d + lay.offset;
    for (long r = 0; r < h; r++) {
        int y = (int)(h - 1 - r);
        for (int x = 0; x < (int)w; x++) {
            /* A sample above maxval is invalid; clamp it rather than reject the file. */
            float c[3];
            for (int k = 0; k < 3; k++)
                c[k] = (p[k] > maxval ? (float)maxval : (float)p[k]) / (float)maxval;
            image_set(img, x, y, v3(c[0], c[1], c[2]));
            p += 3;
        }
    }
    return true;
}

static bool ppm_sniff(const uint8_t *d, size_t len)
{
    return len >= 2 && d[0] == 'P' && d[1] == '6';
}

static const char *const ppm_extensions[] = {".ppm", NULL};

const ImageCodec ppm_codec = {"ppm", ppm_extensions, ppm_sniff, ppm_encode, ppm_layout, ppm_decode,
                              NULL, NULL, ppm_head, ppm_rows};
