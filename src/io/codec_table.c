/* The image formats this program knows, and finding one by name, file name or content.
 * A new format is its own file (defining `const ImageCodec NAME_codec`, see rt/image.h)
 * plus one row here. */
#include "codec.h"

#include <string.h>
#include <strings.h>

/* Each codec lives in its own file; the table is the only place that names them all.
 * Exactly one format has no signature (TGA): image_codec_for_data falls back to it. */
extern const ImageCodec tga_codec, ppm_codec, png_codec;

static const ImageCodec *const codecs[] = {
    &tga_codec,
    &ppm_codec,
    &png_codec,
};
enum { NUM_CODECS = (int)(sizeof codecs / sizeof codecs[0]) };

const ImageCodec *image_codec_at(int i)
{
    return i >= 0 && i < NUM_CODECS ? codecs[i] : NULL;
}

const ImageCodec *image_codec_find(const char *name)
{
    for (int i = 0; i < NUM_CODECS; i++)
        if (strcmp(codecs[i]->name, name) == 0)
            return codecs[i];
    return NULL;
}

const ImageCodec *image_codec_for_path(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    if (!dot)
        return NULL;
    for (int i = 0; i < NUM_CODECS; i++)
        for (const char *const *e = codecs[i]->extensions; *e; e++)
            if (strcasecmp(dot, *e) == 0)
                return codecs[i];
    return NULL;
}

const ImageCodec *image_codec_for_data(const uint8_t *data, size_t len)
{
    const ImageCodec *fallback = NULL;
    for (int i = 0; i < NUM_CODECS; i++) {
        if (!codecs[i]->sniff)
            fallback = codecs[i];
        else if (codecs[i]->sniff(data, len))
            return codecs[i];
    }
    return fallback;
}

bool image_format_supported(const char *name)
{
    const ImageCodec *c = image_codec_find(name);
    return c && c->encode && c->decode;
}

void image_format_list(char *buf, size_t size)
{
    size_t n = 0;
    if (size == 0)
        return;
    buf[0] = '\0';
    for (int i = 0; i < NUM_CODECS; i++) {
        if (!codecs[i]->encode)
            continue;
        for (const char *const *e = codecs[i]->extensions; *e; e++) {
            int k = snprintf(buf + n, size - n, "%s%s", n ? ", " : "", *e);
            if (k < 0 || (size_t)k >= size - n) {
                buf[n] = '\0'; /* whole entries only */
                return;
            }
            n += (size_t)k;
        }
    }
}

void image_format_names(char *buf, size_t size)
{
    size_t n = 0;
    if (size == 0)
        return;
    buf[0] = '\0';
    for (int i = 0; i < NUM_CODECS; i++)
        if (codecs[i]->encode && n + strlen(codecs[i]->name) + 3 < size)
            n += (size_t)snprintf(buf + n, size - n, "%s%s", n ? ", " : "", codecs[i]->name);
}
