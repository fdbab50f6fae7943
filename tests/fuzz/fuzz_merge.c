/* Fuzz target: raytracer -merge (image_merge) on part images made of the input's bytes.
 * Input layout: byte 0 gives the number of parts (1 + b % 8) and the output's format
 * ((b >> 3) % 3: TGA, PPM, PNG); then per part one byte for its format (b % 3), two bytes
 * of length (little-endian) and that many bytes of file (fewer when the input ends).
 * The parts are written into this process's temporary folder and merged. Besides no
 * crash, leak or hang, the merge must be all or nothing: when it succeeds the output
 * reads back as an image without a region record, when it fails no output file (and no
 * temporary file) is left. The seeds (tests/fuzz/seeds/merge/) pack real -tile parts of
 * a small scene in the three formats, plus overlapping, gapped and mixed-size sets. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fuzz.h"
#include "fuzz_tmp.h"
#include "rt/image.h"

enum { MERGE_MAX_PARTS = 8 };

static const char *const g_ext[3] = {"tga", "ppm", "png"};
static const char *g_dir;

int LLVMFuzzerInitialize(int *argc, char ***argv)
{
    (void)argc;
    (void)argv;
    g_dir = fuzz_tmp_dir();
    if (!g_dir)
        abort(); /* set-up of the harness itself, not an input */
    return 0;
}

static bool write_bytes(const char *path, const uint8_t *data, size_t len)
{
    FILE *f = fopen(path, "wb");
    if (!f)
        return false;
    bool ok = fwrite(data, 1, len, f) == len;
    return fclose(f) == 0 && ok;
}

/* The number of entries of the folder other than . and .. */
static int entries(const char *dir)
{
    DIR *d = opendir(dir);
    int n = 0;
    struct dirent *e;
    while (d && (e = readdir(d)) != NULL)
        n += strcmp(e->d_name, ".") != 0 && strcmp(e->d_name, "..") != 0;
    if (d)
        closedir(d);
    return n;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1 || !g_dir)
        return 0;
    int n = 1 + data[0] % MERGE_MAX_PARTS;
    const char *out_ext = g_ext[(data[0] >> 3) % 3];
    if (!image_format_supported(out_ext))
        out_ext = "tga";
    char paths[MERGE_MAX_PARTS][4200], out[4200];
    const char *parts[MERGE_MAX_PARTS];
    size_t pos = 1;
    for (int i = 0; i < n; i++) {
        size_t len = 0;
        int fmt = 0;
        if (pos < size)
            fmt = data[pos++] % 3;
        if (pos + 1 < size) {
            len = (size_t)data[pos] | (size_t)data[pos + 1] << 8;
            pos += 2;
        } else {
            pos = size;
        }
        if (len > size - pos)
            len = size - pos;
        snprintf(paths[i], sizeof paths[i], "%s/part%d.%s", g_dir, i, g_ext[fmt]);
        if (!write_bytes(paths[i], data + pos, len))
            abort(); /* the harness's own folder */
        pos += len;
        parts[i] = paths[i];
    }
    snprintf(out, sizeof out, "%s/merged.%s", g_dir, out_ext);
    Diag d;
    diag_init(&d, NULL);
    bool ok = image_merge(out, parts, n, NULL, &d);
    if (ok) {
        Image img;
        Diag rd;
        diag_init(&rd, NULL);
        if (!image_read(&img, out, &rd) || img.has_region || img.width < 1 || img.height < 1)
            abort(); /* a merge that succeeded wrote something unreadable */
        image_free(&img);
    } else if (d.errors == 0) {
        abort(); /* a refusal without a message */
    }
    /* All or nothing: a failed merge leaves no output and no temporary file. */
    if (!ok && entries(g_dir) != n)
        abort();
    for (int i = 0; i < n; i++)
        remove(paths[i]);
    remove(out);
    return 0;
}
