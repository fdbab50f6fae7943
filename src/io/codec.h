/* Private to src/io/: the codec table and the decoders' error reporting. */
#ifndef RT_IO_CODEC_H
#define RT_IO_CODEC_H

#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include "rt/bigmem.h"
#include "rt/image.h"
#include <string.h>

/* The codec that reads data: the first whose signature matches, else the one without a
 * signature (TGA). Never NULL. */
const ImageCodec *image_codec_for_data(const uint8_t *data, size_t len);

/* Formats the reason a decoder refuses its input into err (if any); returns false so
 * decoders can write `return codec_fail(err, errlen, "...")`. */
static inline bool codec_fail(char *err, size_t errlen, const char *fmt, ...)
    __attribute__((format(printf, 3, 4)));
static inline bool codec_fail(char *err, size_t errlen, const char *fmt, ...)
{
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return false;
}

/* A codec's layout made from its head: the whole file allocated (rt/bigmem.h, zeroed)
 * and the header copied to its start. */
static inline bool codec_layout_from_head(bool (*head)(const Image *, uint8_t *, size_t *,
                                                       size_t *, bool *),
                                          const Image *img, uint8_t **out, size_t *out_len,
                                          size_t *top, bool *bgr)
{
    uint8_t h[IMAGE_HEAD_MAX];
    if (!head(img, h, top, out_len, bgr))
        return false;
    uint8_t *b = bigmem_alloc(*out_len);
    if (!b)
        return false;
    memcpy(b, h, *top);
    *out = b;
    return true;
}

#endif
