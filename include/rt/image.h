/* Float RGB images and their files. Pixel (x, y): x left->right, y bottom->top,
 * like the course Image class. */
#ifndef RT_IMAGE_H
#define RT_IMAGE_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>
#include "rt/diag.h"
#include "rt/vec.h"

/* Where a part image sits in the full image it was cut from (-region, -tile): its
 * top-left pixel (x, y), counted from the full image's top-left corner as files store
 * images, and the full image's size; and which render it is a part of. Files carry it
 * as one line of text (REGION_TAG x y w h full_width full_height render=ID, ID 16
 * lowercase hex digits; files of earlier versions end before " render="): the TGA
 * image ID field, a PNG tEXt chunk with the keyword REGION_TAG, or a PPM comment line
 * "# REGION_TAG ...".
 * The render identity: parts with the same one come from the same scene text, the same
 * OBJ files' bytes and the same options that decide pixels (the image's kind -- colour,
 * depth or normals -- included); options that never change a pixel (-threads, -grid,
 * -accel, -cache, -stats, the output's format, ...) do not enter it, so parts rendered
 * with different ones merge. -merge refuses parts of different identities. */
typedef struct ImageRegion {
    int x, y;
    int full_width, full_height;
    bool has_id;        /* false: a record without one (an earlier version's part) */
    uint64_t id;
} ImageRegion;
#define IMAGE_REGION_TAG "raytracer-region"

typedef struct Image {
    int width, height;
    Vec3 *pixels;       /* width*height, row y = 0 (bottom) first; NULL in a byte image */
    bool has_region;    /* false: a whole image (no record written or found) */
    ImageRegion region; /* when has_region: this image is region x y width height */
    /* A byte image (image_init_bytes) instead holds the bytes a file gets: width*height
     * R, G, B triples, row y = 0 first, each colour quantised as it is stored
     * (image_put). It is made to be written (image_row_bytes, the encoders), not read
     * back: image_get, image_set and image_fill need pixels. */
    uint8_t *bytes;
} Image;

/* Allocates a black image; false on bad size or out of memory. */
bool image_init(Image *img, int width, int height);
/* Allocates a black byte image (see Image.bytes): a quarter of the memory of a float
 * image, and the encoders only copy it. For images that are only written. */
bool image_init_bytes(Image *img, int width, int height);
void image_free(Image *img);
void image_fill(Image *img, Vec3 c);
static inline void image_set(Image *img, int x, int y, Vec3 c) { img->pixels[(long)y * img->width + x] = c; }
static inline Vec3 image_get(const Image *img, int x, int y) { return img->pixels[(long)y * img->width + x]; }

/* The record's text "x y w h full_width full_height" (without the tag) into buf;
 * false if it does not fit. */
bool image_region_format(const Image *img, char *buf, size_t size);
/* Parses that text for an image of w x h pixels; false (with a reason in err) when it is
 * malformed or the rectangle does not lie inside the full size. */
bool image_region_parse(const char *text, size_t len, int w, int h, ImageRegion *out,
                        char *err, size_t errlen);

/* The course quantisation: clamp(int(c * 255), 0, 255); NaN -> 0 (docs/images.md). */
static inline uint8_t image_color_to_byte(float c)
{
    /* The course: v = (int)(c * 255), then clamped to 0..255. The clamp happens in float
     * first because converting NaN or a huge float to int is undefined in C; for every
     * finite input the result equals the course's. */
    float v = c * 255.0f;
    if (!(v > 0.0f)) /* also catches NaN */
        return 0;
    if (v >= 255.0f)
        return 255;
    return (uint8_t)(int)v; /* truncation toward zero, like the course */
}

/* Stores colour c at (x, y) of a float image, or its bytes in a byte image. */
static inline void image_put(Image *img, int x, int y, Vec3 c)
{
    long i = (long)y * img->width + x;
    if (img->bytes) {
        uint8_t *b = img->bytes + 3 * i;
        b[0] = image_color_to_byte(c.x);
        b[1] = image_color_to_byte(c.y);
        b[2] = image_color_to_byte(c.z);
    } else {
        img->pixels[i] = c;
    }
}

/* Row y of any image as the bytes a file holds: 3 * width bytes, R G B per pixel, or
 * B G R when bgr (TGA's order); a float image is quantised (image_color_to_byte). */
void image_row_bytes(const Image *img, int y, bool bgr, uint8_t *out);

/* Writes by file name extension (image_codec_for_path): .tga (course layout), .ppm (P6),
 * .png (when built with libpng). Writes to a temporary file in the same folder and
 * renames it, so a failure leaves no file. The path "-" (IMAGE_STDOUT) is standard
 * output, in TGA. Reports failures to diag. */
bool image_write(const Image *img, const char *path, Diag *diag);

/* The file name that means standard output (-output -). */
#define IMAGE_STDOUT "-"

/* True when path names the null device (/dev/null, or a link to it): an image written
 * there is discarded (-output /dev/null times a render without keeping it). Its name
 * needs no extension: TGA bytes are written into it, in place, like into any device. */
bool image_is_null_device(const char *path);

/* Before any work: whether image_write_all could write path in format (a codec's name;
 * NULL: by the extension, TGA for standard output), judged without writing: the format
 * is one this build writes, a file's extension names that format, and path is no
 * folder and lies in an existing folder that takes new files (or is an existing pipe or
 * device that takes writes); standard output must be open and not a terminal (binary
 * bytes would garble it). False with the reason reported to diag. */
bool image_check_output(const char *path, const char *format, Diag *diag);

/* Standard output is a launcher's channel (an MPI rank's): from then on
 * image_check_output does not refuse a terminal there. OpenMPI's mpirun gives every
 * rank a pseudo-terminal as standard output and copies its bytes, unchanged, to its own
 * standard output, so a terminal there says nothing about where the image goes
 * (mpirun ... -output - > frame.tga was refused). */
void image_stdout_forwarded(bool forwarded);

/* Several images, all or nothing: each goes to its temporary file first (an existing
 * pipe or device is written in place after those), and the temporary files are renamed
 * into place only when every write succeeded; on failure none is renamed and all are
 * removed. The caller refuses the same path twice. One write at a time per process. */
enum { IMAGE_MAX_OUTPUTS = 8 };
typedef struct ImageOutput {
    const Image *image;
    const char *path;     /* IMAGE_STDOUT: standard output, written after the files */
    const char *format;   /* a codec's name; NULL: by the extension (TGA for stdout) */
    /* NULL, or the file's bytes already made from image (image_encoding_begin, every
     * row then given to image_encoding_row): written as they are, not encoded again.
     * The caller keeps owning them. */
    struct ImageEncoding *encoded;
} ImageOutput;
bool image_write_all(const ImageOutput *outs, int n, Diag *diag);

/* An image file made row by row while its image is being made (the renderer calls
 * image_encoding_row for each finished row, on its worker threads, or renders the colour
 * straight into data: RenderTarget.color_file), for the formats
 * that store uncompressed rows at fixed places (TGA, PPM): the write after the render
 * then only writes. The bytes are exactly the codec's encode's. */
typedef struct ImageEncoding {
    uint8_t *data;        /* the whole file (rt/bigmem.h), its header written */
    size_t len;
    size_t top;           /* offset of the image's top row (both formats store it first) */
    int width, height;    /* of the image it was begun for */
    bool bgr;             /* B G R per pixel (TGA) */
    /* Streamed (image_encoding_stream): the temporary file written as rows are
     * flushed, its slot for image_write_abort, the path it will be renamed to, and the
     * first failed write's errno (0: none). fd and slot -1 otherwise. */
    int fd, slot;
    char *target;
    atomic_int err;
    /* data holds only the header (its first top bytes), len is still the whole file's:
     * the rows exist only in the streamed file (image_encoding_stream_only).
     * image_encoding_row and image_encoding_flush then do nothing, and image_write_all
     * takes the encoding only as the streamed file it is. */
    bool head_only;
    /* Bytes written so far by image_encoding_append (src/io/codec.h: -merge's PNG). */
    size_t appended;
} ImageEncoding;
/* Begins the file of img (its size and region record) for path in format (as
 * ImageOutput). False, with *e zeroed and nothing reported, when the format has no
 * such layout (PNG), the codec is not found or memory is short: the caller encodes at
 * the end as before (image_write_all reports what is wrong). */
bool image_encoding_begin(ImageEncoding *e, const Image *img, const char *path,
                          const char *format);
/* Row y of img (0 = bottom, as Image) into its place: rows are disjoint, so threads may
 * encode different rows at once. */
void image_encoding_row(const ImageEncoding *e, const Image *img, int y);
/* Also writes the file while it is made: creates its temporary file now (in the folder
 * of path, named and registered as image_write_all's, header written), into which
 * image_encoding_flush writes finished rows; image_write_all then only renames it (or
 * reports the first failed write and removes it). False, and nothing made, for
 * standard output, pipes and devices (written at the end) or when the file cannot be
 * made (the write reports it later). */
bool image_encoding_stream(ImageEncoding *e, const char *path);
/* Rows y_lo..y_hi of the image, already encoded, into the streamed file at their place
 * (nothing when not streamed). Threads may flush disjoint rows at once. */
void image_encoding_flush(ImageEncoding *e, int y_lo, int y_hi);
/* The same from rows given in the file's layout (row y_hi first, 3 * width bytes each)
 * instead of from e->data, whose rows are then left as they are: for rows made
 * elsewhere (RenderTarget.color_rows). */
void image_encoding_flush_rows(ImageEncoding *e, int y_lo, int y_hi, const uint8_t *rows);
/* Begins img's file for path in format (as image_encoding_begin) and streams it (as
 * image_encoding_stream) without ever holding its rows: only the header is kept
 * (head_only), and the rows are given by image_encoding_put. For an image too big to
 * hold whole (an antialiased render's rows come strip by strip: rt/film.h). img is only
 * read for its size and region record (it needs no pixels). False, with nothing made
 * and nothing reported, where image_encoding_begin or image_encoding_stream would fail
 * (PNG, standard output, a pipe or device, a file that cannot be made): the caller then
 * renders the whole image as before. */
bool image_encoding_stream_only(ImageEncoding *e, const Image *img, const char *path,
                                const char *format);
/* Whether image_encoding_stream_only would stream path's file: a format with fixed
 * rows (TGA, PPM, by format or else the extension), and a path that is neither
 * standard output nor an existing pipe or device (a regular file, or none yet). Made
 * for deciding ahead; the stream itself may still fail (and say so). */
bool image_output_streams(const char *path, const char *format);
/* Part of the image into the streamed file at its place: part's pixels (a float or byte
 * image, row 0 at the bottom) are the image's columns x .. x + part->width - 1 of rows
 * y .. y + part->height - 1. A failed write is kept for image_write_all to report, as
 * image_encoding_flush's; nothing happens when not streamed or when part does not lie
 * inside. Calls for disjoint parts may run at once. */
void image_encoding_put(ImageEncoding *e, const Image *part, int x, int y);
/* Frees the bytes; a streamed file not handed to image_write_all is closed and removed
 * (a failed or stopped render leaves no file). */
void image_encoding_free(ImageEncoding *e);
/* The errno of the first failed write into e's streamed file, 0 while none failed (any
 * thread: a render checks it after each write, so that a full disk or a file-size
 * limit stops the render at once instead of being reported only at its end). */
int image_encoding_error(const ImageEncoding *e);
/* Reports err for path as image_write_all reports a failed write ("cannot write image:
 * <reason>"), for a render that stopped on image_encoding_error. */
void image_report_write_error(const char *path, int err, Diag *diag);

/* For a signal handler (async-signal-safe): when image_write_all is writing its
 * temporary files, removes them and returns true (the caller then ends the process
 * with _exit, and nothing has been renamed into place); false when no write is under
 * way or the renames have begun (they finish: the images are then complete). */
bool image_write_abort(void);
/* Reads any format of the codec table: by its signature (PPM "P6", PNG), else as TGA
 * (uncompressed 24/32-bit, either row order), the format without one. The path "-"
 * reads standard input. */
bool image_read(Image *img, const char *path, Diag *diag);

/* One image file format: a static const table in the format's own file (src/io/tga.c,
 * ppm.c, png.c), listed in src/io/codec_table.c. Adding a format is one new file and one
 * row there. */
struct ImageRowLayout;
typedef struct ImageCodec {
    const char *name;              /* "tga": lower case, what image_codec_find takes */
    const char *const *extensions; /* NULL-terminated, with the dot: ".tga" */
    /* True when data begins with the format's signature. NULL for a format without one
     * (TGA): image_read decodes as that format when no signature matched. */
    bool (*sniff)(const uint8_t *data, size_t len);
    /* Encodes into a buffer of rt/bigmem.h (the caller frees *out with bigmem_free: a
     * 1080p TGA is 6 MB, which huge pages fault in 2 MB at a time); false only when out
     * of memory. img may be a byte image (pixels NULL: what a render writes), so read its
     * rows with image_row_bytes, never image_get. When img->has_region (a -tile or
     * -region part) the file must carry the record (image_region_format, the tag
     * IMAGE_REGION_TAG) and decode must give it back, or -merge cannot use the part. */
    bool (*encode)(const Image *img, uint8_t **out, size_t *out_len);
    /* NULL, or for formats of uncompressed rows, top row first: allocates the file of
     * img (rt/bigmem.h) with its header written, its rows left for the caller: *top is
     * the top row's offset, rows follow at 3 * width bytes each, B G R when *bgr, else
     * R G B (image_row_bytes). False only when out of memory. */
    bool (*layout)(const Image *img, uint8_t **out, size_t *out_len, size_t *top, bool *bgr);
    /* Fills a fresh image (the caller frees it with image_free) or returns false with a
     * one-line reason in err and img left empty; never reads past data + len. */
    bool (*decode)(const uint8_t *data, size_t len, Image *img, char *err, size_t errlen);
    /* A format whose library this build lacks has NULL encode and decode, and this
     * says how to get it ("install libpng-dev and rebuild (make PNG=1)"); else NULL. */
    const char *missing;
    /* NULL, or a look at a file's first bytes (64 KiB, while more follow) before the
     * rest is read: false with decode's reason when they cannot begin a file decode
     * takes; else *max_len is the longest file they can begin (what the header declares
     * and room for what decode ignores after it). image_read stops there, so an endless
     * input (/dev/zero) is refused at its header instead of after gigabytes. */
    bool (*header)(const uint8_t *data, size_t len, size_t *max_len, char *err,
                   size_t errlen);
    /* NULL, or layout's file without the rows, for a file written row by row without
     * ever being held whole (image_encoding_stream_only): its first *top bytes (the
     * header, at most IMAGE_HEAD_MAX) into head, the whole file's length into *out_len,
     * the pixels' order into *bgr. False when img's region record cannot be written. */
    bool (*head)(const Image *img, uint8_t *head, size_t *top, size_t *out_len, bool *bgr);
    /* NULL, or for formats of uncompressed rows at fixed places (TGA, PPM), for -merge,
     * which reads its parts row by row: from a file's first len bytes (at least 64 KiB
     * of a longer file) and its length file_len, what decode checks before the pixels,
     * with its reasons (1 when it would go on, 0 with the reason in err), and where the
     * rows lie (*lay, src/io/codec.h); -1 when the header does not end within len. */
    int (*rows)(const uint8_t *data, size_t len, size_t file_len, struct ImageRowLayout *lay,
                char *err, size_t errlen);
} ImageCodec;

/* The longest header ImageCodec.head writes. */
enum { IMAGE_HEAD_MAX = 256 };

/* The i-th codec of the table (0, 1, ...), built in or not; NULL past the last. */
const ImageCodec *image_codec_at(int i);
/* The codec called name, built in or not; NULL when there is none. */
const ImageCodec *image_codec_find(const char *name);
/* The codec whose extension ends path's file name (case-insensitive); NULL for none. */
const ImageCodec *image_codec_for_path(const char *path);
/* True when this build reads and writes the format called name. */
bool image_format_supported(const char *name);
/* The extensions this build writes, for messages: ".tga, .ppm, .png". Always
 * NUL-terminated; when size is too small, only the entries that fit whole. */
void image_format_list(char *buf, size_t size);
/* The names of the formats this build writes, as -format takes them: "tga, ppm, png".
 * Always NUL-terminated; when size is too small, only the names that fit whole. */
void image_format_names(char *buf, size_t size);

/* raytracer -merge: reads the headers of the n part images (each with a region
 * record), checks that they are parts of one full size and render, do not overlap and
 * leave no gap, and only then writes the full image to out (without a region record),
 * strip by strip from the parts' rows, so that neither the image nor a part is held
 * (src/io/merge.c). Any problem, also one found in a part's pixels during the write, is
 * reported to diag naming the file, and nothing is written. stop (NULL: none) is polled
 * before each part and before each strip: once it is non-zero the merge returns false,
 * says nothing and writes nothing (the caller reports the signal that set it). */
bool image_merge(const char *out, const char *const *parts, int n,
                 const volatile int *stop, Diag *diag);

#endif
