/* The body of the image decoder targets (fuzz_tga.c, fuzz_ppm.c, fuzz_png.c): the
 * format's decoder from the codec table on raw bytes and, when it accepts them, its
 * encoder on the decoded image (what we read we can write). A format this build lacks
 * (PNG without libpng) has no decoder: the input is then only read by image_read's
 * sniffing, which must refuse it cleanly. */
#ifndef RT_FUZZ_IMAGE_H
#define RT_FUZZ_IMAGE_H

#include <stdlib.h>

#include "rt/bigmem.h"
#include "rt/image.h"

static inline void fuzz_codec(const char *name, const uint8_t *data, size_t size)
{
    const ImageCodec *c = image_codec_find(name);
    if (!c || !c->decode)
        return;
    Image img;
    char err[256];
    if (c->decode(data, size, &img, err, sizeof err)) {
        uint8_t *out = NULL;
        size_t len = 0;
        if (c->encode && c->encode(&img, &out, &len))
            bigmem_free(out);
        image_free(&img);
    }
}

#endif
