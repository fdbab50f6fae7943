/* Unit tests of src/io: the course TGA bytes (docs/images.md), PPM/PNG round trips,
 * decoders on damaged input, the temp-file-and-rename writer, and image_compare's
 * figures. */
#define _GNU_SOURCE /* fallocate (Linux) */
#include "../harness.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <pthread.h>
#include <signal.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include "rt/bigmem.h"
#include "rt/image.h"
#include "rt/image_compare.h"

/* A fresh temporary folder per test (the harness forks, so each test has its own). */
static char *make_tmpdir(void)
{
    static char path[64];
    snprintf(path, sizeof path, "/tmp/rt_test_image.XXXXXX");
    return mkdtemp(path);
}

static int count_entries(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return -1;
    int n = 0;
    struct dirent *e;
    while ((e = readdir(d)) != NULL)
        if (strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0)
            n++;
    closedir(d);
    return n;
}

static void remove_tree(const char *dir)
{
    DIR *d = opendir(dir);
    if (!d)
        return;
    struct dirent *e;
    char p[512];
    while ((e = readdir(d)) != NULL) {
        if (strcmp(e->d_name, ".") == 0 || strcmp(e->d_name, "..") == 0)
            continue;
        snprintf(p, sizeof p, "%s/%s", dir, e->d_name);
        unlink(p);
    }
    closedir(d);
    rmdir(dir);
}

/* The codecs reached through their table, as image_read and image_write reach them. */
static const ImageCodec *codec(const char *name)
{
    const ImageCodec *c = image_codec_find(name);
    if (!c) {
        harness_fail(__FILE__, __LINE__, "no codec named %s", name);
        harness_skip("cannot go on without the codec"); /* ends the test failed */
    }
    return c;
}

static bool tga_encode(const Image *img, uint8_t **out, size_t *len)
{
    return codec("tga")->encode(img, out, len);
}

static bool tga_decode(const uint8_t *d, size_t len, Image *img, char *err, size_t errlen)
{
    return codec("tga")->decode(d, len, img, err, errlen);
}

static bool ppm_encode(const Image *img, uint8_t **out, size_t *len)
{
    return codec("ppm")->encode(img, out, len);
}

static bool ppm_decode(const uint8_t *d, size_t len, Image *img, char *err, size_t errlen)
{
    return codec("ppm")->decode(d, len, img, err, errlen);
}

/* 3x2 test picture with distinct values per channel, exercising the quantisation. */
static void make_small(Image *img)
{
    CHECK(image_init(img, 3, 2));
    /* bottom row (y = 0) */
    image_set(img, 0, 0, v3(0.7f, 0.2f, 1.0f));
    image_set(img, 1, 0, v3(1.5f, -0.3f, NAN));
    image_set(img, 2, 0, v3(0.5f, 0.0f, 0.999f));
    /* top row (y = 1) */
    image_set(img, 0, 1, v3(0.1f, 0.2f, 0.3f));
    image_set(img, 1, 1, v3(INFINITY, -INFINITY, 1e30f));
    image_set(img, 2, 1, v3(1.0f / 255.0f, 2.0f / 255.0f, 254.0f / 255.0f));
}

static void test_color_to_byte(void)
{
    CHECK_INT(image_color_to_byte(0.7f), 178);
    CHECK_INT(image_color_to_byte(0.2f), 51);
    CHECK_INT(image_color_to_byte(0.5f), 127);
    CHECK_INT(image_color_to_byte(1.0f), 255);
    CHECK_INT(image_color_to_byte(1.0001f), 255);
    CHECK_INT(image_color_to_byte(7.0f), 255);
    CHECK_INT(image_color_to_byte(0.0f), 0);
    CHECK_INT(image_color_to_byte(-0.001f), 0);
    CHECK_INT(image_color_to_byte(-5.0f), 0);
    CHECK_INT(image_color_to_byte(NAN), 0);
    CHECK_INT(image_color_to_byte(INFINITY), 255);
    CHECK_INT(image_color_to_byte(-INFINITY), 0);
    CHECK_INT(image_color_to_byte(1e30f), 255);
    /* truncation, not rounding: 0.999 * 255 = 254.7 -> 254 */
    CHECK_INT(image_color_to_byte(0.999f), 254);
    /* every stored byte value survives byte -> b/255 -> byte */
    for (int b = 0; b < 256; b++)
        CHECK_INT(image_color_to_byte((float)b / 255.0f), b);
}

static void test_tga_exact_bytes(void)
{
    Image img;
    make_small(&img);
    uint8_t *buf = NULL;
    size_t len = 0;
    CHECK(tga_encode(&img, &buf, &len));
    CHECK_INT(len, 18 + 3 * 2 * 3);
    static const uint8_t want_header[18] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0,
                                            3, 0, 2, 0, 24, 0x20};
    for (int i = 0; i < 18; i++)
        CHECK_MSG(buf[i] == want_header[i], "header byte %d = %d, expected %d", i, buf[i],
                  want_header[i]);
    /* Top row (y = 1) first, then the bottom row; each pixel B, G, R. */
    static const uint8_t want_pixels[18] = {
        76, 51, 25,     /* (0,1): 0.1 0.2 0.3 -> R 25 G 51 B 76 */
        255, 0, 255,    /* (1,1): inf -inf 1e30 */
        254, 2, 1,      /* (2,1) */
        255, 51, 178,   /* (0,0): 0.7 0.2 1.0 */
        0, 0, 255,      /* (1,0): 1.5 -0.3 NaN */
        254, 0, 127,    /* (2,0): 0.5 0 0.999 */
    };
    for (int i = 0; i < 18; i++)
        CHECK_MSG(buf[18 + i] == want_pixels[i], "pixel byte %d = %d, expected %d", i,
                  buf[18 + i], want_pixels[i]);
    bigmem_free(buf);
    image_free(&img);
}

static void test_tga_size_fields_little_endian(void)
{
    Image img;
    CHECK(image_init(&img, 300, 2));
    uint8_t *buf = NULL;
    size_t len = 0;
    CHECK(tga_encode(&img, &buf, &len));
    CHECK_INT(buf[12], 300 & 0xff);
    CHECK_INT(buf[13], 300 >> 8);
    CHECK_INT(buf[14], 2);
    CHECK_INT(buf[15], 0);
    CHECK_INT(len, 18 + 300 * 2 * 3);
    bigmem_free(buf);
    image_free(&img);
}

/* Both images hold the same bytes after quantisation. */
static void check_same_bytes(const Image *a, const Image *b)
{
    CHECK_INT(a->width, b->width);
    CHECK_INT(a->height, b->height);
    if (a->width != b->width || a->height != b->height)
        return;
    ImageDiff d = image_compare(a, b, 0);
    CHECK_INT(d.identical, (long)a->width * a->height);
    CHECK_INT(d.max_diff, 0);
}

static void test_tga_round_trip(void)
{
    Image img, back;
    make_small(&img);
    uint8_t *buf = NULL;
    size_t len = 0;
    char err[256] = "";
    CHECK(tga_encode(&img, &buf, &len));
    CHECK_MSG(tga_decode(buf, len, &back, err, sizeof err), "decode: %s", err);
    check_same_bytes(&img, &back);
    /* stored values are byte / 255 exactly, as the course's LoadTGA does */
    CHECK_NEAR(image_get(&back, 0, 0).x, 178.0f / 255.0f, 0.0);
    bigmem_free(buf);
    image_free(&back);
    image_free(&img);
}

static void test_tga_decode_bottom_up_and_32bit(void)
{
    /* 2x2, 32 bits, bottom-up (descriptor 0x08: 8 alpha bits, bit 5 clear), with a
     * 3-byte image ID to skip. Stored rows: bottom first. */
    uint8_t f[18 + 3 + 16] = {3, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 2, 0, 32, 0x08};
    uint8_t *p = f + 18;
    *p++ = 'a'; *p++ = 'b'; *p++ = 'c';
    const uint8_t px[16] = {
        10, 20, 30, 255,   40, 50, 60, 255,     /* y = 0: (0,0) (1,0) as B G R A */
        70, 80, 90, 0,     100, 110, 120, 128,  /* y = 1 */
    };
    memcpy(p, px, sizeof px);
    Image img;
    char err[256] = "";
    CHECK_MSG(tga_decode(f, sizeof f, &img, err, sizeof err), "decode: %s", err);
    CHECK_INT(img.width, 2);
    CHECK_INT(img.height, 2);
    if (img.pixels) {
        CHECK_INT(image_color_to_byte(image_get(&img, 0, 0).x), 30);
        CHECK_INT(image_color_to_byte(image_get(&img, 0, 0).z), 10);
        CHECK_INT(image_color_to_byte(image_get(&img, 1, 0).y), 50);
        CHECK_INT(image_color_to_byte(image_get(&img, 0, 1).x), 90);
        CHECK_INT(image_color_to_byte(image_get(&img, 1, 1).z), 100);
    }
    image_free(&img);
}

static void test_tga_decode_rejects(void)
{
    Image img;
    char err[256];
    uint8_t good_header[18] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 4, 0, 4, 0, 24, 0x20};
    uint8_t buf[18 + 48];
    memset(buf, 7, sizeof buf);
    memcpy(buf, good_header, 18);

    /* truncated at every length short of complete */
    for (size_t n = 0; n < sizeof buf; n++) {
        err[0] = '\0';
        CHECK_MSG(!tga_decode(buf, n, &img, err, sizeof err), "accepted %zu bytes", n);
        CHECK(img.pixels == NULL);
        CHECK(err[0] != '\0');
    }
    CHECK(tga_decode(buf, sizeof buf, &img, err, sizeof err));
    image_free(&img);

    buf[2] = 10; /* RLE */
    CHECK(!tga_decode(buf, sizeof buf, &img, err, sizeof err));
    CHECK_CONTAINS(err, "RLE");
    buf[2] = 1; /* colour-mapped */
    buf[1] = 1;
    CHECK(!tga_decode(buf, sizeof buf, &img, err, sizeof err));
    CHECK_CONTAINS(err, "colour-mapped");
    buf[1] = 0;
    buf[2] = 2;
    buf[16] = 16; /* unsupported depth */
    CHECK(!tga_decode(buf, sizeof buf, &img, err, sizeof err));
    CHECK_CONTAINS(err, "16 bits");
    buf[16] = 24;
    buf[12] = 0; /* zero width */
    CHECK(!tga_decode(buf, sizeof buf, &img, err, sizeof err));
    buf[12] = 0xff; /* huge size, few bytes */
    buf[13] = 0xff;
    CHECK(!tga_decode(buf, sizeof buf, &img, err, sizeof err));
    CHECK_CONTAINS(err, "truncated");

    /* Files that are no TGA at all (TGA has no signature: it is the fallback) are
     * called that, not refused for one of their fields. */
    static const char *const not_tga[] = {
        "OrthographicCamera { center 0 0 10 direction 0 0 -1 }\n", /* a scene */
        "P3\n2 2\n255\n0 0 0 255 255 255 0 0 0 255 255 255\n",    /* ASCII PPM */
        "\xff\xd8\xff\xe0\x00\x10JFIF\x00\x01\x01\x00\x00\x01\x00\x01\x00\x00", /* JPEG */
        "GIF89a\x04\x00\x04\x00\x80\x00\x00\x00\x00\x00\xff\xff\xff\x21",
        "short text\n",
    };
    for (size_t i = 0; i < sizeof not_tga / sizeof not_tga[0]; i++) {
        err[0] = '\0';
        CHECK(!tga_decode((const uint8_t *)not_tga[i], strlen(not_tga[i]), &img, err,
                          sizeof err));
        CHECK_MSG(strstr(err, "not a TGA image") != NULL, "case %zu: %s", i, err);
    }
    /* the real TGA variants keep their own messages (above): a TGA stays a TGA */
    buf[17] = 0xc0; /* interleaving bits: no TGA written since the 1990s */
    CHECK(!tga_decode(buf, sizeof buf, &img, err, sizeof err));
    CHECK_CONTAINS(err, "not a TGA image");
    buf[17] = 0x20;

    /* deterministic garbage: never crashes, and any accepted file is complete */
    uint32_t s = 12345u;
    uint8_t junk[200];
    for (int round = 0; round < 2000; round++) {
        size_t n = (size_t)(round % (int)sizeof junk);
        for (size_t i = 0; i < n; i++) {
            s = s * 1664525u + 1013904223u;
            junk[i] = (uint8_t)(s >> 24);
        }
        if (round % 3 == 0 && n >= 18)
            junk[2] = 2, junk[1] = 0, junk[16] = 24;
        if (tga_decode(junk, n, &img, err, sizeof err)) {
            CHECK((size_t)img.width * (size_t)img.height * 3 + 18 <= n);
            image_free(&img);
        }
    }
}

static void test_ppm_round_trip_and_header(void)
{
    Image img, back;
    make_small(&img);
    uint8_t *buf = NULL;
    size_t len = 0;
    char err[256] = "";
    CHECK(ppm_encode(&img, &buf, &len));
    CHECK(len > 11 && memcmp(buf, "P6\n3 2\n255\n", 11) == 0);
    CHECK_INT(len, 11 + 18);
    /* first stored pixel is the top-left one, R G B */
    CHECK_INT(buf[11], 25);
    CHECK_INT(buf[12], 51);
    CHECK_INT(buf[13], 76);
    CHECK_MSG(ppm_decode(buf, len, &back, err, sizeof err), "decode: %s", err);
    check_same_bytes(&img, &back);
    image_free(&back);
    bigmem_free(buf);
    image_free(&img);
}

static void test_ppm_comments_and_rejects(void)
{
    static const char text[] = "P6\n# made by hand\n2 # width\n1\n#maxval next\n255\n"
                               "\x01\x02\x03\xfa\xfb\xfc";
    Image img;
    char err[256] = "";
    CHECK_MSG(ppm_decode((const uint8_t *)text, sizeof text - 1, &img, err, sizeof err),
              "decode: %s", err);
    CHECK_INT(img.width, 2);
    CHECK_INT(img.height, 1);
    if (img.pixels) {
        CHECK_INT(image_color_to_byte(image_get(&img, 0, 0).x), 1);
        CHECK_INT(image_color_to_byte(image_get(&img, 1, 0).z), 0xfc);
    }
    image_free(&img);

    for (size_t n = 0; n < sizeof text - 1; n++) {
        CHECK_MSG(!ppm_decode((const uint8_t *)text, n, &img, err, sizeof err),
                  "accepted %zu bytes", n);
        CHECK(img.pixels == NULL);
    }
    static const char *bad[] = {"P5\n1 1\n255\n\x01", "P6\n1 1\n65535\n\x01\x02\x03",
                                "P6\n-1 1\n255\n", "P6\n1 x\n255\n", "P6 1 1 255",
                                "P6\n99999999999 1\n255\n"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; i++)
        CHECK_MSG(!ppm_decode((const uint8_t *)bad[i], strlen(bad[i]), &img, err, sizeof err),
                  "accepted bad PPM %zu", i);
}

static void test_png_round_trip(void)
{
    const ImageCodec *png = codec("png");
    if (!png->encode) {
        /* Not built in: the codec still knows its files and says what to install, or
         * that a PNG=0 build leaves it out on purpose. */
        CHECK(png->decode == NULL);
#ifdef RT_PNG_LEFT_OUT
        CHECK(png->missing && strstr(png->missing, "PNG=0"));
#else
        CHECK(png->missing && strstr(png->missing, "libpng-dev"));
#endif
        CHECK(!image_format_supported("png"));
        harness_skip("built without libpng (PNG=0 or libpng-dev missing)");
    }
    CHECK(png->decode != NULL && png->missing == NULL);
    Image img, back;
    make_small(&img);
    uint8_t *buf = NULL;
    size_t len = 0;
    char err[256] = "";
    CHECK(png->encode(&img, &buf, &len));
    CHECK(len > 8 && memcmp(buf, "\x89PNG\r\n\x1a\n", 8) == 0);
    CHECK_MSG(png->decode(buf, len, &back, err, sizeof err), "decode: %s", err);
    check_same_bytes(&img, &back);
    image_free(&back);
    for (size_t n = 0; n < len; n += 7)
        CHECK_MSG(!png->decode(buf, n, &back, err, sizeof err), "accepted %zu bytes", n);
    bigmem_free(buf);
    image_free(&img);
}

/* A PNG wider than 65535 (what PPM and TGA hold, and the -merge parts' limit) is
 * refused by its size, as a PPM is: libpng's own limit of 65535 said "corrupt or
 * truncated PNG file" for a valid 65536 x 1 header. The file: the signature, IHDR
 * (65536 x 1, 8-bit RGB), an empty IDAT and IEND, each with its CRC; the size is
 * refused before any pixel is read. */
static void test_png_too_wide(void)
{
    const ImageCodec *png = codec("png");
    if (!png->decode) {
        harness_skip("built without libpng (PNG=0 or libpng-dev missing)");
        return;
    }
    static const uint8_t file[] = {
        0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x0d, 0x49, 0x48, 0x44,
        0x52, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x00, 0x01, 0x08, 0x02, 0x00, 0x00, 0x00, 0xe4,
        0x10, 0x74, 0x8f, 0x00, 0x00, 0x00, 0x00, 0x49, 0x44, 0x41, 0x54, 0x35, 0xaf, 0x06, 0x1e,
        0x00, 0x00, 0x00, 0x00, 0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
    Image back;
    char err[256] = "";
    CHECK(!png->decode(file, sizeof file, &back, err, sizeof err));
    CHECK_CONTAINS(err, "unsupported PNG size 65536x1 (at most 65535x65535)");
}

static void test_write_read_by_extension(void)
{
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    Image img, back;
    make_small(&img);
    Diag diag;
    diag_init(&diag, NULL);
    const char *exts[] = {"tga", "ppm", "png"};
    for (int i = 0; i < 3; i++) {
        if (i == 2 && !image_format_supported("png"))
            break;
        char path[256];
        snprintf(path, sizeof path, "%s/out.%s", dir, exts[i]);
        CHECK_MSG(image_write(&img, path, &diag), "%s: %s", path, diag.last);
        CHECK_MSG(image_read(&back, path, &diag), "%s: %s", path, diag.last);
        check_same_bytes(&img, &back);
        image_free(&back);
        struct stat st;
        CHECK(stat(path, &st) == 0);
        if (i == 0)
            CHECK_INT(st.st_size, 18 + 18);
        CHECK(st.st_mode & S_IRUSR);
    }
    /* only the finished files are left: no temporary files */
    CHECK_INT(count_entries(dir), image_format_supported("png") ? 3 : 2);

    /* unknown extension: error naming the supported ones, nothing written */
    char path[256];
    snprintf(path, sizeof path, "%s/out.bmp", dir);
    CHECK(!image_write(&img, path, &diag));
    CHECK_CONTAINS(diag.last, ".tga");
    CHECK_CONTAINS(diag.last, ".ppm");
    CHECK_CONTAINS(diag.last, "out.bmp");
    snprintf(path, sizeof path, "%s/noextension", dir);
    CHECK(!image_write(&img, path, &diag));
    CHECK_INT(count_entries(dir), image_format_supported("png") ? 3 : 2);
    if (!image_format_supported("png")) {
        snprintf(path, sizeof path, "%s/out.png", dir);
        CHECK(!image_write(&img, path, &diag));
#ifdef RT_PNG_LEFT_OUT
        CHECK_CONTAINS(diag.last, "leaves it out on purpose, PNG=0");
#else
        CHECK_CONTAINS(diag.last, "libpng");
#endif
    }
    /* overwriting an existing file replaces it */
    snprintf(path, sizeof path, "%s/out.tga", dir);
    image_set(&img, 0, 0, v3(0, 0, 0));
    CHECK(image_write(&img, path, &diag));
    CHECK(image_read(&back, path, &diag));
    if (back.pixels)
        CHECK_INT(image_color_to_byte(image_get(&back, 0, 0).x), 0);
    image_free(&back);

    image_free(&img);
    remove_tree(dir);
}

/* Replacing an image keeps the old file's permission bits (the new bytes arrive by a
 * rename, so without care a private 0600 file would come back 0644); a new file gets
 * the umask's. Both the plain write and the streamed one go through the same temporary
 * file. */
static void test_write_keeps_permissions(void)
{
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    Image img;
    make_small(&img);
    Diag diag;
    diag_init(&diag, NULL);
    char path[256];
    snprintf(path, sizeof path, "%s/keep.tga", dir);
    const mode_t modes[] = {0600, 0640, 0444, 0755};
    for (size_t i = 0; i < sizeof modes / sizeof modes[0]; i++) {
        CHECK_MSG(image_write(&img, path, &diag), "%s: %s", path, diag.last);
        CHECK(chmod(path, modes[i]) == 0);
        CHECK_MSG(image_write(&img, path, &diag), "%s: %s", path, diag.last);
        struct stat st;
        CHECK(stat(path, &st) == 0);
        CHECK_MSG((st.st_mode & 07777) == modes[i], "mode %o after replacing a %o file",
                  (unsigned)(st.st_mode & 07777), (unsigned)modes[i]);
        CHECK(chmod(path, 0644) == 0);
    }
    /* A new file: 0666 less the umask. */
    mode_t mask = umask(022);
    snprintf(path, sizeof path, "%s/new.tga", dir);
    CHECK(image_write(&img, path, &diag));
    struct stat st;
    CHECK(stat(path, &st) == 0);
    CHECK_INT((int)(st.st_mode & 07777), 0644);
    umask(mask);
    CHECK_INT(count_entries(dir), 2);
    image_free(&img);
    remove_tree(dir);
}

static void test_write_failure_leaves_nothing(void)
{
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    Image img;
    make_small(&img);
    Diag diag;
    diag_init(&diag, NULL);
    char path[256];
    snprintf(path, sizeof path, "%s/missing/out.tga", dir);
    CHECK(!image_write(&img, path, &diag));
    CHECK_INT(diag.errors, 1);
    char want[400];
    snprintf(want, sizeof want, "%s: error: cannot write image: No such file or directory",
             path);
    CHECK_STR(diag.last, want);
    CHECK_INT(count_entries(dir), 0);

    /* a folder in the way of the rename: the temp file is cleaned up */
    snprintf(path, sizeof path, "%s/adir.tga", dir);
    CHECK(mkdir(path, 0755) == 0);
    CHECK(!image_write(&img, path, &diag));
    CHECK_CONTAINS(diag.last, "cannot write image: ");
    CHECK_INT(count_entries(dir), 1);
    rmdir(path);

    /* reading a missing file reports its path */
    Image back;
    snprintf(path, sizeof path, "%s/nothere.tga", dir);
    CHECK(!image_read(&back, path, &diag));
    CHECK_CONTAINS(diag.last, "nothere.tga: error: cannot read image");
    CHECK(back.pixels == NULL);

    image_free(&img);
    remove_tree(dir);
}

static void test_write_unwritable_folder(void)
{
    Image img;
    make_small(&img);
    Diag diag;
    diag_init(&diag, NULL);
    if (geteuid() == 0) {
        /* Permissions do not stop root; sysfs refuses new files even to root. */
        CHECK(!image_write(&img, "/sys/rt_test_out.tga", &diag));
        CHECK_CONTAINS(diag.last, "/sys/rt_test_out.tga: error: cannot write image: ");
        CHECK(access("/sys/rt_test_out.tga", F_OK) != 0);
        image_free(&img);
        return;
    }
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    chmod(dir, 0555);
    char path[256];
    snprintf(path, sizeof path, "%s/out.tga", dir);
    CHECK(!image_write(&img, path, &diag));
    CHECK_CONTAINS(diag.last, "Permission denied");
    chmod(dir, 0755);
    CHECK_INT(count_entries(dir), 0);
    image_free(&img);
    remove_tree(dir);
}

static void test_write_devices_and_links(void)
{
    Image img;
    make_small(&img);
    Diag diag;
    diag_init(&diag, NULL);
    /* a device is written into, never replaced by a regular file */
    struct stat st;
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    char fifo_like[256];
    snprintf(fifo_like, sizeof fifo_like, "%s/null.tga", dir);
    CHECK(symlink("/dev/null", fifo_like) == 0);
    CHECK_MSG(image_write(&img, fifo_like, &diag), "%s", diag.last);
    CHECK(stat("/dev/null", &st) == 0 && S_ISCHR(st.st_mode));
    CHECK(lstat(fifo_like, &st) == 0 && S_ISLNK(st.st_mode));
    unlink(fifo_like);

    /* a symbolic link to a regular file: the target is replaced, the link stays */
    char target[256], link[256];
    snprintf(target, sizeof target, "%s/real.tga", dir);
    snprintf(link, sizeof link, "%s/link.tga", dir);
    FILE *f = fopen(target, "w");
    CHECK(f != NULL);
    if (f)
        fclose(f);
    CHECK(symlink("real.tga", link) == 0);
    CHECK_MSG(image_write(&img, link, &diag), "%s", diag.last);
    CHECK(lstat(link, &st) == 0 && S_ISLNK(st.st_mode));
    CHECK(stat(target, &st) == 0 && st.st_size == 18 + 18);
    CHECK_INT(count_entries(dir), 2);
    image_free(&img);
    remove_tree(dir);
}

/* A dangling symbolic link (its target does not exist yet) is written through too: the
 * target is created beside the link's text, the temporary file made in the target's
 * folder, and the link stays a link (it was replaced by a regular file). Also along a
 * chain of links, for a streamed output, and on the failure paths (a target folder that
 * does not exist, a write that fails midway): nothing created, the link unchanged. */
static void test_write_dangling_links(void)
{
    Image img;
    make_small(&img);
    Diag diag;
    diag_init(&diag, NULL);
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    char a[128], b[128], link[192], chain[192], mid[192], streamed[192], lost[192];
    char real[192], real2[192], real3[192];
    snprintf(a, sizeof a, "%s/a", dir);
    snprintf(b, sizeof b, "%s/b", dir);
    CHECK(mkdir(a, 0755) == 0 && mkdir(b, 0755) == 0);
    snprintf(link, sizeof link, "%s/link.tga", a);
    snprintf(chain, sizeof chain, "%s/chain.tga", a);
    snprintf(mid, sizeof mid, "%s/mid.tga", a);
    snprintf(streamed, sizeof streamed, "%s/streamed.tga", a);
    snprintf(lost, sizeof lost, "%s/lost.tga", a);
    snprintf(real, sizeof real, "%s/real.tga", b);
    snprintf(real2, sizeof real2, "%s/real2.tga", b);
    snprintf(real3, sizeof real3, "%s/real3.tga", b);
    CHECK(symlink("../b/real.tga", link) == 0);
    CHECK(symlink("mid.tga", chain) == 0);
    CHECK(symlink("../b/real2.tga", mid) == 0);
    CHECK(symlink("../b/real3.tga", streamed) == 0);
    CHECK(symlink("../missing/x.tga", lost) == 0);
    struct stat st;

    CHECK_MSG(image_check_output(link, NULL, &diag), "%s", diag.last);
    CHECK_MSG(image_write(&img, link, &diag), "%s", diag.last);
    CHECK(lstat(link, &st) == 0 && S_ISLNK(st.st_mode));
    CHECK(stat(real, &st) == 0 && S_ISREG(st.st_mode) && st.st_size == 18 + 18);

    CHECK_MSG(image_check_output(chain, NULL, &diag), "%s", diag.last);
    CHECK_MSG(image_write(&img, chain, &diag), "%s", diag.last);
    CHECK(lstat(chain, &st) == 0 && S_ISLNK(st.st_mode));
    CHECK(lstat(mid, &st) == 0 && S_ISLNK(st.st_mode));
    CHECK(stat(real2, &st) == 0 && S_ISREG(st.st_mode) && st.st_size == 18 + 18);

    /* streamed: the temporary file sits in b, beside the target */
    ImageEncoding e;
    CHECK(image_encoding_begin(&e, &img, streamed, NULL));
    CHECK(image_encoding_stream(&e, streamed));
    CHECK_INT(count_entries(b), 3);
    for (int y = 0; y < img.height; y++)
        image_encoding_row(&e, &img, y);
    image_encoding_flush(&e, 0, img.height - 1);
    ImageOutput out = {&img, streamed, NULL, &e};
    CHECK_MSG(image_write_all(&out, 1, &diag), "%s", diag.last);
    image_encoding_free(&e);
    CHECK(lstat(streamed, &st) == 0 && S_ISLNK(st.st_mode));
    CHECK(stat(real3, &st) == 0 && S_ISREG(st.st_mode) && st.st_size == 18 + 18);
    CHECK_INT(count_entries(a), 5);
    CHECK_INT(count_entries(b), 3);

    /* the target's folder is missing: refused before any work, and by the write */
    CHECK(!image_check_output(lost, NULL, &diag));
    CHECK_CONTAINS(diag.last, "missing");
    CHECK(!image_write(&img, lost, &diag));
    CHECK(lstat(lost, &st) == 0 && S_ISLNK(st.st_mode));

    /* a write failing midway (a file size limit): no target, no temporary file */
    unlink(real);
    signal(SIGXFSZ, SIG_IGN);
    struct rlimit old_lim, lim;
    CHECK(getrlimit(RLIMIT_FSIZE, &old_lim) == 0);
    lim = old_lim;
    lim.rlim_cur = 20;
    CHECK(setrlimit(RLIMIT_FSIZE, &lim) == 0);
    CHECK(!image_write(&img, link, &diag));
    setrlimit(RLIMIT_FSIZE, &old_lim);
    CHECK_CONTAINS(diag.last, "File too large");
    CHECK(lstat(link, &st) == 0 && S_ISLNK(st.st_mode));
    CHECK_INT(count_entries(a), 5);
    CHECK_INT(count_entries(b), 2);

    image_free(&img);
    remove_tree(a);
    remove_tree(b);
    remove_tree(dir);
}

static void test_image_init_bounds(void)
{
    Image img;
    CHECK(!image_init(&img, 0, 5));
    CHECK(img.pixels == NULL);
    CHECK(!image_init(&img, 5, -1));
    CHECK(!image_init(&img, 70000, 1));
    CHECK(image_init(&img, 2, 3));
    CHECK_INT(img.width, 2);
    CHECK_INT(img.height, 3);
    CHECK(v3_is_zero(image_get(&img, 1, 2)));
    image_fill(&img, v3(0.25f, 0.5f, 1.0f));
    CHECK_NEAR(image_get(&img, 1, 2).y, 0.5, 0.0);
    CHECK_NEAR(image_get(&img, 0, 0).z, 1.0, 0.0);
    image_free(&img);
    CHECK(img.pixels == NULL);
    image_free(&img); /* twice is harmless */
}

static void test_compare_figures(void)
{
    Image a, b;
    CHECK(image_init(&a, 4, 1));
    CHECK(image_init(&b, 4, 1));
    /* pixel 0 identical; pixel 1 off by 1 in one channel; pixel 2 off by 8 in one and
     * 3 in another; pixel 3 off by 100 in one channel. */
    image_set(&a, 0, 0, v3(10 / 255.0f, 20 / 255.0f, 30 / 255.0f));
    image_set(&b, 0, 0, v3(10 / 255.0f, 20 / 255.0f, 30 / 255.0f));
    image_set(&a, 1, 0, v3(10 / 255.0f, 20 / 255.0f, 30 / 255.0f));
    image_set(&b, 1, 0, v3(11 / 255.0f, 20 / 255.0f, 30 / 255.0f));
    image_set(&a, 2, 0, v3(10 / 255.0f, 20 / 255.0f, 30 / 255.0f));
    image_set(&b, 2, 0, v3(18 / 255.0f, 17 / 255.0f, 30 / 255.0f));
    image_set(&a, 3, 0, v3(0, 0, 200 / 255.0f));
    image_set(&b, 3, 0, v3(0, 0, 100 / 255.0f));
    ImageDiff d = image_compare(&a, &b, 3);
    CHECK(d.same_size);
    CHECK_INT(d.pixels, 4);
    CHECK_INT(d.identical, 1);
    CHECK_INT(d.max_diff, 100);
    CHECK_NEAR(d.mean_abs, (1 + 8 + 3 + 100) / 12.0, 1e-12);
    CHECK_NEAR(d.pct_within_1, 50.0, 1e-12);
    CHECK_NEAR(d.pct_within_8, 75.0, 1e-12);
    CHECK_NEAR(d.pct_within_t, 50.0, 1e-12);
    double mse = (1.0 + 64.0 + 9.0 + 10000.0) / 12.0;
    CHECK_NEAR(d.psnr, 10.0 * log10(255.0 * 255.0 / mse), 1e-9);

    ImageDiff same = image_compare(&a, &a, 0);
    CHECK(isinf(same.psnr));
    CHECK_INT(same.identical, 4);
    CHECK_NEAR(same.pct_within_t, 100.0, 0.0);

    /* values beyond 0..1 compare after quantisation: 2.0 and 1.0 are both 255 */
    image_set(&b, 0, 0, v3(2.0f, 20 / 255.0f, 30 / 255.0f));
    image_set(&a, 0, 0, v3(1.0f, 20 / 255.0f, 30 / 255.0f));
    d = image_compare(&a, &b, 3);
    CHECK_INT(d.identical, 1);

    Image c;
    CHECK(image_init(&c, 2, 2));
    ImageDiff other = image_compare(&a, &c, 8);
    CHECK(!other.same_size);
    image_free(&c);
    image_free(&a);
    image_free(&b);
}

/* The table: every codec is found by its name and by each of its extensions (in any
 * case), signatures pick PPM and PNG, anything else reads as TGA, and the list of
 * writable extensions follows what is built in. */
/* A 128-byte PNG whose text chunk declares 1 GB (found by the merge fuzz target):
 * refused with a message, without libpng allocating and clearing the declared length
 * first (it took 1 GB and 6 s). Checked by the peak memory of this process, which stays
 * far below 1 GB whatever the machine's speed. */
static void test_png_huge_chunk(void)
{
    if (!image_format_supported("png"))
        harness_skip("built without libpng (PNG=0 or libpng-dev missing)");
    char path[4096];
    snprintf(path, sizeof path, "%s/tests/bad/png_1gb_text_chunk.png", harness_root());
    Image img;
    Diag d;
    diag_init(&d, NULL);
    CHECK(!image_read(&img, path, &d));
    CHECK_INT(d.errors, 1);
    CHECK_CONTAINS(d.last, "PNG");
    struct rusage ru;
    CHECK(getrusage(RUSAGE_SELF, &ru) == 0);
    CHECK_MSG(ru.ru_maxrss < 256 * 1024, "peak memory %ld KB after reading it", ru.ru_maxrss);
}

/* A file longer than any image the program writes (a sparse 4 GiB file: no disk
 * used) is refused before it is read: "File too large", in little memory. The reader
 * grew its buffer up to 1 TiB, so -merge out.tga /dev/zero ran until the system killed
 * it; a pipe or device has the same limit (3 GiB of pixels and 64 MiB), checked by hand
 * (14 s for /dev/zero here): too slow for the suite. */
static void test_read_too_long(void)
{
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    char path[4096];
    snprintf(path, sizeof path, "%s/huge.tga", dir);
    int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0600);
    CHECK(fd >= 0);
    bool sized = fd >= 0 && ftruncate(fd, (off_t)4 << 30) == 0;
    if (fd >= 0)
        close(fd);
    if (!sized) {
        unlink(path);
        rmdir(dir);
        harness_skip("this file system cannot hold a sparse 4 GiB file");
    }
    Image img;
    Diag d;
    diag_init(&d, NULL);
    CHECK(!image_read(&img, path, &d));
    CHECK_INT(d.errors, 1);
    CHECK_CONTAINS(d.last, "cannot read image: File too large");
    struct rusage ru;
    CHECK(getrusage(RUSAGE_SELF, &ru) == 0);
    CHECK_MSG(ru.ru_maxrss < 256 * 1024, "peak memory %ld KB after reading it", ru.ru_maxrss);
    unlink(path);
    rmdir(dir);
}

/* The writer of test_read_header_first: zeros into the FIFO until the reader goes
 * (EPIPE) or 8 MiB are written; how many it wrote. */
typedef struct ZeroWriter {
    const char *fifo;
    size_t written;
} ZeroWriter;

static void *zero_writer(void *arg)
{
    ZeroWriter *z = arg;
    int fd = open(z->fifo, O_WRONLY);
    static const uint8_t zeros[4096];
    while (fd >= 0 && z->written < ((size_t)8 << 20)) {
        ssize_t w = write(fd, zeros, sizeof zeros);
        if (w <= 0)
            break;
        z->written += (size_t)w;
    }
    if (fd >= 0)
        close(fd);
    return NULL;
}

/* An input whose header no writer of ours makes is refused at its header, not after
 * reading it to the end or to the 3 GiB limit (cli27: -merge out.tga /dev/zero read
 * 3 GiB, 14 s, first). A FIFO fed zeros: the reader stops after its first 64 KiB, so
 * the writer meets EPIPE long before its 8 MiB (without the check it wrote them all and
 * the reader decoded them). And a regular file longer than its header allows (a 10x10
 * TGA and 200 MiB after it, sparse) is refused without being read; one with a short
 * trailer (TGA 2.0's footer) still reads. */
static void test_read_header_first(void)
{
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    char fifo[256], path[256];
    snprintf(fifo, sizeof fifo, "%s/zeros", dir);
    snprintf(path, sizeof path, "%s/long.tga", dir);
    CHECK(mkfifo(fifo, 0600) == 0);
    signal(SIGPIPE, SIG_IGN);
    ZeroWriter z = {fifo, 0};
    pthread_t t;
    CHECK(pthread_create(&t, NULL, zero_writer, &z) == 0);
    Image img;
    Diag d;
    diag_init(&d, NULL);
    CHECK(!image_read(&img, fifo, &d));
    pthread_join(t, NULL);
    CHECK_CONTAINS(d.last, "cannot read image: unsupported TGA image type 0");
    CHECK_MSG(z.written < ((size_t)8 << 20), "the reader took all %zu bytes", z.written);
    unlink(fifo);

    Image small;
    make_small(&small);
    CHECK(image_write(&small, path, &d));
    int fd = open(path, O_WRONLY);
    CHECK(fd >= 0);
    /* a 26-byte trailer: read as before */
    static const uint8_t footer[26] = {0};
    CHECK(fd >= 0 && lseek(fd, 0, SEEK_END) > 0 && write(fd, footer, sizeof footer) == 26);
    CHECK_MSG(image_read(&img, path, &d), "%s", d.last);
    image_free(&img);
    bool sized = fd >= 0 && ftruncate(fd, (off_t)200 << 20) == 0;
    if (fd >= 0)
        close(fd);
    CHECK(sized);
    CHECK(!image_read(&img, path, &d));
    CHECK_CONTAINS(d.last, "cannot read image: the file goes on past the ");
    CHECK_CONTAINS(d.last, " bytes its TGA header allows");
    struct rusage ru;
    CHECK(getrusage(RUSAGE_SELF, &ru) == 0);
    CHECK_MSG(ru.ru_maxrss < 128 * 1024, "peak memory %ld KB after reading it", ru.ru_maxrss);
    image_free(&small);
    unlink(path);
    rmdir(dir);
}

/* A file name of 248-255 bytes is valid (NAME_MAX 255) but its temporary, ".NAME.XXXXXX",
 * was 8 bytes too long: the write failed with "File name too long" (after the whole
 * render). Written now, under its own name, with no temporary file left. */
static void test_write_longest_name(void)
{
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    if (!dir)
        return;
    char name[256], path[4096];
    memset(name, 'a', 251);
    memcpy(name + 251, ".tga", 5); /* 255 bytes */
    snprintf(path, sizeof path, "%s/%s", dir, name);
    Image img;
    CHECK(image_init(&img, 3, 2));
    Diag d;
    diag_init(&d, NULL);
    CHECK_MSG(image_write(&img, path, &d), "%s", d.last);
    struct stat st;
    CHECK(stat(path, &st) == 0 && st.st_size > 18);
    CHECK_INT(count_entries(dir), 1);
    /* One byte more is refused by the check made before a render, not after it. */
    char longer[4096];
    snprintf(longer, sizeof longer, "%s/b%s", dir, name);
    CHECK(!image_check_output(longer, NULL, &d));
    CHECK_CONTAINS(d.last, "cannot write image: File name too long");
    image_free(&img);
    unlink(path);
    rmdir(dir);
}

static void test_codec_table(void)
{
    const char *names[] = {"tga", "ppm", "png"};
    for (int i = 0; i < 3; i++) {
        const ImageCodec *c = codec(names[i]);
        CHECK_STR(c->name, names[i]);
        CHECK(c->extensions && c->extensions[0]);
        for (const char *const *e = c->extensions; *e; e++) {
            char path[64], upper[64];
            snprintf(path, sizeof path, "dir.x/out%s", *e);
            CHECK(image_codec_for_path(path) == c);
            size_t k = 0;
            for (; path[k]; k++)
                upper[k] = (char)(path[k] >= 'a' && path[k] <= 'z' ? path[k] - 32 : path[k]);
            upper[k] = '\0';
            CHECK_MSG(image_codec_for_path(upper) == c, "%s", upper);
        }
        CHECK_INT(image_format_supported(names[i]), c->encode && c->decode);
        CHECK(c->encode || c->missing);
    }
    CHECK(image_codec_find("bmp") == NULL);
    CHECK(image_codec_find("TGA") == NULL);
    CHECK(image_codec_for_path("out.bmp") == NULL);
    CHECK(image_codec_for_path("out") == NULL);
    CHECK(image_codec_for_path("a.tga/out") == NULL); /* the dot must be in the file name */
    CHECK(image_codec_find("tga")->sniff == NULL);
    CHECK(image_codec_find("ppm")->sniff((const uint8_t *)"P6\n", 3));
    CHECK(!image_codec_find("ppm")->sniff((const uint8_t *)"P5\n", 3));
    CHECK(!image_codec_find("ppm")->sniff((const uint8_t *)"P", 1));
    CHECK(image_codec_find("png")->sniff((const uint8_t *)"\x89PNG\r\n\x1a\n", 8));
    CHECK(!image_codec_find("png")->sniff((const uint8_t *)"\x89PNG\r\n\x1a", 7));
    char list[128];
    image_format_list(list, sizeof list);
    CHECK_STR(list, image_format_supported("png") ? ".tga, .ppm, .png" : ".tga, .ppm");
    image_format_list(list, 8);
    CHECK_STR(list, ".tga"); /* cut at a whole entry */
}

/* Every codec of the table that reads and writes gives back what it wrote: the bytes,
 * and the region record of a -tile part (without it -merge cannot use the part), for a
 * float and a byte image. A new format is held to this without a line here. */
static void test_codec_round_trips(void)
{
    for (int i = 0; image_codec_at(i); i++) {
        const ImageCodec *c = image_codec_at(i);
        if (!c->encode || !c->decode)
            continue;
        for (int kind = 0; kind < 4; kind++) {
            Image img;
            make_small(&img);
            if (kind & 1) { /* the same colours as bytes (Image.bytes) */
                Image b;
                CHECK(image_init_bytes(&b, img.width, img.height));
                for (int y = 0; y < img.height; y++)
                    for (int x = 0; x < img.width; x++)
                        image_put(&b, x, y, image_get(&img, x, y));
                image_free(&img);
                img = b;
            }
            if (kind & 2) {
                img.has_region = true;
                img.region = (ImageRegion){4, 1, 9, 5, true, 0x0123456789abcdefull};
            }
            uint8_t *buf = NULL;
            size_t len = 0;
            char err[256] = "";
            Image back;
            CHECK(c->encode(&img, &buf, &len));
            CHECK_MSG(c->decode(buf, len, &back, err, sizeof err), "%s: %s", c->name, err);
            CHECK_MSG(back.has_region == img.has_region, "%s: region record %s", c->name,
                      img.has_region ? "lost" : "made up");
            if (img.has_region && back.has_region)
                CHECK_MSG(back.region.x == 4 && back.region.y == 1 && back.region.full_width == 9 &&
                              back.region.full_height == 5 && back.region.has_id &&
                              back.region.id == img.region.id,
                          "%s: region record changed", c->name);
            Image ref;
            make_small(&ref);
            check_same_bytes(&ref, &back);
            image_free(&ref);
            image_free(&back);
            bigmem_free(buf);
            image_free(&img);
        }
    }
}

/* A byte image (image_init_bytes, image_put) encodes to the same file bytes as a float
 * image holding the same colours, in every format this build writes, with and without a
 * region record; colours cover the quantisation's edges (negative, 0, 1/255 steps, 1,
 * above 1, NaN, infinities). */
static void test_byte_image_same_files(void)
{
    const float edge[] = {-1.0f, -0.0f, 0.0f, 0.5f / 255.0f, 1.0f / 255.0f, 0.2f, 0.999f,
                          1.0f, 1.5f, 1e30f, NAN, INFINITY, -INFINITY};
    int w = 7, h = 5, ne = (int)(sizeof edge / sizeof edge[0]);
    for (int region = 0; region < 2; region++) {
        Image f, b;
        CHECK(image_init(&f, w, h));
        CHECK(image_init_bytes(&b, w, h));
        CHECK(b.pixels == NULL && b.bytes != NULL);
        for (int y = 0; y < h; y++)
            for (int x = 0; x < w; x++) {
                int k = y * w + x;
                Vec3 c = v3(edge[k % ne], edge[(k * 5 + 1) % ne], (float)k / (float)(w * h));
                image_put(&f, x, y, c);
                image_put(&b, x, y, c);
            }
        if (region) {
            f.has_region = b.has_region = true;
            f.region = b.region = (ImageRegion){3, 4, 20, 30, true, 0x00c0ffee12345678ull};
        }
        for (int i = 0; image_codec_at(i); i++) {
            const ImageCodec *c = image_codec_at(i);
            if (!c->encode)
                continue;
            uint8_t *da = NULL, *db = NULL;
            size_t la = 0, lb = 0;
            CHECK(c->encode(&f, &da, &la));
            CHECK(c->encode(&b, &db, &lb));
            CHECK_MSG(la == lb && memcmp(da, db, la) == 0, "%s: byte image encodes differently",
                      c->name);
            bigmem_free(da);
            bigmem_free(db);
        }
        /* Rows in both orders. */
        uint8_t ra[21], rb[21];
        image_row_bytes(&f, 2, true, ra);
        image_row_bytes(&b, 2, true, rb);
        CHECK(memcmp(ra, rb, sizeof ra) == 0);
        CHECK_INT(ra[0], image_color_to_byte(image_get(&f, 0, 2).z));
        image_row_bytes(&b, 2, false, rb);
        CHECK_INT(rb[0], image_color_to_byte(image_get(&f, 0, 2).x));
        image_free(&f);
        image_free(&b);
        CHECK(b.bytes == NULL);
    }
    Image bad;
    CHECK(!image_init_bytes(&bad, 0, 3));
    CHECK(!image_init_bytes(&bad, 70000, 1));
}

/* A file made row by row (image_encoding_begin, rows in any order) holds exactly the
 * codec's encode's bytes, with and without a region record, for byte and float images;
 * PNG (no row layout) and unknown formats decline; image_write_all writes the encoded
 * bytes as they are (a marker planted in them reaches the file) and encodes outputs
 * without them as before. */
static void test_encoding_rows(void)
{
    int w = 9, h = 6;
    const char *names[] = {"x.tga", "x.ppm", "x.png", "x.bmp", "-"};
    for (int bytes = 0; bytes < 2; bytes++)
        for (int region = 0; region < 2; region++) {
            Image img;
            CHECK(bytes ? image_init_bytes(&img, w, h) : image_init(&img, w, h));
            for (int y = 0; y < h; y++)
                for (int x = 0; x < w; x++)
                    image_put(&img, x, y, v3((float)x / 9.0f, (float)y / 6.0f, 0.3f));
            if (region) {
                img.has_region = true;
                img.region = (ImageRegion){2, 1, 30, 20, false, 0};
            }
            for (size_t n = 0; n < sizeof names / sizeof names[0]; n++) {
                ImageEncoding e;
                memset(&e, 0x5a, sizeof e);
                bool begun = image_encoding_begin(&e, &img, names[n], NULL);
                const ImageCodec *c = n == 4 ? image_codec_find("tga")
                                             : image_codec_for_path(names[n]);
                bool want = c && c->layout;
                CHECK_MSG(begun == want, "%s: begun %d", names[n], begun);
                if (!begun) {
                    CHECK(e.data == NULL && e.len == 0);
                    continue;
                }
                for (int y = 0; y < h; y += 2) /* odd rows after the even ones */
                    image_encoding_row(&e, &img, y);
                for (int y = 1; y < h; y += 2)
                    image_encoding_row(&e, &img, y);
                uint8_t *ref = NULL;
                size_t len = 0;
                CHECK(c->encode(&img, &ref, &len));
                CHECK_MSG(len == e.len && memcmp(ref, e.data, len) == 0,
                          "%s (bytes %d, region %d): rows differ from encode", names[n], bytes,
                          region);
                bigmem_free(ref);
                image_encoding_free(&e);
                CHECK(e.data == NULL);
            }
            image_free(&img);
        }

    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    Image a, b;
    CHECK(image_init_bytes(&a, w, h));
    CHECK(image_init_bytes(&b, w, h));
    char pa[128], pb[128];
    snprintf(pa, sizeof pa, "%s/a.tga", dir);
    snprintf(pb, sizeof pb, "%s/b.ppm", dir);
    ImageEncoding e;
    CHECK(image_encoding_begin(&e, &a, pa, NULL));
    for (int y = 0; y < h; y++)
        image_encoding_row(&e, &a, y);
    e.data[e.len - 1] = 0xab; /* not what the image holds: proves these bytes are written */
    ImageOutput outs[2] = {{&a, pa, NULL, &e}, {&b, pb, NULL, NULL}};
    Diag d;
    diag_init(&d, NULL);
    CHECK(image_write_all(outs, 2, &d));
    FILE *f = fopen(pa, "rb");
    CHECK(f != NULL);
    if (f) {
        CHECK(fseek(f, -1, SEEK_END) == 0);
        CHECK_INT(fgetc(f), 0xab);
        CHECK(ftell(f) == (long)e.len);
        fclose(f);
    }
    CHECK(e.data != NULL); /* still the caller's */
    Image back;
    CHECK(image_read(&back, pb, &d));
    CHECK(back.width == w && back.height == h);
    image_free(&back);
    image_encoding_free(&e);
    image_free(&a);
    image_free(&b);
    unlink(pa);
    unlink(pb);
    rmdir(dir);
}

/* A whole file's bytes (malloc'd), NULL when it cannot be read. */
static uint8_t *read_all(const char *path, size_t *len)
{
    FILE *f = fopen(path, "rb");
    if (!f)
        return NULL;
    size_t cap = 1 << 16, n = 0;
    uint8_t *b = malloc(cap);
    size_t got;
    while (b && (got = fread(b + n, 1, cap - n, f)) > 0) {
        n += got;
        if (n == cap) {
            uint8_t *nb = realloc(b, cap *= 2);
            if (!nb)
                free(b);
            b = nb;
        }
    }
    fclose(f);
    *len = n;
    return b;
}

/* Whether the file system of dir gives a file its blocks ahead (fallocate). */
static bool folder_preallocates(const char *dir)
{
#if defined(__linux__)
    char probe[160];
    snprintf(probe, sizeof probe, "%s/probe", dir);
    int fd = open(probe, O_CREAT | O_WRONLY | O_EXCL, 0600);
    if (fd < 0)
        return false;
    bool ok = fallocate(fd, 0, 0, 4096) == 0;
    close(fd);
    unlink(probe);
    return ok;
#else
    (void)dir;
    return false;
#endif
}

/* A streamed file has its whole length (and disk blocks) from the start where the file
 * system allows, so that renaming it over an existing image has no blocks left to
 * allocate (ext4 would allocate and start writing them inside the rename); elsewhere
 * only the header is there yet. */
static void check_preallocated(const ImageEncoding *e, const char *dir)
{
    struct stat st;
    CHECK(fstat(e->fd, &st) == 0);
    if (folder_preallocates(dir)) {
        CHECK_INT((long long)st.st_size, (long long)e->len);
        CHECK((long long)st.st_blocks * 512 >= (long long)e->len);
    } else {
        CHECK_INT((long long)st.st_size, (long long)e->top);
    }
}

/* Streamed files (image_encoding_stream): the temporary file exists while rows are
 * flushed (in any order), image_write_all renames it into place with encode's bytes and
 * leaves nothing else; freed without a write, it is removed; a write that fails midway
 * (a file size limit) is reported by image_write_all, which removes it: no output, no
 * temporary file. Standard output is not streamed. */
static void test_encoding_stream(void)
{
    int w = 30, h = 20;
    Image img;
    CHECK(image_init_bytes(&img, w, h));
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++)
            image_put(&img, x, y, v3((float)x / 30.0f, 0.5f, (float)y / 20.0f));
    const char *names[] = {"s.tga", "s.ppm"};
    for (int n = 0; n < 2; n++) {
        char *dir = make_tmpdir();
        CHECK(dir != NULL);
        char path[128];
        snprintf(path, sizeof path, "%s/%s", dir, names[n]);
        ImageEncoding e;
        CHECK(image_encoding_begin(&e, &img, path, NULL));
        CHECK(image_encoding_stream(&e, path));
        CHECK_INT(count_entries(dir), 1); /* the temporary file */
        check_preallocated(&e, dir);
        for (int y0 = 16; y0 >= 0; y0 -= 8) { /* bands, top band (rows 16-19) first */
            int y1 = y0 + 8 < h ? y0 + 8 : h;
            for (int y = y0; y < y1; y++)
                image_encoding_row(&e, &img, y);
            image_encoding_flush(&e, y0, y1 - 1);
        }
        struct stat st;
        CHECK(stat(path, &st) != 0); /* not there before the write */
        ImageOutput out = {&img, path, NULL, &e};
        Diag d;
        diag_init(&d, NULL);
        CHECK_MSG(image_write_all(&out, 1, &d), "%s", d.last);
        CHECK_INT(count_entries(dir), 1);
        uint8_t *ref = NULL, *got = NULL;
        size_t len = 0, glen = 0;
        CHECK(image_codec_for_path(path)->encode(&img, &ref, &len));
        got = read_all(path, &glen);
        CHECK_MSG(got && glen == len && memcmp(got, ref, len) == 0, "%s: file differs",
                  names[n]);
        free(got);
        bigmem_free(ref);
        image_encoding_free(&e);
        CHECK_INT(count_entries(dir), 1);

        /* Freed without a write: nothing is left. */
        unlink(path);
        CHECK(image_encoding_begin(&e, &img, path, NULL));
        CHECK(image_encoding_stream(&e, path));
        image_encoding_flush(&e, 0, 7);
        CHECK_INT(count_entries(dir), 1);
        image_encoding_free(&e);
        CHECK_INT(count_entries(dir), 0);
        remove_tree(dir);
    }

    /* Standard output is written at the end, not streamed. */
    ImageEncoding e;
    CHECK(image_encoding_begin(&e, &img, "-", NULL));
    CHECK(!image_encoding_stream(&e, "-"));
    image_encoding_free(&e);

    /* A failing write midway: the header fits the limit, the rows do not. */
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    char path[128];
    snprintf(path, sizeof path, "%s/big.tga", dir);
    signal(SIGXFSZ, SIG_IGN);
    struct rlimit old_lim, lim;
    CHECK(getrlimit(RLIMIT_FSIZE, &old_lim) == 0);
    lim = old_lim;
    lim.rlim_cur = 600; /* the soft limit only: the test can raise it again */
    CHECK(setrlimit(RLIMIT_FSIZE, &lim) == 0);
    CHECK(image_encoding_begin(&e, &img, path, NULL));
    CHECK(image_encoding_stream(&e, path));
    for (int y = 0; y < h; y++)
        image_encoding_row(&e, &img, y);
    image_encoding_flush(&e, 0, h - 1);
    ImageOutput out = {&img, path, NULL, &e};
    Diag d;
    diag_init(&d, NULL);
    CHECK(!image_write_all(&out, 1, &d));
    CHECK_CONTAINS(d.last, "cannot write image: File too large");
    image_encoding_free(&e);
    CHECK_INT(count_entries(dir), 0);
    setrlimit(RLIMIT_FSIZE, &old_lim);
    remove_tree(dir);
    image_free(&img);
}

/* Files streamed without their rows in memory (image_encoding_stream_only, the
 * antialiased render's): only the header is held (head_only, data of top bytes), the
 * parts given by image_encoding_put -- column chunks of part rows, whole-row strips, a
 * float part and byte parts, in any order -- land at their places, and image_write_all
 * renames the file with encode's bytes (a part image's region record in the header too);
 * image_encoding_row and image_encoding_flush leave such a file alone; a part that does
 * not lie inside is ignored; freed without a write, nothing is left. Standard output and
 * PNG are not streamed, and image_write_all does not take a header-only encoding that
 * is not streamed as the file's bytes. */
static void test_encoding_stream_only(void)
{
    int w = 37, h = 23;
    Image img, fimg;
    CHECK(image_init_bytes(&img, w, h));
    CHECK(image_init(&fimg, w, h));
    for (int y = 0; y < h; y++)
        for (int x = 0; x < w; x++) {
            Vec3 c = v3((float)x / 37.0f, (float)(x ^ y) / 64.0f, (float)y / 23.0f);
            image_put(&img, x, y, c);
            image_set(&fimg, x, y, c);
        }
    /* A part of img: columns x0 .. x0 + pw - 1, rows y0 .. y0 + ph - 1. */
#define PART(dst, src, x0, y0, pw, ph, bytes)                                              \
    do {                                                                                   \
        CHECK((bytes) ? image_init_bytes(&(dst), pw, ph) : image_init(&(dst), pw, ph));    \
        for (int yy = 0; yy < (ph); yy++)                                                  \
            for (int xx = 0; xx < (pw); xx++)                                              \
                image_put(&(dst), xx, yy, image_get(&(src), (x0) + xx, (y0) + yy));        \
    } while (0)
    const char *names[] = {"o.tga", "o.ppm"};
    for (int n = 0; n < 2; n++)
        for (int region = 0; region < 2; region++) {
            char *dir = make_tmpdir();
            CHECK(dir != NULL);
            char path[128];
            snprintf(path, sizeof path, "%s/%s", dir, names[n]);
            img.has_region = region != 0;
            if (region) {
                img.region = (ImageRegion){5, 7, 100, 90, true, 0x1234abcdULL};
            }
            Image shape;
            memset(&shape, 0, sizeof shape);
            shape.width = w;
            shape.height = h;
            shape.has_region = img.has_region;
            shape.region = img.region;
            ImageEncoding e;
            CHECK(image_encoding_stream_only(&e, &shape, path, NULL));
            CHECK(e.head_only && e.fd >= 0 && e.top < 256 && e.len == e.top + (size_t)w * h * 3);
            CHECK_INT(count_entries(dir), 1); /* the temporary file */
            /* Column chunks of the top 11 rows (a float part among them), then two
             * whole-row strips, the lower one first. */
            Image p;
            int cols[] = {0, 16, 32, 37};
            for (int k = 0; k < 3; k++) {
                PART(p, fimg, cols[k], 12, cols[k + 1] - cols[k], 11, k != 1);
                image_encoding_put(&e, &p, cols[k], 12);
                image_free(&p);
            }
            PART(p, fimg, 0, 0, w, 5, true);
            image_encoding_put(&e, &p, 0, 0);
            image_free(&p);
            PART(p, fimg, 0, 5, w, 7, true);
            image_encoding_put(&e, &p, 0, 5);
            /* Outside: ignored (it would overwrite rows 5-11 with row 17's place). */
            image_encoding_put(&e, &p, 1, 5);
            image_encoding_put(&e, &p, 0, 17);
            image_free(&p);
            image_encoding_row(&e, &img, 3);
            image_encoding_flush(&e, 0, h - 1);
            ImageOutput out = {&shape, path, NULL, &e};
            Diag d;
            diag_init(&d, NULL);
            CHECK_MSG(image_write_all(&out, 1, &d), "%s", d.last);
            CHECK_INT(count_entries(dir), 1);
            uint8_t *ref = NULL, *got = NULL;
            size_t len = 0, glen = 0;
            CHECK(image_codec_for_path(path)->encode(&img, &ref, &len));
            got = read_all(path, &glen);
            CHECK_MSG(got && glen == len && memcmp(got, ref, len) == 0,
                      "%s region %d: the streamed file differs from encode's", names[n], region);
            free(got);
            bigmem_free(ref);
            image_encoding_free(&e);

            /* Freed without a write: nothing is left. */
            unlink(path);
            CHECK(image_encoding_stream_only(&e, &shape, path, NULL));
            CHECK_INT(count_entries(dir), 1);
            image_encoding_free(&e);
            CHECK_INT(count_entries(dir), 0);
            remove_tree(dir);
        }
#undef PART
    img.has_region = false;
    ImageEncoding e;
    CHECK(!image_encoding_stream_only(&e, &img, "-", NULL));
    CHECK(e.data == NULL && e.fd < 0);
    char *dir = make_tmpdir();
    CHECK(dir != NULL);
    char path[128];
    snprintf(path, sizeof path, "%s/o.png", dir);
    CHECK(!image_encoding_stream_only(&e, &img, path, NULL));
    CHECK_INT(count_entries(dir), 0);
    /* Not streamed (made by hand here): the file is encoded from the image instead. */
    snprintf(path, sizeof path, "%s/o.tga", dir);
    CHECK(image_encoding_stream_only(&e, &img, path, NULL));
    image_encoding_free(&e);
    CHECK(image_encoding_begin(&e, &img, path, NULL));
    e.head_only = true;
    ImageOutput out = {&img, path, NULL, &e};
    Diag d;
    diag_init(&d, NULL);
    CHECK_MSG(image_write_all(&out, 1, &d), "%s", d.last);
    uint8_t *ref = NULL, *got = NULL;
    size_t len = 0, glen = 0;
    CHECK(image_codec_for_path(path)->encode(&img, &ref, &len));
    got = read_all(path, &glen);
    CHECK(got && glen == len && memcmp(got, ref, len) == 0);
    free(got);
    bigmem_free(ref);
    image_encoding_free(&e);
    remove_tree(dir);
    image_free(&img);
    image_free(&fimg);
}

/* A failed decode leaves every field of the image defined (no pixels, no bytes), whatever
 * the caller's struct held before, so image_free after a failure is always safe: callers
 * (merge, imgdiff, the fuzz targets) keep an uninitialised Image on the stack. Inputs:
 * the PNG the png fuzz target found (a damaged IHDR), a truncated TGA, a bad PPM. */
static void test_failed_decode_defines_image(void)
{
    static const uint8_t bad_png[] = {
        0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a, 0x00, 0x00, 0x00, 0x49, 0x48, 0x44,
        0x52, 0x00, 0x0d, 0x49, 0x48, 0x44, 0x52, 0x00, 0x02, 0x00, 0x02, 0x00, 0x00, 0x00,
        0x03, 0x08, 0x02, 0x00, 0x00, 0x00, 0x36, 0x88, 0x49, 0xd6, 0x00, 0x00, 0x00, 0x00,
        0x49, 0x45, 0x4e, 0x44, 0xae, 0x42, 0x60, 0x82};
    static const uint8_t bad_tga[] = {0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 4, 0, 4, 0, 24, 0, 1};
    static const uint8_t bad_ppm[] = "P6\n4 4\n255\n\x01\x02";
    const struct { const char *codec; const uint8_t *data; size_t len; } cases[] = {
        {"png", bad_png, sizeof bad_png},
        {"tga", bad_tga, sizeof bad_tga},
        {"ppm", bad_ppm, sizeof bad_ppm - 1},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        const ImageCodec *c = image_codec_find(cases[i].codec);
        if (!c || !c->decode)
            continue;   /* PNG without libpng: no decoder to test */
        Image img;
        memset(&img, 0x5a, sizeof img);   /* what an uninitialised struct may hold */
        char err[256] = "";
        CHECK_MSG(!c->decode(cases[i].data, cases[i].len, &img, err, sizeof err), "%s",
                  cases[i].codec);
        CHECK_MSG(img.pixels == NULL && img.bytes == NULL, "%s left a pointer", cases[i].codec);
        CHECK_MSG(img.width == 0 && img.height == 0 && !img.has_region, "%s", cases[i].codec);
        image_free(&img);
    }
    char path[4096];
    snprintf(path, sizeof path, "%s/tests/bad/png_1gb_text_chunk.png", harness_root());
    Image img;
    memset(&img, 0x5a, sizeof img);
    Diag d;
    diag_init(&d, NULL);
    CHECK(!image_read(&img, path, &d));
    CHECK(img.pixels == NULL && img.bytes == NULL);
    image_free(&img);
}

/* The merge's test pixel at (x, y) of the whole image: every column of a part and every
 * part differs, so a column or part out of place shows. */
static Vec3 merge_pixel(int x, int y, int part_w)
{
    return v3((float)(x % 256) / 255.0f, (float)(y % 256) / 255.0f,
              (float)((x / part_w) * 37 % 256) / 255.0f);
}

static bool same_file_bytes(const char *a, const char *b)
{
    FILE *fa = fopen(a, "rb"), *fb = fopen(b, "rb");
    bool same = fa && fb;
    while (same) {
        int ca = getc(fa), cb = getc(fb);
        same = ca == cb;
        if (ca == EOF)
            break;
    }
    if (fa)
        fclose(fa);
    if (fb)
        fclose(fb);
    return same;
}

/* -merge kept each part's file open from its first strip to its last, so parts side by
 * side held one descriptor each across a strip: some 500 of them met the default limit
 * of 1024 open files ("cannot read image: Too many open files", exit 1). 130 parts of
 * 100 x 110 pixels side by side in a 13000 x 110 image (whose strips are 107 rows: every
 * part crosses the first strip's end), as TGA, PPM and PNG (when built), merge into the
 * whole image's bytes under an open-file limit of 32: with the hard limit above what
 * they need (the merge raises its soft limit), then with soft and hard both 32 (parts'
 * files are closed and opened again). The harness runs each test in a child process, so
 * the lowered limits end with it. */
static void test_merge_many_parts(void)
{
    enum { NP = 130, PW = 100, H = 110 };
    char dir[] = "/tmp/rt_merge_XXXXXX";
    if (!mkdtemp(dir)) {
        CHECK_MSG(false, "cannot make a temporary folder");
        return;
    }
    Diag d;
    diag_init(&d, NULL);
    static char paths[NP + 1][64];
    const char *parts[NP];
    Image whole;
    CHECK(image_init_bytes(&whole, NP * PW, H));
    for (int y = 0; y < H; y++)
        for (int x = 0; x < NP * PW; x++)
            image_put(&whole, x, y, merge_pixel(x, y, PW));
    snprintf(paths[NP], sizeof paths[NP], "%s/whole.tga", dir);
    CHECK_MSG(image_write(&whole, paths[NP], &d), "%s", d.last);
    image_free(&whole);
    const ImageCodec *png = image_codec_find("png");
    int kinds = png && png->encode ? 3 : 2;
    static const char *const ext[] = {"tga", "ppm", "png"};
    for (int i = 0; i < NP && !harness_failures; i++) {
        Image part;
        CHECK(image_init_bytes(&part, PW, H));
        for (int y = 0; y < H; y++)
            for (int x = 0; x < PW; x++)
                image_put(&part, x, y, merge_pixel(i * PW + x, y, PW));
        part.has_region = true;
        part.region = (ImageRegion){i * PW, 0, NP * PW, H, true, 0x5eed0123456789abull};
        snprintf(paths[i], sizeof paths[i], "%s/p%03d.%s", dir, i, ext[i % kinds]);
        parts[i] = paths[i];
        CHECK_MSG(image_write(&part, paths[i], &d), "%s", d.last);
        image_free(&part);
    }
    struct rlimit rl;
    CHECK(getrlimit(RLIMIT_NOFILE, &rl) == 0);
    for (int round = 0; round < 2 && !harness_failures; round++) {
        /* The raise needs a hard limit above the parts' count. */
        if (round == 0 && rl.rlim_max != RLIM_INFINITY && rl.rlim_max < NP + 64)
            continue;
        struct rlimit low = {32, round == 0 ? rl.rlim_max : 32};
        if (setrlimit(RLIMIT_NOFILE, &low) != 0) {
            /* valgrind keeps descriptors of its own at the top and refuses to lower the
             * hard limit (EPERM): that round cannot be set up there, and says so; the
             * soft limit's round must always run. */
            int e = errno;
            CHECK_MSG(round == 1 && e == EPERM, "setrlimit(RLIMIT_NOFILE, 32): %s",
                      strerror(e));
            fprintf(stderr, "    (hard open-file limit 32 refused here: %s; that round not "
                    "run)\n", strerror(e));
            continue;
        }
        char out[80];
        snprintf(out, sizeof out, "%s/merged%d.tga", dir, round);
        diag_init(&d, NULL);
        CHECK_MSG(image_merge(out, parts, NP, NULL, &d), "open-file limit 32, hard %s: %s",
                  round == 0 ? "higher" : "32", d.last);
        CHECK_MSG(same_file_bytes(out, paths[NP]), "open-file limit 32, hard %s: the merged "
                  "image is not the whole image's bytes", round == 0 ? "higher" : "32");
    }
    char cmd[128];
    snprintf(cmd, sizeof cmd, "rm -rf '%s'", dir);
    CHECK(system(cmd) == 0);
}

static const TestCase tests[] = {
    {"image: merge of 130 parts side by side under an open-file limit of 32", test_merge_many_parts},
    {"image: codec table: names, extensions, signatures", test_codec_table},
    {"image: every codec reads back its bytes and region record", test_codec_round_trips},
    {"image: PNG declaring a 1 GB chunk refused in little memory", test_png_huge_chunk},
    {"image: a file longer than any image refused unread", test_read_too_long},
    {"image: an input refused at its header, or past its declared length", test_read_header_first},
    {"image: a file name of 255 bytes is written", test_write_longest_name},
    {"image: image_color_to_byte truncates and clamps", test_color_to_byte},
    {"image: TGA bytes of a 3x2 image", test_tga_exact_bytes},
    {"image: TGA size fields little-endian", test_tga_size_fields_little_endian},
    {"image: TGA round trip", test_tga_round_trip},
    {"image: TGA decoder: bottom-up, 32-bit, image ID", test_tga_decode_bottom_up_and_32bit},
    {"image: TGA decoder rejects bad files", test_tga_decode_rejects},
    {"image: PPM round trip and header", test_ppm_round_trip_and_header},
    {"image: PPM comments, truncation, bad headers", test_ppm_comments_and_rejects},
    {"image: PNG round trip", test_png_round_trip},
    {"image: a PNG wider than 65535 is refused by its size", test_png_too_wide},
    {"image: write/read by extension", test_write_read_by_extension},
    {"image: replacing a file keeps its permissions", test_write_keeps_permissions},
    {"image: failed write leaves nothing", test_write_failure_leaves_nothing},
    {"image: unwritable folder", test_write_unwritable_folder},
    {"image: devices written into, links followed", test_write_devices_and_links},
    {"image: a dangling link is written through (target created)", test_write_dangling_links},
    {"image: init bounds, fill, free", test_image_init_bounds},
    {"image: a byte image writes the float image's files", test_byte_image_same_files},
    {"image_compare: figures on hand-made images", test_compare_figures},
    {"image: a failed decode leaves no pointer for image_free", test_failed_decode_defines_image},
    {"image: files made row by row = encode; written as they are", test_encoding_rows},
    {"image: streamed files: renamed whole, removed when not written or failed",
     test_encoding_stream},
    {"image: streamed without rows in memory: parts at their places, renamed whole",
     test_encoding_stream_only},
};

RT_TEST_MAIN(tests)
