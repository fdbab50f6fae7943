/* Reconstruction filters (A7 and its extra credit): box, tent, Gaussian, Mitchell-
 * Netravali. One ops table each, looked up by the name the option carries. */
#include "rt/filter.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

/* A square of half-width r, edges included, compared in float: the course's filter
 * pictures draw the edge samples white. */
static float box_weight(const Filter *f, float x, float y)
{
    return fabsf(x) <= f->r && fabsf(y) <= f->r ? 1.0f : 0.0f;
}

static float box_weight_1d(const Filter *f, float x) { return fabsf(x) <= f->r ? 1.0f : 0.0f; }

static double radius_extent(const Filter *f) { return (double)f->r; }

/* A cone: radial, not separable. d in float, 1 - d/r in double (this mix reproduces
 * every byte of the course's tent pictures, e.g. exactly 85/255 at d = 1, r = 1.5). */
static float tent_weight(const Filter *f, float x, float y)
{
    float d = sqrtf(x * x + y * y);
    if (!(d < f->r))
        return 0.0f;
    return (float)(1.0 - (double)d / (double)f->r);
}

/* Not cut off at 2 sigma: the course's pictures keep the small weights in the corners
 * of the support square. */
static float gaussian_weight(const Filter *f, float x, float y)
{
    float d2 = x * x + y * y;
    double s = (double)f->r;
    return (float)exp(-(double)d2 / (2.0 * s * s));
}

static float gaussian_weight_1d(const Filter *f, float x)
{
    double s = (double)f->r;
    return (float)exp(-(double)(x * x) / (2.0 * s * s));
}

static double gaussian_extent(const Filter *f) { return 2.0 * (double)f->r; }

/* Mitchell and Netravali's cubic (SIGGRAPH 1988) with B = C = 1/3, their recommended
 * compromise between blurring and ringing, on [-2, 2] stretched to [-r, r] and scaled to
 * 1 at the centre. Separable, as pbrt uses it. Negative lobes sharpen edges. */
static double mitchell_1d(double t)
{
    const double B = 1.0 / 3.0, C = 1.0 / 3.0;
    t = fabs(t);
    double v;
    if (t < 1.0)
        v = ((12 - 9 * B - 6 * C) * t * t * t + (-18 + 12 * B + 6 * C) * t * t + (6 - 2 * B));
    else if (t < 2.0)
        v = ((-B - 6 * C) * t * t * t + (6 * B + 30 * C) * t * t + (-12 * B - 48 * C) * t +
             (8 * B + 24 * C));
    else
        v = 0.0;
    return v / (6 - 2 * B);
}

static float mitchell_weight_1d(const Filter *f, float x)
{
    return (float)mitchell_1d(2.0 * (double)x / (double)f->r);
}

static float mitchell_weight(const Filter *f, float x, float y)
{
    return (float)(mitchell_1d(2.0 * (double)x / (double)f->r) *
                   mitchell_1d(2.0 * (double)y / (double)f->r));
}

static const FilterOps box_ops = {"box", "radius", box_weight, box_weight_1d, radius_extent};
static const FilterOps tent_ops = {"tent", "radius", tent_weight, NULL, radius_extent};
static const FilterOps gaussian_ops = {"gaussian", "sigma", gaussian_weight,
                                       gaussian_weight_1d, gaussian_extent};
static const FilterOps mitchell_ops = {"mitchell", "radius", mitchell_weight,
                                       mitchell_weight_1d, radius_extent};

static const FilterOps *const all_filters[] = {&box_ops, &tent_ops, &gaussian_ops,
                                               &mitchell_ops};

const FilterOps *filter_find(const char *name)
{
    for (size_t i = 0; i < sizeof all_filters / sizeof all_filters[0]; i++)
        if (strcmp(all_filters[i]->name, name) == 0)
            return all_filters[i];
    return NULL;
}

bool filter_init(Filter *f, const FilterOps *ops, float r, char *why, size_t whylen)
{
    memset(f, 0, sizeof *f);
    if (!(r > 0.0f) || !(r <= FILTER_MAX_RADIUS)) {
        snprintf(why, whylen, "%s %g is out of range (0, %g]", ops->param, (double)r,
                 (double)FILTER_MAX_RADIUS);
        return false;
    }
    f->ops = ops;
    f->r = r;
    /* A sample of pixel i + k lies at least |k| - 0.5 pixels from the centre of pixel i,
     * so pixels up to ceil(extent - 0.5) away can contribute ("conservative integer
     * support radius"; box 2.3 reaches 2 pixels, not 3). */
    double R = ceil(ops->extent(f) - 0.5);
    f->support = R > 0.0 ? (int)R : 0;
    return true;
}

void filter_init_default(Filter *f)
{
    char why[8];
    filter_init(f, &box_ops, 0.5f, why, sizeof why);
}
