/* Optional PNG support through libpng (built when mk/png.mk defines RT_HAVE_PNG): 8-bit
 * RGB out, 8/16-bit grey/RGB/palette (with or without alpha) in. Without libpng the
 * codec has no encoder or decoder and says what to install. */
#include "rt/image.h"
#include "rt/bigmem.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef RT_HAVE_PNG

#include "codec.h"
#include <errno.h>
#include <unistd.h>

#include <png.h>
#include <setjmp.h>

/* Growable output buffer for libpng's write callback. */
typedef struct PngBuf {
    uint8_t *data;
    size_t len, cap;
} PngBuf;

static void buf_flush(png_structp png) { (void)png; }


/* libpng reports through longjmp; its default handler also prints to stderr, which we
 * replace with silence because the caller reports the failure itself. */
static void quiet_error(png_structp png, png_const_charp msg)
{
    (void)msg;
    png_longjmp(png, 1);
}

static void quiet_warning(png_structp png, png_const_charp msg)
{
    (void)png;
    (void)msg;
}

/* A PNG file being written row by row (codec.h). */
struct PngOut {
    png_structp png;
    png_infop info;
    bool (*write)(void *ctx, const uint8_t *p, size_t n);
    void *ctx;
};

static void out_write(png_structp png, png_bytep src, png_size_t n)
{
    PngOut *o = png_get_io_ptr(png);
    if (!o->write(o->ctx, src, n))
        png_error(png, "write");
}

void png_out_free(PngOut *o)
{
    if (!o)
        return;
    png_destroy_write_struct(&o->png, &o->info);
    free(o);
}

/* The header chunks of img (its region record as a tEXt chunk); false on failure. */
static bool out_start(PngOut *o, const Image *img)
{
    if (setjmp(png_jmpbuf(o->png)))
        return false;
    png_set_write_fn(o->png, o, out_write, buf_flush);
    png_set_IHDR(o->png, o->info, (png_uint_32)img->width, (png_uint_32)img->height, 8,
                 PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
                 PNG_FILTER_TYPE_DEFAULT);
    /* A part image (-region) names its place in a tEXt chunk before the pixels. */
    char rec[96];
    if (img->has_region) {
        if (!image_region_format(img, rec, sizeof rec))
            png_error(o->png, "region record");
        png_text text;
        memset(&text, 0, sizeof text);
        text.compression = PNG_TEXT_COMPRESSION_NONE;
        text.key = (png_charp)IMAGE_REGION_TAG;
        text.text = rec;
        text.text_length = strlen(rec);
        png_set_text(o->png, o->info, &text, 1);
    }
    png_write_info(o->png, o->info);
    return true;
}

PngOut *png_out_begin(const Image *img, bool (*write)(void *ctx, const uint8_t *p, size_t n),
                      void *ctx)
{
    PngOut *o = calloc(1, sizeof *o);
    if (!o)
        return NULL;
    o->write = write;
    o->ctx = ctx;
    o->png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, quiet_error, quiet_warning);
    o->info = o->png ? png_create_info_struct(o->png) : NULL;
    if (!o->png || !o->info || !out_start(o, img)) {
        png_out_free(o);
        return NULL;
    }
    return o;
}

bool png_out_row(PngOut *o, const uint8_t *rgb)
{
    if (setjmp(png_jmpbuf(o->png)))
        return false;
    png_write_row(o->png, rgb);
    return true;
}

static bool out_end(PngOut *o)
{
    if (setjmp(png_jmpbuf(o->png)))
        return false;
    png_write_end(o->png, o->info);
    return true;
}

bool png_out_end(PngOut *o)
{
    bool ok = out_end(o);
    png_out_free(o);
    return ok;
}

/* png_encode's sink: the growable buffer. */
static bool buf_put(void *ctx, const uint8_t *src, size_t n)
{
    PngBuf *b = ctx;
    if (b->len + n > b->cap) {
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->len + n)
            cap *= 2;
        uint8_t *nd = bigmem_resize(b->data, cap);
        if (!nd)
            return false;
        b->data = nd;
        b->cap = cap;
    }
    memcpy(b->data + b->len, src, n);
    b->len += n;
    return true;
}

static bool png_encode(const Image *img, uint8_t **out, size_t *out_len)
{
    int w = img->width, h = img->height;
    PngBuf buf = {NULL, 0, 0};
    uint8_t *row = malloc((size_t)w * 3);
    PngOut *o = row ? png_out_begin(img, buf_put, &buf) : NULL;
    bool ok = o != NULL;
    for (int y = h - 1; y >= 0 && ok; y--) { /* PNG stores the top row first */
        image_row_bytes(img, y, false, row);
        ok = png_out_row(o, row);
    }
    if (o)
        ok = png_out_end(o) && ok;
    free(row);
    if (!ok) {
        bigmem_free(buf.data);
        return false;
    }
    *out = buf.data;
    *out_len = buf.len;
    return true;
}

typedef struct PngSrc {
    const uint8_t *data;
    size_t len, pos;
} PngSrc;

static void src_read(png_structp png, png_bytep dst, png_size_t n)
{
    PngSrc *s = png_get_io_ptr(png);
    if (n > s->len - s->pos)
        png_error(png, "truncated PNG file");
    memcpy(dst, s->data + s->pos, n);
    s->pos += n;
}

/* Whether every chunk's declared length fits in the bytes that follow it. libpng
 * allocates (and clears) a chunk's declared length before reading it, so 128 bytes
 * declaring a 1 GB text chunk once cost 1 GB and seconds before "truncated"; no chunk
 * of a complete file can be longer than the file. Stops at IEND or the end. */
static bool chunks_fit(const uint8_t *data, size_t len)
{
    size_t pos = 8; /* the signature */
    while (pos + 8 <= len) {
        uint32_t n = (uint32_t)data[pos] << 24 | (uint32_t)data[pos + 1] << 16 |
                     (uint32_t)data[pos + 2] << 8 | (uint32_t)data[pos + 3];
        if ((size_t)n > len - pos - 8)
            return false;
        if (memcmp(data + pos + 4, "IEND", 4) == 0)
            return true;
        pos += 8 + (size_t)n + 4; /* length, type, data, CRC */
    }
    return true; /* a file cut inside a chunk header: libpng reports it */
}

/* The sizes read, as for PPM: 1..65535 each way (a TGA's 16-bit fields; -size and
 * -merge stay far below). */
static bool sizes_fit(png_uint_32 w, png_uint_32 h, char *err, size_t errlen)
{
    if (w >= 1 && h >= 1 && w <= 65535 && h <= 65535)
        return true;
    if (err && errlen)
        snprintf(err, errlen, "unsupported PNG size %lux%lu (at most 65535x65535)",
                 (unsigned long)w, (unsigned long)h);
    return false;
}

static bool png_decode(const uint8_t *data, size_t len, Image *img, char *err, size_t errlen)
{
    PngSrc src = {data, len, 0};
    memset(img, 0, sizeof *img);   /* every field, so image_free is safe on failure */
    if (!chunks_fit(data, len)) {
        if (err && errlen)
            snprintf(err, errlen, "corrupt or truncated PNG file (a chunk is longer than the "
                     "file)");
        return false;
    }
    /* volatile: these change between setjmp and a possible longjmp. */
    uint8_t *volatile row = NULL;
    png_bytep *volatile rows = NULL;

    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, quiet_error,
                                             quiet_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_read_struct(&png, &info, NULL);
        if (err && errlen)
            snprintf(err, errlen, "out of memory");
        return false;
    }
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        free(row);
        free(rows);
        image_free(img);
        if (err && errlen)
            snprintf(err, errlen, "corrupt or truncated PNG file");
        return false;
    }
    png_set_read_fn(png, &src, src_read);
    /* libpng's own limits as wide as the format's: png_read_info allocates no pixel
     * memory, and sizes_fit below refuses what we do not read with a message saying so
     * (a limit of 65535 here made libpng's error 'corrupt or truncated PNG file'). */
    png_set_user_limits(png, PNG_UINT_31_MAX, PNG_UINT_31_MAX);
    png_read_info(png, info);
    png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
    if (!sizes_fit(w, h, err, errlen)) {
        png_destroy_read_struct(&png, &info, NULL);
        return false;
    }
    /* Our region record, if any (a tEXt chunk before the pixels). */
    volatile bool has_region = false;
    ImageRegion region;
    png_textp texts = NULL;
    int ntexts = 0;
    png_get_text(png, info, &texts, &ntexts);
    for (int i = 0; i < ntexts; i++) {
        if (strcmp(texts[i].key, IMAGE_REGION_TAG) != 0)
            continue;
        char why[160];
        if (!image_region_parse(texts[i].text, texts[i].text_length, (int)w, (int)h, &region,
                                why, sizeof why)) {
            png_destroy_read_struct(&png, &info, NULL);
            if (err && errlen)
                snprintf(err, errlen, "%s", why);
            return false;
        }
        has_region = true;
    }
    /* Normalise every colour type and depth to 8-bit RGB. */
    png_set_expand(png);
    png_set_strip_16(png);
    png_set_strip_alpha(png);
    png_set_gray_to_rgb(png);
    png_set_interlace_handling(png);
    png_read_update_info(png, info);
    if (png_get_rowbytes(png, info) != (size_t)w * 3)
        png_error(png, "unexpected row layout");
    /* Interlaced files need every row in memory; read the whole picture at once. */
    row = malloc((size_t)w * 3 * h);
    rows = malloc(sizeof(png_bytep) * h);
    if (!row || !rows || !image_init(img, (int)w, (int)h))
        png_error(png, "out of memory");
    for (png_uint_32 r = 0; r < h; r++)
        rows[r] = row + (size_t)r * w * 3;
    png_read_image(png, rows);
    png_read_end(png, NULL);
    for (png_uint_32 r = 0; r < h; r++) {
        const uint8_t *p = row + (size_t)r * w * 3;
        int y = (int)(h - 1 - r);
        for (png_uint_32 x = 0; x < w; x++, p += 3)
            image_set(img, (int)x, y, v3(p[0] / 255.0f, p[1] / 255.0f, p[2] / 255.0f));
    }
    png_destroy_read_struct(&png, &info, NULL);
    free(rows);
    free(row);
    img->has_region = has_region;
    if (has_region)
        img->region = region;
    return true;
}

/* ---- row by row (-merge's parts, codec.h) ----------------------------------------- */

/* The decoder reads the file through buf at its own offset pos, from the descriptor of
 * the current call: -merge may close a part's file between rows and open it again (its
 * open files are limited: codec.h, ImageRowsFiles). It had its own FILE (a dup of the
 * descriptor), a second descriptor per part held from the first row to the last. */
struct PngRows {
    png_structp png;
    png_infop info;
    int fd;          /* the current call's */
    size_t pos;      /* the file offset of buf's end */
    size_t have, at; /* bytes in buf, of which at are used */
    uint8_t buf[8192];
};

static void file_read(png_structp png, png_bytep dst, png_size_t n)
{
    PngRows *r = png_get_io_ptr(png);
    while (n > 0) {
        if (r->at == r->have) {
            ssize_t k;
            do
                k = pread(r->fd, r->buf, sizeof r->buf, (off_t)r->pos);
            while (k < 0 && errno == EINTR);
            if (k <= 0)
                png_error(png, "truncated PNG file");
            r->pos += (size_t)k;
            r->have = (size_t)k;
            r->at = 0;
        }
        size_t take = r->have - r->at < n ? r->have - r->at : n;
        memcpy(dst, r->buf + r->at, take);
        r->at += take;
        dst += take;
        n -= take;
    }
}

/* chunks_fit on a file: the chunk headers read at their places, the data skipped. */
static bool chunks_fit_fd(int fd, size_t len)
{
    size_t pos = 8;
    while (pos + 8 <= len) {
        uint8_t h[8];
        if (pread(fd, h, 8, (off_t)pos) != 8)
            return true; /* libpng meets the same end and reports it */
        uint32_t n = (uint32_t)h[0] << 24 | (uint32_t)h[1] << 16 | (uint32_t)h[2] << 8 | h[3];
        if ((size_t)n > len - pos - 8)
            return false;
        if (memcmp(h + 4, "IEND", 4) == 0)
            return true;
        pos += 8 + (size_t)n + 4;
    }
    return true;
}

void png_rows_free(PngRows *r)
{
    if (!r)
        return;
    png_destroy_read_struct(&r->png, &r->info, NULL);
    free(r);
}

PngRows *png_rows_open(int fd, size_t len, ImageRowLayout *lay, bool *interlaced, char *err,
                       size_t errlen)
{
    memset(lay, 0, sizeof *lay);
    *interlaced = false;
    if (!chunks_fit_fd(fd, len)) {
        codec_fail(err, errlen, "corrupt or truncated PNG file (a chunk is longer than the "
                   "file)");
        return NULL;
    }
    PngRows *r = calloc(1, sizeof *r);
    if (r) {
        r->fd = fd;
        r->png = png_create_read_struct(PNG_LIBPNG_VER_STRING, NULL, quiet_error,
                                        quiet_warning);
    }
    if (r && r->png)
        r->info = png_create_info_struct(r->png);
    if (!r || !r->png || !r->info) {
        png_rows_free(r);
        codec_fail(err, errlen, "out of memory");
        return NULL;
    }
    if (setjmp(png_jmpbuf(r->png))) {
        png_rows_free(r);
        codec_fail(err, errlen, "corrupt or truncated PNG file");
        return NULL;
    }
    png_set_read_fn(r->png, r, file_read);
    png_set_user_limits(r->png, PNG_UINT_31_MAX, PNG_UINT_31_MAX); /* as png_decode */
    png_read_info(r->png, r->info);
    png_uint_32 w = png_get_image_width(r->png, r->info);
    png_uint_32 h = png_get_image_height(r->png, r->info);
    if (!sizes_fit(w, h, err, errlen)) {
        png_rows_free(r);
        return NULL;
    }
    png_textp texts = NULL;
    int ntexts = 0;
    png_get_text(r->png, r->info, &texts, &ntexts);
    for (int i = 0; i < ntexts; i++) {
        if (strcmp(texts[i].key, IMAGE_REGION_TAG) != 0)
            continue;
        char why[160];
        if (!image_region_parse(texts[i].text, texts[i].text_length, (int)w, (int)h,
                                &lay->region, why, sizeof why)) {
            png_rows_free(r);
            codec_fail(err, errlen, "%s", why);
            return NULL;
        }
        lay->has_region = true;
    }
    lay->width = (int)w;
    lay->height = (int)h;
    /* The passes of an interlaced file each cover the whole image. */
    if (png_get_interlace_type(r->png, r->info) != PNG_INTERLACE_NONE) {
        *interlaced = true;
        return r;
    }
    /* As decode: every colour type and depth to 8-bit RGB. */
    png_set_expand(r->png);
    png_set_strip_16(r->png);
    png_set_strip_alpha(r->png);
    png_set_gray_to_rgb(r->png);
    png_read_update_info(r->png, r->info);
    if (png_get_rowbytes(r->png, r->info) != (size_t)w * 3)
        png_error(r->png, "unexpected row layout");
    return r;
}

bool png_rows_next(PngRows *r, int fd, uint8_t *rgb, char *err, size_t errlen)
{
    r->fd = fd;
    if (setjmp(png_jmpbuf(r->png)))
        return codec_fail(err, errlen, "corrupt or truncated PNG file");
    png_read_row(r->png, rgb, NULL);
    return true;
}

static bool rows_end(PngRows *r, char *err, size_t errlen)
{
    if (setjmp(png_jmpbuf(r->png)))
        return codec_fail(err, errlen, "corrupt or truncated PNG file");
    png_read_end(r->png, NULL);
    return true;
}

bool png_rows_finish(PngRows *r, int fd, char *err, size_t errlen)
{
    r->fd = fd;
    bool ok = rows_end(r, err, errlen);
    png_rows_free(r);
    return ok;
}

#endif

/* The signature is known without libpng, so a PNG file is recognised (and refused with
 * the remedy) even when the codec is not built in. */
static bool png_sniff(const uint8_t *d, size_t len)
{
    static const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    return len >= sizeof sig && memcmp(d, sig, sizeof sig) == 0;
}

static const char *const png_extensions[] = {".png", NULL};

#ifdef RT_HAVE_PNG
const ImageCodec png_codec = {"png", png_extensions, png_sniff, png_encode, NULL, png_decode,
                              NULL, NULL, NULL, NULL};
#else
/* Why PNG is missing, for its messages and --version. A PNG=0 build (mk/png.mk defines
 * RT_PNG_LEFT_OUT) left it out on purpose: telling its user to install libpng-dev, which
 * may well be installed, would change nothing. Otherwise pkg-config found no libpng. */
#ifdef RT_PNG_LEFT_OUT
#define PNG_MISSING "this build leaves it out on purpose, PNG=0: rebuild without PNG=0 (make)"
#else
#define PNG_MISSING "install libpng-dev and rebuild (make PNG=1)"
#endif
const ImageCodec png_codec = {"png", png_extensions, png_sniff, NULL, NULL, NULL, PNG_MISSING,
                              NULL, NULL, NULL};
#endif
