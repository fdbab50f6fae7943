/* The image loop: one primary ray per pixel, bands of rows handed out to worker threads. The
 * result depends only on the pixel, never on the thread count. */
#ifndef RT_RENDER_H
#define RT_RENDER_H

#include "rt/image.h"
#include "rt/progress.h"
#include "rt/raytracer.h"

typedef struct RenderTarget {
    int width, height;         /* the full image: the camera's screen */
    Image *color;              /* NULL: not requested; float or byte images */
    Image *depth;              /* -depth */
    float depth_min, depth_max;
    Image *normals;            /* -normals */
    /* The rectangle rendered: columns x0..x0+w-1 and rows y0..y0+h-1 of the full image,
     * y0 counted from the bottom row like Image. w or h = 0 (zero-initialised) means the whole
     * image. The images are w x h and hold exactly those pixels, with the values the
     * whole render gives them. */
    int x0, y0, w, h;
    Progress *progress;        /* NULL, or gets each finished row and its rays */
    /* NULL, or where color's bytes go instead of color, which the render then leaves
     * untouched: the rectangle's rows as an uncompressed file stores them (rt/image.h,
     * ImageEncoding), top row first, 3 * w bytes each, B G R per pixel when color_bgr,
     * else R G B; row y (0 = bottom, as Image) at color_file + (h - 1 - y) * 3 * w.
     * For a byte colour image whose file is made during the render: its 6 MB (1080p)
     * are then neither faulted in nor copied row by row into the file. */
    uint8_t *color_file;
    bool color_bgr;
    /* NULL, or the colour rows go band by band (rows y_lo..y_hi of the full image,
     * y_lo = bottom, each band once, when all of its pixels are there and before
     * row_done is called for its rows) to this function with render_image's user, in
     * color_file's layout from row y_hi down (3 * w bytes each), from a small buffer
     * used again afterwards; color_file (which may then be NULL) and color's pixels
     * (color may be an image of its size only) are not written. For a file written
     * while it is made: the whole image's rows would be fresh memory only to be copied
     * once, or not even that. */
    void (*color_rows)(void *user, int y_lo, int y_hi, const uint8_t *rows);
    /* The same for the depth and the normal images (each with its own file, so its own
     * order: normals_bgr as color_bgr; the depth's grey reads the same either way):
     * NULL, or their rows go band by band to these, and the images' pixels (they may
     * be images of their size only) are not written. A 20000 x 20000 render's depth
     * and normals would otherwise be 1.2 GB each, only to be copied into their files. */
    void (*depth_rows)(void *user, int y_lo, int y_hi, const uint8_t *rows);
    void (*normals_rows)(void *user, int y_lo, int y_hi, const uint8_t *rows);
    bool normals_bgr;
} RenderTarget;

/* Called from a worker thread after row y (0 = bottom, of the full image) is complete
 * (rows finish in bands of 8); may be NULL. */
typedef void (*RenderRowFn)(void *user, int y);

/* Renders every pixel of target's rectangle with camera; images must be allocated at
 * the rectangle's size. threads <= 0 means all cores. Merged counters go to stats_out (may be NULL).
 * cancel, if non-NULL, is polled between rows: a non-zero value stops early (returns
 * false). Returns false on failure to start threads or allocate contexts. */
bool render_image(const RayTracer *rt, const Camera *camera, RenderTarget *target,
                  int threads, RtStats *stats_out, RenderRowFn row_done, void *user,
                  volatile int *cancel);

/* One job of a parallel run: job is in [0, jobs); ctx is the worker's own context
 * (statistics, grid scratch). */
typedef void (*RenderJobFn)(void *user, RenderCtx *ctx, int job);

/* Runs fn(user, ctx, job) once for every job in [0, jobs) on `threads` workers (<= 0:
 * all cores; the calling thread is one of them), jobs handed out in increasing order
 * through an atomic counter. With rt non-NULL each worker gets a RenderCtx for rt (the
 * merged counters go to stats_out, may be NULL); with rt NULL the contexts are empty
 * (jobs that trace nothing). cancel as render_image. False on failure to allocate the
 * contexts or when cancelled. */
bool render_parallel(const RayTracer *rt, int threads, int jobs, RenderJobFn fn, void *user,
                     RtStats *stats_out, volatile int *cancel);

/* What a hit puts into the -depth image (grey: t <= dmin white, t >= dmax black, no hit
 * black) and into the -normals image (|nx| |ny| |nz|, no hit black). */
Vec3 render_depth_color(const Hit *hit, float depth_min, float depth_max);
Vec3 render_normal_color(const Hit *hit);

/* Pixels are traced in RENDER_TILE x RENDER_TILE tiles (a power of two), each as one
 * ray packet with a grid, in Z (Morton) order: pixel k of a tile is (dx, dy) below.
 * Every quarter of the order is a quarter of the tile, which is how the grid splits a
 * packet that is too wide. */
#define RENDER_TILE 8
/* Inline and without a loop: the tracers call it for every pixel of every tile. The
 * even bits of k make dx, the odd bits dy (RENDER_TILE 8: three bits each). */
static inline void render_tile_order(int k, int *dx, int *dy)
{
    _Static_assert(RENDER_TILE == 8, "render_tile_order spreads three bits per axis");
    *dx = (k & 1) | ((k >> 1) & 2) | ((k >> 2) & 4);
    *dy = ((k >> 1) & 1) | ((k >> 2) & 2) | ((k >> 3) & 4);
}

/* Number of online cores (at least 1). */
int render_default_threads(void);

/* Whether render_image may take a whole tile's colours as planes (raytracer_trace_tile_bytes)
 * and store them with AVX2 (the default where this CPU runs it); false: every tile's
 * colours as Vec3s (store_tile_bytes). Returns whether the plane store is on after the
 * call (false on a CPU without AVX2). For tests and measurements; not while rendering. */
bool render_use_tile_planes(bool on);

#endif
