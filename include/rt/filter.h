/* Reconstruction filters (A7): a weight function of the offset (x, y) in pixels from
 * the centre of the pixel being computed, and the integer support radius R: only the
 * samples of pixels i-R..i+R, j-R..j+R can have a non-zero weight for pixel (i, j). */
#ifndef RT_FILTER_H
#define RT_FILTER_H

#include <stdbool.h>
#include <stddef.h>

/* Largest radius (box, tent, Mitchell) or sigma (Gaussian) accepted: the support then
 * spans at most 33 x 33 pixels, (2R+1)^2 neighbours per output pixel. */
#define FILTER_MAX_RADIUS 16.0f

typedef struct Filter Filter;

typedef struct FilterOps {
    const char *name;          /* the option is -<name>_filter ("box") */
    const char *param;         /* what its argument is: "radius" or "sigma" */
    /* The weight at (x, y). Evaluated as the course's images require: box compared in
     * float; tent and Gaussian with d^2 = x*x + y*y and d in float, the formula in double,
     * the weight rounded to float. May be negative (Mitchell). */
    float (*weight)(const Filter *f, float x, float y);
    /* Non-NULL when the filter is separable: weight(x, y) == w1(x) * w1(y) up to float
     * rounding. The film uses it for random sample positions (2(2R+1) evaluations per
     * sample instead of (2R+1)^2). */
    float (*weight_1d)(const Filter *f, float x);
    /* Optional batch form of weight_1d: w[i] = weight_1d(f, x[i]) for i < n, the same
     * bits, in one call (the film asks for the 2(2R+1) weights of a pixel's samples
     * together, which a filter can compute in vector lanes). NULL: weight_1d each. */
    void (*weights_1d)(const Filter *f, const float *x, float *w, int n);
    /* Optional form of filter_weights_1d_offsets (below), the same bits, for a filter
     * that makes the arguments in its own lanes. NULL: the arguments in double, rounded
     * to float, through weights_1d (or weight_1d each). */
    void (*weights_1d_offsets)(const Filter *f, const float *pos, int n, int R, float *w,
                               size_t plane);
    /* Half-width beyond which the weight is negligible or zero: r, or 2 sigma. */
    double (*extent)(const Filter *f);
    /* The weight is negative somewhere in the support (Mitchell's lobes): the film then
     * guards against weight sums near or below zero (filter_has_negative_lobes). A
     * filter that is never negative leaves it false; test_antialias checks every filter
     * of filter_registry against its own weights. */
    bool negative_lobes;
} FilterOps;

struct Filter {
    const FilterOps *ops;
    float r;                   /* radius or sigma (float, like the course's atof) */
    int support;               /* R = ceil(extent - 0.5), at least 0 */
    /* The Gaussian's constants (0 for the other filters): ni = -1/(2 sigma^2) in
     * double, rounded to float once (the weight is exp(ni x^2)), and the factors
     * between a sample's weights towards neighbouring pixels, exp(ni) and exp(4 ni),
     * each rounded to float once (filter.c, FILTER_STEPS). Set once by filter_init:
     * the film asks for weights many thousand times a render. */
    float gauss_ni, gauss_e1, gauss_e4;
};

/* The filters, in the order -h lists them; NULL-terminated. */
extern const FilterOps *const filter_registry[];
/* The filter whose option is -<name>_filter; NULL when unknown. The options parser
 * takes -<name>_filter for every filter of filter_registry; the -h text, README.txt and
 * the manual page list them by hand. */
const FilterOps *filter_find(const char *name);
/* Sets up a filter; false with a one-line reason in why unless 0 < r <= FILTER_MAX_RADIUS. */
bool filter_init(Filter *f, const FilterOps *ops, float r, char *why, size_t whylen);
/* The default when no filter option is given: box of radius 0.5, the plain average of the
 * pixel's own samples (one centred sample: the A6 pixel exactly). */
void filter_init_default(Filter *f);

static inline float filter_weight(const Filter *f, float x, float y)
{
    return f->ops->weight(f, x, y);
}

/* Whether f is the box filter (weight 1 where |x| <= r and |y| <= r, compared in float,
 * else 0): the film sums a pixel's own samples without a call per weight. */
bool filter_is_box(const Filter *f);

/* Whether f has negative lobes (Mitchell; FilterOps.negative_lobes): a pixel's weight
 * sum may then come out small or negative with few samples, which the film guards
 * against (film.c, film_fix_lobes). */
bool filter_has_negative_lobes(const Filter *f);

/* w[i] = the separable weight_1d at x[i] for i < n (ops->weights_1d when the filter
 * has one, else one call each); the filter must have weight_1d. */
void filter_weights_1d(const Filter *f, const float *x, float *w, int n);

/* The separable weights of n sample positions towards the 2R+1 pixels around:
 * w[k * plane + i] = weight_1d(f, (float)((double)pos[i] - 0.5 - R + k)) for k <= 2R,
 * i < n, the argument's sum in double rounded to float once (the film's offset from
 * the centre of pixel k - R). The same bits as filter_weights_1d on those arguments;
 * the Gaussian makes them in its vector lanes. Except the Gaussian at R = 1 and 2 (and
 * sigma >= 1/4) for positions in [0, 1]: their weights are made from the position, the
 * Gaussian at the offsets u - R + k exactly, u = pos - 0.5 rounded to float (two exps a
 * position, filter.c's FILTER_STEPS), within 8 ulps of the exact weights; the centre
 * weight (k = R) is weight_1d's bits, the others may differ from weight_1d's by a few
 * ulps. The same bits on every vector path and CPU, for any n and offset in a batch. */
void filter_weights_1d_offsets(const Filter *f, const float *pos, int n, int R, float *w,
                               size_t plane);

/* filter_weights_1d_offsets for nblk groups of eight positions whose weights lie in
 * separate blocks: position 8v + i (i < 8) has weight k at w[v * bstride + k * plane + i],
 * the same bits as filter_weights_1d_offsets gives it (the film's tile rows: a sample
 * slot's positions of eight pixels at a time, each group's 2R+1 weights towards its own
 * planes). */
void filter_weights_1d_blocks(const Filter *f, const float *pos, int nblk, int R, float *w,
                              size_t plane, size_t bstride);

/* exp(t) for t <= 0 in float without libm, the separable Gaussian's: within about an ulp
 * of exp(t) rounded to float (subnormals included), exactly 1 at 0, 0 below -104 and for
 * NaN. The same bits on every path and CPU (its operations are plain IEEE single ones, in
 * one order). Tested against libm in tests/unit/test_antialias.c. */
float filter_expf(float t);

/* The widest vector path the separable Gaussian may use: 0 the plain build, 1 AVX2,
 * 2 AVX-512 (the default; a path the CPU lacks is never taken). For tests, which hold
 * every path to the plain build's bits; call it before any render starts. */
void filter_gaussian_path_set(int cap);

#endif
