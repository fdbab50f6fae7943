/* src/io/png.c as a PNG=0 build compiles it (mk/png.mk's rule for this object removes
 * RT_HAVE_PNG and adds PNG=0's flags), whatever this build is: the codec must say that
 * the build leaves PNG out on purpose, not to install libpng-dev (user27: a PNG=0 build
 * with libpng-dev installed told its user to install it). The whole PNG=0 binary is
 * not built by make test (a minute on two cores); its --version and -output x.png
 * messages print this codec's text. */
#include "../harness.h"

/* The library's own png_codec (with libpng here) keeps its name; this copy is apart. */
#define png_codec png_codec_left_out
#include "../../src/io/png.c"

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

static const TestCase tests[] = {
    {"png: a PNG=0 build says PNG is left out on purpose", test_png_left_out_message},
};

RT_TEST_MAIN(tests)
