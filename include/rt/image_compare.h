/* Image comparison used by tools/imgdiff and the tests. Differences are measured on
 * bytes (0..255) per channel, as the images are stored. */
#ifndef RT_IMAGE_COMPARE_H
#define RT_IMAGE_COMPARE_H

#include <stdbool.h>
#include "rt/image.h"

typedef struct ImageDiff {
    bool same_size;
    long pixels;
    double mean_abs;        /* mean absolute channel difference, in 1/255 units */
    int max_diff;           /* largest channel difference */
    double pct_within_1;    /* % pixels whose largest channel difference <= 1 */
    double pct_within_8;    /* % <= 8 */
    double pct_within_t;    /* % <= the threshold asked for */
    double psnr;            /* dB; INFINITY when identical */
    long identical;         /* pixels with all bytes equal */
} ImageDiff;

/* Compares a and b after the course quantisation (image_color_to_byte). */
ImageDiff image_compare(const Image *a, const Image *b, int threshold);

#endif
