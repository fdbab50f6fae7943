/* Part images read row by row, for -merge (codec.h: ImageRows). A merge of a big frame
 * held every part's pixels in turn and the whole output: 163 MB for 6000x4000. Read by
 * rows, a part costs one row buffer while the merge reads it, and nothing before. The
 * checks image_read makes before the pixels are made here the same way (the same
 * functions where they can be shared, the same messages), before any row is read. */
#include "codec.h"

#include <errno.h>
#include <fcntl.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

enum { ROWS_FILE = 1, ROWS_PNG, ROWS_WHOLE };

static void rows_report(Diag *diag, const char *path, const char *why)
{
    SrcLoc loc = {strcmp(path, "-") == 0 ? "<stdin>" : path, 0, 0};
    diag_error(diag, &loc, "cannot read image: %s", why);
}

void codec_row_to_rgb(const ImageRowLayout *lay, const uint8_t *stored, uint8_t *rgb)
{
    /* decode gives each sample s as min(s, maxval) / maxval, which quantises back to s
     * when maxval is 255 (all 256 values); other maxvals go through the same float
     * division and quantisation, so the bytes are those of decode and image_put. */
    uint8_t map[256];
    for (int v = 0; v < 256; v++)
        map[v] = image_color_to_byte((float)(v > lay->maxval ? lay->maxval : v) /
                                     (float)lay->maxval);
    int w = lay->width;
    size_t pb = (size_t)lay->pixel_bytes;
    for (int i = 0; i < w; i++) {
        const uint8_t *p = stored + (size_t)i * pb;
        int x = lay->right_to_left ? w - 1 - i : i;
        uint8_t *o = rgb + (size_t)x * 3;
        o[0] = map[lay->bgr ? p[2] : p[0]];
        o[1] = map[p[1]];
        o[2] = map[lay->bgr ? p[0] : p[2]];
    }
}

/* The whole file through image_read, kept as R G B bytes: for what cannot be read by
 * rows. */
static bool read_whole(ImageRows *r, Diag *diag)
{
    Image img;
    if (!image_read(&img, r->path, diag))
        return false;
    r->width = img.width;
    r->height = img.height;
    r->has_region = img.has_region;
    r->region = img.region;
    size_t row = (size_t)img.width * 3;
    r->whole = malloc(row * (size_t)img.height);
    if (!r->whole) {
        image_free(&img);
        rows_report(diag, r->path, strerror(ENOMEM));
        return false;
    }
    for (int t = 0; t < img.height; t++)
        image_row_bytes(&img, img.height - 1 - t, false, r->whole + (size_t)t * row);
    image_free(&img);
    r->mode = ROWS_WHOLE;
    return true;
}

/* Reads the first n bytes of fd into buf: false on a read error (errno set). */
static bool read_head(int fd, uint8_t *buf, size_t n)
{
    size_t got = 0;
    while (got < n) {
        ssize_t k = pread(fd, buf + got, n - got, (off_t)got);
        if (k < 0 && errno == EINTR)
            continue;
        if (k < 0)
            return false;
        if (k == 0) {
            errno = EIO; /* the file shrank under us */
            return false;
        }
        got += (size_t)k;
    }
    return true;
}

bool image_rows_open(ImageRows *r, const char *path, Diag *diag)
{
    memset(r, 0, sizeof *r);
    r->path = path;
    r->fd = -1;
    /* Standard input, a pipe or a device can be read once: now, whole (a FIFO opened
     * here to look would take its one writer's bytes). A file that cannot be opened is
     * reported by image_read as always. */
    struct stat st;
    if (strcmp(path, "-") == 0 || stat(path, &st) != 0 || !S_ISREG(st.st_mode))
        return read_whole(r, diag);
    int fd = open(path, O_RDONLY | O_CLOEXEC);
    if (fd < 0 || fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
        if (fd >= 0)
            close(fd);
        return read_whole(r, diag);
    }
    r->dev = st.st_dev;
    r->ino = st.st_ino;
    if ((uintmax_t)st.st_size > IMAGE_READ_MAX_BYTES) {
        close(fd);
        rows_report(diag, path, strerror(EFBIG));
        return false;
    }
    size_t len = (size_t)st.st_size;
    size_t head_len = len < IMAGE_HEAD_PEEK ? len : IMAGE_HEAD_PEEK;
    uint8_t *head = malloc(head_len ? head_len : 1);
    char why[256] = "";
    bool ok = head != NULL;
    if (!ok)
        snprintf(why, sizeof why, "%s", strerror(ENOMEM));
    else if (!read_head(fd, head, head_len)) {
        snprintf(why, sizeof why, "%s", strerror(errno));
        ok = false;
    }
    /* As image_read: a file of at least 64 KiB is first judged by its header, which
     * also bounds how long the file may be. */
    const ImageCodec *codec = ok ? image_codec_for_data(head, head_len) : NULL;
    if (ok && head_len == IMAGE_HEAD_PEEK) {
        size_t limit = IMAGE_READ_MAX_BYTES;
        ok = codec_header_ok(head, head_len, &limit, why, sizeof why);
        if (ok && len > limit) {
            char name[16];
            codec_upper_name(codec, name, sizeof name);
            snprintf(why, sizeof why, "the file goes on past the %zu bytes its %s header "
                     "allows", limit, name);
            ok = false;
        }
    }
    if (ok && !codec->decode) {
        char name[16];
        codec_upper_name(codec, name, sizeof name);
        snprintf(why, sizeof why, "%s input is not built in: %s", name, codec->missing);
        ok = false;
    }
    int got = -1;
    if (ok && codec->rows) {
        got = codec->rows(head, head_len, len, &r->lay, why, sizeof why);
        ok = got != 0;
    }
    free(head);
#ifdef RT_HAVE_PNG
    if (ok && got < 0 && !codec->rows && strcmp(codec->name, "png") == 0) {
        bool interlaced = false;
        PngRows *png = png_rows_open(fd, len, &r->lay, &interlaced, why, sizeof why);
        ok = png != NULL;
        if (png) {
            png_rows_free(png);
            got = interlaced ? -1 : 1;
            r->mode = interlaced ? ROWS_WHOLE : ROWS_PNG;
        }
    } else
#endif
    if (ok && got == 1)
        r->mode = ROWS_FILE;
    close(fd);
    if (!ok) {
        rows_report(diag, path, why);
        return false;
    }
    if (got < 0 && r->mode != ROWS_WHOLE) {
        /* Not to be read by rows and not yet checked (a PPM of long comments): whole,
         * now, as image_read would. */
        return read_whole(r, diag);
    }
    /* An interlaced PNG: checked; read whole when its first row is needed. */
    r->file_len = len;
    r->width = r->lay.width;
    r->height = r->lay.height;
    r->has_region = r->lay.has_region;
    r->region = r->lay.region;
    return true;
}

/* r's place in its files' list (newest first), while its file is open. */
static void files_remove(ImageRows *r)
{
    ImageRowsFiles *f = r->files;
    if (!f)
        return;
    if (r->newer)
        r->newer->older = r->older;
    else
        f->newest = r->older;
    if (r->older)
        r->older->newer = r->newer;
    else
        f->oldest = r->newer;
    r->newer = r->older = NULL;
    f->open--;
}

static void files_add(ImageRows *r)
{
    ImageRowsFiles *f = r->files;
    if (!f)
        return;
    r->newer = NULL;
    r->older = f->newest;
    if (f->newest)
        f->newest->newer = r;
    else
        f->oldest = r;
    f->newest = r;
    f->open++;
}

/* Closes r's file; its place (the next row, a PNG decoder's offset) is kept. */
static void rows_close(ImageRows *r)
{
    if (r->fd < 0)
        return;
    files_remove(r);
    close(r->fd);
    r->fd = -1;
}

/* r's file, open in r->fd and the newest of its files: opened (again) when it is not,
 * after closing the file read longest ago when cap are open, or when the open finds
 * no descriptor left (the cap is the merge's estimate; the process may hold others).
 * It must be the file image_rows_open checked: one renamed over it meanwhile (a part
 * rendered again) would mix two files' rows. */
static bool rows_file(ImageRows *r, Diag *diag)
{
    ImageRowsFiles *f = r->files;
    if (r->fd >= 0) {
        if (f && f->newest != r) {
            files_remove(r);
            files_add(r);
        }
        return true;
    }
    if (f && f->open >= f->cap && f->oldest)
        rows_close(f->oldest);
    int fd;
    for (;;) {
        fd = open(r->path, O_RDONLY | O_CLOEXEC);
        if (fd >= 0)
            break;
        if (errno == EINTR)
            continue;
        if ((errno == EMFILE || errno == ENFILE) && f && f->oldest) {
            rows_close(f->oldest);
            continue;
        }
        rows_report(diag, r->path, strerror(errno));
        return false;
    }
    struct stat st;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_dev != r->dev ||
        st.st_ino != r->ino || (uintmax_t)st.st_size != (uintmax_t)r->file_len) {
        close(fd);
        rows_report(diag, r->path, "the file changed while it was merged");
        return false;
    }
    r->fd = fd;
    files_add(r);
    return true;
}

/* Opens the file for its rows (the first image_rows_read). */
static bool rows_start(ImageRows *r, Diag *diag)
{
    if (r->mode == ROWS_WHOLE) {
        if (r->whole)
            return true;
        /* An interlaced PNG, whose size and record were checked: all of it now. */
        int w = r->width, h = r->height;
        if (!read_whole(r, diag))
            return false;
        if (r->width != w || r->height != h) {
            rows_report(diag, r->path, "the file changed while it was merged");
            return false;
        }
        return true;
    }
    if (!rows_file(r, diag))
        return false;
    char why[256] = "";
#ifdef RT_HAVE_PNG
    if (r->mode == ROWS_PNG) {
        ImageRowLayout lay;
        bool interlaced = false;
        r->png = png_rows_open(r->fd, r->file_len, &lay, &interlaced, why, sizeof why);
        if (r->png && (interlaced || lay.width != r->width || lay.height != r->height)) {
            png_rows_free(r->png);
            r->png = NULL;
            snprintf(why, sizeof why, "the file changed while it was merged");
        }
        if (!r->png) {
            rows_report(diag, r->path, why);
            return false;
        }
        return true;
    }
#endif
    r->stored = malloc((size_t)r->width * (size_t)r->lay.pixel_bytes);
    if (!r->stored) {
        rows_report(diag, r->path, strerror(ENOMEM));
        return false;
    }
    return true;
}

bool image_rows_read(ImageRows *r, int row, uint8_t *rgb, Diag *diag)
{
    if (row < r->next || row >= r->height || r->done)
        return false;
    if (!r->started) {
        if (!rows_start(r, diag))
            return false;
        r->started = true;
    }
    size_t w3 = (size_t)r->width * 3;
    char why[256] = "";
    if (r->mode == ROWS_WHOLE) {
        memcpy(rgb, r->whole + (size_t)row * w3, w3);
    } else if (!rows_file(r, diag)) {
        return false;
    } else if (r->mode == ROWS_FILE) {
        const ImageRowLayout *lay = &r->lay;
        size_t stored = (size_t)r->width * (size_t)lay->pixel_bytes;
        size_t index = lay->top_down ? (size_t)row : (size_t)(r->height - 1 - row);
        ssize_t k;
        size_t got = 0;
        while (got < stored) {
            k = pread(r->fd, r->stored + got, stored - got,
                      (off_t)(lay->offset + index * stored + got));
            if (k < 0 && errno == EINTR)
                continue;
            if (k <= 0) {
                rows_report(diag, r->path, k < 0 ? strerror(errno)
                                                 : "the file changed while it was merged");
                return false;
            }
            got += (size_t)k;
        }
        codec_row_to_rgb(lay, r->stored, rgb);
#ifdef RT_HAVE_PNG
    } else if (r->mode == ROWS_PNG) {
        /* libpng gives the rows in order: the ones skipped are read and dropped. */
        for (int t = r->next; t <= row; t++)
            if (!png_rows_next(r->png, r->fd, rgb, why, sizeof why)) {
                rows_report(diag, r->path, why);
                return false;
            }
#endif
    }
    r->next = row + 1;
    return true;
}

bool image_rows_end(ImageRows *r, Diag *diag)
{
    bool ok = true;
#ifdef RT_HAVE_PNG
    if (r->png) {
        char why[256] = "";
        /* The rest of the file is read (reported by rows_file when it cannot be). */
        bool reported = !rows_file(r, diag);
        ok = !reported;
        /* Rows left unread would fail png_read_end: read them first. */
        uint8_t *rest = ok && r->next < r->height ? malloc((size_t)r->width * 3) : NULL;
        if (ok && !rest && r->next < r->height) {
            snprintf(why, sizeof why, "%s", strerror(ENOMEM));
            ok = false;
        }
        for (int t = r->next; t < r->height && ok; t++)
            ok = png_rows_next(r->png, r->fd, rest, why, sizeof why);
        free(rest);
        if (ok)
            ok = png_rows_finish(r->png, r->fd, why, sizeof why); /* frees it */
        else
            png_rows_free(r->png);
        r->png = NULL;
        if (!ok && !reported)
            rows_report(diag, r->path, why);
    }
#else
    (void)diag;
#endif
    rows_close(r);
    free(r->stored);
    r->stored = NULL;
    free(r->whole);
    r->whole = NULL;
    r->done = true;
    return ok;
}

void image_rows_free(ImageRows *r)
{
#ifdef RT_HAVE_PNG
    png_rows_free(r->png);
    r->png = NULL;
#endif
    rows_close(r);
    free(r->stored);
    free(r->whole);
    r->stored = r->whole = NULL;
}
