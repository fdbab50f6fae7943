/* The film (A7): every sample of a pixel -- its offset in the pixel and its colours --
 * is kept until the filter has used it, because a filter reaches into neighbouring
 * pixels. The film renders a requested rectangle of the full image: the samples of the
 * rectangle plus the filter's margin of R pixels on each side (cropped at the image
 * border) are traced, the rectangle's pixels are filtered, the margin is discarded. A
 * rectangle's pixels are therefore exactly the bytes of the same pixels of the full
 * render (every sample depends only on its pixel, index and seed; every sum runs in
 * one fixed order).
 *
 * Memory stays bounded: the rectangle is filtered in strips of rows; only the sample
 * rows a strip needs (its rows plus R above and below) are held, within a budget
 * (FILM_DEFAULT_BUDGET; with one worker a strip holds one new 8-row band of packet
 * tiles and the 2R rows kept from the strip before, the budget only an upper bound), in
 * a ring of rows: the 2R rows shared with the next strip stay in place, not traced
 * again: every sample is traced exactly once. */
#ifndef RT_FILM_H
#define RT_FILM_H

#include <stddef.h>
#include "rt/camera.h"
#include "rt/filter.h"
#include "rt/image.h"
#include "rt/progress.h"
#include "rt/raytracer.h"
#include "rt/sampler.h"

/* Bytes of samples held at once by default (strips are sized to fit). */
#define FILM_DEFAULT_BUDGET ((size_t)8 << 20)
/* A strip is at least 2R + 1 rows of the rectangle's width, whatever the budget: many
 * samples on a wide image with a wide filter (3840 wide, 256 samples, the Gaussian 1.0:
 * 59 MB a row) held 294 MB. Beyond this the rectangle goes in column chunks. */
#define FILM_STRIP_LIMIT ((size_t)32 << 20)

/* One strip of output rows handed over by film_render (FilmConfig.rows): byte images
 * (rt/image.h) of the strip's rows for the outputs asked for (NULL for the others), all
 * of one size, whose pixel (0, 0) is pixel (x, y) of the outputs (the rectangle's
 * coordinates, y from the bottom, as FilmConfig's images). They are the film's own and
 * reused for the next strip. */
typedef struct FilmRows {
    int x, y;
    const Image *color, *depth, *normals;
} FilmRows;

/* FilmConfig.rows_wanted's outputs. */
enum { FILM_COLOR = 1, FILM_DEPTH = 2, FILM_NORMALS = 4 };

typedef struct FilmConfig {
    const Sampler *sampler;    /* required */
    const Filter *filter;      /* required */
    /* Adaptive sampling: when refine is non-NULL, a pixel whose first samples (from
     * sampler) differ by more than threshold in some channel (largest minus smallest
     * value) is sampled again with refine, whose samples replace the first ones. Each
     * pixel's samples then weigh 1/count each, so a pixel counts as one pixel's area
     * in its neighbours' sums however many samples it has. */
    const Sampler *refine;
    float threshold;
    int full_width, full_height;      /* the whole image W x H (the camera mapping) */
    int x0, y0, width, height;        /* the rectangle, inside the image; y from the bottom */
    /* Outputs, each width x height (the rectangle), or NULL when not wanted; float or
     * byte images (rt/image.h: written once per pixel, by image_put). Depth and normal
     * images are filtered like the colour (each sample's grey depth, |normal|). */
    Image *color, *depth, *normals;
    /* Or strip by strip, for outputs too big to hold whole (a file written while it is
     * made): when rows is non-NULL, color, depth, normals and samples must be NULL,
     * and the outputs named in rows_wanted (FILM_COLOR | FILM_DEPTH | FILM_NORMALS, at
     * least one) are filtered into the film's byte images of one strip's output rows,
     * which rows gets with rows_user on the calling thread once each strip is filtered:
     * strips from the bottom up, within each column chunk (strip_limit) in turn, every
     * output pixel once. The bytes are the whole images' (the same image_put). */
    void (*rows)(void *user, const FilmRows *r);
    void *rows_user;
    unsigned rows_wanted;
    float depth_min, depth_max;
    /* The samples picture of the rectangle, (width*zoom) x (height*zoom), or NULL: pixel
     * blocks grey (0.2) and black like a checkerboard, (0,0) grey, each sample a dot of
     * its colour at floor((i + px) * zoom), floor((j + py) * zoom). */
    Image *samples;
    int samples_zoom;
    size_t budget;                    /* 0: FILM_DEFAULT_BUDGET */
    /* A rectangle whose thinnest strip (2R + 1 rows of its whole traced width) would hold
     * more than this (0: FILM_STRIP_LIMIT) is rendered in column chunks whose strips fit
     * it (at least 16 R columns), one after the other, each with its own margin of R
     * columns. */
    size_t strip_limit;
    /* Where column x0 lands in the outputs (color, depth, normals, samples): column
     * out_x; 0 but inside film_render's column chunks. */
    int out_x;
    /* NULL, or gets every traced pixel (the rectangle and its filter margin, see
     * film_traced_pixels) and the rays it cast, as each band of rows is traced. */
    Progress *progress;
    /* Out: CPU seconds the calling thread spent tracing and filtering (with one
     * thread, the whole cost of each phase; for -timings and the benchmark). */
    double trace_cpu, filter_cpu;
    /* Out: the largest sample storage (bytes) held at once (the tests' check of the
     * budget). */
    size_t held;
} FilmConfig;

/* Renders cfg's rectangle with camera on `threads` workers (<= 0: all cores); images
 * must be allocated at their sizes. Counters of every ray cast go to stats_out (may be
 * NULL). cancel as render_image. False on a bad configuration, out of memory or cancel. */
bool film_render(const RayTracer *rt, const Camera *camera, FilmConfig *cfg,
                 int threads, RtStats *stats_out, volatile int *cancel);

/* For tests: the widest vector code film_render may use, 0 the plain loops, 1 AVX2,
 * 2 AVX-512 (the default; each as far as the CPU has it). Set before a render starts,
 * never during one. */
void film_path_set(int cap);

/* Pixels film_render traces for cfg's rectangle: the rectangle widened by the filter's
 * support R on each side, cropped at the image border, each column chunk's own (the
 * progress line's total). */
uint64_t film_traced_pixels(const FilmConfig *cfg);

/* The filter picture (-render_filter file zoom) of a W x H image: out must be allocated
 * at (W*zoom + 1) x (H*zoom + 1). Medium blue (0,0,0.5); the weights for the centre pixel
 * c = (W/2, W/2) (both from the width, as the course does) over its (2R+1)^2 support
 * pixels (cropped at the border), sampled zoom x zoom per pixel, as grey; then a blue
 * (0,0,1) grid line at every multiple of zoom. Independent of the scene and sampler. */
void film_filter_picture(const Filter *f, int width, int height, int zoom, Image *out);

#endif
