/* Targa files in memory: the course's exact layout on output (below) and a
 * tolerant reader for uncompressed true-colour files (24/32 bits, either row order). */
#include "rt/image.h"
#include "rt/bigmem.h"
#include "codec.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

enum { TGA_HEADER = 18 };

static bool tga_head(const Image *img, uint8_t *b, size_t *top, size_t *out_len, bool *bgr)
{
    int w = img->width, h = img->height;
    /* A part image (-region) names its place in the image ID field, which the format
     * reserves for such free text (at most 255 bytes). */
    char id[128] = "";
    size_t id_len = 0;
    if (img->has_region) {
        char rec[96];
        if (!image_region_format(img, rec, sizeof rec))
            return false;
        id_len = (size_t)snprintf(id, sizeof id, "%s %s", IMAGE_REGION_TAG, rec);
    }
    _Static_assert(TGA_HEADER + sizeof id <= IMAGE_HEAD_MAX, "the header fits");
    memset(b, 0, TGA_HEADER);
    b[0] = (uint8_t)id_len;
    memcpy(b + TGA_HEADER, id, id_len);
    /* The course's header: no ID (except the region record), no colour map, type 2
     * (uncompressed true colour), origin 0,0, little-endian width and height, 24 bits per
     * pixel, descriptor 0x20 (top row first). */
    b[2] = 2;
    b[12] = (uint8_t)(w & 0xff);
    b[13] = (uint8_t)((w >> 8) & 0xff);
    b[14] = (uint8_t)(h & 0xff);
    b[15] = (uint8_t)((h >> 8) & 0xff);
    b[16] = 24;
    b[17] = 0x20;
    *out_len = TGA_HEADER + id_len + (size_t)w * (size_t)h * 3;
    *top = TGA_HEADER + id_len;
    *bgr = true; /* each pixel as B, G, R */
    return true;
}

static bool tga_layout(const Image *img, uint8_t **out, size_t *out_len, size_t *top,
                       bool *bgr)
{
    return codec_layout_from_head(tga_head, img, out, out_len, top, bgr);
}

static bool tga_encode(const Image *img, uint8_t **out, size_t *out_len)
{
    size_t top;
    bool bgr;
    if (!tga_layout(img, out, out_len, &top, &bgr))
        return false;
    int w = img->width, h = img->height;
    uint8_t *p = *out + top;
    /* The image's top row (y = h-1) is stored first. */
    for (int y = h - 1; y >= 0; y--, p += (size_t)w * 3)
        image_row_bytes(img, y, bgr, p);
    return true;
}

/* Whether the 18-byte header holds values some TGA file has: colour map type 0 or 1,
 * a defined image type, a pixel depth TGA knows and no interleaving bits. TGA has no
 * signature, so it is the fallback for every file the other codecs do not recognise:
 * text or another format named .tga must be "not a TGA image", not a complaint about
 * one of its fields. */
static bool tga_header_plausible(const uint8_t *d)
{
    unsigned cmap_type = d[1], type = d[2], bpp = d[16], desc = d[17];
    static const unsigned types[] = {0, 1, 2, 3, 9, 10, 11, 32, 33};
    bool type_ok = false;
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        type_ok = type_ok || type == types[i];
    bool bpp_ok = type == 0 || bpp == 8 || bpp == 15 || bpp == 16 || bpp == 24 || bpp == 32;
    return cmap_type <= 1 && type_ok && bpp_ok && (desc & 0xc0) == 0;
}

/* The header's checks (what decode refuses before looking at pixels); *need: the
 * bytes the header declares (header, ID field, pixels). */
static bool tga_check_header(const uint8_t *d, size_t len, size_t *need, char *err,
                             size_t errlen)
{
    if (len < TGA_HEADER)
        return codec_fail(err, errlen, "not a TGA image (nor PPM or PNG): only %zu bytes", len);
    if (!tga_header_plausible(d))
        return codec_fail(err, errlen, "not a TGA image (nor PPM or PNG): its first bytes are "
                          "no image header");
    unsigned id_len = d[0], cmap_type = d[1], type = d[2];
    int w = d[12] | (d[13] << 8), h = d[14] | (d[15] << 8);
    unsigned bpp = d[16];

    if (type == 10 || type == 11 || type == 9)
        return codec_fail(err, errlen, "RLE-compressed TGA (type %u) is not supported; "
                    "save it uncompressed (type 2)", type);
    if (type == 1 || cmap_type != 0)
        return codec_fail(err, errlen, "colour-mapped TGA is not supported; save it as "
                    "uncompressed true colour (type 2)");
    if (type != 2)
        return codec_fail(err, errlen, "unsupported TGA image type %u (only uncompressed true "
                    "colour, type 2)", type);
    if (bpp != 24 && bpp != 32)
        return codec_fail(err, errlen, "unsupported TGA depth of %u bits (only 24 or 32)", bpp);
    if (w == 0 || h == 0)
        return codec_fail(err, errlen, "TGA image has zero size (%dx%d)", w, h);
    *need = TGA_HEADER + (size_t)id_len + (size_t)w * (size_t)h * (bpp / 8);
    return true;
}

/* What may follow the pixels and decode ignores: TGA 2.0's developer and extension
 * areas and its footer. The developer area has no size limit of its own; 64 MiB is
 * the room image_read's own limit leaves above the largest image. */
#define TGA_TRAILER_ROOM ((size_t)64 << 20)

/* image_read's early look (ImageCodec.header): an all-zero header (/dev/zero) is type
 * 0, "no image data", refused at once; a good one bounds the file's length. */
static bool tga_header(const uint8_t *d, size_t len, size_t *max_len, char *err,
                       size_t errlen)
{
    size_t need = 0;
    if (!tga_check_header(d, len, &need, err, errlen))
        return false;
    *max_len = need + TGA_TRAILER_ROOM;
    return true;
}

/* Everything decode checks before the pixels, from the file's first len bytes (all of
 * them, or at least the header and the ID field) of file_len: where the rows lie. */
static int tga_rows(const uint8_t *d, size_t len, size_t file_len, ImageRowLayout *lay,
                    char *err, size_t errlen)
{
    memset(lay, 0, sizeof *lay);
    size_t need = 0;
    if (!tga_check_header(d, len, &need, err, errlen))
        return 0;
    unsigned id_len = d[0];
    int w = d[12] | (d[13] << 8), h = d[14] | (d[15] << 8);
    unsigned bpp = d[16], desc = d[17];
    if (file_len < need)
        return codec_fail(err, errlen, "truncated TGA file: %dx%d needs %zu bytes, file has %zu",
                    w, h, need, file_len);
    if (len < TGA_HEADER + (size_t)id_len)
        return -1; /* not reached: image_rows_open gives at least 64 KiB */
    const char *id = (const char *)d + TGA_HEADER;
    size_t tag = sizeof IMAGE_REGION_TAG - 1;
    if (id_len > tag && memcmp(id, IMAGE_REGION_TAG " ", tag + 1) == 0) {
        if (!image_region_parse(id + tag + 1, id_len - tag - 1, w, h, &lay->region, err, errlen))
            return 0;
        lay->has_region = true;
    }
    lay->width = w;
    lay->height = h;
    lay->offset = TGA_HEADER + id_len;
    lay->pixel_bytes = (int)(bpp / 8);
    /* Descriptor bit 5: first stored row is the top one; bit 4: pixels run right to left. */
    lay->top_down = (desc & 0x20) != 0;
    lay->right_to_left = (desc & 0x10) != 0;
    lay->bgr = true;
    lay->maxval = 255;
    return 1;
}

static bool tga_decode(const uint8_t *d, size_t len, Image *img, char *err, size_t errlen)
{
    memset(img, 0, sizeof *img);   /* every field, so image_free is safe on failure */
    ImageRowLayout lay;
    if (tga_rows(d, len, len, &lay, err, errlen) != 1)
        return false;
    int w = lay.width, h = lay.height;
    if (!image_init(img, w, h))
        return codec_fail(err, errlen, "out of memory for a %dx%d image", w, h);
    img->has_region = lay.has_region;
    if (lay.has_region)
        img->region = lay.region;

    size_t bytes = (size_t)lay.pixel_bytes;
    const uint8_t *p = d + lay.offset;
    for (int r = 0; r < h; r++) {
        int y = lay.top_down ? h - 1 - r : r;
        for (int i = 0; i < w; i++) {
            int x = lay.right_to_left ? w - 1 - i : i;
            Vec3 c = v3(p[2] / 255.0f, p[1] / 255.0f, p[0] / 255.0f);
            image_set(img, x, y, c);
            p += bytes;
        }
    }
    return true;
}

static const char *const tga_extensions[] = {".tga", NULL};

/* No signature: TGA is what image_read assumes when no other format's matched. */
const ImageCodec tga_codec = {"tga", tga_extensions, NULL, tga_encode, tga_layout, tga_decode,
                              NULL, tga_header, tga_head, tga_rows};
