/* Unit tests: matrices (composition, inverse, rotations) and bounding boxes. */
#include "harness.h"
#include "rt/bbox.h"
#include "rt/matrix.h"

static void check_vec(Vec3 a, Vec3 b, double eps)
{
    CHECK_NEAR(a.x, b.x, eps);
    CHECK_NEAR(a.y, b.y, eps);
    CHECK_NEAR(a.z, b.z, eps);
}

static void test_rotations_right_handed(void)
{
    Mat4 x = mat4_rotate_x(90), y = mat4_rotate_y(90), z = mat4_rotate_z(90);
    check_vec(mat4_point(&x, v3(0, 1, 0)), v3(0, 0, 1), 1e-6);
    check_vec(mat4_point(&y, v3(0, 0, 1)), v3(1, 0, 0), 1e-6);
    check_vec(mat4_point(&z, v3(1, 0, 0)), v3(0, 1, 0), 1e-6);
    Mat4 a = mat4_rotate_axis(v3(1, 0, 0), 37.0f), b = mat4_rotate_x(37.0f);
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            CHECK_NEAR(a.m[i][j], b.m[i][j], 1e-6);
}

static void test_composition_order(void)
{
    /* Transforms apply last-written first: "Translate 1 0 0" then "Scale 2 2 2" = T * S:
     * scale first. */
    Mat4 t = mat4_translate(v3(1, 0, 0)), s = mat4_scale(v3(2, 2, 2));
    Mat4 m = mat4_mul(&t, &s);
    check_vec(mat4_point(&m, v3(1, 1, 1)), v3(3, 2, 2), 0);
    check_vec(mat4_dir(&m, v3(1, 1, 1)), v3(2, 2, 2), 0);
}

static void test_inverse(void)
{
    Mat4 r = mat4_rotate_axis(v3(0.3f, 0.5f, 0.8f), 33), s = mat4_scale(v3(2, 0.5f, 3)),
         t = mat4_translate(v3(1, -2, 5));
    Mat4 a = mat4_mul(&t, &r);
    a = mat4_mul(&a, &s);
    Mat4 inv, id;
    CHECK(mat4_inverse(&a, &inv));
    id = mat4_mul(&a, &inv);
    for (int i = 0; i < 4; i++)
        for (int j = 0; j < 4; j++)
            CHECK_NEAR(id.m[i][j], i == j ? 1.0 : 0.0, 1e-5);
    Mat4 z = mat4_scale(v3(0, 0, 0));
    CHECK(!mat4_inverse(&z, &inv));
    Mat4 flat = mat4_scale(v3(1, 1, 0));
    CHECK(!mat4_inverse(&flat, &inv));
}

/* A translation cannot make a matrix singular, so it must not count in the inverse's
 * relative pivot test: Translate 2e12 (pivots 1 against 2e12) and a rotation moved by
 * 1e15 invert, exactly enough to take the moved origin back to 0; zero and flattened
 * scales, and factors 1e13 apart, are still refused. */
static void test_inverse_far_translation(void)
{
    Mat4 r = mat4_rotate_y(30), t = mat4_translate(v3(2e12f, -3e12f, 1e15f));
    Mat4 moves[2] = {mat4_translate(v3(2e12f, 0, 0)), mat4_mul(&t, &r)};
    for (int k = 0; k < 2; k++) {
        Mat4 inv;
        CHECK_MSG(mat4_inverse(&moves[k], &inv), "case %d refused", k);
        Vec3 o = mat4_point(&moves[k], v3(0, 0, 0));
        Vec3 back = mat4_point(&inv, o);
        CHECK_MSG(fabsf(back.x) + fabsf(back.y) + fabsf(back.z) <= 1e15f * 1e-6f,
                  "case %d: the origin comes back at (%g, %g, %g)", k, (double)back.x,
                  (double)back.y, (double)back.z);
        Vec3 d = mat4_dir(&inv, v3(1, 0, 0));
        CHECK_NEAR(v3_length(d), 1, 1e-6);
    }
    Mat4 inv, flat = mat4_scale(v3(1, 0, 1)), apart = mat4_scale(v3(1e-7f, 1e6f, 1));
    Mat4 far_flat = mat4_mul(&moves[0], &flat);
    CHECK(!mat4_inverse(&far_flat, &inv));
    CHECK(!mat4_inverse(&apart, &inv));
}

static void test_from_rows_and_transpose(void)
{
    float v[16] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 0, 0, 0, 1};
    Mat4 m = mat4_from_rows(v);
    CHECK_NEAR(m.m[0][3], 4, 0);
    CHECK_NEAR(m.m[2][0], 9, 0);
    Mat4 t = mat4_transpose(&m);
    CHECK_NEAR(t.m[3][0], 4, 0);
    check_vec(mat4_dir_transposed(&m, v3(1, 0, 0)), v3(1, 2, 3), 0);
}

static void test_bbox(void)
{
    BBox e = bbox_empty();
    CHECK(bbox_is_empty(&e));
    BBox b = bbox_add_point(bbox_add_point(e, v3(-1, -1, -1)), v3(1, 1, 1));
    CHECK(!bbox_is_empty(&b));
    Mat4 r = mat4_rotate_z(45);
    BBox t = bbox_transform(&b, &r);
    CHECK_NEAR(t.max.x, sqrt(2.0), 1e-5);
    CHECK_NEAR(t.min.y, -sqrt(2.0), 1e-5);
    CHECK_NEAR(t.max.z, 1, 1e-6);
    BBox et = bbox_transform(&e, &r);
    CHECK(bbox_is_empty(&et));
    float t0, t1;
    CHECK(bbox_ray_interval(&b, v3(-5, 0, 0), v3(1, 0, 0), &t0, &t1));
    CHECK_NEAR(t0, 4, 1e-6);
    CHECK_NEAR(t1, 6, 1e-6);
    CHECK(!bbox_ray_interval(&b, v3(-5, 2, 0), v3(1, 0, 0), &t0, &t1));
    /* Axis-parallel ray on the boundary plane still counts (closed box). */
    CHECK(bbox_ray_interval(&b, v3(-5, 1, 0), v3(1, 0, 0), &t0, &t1));
}

static const TestCase tests[] = {
    {"math: rotations are right-handed", test_rotations_right_handed},
    {"math: composition order T*S", test_composition_order},
    {"math: inverse and singular matrices", test_inverse},
    {"math: inverse: a far translation is not singular", test_inverse_far_translation},
    {"math: Matrix rows and transpose", test_from_rows_and_transpose},
    {"math: bounding boxes and slabs", test_bbox},
};
RT_TEST_MAIN(tests)
