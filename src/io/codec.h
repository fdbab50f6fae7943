/* Private to src/io/: the codec table and the decoders' error reporting. */
#ifndef RT_IO_CODEC_H
#define RT_IO_CODEC_H

#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <sys/types.h>
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

/* The longest file image_read takes (image.c says why). */
#define IMAGE_READ_MAX_BYTES ((size_t)3 * 32768 * 32768 + ((size_t)64 << 20))
/* How much of a file image_read reads before its codec's header function looks at it
 * (ImageCodec.header). */
enum { IMAGE_HEAD_PEEK = 1 << 16 };

/* image_read's early look at a file's first len bytes (at least IMAGE_HEAD_PEEK, a file
 * longer than that): false with the reason in why when they cannot begin an image of
 * their codec; else *limit is lowered to the longest file they can begin. */
bool codec_header_ok(const uint8_t *data, size_t len, size_t *limit, char *why,
                     size_t whylen);
/* The codec's name as messages write it: "PNG". */
void codec_upper_name(const ImageCodec *codec, char *buf, size_t size);

/* Where the rows of an uncompressed file lie (ImageCodec.rows), and how a stored
 * pixel becomes the bytes image_read's decode, quantised again, gives. */
typedef struct ImageRowLayout {
    int width, height;
    bool has_region;
    ImageRegion region;
    size_t offset;          /* of the first stored row */
    int pixel_bytes;        /* 3, or 4 (TGA with alpha, which is ignored) */
    bool top_down;          /* the first stored row is the top one */
    bool right_to_left;     /* pixels stored from the right edge */
    bool bgr;               /* B G R order in the file */
    int maxval;             /* samples above it clamp to it; 255 except in PPM */
} ImageRowLayout;

/* A stored row (pixel_bytes per pixel, as in the file) into R G B bytes, left to right:
 * the bytes of decode's pixels quantised (image_color_to_byte), so a merge that goes
 * through this is byte for byte the one through decode. */
void codec_row_to_rgb(const ImageRowLayout *lay, const uint8_t *stored, uint8_t *rgb);

#ifdef RT_HAVE_PNG
/* A PNG file read row by row (png.c): png_rows_open reads the chunks before the pixels
 * from fd (which it neither keeps nor closes; len is the file's length) and fills lay's size and
 * region record; *interlaced files cannot be read by rows (every pass covers all of
 * them): the caller reads those whole. png_rows_next gives the next row down as R G B
 * bytes, and png_rows_finish reads the rest of the file (the checksums decode checks)
 * and frees. False with decode's reason in err; png_rows_free frees after a failure. */
typedef struct PngRows PngRows;
PngRows *png_rows_open(int fd, size_t len, ImageRowLayout *lay, bool *interlaced, char *err,
                       size_t errlen);
/* fd: the file, open (it is read at the decoder's own offset, so it may be another
 * descriptor of the same file than the last call's, which may have been closed). */
bool png_rows_next(PngRows *r, int fd, uint8_t *rgb, char *err, size_t errlen);
bool png_rows_finish(PngRows *r, int fd, char *err, size_t errlen);
void png_rows_free(PngRows *r);

/* A PNG file written row by row (the top row first) through write(ctx, bytes, n), which
 * returns false on failure: the very bytes of png_codec's encode for the same rows (it
 * is made by these too). png_out_end writes the end and frees; png_out_free frees after
 * a failure. */
typedef struct PngOut PngOut;
PngOut *png_out_begin(const Image *img, bool (*write)(void *ctx, const uint8_t *p, size_t n),
                      void *ctx);
bool png_out_row(PngOut *o, const uint8_t *rgb);
bool png_out_end(PngOut *o);
void png_out_free(PngOut *o);
#endif

/* The open files of a merge's parts (rows.c). A part's file stays open from row to row
 * while fewer than cap are; to open another beyond that, the one read longest ago is
 * closed (and opened again at its next row: a TGA or PPM part is read at each row's
 * offset, a PNG part's decoder keeps its place in the file). Without it every part
 * crossing a strip held its file open, and a merge of some 500 parts side by side (two
 * per PNG part: 250) met the usual limit of 1024 open files (RLIMIT_NOFILE). */
typedef struct ImageRowsFiles {
    int open, cap;
    struct ImageRows *newest, *oldest; /* the parts whose file is open, by last read */
} ImageRowsFiles;

/* A part image read by rows for -merge (rows.c): image_rows_open checks the file as
 * image_read would before its pixels (the codec's header, the region record, the
 * length the header declares) and keeps no descriptor open; image_rows_read then gives
 * rows from the top, in increasing order, opening the file at the first, and
 * image_rows_end closes it (the rows read are all of them: a PNG's end is checked).
 * With files set (after image_rows_open) the file may be closed and opened again in
 * between, as ImageRowsFiles says; it must then still be the same file (device, inode
 * and length), or the read fails with "the file changed while it was merged".
 * Formats or files that cannot be read by rows (an interlaced PNG, a pipe, standard
 * input, a PPM whose header runs past its first 64 KiB) are read whole, as bytes, when
 * their first row is asked for (pipes when opened: they can be read once). Failures are
 * reported to diag as image_read reports them. */
typedef struct ImageRows {
    const char *path;
    int width, height;
    bool has_region;
    ImageRegion region;
    ImageRowsFiles *files; /* NULL: the file stays open from the first row to the end */
    /* The rest is rows.c's. */
    int mode;
    int fd;
    size_t file_len;
    dev_t dev;           /* the file image_rows_open checked */
    ino_t ino;
    struct ImageRows *newer, *older; /* in files' list while fd is open */
    ImageRowLayout lay;
    uint8_t *stored;     /* one stored row (ROWS_FILE) */
    uint8_t *whole;      /* the whole image as R G B, top row first (ROWS_WHOLE) */
    void *png;           /* PngRows (ROWS_PNG) */
    int next;            /* the next row from the top image_rows_read may give */
    bool started, done;
} ImageRows;
bool image_rows_open(ImageRows *r, const char *path, Diag *diag);
bool image_rows_read(ImageRows *r, int row, uint8_t *rgb, Diag *diag);
bool image_rows_end(ImageRows *r, Diag *diag);
void image_rows_free(ImageRows *r);

/* A sequentially written temporary file for path (ImageEncoding, head_only, nothing
 * written yet), renamed into place by image_write_all as image_encoding_stream's:
 * bytes go in with image_encoding_append. False where image_encoding_stream fails. */
bool image_encoding_stream_raw(ImageEncoding *e, const Image *img, const char *path);
void image_encoding_append(ImageEncoding *e, const uint8_t *p, size_t n);

#endif
