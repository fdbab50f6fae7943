/* raytracer: options -> scene -> grid -> render -> images -> statistics -> exit status.
 * Exit status: 0 images written, 1 input or output error, 2 usage error, 128 + signal
 * when stopped (130 Ctrl-C, 143 SIGTERM, 129 SIGHUP). */
#define _POSIX_C_SOURCE 200809L
#include <errno.h>
#include <signal.h>
#include <stdatomic.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "rt/clock.h"
#include "rt/dist.h"
#include "rt/film.h"
#include "rt/grid.h"
#include "rt/accel.h"
#include "rt/bigmem.h"
#include "rt/file.h"
#include "rt/twolevel.h"
#include "rt/image.h"
#include "rt/cpu.h"
#include "rt/options.h"
#include "rt/par.h"
#include "rt/preview.h"
#include "rt/progress.h"
#include "rt/render.h"
#include "rt/scene.h"

#define RT_VERSION "1.0.0"

enum { EXIT_INPUT = 1, EXIT_USAGE = 2 };

/* Above this many primitives a render without an accelerator earns a hint: the
 * course's 1k bunny takes ~70x longer without its grid. */
enum { HINT_PRIMITIVES = 1000 };

/* The stopping signal received (SIGINT, SIGTERM, SIGHUP), 0 while none: the render
 * polls it and stops early. */
static volatile int g_cancel;
/* The stop flag a render in one process polls: the stop signals set it as they set
 * g_cancel, and so does a failed write into an image file streamed during the render
 * (RectJob.write_failed), which must end the render at once (a full disk met in the
 * first minutes of a render of hours was reported only at its end). g_cancel itself
 * still says whether a signal came. MPI ranks poll g_cancel (dist_render copies rank
 * 0's signal into every rank's), and stream nothing. */
static volatile int g_render_stop;

/* Ctrl-C, kill and a closed terminal all end the run the same way: no image written,
 * exit status 128 + signal. During the render the workers notice g_cancel; while the
 * images are being written the handler removes the temporary files itself and ends
 * the process at once (a write into a pipe may block for ever). */
static void on_stop_signal(int sig)
{
    g_cancel = sig; /* first: render_and_write's reset of g_render_stop relies on it */
    g_render_stop = sig;
    /* Reading a scene or OBJ file from a pipe, a FIFO or a terminal: the read may wait
     * for bytes for ever, and it restarts after this handler (SA_RESTART), so only
     * ending here ends it. No image or cache file exists yet (they come after the
     * reading), so there is nothing to remove. */
    if (image_write_abort() || file_input_waiting()) {
        static const char msg[] = ": interrupted; no image written\n";
        const char *name = diag_program();
        ssize_t w = write(STDERR_FILENO, name, strlen(name));
        w = write(STDERR_FILENO, msg, sizeof msg - 1);
        (void)w;
        _exit(128 + sig);
    }
}

/* A stop signal the run was started with ignored stays ignored: that is how a user
 * asks for a run that outlives the terminal (nohup: SIGHUP), and how a shell keeps
 * Ctrl-C away from the jobs a script starts in the background (SIGINT). Catching
 * those anyway ended a nohup render at logout, with no image. */
static void catch_unless_ignored(int sig, const struct sigaction *sa)
{
    struct sigaction old;
    if (sigaction(sig, NULL, &old) == 0 && !(old.sa_flags & SA_SIGINFO) &&
        old.sa_handler == SIG_IGN)
        return;
    sigaction(sig, sa, NULL);
}

static void install_signal_handlers(void)
{
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop_signal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    catch_unless_ignored(SIGINT, &sa);
    catch_unless_ignored(SIGTERM, &sa);
    catch_unless_ignored(SIGHUP, &sa);
    /* A closed pipe on stdout (raytracer -stats | head) is an output error with a
     * message and exit status 1, not a silent death by SIGPIPE. */
    signal(SIGPIPE, SIG_IGN);
    /* Likewise a file-size limit (ulimit -f) reached while writing an image: the write
     * fails with EFBIG, reported as "File too large", and the temporary file is
     * removed; by default SIGXFSZ ended the run silently with it left behind. */
    signal(SIGXFSZ, SIG_IGN);
}

/* Exit status for a run stopped by the signal in g_cancel. */
static int interrupted_status(void) { return 128 + g_cancel; }

typedef struct App {
    Options opt;
    Diag diag;
    Scene *scene;
    PrimTable prims;    /* the scene's leaves, flattened once */
    Accel accel;        /* built over prims */
    RayTracer rt;
    SetupCache *cache;  /* -cache FILE, NULL without */
    double t_parse, t_grid;
    bool last_render;   /* render_and_write's images are the run's last work */
    struct Prepared *prepared; /* the output's image and file made ahead, or NULL */
} App;

static void print_version(void)
{
    char gui[160] = "yes", snap[160] = "yes";
    if (!preview_window_built())
        snprintf(gui, sizeof gui, "no (%s)", preview_remedy(true));
    if (!preview_snapshot_built())
        snprintf(snap, sizeof snap, "no (%s)", preview_remedy(false));
    printf("%s %s\n", diag_program(), RT_VERSION);
    /* PNG's remedy is its codec's: "install libpng-dev ..." or, in a PNG=0 build, that
     * the build leaves it out on purpose. */
    char png[160] = "yes";
    const ImageCodec *png_codec = image_codec_find("png");
    if (!image_format_supported("png"))
        snprintf(png, sizeof png, "no (%s)", png_codec && png_codec->missing
                                                 ? png_codec->missing : "not built in");
    printf("features: png %s, gui window %s, gui snapshot (osmesa) %s\n", png, gui, snap);
    printf("threads: %d by default (all cores)\n", render_default_threads());
    printf("mpi: %s\n", dist_describe());
}

/* The kinds of image a render writes, in a part's render identity. */
enum { IMAGE_KIND_COLOR = 1, IMAGE_KIND_DEPTH, IMAGE_KIND_NORMALS };

static SetupKey key_float(SetupKey k, float v)
{
    uint32_t bits;
    memcpy(&bits, &v, sizeof bits);
    return setup_hash_u64(k, bits);
}

static SetupKey key_text(SetupKey k, const char *s)
{
    return s ? setup_hash(s, strlen(s) + 1, k) : setup_hash_u64(k, 0);
}

/* A part image's render identity (rt/image.h): the key of the scene's inputs (the
 * scene text and every OBJ file's bytes, Scene.inputs) chained with the program's
 * version, the image's kind and every option that can change one of its pixels. Left
 * out, because no pixel depends on them: -threads, -grid and -accel (byte-identical
 * images; but they shape -visualize_grid's picture, so then they count), -cache,
 * -no_packets, -isa, -stats, -timings, -progress, -quiet, the output's name and format, the
 * preview's options, and the region itself (the record says where the part sits).
 * Options are taken as the renderer uses them, so that equal renders spelt
 * differently agree: -seed only for the samplers that draw random numbers, the count
 * only of the sampler in use, -weight only with -bounces above 0, no filter as the box
 * of radius 0.5 it stands for, and -uniform_samples 1 as the centre sample it is. */
static uint64_t render_identity(const Scene *s, const Options *o, int kind)
{
    static const char version[] = RT_VERSION;
    SetupKey k = setup_hash(version, sizeof version, s->inputs);
    k = setup_hash_u64(k, (uint64_t)kind);
    k = setup_hash_u64(k, (uint64_t)o->width << 32 | (uint64_t)o->height);
    k = setup_hash_u64(k, (uint64_t)o->shade_back | (uint64_t)o->shadows << 1 |
                              (uint64_t)o->noise_cutoff << 2 | (uint64_t)o->adaptive << 3 |
                              (uint64_t)o->visualize_grid << 4 |
                              (uint64_t)o->visualize_grid_count << 5);
    k = setup_hash_u64(k, (uint64_t)(uint32_t)o->bounces);
    if (o->bounces > 0)
        k = key_float(k, o->weight);
    if (kind == IMAGE_KIND_DEPTH) {
        k = key_float(k, o->depth_min);
        k = key_float(k, o->depth_max);
    }
    /* One uniform sample is the centre sample, the default's (the same pixels). */
    const char *sampler = o->sampler;
    if (sampler && !o->adaptive && o->samples == 1 && strcmp(sampler, "uniform") == 0)
        sampler = NULL;
    k = key_text(k, sampler);
    if (sampler)
        k = setup_hash_u64(k, (uint64_t)(uint32_t)o->samples);
    if (o->adaptive) {
        k = setup_hash_u64(k, (uint64_t)(uint32_t)o->adaptive_min << 32 |
                                  (uint32_t)o->adaptive_max);
        k = key_float(k, o->adaptive_threshold);
    }
    k = key_text(k, o->filter ? o->filter : "box");
    k = key_float(k, o->filter ? o->filter_param : 0.5f);
    if (o->adaptive || (sampler && strcmp(sampler, "uniform") != 0))
        k = setup_hash_u64(k, o->seed);
    if (o->visualize_grid || o->visualize_grid_count) {
        k = setup_hash_u64(k, (uint64_t)o->grid | (uint64_t)o->grid_auto << 1 |
                                  (uint64_t)o->no_marking << 2);
        for (int i = 0; i < 3; i++)
            k = setup_hash_u64(k, (uint64_t)(uint32_t)o->grid_n[i]);
        k = key_text(k, o->accel);
    }
    return k.a ^ k.b;
}

/* Allocates the image of the rendered rectangle; a part image (-region, -tile) records
 * where it sits in the full image and its render identity. bytes: a byte image
 * (rt/image.h), for an image that is only written: the renderer quantises each pixel as
 * it stores it, and the encoder copies rows (a 1080p frame is 6 MB instead of 25 MB of
 * floats read back). shape_only: no pixels at all, only the size and the record (an
 * image whose file is written strip by strip while it is rendered: stream_film). */
static bool alloc_image(Image **slot, Image *storage, const char *want, const Options *o,
                        bool bytes, const Scene *s, int kind, bool shape_only, Diag *d)
{
    *slot = NULL;
    if (!want)
        return true;
    int w = o->region ? o->region_w : o->width, h = o->region ? o->region_h : o->height;
    if (!dist_is_root() || shape_only) {
        /* Only the root gathers pixels: the others say what is wanted. */
        memset(storage, 0, sizeof *storage);
        storage->width = w;
        storage->height = h;
        *slot = storage;
        if (!dist_is_root())
            return true;
    } else if (!(bytes ? image_init_bytes(storage, w, h) : image_init(storage, w, h))) {
        diag_error(d, NULL, "out of memory for a %dx%d image", w, h);
        return false;
    }
    if (o->region) {
        storage->has_region = true;
        storage->region.x = o->region_x;
        storage->region.y = o->region_y;
        storage->region.full_width = o->width;
        storage->region.full_height = o->height;
        storage->region.has_id = true;
        storage->region.id = render_identity(s, o, kind);
    }
    *slot = storage;
    return true;
}

/* Flushes stdout; false (with a message) when what was printed there was lost (a full
 * disk, a closed stdout, a reader that went away). */
static bool stdout_ok(Diag *d, const char *what)
{
    if (fflush(stdout) == 0 && !ferror(stdout))
        return true;
    diag_error(d, NULL, "cannot write %s to standard output: %s", what, strerror(errno));
    clearerr(stdout);
    return false;
}

/* True when an image goes to standard output (an output file "-", or the preview's
 * shot:- in -gui_keys): then it carries the image alone, and the -stats block and the
 * preview's lines go to stderr. */
static bool image_to_stdout(const Options *o)
{
    const char *files[] = {o->output, o->depth_file, o->normals_file, o->samples_file,
                           o->filter_file, o->gui_snapshot};
    for (size_t i = 0; i < sizeof files / sizeof files[0]; i++)
        if (files[i] && strcmp(files[i], IMAGE_STDOUT) == 0)
            return true;
    return (o->gui || o->gui_snapshot) && preview_keys_shot_stdout(o->gui_keys);
}

/* The format of an image written to path: -format for standard output, else NULL (the
 * extension decides). */
static const char *stdout_format(const Options *o, const char *path)
{
    return path && strcmp(path, IMAGE_STDOUT) == 0 ? o->format : NULL;
}

/* Any antialiasing option: the render goes through the film (samplers, filters). */
static bool antialiasing_requested(const Options *o)
{
    return o->sampler || o->adaptive || o->filter || o->samples_file || o->filter_file;
}

/* Whether the run traces any ray: only a filter picture (-render_filter with no image
 * of the scene, no samples picture and no preview) is drawn from the filter alone, as
 * render_and_write decides. Advice about tracing speed is for the others. */
static bool traces_rays(const Options *o)
{
    return !o->filter_file || o->output || o->depth_file || o->normals_file ||
           o->samples_file || o->gui || o->gui_snapshot;
}

/* The colour image and its file's layout (ImageEncoding), made before the render by
 * the set-up's helper in its idle moments (par_background) (their pages were faulted
 * in too, before the render wrote neither of them: prepare_piece):
 * with several threads the set-up's serial stretches (the scene's and the grid's
 * table walks, the CSR fill) leave the helper waiting, while the main thread did this
 * work between the grid and the render (two 6 MB blocks at 1080p: their mappings, the
 * file's header and 0.6-0.9 ms of page faults, most of them in the render's first
 * bands). The temporary file is still made by render_and_write on the main thread
 * (the signal handler's registry, image_encoding_stream). Only for the plain renderer
 * writing a whole image in one process, which render_and_write would make the same
 * way, into a pipe, a device or PNG: a TGA or PPM file is written while it is made,
 * and needs neither block (stream_plain). */
typedef struct Prepared {
    int width, height;
    const char *path, *format;
    Image color;
    ImageEncoding enc;
    bool have_image, have_enc; /* what piece 0 made (else render_and_write makes it) */
    atomic_bool skip;          /* the run ends without a render: pieces do nothing */
} Prepared;

/* 2 MB steps of the prefault pieces: one huge page each. */
enum { PREPARE_STEP = 2 << 20 };

static size_t prepare_steps(size_t bytes) { return (bytes + PREPARE_STEP - 1) / PREPARE_STEP; }

/* Piece 0 allocates; pieces 1.. fault in one step each of the image when its file could
 * not be made (else nothing: see below). */
static void prepare_piece(void *ctx, int i)
{
    Prepared *p = ctx;
    if (atomic_load_explicit(&p->skip, memory_order_relaxed))
        return;
    if (i == 0) {
        p->have_image = image_init_bytes(&p->color, p->width, p->height);
        p->have_enc = p->have_image &&
                      image_encoding_begin(&p->enc, &p->color, p->path, p->format);
        return;
    }
    size_t k = (size_t)i - 1;
    size_t img_len = (size_t)p->width * (size_t)p->height * 3;
    size_t img_steps = prepare_steps(img_len);
    /* With the file made, the render puts the colour bytes straight into it
     * (color_direct), the image's own bytes untouched. */
    if (p->have_enc)
        return;
    if (k < img_steps && p->have_image)
        bigmem_prefault(p->color.bytes, k * PREPARE_STEP, PREPARE_STEP);
}

/* Posts the preparation when the run qualifies and a helper can do it (at one thread
 * everything stays in render_and_write, as before). */
static void prepare_output(App *app)
{
    const Options *o = &app->opt;
    if (!o->output || o->region || dist_size() != 1 || antialiasing_requested(o) ||
        o->gui || o->gui_snapshot || strcmp(o->output, IMAGE_STDOUT) == 0 ||
        par_threads() < 2)
        return;
    /* A file written while it is made needs neither (render_and_write, stream_plain). */
    if (image_output_streams(o->output, stdout_format(o, o->output)))
        return;
    Prepared *p = calloc(1, sizeof *p);
    if (!p)
        return;
    p->width = o->width;
    p->height = o->height;
    p->path = o->output;
    p->format = stdout_format(o, o->output);
    /* The file: the image's bytes and a header and footer well under a step. */
    size_t img_len = (size_t)o->width * (size_t)o->height * 3;
    size_t pieces = 1 + prepare_steps(img_len) + prepare_steps(img_len + 4096);
    if (pieces > 4096 || !par_background((int)pieces, prepare_piece, p)) {
        free(p);
        return;
    }
    app->prepared = p;
}

/* The prepared output, once every piece has run (NULL when there is none, or when it
 * cannot be used); the caller owns what it holds then. */
static Prepared *prepared_take(App *app)
{
    Prepared *p = app->prepared;
    app->prepared = NULL;
    if (!p)
        return NULL;
    if (!par_background_finish()) { /* a forked child: pieces maybe half run */
        free(p);
        return NULL;
    }
    return p;
}

/* Frees what an unused preparation made (a run that ends before its render). */
static void prepared_free(App *app)
{
    if (app->prepared)
        atomic_store_explicit(&app->prepared->skip, true, memory_order_relaxed);
    Prepared *p = prepared_take(app);
    if (!p)
        return;
    if (p->have_enc)
        image_encoding_free(&p->enc);
    if (p->have_image)
        image_free(&p->color);
    free(p);
}

/* The film's sampler(s) and filter from the options (already validated by
 * options_parse, so the inits cannot fail here). */
static void film_setup(const Options *o, Sampler *sampler, Sampler *refine, Filter *filter,
                       bool *adaptive)
{
    char why[160];
    *adaptive = false;
    if (o->adaptive) {
        const SamplerOps *j = sampler_find("jittered");
        sampler_init(sampler, j, o->adaptive_min, o->seed, why, sizeof why);
        sampler_init(refine, j, o->adaptive_max, o->seed, why, sizeof why);
        refine->stream = 1; /* independent of the first pass's draws */
        *adaptive = true;
    } else if (o->sampler) {
        sampler_init(sampler, sampler_find(o->sampler), o->samples, o->seed, why, sizeof why);
    } else {
        sampler_init_center(sampler);
    }
    if (o->filter)
        filter_init(filter, filter_find(o->filter), o->filter_param, why, sizeof why);
    else
        filter_init_default(filter);
}

/* One rectangle of the image for dist_render: the plain renderer, or the film with
 * antialiasing (fc, with everything but the rectangle and its images set). */
typedef struct RectJob {
    App *app;
    const Camera *camera;
    FilmConfig *fc;            /* NULL: no antialiasing; its CPU times add up here */
    Progress *progress;        /* NULL, or gets the rows rendered (no antialiasing; the
                                  film reports through fc->progress) */
    /* The output files made row by row on the render's threads (rt/image.h,
     * ImageEncoding), for the images of the target rectangle (x0, y0, w, h): enc[i]
     * of img[i] where enc[i].data is set. rows counts the rows encoded: the files
     * are used only when every row was. */
    int x0, y0, w, h;
    ImageEncoding enc[3];
    const Image *img[3];
    atomic_int rows;
    /* render_rect put image i's bytes into enc[i] (the colour: color_direct), or band
     * by band straight into its file (staged: RenderTarget's color_rows, depth_rows,
     * normals_rows); the image itself then holds no pixel. */
    bool in_file[3], staged[3];
    /* The film hands its output rows strip by strip to film_rows_out (stream_film):
     * into enc[i] where that is a streamed file held as its header only, else into
     * whole[i], the image rendered whole (standard output, a pipe, PNG). film_pixels
     * counts the output pixels handed over: the files are used only when it reaches
     * w * h. */
    bool film_rows;
    Image *whole[3];
    uint64_t film_pixels;
    /* The render's stop flag, and whether a write into one of the streamed files
     * failed: the first failure sets both (stop_on_write_error), so the render ends
     * within a band or strip and the run reports the write's error. */
    volatile int *stop;
    atomic_bool write_failed;
} RectJob;

/* After a write into enc (any thread): when it failed, stops the render. One load per
 * band or strip written. */
static void stop_on_write_error(RectJob *rj, const ImageEncoding *enc)
{
    if (image_encoding_error(enc) &&
        !atomic_exchange_explicit(&rj->write_failed, true, memory_order_relaxed))
        *rj->stop = 1;
}

/* Whether the whole rectangle's render puts the colour bytes straight into their file
 * (RenderTarget.color_file): when that file is made during the render from a byte
 * image (whose own bytes are then never touched: the file is what gets written). */
static bool color_direct(const RectJob *rj)
{
    return rj->enc[0].data && rj->img[0] && rj->img[0]->bytes &&
           rj->enc[0].width == rj->w && rj->enc[0].height == rj->h;
}

/* RenderTarget's color_rows, depth_rows, normals_rows (worker threads): rows
 * y_lo..y_hi of the full image, in the file's layout, into streamed file i. */
static void rows_to_file(RectJob *rj, int i, int y_lo, int y_hi, const uint8_t *rows)
{
    image_encoding_flush_rows(&rj->enc[i], y_lo - rj->y0, y_hi - rj->y0, rows);
    stop_on_write_error(rj, &rj->enc[i]);
}

static void color_rows_to_file(void *user, int y_lo, int y_hi, const uint8_t *rows)
{
    rows_to_file(user, 0, y_lo, y_hi, rows);
}

static void depth_rows_to_file(void *user, int y_lo, int y_hi, const uint8_t *rows)
{
    rows_to_file(user, 1, y_lo, y_hi, rows);
}

static void normals_rows_to_file(void *user, int y_lo, int y_hi, const uint8_t *rows)
{
    rows_to_file(user, 2, y_lo, y_hi, rows);
}

/* FilmConfig.rows (the calling thread, between strips): a strip of the rectangle's
 * output rows into the streamed files or the whole images. */
static void film_rows_out(void *user, const FilmRows *r)
{
    RectJob *rj = user;
    const Image *part[3] = {r->color, r->depth, r->normals};
    for (int i = 0; i < 3; i++) {
        const Image *p = part[i];
        if (!p)
            continue;
        if (rj->enc[i].head_only) {
            image_encoding_put(&rj->enc[i], p, r->x, r->y);
            stop_on_write_error(rj, &rj->enc[i]);
        } else if (rj->whole[i] && rj->whole[i]->bytes) { /* byte images in one process */
            Image *img = rj->whole[i];
            size_t row = (size_t)p->width * 3;
            for (int k = 0; k < p->height; k++)
                memcpy(img->bytes + ((size_t)(r->y + k) * (size_t)img->width + (size_t)r->x) * 3,
                       p->bytes + (size_t)k * row, row);
        }
    }
    const Image *any = part[0] ? part[0] : part[1] ? part[1] : part[2];
    if (any)
        rj->film_pixels += (uint64_t)any->width * (uint64_t)any->height;
}

/* render_image's row callback (worker threads): row y of the full image is done. */
static void encode_row(void *user, int y)
{
    RectJob *rj = user;
    int r = y - rj->y0;
    if (r < 0 || r >= rj->h)
        return;
    /* The rows of a band come in increasing order from one thread: at its last row
     * inside the rectangle, the band's rows go to the files at once. */
    bool last = (y + 1) % RENDER_TILE == 0 || r == rj->h - 1;
    int lo = y - y % RENDER_TILE - rj->y0;
    for (int i = 0; i < 3; i++)
        if (rj->enc[i].data) {
            if (!rj->in_file[i]) /* else the render put the row there */
                image_encoding_row(&rj->enc[i], rj->img[i], r);
            if (last && !rj->staged[i]) { /* else the rows callback wrote it */
                image_encoding_flush(&rj->enc[i], lo > 0 ? lo : 0, r);
                stop_on_write_error(rj, &rj->enc[i]);
            }
        }
    atomic_fetch_add_explicit(&rj->rows, 1, memory_order_relaxed);
}

static bool render_rect(void *user, int x0, int y0, int w, int h, Image *color, Image *depth,
                        Image *normals, RtStats *stats, volatile int *cancel)
{
    RectJob *rj = user;
    const Options *o = &rj->app->opt;
    RtStats st;
    memset(&st, 0, sizeof st);
    bool ok;
    if (!rj->fc) {
        RenderTarget t;
        memset(&t, 0, sizeof t);
        t.width = o->width;
        t.height = o->height;
        t.depth_min = o->depth_min;
        t.depth_max = o->depth_max;
        t.x0 = x0;
        t.y0 = y0;
        t.w = w;
        t.h = h;
        t.color = color;
        t.depth = depth;
        t.normals = normals;
        t.progress = rj->progress;
        /* The files are made during the render when this call renders the whole
         * rectangle (one process does). */
        bool whole = x0 == rj->x0 && y0 == rj->y0 && w == rj->w && h == rj->h;
        bool any = rj->enc[0].data || rj->enc[1].data || rj->enc[2].data;
        if (whole && rj->enc[0].head_only && color == rj->img[0]) {
            /* The colour's file begun as its header only (stream_plain): band by band
             * into it, from the render's band buffers. */
            t.color_bgr = rj->enc[0].bgr;
            t.color_rows = color_rows_to_file;
            rj->in_file[0] = rj->staged[0] = true; /* before the workers start */
        } else if (whole && color_direct(rj) && color == rj->img[0]) {
            t.color_file = rj->enc[0].data + rj->enc[0].top;
            t.color_bgr = rj->enc[0].bgr;
            rj->in_file[0] = true; /* before the workers start */
            /* A streamed file takes the rows as they come: the render keeps them in
             * band buffers, and the file's 6 MB (1080p) in memory hold only its
             * header. */
            if (rj->enc[0].fd >= 0) {
                t.color_rows = color_rows_to_file;
                rj->staged[0] = true;
            }
        }
        /* The depth and normal files begun as their headers only (stream_plain): the
         * same, band by band from the render's band buffers. */
        if (whole && rj->enc[1].head_only && depth == rj->img[1]) {
            t.depth_rows = depth_rows_to_file;
            rj->in_file[1] = rj->staged[1] = true;
        }
        if (whole && rj->enc[2].head_only && normals == rj->img[2]) {
            t.normals_rows = normals_rows_to_file;
            t.normals_bgr = rj->enc[2].bgr;
            rj->in_file[2] = rj->staged[2] = true;
        }
        ok = render_image(&rj->app->rt, rj->camera, &t, o->threads, &st,
                          whole && any ? encode_row : NULL, (void *)rj, cancel);
    } else {
        FilmConfig fc = *rj->fc;
        fc.x0 = x0;
        fc.y0 = y0;
        fc.width = w;
        fc.height = h;
        fc.color = color;
        fc.depth = depth;
        fc.normals = normals;
        if (rj->film_rows) {
            /* Strip by strip (stream_film): one call renders the whole rectangle. */
            Image *given[3] = {color, depth, normals};
            static const unsigned which[3] = {FILM_COLOR, FILM_DEPTH, FILM_NORMALS};
            fc.rows = film_rows_out;
            fc.rows_user = rj;
            fc.rows_wanted = 0;
            for (int i = 0; i < 3; i++) {
                rj->whole[i] = given[i] && !rj->enc[i].head_only ? given[i] : NULL;
                if (given[i])
                    fc.rows_wanted |= which[i];
            }
            rj->film_pixels = 0;
            fc.color = fc.depth = fc.normals = NULL;
        }
        fc.trace_cpu = fc.filter_cpu = 0.0;
        ok = film_render(&rj->app->rt, rj->camera, &fc, o->threads, &st, cancel);
        rj->fc->trace_cpu += fc.trace_cpu;
        rj->fc->filter_cpu += fc.filter_cpu;
    }
    if (ok)
        stats_merge(stats, &st);
    return ok;
}

/* Renders the requested images with camera and writes them (also the `r` key of the
 * preview, whose stop flag is cancel; NULL: g_cancel, set by the stop signals). Returns
 * an exit status. */
static int render_and_write(void *user, const Camera *camera, volatile int *cancel)
{
    App *app = user;
    /* What the render polls: the preview's flag, or in one process g_render_stop (so
     * that a failed write can stop it too), or under MPI g_cancel. */
    volatile int *stop = cancel;
    if (!cancel) {
        cancel = stop = &g_cancel;
        if (dist_size() == 1) {
            /* Cleared of an earlier render's failed write, keeping any signal: one that
             * comes between the two stores has set g_cancel before g_render_stop. */
            g_render_stop = 0;
            if (g_cancel)
                g_render_stop = g_cancel;
            stop = &g_render_stop;
        }
    }
    const Options *o = &app->opt;
    Image color, depth, normals;
    Image samples_img, filter_img;
    Image *samples = NULL, *filter_pic = NULL;
    RenderTarget target;
    memset(&target, 0, sizeof target);
    target.width = o->width;
    target.height = o->height;
    target.depth_min = o->depth_min;
    target.depth_max = o->depth_max;
    target.w = o->width;
    target.h = o->height;
    if (o->region) { /* the options count rows from the top, the renderer from the bottom */
        target.x0 = o->region_x;
        target.y0 = o->height - o->region_y - o->region_h;
        target.w = o->region_w;
        target.h = o->region_h;
    }
    int status = 0;
    /* A streamed file's failed write that stopped the render: its output and errno. */
    const char *failed_path = NULL;
    int failed_err = 0;
    /* The files of color, depth and normals when the render made them (RectJob); freed at done. */
    ImageEncoding encoded[3];
    memset(encoded, 0, sizeof encoded);
    /* The files streamed without their image ever being held (stream_film, stream_plain),
     * until the render takes them (RectJob.enc). */
    ImageEncoding shaped_enc[3];
    memset(shaped_enc, 0, sizeof shaped_enc);
    for (int i = 0; i < 3; i++)
        shaped_enc[i].fd = shaped_enc[i].slot = -1;
    /* Byte images where nothing reads the pixels back: the plain renderer and the film
     * (it filters in float and stores each output pixel once) in one process (MPI
     * ranks send float tiles to the root). A 1080p frame is then 6 MB instead of 25,
     * and a -tile part of 16 rows 92 KB instead of 368. */
    bool bytes = dist_size() == 1;
    const Scene *s = app->scene;
    /* The colour image and its file's layout made ahead (prepare_output), if any. */
    ImageEncoding pre_enc;
    memset(&pre_enc, 0, sizeof pre_enc);
    pre_enc.fd = pre_enc.slot = -1;
    bool pre_image = false;
    Prepared *prep = prepared_take(app);
    if (prep) {
        if (prep->have_image) {
            color = prep->color;
            target.color = &color;
            pre_image = true;
        }
        if (prep->have_enc)
            pre_enc = prep->enc;
        free(prep);
    }
    bool film = antialiasing_requested(o);
    /* An antialiased render in one process writes each image whose file can be written
     * while it is made (a regular file, TGA or PPM: image_encoding_stream_only) strip by
     * strip as the film filters it (FilmConfig.rows, film_rows_out): such an image is
     * never held whole, in memory or in an encoding (6000 x 6000, uniform 4: 226 MB of
     * memory at most before). The others (standard output, a pipe or device, PNG) are
     * rendered whole as before, and filled from the same strips. Not in the preview
     * (its r key), nor with -render_samples or -render_filter, whose pictures are whole
     * images anyway. */
    bool stream_film = film && bytes && !o->gui && !o->gui_snapshot && !o->samples_file &&
                       !o->filter_file;
    /* The plain renderer in one process puts the colour band by band into its file
     * (RenderTarget.color_rows, color_rows_to_file) where that file is written while it
     * is made: the image's bytes and the file's rows were never touched, yet reserved
     * whole (two 48 MB blocks at 4000 x 4000, which a `ulimit -v` counts). Such a file
     * is begun as its header only, and the image as its size only. So are the depth and
     * normal images (RenderTarget's depth_rows, normals_rows): 1.2 GB each at
     * 20000 x 20000, only to be copied into their files. */
    bool stream_plain = !film && bytes;
    bool any_streamed = false;
    const char *out_paths[3] = {o->output, o->depth_file, o->normals_file};
    Image *out_storage[3] = {&color, &depth, &normals};
    Image **out_slot[3] = {&target.color, &target.depth, &target.normals};
    static const int out_kind[3] = {IMAGE_KIND_COLOR, IMAGE_KIND_DEPTH, IMAGE_KIND_NORMALS};
    bool allocated = true;
    for (int i = 0; i < 3 && allocated; i++) {
        if (i == 0 && pre_image)
            continue;
        if ((stream_film || stream_plain) && out_paths[i] &&
            alloc_image(out_slot[i], out_storage[i], out_paths[i], o, bytes, s, out_kind[i],
                        true, &app->diag) &&
            image_encoding_stream_only(&shaped_enc[i], out_storage[i], out_paths[i],
                                       stdout_format(o, out_paths[i]))) {
            any_streamed = true;
            continue;
        }
        allocated = alloc_image(out_slot[i], out_storage[i], out_paths[i], o, bytes, s,
                                out_kind[i], false, &app->diag);
    }
    if (!dist_root_ok(allocated)) {
        status = EXIT_INPUT;
        goto done;
    }

    Sampler sampler, refine;
    Filter filter;
    bool adaptive = false;
    if (film) {
        film_setup(o, &sampler, &refine, &filter, &adaptive);
        if (o->samples_file) {
            if (!image_init(&samples_img, o->width * o->samples_zoom,
                            o->height * o->samples_zoom)) {
                diag_error(&app->diag, NULL, "out of memory for the samples picture");
                status = EXIT_INPUT;
                goto done;
            }
            samples = &samples_img;
        }
        if (o->filter_file) {
            if (!image_init(&filter_img, o->width * o->filter_zoom + 1,
                            o->height * o->filter_zoom + 1)) {
                diag_error(&app->diag, NULL, "out of memory for the filter picture");
                status = EXIT_INPUT;
                goto done;
            }
            filter_pic = &filter_img;
            film_filter_picture(&filter, o->width, o->height, o->filter_zoom, filter_pic);
        }
    }

    /* -noise_cutoff: the pixel's cone for this camera (the preview may have moved it). */
    if (o->noise_cutoff && camera) /* none for a filter picture alone */
        raytracer_set_pixel_cone(&app->rt, camera, o->width, o->height);

    RtStats counts;
    memset(&counts, 0, sizeof counts);
    /* The preview shows its rows in the window; a terminal line would only interleave
     * with its key messages. MPI ranks do not report their tiles yet, so they get no
     * line rather than one that never moves. */
    bool preview = o->gui || o->gui_snapshot;
    bool show_progress = !preview && dist_size() == 1;
    double t0 = clock_now(), cpu0 = clock_thread_cpu();
    bool ok = true;
    FilmConfig fc;
    memset(&fc, 0, sizeof fc);
    /* Only a filter picture needs no samples: nothing is traced then. */
    if (!film || target.color || target.depth || target.normals || samples || !filter_pic) {
        if (!film && show_progress) /* units: image rows */
            target.progress = progress_start(o->progress, stderr, "rendering",
                                             (uint64_t)target.h);
        if (film) {
            fc.sampler = &sampler;
            fc.filter = &filter;
            fc.refine = adaptive ? &refine : NULL;
            fc.threshold = o->adaptive_threshold;
            fc.full_width = o->width;
            fc.full_height = o->height;
            fc.depth_min = o->depth_min;
            fc.depth_max = o->depth_max;
            fc.samples = samples; /* only without -region and MPI (options, run) */
            fc.samples_zoom = o->samples_zoom;
            /* Units: the film's traced pixels, margins included (one rectangle here:
             * the local run renders the target in one piece). */
            fc.x0 = target.x0;
            fc.y0 = target.y0;
            fc.width = target.w;
            fc.height = target.h;
            if (show_progress)
                target.progress = progress_start(o->progress, stderr, "rendering",
                                                 film_traced_pixels(&fc));
            fc.progress = target.progress;
        }
        RectJob rj;
        memset(&rj, 0, sizeof rj);
        rj.app = app;
        rj.camera = camera;
        rj.fc = film ? &fc : NULL;
        rj.progress = target.progress;
        rj.x0 = target.x0;
        rj.y0 = target.y0;
        rj.w = target.w;
        rj.h = target.h;
        atomic_init(&rj.rows, 0);
        rj.stop = stop;
        atomic_init(&rj.write_failed, false);
        if (any_streamed) {
            rj.film_rows = film;
            for (int i = 0; i < 3; i++) {
                rj.enc[i] = shaped_enc[i];
                memset(&shaped_enc[i], 0, sizeof shaped_enc[i]);
                shaped_enc[i].fd = shaped_enc[i].slot = -1;
            }
            if (!film) { /* their sizes only (stream_plain) where rj.enc[i] is set */
                Image *given[3] = {target.color, target.depth, target.normals};
                for (int i = 0; i < 3; i++)
                    if (rj.enc[i].head_only)
                        rj.img[i] = given[i];
            }
        }
        /* The plain renderer in one process fills byte images: their TGA and PPM files
         * are encoded row by row on its threads (a 1080p TGA's 6 MB took ~4 ms after
         * the render), and the write only writes them. The colour goes straight into
         * its file's rows (color_direct) or, streamed, band by band into the file
         * (stream_plain, above): its image's 6 MB are not touched at all. */
        if (!film && bytes) {
            const char *paths[3] = {o->output, o->depth_file, o->normals_file};
            const Image *imgs[3] = {target.color, target.depth, target.normals};
            for (int i = 0; i < 3; i++) {
                if (i == 0 && pre_enc.data) { /* made ahead for this image */
                    rj.enc[0] = pre_enc;
                    memset(&pre_enc, 0, sizeof pre_enc);
                    pre_enc.fd = pre_enc.slot = -1;
                    rj.img[0] = imgs[0];
                    image_encoding_stream(&rj.enc[0], paths[0]);
                    continue;
                }
                if (imgs[i] && paths[i] && imgs[i]->bytes &&
                    image_encoding_begin(&rj.enc[i], imgs[i], paths[i],
                                         stdout_format(o, paths[i]))) {
                    rj.img[i] = imgs[i];
                    /* Into its temporary file band by band: the write overlaps the
                     * render (best effort: else it is written after the render). */
                    image_encoding_stream(&rj.enc[i], paths[i]);
                }
            }
        }
        DistJob job;
        memset(&job, 0, sizeof job);
        job.x0 = target.x0;
        job.y0 = target.y0;
        job.w = target.w;
        job.h = target.h;
        job.color = target.color;
        job.depth = target.depth;
        job.normals = target.normals;
        job.threads = o->threads;
        /* A film tile traces the filter's margin of R rows again on each side: tiles
         * of 16 R rows or more keep that within 1/8 even for the last, smallest tiles
         * (docs/distributed.md). A filter of no margin (box of radius 0.5) needs none. */
        job.min_tile_rows = film ? 16 * filter.support : 0;
        job.render = render_rect;
        job.user = &rj;
        job.progress = preview ? PROGRESS_NEVER : o->progress;
        ok = dist_render(&job, &counts, stop);
        /* The first output whose write failed, in the order image_write_all writes
         * them (its report, had the render gone on to the end). */
        for (int i = 0; i < 3 && !failed_err && atomic_load(&rj.write_failed); i++)
            if ((failed_err = image_encoding_error(&rj.enc[i])) != 0)
                failed_path = out_paths[i];
        bool complete = rj.film_rows ? rj.film_pixels == (uint64_t)rj.w * (uint64_t)rj.h
                                     : atomic_load(&rj.rows) == rj.h;
        if (complete && !failed_err) {
            for (int i = 0; i < 3; i++)
                encoded[i] = rj.enc[i];
        } else {
            /* Never after a whole render (each of its rows is reported); but with the
             * colour put straight into its file, or streamed strip by strip, the image
             * itself holds no pixel. */
            if (ok && (rj.in_file[0] || rj.in_file[1] || rj.in_file[2] || rj.film_rows))
                ok = false;
            for (int i = 0; i < 3; i++)
                image_encoding_free(&rj.enc[i]);
        }
    }
    double t_render = clock_now() - t0, cpu_render = clock_thread_cpu() - cpu0;
    /* The run's last render is over: the helpers exit now, during the write, rather
     * than being woken by the process's exit to be ended (rt/par.h). */
    if (app->last_render)
        par_release();
    progress_finish(target.progress);
    target.progress = NULL;
    if (failed_err && !g_cancel) {
        /* Nothing was written: the streamed files are removed below. */
        image_report_write_error(failed_path, failed_err, &app->diag);
        status = EXIT_INPUT;
        goto done;
    }
    if (*cancel && cancel != &g_cancel)
        goto done; /* the preview stopped it (q, a moved camera): nothing to write */
    if (g_cancel) {
        if (dist_is_root())
            fprintf(stderr, "%s: interrupted; no image written\n", diag_program());
        status = interrupted_status();
        goto done;
    }
    if (!ok) {
        diag_error(&app->diag, NULL, "could not start the render (out of memory?)");
        status = EXIT_INPUT;
        goto done;
    }
    /* -timings under MPI: each phase's longest time over the ranks. A collective, so
     * before the root alone writes (and perhaps fails). */
    double phases[3] = {app->t_parse, app->t_grid, t_render};
    if (o->timings)
        dist_max(phases, 3);

    t0 = clock_now();
    ImageOutput outs[5];
    int nout = 0;
    if (target.color)
        outs[nout++] = (ImageOutput){target.color, o->output, stdout_format(o, o->output),
                                     &encoded[0]};
    if (target.depth)
        outs[nout++] = (ImageOutput){target.depth, o->depth_file,
                                     stdout_format(o, o->depth_file), &encoded[1]};
    if (target.normals)
        outs[nout++] = (ImageOutput){target.normals, o->normals_file,
                                     stdout_format(o, o->normals_file), &encoded[2]};
    if (samples)
        outs[nout++] = (ImageOutput){samples, o->samples_file,
                                     stdout_format(o, o->samples_file), NULL};
    if (filter_pic)
        outs[nout++] = (ImageOutput){filter_pic, o->filter_file,
                                     stdout_format(o, o->filter_file), NULL};
    if (dist_is_root() && nout > 0 && !image_write_all(outs, nout, &app->diag)) {
        status = EXIT_INPUT;
        goto done;
    }
    double t_write = clock_now() - t0;
    if (g_cancel) {
        /* The signal came while the images were being renamed into place: they are
         * complete, but the run was asked to stop. */
        fprintf(stderr, "%s: interrupted after the images were written\n", diag_program());
        status = interrupted_status();
        goto done;
    }

    if (o->stats && dist_is_root()) {
        StatsReport r;
        memset(&r, 0, sizeof r);
        r.width = target.w; /* the pixels rendered: the region's, with -region */
        r.height = target.h;
        BBox bounds = app->scene->bounds;
        /* The scene box (NULL when nothing is bounded): the grid's box, and without a
         * grid the course gives no rule, so we print it as most implementations do. */
        r.bounds = bbox_is_empty(&bounds) ? NULL : &bounds;
        accel_report(&app->accel, &r);
        r.elapsed_seconds = t_render;
        r.counts = counts;
        /* Standard output carries the image (-output -): the block goes to stderr. */
        if (image_to_stdout(o)) {
            stats_print(stderr, &r);
        } else {
            stats_print(stdout, &r);
            if (!stdout_ok(&app->diag, "the statistics"))
                status = EXIT_INPUT;
        }
    }
    /* The precise rate goes here; the -stats block has the course's whole-second one. */
    if (o->timings && dist_is_root()) {
        /* The build phase is named after the accelerator built ("grid", "twolevel");
         * without one (-accel none, no -grid, or the fallback of a scene of planes) it
         * is left out: flattening the scene was all it did. */
        char build[64] = "";
        if (app->accel.ops && app->accel.ops != &accel_none_ops)
            snprintf(build, sizeof build, ", %s %.3f ms", app->accel.ops->name,
                     phases[1] * 1e3);
        fprintf(stderr, "timings: parse %.3f ms%s, render %.3f ms, write %.3f ms, "
                "rays per second %.1f\n", phases[0] * 1e3, build, phases[2] * 1e3,
                t_write * 1e3,
                stats_rays_per_second(counts.nonshadow_rays + counts.shadow_rays, phases[2]));
    }
    /* Worded so that no "render N ms" appears twice (bench/run.sh reads the line above).
     * The calling thread's CPU time is the render's whole cost only on one thread; with
     * more it is that thread's share, and the note says so instead of reading as if the
     * run had one thread. */
    int threads = o->threads > 0 ? o->threads : render_default_threads();
    const char *whose = threads == 1 ? "the whole cost on one thread"
                                     : "its share of the work; with -threads 1 the whole "
                                       "cost";
    if (o->timings && dist_is_root())
        fprintf(stderr, "timings: CPU time of the calling thread in the render phase %.3f ms "
                "(%s)\n", cpu_render * 1e3, whose);
    if (o->timings && film && dist_is_root())
        fprintf(stderr, "timings: film: tracing %.3f ms, filtering %.3f ms (CPU time of the "
                "calling thread, %s)\n", fc.trace_cpu * 1e3, fc.filter_cpu * 1e3, whose);
    if (o->timings && dist_is_root())
        dist_report(stderr);
done:
    /* The run ends here: the big frees below and in main leave their mappings to the
     * exit (rt/bigmem.h). */
    if (app->last_render)
        bigmem_leave_to_exit();
    image_encoding_free(&pre_enc); /* made ahead and not used (a run stopped before) */
    for (int i = 0; i < 3; i++)
        image_encoding_free(&shaped_enc[i]); /* a run stopped before its render */
    for (int i = 0; i < 3; i++)
        image_encoding_free(&encoded[i]);
    if (target.color && (target.color->pixels || target.color->bytes))
        image_free(target.color);
    if (target.depth && (target.depth->pixels || target.depth->bytes))
        image_free(target.depth);
    if (target.normals && (target.normals->pixels || target.normals->bytes))
        image_free(target.normals);
    if (samples)
        image_free(samples);
    if (filter_pic)
        image_free(filter_pic);
    return status;
}

/* A stop signal that came during the set-up (parse, grid build), in one process: true
 * after saying so. It is looked at between the set-up's phases, and the long loops
 * inside them (the OBJ reader's lines, the grid build's chunks) poll it too (rt/par.h)
 * and end early, reporting nothing, so a Ctrl-C is obeyed within milliseconds, not at
 * the end of the phase it came in (0.2-0.6 s each for a 1M-triangle mesh), nor after
 * the whole set-up and the -cache file's write. Under MPI the ranks meet in the scene's
 * broadcast and the render's farm: a rank that left here alone would leave the others
 * waiting there (the loops are not told to poll then). */
static bool stopped_in_setup(void)
{
    if (!g_cancel || dist_size() != 1)
        return false;
    fprintf(stderr, "%s: interrupted; no image written\n", diag_program());
    return true;
}

static int run(App *app)
{
    const Options *o = &app->opt;
    /* -threads n bounds the set-up's threads too (rt/par.h): n - 1 helpers. */
    if (o->threads > 0)
        par_set_helpers(o->threads - 1 < PAR_MAX_WORKERS - 1 ? o->threads - 1 : PAR_MAX_WORKERS - 1);
    /* Every output is checked before the scene is even opened: a wrong extension or a
     * missing folder should not cost a long parse and render first. */
    const char *outputs[] = {o->output, o->depth_file, o->normals_file, o->gui_snapshot,
                             o->samples_file, o->filter_file};
    for (size_t i = 0; i < sizeof outputs / sizeof outputs[0]; i++)
        if (outputs[i] && !image_check_output(outputs[i], outputs[i] == o->gui_snapshot
                                                              ? NULL /* always TGA */
                                                              : stdout_format(o, outputs[i]),
                                              &app->diag))
            return EXIT_INPUT;
    /* So are the preview's: a build without it, a bad -gui_keys command, a shot:FILE
     * that cannot be written said so only after the scene's parse and grid build. */
    if (o->gui_snapshot && !preview_snapshot_built()) {
        diag_error(&app->diag, NULL, "-gui_snapshot is not built in: %s",
                   preview_remedy(false));
        return EXIT_USAGE;
    }
    if (o->gui && !o->gui_snapshot && !preview_window_built()) {
        diag_error(&app->diag, NULL, "-gui is not built in: %s", preview_remedy(true));
        return EXIT_USAGE;
    }
    if ((o->gui || o->gui_snapshot) && o->gui_keys) {
        int status = preview_keys_validate(o->gui_keys, &app->diag);
        if (status)
            return status == 2 ? EXIT_USAGE : EXIT_INPUT;
    }
    /* -gui_snapshot draws one frame; the images and statistics asked for come only from
     * the script's r (in the window the user may still press it). Without r they were
     * left out in silence, with exit status 0. */
    if (o->gui_snapshot && !preview_keys_render(o->gui_keys)) {
        const char *names[] = {"-output", "-depth", "-normals", "-stats", "-render_samples",
                               "-render_filter"};
        bool given[] = {o->output != NULL, o->depth_file != NULL, o->normals_file != NULL,
                        o->stats, o->samples_file != NULL, o->filter_file != NULL};
        char list[160] = "";
        for (size_t i = 0; i < sizeof names / sizeof names[0]; i++)
            if (given[i])
                snprintf(list + strlen(list), sizeof list - strlen(list), "%s%s",
                         list[0] ? ", " : "", names[i]);
        if (list[0] && dist_is_root())
            fprintf(stderr, "%s: warning: nothing is rendered for %s: with -gui_snapshot "
                    "only an r in -gui_keys renders (-gui_keys r)\n", diag_program(), list);
    }
    /* A filter picture alone depends on the filter options, -size and the zoom only:
     * the scene (a big mesh's file and grid take seconds; a scene that is missing or
     * broken failed the run) is not read, and render_and_write traces nothing. */
    if (!options_needs_scene(o)) {
        app->last_render = true;
        return render_and_write(app, NULL, NULL);
    }
    /* The set-up's helpers start now and stay for the render (rt/par.h): each starts
     * once, while the scene file is read, instead of once per parallel step and again
     * for the render. */
    par_hold();
    double t0 = clock_now();
    if (o->cache_file) {
        /* A cache that cannot be used is not an error: the set-up is built instead. */
        app->cache = setup_cache_open(o->cache_file);
        if (app->cache && setup_cache_rejected(app->cache)[0] && o->timings && dist_is_root())
            fprintf(stderr, "timings: set-up cache %s not used (%s): building\n",
                    o->cache_file, setup_cache_rejected(app->cache));
    }
    /* -input - on a terminal waits for typed text without a word, which looks like a
     * hang: say what it waits for and how to end it. */
    if (o->input && !strcmp(o->input, "-") && !o->quiet && dist_is_root() &&
        isatty(STDIN_FILENO) == 1)
        fprintf(stderr, "%s: reading the scene from the terminal (-input -): type or paste "
                "it, then press Ctrl-D on a line of its own\n", diag_program());
    /* A part image records the render's identity (rt/image.h): the scene's files are
     * keyed as they are read. */
    app->scene = dist_scene_load(o->input, app->cache, o->region, &app->diag);
    app->t_parse = clock_now() - t0;
    if (!app->scene) /* an error was reported, or a stop cut the parse (nothing said) */
        return app->diag.errors == 0 && stopped_in_setup() ? interrupted_status()
                                                           : EXIT_INPUT;
    if (stopped_in_setup())
        return interrupted_status();
    /* The output's image and file are made now on the helper, between the grid's
     * parallel steps (prepare_output). */
    prepare_output(app);
    Scene *s = app->scene;
    SrcLoc file = {s->path, 0, 0};
    if (!scene_check_renderable(s, &app->diag))
        return EXIT_INPUT;
    scene_warn_no_lights(s, &app->diag);

    app->rt.scene = s;
    app->rt.shadows = o->shadows;
    app->rt.shade_back = o->shade_back;
    app->rt.bounces = o->bounces;
    app->rt.weight = o->weight;
    /* -stats counts the course's way: the tests and cells of each ray's own march.
     * Packets test a superset per ray, in another order, so with -stats every ray is
     * marched on its own (same image; the render takes about as long as with
     * -no_packets, docs/statistics.md). */
    app->rt.single_rays = o->no_packets || o->stats;

    t0 = clock_now();
    if (!prim_table_build(&app->prims, s)) {
        if (stopped_in_setup()) /* cut short by a stop signal, reporting nothing */
            return interrupted_status();
        diag_error(&app->diag, NULL, "out of memory flattening the scene");
        return EXIT_INPUT;
    }
    if (stopped_in_setup())
        return interrupted_status();
    const AccelOps *ops = accel_find(o->accel ? o->accel : o->grid ? "grid" : "none");
    /* -grid auto: the two-level grid where the scene is crowded (a dense part in a big
     * sparse box), the uniform grid otherwise (docs/twolevel.md). */
    if (!o->accel && o->grid_auto && twolevel_preferred(&app->prims))
        ops = &accel_twolevel_ops;
    AccelConfig acfg;
    memset(&acfg, 0, sizeof acfg);
    memcpy(acfg.grid_n, o->grid_n, sizeof acfg.grid_n);
    acfg.grid_auto = o->grid_auto;
    acfg.no_marking = o->no_marking;
    acfg.visualize = o->visualize_grid;
    acfg.cache = app->cache;
    acfg.inputs = s->inputs;
    /* Leaves with huge boxes stay out of the cells (rt/prim.h): said once, where the
     * first of them is written. */
    if (ops != &accel_none_ops && app->prims.num_kept_out > 0 && dist_is_root()) {
        const Prim *p = &app->prims.prims[app->prims.first_kept_out];
        SrcLoc at;
        scene_leaf_loc(s, p->id, &at);
        char more[64] = "";
        if (app->prims.num_kept_out > 1)
            snprintf(more, sizeof more, " (and %u more objects)", app->prims.num_kept_out - 1);
        diag_warning(&app->diag, &at, "%s reaches beyond +-%g: kept out of the %s and tested "
                     "by every ray%s", p->obj->ops->type_name, (double)PRIM_MAX_COORD, "grid",
                     more);
    }
    int errors = app->diag.errors;
    if (!accel_init(&app->accel, ops, &app->prims, &acfg, &app->diag)) {
        if (app->diag.errors > errors)
            return EXIT_INPUT;
        if (stopped_in_setup()) /* the build was cut short, reporting nothing */
            return interrupted_status();
        if (app->prims.num_prims == 0)
            diag_warning(&app->diag, &file, "the scene has no objects: rendering without a %s",
                         ops->name);
        else
            diag_warning(&app->diag, &file, "nothing bounded to put in a %s (only planes%s): "
                         "rendering without one", ops->name,
                         app->prims.num_kept_out ? " and objects kept out of it" : "");
        if (!accel_init(&app->accel, &accel_none_ops, &app->prims, &acfg, &app->diag))
            return EXIT_INPUT;
    } else if (o->timings && twolevel_of_accel(&app->accel) && dist_is_root()) {
        StatsReport r;
        memset(&r, 0, sizeof r);
        accel_report(&app->accel, &r);
        uint32_t subs;
        uint64_t leaf;
        twolevel_counts(twolevel_of_accel(&app->accel), &subs, &leaf);
        fprintf(stderr, "timings: %s: two-level, %d x %d x %d top cells, %u leaf grids of %llu cells\n",
                o->grid_auto && !o->accel ? "grid auto" : "accel twolevel", r.nx, r.ny, r.nz,
                subs, (unsigned long long)leaf);
    } else if (o->timings && o->grid_auto && dist_is_root()) {
        StatsReport r;
        memset(&r, 0, sizeof r);
        accel_report(&app->accel, &r);
        fprintf(stderr, "timings: grid auto chose %d x %d x %d cells\n", r.nx, r.ny, r.nz);
    }
    /* Before the -cache file: a set-up the user stopped is not written for the next
     * run (97 MB, 2 s here for 1M triangles). */
    if (stopped_in_setup())
        return interrupted_status();
    if (app->cache && dist_is_root()) {
        bool dirty = setup_cache_dirty(app->cache);
        char why[512] = "";
        if (dirty && !setup_cache_write(app->cache, why, sizeof why))
            diag_warning(&app->diag, NULL, "set-up cache not written (%s): carrying on", why);
        else if (o->timings)
            fprintf(stderr, "timings: set-up cache %s: %s (OBJ files known by their "
                    "identity, not read: %d)\n", o->cache_file,
                    dirty ? "built and written"
                    : setup_cache_hits(app->cache) ? "used" : "nothing to cache",
                    setup_cache_hits_of(app->cache, SETUP_TAG_FILE));
    }
    /* The build phase ends here: the sums below are -timings' own (the course counts
     * and the exact reference estimate, passes over every primitive that no render
     * makes: 8-10 ms of CPU on line 07's 40k bunny, more than half the grid build),
     * so they are not counted in it. */
    app->t_grid = clock_now() - t0;
    const Grid *grid = grid_of_accel(&app->accel);
    if (o->timings && grid && dist_is_root()) {
        /* Both sums below run on the set-up threads. */
        par_prepare();
        uint64_t course, marching;
        grid_entry_totals(grid, &course, &marching);
        int n[3];
        grid_dims(grid, n);
        fprintf(stderr, "timings: grid cell references: %llu marching, %llu course, at most "
                "%llu (cap %llu)\n", (unsigned long long)marching, (unsigned long long)course,
                (unsigned long long)grid_ref_estimate(&app->prims, n),
                (unsigned long long)grid_ref_cap(app->prims.num_bounded));
    }
    /* Without an accelerator every ray tests every primitive: fine for the course's
     * small scenes, thousands of times slower on a mesh. The course's semantics stay (no
     * -grid, no grid); the user is told once, and not when nothing is traced (a filter
     * picture alone), where a grid would only add its build. */
    if (!o->grid && !o->accel && !o->quiet && dist_is_root() && traces_rays(o) &&
        s->num_primitives > HINT_PRIMITIVES)
        fprintf(stderr, "%s: hint: %u primitives and no -grid: add -grid auto (same "
                "image, much faster)\n", diag_program(), (unsigned)s->num_primitives);
    app->rt.accel = &app->accel;

    if ((o->gui || o->gui_snapshot || o->samples_file) && dist_size() > 1) {
        diag_error(&app->diag, NULL, "the preview (-gui, -gui_snapshot) and -render_samples "
                   "run in one process, not under MPI");
        return EXIT_USAGE;
    }
    if (o->gui || o->gui_snapshot) {
        /* r traces the preview's own picture (the window's, the snapshot's frame)
         * before render_and_write sets the pixel cone for the files: without it here
         * the first r drew its picture with no -noise_cutoff at all, the later ones
         * with it. The cone depends on the angle or size and -size only, which no move
         * of the preview's camera changes. */
        if (o->noise_cutoff)
            raytracer_set_pixel_cone(&app->rt, &s->camera, o->width, o->height);
        PreviewConfig cfg;
        memset(&cfg, 0, sizeof cfg);
        cfg.scene = s;
        cfg.tracer = &app->rt;
        cfg.width = o->width;
        cfg.height = o->height;
        cfg.tess_theta = o->tess_theta;
        cfg.tess_phi = o->tess_phi;
        cfg.gouraud = o->gouraud;
        cfg.visualize_grid = o->visualize_grid;
        cfg.threads = o->threads;
        cfg.render = render_and_write;
        cfg.render_user = app;
        cfg.snapshot_path = o->gui_snapshot;
        cfg.keys = o->gui_keys;
        cfg.stop = &g_cancel;
        /* The c, t, g and r lines were printed on stdout also when it carried the
         * image (-gui_snapshot -, shot:-, -output - written by r): text inside the
         * image's bytes. */
        cfg.messages = image_to_stdout(o) ? stderr : stdout;
        if (!o->gui_snapshot)
            return preview_run_window(&cfg, &app->diag);
        int status = preview_snapshot(&cfg, &app->diag);
        if (status == 0 && g_cancel) {
            /* The signal came while the snapshot was being renamed into place. */
            fprintf(stderr, "%s: interrupted after the images were written\n", diag_program());
            status = interrupted_status();
        }
        return status;
    }
    app->last_render = true;
    return render_and_write(app, &s->camera, NULL);
}

int main(int argc, char **argv)
{
    diag_set_program(dist_program_name);
    /* raytracer -merge out part...: its own small command (README.txt). */
    if (argc >= 2 && strcmp(argv[1], "-merge") == 0) {
        /* Under mpirun (or srun with an MPI plugin) every rank runs this same command:
         * each merged and wrote the output, and each printed every message. The merge
         * is one process's work and needs no MPI (none is started): rank 0 does it, the
         * others leave at once, saying and writing nothing, with status 0 (mpirun's
         * status is then rank 0's). */
        int rank = dist_launcher_rank();
        if (rank > 0)
            return 0;
        if (!options_check_merge(argc, argv, stderr))
            return EXIT_USAGE;
        /* -merge - under mpirun: standard output is mpirun's channel (its
         * pseudo-terminal), not the user's terminal, as for a render's -output -. */
        image_stdout_forwarded(rank == 0);
        /* A merge of big parts takes seconds. Without the handlers a Ctrl-C or kill
         * ended it by the signal itself, and one that came during the write left the
         * temporary file behind (a 48 MB ".whole.tga.XXXXXX" for a 4000x4000 image).
         * With them it ends as a render does: the temporary file removed
         * (image_write_abort), "interrupted", exit status 128 + signal. */
        install_signal_handlers();
        Diag d;
        diag_init(&d, stderr);
        bool merged = image_merge(argv[2], (const char *const *)(argv + 3), argc - 3,
                                  &g_cancel, &d);
        if (g_cancel) {
            fprintf(stderr, merged ? "%s: interrupted after the images were written\n"
                                   : "%s: interrupted; no image written\n", diag_program());
            return interrupted_status();
        }
        return merged ? 0 : EXIT_INPUT;
    }
    /* The stop signals are caught from the start: a Ctrl-C while MPI starts up (the
     * singleton's orted takes a second) was lost, and the render then ran on. MPI_Init
     * may install handlers of its own, so they are installed again after it. */
    install_signal_handlers();
    if (!dist_init(&argc, &argv))
        return EXIT_INPUT;
    install_signal_handlers();
    /* -output - under mpirun: the rank's standard output is mpirun's pseudo-terminal,
     * not the user's (-merge, before this, sets it the same way). */
    image_stdout_forwarded(dist_stdout_forwarded());
    /* The set-up's long loops (OBJ reading, grid build) end early on a stop signal
     * (rt/par.h). In one process only, as stopped_in_setup: MPI ranks must all reach the
     * scene's broadcast and the render's farm. */
    if (dist_size() == 1)
        par_set_stop_flag(&g_cancel);
    /* Under MPI every rank runs this with the same options; only the root speaks. */
    FILE *err = dist_is_root() ? stderr : NULL;
    FILE *quiet = err ? NULL : fopen("/dev/null", "w");
    App app;
    memset(&app, 0, sizeof app);
    options_defaults(&app.opt);
    bool parsed = options_parse(&app.opt, argc, argv, err ? err : quiet ? quiet : stderr);
    if (quiet)
        fclose(quiet);
    if (!parsed)
        return dist_finish(EXIT_USAGE);
    /* Before anything chooses a kernel (each module chooses at its first use). */
    cpu_isa_cap = app.opt.isa;
    if (app.opt.help || app.opt.version) {
        int status = 0;
        if (dist_is_root()) {
            if (app.opt.help)
                options_usage(stdout);
            else
                print_version();
            /* A text that did not arrive (a full disk, stdout closed) is an output
             * error like lost statistics, not a success a script would trust. */
            diag_init(&app.diag, err);
            if (!stdout_ok(&app.diag, app.opt.help ? "the help text" : "the version"))
                status = EXIT_INPUT;
        }
        return dist_finish(status);
    }
    diag_init(&app.diag, err);
    /* Only the root speaks: under mpirun every rank printed each warning. */
    if (err)
        options_warn(&app.opt, render_default_threads(), err);

    int status = run(&app);
    prepared_free(&app); /* when the run ended before its render */
    /* Anything else printed on stdout must have arrived too. */
    if (status == 0 && !stdout_ok(&app.diag, "the output"))
        status = EXIT_INPUT;
    accel_free(&app.accel);
    prim_table_free(&app.prims);
    scene_free(app.scene);
    setup_cache_release(app.cache);
    return dist_finish(status);
}
