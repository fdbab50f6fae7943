/* Small 3-vector and colour math, header-only so the hot paths inline.
 * Colours are Vec3 too (r,g,b in x,y,z); never clamped until written to a file. */
#ifndef RT_VEC_H
#define RT_VEC_H

#include <float.h>
#include <math.h>
#include <stdbool.h>

typedef struct Vec3 {
    float x, y, z;
} Vec3;

static inline Vec3 v3(float x, float y, float z) { Vec3 r = {x, y, z}; return r; }
static inline Vec3 v3_add(Vec3 a, Vec3 b) { return v3(a.x + b.x, a.y + b.y, a.z + b.z); }
static inline Vec3 v3_sub(Vec3 a, Vec3 b) { return v3(a.x - b.x, a.y - b.y, a.z - b.z); }
static inline Vec3 v3_mul(Vec3 a, Vec3 b) { return v3(a.x * b.x, a.y * b.y, a.z * b.z); }
static inline Vec3 v3_scale(Vec3 a, float s) { return v3(a.x * s, a.y * s, a.z * s); }
static inline Vec3 v3_neg(Vec3 a) { return v3(-a.x, -a.y, -a.z); }
static inline float v3_dot(Vec3 a, Vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
static inline Vec3 v3_cross(Vec3 a, Vec3 b)
{
    return v3(a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x);
}
static inline float v3_length(Vec3 a) { return sqrtf(v3_dot(a, a)); }
/* a + s*b, the ray-point form. */
static inline Vec3 v3_madd(Vec3 a, Vec3 b, float s) { return v3(a.x + b.x * s, a.y + b.y * s, a.z + b.z * s); }
/* Unit vector; a zero vector stays zero (no division by zero, no NaN). */
static inline Vec3 v3_normalize(Vec3 a)
{
    float l = v3_length(a);
    return l > 0.0f ? v3_scale(a, 1.0f / l) : a;
}
/* The unit vector of a normal made once per primitive (a Triangle's e1 x e2, a
 * Plane's normal as given), whose squared length may leave float's range: beyond
 * about 1.8e19 it overflowed and normalize gave a zero normal (a floor Triangle with
 * vertices at 1e10 was lit by no light); below about 1e-19 its bits were lost. Where
 * the squared length is a normal float, v3_normalize's bits; else the squares, the
 * sums and the length in double, whose range holds them, rounded to float once. A
 * zero vector stays zero. */
static inline Vec3 v3_unit_wide(double x, double y, double z)
{
    double l = sqrt(x * x + y * y + z * z);
    if (!(l > 0.0) || !isfinite(l))
        return v3(0.0f, 0.0f, 0.0f);
    return v3((float)(x / l), (float)(y / l), (float)(z / l));
}
static inline Vec3 v3_normalize_wide(Vec3 a)
{
    float l2 = v3_dot(a, a);
    if (l2 >= FLT_MIN && l2 <= FLT_MAX)
        return v3_normalize(a);
    return v3_unit_wide((double)a.x, (double)a.y, (double)a.z);
}
/* normalize(a x b) so: where float's squared length fails, the cross product too in
 * double (its products of floats are exact there). */
static inline Vec3 v3_unit_cross(Vec3 a, Vec3 b)
{
    Vec3 c = v3_cross(a, b);
    float l2 = v3_dot(c, c);
    if (l2 >= FLT_MIN && l2 <= FLT_MAX)
        return v3_normalize(c);
    double ax = (double)a.x, ay = (double)a.y, az = (double)a.z;
    double bx = (double)b.x, by = (double)b.y, bz = (double)b.z;
    return v3_unit_wide(ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx);
}
static inline bool v3_is_zero(Vec3 a) { return a.x == 0.0f && a.y == 0.0f && a.z == 0.0f; }
static inline Vec3 v3_lerp(Vec3 a, Vec3 b, float t) /* t*a + (1-t)*b: weight on the FIRST */
{
    return v3_add(v3_scale(a, t), v3_scale(b, 1.0f - t));
}
static inline float v3_comp(Vec3 a, int axis) { return axis == 0 ? a.x : axis == 1 ? a.y : a.z; }
/* Plain compares, not fminf/fmaxf (libm calls without -ffast-math). NaN never reaches
 * them: the parser rejects non-finite numbers. An empty box's +/-inf works as usual. */
static inline float rt_minf(float a, float b) { return b < a ? b : a; }
static inline float rt_maxf(float a, float b) { return b > a ? b : a; }
static inline Vec3 v3_min(Vec3 a, Vec3 b) { return v3(rt_minf(a.x, b.x), rt_minf(a.y, b.y), rt_minf(a.z, b.z)); }
static inline Vec3 v3_max(Vec3 a, Vec3 b) { return v3(rt_maxf(a.x, b.x), rt_maxf(a.y, b.y), rt_maxf(a.z, b.z)); }
static inline bool v3_isfinite(Vec3 a) { return isfinite(a.x) && isfinite(a.y) && isfinite(a.z); }

/* Double-precision 3-vectors as arrays (the build geometry of accelerators). */
static inline double d3_dot(const double a[3], const double b[3])
{
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
static inline void d3_cross(const double a[3], const double b[3], double out[3])
{
    out[0] = a[1] * b[2] - a[2] * b[1];
    out[1] = a[2] * b[0] - a[0] * b[2];
    out[2] = a[0] * b[1] - a[1] * b[0];
}
static inline double d_min3(double a, double b, double c)
{
    double m = a < b ? a : b;
    return m < c ? m : c;
}
static inline double d_max3(double a, double b, double c)
{
    double m = a > b ? a : b;
    return m > c ? m : c;
}

#endif
