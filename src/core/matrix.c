/* 4x4 matrices for transforms (course matrix.C conventions: column vectors, m[row][col]). */
#include "rt/matrix.h"

#include <math.h>
#include <string.h>

#ifndef M_PI
#define M_PI 3.14159265358979323846
#endif

Mat4 mat4_identity(void)
{
    Mat4 r;
    memset(&r, 0, sizeof r);
    for (int i = 0; i < 4; i++)
        r.m[i][i] = 1.0f;
    return r;
}

Mat4 mat4_mul(const Mat4 *a, const Mat4 *b)
{
    Mat4 r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            float s = 0.0f;
            for (int k = 0; k < 4; k++)
                s += a->m[i][k] * b->m[k][j];
            r.m[i][j] = s;
        }
    return r;
}

Mat4 mat4_transpose(const Mat4 *m)
{
    Mat4 r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            r.m[i][j] = m->m[j][i];
    return r;
}

/* Gauss-Jordan elimination with partial pivoting in double precision: the inverse of
 * a scene transform is computed once, so accuracy matters more than speed here. */
bool mat4_inverse(const Mat4 *m, Mat4 *out)
{
    double a[4][8];
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            a[i][j] = (double)m->m[i][j];
            a[i][j + 4] = (i == j) ? 1.0 : 0.0;
        }
    /* The pivots are judged against the largest entry of the linear part and of the
     * last row (0 0 0 1 for an affine matrix), not of the translation: a translation
     * cannot make a matrix singular, yet "Translate 2e12 0 0" was refused, its pivots
     * of 1 being below 1e-12 of 2e12 (while a Sphere at x = 2e12 is fine). The scale
     * is the old one or smaller, so every matrix accepted before is inverted by the
     * same operations (the same bits) and only such ones are accepted anew. */
    double scale = 0.0;
    bool finite = true;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++) {
            finite = finite && isfinite(a[i][j]);
            if (j < 3 || i == 3)
                scale = fmax(scale, fabs(a[i][j]));
        }
    if (!(scale > 0.0) || !finite)
        return false;
    for (int col = 0; col < 4; col++) {
        int piv = col;
        for (int r = col + 1; r < 4; r++)
            if (fabs(a[r][col]) > fabs(a[piv][col]))
                piv = r;
        /* Relative threshold: Scale 0 0 0 or a flattened Matrix is singular. */
        if (fabs(a[piv][col]) <= 1e-12 * scale)
            return false;
        if (piv != col)
            for (int j = 0; j < 8; j++) {
                double t = a[col][j];
                a[col][j] = a[piv][j];
                a[piv][j] = t;
            }
        double inv = 1.0 / a[col][col];
        for (int j = 0; j < 8; j++)
            a[col][j] *= inv;
        for (int r = 0; r < 4; r++) {
            if (r == col || a[r][col] == 0.0)
                continue;
            double f = a[r][col];
            for (int j = 0; j < 8; j++)
                a[r][j] -= f * a[col][j];
        }
    }
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            out->m[i][j] = (float)a[i][j + 4];
    return mat4_isfinite(out);
}

Mat4 mat4_translate(Vec3 t)
{
    Mat4 r = mat4_identity();
    r.m[0][3] = t.x;
    r.m[1][3] = t.y;
    r.m[2][3] = t.z;
    return r;
}

Mat4 mat4_scale(Vec3 s)
{
    Mat4 r = mat4_identity();
    r.m[0][0] = s.x;
    r.m[1][1] = s.y;
    r.m[2][2] = s.z;
    return r;
}

static float deg2rad(float d) { return d * (float)(M_PI / 180.0); }

Mat4 mat4_rotate_x(float degrees)
{
    float t = deg2rad(degrees), c = cosf(t), s = sinf(t);
    Mat4 r = mat4_identity();
    r.m[1][1] = c;
    r.m[1][2] = -s;
    r.m[2][1] = s;
    r.m[2][2] = c;
    return r;
}

Mat4 mat4_rotate_y(float degrees)
{
    float t = deg2rad(degrees), c = cosf(t), s = sinf(t);
    Mat4 r = mat4_identity();
    r.m[0][0] = c;
    r.m[0][2] = s;
    r.m[2][0] = -s;
    r.m[2][2] = c;
    return r;
}

Mat4 mat4_rotate_z(float degrees)
{
    float t = deg2rad(degrees), c = cosf(t), s = sinf(t);
    Mat4 r = mat4_identity();
    r.m[0][0] = c;
    r.m[0][1] = -s;
    r.m[1][0] = s;
    r.m[1][1] = c;
    return r;
}

/* Rodrigues' formula with the axis components as given, like the course's
 * Matrix::MakeAxisRotation (which does not normalise the axis). */
Mat4 mat4_rotate_axis(Vec3 a, float degrees)
{
    float t = deg2rad(degrees), c = cosf(t), s = sinf(t), k = 1.0f - c;
    Mat4 r = mat4_identity();
    r.m[0][0] = a.x * a.x * k + c;
    r.m[0][1] = a.x * a.y * k - a.z * s;
    r.m[0][2] = a.x * a.z * k + a.y * s;
    r.m[1][0] = a.y * a.x * k + a.z * s;
    r.m[1][1] = a.y * a.y * k + c;
    r.m[1][2] = a.y * a.z * k - a.x * s;
    r.m[2][0] = a.z * a.x * k - a.y * s;
    r.m[2][1] = a.z * a.y * k + a.x * s;
    r.m[2][2] = a.z * a.z * k + c;
    return r;
}

Mat4 mat4_from_rows(const float v[16])
{
    Mat4 r;
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            r.m[i][j] = v[i * 4 + j];
    return r;
}

bool mat4_isfinite(const Mat4 *m)
{
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            if (!isfinite(m->m[i][j]))
                return false;
    return true;
}
