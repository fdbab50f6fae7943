/* Command line (README.txt lists it): the course's flags with their exact spelling, plus
 * -threads, -h/--help, --version and the preview's -gui_snapshot/-gui_keys. */
#ifndef RT_OPTIONS_H
#define RT_OPTIONS_H

#include <stdbool.h>
#include <stdio.h>

#include "rt/cpu.h"
#include "rt/progress.h"

typedef struct Options {
    const char *input;           /* required unless help/version */
    const char *output;          /* NULL: no colour image; "-": standard output */
    const char *format;          /* -format NAME: a codec's name for images written to
                                    standard output (NULL: TGA); a file's extension must
                                    name the same format */
    int width, height;           /* default 100 100 */
    const char *depth_file;      /* -depth dmin dmax file */
    float depth_min, depth_max;
    const char *normals_file;
    bool shade_back, shadows, stats;
    bool noise_cutoff;           /* -noise_cutoff: noise octaves finer than a pixel left out */
    bool timings;                /* -timings: phase times on stderr */
    const char *cache_file;      /* -cache FILE: the set-up cache of split renders */
    int bounces;                 /* default 0 */
    float weight;                /* default 0 */
    bool grid;                   /* -grid given */
    bool grid_auto;              /* -grid auto */
    int grid_n[3];
    bool visualize_grid, visualize_grid_count;
    bool no_marking;             /* -no_marking: grid without mailboxing (analysis) */
    bool no_packets;             /* -no_packets: every ray marched alone (comparisons) */
    CpuIsa isa;                  /* -isa NAME: the widest instruction set used (rt/cpu.h;
                                    default the widest, which the CPU caps) */
    const char *accel;           /* -accel NAME (a registered one, rt/accel.h); NULL:
                                    "grid" when -grid is given, else "none" */
    bool gui, gouraud;
    int tess_theta, tess_phi;    /* default 20 10 */
    bool tessellation_given;     /* -tessellation was given */
    const char *gui_snapshot;    /* -gui_snapshot file.tga: headless preview frame */
    const char *gui_keys;        /* -gui_keys "script" */
    int threads;                 /* 0 = all cores */
    /* Antialiasing (A7). The three course samplers and -nrooks_samples set one setting
     * (the last wins); so do the filters. Checked here: counts, squares, radii, zooms. */
    const char *sampler;         /* NULL: one centred sample; else "uniform", "random",
                                    "jittered", "nrooks" (-<name>_samples n) */
    int samples;                 /* its count */
    bool adaptive;               /* -adaptive_samples min max threshold (jittered) */
    int adaptive_min, adaptive_max;
    float adaptive_threshold;
    const char *filter;          /* NULL: box of radius 0.5; else "box", "tent",
                                    "gaussian", "mitchell" (-<name>_filter r) */
    float filter_param;          /* radius or sigma */
    const char *samples_file;    /* -render_samples file zoom */
    int samples_zoom;
    const char *filter_file;     /* -render_filter file zoom */
    int filter_zoom;
    unsigned long long seed;     /* -seed n: the random samplers' seed (default 0) */
    bool seed_given;             /* -seed was given (options_warn) */
    /* The sampler and filter options as given, for options_warn: the one in use
     * (-jittered_samples) and the last other one it replaced (NULL: none). The later of
     * two wins, said in a warning: a typo'd second sampler would otherwise go unseen. */
    const char *sampler_flag, *sampler_replaced;
    const char *filter_flag, *filter_replaced;
    /* -region x y w h / -tile k n: render only this rectangle of the -size image, x y
     * its top-left pixel counted from the image's top-left corner. options_parse turns
     * -tile into the region (options_tile_rows) and checks it lies inside the image. */
    bool region;
    int region_x, region_y, region_w, region_h;
    bool tile;                   /* the region came from -tile k n */
    int tile_k, tile_n;          /* tile k of tile_n: tile_cols columns, tile_n / tile_cols */
    int tile_cols;               /* rows (1 column: bands; -tile k CxR) */
    ProgressMode progress;       /* -progress ALWAYS, -quiet NEVER, else AUTO */
    bool quiet;                  /* -quiet: no progress line, no hints */
    bool help, version;
} Options;

/* The one limit on a grid's cells (nx * ny * nz), checked with the options (-grid) and
 * by the grid builder itself. */
enum { RT_GRID_MAX_CELLS = 1 << 24 };

void options_defaults(Options *o);
/* Parses argv. On a usage error prints one line "raytracer: <why>" (and a hint to run
 * -h) on err and returns false; the caller exits 2. */
bool options_parse(Options *o, int argc, char **argv, FILE *err);
void options_usage(FILE *out);
/* Checks the command "raytracer -merge out part..." (argv[1] is "-merge"): at least one
 * part, no option names among the files (-merge takes nothing else), the output not
 * also a part and no part twice (the same text or the same file, rt/file.h file_same).
 * On a usage error prints one line on err and returns false; the caller exits 2. */
bool options_check_merge(int argc, char **argv, FILE *err);
/* Whether the run reads the scene: not for a -render_filter picture alone (no -output,
 * -depth, -normals, -render_samples, -gui, -gui_snapshot, -stats or -cache), which is
 * drawn from -size, the zoom and the filter options only; -input may be left out then,
 * and a scene given is not even opened. */
bool options_needs_scene(const Options *o);
/* Warnings for options that do nothing here (preview options without a preview,
 * -threads far above the cores), each one line on err. */
void options_warn(const Options *o, int cores, FILE *err);
/* The option names of the usage text, in its order ("-input", ..., "-h", "--help"):
 * up to max into names; returns how many there are. */
int options_names(const char **names, int max);

/* Band k (0 = top) of n horizontal bands of an image of height rows: its first row from
 * the top and its number of rows. The bands cover the image without overlap; when
 * n <= ceil(height / 8) their edges fall on the renderer's 8-row packet bands (counted
 * from the bottom row), so a split render traces the same ray packets as a whole one.
 * Needs 1 <= n <= height and 0 <= k < n. */
void options_tile_rows(int k, int n, int height, int *y, int *h);

/* Column k (0 = left) of n columns of tiles of an image of width columns: its first
 * column and its width. As options_tile_rows, on the renderer's 8-column packet grid
 * (counted from the left column) when n <= ceil(width / 8). Needs 1 <= n <= width. */
void options_tile_cols(int k, int n, int width, int *x, int *w);

#endif
