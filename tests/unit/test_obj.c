/* OBJ reader tests: record forms, fans, negative indices, CRLF, located errors, the float
 * fast path against strtof, and the official meshes against a course-style reader. */
#define _POSIX_C_SOURCE 200809L
#include <stdint.h>
#include <stdlib.h>

#include "../harness.h"
#include "../../src/scene/obj_loader.h"
#include "rt/bigmem.h"
#include "rt/file.h"

static Diag g_diag;

static bool parse(const char *text, ObjMesh *m)
{
    diag_init(&g_diag, NULL);
    return objfile_parse(text, strlen(text), "m.obj", m, &g_diag);
}

#define EXPECT_OBJ_ERROR(text, msg) \
    do { \
        ObjMesh m_; \
        CHECK_MSG(!parse((text), &m_), "parsed, expected \"%s\"", (msg)); \
        CHECK_CONTAINS(g_diag.last, (msg)); \
        CHECK(m_.verts == NULL && m_.tris == NULL); \
    } while (0)

static void check_tri(const ObjMesh *m, int i, int a, int b, int c)
{
    CHECK_MSG(i < m->ntris, "triangle %d missing (%d triangles)", i, m->ntris);
    if (i >= m->ntris)
        return;
    CHECK_MSG(m->tris[i][0] == a && m->tris[i][1] == b && m->tris[i][2] == c,
              "triangle %d = (%d %d %d), expected (%d %d %d)", i, m->tris[i][0],
              m->tris[i][1], m->tris[i][2], a, b, c);
}

static void test_basic(void)
{
    ObjMesh m;
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", &m));
    CHECK_INT(m.nverts, 3);
    CHECK_INT(m.ntris, 1);
    check_tri(&m, 0, 0, 1, 2);
    CHECK_NEAR(m.verts[1].x, 1, 0);
    CHECK_NEAR(m.verts[2].y, 1, 0);
    objfile_mesh_free(&m);
    /* Empty input: nothing, no error (the scene parser rejects a mesh without faces). */
    CHECK(parse("", &m));
    CHECK_INT(m.nverts, 0);
    CHECK_INT(m.ntris, 0);
    objfile_mesh_free(&m);
}

static void test_slash_forms(void)
{
    ObjMesh m;
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\n"
                "f 1/1/1 2/2/2 3/3/3\nf 2//1 4//1 3//1\nf 1/5 3/6 4/7\n", &m));
    CHECK_INT(m.ntris, 3);
    check_tri(&m, 0, 0, 1, 2);
    check_tri(&m, 1, 1, 3, 2);
    check_tri(&m, 2, 0, 2, 3);
    objfile_mesh_free(&m);
}

static void test_polygon_fan(void)
{
    ObjMesh m;
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 2 1 0\nv 1 2 0\nv 0 1 0\nf 1 2 3 4 5\n", &m));
    CHECK_INT(m.ntris, 3);
    check_tri(&m, 0, 0, 1, 2);
    check_tri(&m, 1, 0, 2, 3);
    check_tri(&m, 2, 0, 3, 4);
    objfile_mesh_free(&m);
}

static void test_negative_indices(void)
{
    ObjMesh m;
    /* Relative to the vertices read so far (OBJ standard). */
    CHECK(parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\nv 5 5 5\nf -1 -3 -4\n", &m));
    CHECK_INT(m.ntris, 2);
    check_tri(&m, 0, 0, 1, 2);
    check_tri(&m, 1, 3, 1, 0);
    objfile_mesh_free(&m);
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nf -1 -2 -3\n",
                     "m.obj:3:9: error: vertex index -3 out of range (2 vertices)");
}

static void test_crlf_comments_ignored_records(void)
{
    ObjMesh m;
    CHECK(parse("# a comment with v and f inside\r\n"
                "mtllib x.mtl\r\no thing\r\ng group\r\ns 1\r\nusemtl red\r\n"
                "\r\n   \r\n"
                "v 0 0 0 1\r\n\tv 1 0 0\r\nv 0 1 0 0.5 0.5 0.5\r\n"
                "vn 0 0 1\r\nvt 0 0\r\nvp 1\r\nl 1 2\r\n"
                "f 1 2 3 # trailing comment\r\nf 1 2 3", &m)); /* no final newline */
    CHECK_INT(m.nverts, 3);
    CHECK_INT(m.ntris, 2);
    check_tri(&m, 1, 0, 1, 2);
    CHECK_NEAR(m.verts[1].x, 1, 0);
    objfile_mesh_free(&m);
}

/* The quick readers take a v or f record whose last number is followed by the line's end
 * (LF or CR LF), blanks or a comment, as the general readers would read it (the same
 * vertices and triangles); more numbers after a vertex's three go to the general reader,
 * which checks them. b502bad sent every vertex with a comment after it to the general
 * reader (21% more instructions for the 40k bunny with a comment on every line). */
static void test_quick_readers_take_common_endings(void)
{
    ObjMesh m;
    unsigned long before = objfile_general_records();
    CHECK(parse("v 0 0 0\n"
                "v 1 0 0\r\n"
                "v 0 1 0 # a comment\n"
                "v 0 0 1#glued\n"
                "v 1 1 0 \t\n"
                "v 1 0 1 \r\n"
                "v 0 1 1  # CR LF and a comment\r\n"
                "f 1 2 3\n"
                "f 1 2 4 # c\n"
                "f 1 2 5#c\r\n"
                "f 1 2 6 \n"
                "f 1 2 7\t# c",
                &m));
    /* One: the first vertex, for which the general reader makes the array. */
    CHECK_MSG(objfile_general_records() - before == 1,
              "%lu of the 12 records went to the general readers, expected 1",
              objfile_general_records() - before);
    CHECK_INT(m.nverts, 7);
    CHECK_INT(m.ntris, 5);
    for (int i = 0; i < 5; i++)
        check_tri(&m, i, 0, 1, 2 + i);
    static const float want[7][3] = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1},
                                     {1, 1, 0}, {1, 0, 1}, {0, 1, 1}};
    for (int i = 0; i < m.nverts && i < 7; i++)
        CHECK_MSG(m.verts[i].x == want[i][0] && m.verts[i].y == want[i][1] &&
                      m.verts[i].z == want[i][2],
                  "vertex %d = (%g %g %g)", i, (double)m.verts[i].x, (double)m.verts[i].y,
                  (double)m.verts[i].z);
    objfile_mesh_free(&m);
    /* A w coordinate, and a face of four vertices: the general readers' (and counted). */
    before = objfile_general_records();
    CHECK(parse("v 0 0 0 1\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3 4\n", &m));
    CHECK_MSG(objfile_general_records() - before == 2, "%lu general records, expected 2",
              objfile_general_records() - before);
    CHECK_INT(m.ntris, 2);
    objfile_mesh_free(&m);
}

static void test_errors(void)
{
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 205\n",
                     "m.obj:4:7: error: vertex index 205 out of range (3 vertices)");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
                     "m.obj:4:3: error: vertex index 0 out of range (indices start at 1)");
    /* Faces only see the vertices read before them. */
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nf 1 2 3\nv 0 1 0\n",
                     "m.obj:3:7: error: vertex index 3 out of range (2 vertices)");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 x\n", "m.obj:2:7: error: malformed number 'x'");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 1.5.3\n", "m.obj:2:7: error: malformed number '1.5.3'");
    /* A decimal comma (an exporter in a European locale) is named as such. */
    EXPECT_OBJ_ERROR("v 1,5 0 0\n", "m.obj:1:3: error: malformed number '1,5' (numbers are "
                     "separated by white space, and their decimal point is '.')");
    EXPECT_OBJ_ERROR("v 0 0 -0,25\n", "malformed number '-0,25' (numbers are separated");
    EXPECT_OBJ_ERROR("v 0 0 x,1\n", "malformed number 'x,1'");
    CHECK(strstr(g_diag.last, "decimal") == NULL);
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0\nv 1 1 1\n", "m.obj:2:6: error: vertex needs 3 coordinates, found 2");
    EXPECT_OBJ_ERROR("v 0 0 #1\n", "m.obj:1:7: error: vertex needs 3 coordinates, found 2");
    /* After the coordinates only a w or a colour (at most four numbers) or a comment:
     * a word there is an error, not skipped (a lost line break would drop a vertex). */
    EXPECT_OBJ_ERROR("v 0 0 0 garbage\n",
                     "m.obj:1:9: error: unexpected 'garbage' after the vertex's coordinates");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0 v 0 1 0\n",
                     "m.obj:2:9: error: unexpected 'v' after the vertex's coordinates");
    EXPECT_OBJ_ERROR("v 0 0 0 1 2 3 4 5\n",
                     "m.obj:1:17: error: unexpected '5' after the vertex's coordinates");
    EXPECT_OBJ_ERROR("v 0 0 0 1x\n", "m.obj:1:9: error: unexpected '1x' after the vertex's");
    EXPECT_OBJ_ERROR("v 0 0 0\rv 1 0 0\rv 0 1 0\r",
                     "m.obj:1:9: error: unexpected 'v' after the vertex's coordinates (a lone "
                     "CR ends no line");
    /* Lone CRs that begin after the faces do: the face's message says so too. */
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\rf 1 2 3\r",
                     "m.obj:4:9: error: malformed face vertex 'f' (a lone CR ends no line");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 f\n", "malformed face vertex 'f'");
    CHECK(strstr(g_diag.last, "lone CR") == NULL);
    /* Capital V and F (a file typed by hand) are errors, not unknown records skipped. */
    EXPECT_OBJ_ERROR("V 0 0 0\nV 1 0 0\nV 0 1 0\nF 1 2 3\n",
                     "m.obj:1:1: error: 'V' is not an OBJ record (keywords are lower case: "
                     "did you mean 'v'?)");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\n  F 1 2 3\n",
                     "m.obj:4:3: error: 'F' is not an OBJ record (keywords are lower case: "
                     "did you mean 'f'?)");
    EXPECT_OBJ_ERROR("v 1 1 1e999\n", "m.obj:1:7: error: number out of range: '1e999'");
    EXPECT_OBJ_ERROR("v 1 1 nan\n", "m.obj:1:7: error: number out of range: 'nan'");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\n  f 1 2\n",
                     "m.obj:4:3: error: face with 2 vertices (at least 3 needed)");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3a\n", "m.obj:4:7: error: malformed face vertex '3a'");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2/x/3 3\n", "m.obj:4:5: error: malformed face vertex '2/x/3'");
    EXPECT_OBJ_ERROR("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999\n",
                     "m.obj:4:7: error: vertex index");
    EXPECT_OBJ_ERROR("v 0 0 0\r\nf 1 1 1\r\nf 1 1 2\r\n", "m.obj:3:7: error: vertex index 2 out of range (1 vertices)");
    /* A UTF-8 byte-order mark at the start is skipped; columns count after it. */
    EXPECT_OBJ_ERROR("\xEF\xBB\xBF" "v 1 1 nan\n", "m.obj:1:7: error: number out of range: 'nan'");
    ObjMesh m;
    diag_init(&g_diag, NULL);
    {
        static const char bom[] = "\xEF\xBB\xBF" "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
        CHECK_MSG(objfile_parse(bom, sizeof bom - 1, "m.obj", &m, &g_diag), "%s", g_diag.last);
        CHECK_INT(m.ntris, 1);
        CHECK_INT(m.nverts, 3);
        objfile_mesh_free(&m);
    }
    /* Two files joined with cat, the second with its own BOM: a BOM at the start of a
     * line is skipped too (the second file's first vertex was an unknown record, and
     * its face took the wrong vertices); it counts as a column, as an editor shows it. */
    {
        static const char joined[] = "\xEF\xBB\xBF" "v 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nf 1 2 3\r\n"
                                     "\xEF\xBB\xBF" "v 0 0 1\r\nv 1 0 1\r\nv 0 1 1\r\nf -3 -2 -1\r\n"
                                     "\xEF\xBB\xBF" "f 4 5 6\r\n";
        CHECK_MSG(objfile_parse(joined, sizeof joined - 1, "m.obj", &m, &g_diag), "%s",
                  g_diag.last);
        CHECK_INT(m.nverts, 6);
        CHECK_INT(m.ntris, 3);
        check_tri(&m, 1, 3, 4, 5);
        check_tri(&m, 2, 3, 4, 5);
        CHECK_NEAR(m.verts[3].z, 1, 0);
        objfile_mesh_free(&m);
    }
    EXPECT_OBJ_ERROR("v 0 0 0\n\xEF\xBB\xBF" "v 1 0 x\n", "m.obj:2:8: error: malformed number 'x'");
    CHECK(!objfile_parse("v 0 0 0\nv 1\0 0 0\n", 17, "m.obj", &m, &g_diag));
    CHECK_CONTAINS(g_diag.last, "m.obj:2:4: error: NUL byte: not a text OBJ file");
    /* Columns count characters: "é" and "→" in a comment are 2 and 3 bytes but one
     * column each (a BOM before them none). */
    {
        static const char utf8[] = "\xEF\xBB\xBF" "v 0 0 0 # \xC3\xA9\xE2\x86\x92\0";
        CHECK(!objfile_parse(utf8, sizeof utf8 - 1, "m.obj", &m, &g_diag));
        CHECK_CONTAINS(g_diag.last, "m.obj:1:13: error: NUL byte");
    }
}

/* objfile_parse_float must give exactly strtof's float (fscanf %f) for every input. */
static void check_float_same(const char *s)
{
    const char *p = s;
    float got = 0;
    bool ok = objfile_parse_float(&p, s + strlen(s), &got);
    char *e;
    float want = strtof(s, &e);
    CHECK_MSG(ok == (e != s), "'%s': ok %d", s, ok);
    if (ok && e != s) {
        CHECK_MSG(memcmp(&got, &want, sizeof got) == 0, "'%s': %.9g, strtof %.9g", s,
                  (double)got, (double)want);
        CHECK_MSG(p == e, "'%s': consumed %d, strtof %d", s, (int)(p - s), (int)(e - s));
    }
}

static void test_float_matches_strtof(void)
{
    static const char *fixed[] = {
        "0", "-0", "0.", ".5", "-.3", "+2", "1e-3", "1E+2", "16777216", "16777217",
        "16777215.5", "0.1", "0.2", "0.3", "3.4028235e38", "3.4028236e38", "1e-45",
        "1.17549435e-38", "-0.0766682", "0.00925504", "123456789012345678901234",
        "0.000000000000000000000000001", "9999999999", "1e10", "1e-10", "1e11", "1e-11",
        "0x1p3", "1.5e", "1e+", "-", ".", "e5", "12abc", "inf", "nan", "1.0000001",
        "0.30000001192092896", "7.038531e-26", "2.5", "-2.5e-3", "00001.2500000"};
    for (size_t i = 0; i < sizeof fixed / sizeof fixed[0]; i++)
        check_float_same(fixed[i]);
    uint32_t rng = 2024u;
    char buf[64];
    for (int i = 0; i < 200000; i++) {
        rng = rng * 1664525u + 1013904223u;
        uint32_t r = rng;
        int intd = (int)(r % 4), fracd = (int)((r >> 2) % 10);
        size_t o = 0;
        if (r & 0x1000)
            buf[o++] = '-';
        for (int k = 0; k < intd; k++) {
            rng = rng * 1664525u + 1013904223u;
            buf[o++] = (char)('0' + (rng >> 20) % 10);
        }
        if (fracd || !intd) {
            buf[o++] = '.';
            for (int k = 0; k < fracd || (!intd && k == 0); k++) {
                rng = rng * 1664525u + 1013904223u;
                buf[o++] = (char)('0' + (rng >> 20) % 10);
            }
        }
        if ((r >> 8) % 5 == 0)
            o += (size_t)snprintf(buf + o, sizeof buf - o, "e%d", (int)((r >> 12) % 30) - 15);
        buf[o] = '\0';
        check_float_same(buf);
    }
}

/* Vertex records, read by the quick reader (read_vertex_simple) or, for anything it
 * does not take, by the general one: every coordinate exactly strtof's, whichever reads
 * it. Random numbers of the quick form and around its limits (9 and 10 digits, 2^24,
 * leading zeros, '+', exponents, '.5', '5.'), with single and other separators, CR LF,
 * a fourth coordinate and a trailing comment. */
static void test_vertex_lines_match_strtof(void)
{
    enum { LINES = 20000 };
    static const char *odd[] = {"16777216", "16777217", "16777216.0", "1677721.7",
                                "0.000000001", "0000000001", "00000000001", "123456789",
                                "1234567890", "+1.5", "1e2", "-1.5E-2", ".5", "5.", "-0",
                                "-0.0", "999999999", "0.99999999", "4294967297",
                                "4294967.297", "-42949.67297"};
    static const char *seps[] = {" ", " ", " ", " ", "\t", "  "};
    static const char *ends[] = {"\n", "\n", "\n", "\r\n", " 1\n", " # c\n", "\t\n", "#c\n",
                                 " 1 0.5 0.5 0.5\n"};
    size_t cap = (size_t)LINES * 96, len = 0;
    char *text = malloc(cap);
    float(*want)[3] = malloc(LINES * sizeof *want);
    CHECK(text && want);
    if (!text || !want) {
        free(text);
        free(want);
        return;
    }
    uint32_t rng = 77u;
    for (int i = 0; i < LINES; i++) {
        len += (size_t)snprintf(text + len, cap - len, "v");
        for (int c = 0; c < 3; c++) {
            rng = rng * 1664525u + 1013904223u;
            char num[40];
            if (rng % 7 == 0) {
                snprintf(num, sizeof num, "%s", odd[(rng >> 8) % (sizeof odd / sizeof *odd)]);
            } else { /* -d.ddddddd: 1-4 integer digits, 0-8 in the fraction */
                int intd = 1 + (int)((rng >> 4) % 4), fracd = (int)((rng >> 6) % 9);
                size_t o = 0;
                if (rng & 0x400)
                    num[o++] = '-';
                for (int k = 0; k < intd; k++) {
                    rng = rng * 1664525u + 1013904223u;
                    num[o++] = (char)('0' + (rng >> 20) % 10);
                }
                if (fracd)
                    num[o++] = '.';
                for (int k = 0; k < fracd; k++) {
                    rng = rng * 1664525u + 1013904223u;
                    num[o++] = (char)('0' + (rng >> 20) % 10);
                }
                num[o] = '\0';
            }
            want[i][c] = strtof(num, NULL);
            len += (size_t)snprintf(text + len, cap - len, "%s%s",
                                    seps[(rng >> 12) % (sizeof seps / sizeof *seps)], num);
        }
        len += (size_t)snprintf(text + len, cap - len, "%s",
                                ends[(rng >> 16) % (sizeof ends / sizeof *ends)]);
    }
    ObjMesh m;
    CHECK_MSG(parse(text, &m), "%s", g_diag.last);
    CHECK_INT(m.nverts, LINES);
    int bad = 0;
    for (int i = 0; i < m.nverts && i < LINES; i++) {
        float got[3] = {m.verts[i].x, m.verts[i].y, m.verts[i].z};
        if (memcmp(got, want[i], sizeof got) != 0 && bad++ < 5)
            CHECK_MSG(false, "line %d: %.9g %.9g %.9g, strtof %.9g %.9g %.9g", i + 1,
                      (double)got[0], (double)got[1], (double)got[2], (double)want[i][0],
                      (double)want[i][1], (double)want[i][2]);
    }
    CHECK_INT(bad, 0);
    objfile_mesh_free(&m);
    free(text);
    free(want);
}

/* The course reader: one character at a time, 'v' -> %f %f %f,
 * 'f' -> %d %d %d. Right for the official files, which contain only v and f lines. */
static bool course_read(const char *path, ObjMesh *m)
{
    FILE *f = fopen(path, "r");
    if (!f)
        return false;
    int cv = 0, ct = 0;
    memset(m, 0, sizeof *m);
    int c;
    while ((c = fgetc(f)) != EOF) {
        if (c == 'v') {
            float x, y, z;
            if (fscanf(f, "%f %f %f", &x, &y, &z) != 3)
                break;
            if (m->nverts == cv) {
                cv = cv ? cv * 2 : 1024;
                m->verts = bigmem_resize(m->verts, (size_t)cv * sizeof *m->verts); /* ObjMesh memory */
            }
            m->verts[m->nverts++] = v3(x, y, z);
        } else if (c == 'f') {
            int a, b, d;
            if (fscanf(f, "%d %d %d", &a, &b, &d) != 3)
                break;
            if (m->ntris == ct) {
                ct = ct ? ct * 2 : 1024;
                m->tris = bigmem_resize(m->tris, (size_t)ct * sizeof *m->tris);
            }
            m->tris[m->ntris][0] = a - 1;
            m->tris[m->ntris][1] = b - 1;
            m->tris[m->ntris][2] = d - 1;
            m->ntris++;
        }
    }
    fclose(f);
    return true;
}

static void test_official_meshes(void)
{
    const char *dir = harness_course_dir();
    if (!dir)
        harness_skip("course data folder absent (set RT_COURSE)");
    static const struct { const char *name; int v, f; } k[] = {
        {"cube.obj", 8, 12},         {"diamond.obj", 57, 110},   {"bunny_200.obj", 102, 200},
        {"bunny_1k.obj", 502, 1000}, {"bunny_5k.obj", 2502, 5000},
        {"bunny_40k.obj", 20002, 40000}, {"vase.obj", 1922, 3840}, {"6.837.obj", 6930, 13852}};
    for (size_t i = 0; i < sizeof k / sizeof k[0]; i++) {
        char path[4096];
        snprintf(path, sizeof path, "%s/%s", dir, k[i].name);
        char *buf;
        size_t len;
        CHECK_MSG(file_read_all(path, &buf, &len), "%s: cannot read", k[i].name);
        ObjMesh m, ref;
        diag_init(&g_diag, NULL);
        bool ok = objfile_parse(buf, len, path, &m, &g_diag);
        free(buf);
        CHECK_MSG(ok, "%s: %s", k[i].name, g_diag.last);
        if (!ok)
            continue;
        CHECK_MSG(m.nverts == k[i].v && m.ntris == k[i].f, "%s: %d v / %d f", k[i].name,
                  m.nverts, m.ntris);
        CHECK(course_read(path, &ref));
        CHECK_INT(ref.nverts, m.nverts);
        CHECK_INT(ref.ntris, m.ntris);
        if (ref.nverts == m.nverts)
            CHECK_MSG(memcmp(ref.verts, m.verts, (size_t)m.nverts * sizeof(Vec3)) == 0,
                      "%s: vertices differ from the course reader's", k[i].name);
        if (ref.ntris == m.ntris)
            CHECK_MSG(memcmp(ref.tris, m.tris, (size_t)m.ntris * sizeof(int[3])) == 0,
                      "%s: faces differ from the course reader's", k[i].name);
        objfile_mesh_free(&m);
        objfile_mesh_free(&ref);
    }
}

static const TestCase tests[] = {
    {"basic", test_basic},
    {"slash_forms", test_slash_forms},
    {"polygon_fan", test_polygon_fan},
    {"negative_indices", test_negative_indices},
    {"crlf_comments_ignored_records", test_crlf_comments_ignored_records},
    {"errors", test_errors},
    {"float_matches_strtof", test_float_matches_strtof},
    {"vertex_lines_match_strtof", test_vertex_lines_match_strtof},
    {"quick_readers_take_common_endings", test_quick_readers_take_common_endings},
    {"official_meshes", test_official_meshes},
};

RT_TEST_MAIN(tests)
