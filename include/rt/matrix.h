/* 4x4 affine matrices acting on column vectors: p' = M * (x, y, z, 1)^T.
 * m[row][col]; the translation is m[0..2][3]. Same convention as the course matrix.C. */
#ifndef RT_MATRIX_H
#define RT_MATRIX_H

#include <stdbool.h>
#include "rt/vec.h"

typedef struct Mat4 {
    float m[4][4];
} Mat4;

Mat4 mat4_identity(void);
Mat4 mat4_mul(const Mat4 *a, const Mat4 *b);              /* a * b */
/* General 4x4 inverse; returns false (and leaves *out unspecified) when singular. */
bool mat4_inverse(const Mat4 *m, Mat4 *out);
Mat4 mat4_transpose(const Mat4 *m);
Mat4 mat4_translate(Vec3 t);
Mat4 mat4_scale(Vec3 s);
Mat4 mat4_rotate_x(float degrees);                        /* right-handed, degrees */
Mat4 mat4_rotate_y(float degrees);
Mat4 mat4_rotate_z(float degrees);
/* Axis-angle (Rodrigues) from the axis as given: like the course, NOT normalised. */
Mat4 mat4_rotate_axis(Vec3 axis, float degrees);
/* Row-major 16 numbers, first four = first row. */
Mat4 mat4_from_rows(const float v[16]);

static inline Vec3 mat4_point(const Mat4 *m, Vec3 p) /* w = 1; affine matrices only */
{
    return v3(m->m[0][0] * p.x + m->m[0][1] * p.y + m->m[0][2] * p.z + m->m[0][3],
              m->m[1][0] * p.x + m->m[1][1] * p.y + m->m[1][2] * p.z + m->m[1][3],
              m->m[2][0] * p.x + m->m[2][1] * p.y + m->m[2][2] * p.z + m->m[2][3]);
}
static inline Vec3 mat4_dir(const Mat4 *m, Vec3 d) /* w = 0 */
{
    return v3(m->m[0][0] * d.x + m->m[0][1] * d.y + m->m[0][2] * d.z,
              m->m[1][0] * d.x + m->m[1][1] * d.y + m->m[1][2] * d.z,
              m->m[2][0] * d.x + m->m[2][1] * d.y + m->m[2][2] * d.z);
}
/* (M^T) * d for the upper 3x3: used with M = inverse to carry normals to world space. */
static inline Vec3 mat4_dir_transposed(const Mat4 *m, Vec3 d)
{
    return v3(m->m[0][0] * d.x + m->m[1][0] * d.y + m->m[2][0] * d.z,
              m->m[0][1] * d.x + m->m[1][1] * d.y + m->m[2][1] * d.z,
              m->m[0][2] * d.x + m->m[1][2] * d.y + m->m[2][2] * d.z);
}
bool mat4_isfinite(const Mat4 *m);

#endif
