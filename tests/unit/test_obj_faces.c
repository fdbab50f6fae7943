/* The OBJ reader's quick path for plain "f a b c" records against its general path:
 * the same triangles and the same located messages on the edges of the quick path
 * (last vertex, one past it, zero, leading zeros, long indices, CRLF, trailing blanks,
 * comments, slashes, signs, polygons). */
#include <stdlib.h>

#include "../harness.h"
#include "../../src/scene/obj_loader.h"

static Diag g_diag;

static bool parse(const char *text, ObjMesh *m)
{
    diag_init(&g_diag, NULL);
    return objfile_parse(text, strlen(text), "m.obj", m, &g_diag);
}

#define VERTS "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\n"

/* text1 takes the quick path (or falls back), text2 the same face written so only the
 * general path reads it: both must give the same triangle list. */
static void same_faces(const char *text1, const char *text2)
{
    ObjMesh a, b;
    bool ok1 = parse(text1, &a);
    CHECK_MSG(ok1, "'%s' failed: %s", text1, g_diag.last);
    bool ok2 = parse(text2, &b);
    CHECK_MSG(ok2, "'%s' failed: %s", text2, g_diag.last);
    if (ok1 && ok2) {
        CHECK_INT(a.ntris, b.ntris);
        if (a.ntris == b.ntris)
            CHECK_MSG(memcmp(a.tris, b.tris, (size_t)a.ntris * sizeof(int[3])) == 0,
                      "'%s' and '%s' give different triangles", text1, text2);
    }
    if (ok1)
        objfile_mesh_free(&a);
    if (ok2)
        objfile_mesh_free(&b);
}

static void same_error(const char *text, const char *msg)
{
    ObjMesh m;
    CHECK_MSG(!parse(text, &m), "'%s' parsed, expected \"%s\"", text, msg);
    CHECK_STR(g_diag.last, msg);
}

static void test_quick_matches_general(void)
{
    /* A tab before the first index sends the line to the general path. */
    same_faces(VERTS "f 1 2 3\n", VERTS "f\t1 2 3\n");
    same_faces(VERTS "f 2 3 4\n", VERTS "f\t2 3 4\n");     /* the last vertex */
    same_faces(VERTS "f 4 3 2", VERTS "f\t4 3 2");          /* no final newline */
    same_faces(VERTS "f 1 2 3\r\n", VERTS "f\t1 2 3\r\n");
    same_faces(VERTS "f 001 02 3\n", VERTS "f\t1 2 3\n");   /* leading zeros */
    same_faces(VERTS "f 0000000001 2 3\n", VERTS "f\t1 2 3\n"); /* 10 digits: general */
    same_faces(VERTS "f 1 2 3 \n", VERTS "f\t1 2 3\n");     /* trailing blank */
    same_faces(VERTS "f 1 2 3 # c\n", VERTS "f\t1 2 3\n");  /* comment */
    same_faces(VERTS "f 1 2 3# c\n", VERTS "f\t1 2 3\n");   /* ... glued to the index */
    same_faces(VERTS "f 1/1 2/2 3/3#c\n", VERTS "f\t1 2 3\n");
    same_faces(VERTS "f 1/1 2/2 3/3\n", VERTS "f\t1 2 3\n");
    same_faces(VERTS "f -4 -3 -2\n", VERTS "f\t1 2 3\n");
    same_faces(VERTS "f 1 2 3 4\n", VERTS "f\t1 2 3\nf\t1 3 4\n");
    same_faces(VERTS "f 1  2 3\n", VERTS "f\t1 2 3\n");     /* two spaces */
}

static void test_quick_path_errors(void)
{
    same_error(VERTS "f 1 2 5\n", "m.obj:5:7: error: vertex index 5 out of range (4 vertices)");
    same_error(VERTS "f 0 2 3\n", "m.obj:5:3: error: vertex index 0 out of range (indices start at 1)");
    same_error(VERTS "f 1 2 99999999999\n",
               "m.obj:5:7: error: vertex index 99999999999 out of range (4 vertices)");
    /* Past 12 digits the reader saturates the value: the message quotes the index as
     * written, not the saturated number (it said 999999999999 for this one). */
    same_error(VERTS "f 1 2 99999999999999999999\n",
               "m.obj:5:7: error: vertex index 99999999999999999999 out of range (4 vertices)");
    same_error(VERTS "f 1 -0000000000000000000005 3\n",
               "m.obj:5:5: error: vertex index -0000000000000000000005 out of range (4 vertices)");
    same_error(VERTS "f 1 2\n", "m.obj:5:1: error: face with 2 vertices (at least 3 needed)");
    same_error(VERTS "f 1 2 3x\n", "m.obj:5:7: error: malformed face vertex '3x'");
    same_error("v 0 0 0\nf 1 2 3\n", "m.obj:2:5: error: vertex index 2 out of range (1 vertices)");
}

static const TestCase tests[] = {
    {"quick_matches_general", test_quick_matches_general},
    {"quick_path_errors", test_quick_path_errors},
};

RT_TEST_MAIN(tests)
