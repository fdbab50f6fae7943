/* Tolerance comparison of two images on their stored bytes (after the course
 * quantisation), as the reference-image checks need: one grazing pixel should not
 * decide, so the figures are shares of pixels within a threshold, not only the maximum. */
#include "rt/image_compare.h"

#include <math.h>
#include <stdlib.h>

ImageDiff image_compare(const Image *a, const Image *b, int threshold)
{
    ImageDiff d = {0};
    d.same_size = a->width == b->width && a->height == b->height;
    if (!d.same_size)
        return d;
    long n = (long)a->width * a->height;
    d.pixels = n;
    if (n <= 0) {
        d.pct_within_1 = d.pct_within_8 = d.pct_within_t = 100.0;
        d.psnr = (double)INFINITY;
        return d;
    }
    double sum_abs = 0.0, sum_sq = 0.0;
    long within_1 = 0, within_8 = 0, within_t = 0;
    for (long i = 0; i < n; i++) {
        Vec3 pa = a->pixels[i], pb = b->pixels[i];
        int da[3] = {image_color_to_byte(pa.x), image_color_to_byte(pa.y),
                     image_color_to_byte(pa.z)};
        int db[3] = {image_color_to_byte(pb.x), image_color_to_byte(pb.y),
                     image_color_to_byte(pb.z)};
        int worst = 0;
        for (int k = 0; k < 3; k++) {
            int diff = abs(da[k] - db[k]);
            sum_abs += diff;
            sum_sq += (double)diff * diff;
            if (diff > worst)
                worst = diff;
        }
        if (worst > d.max_diff)
            d.max_diff = worst;
        within_1 += worst <= 1;
        within_8 += worst <= 8;
        within_t += worst <= threshold;
        d.identical += worst == 0;
    }
    double channels = 3.0 * (double)n;
    d.mean_abs = sum_abs / channels;
    d.pct_within_1 = 100.0 * (double)within_1 / (double)n;
    d.pct_within_8 = 100.0 * (double)within_8 / (double)n;
    d.pct_within_t = 100.0 * (double)within_t / (double)n;
    /* PSNR = 10 log10(255^2 / MSE), MSE over all channels in byte units. */
    double mse = sum_sq / channels;
    d.psnr = mse > 0.0 ? 10.0 * log10(255.0 * 255.0 / mse) : (double)INFINITY;
    return d;
}
