/* imgdiff: compares two images with a tolerance (docs/images.md) and prints the
 * figures; exit 0 when enough pixels are within the threshold, 1 when not, 2 on a usage
 * or read error. Optionally writes an amplified difference image. */
#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rt/diag.h"
#include "rt/image.h"
#include "rt/image_compare.h"

/* Each channel's byte difference is multiplied by this in the -o image, so a 1/255
 * difference is visible (and anything >= 32/255 saturates). */
enum { DIFF_GAIN = 8 };

static void usage(FILE *out)
{
    char formats[128];
    image_format_list(formats, sizeof formats);
    fprintf(out,
            "usage: imgdiff [-t threshold] [-p min_percent] [-q] a.tga b.tga [-o diff.tga]\n"
            "  Compares two images (%s) byte by byte per channel; - reads one of them\n"
            "  from standard input.\n"
            "  -t N   a pixel matches when its largest channel difference is <= N/255 "
            "(default 8)\n"
            "  -p P   pass when at least P%% of the pixels match (default 99.5)\n"
            "  -q     print nothing, only set the exit status\n"
            "  -o F   write the difference image (|a-b| x %d per channel) to F\n"
            "exit status: 0 pass, 1 images differ (or sizes differ), 2 usage or read error\n",
            formats, DIFF_GAIN);
}

static bool parse_int(const char *s, int lo, int hi, int *out)
{
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || end == s || *end || v < lo || v > hi)
        return false;
    *out = (int)v;
    return true;
}

static bool parse_double(const char *s, double lo, double hi, double *out)
{
    char *end;
    errno = 0;
    double v = strtod(s, &end);
    if (errno || end == s || *end || !(v >= lo && v <= hi))
        return false;
    *out = v;
    return true;
}

int main(int argc, char **argv)
{
    int threshold = 8;
    double min_pct = 99.5;
    bool quiet = false;
    const char *files[2] = {NULL, NULL};
    const char *diff_out = NULL;
    int nfiles = 0;

    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            usage(stdout);
            return 0;
        } else if (strcmp(a, "-q") == 0) {
            quiet = true;
        } else if (strcmp(a, "-t") == 0 || strcmp(a, "-p") == 0 || strcmp(a, "-o") == 0) {
            if (i + 1 >= argc) {
                fprintf(stderr, "imgdiff: option %s needs a value\n", a);
                usage(stderr);
                return 2;
            }
            const char *v = argv[++i];
            bool ok = true;
            if (a[1] == 't')
                ok = parse_int(v, 0, 255, &threshold);
            else if (a[1] == 'p')
                ok = parse_double(v, 0.0, 100.0, &min_pct);
            else
                diff_out = v;
            if (!ok) {
                fprintf(stderr, "imgdiff: bad value for %s: '%s'\n", a, v);
                return 2;
            }
        } else if (a[0] == '-' && a[1] != '\0') {
            fprintf(stderr, "imgdiff: unknown option '%s'\n", a);
            usage(stderr);
            return 2;
        } else if (nfiles < 2) {
            files[nfiles++] = a;
        } else {
            fprintf(stderr, "imgdiff: too many file names ('%s')\n", a);
            usage(stderr);
            return 2;
        }
    }
    if (nfiles != 2) {
        usage(stderr);
        return 2;
    }
    if (strcmp(files[0], "-") == 0 && strcmp(files[1], "-") == 0) {
        fprintf(stderr, "imgdiff: only one image can come from standard input\n");
        return 2;
    }

    Diag diag;
    diag_init(&diag, stderr);
    Image a, b;
    if (!image_read(&a, files[0], &diag))
        return 2;
    if (!image_read(&b, files[1], &diag)) {
        image_free(&a);
        return 2;
    }

    ImageDiff d = image_compare(&a, &b, threshold);
    int status;
    if (!d.same_size) {
        if (!quiet)
            printf("size differs: %dx%d vs %dx%d\nFAIL\n", a.width, a.height, b.width,
                   b.height);
        status = 1;
    } else {
        status = d.pct_within_t >= min_pct ? 0 : 1;
        if (!quiet) {
            printf("pixels          %ld (%dx%d)\n", d.pixels, a.width, a.height);
            printf("identical       %ld (%.3f%%)\n", d.identical,
                   100.0 * (double)d.identical / (double)d.pixels);
            printf("mean abs diff   %.4f /255\n", d.mean_abs);
            printf("max diff        %d /255\n", d.max_diff);
            printf("within 1/255    %.3f%%\n", d.pct_within_1);
            printf("within 8/255    %.3f%%\n", d.pct_within_8);
            /* The threshold's own line, unless it is one of the two above. */
            if (threshold != 1 && threshold != 8)
                printf("within %d/255%*s%.3f%%\n", threshold, threshold >= 100 ? 2
                       : threshold >= 10 ? 3 : 4, "", d.pct_within_t);
            if (isinf(d.psnr))
                printf("psnr            inf\n");
            else
                printf("psnr            %.2f dB\n", d.psnr);
            printf("%s (need >= %.2f%% within %d/255)\n", status == 0 ? "PASS" : "FAIL",
                   min_pct, threshold);
        }
        if (diff_out) {
            Image out;
            if (!image_init(&out, a.width, a.height)) {
                fprintf(stderr, "imgdiff: out of memory\n");
                status = 2;
            } else {
                long n = (long)a.width * a.height;
                for (long i = 0; i < n; i++) {
                    float ca[3] = {a.pixels[i].x, a.pixels[i].y, a.pixels[i].z};
                    float cb[3] = {b.pixels[i].x, b.pixels[i].y, b.pixels[i].z};
                    float c[3];
                    for (int k = 0; k < 3; k++) {
                        int diff = abs(image_color_to_byte(ca[k]) -
                                       image_color_to_byte(cb[k])) * DIFF_GAIN;
                        c[k] = (float)(diff > 255 ? 255 : diff) / 255.0f;
                    }
                    out.pixels[i] = v3(c[0], c[1], c[2]);
                }
                if (!image_write(&out, diff_out, &diag))
                    status = 2;
                image_free(&out);
            }
        }
    }
    image_free(&a);
    image_free(&b);
    return status;
}
