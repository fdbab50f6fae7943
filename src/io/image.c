/* The in-memory Image, the course's float->byte quantisation, and writing/reading image
 * files by name: the format follows the extension, and a write goes to a temporary file
 * in the target folder that is renamed into place, so a failed run leaves no file. */
#define _POSIX_C_SOURCE 200809L
#include "rt/image.h"

#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>
#include <unistd.h>

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

/* ---- file names ---------------------------------------------------------------- */

typedef enum ImageFormat { FMT_UNKNOWN, FMT_TGA, FMT_PPM, FMT_PNG } ImageFormat;

static ImageFormat format_from_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    const char *dot = strrchr(base, '.');
    if (!dot)
        return FMT_UNKNOWN;
    if (strcasecmp(dot, ".tga") == 0)
        return FMT_TGA;
    if (strcasecmp(dot, ".ppm") == 0)
        return FMT_PPM;
    if (strcasecmp(dot, ".png") == 0)
        return FMT_PNG;
    return FMT_UNKNOWN;
}

static const char *supported_list(void)
{
    return image_png_supported() ? ".tga, .ppm, .png" : ".tga, .ppm";
}

static void report(Diag *diag, const char *path, const char *fmt_msg, const char *detail)
{
    if (!diag)
        return;
    SrcLoc loc = {path, 0, 0};
    diag_error(diag, &loc, "%s%s", fmt_msg, detail ? detail : "");
}

/* ---- writing ------------------------------------------------------------------- */

static bool write_all(int fd, const uint8_t *p, size_t n)
{
    while (n > 0) {
        ssize_t w = write(fd, p, n);
        if (w < 0) {
            if (errno == EINTR)
                continue;
            return false;
        }
        if (w == 0) {
            errno = EIO;
            return false;
        }
        p += w;
        n -= (size_t)w;
    }
    return true;
}

/* Writes bytes to path through "<dir>/.<name>.XXXXXX" + rename(2): rename within one
 * folder is atomic, so readers (and a crash) see either no file or the whole file. */
static bool write_atomically(const char *path, const uint8_t *data, size_t len, Diag *diag)
{
    size_t plen = strlen(path);
    const char *slash = strrchr(path, '/');
    size_t dirlen = slash ? (size_t)(slash - path) + 1 : 0;
    char *tmp = malloc(plen + 16);
    if (!tmp) {
        report(diag, path, "cannot write image: ", strerror(ENOMEM));
        return false;
    }
    memcpy(tmp, path, dirlen);
    tmp[dirlen] = '.';
    memcpy(tmp + dirlen + 1, path + dirlen, plen - dirlen);
    memcpy(tmp + plen + 1, ".XXXXXX", 8);

    int fd = mkstemp(tmp);
    if (fd < 0) {
        int e = errno;
        report(diag, path, "cannot write image: ", strerror(e));
        free(tmp);
        return false;
    }
    /* mkstemp creates the file 0600; give it the permissions a plain fopen would. */
    mode_t mask = umask(0);
    umask(mask);
    bool ok = fchmod(fd, (mode_t)(0666 & ~mask)) == 0 && write_all(fd, data, len);
    int e = errno;
    if (close(fd) != 0 && ok) {
        ok = false;
        e = errno;
    }
    if (ok && rename(tmp, path) != 0) {
        ok = false;
        e = errno;
    }
    if (!ok) {
        unlink(tmp);
        report(diag, path, "cannot write image: ", strerror(e));
    }
    free(tmp);
    return ok;
}

/* Writes straight into an existing non-regular file (a pipe, /dev/stdout, /dev/null):
 * renaming over it would replace the device node instead of writing to it. */
static bool write_direct(const char *path, const uint8_t *data, size_t len, Diag *diag)
{
    int fd = open(path, O_WRONLY | O_TRUNC);
    if (fd < 0) {
        report(diag, path, "cannot write image: ", strerror(errno));
        return false;
    }
    bool ok = write_all(fd, data, len);
    int e = errno;
    if (close(fd) != 0 && ok) {
        ok = false;
        e = errno;
    }
    if (!ok)
        report(diag, path, "cannot write image: ", strerror(e));
    return ok;
}

/* Chooses how to put the bytes at path: through a temporary file and rename for new or
 * regular files (following a symbolic link to its target, so the link stays a link),
 * directly for devices and pipes. Messages name the path the user gave. */
static bool write_bytes(const char *path, const uint8_t *data, size_t len, Diag *diag)
{
    struct stat st, lst;
    if (stat(path, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode))
        return write_direct(path, data, len, diag);
    if (lstat(path, &lst) == 0 && S_ISLNK(lst.st_mode)) {
        char *target = realpath(path, NULL);
        if (target) {
            Diag quiet;
            diag_init(&quiet, NULL);
            bool ok = write_atomically(target, data, len, &quiet);
            free(target);
            if (!ok && diag) {
                const char *why = strstr(quiet.last, "cannot write image: ");
                report(diag, path, why ? why : "cannot write image", NULL);
            }
            return ok;
        }
    }
    return write_atomically(path, data, len, diag);
}

bool image_write(const Image *img, const char *path, Diag *diag)
{
    uint8_t *buf = NULL;
    size_t len = 0;
    bool ok = false;

    if (!img || !img->pixels || img->width <= 0 || img->height <= 0) {
        report(diag, path, "cannot write image: ", "empty image");
        return false;
    }
    switch (format_from_name(path)) {
    case FMT_TGA:
        ok = tga_encode(img, &buf, &len);
        break;
    case FMT_PPM:
        ok = ppm_encode(img, &buf, &len);
        break;
    case FMT_PNG:
        if (!image_png_supported()) {
            report(diag, path, "PNG output is not built in: install libpng-dev and "
                   "rebuild (make PNG=1), or write .tga or .ppm", NULL);
            return false;
        }
        ok = png_encode(img, &buf, &len);
        break;
    case FMT_UNKNOWN:
    default:
        if (diag) {
            SrcLoc loc = {path, 0, 0};
            diag_error(diag, &loc, "unknown image format (file name must end in one of %s)",
                       supported_list());
        }
        return false;
    }
    if (!ok) {
        report(diag, path, "cannot write image: ", strerror(ENOMEM));
        return false;
    }
    ok = write_bytes(path, buf, len, diag);
    free(buf);
    return ok;
}

/* ---- reading ------------------------------------------------------------------- */

/* Reads a whole regular file; sets errno-style text in err on failure. */
static bool read_file(const char *path, uint8_t **out, size_t *out_len, int *err)
{
    FILE *f = fopen(path, "rb");
    if (!f) {
        *err = errno;
        return false;
    }
    size_t cap = 1 << 16, len = 0;
    uint8_t *buf = malloc(cap);
    if (!buf) {
        fclose(f);
        *err = ENOMEM;
        return false;
    }
    for (;;) {
        if (len == cap) {
            if (cap > (size_t)1 << 40) {
                free(buf);
                fclose(f);
                *err = EFBIG;
                return false;
            }
            uint8_t *nb = realloc(buf, cap * 2);
            if (!nb) {
                free(buf);
                fclose(f);
                *err = ENOMEM;
                return false;
            }
            buf = nb;
            cap *= 2;
        }
        size_t n = fread(buf + len, 1, cap - len, f);
        len += n;
        if (n == 0) {
            if (ferror(f)) {
                *err = errno ? errno : EIO;
                free(buf);
                fclose(f);
                return false;
            }
            break;
        }
    }
    fclose(f);
    *out = buf;
    *out_len = len;
    return true;
}

bool image_read(Image *img, const char *path, Diag *diag)
{
    uint8_t *data = NULL;
    size_t len = 0;
    int e = 0;
    char why[256] = "";
    bool ok;

    img->width = img->height = 0;
    img->pixels = NULL;
    if (!read_file(path, &data, &len, &e)) {
        report(diag, path, "cannot read image: ", strerror(e));
        return false;
    }
    /* PPM and PNG carry a signature; TGA has none, so it is the fallback. */
    static const uint8_t png_sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (len >= 2 && data[0] == 'P' && data[1] == '6') {
        ok = ppm_decode(data, len, img, why, sizeof why);
    } else if (len >= 8 && memcmp(data, png_sig, 8) == 0) {
        if (image_png_supported())
            ok = png_decode(data, len, img, why, sizeof why);
        else {
            snprintf(why, sizeof why, "PNG input is not built in (install libpng-dev and "
                     "rebuild)");
            ok = false;
        }
    } else {
        ok = tga_decode(data, len, img, why, sizeof why);
    }
    free(data);
    if (!ok)
        report(diag, path, "cannot read image: ", why);
    return ok;
}
