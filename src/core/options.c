/* Command-line parsing (README.txt lists the options): one pass over argv, each flag
 * followed by its fixed number of arguments; the later of two occurrences wins, like the
 * course loop. Unlike the course (atoi/atof, assert), every value is validated. */
#include "rt/options.h"
#include "rt/cpu.h"
#include "rt/diag.h"
#include "rt/filter.h"
#include "rt/sampler.h"
#include "rt/accel.h"
#include "rt/file.h"
#include "rt/image.h"
#include "rt/suggest.h"

#include <ctype.h>
#include <errno.h>
#include <float.h>
#include <limits.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

enum {
    MAX_IMAGE_SIDE = 32768,
    MAX_GRID_SIDE = 2048,
    MAX_BOUNCES = 1000,
    MAX_THREADS = 1024,
    MAX_TESSELLATION = 10000,
    MAX_ZOOM = 100,
    MAX_PICTURE = 16 * 1024 * 1024
};

void options_defaults(Options *o)
{
    memset(o, 0, sizeof *o);
    o->width = 100; /* the course sample code's default */
    o->height = 100;
    o->depth_min = 0.0f;
    o->depth_max = 1.0f;
    o->tess_theta = 20;
    o->tess_phi = 10;
    o->isa = CPU_ISA_AVX512; /* the widest; the CPU caps it */
}

/* The one list of options: -h prints it, and "did you mean", the extra-value message,
 * the man page test and the bash completion all read the option names from it (an
 * option line starts with two blanks and a dash; the names before the first double
 * blank are its synopsis). A new option needs only its line here. */
static const char usage_text[] =
        "usage: raytracer -input scene.txt [options]\n"
        "       raytracer -merge out part...\n"
        "\n"
        "Input and output\n"
        "  -input file              the scene file (required; - reads standard input)\n"
        "  -output file             shaded image, in the format its extension names\n"
        "                           (see -format); - writes standard output, /dev/null\n"
        "                           discards it (timing a render)\n"
        "  -format name             the format of an image written to standard output\n"
        "                           (default tga); the formats and their extensions:\n"
        "  -size w h                image size in pixels (default 100 100)\n"
        "  -depth dmin dmax file    depth image: dmin white, dmax black, linear between\n"
        "                           (dmin != dmax; dmin > dmax: near black, far white)\n"
        "  -normals file            normal image: |nx| |ny| |nz| as RGB\n"
        "  -stats                   print the RAY TRACING STATISTICS block on stdout\n"
        "                           (traces rays one by one to count them: up to 4x\n"
        "                           slower)\n"
        "  -timings                 print parse/build/render/write times on stderr\n"
        "  -progress                show the progress line even when stderr is not a\n"
        "                           terminal (there as whole lines: at most one per 5%\n"
        "                           and 30 s)\n"
        "  -quiet                   no progress line and no hints on stderr\n"
        "Shading\n"
        "  -shadows                 cast shadow rays toward every light\n"
        "  -shade_back              shade back faces (flipped normal); else they are\n"
        "                           black\n"
        "  -bounces n               maximum reflection/refraction depth (default 0)\n"
        "  -weight w                do not trace secondary rays weighing less than w\n"
        "                           (default 0)\n"
        "  -noise_cutoff            Noise/Marble/Wood: leave out the noise octaves finer\n"
        "                           than a pixel (distant textures stop shimmering)\n"
        "Acceleration\n"
        "  -grid nx ny nz           uniform grid of nx*ny*nz cells; every ray marches it\n"
        "  -grid auto               grid resolution chosen from the scene\n"
        "  -visualize_grid          render the occupied grid cells instead of the scene\n"
        "                           (needs -grid)\n"
        "  -visualize_grid_count    same as -visualize_grid (cells coloured by count)\n"
        "  -no_marking              grid: test an object again in every cell (analysis)\n"
        "  -no_packets              grid: march every ray on its own, no ray packets\n"
        "  -isa name                widest instruction set used: base, avx2 or avx512\n"
        "                           (default: the CPU's widest; the same images)\n"
        "  -accel name              accelerator by name (-accel grid: -grid auto):\n"
        "  -threads n               render threads (default: all cores)\n"
        "Antialiasing (one centred sample and a box filter of radius 0.5 by default)\n"
        "  -uniform_samples n       n = k*k samples per pixel on a regular k x k grid\n"
        "                           (1..1024)\n"
        "  -jittered_samples n      n = k*k samples, one at random in each cell of a\n"
        "                           k x k grid (1..1024)\n"
        "  -random_samples n        n samples per pixel at random positions (1..1024)\n"
        "  -nrooks_samples n        n samples, one in each row and each column of an\n"
        "                           n x n grid (1..1024)\n"
        "  -poisson_samples n       n samples kept apart (best candidate of 8; n <= 256)\n"
        "  -adaptive_samples a b t  a = k*k jittered samples; pixels whose samples\n"
        "                           differ by more than t (0..1, any channel) get\n"
        "                           b = m*m instead (a 4..1024, b > a)\n"
        "  -box_filter r            box filter of half-width r pixels (0 < r <= 16)\n"
        "  -tent_filter r           tent (cone) filter of radius r (0 < r <= 16)\n"
        "  -gaussian_filter s       Gaussian filter, standard deviation s (0 < s <= 16)\n"
        "  -mitchell_filter r       Mitchell-Netravali cubic, B = C = 1/3, radius r\n"
        "                           (0 < r <= 16)\n"
        "  -render_samples file z   also write the sample positions, zoomed z times\n"
        "                           (1..100)\n"
        "  -render_filter file z    also write the filter weights, zoomed z times\n"
        "                           (2..100); alone, it needs no -input (not read)\n"
        "  -seed n                  seed of the random samplers (default 0)\n"
        "Splitting a render (README.txt, 8)\n"
        "  -region x y w h          render only the w x h rectangle at (x, y) (top-left)\n"
        "  -tile k n                render only band k (0 = top) of n horizontal bands;\n"
        "                           n as CxR: tile k of C columns x R rows (row by row)\n"
        "  -merge out part...       (first option) assemble -region/-tile parts into out\n"
        "                           (under mpirun only rank 0 merges)\n"
        "  -cache file              set-up cache: the first process writes the parsed\n"
        "                           meshes and the grid to file, the others read them\n"
        "                           (same image)\n"
        "OpenGL preview (when built)\n"
        "  -gui                     open the interactive preview window\n"
        "  -tessellation theta phi  sphere tessellation of the preview (default 20 10)\n"
        "  -gouraud                 smooth sphere shading in the preview\n"
        "  -gui_snapshot file       draw one preview frame offscreen (OSMesa) into file\n"
        "  -gui_keys script         key commands for the preview to run first, in one\n"
        "                           argument (\"r t:100,100 q\"; README.txt, 7)\n"
        "Other\n"
        "  -h, --help               this text\n"
        "  --version                version and optional features\n"
        "\n"
        "Exit status: 0 image(s) written, 1 input or output error, 2 usage error,\n"
        "130 interrupted (Ctrl-C; 143 for SIGTERM, 129 for SIGHUP).\n";

/* Writes usage_text from *pos to the end of the line holding marker, and moves *pos
 * there; false (nothing written) when marker is not in the rest of the text. */
static bool usage_through(FILE *out, const char **pos, const char *marker)
{
    const char *at = strstr(*pos, marker);
    const char *eol = at ? strchr(at, '\n') : NULL;
    if (!eol)
        return false;
    fwrite(*pos, 1, (size_t)(eol + 1 - *pos), out);
    *pos = eol + 1;
    return true;
}

void options_usage(FILE *out)
{
    /* The image formats are listed from the codec table under -format, the
     * accelerators from their registry under -accel (bash completion reads both). */
    const char *pos = usage_text;
    /* The synopsis names the binary the user ran (raytracer-mpi takes the same options). */
    static const char synopsis[] = "usage: raytracer ", merge[] = "       raytracer ";
    if (strncmp(pos, synopsis, sizeof synopsis - 1) == 0) {
        fprintf(out, "usage: %s ", diag_program());
        pos += sizeof synopsis - 1;
        /* the second form, -merge, under the same name */
        const char *eol = strchr(pos, '\n');
        if (eol && strncmp(eol + 1, merge, sizeof merge - 1) == 0) {
            fwrite(pos, 1, (size_t)(eol + 1 - pos), out);
            fprintf(out, "       %s ", diag_program());
            pos = eol + 1 + sizeof merge - 1;
        }
    }
    if (usage_through(out, &pos, "the formats and their extensions:")) {
        const ImageCodec *c;
        for (int i = 0; (c = image_codec_at(i)) != NULL; i++) {
            fprintf(out, "      %-20s", c->name);
            for (const char *const *e = c->extensions; *e; e++)
                fprintf(out, " %s", *e);
            fputs(c->encode ? "\n" : " (not built in)\n", out);
        }
    }
    if (usage_through(out, &pos, "  -accel name"))
        for (int i = 0; accel_registry[i]; i++)
            fprintf(out, "      %-20s %s\n", accel_registry[i]->name,
                    accel_registry[i]->summary);
    fputs(pos, out);
}

typedef struct Cursor {
    int argc, i;
    char **argv;
    FILE *err;
    int opt, prev;   /* where the current and the previous option began (0: none) */
    bool hinted;     /* the message already says what to do: no "-h for help" */
} Cursor;

enum { MAX_OPTION_NAMES = 256 };

/* The option names of usage_text, in order ("-h" and "--help" both). */
int options_names(const char **names, int max)
{
    static char store[sizeof usage_text];
    static const char *found[MAX_OPTION_NAMES];
    static int count = -1;
    if (count < 0) {
        count = 0;
        size_t used = 0;
        for (const char *line = usage_text; *line;) {
            const char *eol = strchr(line, '\n');
            if (!eol)
                eol = line + strlen(line);
            const char *p = line;
            if (p[0] == ' ' && p[1] == ' ' && p[2] == '-') {
                p += 2;
                /* "-h, --help   ..." lists two names; a synopsis ends at two blanks. */
                while (*p == '-' && count < MAX_OPTION_NAMES) {
                    size_t n = strcspn(p, " ,\n");
                    memcpy(store + used, p, n);
                    store[used + n] = '\0';
                    bool seen = false; /* -grid has two lines */
                    for (int k = 0; k < count && !seen; k++)
                        seen = !strcmp(found[k], store + used);
                    if (!seen) {
                        found[count++] = store + used;
                        used += n + 1;
                    }
                    p += n;
                    if (p[0] == ',' && p[1] == ' ')
                        p += 2;
                    else
                        break;
                }
            }
            line = *eol ? eol + 1 : eol;
        }
    }
    int n = count < max ? count : max;
    for (int i = 0; i < n; i++)
        names[i] = found[i];
    return count;
}

/* The synopsis of option name from usage_text ("-size w h"), into buf; "" if none. An
 * option with two forms (-grid nx ny nz, -grid auto) gives the one of values value
 * words when there is one, else its first; values < 0 asks for the first. */
static void option_synopsis_of(const char *name, int values, char *buf, size_t size)
{
    size_t len = strlen(name);
    buf[0] = '\0';
    for (const char *line = usage_text; *line;) {
        const char *eol = strchr(line, '\n');
        if (!eol)
            eol = line + strlen(line);
        if (!strncmp(line, "  ", 2) && !strncmp(line + 2, name, len) &&
            (line[2 + len] == ' ' || line[2 + len] == ',')) {
            const char *start = line + 2, *end = strstr(start, "  ");
            if (!end || end > eol)
                end = eol;
            int words = 0;
            for (const char *p = start; p < end; words++) {
                p += strcspn(p, " ");
                p += strspn(p, " ");
            }
            bool fits = values < 0 || words - 1 == values;
            if (fits || !buf[0])
                snprintf(buf, size, "%.*s", (int)(end - start), start);
            if (fits)
                return;
        }
        line = *eol ? eol + 1 : eol;
    }
}

static void option_synopsis(const char *name, char *buf, size_t size)
{
    option_synopsis_of(name, -1, buf, size);
}

static bool usage_error(Cursor *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

static bool usage_error(Cursor *c, const char *fmt, ...)
{
    va_list ap;
    fprintf(c->err, "%s: ", diag_program());
    va_start(ap, fmt);
    vfprintf(c->err, fmt, ap);
    va_end(ap);
    if (c->hinted)
        fputs("\n", c->err);
    else
        fprintf(c->err, " (%s -h for help)\n", diag_program());
    return false;
}

static bool is_option_name(const char *a);

/* The name the usage text gives the value just taken (argv[c->i]) of option flag:
 * "h" for the second value of "-size w h"; "value" when the synopsis has none. */
static void value_name(const Cursor *c, const char *flag, char *buf, size_t size)
{
    char synopsis[128];
    option_synopsis(flag, synopsis, sizeof synopsis);
    const char *p = synopsis;
    for (int k = 0; k <= c->i - c->opt && *p; k++) { /* word 0 is the option itself */
        p += strspn(p, " ");
        if (k == c->i - c->opt) {
            size_t n = strcspn(p, " ");
            snprintf(buf, size, "%.*s", (int)n, p);
            if (n > 0)
                return;
        }
        p += strcspn(p, " ");
    }
    snprintf(buf, size, "value");
}

static bool take(Cursor *c, const char *flag, const char **out)
{
    char synopsis[128];
    if (c->i + 1 >= c->argc) {
        /* Name the value that is missing ("-size 200": h), as the range errors do. */
        Cursor next = *c;
        next.i++;
        char name[32];
        value_name(&next, flag, name, sizeof name);
        option_synopsis(flag, synopsis, sizeof synopsis);
        return usage_error(c, "missing value for %s: the command line ends before %s%s%s%s",
                           flag, name, synopsis[0] ? " (" : "", synopsis,
                           synopsis[0] ? ")" : "");
    }
    /* "-output -size 10 10": the value was left out and the next option taken for it.
     * Only an exact option name is refused: "-" (standard input or output) and
     * negative numbers are values. */
    if (is_option_name(c->argv[c->i + 1])) {
        option_synopsis(flag, synopsis, sizeof synopsis);
        return usage_error(c, "missing value for %s: the next argument '%s' is an option%s%s%s",
                           flag, c->argv[c->i + 1], synopsis[0] ? " (" : "", synopsis,
                           synopsis[0] ? ")" : "");
    }
    /* An empty value (-output "$OUT" with OUT unset) names nothing: said here, not as
     * an error about a file without a name (": error: ..."). A key script may be empty. */
    if (!c->argv[c->i + 1][0] && strcmp(flag, "-gui_keys") != 0) {
        option_synopsis(flag, synopsis, sizeof synopsis);
        return usage_error(c, "option %s: the value is empty%s%s%s", flag,
                           synopsis[0] ? " (" : "", synopsis, synopsis[0] ? ")" : "");
    }
    *out = c->argv[++c->i];
    return true;
}

/* How many whole numbers s holds when it is two or more of them joined by 'x', 'X',
 * '*' or ',' ("200x150", "10,10,10"), with those numbers written apart by blanks into
 * buf ("200 150"); 0 for anything else. */
static int numbers_run_together(const char *s, char *buf, size_t size)
{
    int count = 0;
    size_t n = 0;
    buf[0] = '\0';
    for (const char *p = s;;) {
        size_t digits = strspn(p, "0123456789");
        if (digits == 0 || digits > 10 || n + digits + 2 > size)
            return 0;
        n += (size_t)snprintf(buf + n, size - n, "%s%.*s", count ? " " : "", (int)digits, p);
        count++;
        p += digits;
        if (*p == '\0')
            return count > 1 ? count : 0;
        if (!strchr("xX*,", *p))
            return 0;
        p++;
    }
}

static bool take_int(Cursor *c, const char *flag, int lo, int hi, int *out)
{
    const char *s = NULL;
    if (!take(c, flag, &s))
        return false;
    char name[32];
    value_name(c, flag, name, sizeof name);
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (end == s || *end != '\0' || errno == ERANGE) {
        /* "-size 200x150" (how sizes are often written), "-grid 10,10,10": all of the
         * option's values in its first argument. Say how to write them. */
        char synopsis[128], apart[64];
        option_synopsis(flag, synopsis, sizeof synopsis);
        int values = -1; /* the synopsis' words after the option's name */
        for (const char *p = synopsis; *p; values++) {
            p += strcspn(p, " ");
            p += strspn(p, " ");
        }
        if (c->i - c->opt == 1 && values > 1 &&
            numbers_run_together(s, apart, sizeof apart) == values) {
            c->hinted = true;
            return usage_error(c, "option %s: %s expects an integer, got '%s' (the %d values "
                               "are separate arguments: %s %s)", flag, name, s, values, flag,
                               apart);
        }
        return usage_error(c, "option %s: %s expects an integer, got '%s'", flag, name, s);
    }
    if (v < lo || v > hi)
        return usage_error(c, "option %s: %s = %ld is out of range %d..%d", flag, name, v, lo,
                           hi);
    *out = (int)v;
    return true;
}

/* The n of -tile k n: a count of bands ("8"), or columns x rows of a grid of tiles
 * ("8x8", numbered row by row from the top left). Sets tile_n (all tiles) and tile_cols
 * (1 for bands). */
static bool parse_tile_count(Cursor *c, const char *s, Options *o)
{
    char *end;
    errno = 0;
    long cols = 1, rows = strtol(s, &end, 10);
    if (end != s && *end == 'x' && errno != ERANGE) {
        cols = rows;
        const char *r = end + 1;
        rows = strtol(r, &end, 10);
        if (end == r || !isdigit((unsigned char)*r))
            end = (char *)s; /* "8x" or "8x-1": not a grid */
    }
    if (end == s || *end != '\0' || errno == ERANGE || !isdigit((unsigned char)s[0]))
        return usage_error(c, "option -tile: n expects an integer or columns x rows (8 or "
                           "8x8), got '%s'", s);
    if (!strchr(s, 'x') && (rows < 1 || rows > MAX_IMAGE_SIDE))
        return usage_error(c, "option -tile: n = %ld is out of range 1..%d", rows,
                           MAX_IMAGE_SIDE);
    if (cols < 1 || rows < 1 || cols > MAX_IMAGE_SIDE || rows > MAX_IMAGE_SIDE)
        return usage_error(c, "option -tile: n = %s: columns and rows must be in 1..%d", s,
                           MAX_IMAGE_SIDE);
    o->tile_cols = (int)cols;
    o->tile_n = (int)(cols * rows);
    return true;
}

static bool take_float(Cursor *c, const char *flag, float *out)
{
    const char *s = NULL;
    if (!take(c, flag, &s))
        return false;
    char name[32];
    value_name(c, flag, name, sizeof name);
    char *end;
    errno = 0;
    float v = strtof(s, &end);
    /* An overflow: '1e40' is a finite number, only too large for a float (as for an
     * underflow, below, 'expects a finite number' would send the user after a typo). */
    if (end != s && *end == '\0' && errno == ERANGE && isinf(v))
        return usage_error(c, "option %s: %s = %s is too large in size for a float (the "
                           "largest is about %g)", flag, name, s, (double)FLT_MAX);
    if (end == s || *end != '\0' || !isfinite(v))
        return usage_error(c, "option %s: %s expects a finite number, got '%s'", flag, name, s);
    /* ERANGE with a finite result is an underflow: '1e-40' is a finite number, and
     * "expects a finite number" sent the user looking for a typo. */
    if (errno == ERANGE)
        return usage_error(c, "option %s: %s = %s is too close to 0 for a float (the smallest "
                           "is about %g)", flag, name, s, (double)FLT_MIN);
    *out = v;
    return true;
}

/* The folder part of path resolved (symbolic links, "." and ".."), then its last
 * component: two spellings of one file compare equal even before the file exists. */
static char *canonical_name(const char *path)
{
    const char *slash = strrchr(path, '/');
    const char *base = slash ? slash + 1 : path;
    char *dir = slash ? strndup(path, (size_t)(slash - path) + 1) : strdup(".");
    char *real = dir ? realpath(dir, NULL) : NULL;
    free(dir);
    if (!real)
        return NULL;
    size_t n = strlen(real) + strlen(base) + 2;
    char *out = malloc(n);
    if (out)
        snprintf(out, n, "%s/%s", real, base);
    free(real);
    return out;
}

/* True when a and b name one file: the same text, the same existing file, or the same
 * name in the same folder. Devices and pipes (/dev/null twice) are not refused. */
static bool same_file(const char *a, const char *b)
{
    struct stat sa, sb;
    if (strcmp(a, b) == 0)
        return stat(a, &sa) != 0 || S_ISREG(sa.st_mode);
    if (stat(a, &sa) == 0 && stat(b, &sb) == 0)
        return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino && S_ISREG(sa.st_mode);
    char *ca = canonical_name(a), *cb = canonical_name(b);
    bool same = ca && cb && strcmp(ca, cb) == 0;
    free(ca);
    free(cb);
    return same;
}

static bool looks_like_number(const char *s)
{
    char *end;
    errno = 0;
    (void)strtod(s, &end);
    return end != s && *end == '\0';
}

static bool looks_like_scene(const char *s)
{
    size_t n = strlen(s);
    struct stat st;
    return (n > 4 && !strcmp(s + n - 4, ".txt")) || (stat(s, &st) == 0 && S_ISREG(st.st_mode));
}

static bool is_option_name(const char *a);

/* argv[c->opt] is no option: say what it probably is. */
static bool unknown_argument(Cursor *c, const Options *o)
{
    const char *a = c->argv[c->opt];
    /* "input scene.txt", "-size 8 8 shadows": a word that is an option without its dash
     * was meant as that option, more likely than as a stray or extra value. */
    char dashed[64];
    if (a[0] != '-' && strlen(a) < sizeof dashed - 1) {
        snprintf(dashed, sizeof dashed, "-%s", a);
        if (is_option_name(dashed)) {
            c->hinted = true;
            return usage_error(c, "unexpected argument '%s' (did you mean %s?)", a, dashed);
        }
    }
    if (a[0] == '-' && a[1] != '\0' && !looks_like_number(a)) {
        const char *names[MAX_OPTION_NAMES];
        int n = options_names(names, MAX_OPTION_NAMES);
        char hint[256];
        suggest_format(hint, sizeof hint, a, names, (size_t)(n < MAX_OPTION_NAMES ? n : MAX_OPTION_NAMES));
        c->hinted = hint[0] != '\0';
        return usage_error(c, "unknown option '%s'%s", a, hint);
    }
    int values = c->prev > 0 ? c->opt - c->prev - 1 : 0;
    if (values > 0) {
        char synopsis[128], given[256];
        /* "-grid auto 3": the form that was given, -grid auto, not -grid nx ny nz. */
        option_synopsis_of(c->argv[c->prev], values, synopsis, sizeof synopsis);
        size_t used = (size_t)snprintf(given, sizeof given, "%s", c->argv[c->prev]);
        for (int k = c->prev + 1; k < c->opt && used < sizeof given; k++)
            used += (size_t)snprintf(given + used, sizeof given - used, " %s", c->argv[k]);
        return usage_error(c, "extra value '%s' after '%s': %s takes %d value%s (%s)", a,
                           given, c->argv[c->prev], values, values == 1 ? "" : "s",
                           synopsis[0] ? synopsis : c->argv[c->prev]);
    }
    c->hinted = true;
    if (!o->input && looks_like_scene(a))
        return usage_error(c, "unexpected argument '%s' (did you mean -input %s?)", a, a);
    return usage_error(c, "unexpected argument '%s': options start with '-'", a);
}

/* True when a is exactly the name of an option of the usage text. */
static bool is_option_name(const char *a)
{
    const char *names[MAX_OPTION_NAMES];
    int n = options_names(names, MAX_OPTION_NAMES);
    for (int k = 0; k < n && k < MAX_OPTION_NAMES; k++)
        if (!strcmp(a, names[k]))
            return true;
    return false;
}

/* Option flag (a sampler or a filter) takes the place of *current; a different one
 * already there is remembered in *replaced for options_warn. */
static void replaced_by(const char **current, const char **replaced, const char *flag)
{
    if (*current && strcmp(*current, flag) != 0)
        *replaced = *current;
    *current = flag;
}

/* A format this build knows but does not write (PNG without libpng, or PNG=0), named by
 * "-format png" or by a file's extension ("-output x.png"): one user error, so one
 * usage error (exit 2, before any work) for both, saying why and what it writes. */
static bool format_not_built_in(Cursor *c, const char *flag, const char *value,
                                const ImageCodec *codec)
{
    char name[16], list[128];
    size_t i = 0;
    for (; codec->name[i] && i + 1 < sizeof name; i++)
        name[i] = (char)toupper((unsigned char)codec->name[i]);
    name[i] = '\0';
    image_format_list(list, sizeof list);
    c->hinted = true; /* the message says what to do: no "-h for help" */
    return usage_error(c, "option %s %s: %s output is not built in: %s, or write one of %s",
                       flag, value, name, codec->missing ? codec->missing : "rebuild with it",
                       list);
}

/* An image file's name must end in a format's extension (the file's format) that this
 * build writes: a name that does not is refused here, as a usage error before any
 * work, naming the extensions this build writes. "-" (standard output, -format's) and
 * the null device (-output /dev/null: render, keep nothing) pass, and so does a
 * folder: image_check_output says "it is a folder", the better message. */
static bool check_image_name(Cursor *c, const char *flag, const char *path)
{
    struct stat st;
    const ImageCodec *codec = path ? image_codec_for_path(path) : NULL;
    if (codec && !codec->encode)
        return format_not_built_in(c, flag, path, codec);
    if (!path || !strcmp(path, IMAGE_STDOUT) || codec || image_is_null_device(path) ||
        (stat(path, &st) == 0 && S_ISDIR(st.st_mode)))
        return true;
    char list[128];
    c->hinted = true;
    /* -output /dev/stdout (or /dev/fd/1, a named pipe): asked to add an extension, a
     * user wrote /dev/stdout.tga, a new file in /dev. Standard output is "-". A name
     * in /dev or /proc counts whatever it leads to (/dev/stdout can be a file). */
    if (!strncmp(path, "/dev/", 5) || !strncmp(path, "/proc/", 6) ||
        (stat(path, &st) == 0 &&
         (S_ISCHR(st.st_mode) || S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode)))) {
        bool merge = !strcmp(flag, "-merge");
        image_format_names(list, sizeof list);
        return usage_error(c, "option %s: unknown image format '%s': a device or a pipe has "
                           "no extension to give one; for standard output give - as the file "
                           "name%s%s%s",
                           flag, path, merge ? "" : ", and -format for its format (",
                           merge ? "" : list, merge ? "" : ")");
    }
    image_format_list(list, sizeof list);
    return usage_error(c, "option %s: unknown image format '%s': the file name must end in "
                       "one of %s", flag, path, list);
}

bool options_check_merge(int argc, char **argv, FILE *err)
{
    Cursor c = {argc, 1, argv, err, 1, 0, false};
    /* Option names first: "-merge out.tga a.tga -size 10 10" would otherwise read a
     * part named -size. */
    for (int i = 2; i < argc; i++)
        if (is_option_name(argv[i]))
            return usage_error(&c, "-merge takes only the output and the parts, not %s (give "
                               "the render options to the renders of the parts)", argv[i]);
    if (argc < 4)
        return usage_error(&c, "usage: %s -merge out.tga part...", diag_program());
    const char *out = argv[2];
    if (!check_image_name(&c, "-merge", out))
        return false;
    for (int i = 3; i < argc; i++)
        if (!strcmp(argv[i], out) || file_same(argv[i], out)) {
            c.hinted = true;
            return usage_error(&c, "-merge: the output '%s' is also listed as a part%s%s%s "
                               "(write the merged image to another file)", out,
                               strcmp(argv[i], out) ? " ('" : "",
                               strcmp(argv[i], out) ? argv[i] : "",
                               strcmp(argv[i], out) ? "')" : "");
        }
    for (int i = 3; i < argc; i++)
        for (int j = i + 1; j < argc; j++)
            if (!strcmp(argv[i], argv[j]) || file_same(argv[i], argv[j])) {
                c.hinted = true;
                if (!strcmp(argv[i], argv[j]))
                    return usage_error(&c, "-merge: the part '%s' is listed twice", argv[i]);
                return usage_error(&c, "-merge: the part '%s' is listed twice (also as '%s')",
                                   argv[i], argv[j]);
            }
    return true;
}

/* The options that only switch a flag on, with the flag. */
static const struct {
    const char *name;
    size_t offset; /* of the bool in Options */
} k_switches[] = {
    {"-shade_back", offsetof(Options, shade_back)},
    {"-noise_cutoff", offsetof(Options, noise_cutoff)},
    {"-shadows", offsetof(Options, shadows)},
    {"-stats", offsetof(Options, stats)},
    {"-timings", offsetof(Options, timings)},
    {"-visualize_grid", offsetof(Options, visualize_grid)},
    {"-no_marking", offsetof(Options, no_marking)},
    {"-no_packets", offsetof(Options, no_packets)},
    {"-gui", offsetof(Options, gui)},
    {"-gouraud", offsetof(Options, gouraud)},
};

/* The flag of o that option a switches on; NULL when a is not such an option. */
static bool *switch_of(Options *o, const char *a)
{
    for (size_t k = 0; k < sizeof k_switches / sizeof k_switches[0]; k++)
        if (!strcmp(a, k_switches[k].name))
            return (bool *)((char *)o + k_switches[k].offset);
    return NULL;
}

/* The filter the option a names when a is -NAME_filter for a NAME of the filter table
 * (filter_find), else NULL: every filter there is an option without a line here. */
static const FilterOps *filter_option(const char *a)
{
    static const char suffix[] = "_filter";
    size_t n = strlen(a), k = sizeof suffix - 1;
    char name[32];
    if (a[0] != '-' || n <= k + 1 || n - k - 1 >= sizeof name || strcmp(a + n - k, suffix) != 0)
        return NULL;
    memcpy(name, a + 1, n - k - 1);
    name[n - k - 1] = '\0';
    return filter_find(name);
}

bool options_parse(Options *o, int argc, char **argv, FILE *err)
{
    Cursor c = {argc, 1, argv, err, 0, 0, false};
    bool region_given = false, tile_given = false;
    for (; c.i < argc; c.i++) {
        c.prev = c.opt;
        c.opt = c.i;
        const char *a = argv[c.i];
        const FilterOps *filter_ops = NULL; /* -NAME_filter: the filter it names */
        bool *flag = switch_of(o, a);
        if (flag) {
            *flag = true;
        } else if (!strcmp(a, "-input")) {
            if (!take(&c, a, &o->input))
                return false;
        } else if (!strcmp(a, "-output")) {
            if (!take(&c, a, &o->output))
                return false;
        } else if (!strcmp(a, "-cache")) {
            if (!take(&c, a, &o->cache_file))
                return false;
            /* "-" is standard input or output for -input and the images, but the cache
             * is written and read back by name: "-cache -" made a file named "-". */
            if (!strcmp(o->cache_file, "-"))
                return usage_error(&c, "option -cache: '-' is no file here: the set-up "
                                   "cache is written and read back by name (-cache "
                                   "frame.cache)");
        } else if (!strcmp(a, "-format")) {
            if (!take(&c, a, &o->format))
                return false;
            /* A name in any case, as an extension is (-output X.PNG is a PNG): the
             * codec's own name is kept, so everything after sees "png". */
            const ImageCodec *codec = NULL, *k;
            for (int i = 0; !codec && (k = image_codec_at(i)) != NULL; i++)
                if (!strcasecmp(k->name, o->format))
                    codec = k;
            if (codec && !codec->encode)
                return format_not_built_in(&c, a, o->format, codec);
            if (!codec) {
                char list[128];
                image_format_names(list, sizeof list);
                return usage_error(&c, "option -format: unknown format '%s' (this build "
                                   "writes %s)", o->format, list);
            }
            o->format = codec->name;
        } else if (!strcmp(a, "-size")) {
            if (!take_int(&c, a, 1, MAX_IMAGE_SIDE, &o->width) ||
                !take_int(&c, a, 1, MAX_IMAGE_SIDE, &o->height))
                return false;
        } else if (!strcmp(a, "-depth")) {
            if (!take_float(&c, a, &o->depth_min) || !take_float(&c, a, &o->depth_max) ||
                !take(&c, a, &o->depth_file))
                return false;
            if (o->depth_min == o->depth_max)
                return usage_error(&c, "option -depth: dmin and dmax must differ");
        } else if (!strcmp(a, "-normals")) {
            if (!take(&c, a, &o->normals_file))
                return false;
        } else if (!strcmp(a, "-bounces")) {
            if (!take_int(&c, a, 0, MAX_BOUNCES, &o->bounces))
                return false;
        } else if (!strcmp(a, "-weight")) {
            if (!take_float(&c, a, &o->weight))
                return false;
            if (o->weight < 0.0f)
                return usage_error(&c, "option -weight: w = %g must be >= 0", (double)o->weight);
        } else if (!strcmp(a, "-grid")) {
            o->grid = true;
            if (c.i + 1 < argc && !strcmp(argv[c.i + 1], "auto")) {
                o->grid_auto = true;
                c.i++;
            } else if (c.i + 1 < argc && isalpha((unsigned char)argv[c.i + 1][0]) &&
                       suggest_distance(argv[c.i + 1], "auto") <= 2) {
                /* "Auto", "atuo", "aut": words are case-sensitive, like the scene's
                 * keywords, and a word near auto is no nx */
                c.hinted = true;
                return usage_error(&c, "option -grid: '%s' (did you mean auto?)",
                                   argv[c.i + 1]);
            } else {
                o->grid_auto = false;
                for (int k = 0; k < 3; k++)
                    if (!take_int(&c, a, 1, MAX_GRID_SIDE, &o->grid_n[k]))
                        return false;
                if ((long long)o->grid_n[0] * o->grid_n[1] * o->grid_n[2] > RT_GRID_MAX_CELLS)
                    return usage_error(&c, "option -grid: %lld cells, the limit is %d",
                                       (long long)o->grid_n[0] * o->grid_n[1] * o->grid_n[2],
                                       (int)RT_GRID_MAX_CELLS);
            }
        } else if (!strcmp(a, "-accel")) {
            if (!take(&c, a, &o->accel))
                return false;
            if (!accel_find(o->accel))
                return usage_error(&c, "option -accel: unknown accelerator '%s' (known: %s)",
                                   o->accel, accel_names());
        } else if (!strcmp(a, "-isa")) {
            const char *name;
            if (!take(&c, a, &name))
                return false;
            if (!cpu_isa_find(name, &o->isa))
                return usage_error(&c,
                                   "option -isa: unknown instruction set '%s' (known: base, "
                                   "avx2, avx512)",
                                   name);
            if (o->isa > cpu_isa_best())
                return usage_error(&c, "option -isa: this CPU has no %s (its widest: %s)", name,
                                   cpu_isa_name(cpu_isa_best()));
        } else if (!strcmp(a, "-visualize_grid_count")) {
            o->visualize_grid = true;
            o->visualize_grid_count = true;
        } else if (!strcmp(a, "-tessellation")) {
            if (!take_int(&c, a, 3, MAX_TESSELLATION, &o->tess_theta) ||
                !take_int(&c, a, 2, MAX_TESSELLATION, &o->tess_phi))
                return false;
            o->tessellation_given = true;
        } else if (!strcmp(a, "-gui_snapshot")) {
            if (!take(&c, a, &o->gui_snapshot))
                return false;
        } else if (!strcmp(a, "-gui_keys")) {
            if (!take(&c, a, &o->gui_keys))
                return false;
        } else if (!strcmp(a, "-threads")) {
            if (!take_int(&c, a, 1, MAX_THREADS, &o->threads))
                return false;
        } else if (!strcmp(a, "-uniform_samples") || !strcmp(a, "-jittered_samples") ||
                   !strcmp(a, "-random_samples") || !strcmp(a, "-nrooks_samples") ||
                   !strcmp(a, "-poisson_samples")) {
            static const char *const names[] = {"uniform", "jittered", "random", "nrooks",
                                                "poisson"};
            const char *name = NULL;
            for (int k = 0; k < 5 && !name; k++)
                if (!strncmp(a + 1, names[k], strlen(names[k])))
                    name = names[k];
            if (!take_int(&c, a, INT_MIN, INT_MAX, &o->samples))
                return false;
            Sampler probe;
            char why[160];
            if (!sampler_init(&probe, sampler_find(name), o->samples, 0, why, sizeof why))
                return usage_error(&c, "option %s: %s", a, why);
            o->sampler = name;
            o->adaptive = false;
            replaced_by(&o->sampler_flag, &o->sampler_replaced, a);
        } else if (!strcmp(a, "-adaptive_samples")) {
            if (!take_int(&c, a, INT_MIN, INT_MAX, &o->adaptive_min) ||
                !take_int(&c, a, INT_MIN, INT_MAX, &o->adaptive_max) ||
                !take_float(&c, a, &o->adaptive_threshold))
                return false;
            Sampler probe;
            char why[160];
            if (!sampler_init(&probe, sampler_find("jittered"), o->adaptive_min, 0, why,
                              sizeof why) ||
                !sampler_init(&probe, sampler_find("jittered"), o->adaptive_max, 0, why,
                              sizeof why))
                return usage_error(&c, "option %s: %s", a, why);
            /* The refinement is decided by the spread of a pixel's first samples: one
             * sample has none, so no pixel would ever get b and the render would be
             * -jittered_samples 1 in silence. */
            if (o->adaptive_min == 1)
                return usage_error(&c, "option %s: a = 1: one first sample cannot differ "
                                   "from itself, so no pixel would get b; a must be 4 or "
                                   "more (2 x 2)", a);
            if (o->adaptive_max <= o->adaptive_min)
                return usage_error(&c, "option %s: the second count (%d) must be larger than "
                                   "the first (%d)", a, o->adaptive_max, o->adaptive_min);
            if (!(o->adaptive_threshold >= 0.0f && o->adaptive_threshold <= 1.0f))
                return usage_error(&c, "option %s: t = %g is out of range 0..1 (a difference "
                                   "of colour channels)", a, (double)o->adaptive_threshold);
            o->adaptive = true;
            o->sampler = NULL;
            replaced_by(&o->sampler_flag, &o->sampler_replaced, a);
        } else if ((filter_ops = filter_option(a)) != NULL) {
            const FilterOps *ops = filter_ops;
            if (!take_float(&c, a, &o->filter_param))
                return false;
            /* The range as the other options word it, with the value as typed: the
             * float it became printed "sigma 16 is out of range (0, 16]" for 16.000001. */
            if (!(o->filter_param > 0.0f && o->filter_param <= FILTER_MAX_RADIUS)) {
                char vname[32];
                value_name(&c, a, vname, sizeof vname);
                return usage_error(&c, "option %s: %s = %s is out of range (0, %g]", a, vname,
                                   c.argv[c.i], (double)FILTER_MAX_RADIUS);
            }
            Filter probe;
            char why[160];
            if (!filter_init(&probe, ops, o->filter_param, why, sizeof why))
                return usage_error(&c, "option %s: %s", a, why);
            o->filter = ops->name;
            replaced_by(&o->filter_flag, &o->filter_replaced, a);
        } else if (!strcmp(a, "-render_samples")) {
            if (!take(&c, a, &o->samples_file) ||
                !take_int(&c, a, 1, MAX_ZOOM, &o->samples_zoom))
                return false;
        } else if (!strcmp(a, "-render_filter")) {
            if (!take(&c, a, &o->filter_file) || !take_int(&c, a, 1, MAX_ZOOM, &o->filter_zoom))
                return false;
            /* The picture's grid lines are every z-th row and column, drawn over the
             * weights (the course's rule): with z = 1 they cover every pixel, and the
             * file was one blue rectangle showing no weight at all. */
            if (o->filter_zoom == 1)
                return usage_error(&c, "option -render_filter: z = 1 draws only the pixel "
                                   "grid (its lines cover every pixel of the picture); z "
                                   "must be 2 or more");
        } else if (!strcmp(a, "-seed")) {
            const char *v = NULL;
            if (!take(&c, a, &v))
                return false;
            char *end;
            errno = 0;
            unsigned long long n = strtoull(v, &end, 10);
            if (end == v || *end != '\0' || errno == ERANGE || strchr(v, '-'))
                return usage_error(&c, "option -seed expects an integer 0..%llu, got '%s'",
                                   (unsigned long long)ULLONG_MAX, v);
            o->seed = n;
            o->seed_given = true;
        } else if (!strcmp(a, "-region")) {
            if (!take_int(&c, a, 0, MAX_IMAGE_SIDE - 1, &o->region_x) ||
                !take_int(&c, a, 0, MAX_IMAGE_SIDE - 1, &o->region_y) ||
                !take_int(&c, a, 1, MAX_IMAGE_SIDE, &o->region_w) ||
                !take_int(&c, a, 1, MAX_IMAGE_SIDE, &o->region_h))
                return false;
            o->region = true;
            o->tile = false;
            region_given = true;
        } else if (!strcmp(a, "-tile")) {
            const char *n = NULL;
            if (!take_int(&c, a, 0, MAX_IMAGE_SIDE * MAX_IMAGE_SIDE - 1, &o->tile_k) ||
                !take(&c, a, &n) || !parse_tile_count(&c, n, o))
                return false;
            if (o->tile_k >= o->tile_n)
                return usage_error(&c, "option -tile k n: k must be below n (0-based), got %d %s",
                                   o->tile_k, n);
            o->tile = true;
            o->region = false;
            tile_given = true;
        } else if (!strcmp(a, "-merge")) {
            return usage_error(&c, "-merge must come first: %s -merge out.tga part...",
                               diag_program());
        } else if (!strcmp(a, "-h") || !strcmp(a, "--help") || !strcmp(a, "-help")) {
            o->help = true;
        } else if (!strcmp(a, "--version") || !strcmp(a, "-version")) {
            o->version = true;
        } else if (!strcmp(a, "-progress")) {
            o->progress = PROGRESS_ALWAYS;
        } else if (!strcmp(a, "-quiet")) {
            o->progress = PROGRESS_NEVER;
            o->quiet = true;
        } else {
            return unknown_argument(&c, o);
        }
    }
    if (o->help || o->version)
        return true;
    if (!o->input && options_needs_scene(o))
        return usage_error(&c, "no scene given: -input scene.txt is required");
    /* Both choose the rectangle; "the later wins" would silently drop one of them. */
    if (region_given && tile_given)
        return usage_error(&c, "-region and -tile both choose the rectangle to render: give "
                           "one of them");
    /* The zoomed pictures are float images like the render: at most 16M pixels. */
    if (o->samples_file &&
        (long long)o->width * o->height * o->samples_zoom * o->samples_zoom > MAX_PICTURE)
        return usage_error(&c, "-render_samples: %dx%d zoomed %d times is more than %d pixels",
                           o->width, o->height, o->samples_zoom, MAX_PICTURE);
    if (o->filter_file && (long long)(o->width * (long long)o->filter_zoom + 1) *
                                  (o->height * (long long)o->filter_zoom + 1) > MAX_PICTURE)
        return usage_error(&c, "-render_filter: %dx%d zoomed %d times is more than %d pixels",
                           o->width, o->height, o->filter_zoom, MAX_PICTURE);
    if (o->accel && strcmp(o->accel, "grid") != 0 && o->grid)
        return usage_error(&c, "option -grid goes with -accel grid, not -accel %s", o->accel);
    if (o->accel && strcmp(o->accel, "grid") == 0 && !o->grid)
        o->grid = o->grid_auto = true;
    if (o->visualize_grid && o->accel && strcmp(o->accel, "grid") != 0)
        return usage_error(&c, "-visualize_grid draws the uniform grid's cells: not with "
                           "-accel %s (use -grid nx ny nz or -grid auto instead)", o->accel);
    if (o->visualize_grid && !o->grid)
        return usage_error(&c, "-visualize_grid needs -grid nx ny nz (or -grid auto)");
    /* Two images into one file: the second would silently replace the first. The
     * snapshot is an image too; the cache is written during the set-up, so an image
     * named like it would replace it (and it the scene, if it named -input). The first
     * five are the render's images (to_stdout below). "-" is standard input or output
     * for -input and the images, never the cache's file: no pair with those two. */
    const char *names[8] = {"-output", "-depth", "-normals", "-render_samples",
                            "-render_filter", "-gui_snapshot", "-cache", "-input"};
    const char *files[8] = {o->output, o->depth_file, o->normals_file, o->samples_file,
                            o->filter_file, o->gui_snapshot, o->cache_file, o->input};
    for (int i = 0; i < 8; i++)
        for (int j = i + 1; j < 8; j++)
            if (files[i] && files[j] &&
                !(j >= 6 && (!strcmp(files[i], "-") || !strcmp(files[j], "-"))) &&
                same_file(files[i], files[j]))
                return usage_error(&c, "%s and %s name the same file '%s'", names[i], names[j],
                                   files[j]);
    /* The preview's shot:FILE too: "-output o.tga -gui_keys 'r shot:o.tga'" wrote the
     * render and then replaced it with the preview's frame. Only where the script runs
     * (otherwise -gui_keys is a warning, below). Words as the key parser splits them;
     * its keywords are case-insensitive. */
    if (o->gui_keys && (o->gui || o->gui_snapshot)) {
        for (const char *w = o->gui_keys; *w;) {
            size_t n = strcspn(w, " \t\n\r\f\v");
            char shot[PATH_MAX];
            if (n > 5 && n - 5 < sizeof shot && strncasecmp(w, "shot:", 5) == 0) {
                snprintf(shot, sizeof shot, "%.*s", (int)(n - 5), w + 5);
                /* "-" of -cache or -input is no standard output (as above), but
                 * shot:- and -output - are both standard output: two images in one. */
                for (int i = 0; i < 8; i++)
                    if (files[i] && !(i >= 6 && strcmp(files[i], "-") == 0) &&
                        same_file(files[i], shot))
                        return usage_error(&c, "%s and -gui_keys shot:%s name the same file",
                                           names[i], shot);
            }
            w += n;
            w += strspn(w, " \t\n\r\f\v");
        }
    }
    if (o->tile) {
        int rows = o->tile_n / o->tile_cols;
        if (rows > o->height)
            return usage_error(&c, "option -tile k n: %d rows of tiles is more than the %d rows "
                               "of the image", rows, o->height);
        if (o->tile_cols > o->width)
            return usage_error(&c, "option -tile k n: %d columns of tiles is more than the %d "
                               "columns of the image", o->tile_cols, o->width);
        o->region = true;
        options_tile_rows(o->tile_k / o->tile_cols, rows, o->height, &o->region_y,
                          &o->region_h);
        options_tile_cols(o->tile_k % o->tile_cols, o->tile_cols, o->width, &o->region_x,
                          &o->region_w);
    }
    /* Standard output carries the image: the preview's c key prints there. */
    bool to_stdout = false;
    for (int i = 0; i < 5; i++)
        to_stdout = to_stdout || (files[i] && !strcmp(files[i], IMAGE_STDOUT));
    if (to_stdout && o->gui)
        return usage_error(&c, "-gui prints on standard output (the c key): an image "
                           "cannot go there too (-output -)");
    for (int i = 0; i < 6; i++)
        if (!check_image_name(&c, names[i], files[i]))
            return false;
    /* -format names the format of the image on standard output. With none there, a
     * -format that disagrees with -output's extension is a mistaken hope of converting;
     * with -depth - or -normals - next to -output FILE it is that image's format, and
     * the file keeps its extension's (refusing it left no way to pick that format). */
    if (o->format && !to_stdout && o->output) {
        const ImageCodec *codec = image_codec_for_path(o->output);
        if (codec != image_codec_find(o->format))
            return usage_error(&c, "-format %s, but -output %s is %s: -format is for "
                               "an image on standard output (-output -, -depth ... -, "
                               "-normals -); a file's extension gives its format", o->format,
                               o->output, codec ? codec->name : "no known format");
    }
    if (o->region) {
        if (o->region_x + o->region_w > o->width || o->region_y + o->region_h > o->height)
            return usage_error(&c, "option -region %d %d %d %d does not lie inside the %dx%d "
                               "image (-size)", o->region_x, o->region_y, o->region_w,
                               o->region_h, o->width, o->height);
        if (o->gui || o->gui_snapshot)
            return usage_error(&c, "-region and -tile render files only; not with -gui or "
                               "-gui_snapshot");
        if (o->samples_file)
            return usage_error(&c, "-region and -tile: -render_samples draws the whole "
                               "image; render it without them");
        /* The filter picture is drawn from the filter alone, never in parts: with no
         * image of the scene to cut, the part asked for would be silently ignored. */
        if (o->filter_file && !o->output && !o->depth_file && !o->normals_file)
            return usage_error(&c, "-region and -tile cut an image of the scene (-output, "
                               "-depth, -normals); -render_filter alone draws the whole "
                               "filter picture");
    }
    /* A run that writes and shows nothing would render for nothing. Every option that
     * produces a result belongs in this test. */
    if (!o->output && !o->depth_file && !o->normals_file && !o->gui && !o->gui_snapshot &&
        !o->stats && !o->samples_file && !o->filter_file) {
        c.hinted = true;
        return usage_error(&c, "nothing to write: give -output FILE (or -depth, -normals, "
                           "-stats, -render_samples, -render_filter, -gui, -gui_snapshot)");
    }
    return true;
}

bool options_needs_scene(const Options *o)
{
    return !o->filter_file || o->output || o->depth_file || o->normals_file ||
           o->samples_file || o->gui || o->gui_snapshot || o->stats || o->cache_file;
}

void options_tile_cols(int k, int n, int width, int *x, int *w)
{
    int blocks = (width + 7) / 8;
    if (n > blocks) { /* too narrow for whole packet columns: split the columns evenly */
        int s = (int)((long long)k * width / n), e = (int)((long long)(k + 1) * width / n);
        *x = s;
        *w = e - s;
        return;
    }
    /* Block b covers columns 8b..8b+7 from the left, like the renderer's packets (the
     * last one may be narrow). */
    int s = (int)((long long)k * blocks / n), e = (int)((long long)(k + 1) * blocks / n);
    int hi = e * 8 > width ? width : e * 8;
    *x = s * 8;
    *w = hi - s * 8;
}

void options_tile_rows(int k, int n, int height, int *y, int *h)
{
    int blocks = (height + 7) / 8;
    if (n > blocks) { /* too thin for whole packet bands: split the rows evenly */
        int s = (int)((long long)k * height / n), e = (int)((long long)(k + 1) * height / n);
        *y = s;
        *h = e - s;
        return;
    }
    /* Block b covers rows 8b..8b+7 counted from the bottom (the last one may be short);
     * band k takes blocks [blocks - e, blocks - s) so band 0 is at the top. */
    int s = (int)((long long)k * blocks / n), e = (int)((long long)(k + 1) * blocks / n);
    int lo = (blocks - e) * 8, hi = (blocks - s) * 8;
    if (hi > height)
        hi = height;
    *y = height - hi;
    *h = hi - lo;
}

void options_warn(const Options *o, int cores, FILE *err)
{
    if (!o->gui && !o->gui_snapshot) {
        static const char *const preview_only[] = {"-gui_keys", "-tessellation", "-gouraud"};
        bool given[3] = {o->gui_keys != NULL, o->tessellation_given, o->gouraud};
        for (int i = 0; i < 3; i++)
            if (given[i])
                fprintf(err, "%s: warning: %s has no effect without -gui or "
                        "-gui_snapshot\n", diag_program(), preview_only[i]);
    }
    /* Options that change nothing in this run: said, as a typo or a wrong assumption
     * (the seed of a uniform lattice, packets without a grid) would otherwise pass
     * silently. Only the samplers that draw random numbers read the seed; only the grid
     * traces rays in packets; marking belongs to the grids (-grid, -accel grid or
     * twolevel). */
    bool random = o->adaptive || (o->sampler && strcmp(o->sampler, "uniform") != 0);
    if (o->seed_given && !random)
        fprintf(err, "%s: warning: -seed has no effect without a random sampler "
                "(-jittered_samples, -random_samples, -nrooks_samples, -poisson_samples, "
                "-adaptive_samples)\n", diag_program());
    bool any_grid = o->grid || (o->accel && strcmp(o->accel, "none") != 0); /* grid, twolevel */
    if (o->no_packets && !o->grid)
        fprintf(err, "%s: warning: -no_packets has no effect without -grid (only the "
                "grid traces rays in packets)\n", diag_program());
    if (o->no_marking && !any_grid)
        fprintf(err, "%s: warning: -no_marking has no effect without a grid (-grid, "
                "or -accel grid or twolevel)\n", diag_program());
    /* The weight only ends reflected and refracted paths, and -bounces 0 (the default)
     * traces none: a forgotten -bounces would otherwise pass for a cut-off weight. */
    if (o->weight > 0.0f && o->bounces == 0)
        fprintf(err, "%s: warning: -weight has no effect without -bounces (no reflected "
                "or refracted ray is traced)\n", diag_program());
    /* Two samplers (or filters): the later wins, as every repeated option does, but a
     * render with another sampler than meant would pass unseen. */
    if (o->sampler_replaced)
        fprintf(err, "%s: warning: %s and %s both choose the sampler: the later, %s, is "
                "used\n", diag_program(), o->sampler_replaced, o->sampler_flag,
                o->sampler_flag);
    if (o->filter_replaced)
        fprintf(err, "%s: warning: %s and %s both choose the filter: the later, %s, is "
                "used\n", diag_program(), o->filter_replaced, o->filter_flag, o->filter_flag);
    /* A few threads more than cores can even out uneven rows; many more only cost. */
    if (o->threads > 4 * cores && o->threads > cores + 8)
        fprintf(err, "%s: warning: -threads %d on %d core%s: the extra threads only "
                "wait their turn (the image is the same)\n", diag_program(), o->threads, cores,
                cores == 1 ? "" : "s");
}
