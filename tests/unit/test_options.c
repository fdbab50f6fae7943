/* Unit tests of the command line (README.txt's options) and of the statistics block
 * layout. */
#define _GNU_SOURCE
#include "harness.h"
#include "rt/options.h"
#include "rt/stats.h"
#include "rt/accel.h"
#include "rt/image.h"

#include <math.h>
#include <stdlib.h>

static bool parse(Options *o, const char *line, char *err, size_t errlen)
{
    char buf[1024], *argv[64];
    int argc = 0;
    snprintf(buf, sizeof buf, "raytracer %s", line);
    for (char *t = strtok(buf, " "); t && argc < 63; t = strtok(NULL, " "))
        argv[argc++] = t;
    argv[argc] = NULL;
    FILE *f = fmemopen(err, errlen, "w");
    options_defaults(o);
    bool ok = options_parse(o, argc, argv, f);
    fclose(f);
    return ok;
}

static void test_course_line(void)
{
    Options o;
    char err[512] = "";
    CHECK(parse(&o, "-input s.txt -size 400 200 -output o.tga -shadows -shade_back -bounces 5 "
                    "-weight 0.01 -grid 80 30 3 -stats -depth -2 2 d.tga -normals n.tga",
                err, sizeof err));
    CHECK_STR(o.input, "s.txt");
    CHECK_INT(o.width, 400);
    CHECK_INT(o.height, 200);
    CHECK(o.shadows && o.shade_back && o.stats && o.grid && !o.grid_auto);
    CHECK_INT(o.bounces, 5);
    CHECK_NEAR(o.weight, 0.01, 1e-7);
    CHECK_INT(o.grid_n[0] * 100 + o.grid_n[1] * 10 + o.grid_n[2], 8000 + 300 + 3);
    CHECK_NEAR(o.depth_min, -2, 0);
    CHECK_STR(o.depth_file, "d.tga");
    CHECK_STR(o.normals_file, "n.tga");
}

static void test_defaults_and_repeats(void)
{
    Options o;
    char err[512] = "";
    CHECK(parse(&o, "-input a.txt -input b.txt -grid auto -output o.tga", err, sizeof err));
    CHECK_STR(o.input, "b.txt"); /* the later occurrence wins */
    CHECK_INT(o.width, 100);
    CHECK_INT(o.bounces, 0);
    CHECK(o.grid_auto);
    CHECK(parse(&o, "-h", err, sizeof err) && o.help);
    /* -accel grid alone is -grid auto; with -grid it keeps the resolution. */
    CHECK(parse(&o, "-input a.txt -output o.tga -accel grid", err, sizeof err));
    CHECK(o.grid && o.grid_auto && o.accel); /* (o.accel points into parse's buffer) */
    CHECK(parse(&o, "-input a.txt -output o.tga -grid 3 4 5 -accel grid", err, sizeof err));
    CHECK(o.grid && !o.grid_auto && o.grid_n[2] == 5);
    CHECK(parse(&o, "-input a.txt -output o.tga -accel none", err, sizeof err));
    CHECK(!o.grid && o.accel);
    CHECK(parse(&o, "--version", err, sizeof err) && o.version);
    /* "-" and negative numbers are values, not options; t = 0 and 1 are in range */
    CHECK(parse(&o, "-input - -output - -depth -2 -1 d.tga", err, sizeof err));
    CHECK_STR(o.input, "-");
    CHECK_STR(o.output, "-");
    CHECK(parse(&o, "-input s.txt -output o.tga -adaptive_samples 4 16 1", err, sizeof err));
    CHECK(parse(&o, "-input s.txt -output o.tga -adaptive_samples 4 16 0", err, sizeof err));
}

static void test_usage_errors(void)
{
    static const char *bad[][2] = {
        {"-input s.txt -bogus", "unknown option '-bogus'"},
        {"-input s.txt -size 10", "missing value for -size: the command line ends before h (-size w h)"},
        {"-input s.txt -size 10 x", "expects an integer, got 'x'"},
        {"-input s.txt -size -5 10", "out of range"},
        {"-input s.txt -size 0 10", "out of range"},
        {"-input s.txt -weight nan", "finite number"},
        {"-input s.txt -weight -1", "option -weight: w = -1 must be >= 0"},
        {"-input s.txt -bounces 1.5", "expects an integer"},
        {"-input s.txt -depth 1 1 d.tga", "must differ"},
        {"-input s.txt -grid 0 1 1", "out of range"},
        {"-input s.txt -grid 10 10", "missing value for -grid: the command line ends before nz"},
        {"-input s.txt -visualize_grid", "needs -grid"},
        {"-output o.tga", "-input scene.txt is required"},
        {"-input s.txt -threads 0", "out of range"},
        {"-input s.txt -accel bvh", "unknown accelerator 'bvh' (known: none, grid, twolevel)"},
        {"-input s.txt -accel", "missing value for -accel: the command line ends before name"},
        {"-input s.txt -accel none -grid 4 4 4", "-grid goes with -accel grid"},
        {"-input s.txt -accel none -visualize_grid", "not with -accel none (use -grid nx ny nz"},
        {"-input s.txt -accel twolevel -visualize_grid -grid auto", "-grid goes with -accel grid"},
        {"-input s.txt -accel twolevel -visualize_grid",
         "-visualize_grid draws the uniform grid's cells: not with -accel twolevel (use -grid nx "
         "ny nz or -grid auto instead)"},
        /* a range error names the value of a multi-value option that is wrong */
        {"-input s.txt -size 0 10", "option -size: w = 0 is out of range 1..32768"},
        {"-input s.txt -size 10 0", "option -size: h = 0 is out of range 1..32768"},
        {"-input s.txt -size 10 x", "option -size: h expects an integer, got 'x'"},
        {"-input s.txt -grid 4 0 4", "option -grid: ny = 0 is out of range"},
        {"-input s.txt -region 0 0 4 0", "option -region: h = 0 is out of range"},
        {"-input s.txt -tile 0 0", "option -tile: n = 0 is out of range"},
        {"-input s.txt -depth 0 x d.tga", "option -depth: dmax expects a finite number"},
        /* an underflow is not "not a finite number" */
        {"-input s.txt -gaussian_filter 1e-40",
         "option -gaussian_filter: s = 1e-40 is too close to 0 for a float"},
        {"-input s.txt -weight 1e-300", "option -weight: w = 1e-300 is too close to 0"},
        /* a filter's range names the value as typed (it printed the float: "sigma 16 is out
         * of range (0, 16]" for 16.000001) */
        {"-input s.txt -gaussian_filter 16.000001",
         "option -gaussian_filter: s = 16.000001 is out of range (0, 16]"},
        {"-input s.txt -mitchell_filter -0", "option -mitchell_filter: r = -0 is out of range (0, 16]"},
        /* nor an overflow; an infinity is still not a finite number */
        {"-input s.txt -weight 1e40", "option -weight: w = 1e40 is too large in size for a float"},
        {"-input s.txt -weight -inf", "option -weight: w expects a finite number, got '-inf'"},
        {"-input s.txt -bounces 2000", "option -bounces: n = 2000 is out of range 0..1000"},
        /* a value that is exactly an option name: the value was left out */
        {"-input s.txt -output -size 10 10", "missing value for -output"},
        {"-input s.txt -size 10 -output o.tga", "missing value for -size"},
        {"-input -output o.tga", "missing value for -input"},
        /* an option written without its dash, also where an extra value would be */
        {"input s.txt -output o.tga", "unexpected argument 'input' (did you mean -input?)"},
        {"-input s.txt -size 8 8 shadows", "unexpected argument 'shadows' (did you mean -shadows?)"},
        {"-input s.txt -output o.tga -normals -stats", "missing value for -normals"},
        /* words are case-sensitive: the right spelling is offered */
        {"-input s.txt -output o.tga -grid Auto", "option -grid: 'Auto' (did you mean auto?)"},
        {"-input s.txt -output o.tga -grid AUTO", "did you mean auto?"},
        {"-input s.txt -output o.tga -grid atuo", "option -grid: 'atuo' (did you mean auto?)"},
        {"-input s.txt -output o.tga -grid aut 10 10", "option -grid: 'aut' (did you mean auto?)"},
        {"-input s.txt -output o.tga -grid x 10 10", "option -grid: nx expects an integer, got 'x'"},
        /* an extra value names the form of the option that was given: "-grid auto 3"
         * said "-grid takes 1 value (-grid nx ny nz)" */
        {"-input s.txt -output o.tga -grid auto 3",
         "extra value '3' after '-grid auto': -grid takes 1 value (-grid auto)"},
        {"-input s.txt -output o.tga -grid 4 4 4 4",
         "extra value '4' after '-grid 4 4 4': -grid takes 3 values (-grid nx ny nz)"},
        /* -adaptive_samples t is a difference of channels in 0..1 */
        {"-input s.txt -output o.tga -adaptive_samples 4 16 1.5",
         "option -adaptive_samples: t = 1.5 is out of range 0..1"},
        {"-input s.txt -output o.tga -adaptive_samples 4 16 -0.1", "t = -0.1 is out of range"},
        /* one first sample cannot differ from itself: b would never be used */
        {"-input s.txt -output o.tga -adaptive_samples 1 16 0",
         "option -adaptive_samples: a = 1: one first sample cannot differ from itself"},
        /* zoom 1: the filter picture's grid lines cover every pixel, no weight shows */
        {"-size 9 9 -render_filter f.tga 1", "option -render_filter: z = 1 draws only the pixel "
                                            "grid"},
        {"-input s.txt -region 0 0 4 4 -tile 0 2 -output o.tga",
         "-region and -tile both choose the rectangle"},
        {"-input s.txt -tile 1 2 -region 0 0 4 4 -output o.tga",
         "-region and -tile both choose the rectangle"},
        /* the snapshot, the set-up cache and the scene are files too: the cache written
         * over the scene destroyed it, an image over the cache made it useless */
        {"-input s.txt -output o.tga -gui_snapshot ./o.tga",
         "-output and -gui_snapshot name the same file './o.tga'"},
        {"-input s.txt -output o.tga -cache o.tga", "-output and -cache name the same file"},
        /* "-" is no cache: it made a file named "-" in the working folder */
        {"-input s.txt -output o.tga -cache -", "option -cache: '-' is no file here"},
        /* and the preview's shot:FILE, which replaced the render r had written there */
        {"-input s.txt -output o.tga -gui_snapshot v.tga -gui_keys shot:o.tga",
         "-output and -gui_keys shot:o.tga name the same file"},
        {"-input s.txt -gui -depth 1 2 d.tga -gui_keys SHOT:./d.tga",
         "-depth and -gui_keys shot:./d.tga name the same file"},
        {"-input s.txt -gui_snapshot v.tga -gui_keys shot:v.tga",
         "-gui_snapshot and -gui_keys shot:v.tga name the same file"},
        /* standard output twice: the render r writes and the frame, one after the other */
        {"-input s.txt -output - -gui_snapshot v.tga -gui_keys shot:-",
         "-output and -gui_keys shot:- name the same file"},
        {"-input s.txt -gui_snapshot - -gui_keys shot:-",
         "-gui_snapshot and -gui_keys shot:- name the same file"},
        {"-input s.txt -output o.tga -cache s.txt", "-cache and -input name the same file"},
        {"-input s.txt -depth 0 1 c -cache ./c", "-depth and -cache name the same file"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++) {
        Options o;
        char err[512] = "";
        bool ok = parse(&o, bad[i][0], err, sizeof err);
        CHECK_MSG(!ok, "accepted: %s", bad[i][0]);
        CHECK_CONTAINS(err, bad[i][1]);
        CHECK_CONTAINS(err, "raytracer: ");
    }
    /* while -input - is standard input: no pair with shot:- */
    Options o;
    char err[512] = "";
    CHECK_MSG(parse(&o, "-input - -gui_snapshot v.tga -gui_keys shot:-", err, sizeof err),
              "refused: %s", err);
}

/* An empty value (a shell variable left unset) is a usage error naming the option; it
 * reached the file layer and came back as ": error: ..." with no name. */
static void test_empty_values(void)
{
    static const char *const flags[][3] = {
        {"-input", "", NULL}, {"-output", "", NULL}, {"-normals", "", NULL},
        {"-cache", "", NULL}, {"-size", "", "10"},
    };
    for (size_t i = 0; i < sizeof flags / sizeof flags[0]; i++) {
        char *argv[12];
        int argc = 0;
        argv[argc++] = (char *)"raytracer";
        if (strcmp(flags[i][0], "-input") != 0) {
            argv[argc++] = (char *)"-input";
            argv[argc++] = (char *)"s.txt";
            argv[argc++] = (char *)"-output";
            argv[argc++] = (char *)"o.tga";
        }
        for (int k = 0; k < 3 && flags[i][k]; k++)
            argv[argc++] = (char *)flags[i][k];
        if (strcmp(flags[i][0], "-input") == 0) {
            argv[argc++] = (char *)"-output";
            argv[argc++] = (char *)"o.tga";
        }
        argv[argc] = NULL;
        char err[512] = "";
        FILE *f = fmemopen(err, sizeof err, "w");
        Options o;
        options_defaults(&o);
        bool ok = options_parse(&o, argc, argv, f);
        fclose(f);
        char want[64];
        snprintf(want, sizeof want, "raytracer: option %s: the value is empty", flags[i][0]);
        CHECK_MSG(!ok && strstr(err, want), "%s '': %s", flags[i][0], err);
    }
    /* the preview's key script may be empty */
    char *keys[] = {(char *)"raytracer", (char *)"-input", (char *)"s.txt", (char *)"-output",
                    (char *)"o.tga", (char *)"-gui_keys", (char *)"", NULL};
    char err[512] = "";
    FILE *f = fmemopen(err, sizeof err, "w");
    Options o;
    options_defaults(&o);
    CHECK_MSG(options_parse(&o, 7, keys, f), "-gui_keys '' refused");
    fclose(f);
}

static void test_stats_block(void)
{
    char buf[4096] = "";
    FILE *f = fmemopen(buf, sizeof buf, "w");
    BBox b = {{-1, -1, -1}, {1, 1, 1}};
    StatsReport r = {200, 200, &b, 0, 0, 0, 0.25, {40000, 0, 40000, 0, 0, 0}};
    stats_print(f, &r);
    fclose(f);
    const char *want =
        "********************************************\n"
        "RAY TRACING STATISTICS\n"
        "  total time                 0:00:01\n"
        "  num pixels                 40000 (200x200)\n"
        "  scene bounds               -1.000000 -1.000000 -1.000000  -> 1.000000 1.000000 1.000000\n"
        "  num grid cells             NULL\n"
        "  num non-shadow rays        40000\n"
        "  num shadow rays            0\n"
        "  total intersections        40000\n"
        "  total cells traversed      0\n"
        "  rays per second            40000.0\n"
        "  rays per pixel             1.0\n"
        "  intersections per ray      1.0\n"
        "  cells traversed per ray    0.0\n"
        "********************************************\n";
    CHECK_STR(buf, want);

    f = fmemopen(buf, sizeof buf, "w");
    StatsReport g = {400, 200, NULL, 40, 40, 33, 3725.5, {100, 50, 300, 900, 0, 0}};
    stats_print(f, &g);
    fclose(f);
    CHECK_CONTAINS(buf, "  total time                 1:02:05\n");
    CHECK_CONTAINS(buf, "  num pixels                 80000 (400x200)\n");
    CHECK_CONTAINS(buf, "  scene bounds               NULL\n");
    CHECK_CONTAINS(buf, "  num grid cells             52800 (40x40x33)\n");
    CHECK_CONTAINS(buf, "  intersections per ray      2.0\n");
    CHECK_CONTAINS(buf, "  cells traversed per ray    6.0\n");
}

/* The course's rays per second: rays over the whole seconds printed as total time (0
 * bumped to 1), divided in single precision; the precise rate is for -timings. */
static void test_stats_rays_per_second(void)
{
    char buf[64];
    /* Course line 07: 106,902 rays in 0.07 s print as 106902.0 next to 0:00:01. */
    snprintf(buf, sizeof buf, "%0.1f", stats_course_rays_per_second(106902, 0.074));
    CHECK_STR(buf, "106902.0");
    CHECK_INT(stats_course_seconds(0.074), 1);
    /* 0 seconds measured: the course bumps the delta to 1. */
    snprintf(buf, sizeof buf, "%0.1f", stats_course_rays_per_second(106902, 0.0));
    CHECK_STR(buf, "106902.0");
    CHECK_INT(stats_course_seconds(0.0), 1);
    /* 2.9 s is 2 whole seconds. */
    snprintf(buf, sizeof buf, "%0.1f", stats_course_rays_per_second(106902, 2.9));
    CHECK_STR(buf, "53451.0");
    CHECK_INT(stats_course_seconds(2.9), 2);
    /* Single precision: 123456789 becomes 123456792.0f, and 123456792 / 7 =
     * 17636684.57 rounds to the float 17636684 (floats are 2 apart there); a double
     * division would print 17636684.1. */
    snprintf(buf, sizeof buf, "%0.1f", stats_course_rays_per_second(123456789, 7.5));
    CHECK_STR(buf, "17636684.0");
    /* Hours: 150 rays in 3725 s. */
    snprintf(buf, sizeof buf, "%0.1f", stats_course_rays_per_second(150, 3725.5));
    CHECK_STR(buf, "0.0");
    /* Out-of-range times stay in range. */
    CHECK_INT(stats_course_seconds(-3.0), 1);
    CHECK_INT(stats_course_seconds((double)NAN), 1);
    /* The precise rate. */
    snprintf(buf, sizeof buf, "%0.1f", stats_rays_per_second(106902, 0.5));
    CHECK_STR(buf, "213804.0");
    snprintf(buf, sizeof buf, "%0.1f", stats_rays_per_second(106902, 0.0));
    CHECK_STR(buf, "0.0");

    /* In the block: line 07's counts, under and over a second. */
    char block[4096] = "";
    FILE *f = fmemopen(block, sizeof block, "w");
    StatsReport r = {200, 200, NULL, 40, 40, 33, 0.074, {40000, 66902, 2253921, 1060169, 0, 0}};
    stats_print(f, &r);
    fclose(f);
    CHECK_CONTAINS(block, "  total time                 0:00:01\n");
    CHECK_CONTAINS(block, "  rays per second            106902.0\n");
    f = fmemopen(block, sizeof block, "w");
    r.elapsed_seconds = 2.9;
    stats_print(f, &r);
    fclose(f);
    CHECK_CONTAINS(block, "  total time                 0:00:02\n");
    CHECK_CONTAINS(block, "  rays per second            53451.0\n");
}

/* -h lists every codec of the table under -format (with its extensions) and every
 * registered accelerator under -accel: what bash completion reads. */
static void test_usage_lists_tables(void)
{
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    CHECK(f != NULL);
    if (!f)
        return;
    options_usage(f);
    fclose(f);
    const char *fmt = strstr(text, "  -format name"), *acc = strstr(text, "  -accel name");
    CHECK(fmt && acc);
    char row[128];
    const ImageCodec *c;
    int n = 0;
    for (int i = 0; (c = image_codec_at(i)) != NULL; i++, n++) {
        snprintf(row, sizeof row, "\n      %-20s %s", c->name, c->extensions[0]);
        const char *at = strstr(text, row);
        CHECK_MSG(at && fmt && at > fmt && at < strstr(fmt + 1, "\n  -"),
                  "format %s not listed under -format", c->name);
    }
    CHECK(n >= 3);
    for (int i = 0; accel_registry[i]; i++) {
        snprintf(row, sizeof row, "\n      %-20s %s\n", accel_registry[i]->name,
                 accel_registry[i]->summary);
        const char *at = strstr(text, row);
        CHECK_MSG(at && acc && at > acc, "accelerator %s not listed under -accel",
                  accel_registry[i]->name);
    }
    free(text);
}

/* -h fits a terminal of 80 columns: every line at most 79 characters (16 lines were
 * 81-97 wide and wrapped, among them the accelerators' summaries, which the registry
 * supplies), the codec rows with "(not built in)" included. */
static void test_usage_fits_80_columns(void)
{
    char *text = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&text, &len);
    CHECK(f != NULL);
    if (!f)
        return;
    options_usage(f);
    fclose(f);
    int lines = 0;
    for (const char *p = text; *p; lines++) {
        size_t n = strcspn(p, "\n");
        CHECK_MSG(n <= 79, "-h line of %zu characters: '%.*s'", n, (int)n, p);
        p += n + (p[n] == '\n');
    }
    CHECK(lines > 50);
    char row[128];
    const ImageCodec *c;
    for (int i = 0; (c = image_codec_at(i)) != NULL; i++) {
        /* the row of a codec left out of the build, as -h would print it */
        int n = snprintf(row, sizeof row, "      %-20s", c->name);
        for (const char *const *e = c->extensions; *e; e++)
            n += snprintf(row + n, sizeof row - (size_t)n, " %s", *e);
        n += snprintf(row + n, sizeof row - (size_t)n, " (not built in)");
        CHECK_MSG(n <= 79, "-h row '%s' is %d characters", row, n);
    }
    free(text);
}

static const TestCase tests[] = {
    {"options: a full course command line", test_course_line},
    {"options: defaults, repeats, -grid auto, -h", test_defaults_and_repeats},
    {"options: usage errors say why", test_usage_errors},
    {"options: an empty value is a usage error", test_empty_values},
    {"options: -h lists the codec table and the accelerator registry", test_usage_lists_tables},
    {"options: -h fits 80 columns", test_usage_fits_80_columns},
    {"stats: the course block, label for label", test_stats_block},
    {"stats: rays per second, the course's formula", test_stats_rays_per_second},
};
RT_TEST_MAIN(tests)
