/* src/io/png.c as a PNG=0 build compiles it (mk/png.mk's rule for this object removes
 * RT_HAVE_PNG and adds PNG=0's flags), whatever this build is: the codec must say that
 * the build leaves PNG out on purpose, not to install libpng-dev (user27: a PNG=0 build
 * with libpng-dev installed told its user to install it). The whole PNG=0 binary is
 * not built by make test (a minute on two cores); its --version and -output x.png
 * messages print this codec's text.
 *
 * The codec table is compiled here too, with that codec in PNG's row: it defines every
 * function of src/io/codec_table.c, so the linker takes none from the library, and the
 * library's options_parse then sees the formats of a PNG=0 build. */
#include "../harness.h"

#include "rt/options.h"

/* The library's own png_codec (with libpng here) keeps its name; this copy is apart. */
#define png_codec png_codec_left_out
#include "../../src/io/png.c"
#include "../../src/io/codec_table.c"

static void test_png_left_out_message(void)
{
    const ImageCodec *c = &png_codec_left_out;
    CHECK(c->encode == NULL && c->decode == NULL);
    CHECK(c->missing != NULL);
    if (!c->missing)
        return;
    CHECK_CONTAINS(c->missing, "this build leaves it out on purpose, PNG=0");
    CHECK_MSG(!strstr(c->missing, "libpng-dev"), "still says to install libpng-dev: %s",
              c->missing);
    /* what it still knows without libpng: its files and their signature */
    CHECK(!strcmp(c->name, "png") && !strcmp(c->extensions[0], ".png"));
    static const uint8_t sig[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    CHECK(c->sniff && c->sniff(sig, sizeof sig));
}

/* options_parse of "raytracer ARGS" (split at blanks) in a PNG=0 build; its messages
 * into err. */
static bool parse(const char *args, char *err, size_t errlen)
{
    char buf[256], *argv[32];
    int argc = 0;
    snprintf(buf, sizeof buf, "raytracer %s", args);
    for (char *t = strtok(buf, " "); t && argc < 31; t = strtok(NULL, " "))
        argv[argc++] = t;
    argv[argc] = NULL;
    err[0] = '\0';
    FILE *f = fmemopen(err, errlen, "w");
    if (!f)
        return true; /* reported as a failure by the caller's checks */
    Options o;
    options_defaults(&o);
    bool ok = options_parse(&o, argc, argv, f);
    fclose(f);
    return ok;
}

/* "-output x.png" and "-format png" are the same user error in a PNG=0 build (a format
 * it lacks): both are refused by options_parse, so both exit 2 (EXIT_USAGE) before any
 * work, with one line saying why. -output x.png was let through to the render's set-up,
 * which refused it with exit 1. The other image options name files the same way. */
static void test_png_left_out_usage_error(void)
{
    static const char *const lines[] = {
        "-input s.txt -output x.png",
        "-input s.txt -output - -format png",
        "-input s.txt -output x.tga -depth 0 1 d.png",
        "-input s.txt -output x.tga -normals n.PNG",
        "-input s.txt -gui_snapshot shot.png",
    };
    for (size_t i = 0; i < sizeof lines / sizeof lines[0]; i++) {
        char err[512];
        CHECK_MSG(!parse(lines[i], err, sizeof err), "'%s' was accepted", lines[i]);
        CHECK_MSG(strstr(err, "PNG output is not built in: this build leaves it out on "
                              "purpose, PNG=0") != NULL,
                  "'%s': %s", lines[i], err);
        CHECK_MSG(strstr(err, "or write one of .tga") != NULL, "'%s': %s", lines[i], err);
        char *nl = strchr(err, '\n');
        CHECK_MSG(nl && nl[1] == '\0', "'%s': not one line: %s", lines[i], err);
    }
    /* What the build writes is still fine. */
    char err[512];
    CHECK_MSG(parse("-input s.txt -output x.tga -format tga", err, sizeof err), "%s", err);
}

static const TestCase tests[] = {
    {"png: a PNG=0 build says PNG is left out on purpose", test_png_left_out_message},
    {"png: a PNG=0 build refuses -output x.png as -format png (usage error)",
     test_png_left_out_usage_error},
};

RT_TEST_MAIN(tests)
